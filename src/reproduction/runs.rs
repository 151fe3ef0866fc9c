//! The runs of a reproduction: what it covers ([`Coverage`]: the tables' recipes and the
//! statements), which specs that needs and how often (a random statistic is repeated with other
//! master seeds, [`repeat_seed`]), running or resuming them through the job store into
//! `OUT/<spec>/seed-<seed>/` ([`run_all`]), which of those folders are complete runs
//! ([`complete_folders`]), and the records the document states about them (wall time, builds).

use super::cnn;
use super::compare::Spread;
use super::extract::{self, Recipe};
use crate::run::{driver, options::RunOptions, plan};
use anyhow::{Context, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What `reproduce` does.
#[derive(Debug, Clone)]
pub struct Options {
    /// Where the runs go (`outputs/reproduction`).
    pub out: PathBuf,
    /// The folder of the specs (`experiments`).
    pub specs: PathBuf,
    /// Runs of each spec whose statistics are random (the first with the spec's own seed).
    pub repeats: usize,
    /// Runs of each such spec that trains networks ([`trains_networks`]; `None`: `repeats`).
    pub cnn_repeats: Option<usize>,
    /// Worker threads of each run.
    pub threads: usize,
    /// Only write the document from the folders there (run nothing).
    pub write_only: bool,
    /// Run only these specs (file stems; empty: every spec the coverage needs).
    pub only: Vec<String>,
    /// No progress output.
    pub quiet: bool,
    /// Where the CNN trainings run in place of the specs' `training.device` (`--device`).
    pub device: Option<crate::apps::cnn::train::Device>,
}

/// What the reproduction covers: the tables' recipes and the computed statements.
#[derive(Debug, Clone)]
pub struct Coverage {
    /// Tables, cell by cell.
    pub recipes: Vec<Recipe>,
    /// Numbers the text states.
    pub statements: Vec<extract::Statement>,
    /// Whether the worked example of Method 2's solver (4.3.1, [`super::solver`]) is computed.
    pub solver: bool,
}

impl Coverage {
    /// Everything [`extract`] and [`cnn`] know.
    pub fn all() -> Coverage {
        Coverage {
            recipes: all_recipes(),
            statements: cnn::gain_statements()
                .into_iter()
                .chain(extract::statements())
                .chain(cnn::stochastic_location())
                .collect(),
            solver: true,
        }
    }

    /// Only the tables `numbers` (no statements): a quick check.
    pub fn tables(numbers: &[u32]) -> Coverage {
        Coverage {
            recipes: all_recipes()
                .into_iter()
                .filter(|r| numbers.contains(&r.number))
                .collect(),
            statements: Vec::new(),
            solver: false,
        }
    }
}

/// Every table's recipes: [`extract`]'s, then the CNN tables'.
fn all_recipes() -> Vec<Recipe> {
    let mut r = extract::recipes();
    r.extend(cnn::recipes());
    r
}

/// The master seed of repeat `k` of a spec whose own seed is `seed`: the spec's for the first,
/// then seeds derived from it (recorded in each run's manifest).
pub fn repeat_seed(seed: u64, k: usize) -> u64 {
    if k == 0 {
        seed
    } else {
        crate::seeds::derive_seed(seed, "repeat", &k.to_string())
    }
}

/// The runs of one spec: `(seed, folder)` per repeat.
#[derive(Debug, Clone)]
pub struct SpecRuns {
    /// The spec's name (file stem).
    pub spec: &'static str,
    /// One per repeat.
    pub runs: Vec<(u64, PathBuf)>,
}

/// Whether `spec` trains networks (the CNN specs, `cnn_*`): a repeat of one trains dozens,
/// and they dominate a reproduction's time.
pub fn trains_networks(spec: &str) -> bool {
    spec.starts_with("cnn_")
}

/// The specs the recipes need, each with its number of repeats (1 where every table reading
/// it is exact; `cnn_repeats`, where given, for the specs that train networks and repeat).
pub fn needed(
    coverage: &Coverage,
    repeats: usize,
    cnn_repeats: Option<usize>,
) -> BTreeMap<&'static str, usize> {
    let mut specs = needed_at(coverage, repeats);
    if let Some(c) = cnn_repeats {
        for (spec, n) in specs.iter_mut() {
            if trains_networks(spec) && *n > 1 {
                *n = c.max(1);
            }
        }
    }
    specs
}

