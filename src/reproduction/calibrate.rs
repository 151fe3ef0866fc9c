//! `isar-clutter calibrate-plants`: the stand-in plants fitted to the dissertation's published
//! statistics and written as the fit record the presets compile in
//! (`reproduction/plant_calibration.json`, [`crate::physics::vegetation::calibration`]).
//! Plants A-C are fitted to Table 16's variances; plants D and E to the similarity tables of
//! their measurements (Tables 29-36), by running the similarity experiment of
//! `experiments/similarity_plants.yaml` on candidate plants and reading its cells through the
//! same queries the reproduction document uses ([`super::extract`]). The CNN tables are never
//! read here.

use super::{extract, reference};
use crate::physics::vegetation::calibration::{
    fit_seeds, fit_variance, FitRecord, MotionScales, PlantFit, SimilarityFit, TableResidual,
};
use crate::physics::vegetation::PlantParams;
use crate::run::{driver, options::RunOptions, plan};
use crate::stats::optimise::nelder_mead;
use anyhow::{Context, Result};
use std::io::Write as _;
use std::path::Path;

/// Samples each generation method draws in the similarity fit (the dissertation does not
/// print it for 4.4.2; docs/reproduction.md's constructions table says why 100).
pub const GENERATED: usize = 100;

/// Which plants `calibrate-plants` fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// A-C to Table 16.
    Variance,
    /// D-E to Tables 29-36.
    Similarity,
    /// Both.
    All,
}

