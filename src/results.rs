//! Result tables and files: builds the long-format Parquet tables of a run from the jobs'
//! results, and writes every output atomically (a temporary name in the same folder, then a
//! rename), so a reader never sees a half-written file.
//!
//! Table layout is a public contract (see `docs/spec.md`): `analysis_maps`,
//! `analysis_summary`, `pixel_stats`, `filter_correlation`, `jobs`.

use crate::analysis::{Analysis, Direction};
use crate::plan::{Job, Plan};
use anyhow::{Context, Result};
use ndarray::Array2;
use polars::prelude::*;
use serde_json::Value as Json;
use std::borrow::Cow;
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// What one successful job computed.
pub struct JobResult {
    /// Whose statistics `analysis` holds: `original` for an analysis job, the method's name
    /// for the generated samples of a synthesis job.
    pub source: &'static str,
    /// The analysis (`None` for a synthesis job with `analyse_generated: false`).
    pub analysis: Option<Analysis>,
    /// A synthesis job's fit and generation.
    pub synthesis: Option<SynthesisOutcome>,
    /// Exact expected correlation maps per level (`[H, V, D]`) for synthetic data.
    pub expected: Option<Vec<[Array2<f64>; 3]>>,
    /// Filter lag correlations for synthetic data with spatially uniform filters.
    pub filter_rows: Vec<FilterRow>,
    /// Stack shape `(N, H, W)`.
    pub shape: (usize, usize, usize),
    /// Seconds spent loading or generating the data.
    pub data_s: f64,
    /// Seconds spent in the analysis kernel.
    pub analysis_s: f64,
    /// Bytes of stack data analysed.
    pub bytes: usize,
    /// The metrics: generated vs original (synthesis jobs) or the noise floor (analysis jobs).
    pub similarity: Option<SimilarityOutcome>,
    /// With `hypotheses`: the mean 2-D correlating function of the original and its pair counts.
    pub correlating: Option<(Array2<f64>, Array2<usize>)>,
}

/// The metrics one job computed.
pub struct SimilarityOutcome {
    /// What was compared with the original: a method's name, or `noise_floor`.
    pub compared: &'static str,
    /// For the noise floor: `draws` or `halves`.
    pub noise_floor: Option<&'static str>,
    /// Rows and KL maps.
    pub comparison: crate::similarity::Comparison,
    /// Seconds spent on the metrics (and, for the noise floor, on its data).
    pub seconds: f64,
}

/// What a synthesis job fitted and generated.
pub struct SynthesisOutcome {
    /// Per-cell parameters of Methods 1 and 2.
    pub filter: Option<crate::synthesis::FilterModel>,
    /// Samples generated.
    pub samples: usize,
    /// Seconds spent fitting.
    pub fit_s: f64,
    /// Seconds spent generating.
    pub generate_s: f64,
}

/// One row of `filter_correlation.parquet` (Table 3).
#[derive(Debug, Clone, PartialEq)]
pub struct FilterRow {
    /// `H` or `V`.
    pub direction: Direction,
    /// Lag `d >= 0`.
    pub lag: usize,
    /// Tap `f(d)`.
    pub coefficient: f64,
    /// `rho(d)` (eq. 66).
    pub correlation: f64,
}

/// Outcome of one job.
pub struct JobOutcome {
    /// Index into the plan's jobs.
    pub index: usize,
    /// The result, or the error's message (with its cause chain).
    pub result: Result<JobResult, String>,
    /// Wall time of the job in seconds.
    pub elapsed_s: f64,
}

/// Writes `path` atomically: `write` fills a temporary file in the same folder, which is then
/// renamed over `path`.
///
/// # Errors
/// If the temporary file cannot be written or renamed; the temporary file is removed.
pub fn atomic_write(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    let tmp: PathBuf = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        // The folder is made only when it is missing (one failed open, not a mkdir per file).
        let file = match File::create(&tmp) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                fs::create_dir_all(dir)
                    .with_context(|| format!("cannot create {}", dir.display()))?;
                File::create(&tmp)
            }
            other => other,
        }
        .with_context(|| format!("cannot create {}", tmp.display()))?;
        // One write call for most outputs: each costs about 20 us on the development VM.
        let mut w = BufWriter::with_capacity(1 << 20, file);
        write(&mut w)?;
        w.flush()?;
        drop(w);
        replace(&tmp, path)
            .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.with_context(|| format!("writing {}", path.display()))
}