/// [`needed`] with one number of repeats for every spec that repeats.
fn needed_at(coverage: &Coverage, repeats: usize) -> BTreeMap<&'static str, usize> {
    let mut specs = BTreeMap::new();
    for s in &coverage.statements {
        for (a, b) in &s.terms {
            for spec in [a.spec, b.spec] {
                specs.insert(spec, repeats.max(1));
            }
        }
    }
    for r in &coverage.recipes {
        let n = match r.spread {
            Spread::Exact => 1,
            _ if r.runs_once() => 1,
            Spread::Random | Spread::Conclusion => repeats.max(1),
        };
        for s in extract::specs_of(r) {
            let e = specs.entry(s).or_insert(1);
            *e = (*e).max(n);
        }
    }
    specs
}

/// Runs (or resumes) every repeat of every needed spec; the folders.
///
/// # Errors
/// If a spec cannot be loaded or a run fails as a whole (a failed job is reported by the
/// document writer, which refuses the folder), or `only` names a spec the coverage does not
/// need.
pub fn run_all(opts: &Options, coverage: &Coverage) -> Result<Vec<SpecRuns>> {
    let needed = needed(coverage, opts.repeats, opts.cnn_repeats);
    if let Some(o) = opts.only.iter().find(|o| !needed.contains_key(o.as_str())) {
        let names: Vec<&str> = needed.keys().copied().collect();
        anyhow::bail!(
            "--only {o}: not a spec the document needs (it needs {})",
            names.join(", ")
        );
    }
    let mut all = Vec::new();
    for (spec, repeats) in needed {
        if !opts.only.is_empty() && !opts.only.iter().any(|o| o == spec) {
            continue;
        }
        let file = opts.specs.join(format!("{spec}.yaml"));
        let base = plan::load(&file)?.spec.seed;
        let mut runs = Vec::new();
        for k in 0..repeats {
            let seed = repeat_seed(base, k);
            let dir = opts.out.join(spec).join(format!("seed-{seed}"));
            if !opts.write_only {
                let mut plan = plan::load_seeded(&file, (k > 0).then_some(seed))?;
                if let Some(device) = opts.device {
                    plan.set_training_device(device);
                }
                if let Some(line) = plan.resolve_training_device()? {
                    if !opts.quiet || line.contains("(auto:") {
                        eprintln!("{spec} seed {seed}: CNN trainings on: {line}");
                    }
                }
                let mut ro = RunOptions::new(dir.clone(), opts.threads);
                ro.quiet = opts.quiet;
                ro.report_follows = false;
                let summary = driver::run(&plan, &ro)
                    .with_context(|| format!("running {} (seed {seed})", file.display()))?;
                if !opts.quiet {
                    eprintln!(
                        "{spec} seed {seed}: {}/{} job(s) ok in {:.1} s",
                        summary.total - summary.failed.len(),
                        summary.total,
                        summary.elapsed_s
                    );
                }
            }
            runs.push((seed, dir));
        }
        all.push(SpecRuns { spec, runs });
    }
    Ok(all)
}

/// The folders of `spec`'s repeats, in repeat order.
pub(super) fn folders<'a>(runs: &'a [SpecRuns], spec: &str) -> Vec<&'a Path> {
    runs.iter()
        .filter(|r| r.spec == spec)
        .flat_map(|r| r.runs.iter().map(|(_, d)| d.as_path()))
        .collect()
}

/// A run folder the document would read but cannot: not run yet, or its run incomplete.
#[derive(Debug, Clone)]
pub struct Missing {
    /// The spec (file stem).
    pub spec: &'static str,
    /// The folder.
    pub dir: PathBuf,
    /// Why it cannot be read, in words.
    pub why: String,
}

impl Missing {
    /// `OUT/spec/seed-N (why)`, for the document.
    pub fn show(&self) -> String {
        format!("{} ({})", self.dir.display(), self.why)
    }
}

/// Splits `runs` into the complete folders and the missing ones: a folder that does not exist,
/// has no manifest or holds a run in progress is missing (its cells and claims are then not
/// decidable, naming it); a finished folder whose files changed since is damaged, and refused.
///
/// # Errors
/// Naming the first damaged folder.
pub fn complete_folders(runs: &[SpecRuns]) -> Result<(Vec<SpecRuns>, Vec<Missing>)> {
    let mut complete = Vec::new();
    let mut missing = Vec::new();
    for r in runs {
        let mut kept = Vec::new();
        for (seed, dir) in &r.runs {
            let Err(e) = crate::io::outdir::check_complete(dir) else {
                kept.push((*seed, dir.clone()));
                continue;
            };
            let absent = !dir.is_dir()
                || !dir.join("manifest.json").is_file()
                || dir
                    .join(crate::io::outdir::STATE)
                    .join("in-progress")
                    .exists();
            if !absent {
                return Err(e).with_context(|| {
                    format!(
                        "the reproduction reads {}: run `isar-clutter reproduce` again to redo it",
                        dir.display()
                    )
                });
            }
            let why = if dir.is_dir() {
                let text = format!("{e:#}");
                let text = text
                    .strip_prefix(&format!("{} ", dir.display()))
                    .unwrap_or(&text)
                    .to_string();
                text.split("; ").next().unwrap_or_default().to_string()
            } else {
                "not run".to_string()
            };
            missing.push(Missing {
                spec: r.spec,
                dir: dir.clone(),
                why,
            });
        }
        complete.push(SpecRuns {
            spec: r.spec,
            runs: kept,
        });
    }
    Ok((complete, missing))
}