/// Fits the plants of `part` with `samples` images per simulation from `seed` (each
/// evaluation the mean over the simulations of `seeds` seeds, `calibration::fit_seeds`: the
/// values of Table 16 for plants A-C, every similarity cell for D and E; the other part's
/// fits are kept from the record at `out`, if any), writes the record to `out` atomically and
/// prints each plant's result. With `kl`, plants D and E are also fitted to the KL divergence
/// tables of their measurements (Tables 13-15, per pixel and per 8x8 area), which the heavy
/// tails of a strong wind response move away from the printed values (docs/definitions.md
/// section 10).
///
/// # Errors
/// If a table is missing from the reference, a simulation or a run fails, or `out` cannot be
/// read or written.
pub fn calibrate_plants(
    samples: usize,
    (seed, seeds): (u64, usize),
    part: Part,
    kl: bool,
    out: &Path,
) -> Result<()> {
    anyhow::ensure!(
        seeds >= 1,
        "--seeds {seeds}: at least one simulation per evaluation"
    );
    let old: Option<FitRecord> = match std::fs::read(out) {
        Ok(bytes) => Some(
            serde_json::from_slice(&bytes)
                .with_context(|| format!("{} is not a fit record", out.display()))?,
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(e).with_context(|| format!("reading {}", out.display())),
    };
    let fits = match (part, &old) {
        (Part::Similarity, Some(r)) => r.fits.clone(),
        _ => variance_fits(samples, &fit_seeds(seed, seeds))?,
    };
    // `--kl` concerns the similarity fits: the record says it only where they are made here.
    let kl = kl && !matches!((part, &old), (Part::Variance, Some(_)));
    let similarity = match (part, &old) {
        (Part::Variance, Some(r)) => r.similarity.clone(),
        _ => ["D", "E"]
            .iter()
            .map(|p| fit_similarity(p, &fit_seeds(seed, seeds), kl))
            .collect::<Result<_>>()?,
    };
    let record = FitRecord {
        source: format!(
            "dissertation Table 16 (mean pixel variance, plants A-C, no and light wind) and \
             Tables 29-36{} (similarity of the generated data to plants D and E, light and \
             medium wind); simulations as the spec's default vegetation_isar dataset (64 x 64, \
             default measurement grid)",
            if kl { " and 13-15" } else { "" }
        ),
        command: format!(
            "isar-clutter calibrate-plants --samples {samples} --seed {seed} --seeds {seeds}{}",
            if kl { " --kl" } else { "" }
        ),
        seed,
        seeds: match (part, &old) {
            (Part::Similarity, Some(r)) => r.seeds,
            _ => seeds,
        },
        samples,
        image_size: 64,
        fits,
        similarity,
    };
    crate::io::atomic::atomic_write(out, |w| {
        serde_json::to_writer_pretty(&mut *w, &record)?;
        w.write_all(b"\n")?;
        Ok(())
    })
    .with_context(|| format!("writing {}", out.display()))
}

/// Plants A-C fitted to Table 16.
fn variance_fits(samples: usize, seeds: &[u64]) -> Result<Vec<PlantFit>> {
    let d = reference::Dissertation::load()?;
    let t16 = d.table(16).context("Table 16 is not in the reference")?;
    let targets: Vec<(String, [f64; 2])> = ["A", "B", "C"]
        .iter()
        .enumerate()
        .map(|(c, p)| {
            let v = |r| t16.number_at(r, c).context("Table 16 has an empty cell");
            Ok((p.to_string(), [v(0)?, v(1)?]))
        })
        .collect::<Result<_>>()?;
    let grid = crate::experiment::MeasurementSpec::default().grid()?;
    let opts = crate::physics::isar::ImagingOptions {
        size: 64,
        ..Default::default()
    };
    let fits = fit_variance(&targets, (&grid, &opts), samples, seeds)?;
    for f in &fits {
        eprintln!(
            "plant {}: gain {:.4}, motion {:.4}; variance none {:.4} (target {}), light {:.4} \
             (target {}); {} simulations",
            f.plant,
            f.gain,
            f.motion,
            f.achieved[0],
            f.target[0],
            f.achieved[1],
            f.target[1],
            f.evaluations
        );
    }
    Ok(fits)
}

/// One printed cell of a similarity table and the query of the tool's value.
struct Target {
    table: u32,
    query: extract::Query,
    printed: f64,
}

/// The tables fitted for `plant` (its light- and medium-wind appendix tables; with `kl`, also
/// the KL divergence tables 13-15).
fn fitted_tables(plant: &str, kl: bool) -> Vec<u32> {
    let mut t = if plant == "D" {
        vec![29, 30, 31, 32]
    } else {
        vec![33, 34, 35, 36]
    };
    if kl {
        t.extend([13, 14, 15]);
    }
    t
}

/// The correlation matrix distance tables (a distance printed near 1 is compared by its
/// distance from 1).
const CMD_TABLES: [u32; 5] = [12, 29, 31, 33, 35];

/// The printed cells of `plant`'s tables: those fitted, then Tables 11-12's rows of the plant.
fn targets(plant: &str, kl: bool) -> Result<Vec<Target>> {
    let d = reference::Dissertation::load()?;
    let prefix = format!("plant_{plant}_");
    let wanted: Vec<u32> = fitted_tables(plant, kl)
        .into_iter()
        .chain([11, 12])
        .collect();
    let mut out = Vec::new();
    for recipe in extract::recipes() {
        if !wanted.contains(&recipe.number) {
            continue;
        }
        let table = d
            .table(recipe.number)
            .with_context(|| format!("Table {} is not in the reference", recipe.number))?;
        for (r, row) in recipe.cells.iter().enumerate() {
            for (c, query) in row.iter().enumerate() {
                let Some(query) = query else { continue };
                let ours = query.filters.iter().any(
                    |(_, k)| matches!(k, extract::Key::S(s) if s.starts_with(prefix.as_str())),
                );
                if let (true, Some(printed)) = (ours, table.number_at(r, c)) {
                    out.push(Target {
                        table: recipe.number,
                        query: query.clone(),
                        printed,
                    });
                }
            }
        }
    }
    Ok(out)
}

/// The log residual of one cell (see [`SimilarityFit`]).
fn residual(table: u32, tool: f64, printed: f64) -> f64 {
    if CMD_TABLES.contains(&table) && printed > 0.5 {
        ((1.0 - tool) / (1.0 - printed)).ln()
    } else {
        (tool / printed).ln()
    }
}

/// The KL divergences of `experiments/similarity_plants.yaml` (the reproduction's estimator), as
/// more entries of a flow-style metrics list.
const KL_METRICS: &str = ", kl_pixel: {symmetric: true, mean_over_bins: true}, kl_area: \
                          {symmetric: true, mean_over_bins: true}";

/// The spec of one evaluation: `plant` in light and medium wind with the wind response ([`MotionScales::for_plant`]) times
/// `motion` and `noise_db` of receiver noise, otherwise `experiments/similarity_plants.yaml`'s
/// construction with [`GENERATED`] samples per method (and its KL divergences with `kl`).
fn spec_text(plant: &str, motion: f64, noise_db: f64, seed: u64, kl: bool) -> Result<String> {
    let p = PlantParams::uncalibrated(plant).context("no such plant preset")?;
    let p = MotionScales::for_plant(plant).apply(p, motion);
    let overrides = format!(
        "{{noise_db: {noise_db}, plant: {{stem_flexibility: {}, branch_flexibility: {}, \
         leaf_flutter_scale: {}}}}}",
        p.stem_flexibility, p.branch_flexibility, p.leaf_flutter_scale
    );
    let ds = |wind: &str| {
        format!(
            "  - {{id: plant_{plant}_{wind}, kind: vegetation_isar, plant: {plant}, wind: \
             {wind}, samples: 100, scene: {overrides}}}\n"
        )
    };
    Ok(format!(
        "name: plant_fit_{plant}\nseed: {seed}\ndatasets:\n{}{}analysis:\n  levels: 3\n\
         synthesis:\n  methods: [full_covariance, method1, method2]\n  samples: {GENERATED}\n  \
         half_width: 8\nmetrics: [multiscale_rmse, cmd{}]\n",
        ds("light"),
        ds("medium"),
        if kl { KL_METRICS } else { "" }
    ))
}

/// Runs the similarity experiment on `plant` with `(motion, noise_db)` in `work` once per seed
/// of `seeds` and returns each target's log residual of the mean of its cell over the runs
/// (the fit is to the expectation over seeds, not to one draw).
fn residuals(
    plant: &str,
    (motion, noise_db): (f64, f64),
    seeds: &[u64],
    targets: &[Target],
    work: &Path,
) -> Result<Vec<f64>> {
    let kl = targets.iter().any(|t| (13..=15).contains(&t.table));
    let mut sums = vec![0.0; targets.len()];
    for &seed in seeds {
        let file = work.join("spec.yaml");
        std::fs::write(&file, spec_text(plant, motion, noise_db, seed, kl)?)?;
        let dir = work.join("run");
        if dir.exists() {
            std::fs::remove_dir_all(&dir)?;
        }
        let plan = plan::load(&file)?;
        let mut ro = RunOptions::new(dir.clone(), crate::run::options::default_threads());
        ro.quiet = true;
        ro.progress_bar = false;
        let summary = driver::run(&plan, &ro)?;
        anyhow::ensure!(summary.failed.is_empty(), "a job of the fit's run failed");
        let mut tables = extract::Tables::default();
        for (sum, t) in sums.iter_mut().zip(targets) {
            *sum += tables.value(&dir, &t.query)?;
        }
    }
    Ok(targets
        .iter()
        .zip(&sums)
        .map(|(t, sum)| residual(t.table, sum / seeds.len() as f64, t.printed))
        .collect())
}

/// Mean square of the residuals of the fitted tables' cells (with `kl`, Tables 13-15's too).
fn objective(targets: &[Target], r: &[f64], plant: &str, kl: bool) -> f64 {
    let fitted = fitted_tables(plant, kl);
    let sq: Vec<f64> = targets
        .iter()
        .zip(r)
        .filter(|(t, _)| fitted.contains(&t.table))
        .map(|(_, v)| v * v)
        .collect();
    sq.iter().sum::<f64>() / sq.len() as f64
}

/// The fit's objective for `plant` (D or E) with `(motion, noise_db)`, simulated from `seeds`
/// (the means of their runs) as the fit simulates: what the record's `objective[1]` states for
/// the fitted factors; `kl` as the fit had it (`--kl`: Tables 13-15 are targets too).
///
/// # Errors
/// If the reference lacks a table or the run fails.
pub fn objective_at(
    plant: &str,
    motion: f64,
    noise_db: f64,
    seeds: &[u64],
    kl: bool,
) -> Result<f64> {
    let targets = targets(plant, kl)?;
    let work = tempfile::tempdir()?;
    let r = residuals(plant, (motion, noise_db), seeds, &targets, work.path())?;
    Ok(objective(&targets, &r, plant, kl))
}

/// `(ln motion, noise_db / 10)` within the searched box: motion 1/8..1024, noise -60..0 dB.
fn inside(x: &[f64]) -> bool {
    (-(8f64.ln())..=1024f64.ln()).contains(&x[0]) && (-6.0..=0.0).contains(&x[1])
}

/// Fits `(motion, noise_db)` of `plant` (D or E) to its similarity tables, each cell the mean
/// over the runs from `seeds`.
fn fit_similarity(plant: &str, seeds: &[u64], kl: bool) -> Result<SimilarityFit> {
    let targets = targets(plant, kl)?;
    let work = tempfile::tempdir()?;
    let at = |x: &[f64]| (x[0].exp(), 10.0 * x[1]);
    let start = [0.0, -4.0];
    let before = residuals(plant, at(&start), seeds, &targets, work.path())?;
    let mut f = |x: &[f64]| -> Result<f64> {
        if !inside(x) {
            return Ok(f64::INFINITY);
        }
        let v = objective(
            &targets,
            &residuals(plant, at(x), seeds, &targets, work.path())?,
            plant,
            kl,
        );
        eprintln!(
            "plant {plant}: motion {:.3}, noise {:.2} dB: objective {v:.4}",
            at(x).0,
            at(x).1
        );
        Ok(v)
    };
    let best = nelder_mead(&mut f, &start, &[4f64.ln(), 1.0], 40, 1e-3)?;
    let (motion, noise_db) = at(&best.x);
    let after = residuals(plant, (motion, noise_db), seeds, &targets, work.path())?;
    let mut tables: Vec<TableResidual> = Vec::new();
    for (t, (b, a)) in targets.iter().zip(before.iter().zip(&after)) {
        if tables.last().is_none_or(|r| r.table != t.table) {
            tables.push(TableResidual {
                table: t.table,
                cells: 0,
                before: 0.0,
                after: 0.0,
            });
        }
        let r = tables.last_mut().expect("pushed");
        r.cells += 1;
        r.before += b * b;
        r.after += a * a;
    }
    for r in &mut tables {
        r.before = (r.before / r.cells as f64).sqrt();
        r.after = (r.after / r.cells as f64).sqrt();
        eprintln!(
            "plant {plant}: Table {}: rms log residual {:.3} -> {:.3} ({} cells)",
            r.table, r.before, r.after, r.cells
        );
    }
    Ok(SimilarityFit {
        plant: plant.into(),
        motion,
        noise_db,
        objective: [objective(&targets, &before, plant, kl), best.value],
        tables,
        evaluations: best.evaluations + 2,
        generated_samples: GENERATED,
        seeds: seeds.len(),
        scales: MotionScales::for_plant(plant),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_distance_near_one_is_compared_by_its_distance_from_one() {
        assert!((residual(29, 0.9, 0.95) - 2f64.ln()).abs() < 1e-12);
        assert!((residual(29, 0.5, 0.25) - 2f64.ln()).abs() < 1e-12);
        assert!((residual(30, 10.0, 5.0) - 2f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn every_cell_of_the_plant_tables_has_a_target() {
        let d = targets("D", false).unwrap();
        // Tables 29/31: 3 cells, 30/32: 27, 11: 2 rows of 6, 12: 2 rows of 2.
        assert_eq!(d.len(), 3 + 27 + 3 + 27 + 12 + 4);
        assert!(d.iter().all(|t| t.printed > 0.0));
        assert_eq!(targets("E", false).unwrap().len(), d.len());
        let spec = spec_text("E", 2.0, -20.0, 7, false).unwrap();
        assert!(spec.contains("plant_E_medium") && spec.contains("noise_db: -20"));
        // With the KL tables: Tables 13-15, 2 rows (light, medium) of 4 cells each.
        let k = targets("D", true).unwrap();
        assert_eq!(k.len(), d.len() + 3 * 2 * 4);
        assert_eq!(
            k.iter().filter(|t| (13..=15).contains(&t.table)).count(),
            24
        );
        assert!(spec_text("D", 2.0, -20.0, 7, true)
            .unwrap()
            .contains("kl_area: {symmetric: true, mean_over_bins: true}"));
    }
}