/// Removes the sub-folders of `parent` whose names are not in `keep` (outputs of jobs an
/// earlier run had and this one has not); nothing if `parent` does not exist.
///
/// # Errors
/// If a folder cannot be removed; the message names it.
pub fn remove_folders_except(parent: &Path, keep: &[&str]) -> Result<()> {
    let Ok(entries) = fs::read_dir(parent) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let kept = entry
            .file_name()
            .to_str()
            .is_some_and(|n| keep.contains(&n));
        if !kept && entry.path().is_dir() {
            fs::remove_dir_all(entry.path())
                .with_context(|| format!("removing stale {}", entry.path().display()))?;
        }
    }
    Ok(())
}

/// Moves the finished file `tmp` to `path`. Where `path` exists (a re-run into the same
/// folder), Linux (glibc) swaps the two names atomically (`renameat2` with
/// `RENAME_EXCHANGE`) and the old file is then removed: a plain rename over an existing file makes ext4 start writing the
/// new file's data back at once (its `auto_da_alloc` safeguard), about 0.2 ms per file on the
/// development VM, which was a fifth of a short run's time. Readers see the old or the new
/// file, never a partial one, either way.
fn replace(tmp: &Path, path: &Path) -> std::io::Result<()> {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        use std::ffi::CString;
        use std::os::unix::ffi::OsStrExt;
        let (a, b) = (
            CString::new(tmp.as_os_str().as_bytes())?,
            CString::new(path.as_os_str().as_bytes())?,
        );
        // SAFETY: both are valid NUL-terminated paths, relative to the working directory.
        let swapped = unsafe {
            libc::renameat2(
                libc::AT_FDCWD,
                a.as_ptr(),
                libc::AT_FDCWD,
                b.as_ptr(),
                libc::RENAME_EXCHANGE,
            )
        } == 0;
        if swapped {
            // `tmp` now names the old file; a failure to remove it loses no result.
            let _ = fs::remove_file(tmp);
            return Ok(());
        }
        // No file at `path` yet (or a file system without RENAME_EXCHANGE): a plain rename.
    }
    fs::rename(tmp, path)
}

/// Reads a Parquet table of a results folder; `Ok(None)` if the file does not exist.
///
/// # Errors
/// If the file exists but cannot be opened or read; the message names it.
pub fn read_parquet(path: &Path) -> Result<Option<DataFrame>> {
    if !path.exists() {
        return Ok(None);
    }
    let file = File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let df = anyhow::Context::with_context(ParquetReader::new(file).finish(), || {
        format!("reading {}", path.display())
    })?;
    Ok(Some(df))
}

/// Writes a DataFrame as Parquet (Snappy-compressed), atomically.
///
/// # Errors
/// If writing fails.
pub fn write_parquet(path: &Path, df: &mut DataFrame) -> Result<()> {
    atomic_write(path, |w| {
        ParquetWriter::new(w)
            .with_compression(ParquetCompression::Snappy)
            .set_parallel(false)
            .finish(df)?;
        Ok(())
    })
}

/// Writes an array as `.npy`, atomically.
///
/// # Errors
/// If writing fails.
pub fn write_npy<A: ndarray_npy::WritableElement, D: ndarray::Dimension>(
    path: &Path,
    a: &ndarray::Array<A, D>,
) -> Result<()> {
    use ndarray_npy::WriteNpyExt;
    atomic_write(path, |w| {
        a.write_npy(w)?;
        Ok(())
    })
}

