//! What a plan's outputs take on disk and what `run` and `merge` hold in memory besides the
//! jobs, estimated before it runs: `validate` prints it, so that a user of a big sweep knows
//! the disk and memory it needs (and that `npy_maps: false` saves most of the files).
//!
//! The model counts, for every dataset job (the jobs whose number a sweep multiplies), the rows
//! it adds to each table and the files it writes: with `H x W` images and `L` levels, the maps
//! of `maps/<job>/` (the mean, complex128, and the variance, `H W`; six maps a level and,
//! for simulated data, three expected maps, `(H / 2^l) (W / 2^l)` float64 cells each; every
//! `.npy` a 128-byte header, every file at least one 4 KiB block), the generated samples a
//! synthesis job saves (complex64), `analysis_maps` (three rows a cell of every level),
//! `pixel_stats` (`H W`) and the small tables (about 100 rows). A table row takes about 20
//! bytes in the Snappy-compressed tables and 40 in the job store's uncompressed packs (measured
//! on a sweep of 4,800 tiny jobs: 195 MB of tables and 394 MB of store for 9.6 million rows). The jobs of the run as a whole (hypotheses, CNN
//! trainings, summaries) write a few rows each and are counted at 64 KiB. The memory is the plan
//! (about 3 KB a job; 2.7 KB measured), what the merge holds at most (a Parquet row group of
//! each table, 65,536 rows, and the jobs being read: counted as 160 MB, see BENCHMARKS.md) and
//! the largest job on each thread.

use crate::run::plan::Plan;
use std::fmt;

/// Bytes a table row takes in the run's tables (Snappy Parquet).
const TABLE_ROW: f64 = 20.0;
/// Bytes a table row takes in the job store's packs (uncompressed Parquet).
const PACK_ROW: f64 = 40.0;
/// Rows of the small tables (summary, filter lags, similarity, model order, jobs) a job adds.
const SMALL_ROWS: f64 = 100.0;
/// Bytes of the plan a job takes (with what else grows with the jobs: their store keys, the
/// allocator's share, each table's footer entries). Measured: peak RSS of `run` of the tiny
/// sweep of BENCHMARKS.md ("Scale: the tables' footers without polars' page records"), 112 MB
/// at 10,000 jobs and 250 MB at 100,000: 1.5 KB a job.
const PLAN_JOB: f64 = 1.5e3;
/// What the merge holds at most besides the plan (a row group of every table being written,
/// the jobs being read, the binary): the same two runs' intercept, about 100 MB.
const MERGE_HELD: f64 = 100e6;
/// The disk a job of the run as a whole takes.
const RUN_WIDE_JOB: f64 = 65536.0;
/// The smallest disk a file takes (one block).
const BLOCK: f64 = 4096.0;

/// A plan's outputs and the memory of its run besides the jobs.
#[derive(Debug, Clone, PartialEq)]
pub struct Footprint {
    /// Jobs of the plan.
    pub jobs: usize,
    /// Files in the output folder besides the tables and the manifest: maps and samples,
    /// counted twice (the store's copy is a hard link, one inode but two names), the store's
    /// packs and its memo of input hashes.
    pub files: f64,
    /// Bytes of the tables.
    pub tables: f64,
    /// Bytes of the maps and samples (once: the store and the folder share them).
    pub maps: f64,
    /// Bytes of the job store's packs.
    pub store: f64,
    /// Bytes `run` and `merge` hold besides the jobs (the plan and the merge's row groups).
    pub memory: f64,
}

/// Bytes of an `.npy` file of `values` values of `size` bytes on disk.
fn npy(values: f64, size: f64) -> f64 {
    (values * size + 128.0).max(BLOCK)
}