/// Records the wall time of the runs that filled `out` (`out/reproduce-run.json`), so that a
/// document written later from the same folders (`--write-only`) states it.
///
/// # Errors
/// If the record cannot be written.
pub fn record_wall(out: &Path, wall_s: f64, repeats: usize) -> Result<()> {
    let record = serde_json::json!({ "wall_s": wall_s, "repeats": repeats });
    crate::io::atomic::atomic_write(&out.join("reproduce-run.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &record)?;
        Ok(())
    })
}

/// The builds of the tool that computed the jobs of every run folder in `runs` (the manifests'
/// `computed_by`; `not recorded` for a job without it), with their job counts.
pub fn builds(runs: &[SpecRuns]) -> Vec<(String, usize)> {
    let mut count: BTreeMap<String, usize> = BTreeMap::new();
    for m in manifests(runs) {
        for job in &m.jobs {
            let b = job.computed_by.as_deref().unwrap_or("not recorded");
            *count.entry(b.to_string()).or_default() += 1;
        }
    }
    count.into_iter().collect()
}

/// The manifest of every run folder in `runs` that has a readable one.
fn manifests(runs: &[SpecRuns]) -> impl Iterator<Item = crate::io::manifest::Manifest> + '_ {
    runs.iter()
        .flat_map(|r| &r.runs)
        .filter_map(|(_, dir)| crate::io::manifest::Manifest::read(dir).ok())
}

/// The plants' calibration records the run folders in `runs` were computed with (the
/// manifests' `plant_calibration_sha256`, its first 12 hex digits; `not recorded` for a
/// manifest of a tool before it), with their run counts.
pub fn plant_records(runs: &[SpecRuns]) -> Vec<(String, usize)> {
    let mut count: BTreeMap<String, usize> = BTreeMap::new();
    for m in manifests(runs) {
        let r = m
            .plant_calibration_sha256
            .as_deref()
            .map_or("not recorded", |h| &h[..h.len().min(12)]);
        *count.entry(r.to_string()).or_default() += 1;
    }
    count.into_iter().collect()
}

/// One spec's compute time in its run folders ([`job_time`]).
#[derive(Debug, Clone, PartialEq)]
pub struct JobTime {
    /// The spec's name.
    pub spec: String,
    /// Its run folders read.
    pub runs: usize,
    /// Their jobs.
    pub jobs: usize,
    /// The jobs' elapsed seconds, each run's sum divided by its worker threads.
    pub seconds: f64,
}

/// The compute time of every spec's run folders in `runs`, from their manifests: each job's
/// own elapsed time (a resumed job's from when it ran), summed over a run and divided by the
/// run's worker threads (its jobs share them), summed over the runs. A folder whose manifest
/// cannot be read is left out.
pub fn job_time(runs: &[SpecRuns]) -> Vec<JobTime> {
    let mut out = Vec::new();
    for r in runs {
        let mut t = JobTime {
            spec: r.spec.to_string(),
            runs: 0,
            jobs: 0,
            seconds: 0.0,
        };
        for (_, dir) in &r.runs {
            let Ok(m) = crate::io::manifest::Manifest::read(dir) else {
                continue;
            };
            let threads = m.threads.unwrap_or(1).max(1) as f64;
            t.runs += 1;
            t.jobs += m.jobs.len();
            t.seconds += m.jobs.iter().filter_map(|j| j.elapsed_s).sum::<f64>() / threads;
        }
        if t.runs > 0 {
            out.push(t);
        }
    }
    out
}

/// The wall time [`record_wall`] recorded in `out`, if any.
pub fn recorded_wall(out: &Path) -> Option<f64> {
    let text = std::fs::read(out.join("reproduce-run.json")).ok()?;
    serde_json::from_slice::<serde_json::Value>(&text).ok()?["wall_s"].as_f64()
}