/// Writes a job's maps under `dir` (`mean.npy`, `variance.npy`,
/// `level{L}_{correlation,covariance}_{H,V,D}.npy`, `expected_level{L}_correlation_{H,V,D}.npy`).
///
/// # Errors
/// If a file cannot be written.
pub fn write_job_maps(dir: &Path, r: &JobResult) -> Result<()> {
    use rayon::prelude::*;
    let mut maps: Vec<(String, &Array2<f64>)> = vec![];
    if let Some(sim) = &r.similarity {
        let prefix = if sim.noise_floor.is_some() {
            "noise_floor_"
        } else {
            ""
        };
        for (stem, map) in &sim.comparison.maps {
            maps.push((format!("{prefix}{stem}"), map));
        }
    }
    if let Some(analysis) = &r.analysis {
        write_npy(&dir.join("mean.npy"), &analysis.mean)?;
        maps.push(("variance".into(), &analysis.variance));
    }
    for lm in r.analysis.iter().flat_map(|a| &a.levels) {
        for d in Direction::ALL {
            maps.push((
                format!("level{}_correlation_{d}", lm.level),
                lm.correlation(d),
            ));
            maps.push((
                format!("level{}_covariance_{d}", lm.level),
                lm.covariance(d),
            ));
        }
    }
    for (l, expected) in r.expected.iter().flatten().enumerate() {
        for d in Direction::ALL {
            maps.push((
                format!("expected_level{}_correlation_{d}", l + 1),
                &expected[d as usize],
            ));
        }
    }
    maps.par_iter()
        .try_for_each(|(name, map)| write_npy(&dir.join(format!("{name}.npy")), *map))
}

/// Column builder for one table: rows are appended job by job, and the swept parameters are
/// added as columns at the end.
struct Table<'a> {
    plan: &'a Plan,
    jobs: Vec<&'a Job>,
    cols: Vec<(String, Values<'a>)>,
    /// Index of the column after the last one written: rows fill columns in declaration
    /// order, so the name lookup usually succeeds at once.
    next: usize,
}

/// Column types: nullable string, i64, u64, f64 and bool.
#[derive(Clone, Copy)]
enum Kind {
    S,
    I,
    U,
    F,
    B,
}

/// Column data.
enum Values<'a> {
    Str(Vec<Option<Cow<'a, str>>>),
    Int(Vec<Option<i64>>),
    UInt(Vec<u64>),
    Float(Vec<Option<f64>>),
    Bool(Vec<Option<bool>>),
}

impl<'a> Table<'a> {
    fn new<S: AsRef<str>>(plan: &'a Plan, names: &[(S, Kind)]) -> Self {
        let cols = names
            .iter()
            .map(|(n, k)| {
                let empty = match k {
                    Kind::S => Values::Str(vec![]),
                    Kind::I => Values::Int(vec![]),
                    Kind::U => Values::UInt(vec![]),
                    Kind::F => Values::Float(vec![]),
                    Kind::B => Values::Bool(vec![]),
                };
                (n.as_ref().to_string(), empty)
            })
            .collect();
        Table {
            plan,
            jobs: vec![],
            cols,
            next: 0,
        }
    }

    fn col(&mut self, name: &str) -> &mut Values<'a> {
        let at = match self.cols.get(self.next) {
            Some((n, _)) if n == name => self.next,
            _ => self
                .cols
                .iter()
                .position(|(n, _)| n == name)
                .expect("declared column"),
        };
        self.next = (at + 1) % self.cols.len();
        &mut self.cols[at].1
    }

    fn s(&mut self, name: &str, v: impl Into<Cow<'a, str>>) {
        self.s_opt(name, Some(v.into()))
    }
    fn s_opt(&mut self, name: &str, v: Option<Cow<'a, str>>) {
        if let Values::Str(c) = self.col(name) {
            c.push(v)
        }
    }
    fn i(&mut self, name: &str, v: i64) {
        self.i_opt(name, Some(v))
    }
    fn i_opt(&mut self, name: &str, v: Option<i64>) {
        if let Values::Int(c) = self.col(name) {
            c.push(v)
        }
    }
    fn b(&mut self, name: &str, v: Option<bool>) {
        if let Values::Bool(c) = self.col(name) {
            c.push(v)
        }
    }
    fn u(&mut self, name: &str, v: u64) {
        if let Values::UInt(c) = self.col(name) {
            c.push(v)
        }
    }
    fn f(&mut self, name: &str, v: Option<f64>) {
        if let Values::Float(c) = self.col(name) {
            c.push(v)
        }
    }

    /// Marks the end of one row of `job`.
    fn row(&mut self, job: &'a Job) {
        self.jobs.push(job);
    }

    fn finish(self) -> Result<DataFrame> {
        let mut columns: Vec<Column> = self
            .cols
            .into_iter()
            .map(|(n, v)| match v {
                Values::Str(v) => Column::new(
                    n.as_str().into(),
                    v.iter().map(|s| s.as_deref()).collect::<Vec<_>>(),
                ),
                Values::Int(v) => Column::new(n.as_str().into(), v),
                Values::UInt(v) => Column::new(n.as_str().into(), v),
                Values::Float(v) => Column::new(n.as_str().into(), v),
                Values::Bool(v) => Column::new(n.as_str().into(), v),
            })
            .collect();
        for key in &self.plan.param_keys {
            let values: Vec<Option<&Json>> = self.jobs.iter().map(|j| j.params.get(key)).collect();
            // The column type follows every job's value, so it is the same in every table.
            let numeric = self
                .plan
                .jobs
                .iter()
                .filter_map(|j| j.params.get(key))
                .all(Json::is_number);
            let name: PlSmallStr = param_column(key, &columns).into();
            columns.push(if numeric {
                Column::new(
                    name,
                    values
                        .iter()
                        .map(|v| v.and_then(Json::as_f64))
                        .collect::<Vec<_>>(),
                )
            } else {
                let text = |v: &Json| match v {
                    Json::String(s) => s.clone(),
                    other => other.to_string(),
                };
                Column::new(name, values.iter().map(|v| v.map(text)).collect::<Vec<_>>())
            });
        }
        Ok(DataFrame::new_infer_height(columns)?)
    }
}