/// The footprint of `plan`, which has `jobs` jobs in all.
pub fn footprint(plan: &Plan, jobs: usize) -> Footprint {
    let mut f = Footprint {
        jobs,
        files: 0.0,
        tables: 0.0,
        maps: 0.0,
        store: 0.0,
        memory: PLAN_JOB * jobs as f64 + MERGE_HELD,
    };
    for job in &plan.jobs {
        let (_, h, w) = job.dataset.shape();
        let (h, w) = (h as f64, w as f64);
        let levels = job.analysis.levels as i32;
        let mut rows = h * w + SMALL_ROWS;
        let mut maps = [npy(h * w, 16.0), npy(h * w, 8.0)].to_vec();
        // The maps' values' bytes, without the files' headers and blocks.
        let mut raw = 24.0 * h * w;
        for l in 1..=levels {
            let cells = (h / 2f64.powi(l)).floor() * (w / 2f64.powi(l)).floor();
            rows += 3.0 * cells;
            maps.extend(std::iter::repeat_n(npy(cells, 8.0), 9));
            raw += 72.0 * cells;
        }
        if plan.spec.outputs.npy_maps {
            f.files += 2.0 * maps.len() as f64;
            f.maps += maps.iter().sum::<f64>();
        }
        if plan.spec.outputs.zarr_maps {
            // The staged chunks (one file in the store) and their copy in maps.zarr, at most
            // their raw size (gzip seldom shrinks estimated statistics much); the store's
            // few files are counted once below.
            f.files += 1.0;
            f.store += raw;
            f.maps += raw;
        }
        // The mean k-space image of an analysis job on k-space data (complex128 `[n_f, n_phi]`).
        let kspace = job.dataset.kspace_grid();
        if let (Some((nf, nphi)), true, None) = (kspace, plan.spec.outputs.npy_maps, job.method) {
            f.files += 2.0;
            f.maps += npy((nf * nphi) as f64, 16.0);
        }
        if let Some(s) = job.synthesis.as_ref().filter(|s| s.save_samples) {
            f.files += 2.0;
            f.maps += npy(s.samples as f64 * h * w, 8.0);
        }
        f.files += 1.0;
        f.tables += rows * TABLE_ROW;
        f.store += rows * PACK_ROW;
    }
    if plan.spec.outputs.zarr_maps {
        // maps.zarr: a shard and its metadata per map name (of the largest level count), and
        // the group.
        let levels = plan
            .jobs
            .iter()
            .map(|j| j.analysis.levels)
            .max()
            .unwrap_or(0);
        f.files += 2.0 * (2 + 9 * levels) as f64 + 1.0;
    }
    let run_wide = jobs.saturating_sub(plan.jobs.len()) as f64;
    // And the store's memo of input hashes.
    f.files += run_wide + 1.0;
    f.store += run_wide * RUN_WIDE_JOB;
    f
}

impl Footprint {
    /// Bytes of the outputs on disk: tables, maps and samples, job store.
    pub fn disk(&self) -> f64 {
        self.tables + self.maps + self.store
    }

    /// The outputs against the free space of the file system of `out`
    /// ([`crate::resources::free_disk`]): `Err` (refused) when even half the estimate would not
    /// fit (the model is an estimate, not a bound: the margin keeps a plausible run from
    /// being refused), `Ok(Some(warning))` when the whole estimate would not, `Ok(None)` when it
    /// fits or the free space is unknown.
    ///
    /// # Errors
    /// The refusal, naming the estimate, the free space and the folder.
    pub fn check_disk(&self, out: &std::path::Path) -> Result<Option<String>, String> {
        let Some(free) = crate::resources::free_disk(out) else {
            return Ok(None);
        };
        let need = self.disk();
        let words = format!(
            "the outputs need about {} on disk, more than the {} free on the file system of {}",
            size(need),
            size(free as f64),
            out.display()
        );
        if need / 2.0 > free as f64 {
            Err(format!(
                "{words}: make the sweep smaller, set `outputs: {{npy_maps: false}}`, or \
                 choose another --out (nothing was written)"
            ))
        } else if need > free as f64 {
            Ok(Some(format!(
                "{words} (an estimate: the run may still fit)"
            )))
        } else {
            Ok(None)
        }
    }
}

/// Bytes with a unit (kB, MB, GB, TB).
fn size(b: f64) -> String {
    match b {
        b if b >= 1e12 => format!("{:.1} TB", b / 1e12),
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.0} MB", b / 1e6),
        b => format!("{:.0} kB", b / 1e3),
    }
}

impl fmt::Display for Footprint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "outputs: about {} on disk (tables {}, maps and samples {}, job store {}), {:.0} \
             files; memory of run and merge besides the jobs: about {} (the plan and the \
             merge's row groups)",
            size(self.tables + self.maps + self.store),
            size(self.tables),
            size(self.maps),
            size(self.store),
            self.files,
            size(self.memory)
        )
    }
}