/// Column name of a swept parameter: its short key, or `swept_<key>` where a table already has
/// a column of that name (`levels` and `samples` in `jobs.parquet`, `mean_im` in
/// `pixel_stats.parquet`).
fn param_column(key: &str, columns: &[Column]) -> String {
    if columns.iter().any(|c| c.name().as_str() == key) {
        format!("swept_{key}")
    } else {
        key.to_string()
    }
}

fn opt(v: f64) -> Option<f64> {
    Some(v)
}

/// `analysis_maps`: one row per job, level, direction and cell.
pub fn analysis_maps(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("source", Kind::S),
            ("level", Kind::I),
            ("direction", Kind::S),
            ("row", Kind::I),
            ("col", Kind::I),
            ("correlation", Kind::F),
            ("covariance", Kind::F),
            ("expected_correlation", Kind::F),
        ],
    );
    for (job, r) in ok(plan, outcomes) {
        let Some(analysis) = &r.analysis else {
            continue;
        };
        for lm in &analysis.levels {
            for d in Direction::ALL {
                let expected = r.expected.as_ref().map(|e| &e[lm.level - 1][d as usize]);
                for ((rc, &corr), &cov) in lm
                    .correlation(d)
                    .indexed_iter()
                    .zip(lm.covariance(d).iter())
                {
                    t.s("job", &job.id);
                    t.s("dataset", &job.dataset_id);
                    t.s("source", r.source);
                    t.i("level", lm.level as i64);
                    t.s("direction", d.as_str());
                    t.i("row", rc.0 as i64);
                    t.i("col", rc.1 as i64);
                    t.f("correlation", opt(corr));
                    t.f("covariance", opt(cov));
                    t.f("expected_correlation", expected.map(|e| e[rc]));
                    t.row(job);
                }
            }
        }
    }
    t.finish()
}

/// `analysis_summary`: NaN-aware means per job, level and direction.
pub fn analysis_summary(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("source", Kind::S),
            ("level", Kind::I),
            ("direction", Kind::S),
            ("mean_correlation", Kind::F),
            ("mean_covariance", Kind::F),
            ("nan_cells", Kind::I),
            ("cells", Kind::I),
            ("rows", Kind::I),
            ("cols", Kind::I),
            ("expected_mean_correlation", Kind::F),
        ],
    );
    for (job, r) in ok(plan, outcomes) {
        let Some(analysis) = &r.analysis else {
            continue;
        };
        for lm in &analysis.levels {
            for d in Direction::ALL {
                let s = lm.summary(d);
                let (rows, cols) = lm.shape();
                let expected = r
                    .expected
                    .as_ref()
                    .map(|e| crate::analysis::nan_mean(&e[lm.level - 1][d as usize]).0);
                t.s("job", &job.id);
                t.s("dataset", &job.dataset_id);
                t.s("source", r.source);
                t.i("level", lm.level as i64);
                t.s("direction", d.as_str());
                t.f("mean_correlation", opt(s.mean_correlation));
                t.f("mean_covariance", opt(s.mean_covariance));
                t.i("nan_cells", s.nan_cells as i64);
                t.i("cells", (rows * cols) as i64);
                t.i("rows", rows as i64);
                t.i("cols", cols as i64);
                t.f("expected_mean_correlation", expected);
                t.row(job);
            }
        }
    }
    t.finish()
}

/// `pixel_stats`: per-pixel mean (real, imaginary) and variance.
pub fn pixel_stats(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("source", Kind::S),
            ("row", Kind::I),
            ("col", Kind::I),
            ("mean_re", Kind::F),
            ("mean_im", Kind::F),
            ("variance", Kind::F),
        ],
    );
    for (job, r) in ok(plan, outcomes) {
        let Some(analysis) = &r.analysis else {
            continue;
        };
        for ((rc, m), &v) in analysis.mean.indexed_iter().zip(analysis.variance.iter()) {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("source", r.source);
            t.i("row", rc.0 as i64);
            t.i("col", rc.1 as i64);
            t.f("mean_re", opt(m.re));
            t.f("mean_im", opt(m.im));
            t.f("variance", opt(v));
            t.row(job);
        }
    }
    t.finish()
}

/// `filter_correlation`: lag correlations of uniform synthetic filters (Table 3).
pub fn filter_correlation(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("direction", Kind::S),
            ("lag", Kind::I),
            ("filter_coefficient", Kind::F),
            ("correlation", Kind::F),
        ],
    );
    for (job, r) in ok(plan, outcomes) {
        for row in &r.filter_rows {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("direction", row.direction.as_str());
            t.i("lag", row.lag as i64);
            t.f("filter_coefficient", opt(row.coefficient));
            t.f("correlation", opt(row.correlation));
            t.row(job);
        }
    }
    t.finish()
}

/// `jobs`: one row per job with status, error, seeds, timing and parameters.
pub fn jobs_table(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("kind", Kind::S),
            ("method", Kind::S),
            ("status", Kind::S),
            ("error", Kind::S),
            ("seed", Kind::U),
            ("data_seed", Kind::U),
            ("generation_seed", Kind::U),
            ("samples", Kind::I),
            ("height", Kind::I),
            ("width", Kind::I),
            ("levels", Kind::I),
            ("elapsed_s", Kind::F),
        ],
    );
    for o in outcomes {
        let job = &plan.jobs[o.index];
        let (n, h, w) = job.dataset.shape();
        t.s("job", &job.id);
        t.s("dataset", &job.dataset_id);
        t.s("kind", job.dataset.kind());
        t.s_opt("method", job.method.map(|m| m.as_str().into()));
        t.s("status", if o.result.is_ok() { "ok" } else { "failed" });
        t.s_opt("error", o.result.as_ref().err().map(|e| e.as_str().into()));
        t.u("seed", job.seed);
        t.u("data_seed", job.data_seed);
        t.u("generation_seed", job.generation_seed);
        t.i("samples", n as i64);
        t.i("height", h as i64);
        t.i("width", w as i64);
        t.i("levels", job.analysis.levels as i64);
        t.f("elapsed_s", opt(o.elapsed_s));
        t.row(job);
    }
    t.finish()
}

/// Successful outcomes with their jobs, in plan order.
fn ok<'a>(
    plan: &'a Plan,
    outcomes: &'a [JobOutcome],
) -> impl Iterator<Item = (&'a Job, &'a JobResult)> {
    outcomes
        .iter()
        .filter_map(move |o| o.result.as_ref().ok().map(|r| (&plan.jobs[o.index], r)))
}

/// `synthesis_params`: one row per synthesis job of Methods 1 and 2 and level-1 cell, with the
/// fitted filter parameters (`alpha_h`, `alpha_v` for Method 1; `r_h1..r_hL`, `r_v1..r_vL` for
/// Method 2, `L` the largest of the run; null where a method has none), the RMS misfit of the
/// reached correlations and the number of directions whose target was unreachable (0-2).
pub fn synthesis_params(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    use crate::synthesis::CellParams;
    let fits: Vec<(&Job, &crate::synthesis::FilterModel)> = ok(plan, outcomes)
        .filter_map(|(j, r)| {
            r.synthesis
                .as_ref()
                .and_then(|s| s.filter.as_ref())
                .map(|f| (j, f))
        })
        .collect();
    let l_max = fits
        .iter()
        .map(|(_, f)| match &f.params {
            CellParams::Dyadic { r_h, .. } => r_h.len(),
            CellParams::Exponential { .. } => 0,
        })
        .max()
        .unwrap_or(0);
    let mut names: Vec<(String, Kind)> = [
        ("job", Kind::S),
        ("dataset", Kind::S),
        ("method", Kind::S),
        ("row", Kind::I),
        ("col", Kind::I),
        ("alpha_h", Kind::F),
        ("alpha_v", Kind::F),
    ]
    .iter()
    .map(|(n, k)| (n.to_string(), *k))
    .collect();
    for dir in ["h", "v"] {
        names.extend((1..=l_max).map(|l| (format!("r_{dir}{l}"), Kind::F)));
    }
    names.extend([
        ("residual_h".to_string(), Kind::F),
        ("residual_v".to_string(), Kind::F),
        ("clamped".to_string(), Kind::I),
    ]);
    let mut t = Table::new(plan, &names);
    for (job, f) in fits {
        for ((r, c), &clamped) in f.clamped.indexed_iter() {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("method", job.method.map_or("", |m| m.as_str()));
            t.i("row", r as i64);
            t.i("col", c as i64);
            let (alpha, rs) = match &f.params {
                CellParams::Exponential { alpha_h, alpha_v } => {
                    (Some((alpha_h[[r, c]], alpha_v[[r, c]])), None)
                }
                CellParams::Dyadic { r_h, r_v } => (None, Some((r_h, r_v))),
            };
            t.f("alpha_h", alpha.map(|a| a.0));
            t.f("alpha_v", alpha.map(|a| a.1));
            for (dir, idx) in [("h", 0), ("v", 1)] {
                for l in 0..l_max {
                    let v = rs.and_then(|(h, v)| [h, v][idx].get(l)).map(|m| m[[r, c]]);
                    t.f(&format!("r_{dir}{}", l + 1), v);
                }
            }
            t.f("residual_h", opt(f.residual_h[[r, c]]));
            t.f("residual_v", opt(f.residual_v[[r, c]]));
            t.i("clamped", clamped as i64);
            t.row(job);
        }
    }
    t.finish()
}

/// `similarity`: one row per job, metric and statistic: each synthesis job's generated samples
/// against the original (`method` = the method), and each analysis job's noise floor (`method`
/// = `noise_floor`, `noise_floor` = `draws` or `halves`), with the metric's parameters (null
/// where a metric has none).
pub fn similarity(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("method", Kind::S),
            ("metric", Kind::S),
            ("level", Kind::I),
            ("direction", Kind::S),
            ("component", Kind::S),
            ("statistic", Kind::S),
            ("value", Kind::F),
            ("units", Kind::I),
            ("samples_original", Kind::I),
            ("samples_compared", Kind::I),
            ("noise_floor", Kind::S),
            ("bins", Kind::I),
            ("smoothing", Kind::F),
            ("symmetric", Kind::B),
            ("db", Kind::B),
            ("block", Kind::I),
            ("cmd_form", Kind::S),
        ],
    );
    for (job, r) in ok(plan, outcomes) {
        let Some(sim) = &r.similarity else { continue };
        for row in &sim.comparison.rows {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("method", sim.compared);
            t.s("metric", row.metric);
            t.i_opt("level", row.level.map(|l| l as i64));
            t.s_opt("direction", row.direction.map(|d| d.as_str().into()));
            t.s_opt("component", row.component.map(Into::into));
            t.s("statistic", row.statistic);
            t.f("value", Some(row.value).filter(|v| !v.is_nan()));
            t.i("units", row.units as i64);
            t.i("samples_original", sim.comparison.samples.0 as i64);
            t.i("samples_compared", sim.comparison.samples.1 as i64);
            t.s_opt("noise_floor", sim.noise_floor.map(Into::into));
            t.i_opt("bins", row.kl.map(|k| k.bins as i64));
            t.f("smoothing", row.kl.map(|k| k.smoothing));
            t.b("symmetric", row.kl.map(|k| k.symmetric));
            t.b("db", row.kl.map(|k| k.db));
            t.i_opt("block", row.block.map(|b| b as i64));
            t.s_opt("cmd_form", row.form.as_deref().map(Into::into));
            t.row(job);
        }
    }
    t.finish()
}

/// `model_order` (ch. 3.2, Tables 1-2): from the per-pixel KL (`kl_pixel`) of the
/// second-order model (the `uncorrelated` method: a Gaussian with the pixel's mean and
/// variance, `model_order` 2) and the fourth-order model (`fourth_order`, 4), the mean and the
/// worst pixel's KL in dB per component; the noise floor's rows have a null `model_order`.
pub fn model_order(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    use crate::synthesis::Method;
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("model_order", Kind::I),
            ("component", Kind::S),
            ("kl_mean_db", Kind::F),
            ("kl_worst_db", Kind::F),
            ("pixels", Kind::I),
            ("samples_original", Kind::I),
            ("samples_compared", Kind::I),
            ("bins", Kind::I),
            ("smoothing", Kind::F),
            ("symmetric", Kind::B),
        ],
    );
    let models = plan
        .jobs
        .iter()
        .any(|j| matches!(j.method, Some(Method::Uncorrelated | Method::FourthOrder)));
    for (job, r) in ok(plan, outcomes).filter(|_| models) {
        let Some(sim) = &r.similarity else { continue };
        let order = match job.method {
            Some(Method::Uncorrelated) => Some(2),
            Some(Method::FourthOrder) => Some(4),
            None => None,
            Some(_) => continue,
        };
        for component in ["re", "im"] {
            let stat = |name: &str| {
                sim.comparison.rows.iter().find(|w| {
                    w.metric == "kl_pixel" && w.component == Some(component) && w.statistic == name
                })
            };
            let (Some(mean), Some(max)) = (stat("mean"), stat("max")) else {
                continue;
            };
            let kl = mean.kl.expect("KL rows carry their options");
            let to_db = |v: f64| if kl.db { v } else { crate::metrics::db(v) };
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.i_opt("model_order", order);
            t.s("component", component);
            t.f(
                "kl_mean_db",
                Some(to_db(mean.value)).filter(|v| !v.is_nan()),
            );
            t.f(
                "kl_worst_db",
                Some(to_db(max.value)).filter(|v| !v.is_nan()),
            );
            t.i("pixels", mean.units as i64);
            t.i("samples_original", sim.comparison.samples.0 as i64);
            t.i("samples_compared", sim.comparison.samples.1 as i64);
            t.i("bins", kl.bins as i64);
            t.f("smoothing", Some(kl.smoothing));
            t.b("symmetric", Some(kl.symmetric));
            t.row(job);
        }
    }
    t.finish()
}

/// Runs the spec's simulated sphere calibration and writes `calibration.parquet` (one row per
/// frequency: `freq_ghz, mie_dbsm, raw_db, calibrated_dbsm, error_db, phase_error_deg`) and
/// `calibration_summary.parquet` (`band, statistic, value`), atomically.
///
/// # Errors
/// If a file cannot be written.
pub fn write_calibration(p: &crate::calibration::ChainParams, seed: u64, out: &Path) -> Result<()> {
    use crate::calibration::{calibrate, simulate, summary};
    let rows = calibrate(p, &simulate(p, seed));
    let col = |name: &str, f: &dyn Fn(&crate::calibration::CalibrationRow) -> f64| {
        Column::new(name.into(), rows.iter().map(f).collect::<Vec<f64>>())
    };
    let mut df = DataFrame::new_infer_height(vec![
        col("freq_ghz", &|r| r.freq / 1e9),
        col("mie_dbsm", &|r| r.mie_db),
        col("raw_db", &|r| r.raw_db),
        col("calibrated_dbsm", &|r| r.calibrated_db),
        col("error_db", &|r| r.error_db),
        col("phase_error_deg", &|r| r.phase_error_deg),
    ])?;
    write_parquet(&out.join("calibration.parquet"), &mut df)?;
    let s = summary(&rows);
    let mut df = DataFrame::new_infer_height(vec![
        Column::new("band".into(), s.iter().map(|x| x.0).collect::<Vec<_>>()),
        Column::new(
            "statistic".into(),
            s.iter().map(|x| x.1).collect::<Vec<_>>(),
        ),
        Column::new("value".into(), s.iter().map(|x| x.2).collect::<Vec<_>>()),
    ])?;
    write_parquet(&out.join("calibration_summary.parquet"), &mut df)
}

/// `correlating_function`: one row per analysis job and offset `(dy, dx)`: the mean over pixel
/// pairs of the correlation at that offset (5.1.3), the offset's length and the pairs used.
pub fn correlating_function(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("dy", Kind::I),
            ("dx", Kind::I),
            ("distance", Kind::F),
            ("mean_correlation", Kind::F),
            ("pairs", Kind::I),
        ],
    );
    for (job, r) in ok(plan, outcomes) {
        let Some((c, pairs)) = &r.correlating else {
            continue;
        };
        let half = (c.nrows() / 2) as i64;
        for ((a, b), &v) in c.indexed_iter() {
            let (dy, dx) = (a as i64 - half, b as i64 - half);
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.i("dy", dy);
            t.i("dx", dx);
            t.f("distance", Some(((dy * dy + dx * dx) as f64).sqrt()));
            t.f("mean_correlation", Some(v).filter(|v| !v.is_nan()));
            t.i("pairs", pairs[[a, b]] as i64);
            t.row(job);
        }
    }
    t.finish()
}

/// `hypotheses` (Table 24): the tests of `crate::hypotheses` over the analysis jobs whose
/// dataset is named `plant_<letter>_<wind>` (first sweep point of each).
pub fn hypotheses(plan: &Plan, outcomes: &[JobOutcome]) -> Result<DataFrame> {
    let mut stats = vec![];
    for (job, r) in ok(plan, outcomes) {
        let (Some(a), Some((c, _)), None) = (&r.analysis, &r.correlating, job.method) else {
            continue;
        };
        let Some((plant, wind)) = crate::hypotheses::parse_id(&job.dataset_id) else {
            continue;
        };
        if stats
            .iter()
            .any(|s: &crate::hypotheses::PlantStats| s.dataset == job.dataset_id)
        {
            continue;
        }
        stats.push(crate::hypotheses::PlantStats {
            dataset: &job.dataset_id,
            plant,
            wind,
            analysis: a,
            correlating: c,
        });
    }
    let rows = crate::hypotheses::test(&stats);
    Ok(DataFrame::new_infer_height(vec![
        Column::new(
            "hypothesis".into(),
            rows.iter().map(|r| r.hypothesis).collect::<Vec<_>>(),
        ),
        Column::new(
            "dataset".into(),
            rows.iter().map(|r| r.dataset.clone()).collect::<Vec<_>>(),
        ),
        Column::new(
            "statistic".into(),
            rows.iter().map(|r| r.statistic.clone()).collect::<Vec<_>>(),
        ),
        Column::new(
            "value".into(),
            rows.iter().map(|r| r.value).collect::<Vec<_>>(),
        ),
        Column::new(
            "verdict".into(),
            rows.iter().map(|r| r.verdict).collect::<Vec<_>>(),
        ),
    ])?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_makes_its_folder_and_replaces_an_existing_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a/b/out.bin");
        atomic_write(&path, |w| Ok(w.write_all(b"first")?)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"first");
        // A re-run: the old file is swapped out and removed, the new one is in place whole.
        atomic_write(&path, |w| Ok(w.write_all(&[7u8; 3 << 20])?)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), vec![7u8; 3 << 20]);
        // A failing writer leaves the last good file and no temporary file.
        let err = atomic_write(&path, |w| {
            w.write_all(b"partial")?;
            anyhow::bail!("disk full")
        })
        .unwrap_err();
        assert!(format!("{err:#}").contains("out.bin"), "{err:#}");
        assert_eq!(fs::read(&path).unwrap().len(), 3 << 20);
        let names: Vec<_> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["out.bin"]);
    }
}
