//! Runs a validated plan: jobs in parallel on a rayon pool of the requested size, a progress
//! bar on a terminal (plain lines otherwise), per-job failures recorded without stopping the
//! others, then the Parquet tables, the `.npy` maps and `manifest.json`, all written
//! atomically into the output folder.

use crate::analysis::Analysis;
use crate::analysis::Direction;
use crate::data::{materialise, Materialised};
use crate::filters::{expected_maps, expected_maps_are_cheap, lag_correlation};
use crate::metrics::Metric;
use crate::plan::{Job, NoiseFloorPlan, Plan};
use crate::results::{self, FilterRow, JobOutcome, JobResult, SimilarityOutcome, SynthesisOutcome};
use crate::similarity::{compare, Side};
use crate::spec::Dataset;
use crate::spec::SynthesisSpec;
use crate::synthesis::{fit, FitOptions, Method};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use ndarray::{s, Array3, ArrayView3};
use num_complex::Complex64;
use rayon::prelude::*;
use serde_json::json;
use std::io::IsTerminal;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Largest image (pixels) for which exact expected maps of spatially varying filters are
/// computed; above it `expected_correlation` is null (the pair sums grow as `4^L` per pixel).
pub const MAX_EXACT_PIXELS: usize = 256 * 256;

/// How to run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Output folder.
    pub out: PathBuf,
    /// Worker threads.
    pub threads: usize,
    /// Show a progress bar (otherwise one line per finished job on stderr).
    pub progress_bar: bool,
    /// Print progress at all.
    pub quiet: bool,
}

impl RunOptions {
    /// Options with a progress bar when stderr is a terminal.
    pub fn new(out: PathBuf, threads: usize) -> Self {
        RunOptions {
            out,
            threads,
            progress_bar: std::io::stderr().is_terminal(),
            quiet: false,
        }
    }
}

/// What a run did.
#[derive(Debug, Clone)]
pub struct RunSummary {
    /// Jobs run.
    pub total: usize,
    /// Jobs that failed.
    pub failed: Vec<(String, String)>,
    /// Output folder.
    pub out: PathBuf,
    /// Wall time in seconds.
    pub elapsed_s: f64,
}

/// Default number of worker threads: the machine's available parallelism.
pub fn default_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// Runs every job of `plan` and writes the outputs.
///
/// # Errors
/// Only for failures outside the jobs (output folder, tables, manifest); a failed job is
/// recorded in `jobs.parquet` and in the returned summary.
pub fn run(plan: &Plan, opts: &RunOptions) -> Result<RunSummary> {
    let start = Instant::now();
    std::fs::create_dir_all(&opts.out)
        .with_context(|| format!("cannot create {}", opts.out.display()))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.max(1))
        .build()?;
    let bar = progress(plan.jobs.len(), opts);
    let groups = data_groups(plan);
    let mut outcomes: Vec<JobOutcome> = pool.install(|| {
        groups
            .par_iter()
            .flat_map_iter(|group| {
                // Expensive datasets read by several jobs are materialised once for the group
                // (no lock: the group owns them), then dropped when its jobs are done.
                let shared =
                    (group.len() > 1 && expensive(&plan.jobs[group[0]].dataset)).then(|| {
                        let job = &plan.jobs[group[0]];
                        catch_unwind(AssertUnwindSafe(|| {
                            materialise(&job.dataset, job.data_seed)
                                .map_err(|e| format!("dataset {}: {e:#}", job.dataset_id))
                        }))
                        .unwrap_or_else(|p| Err(format!("dataset panicked: {}", panic_message(&p))))
                    });
                group
                    .par_iter()
                    .map(|&index| {
                        let job = &plan.jobs[index];
                        let t = Instant::now();
                        let result = match &shared {
                            Some(Err(e)) => Err(e.clone()),
                            _ => {
                                let data = shared.as_ref().and_then(|r| r.as_ref().ok());
                                catch_unwind(AssertUnwindSafe(|| {
                                    run_job(plan, job, &opts.out, data)
                                }))
                                .unwrap_or_else(|p| {
                                    Err(anyhow::anyhow!("job panicked: {}", panic_message(&p)))
                                })
                                .map_err(|e| format!("{e:#}"))
                            }
                        };
                        let outcome = JobOutcome {
                            index,
                            result,
                            elapsed_s: t.elapsed().as_secs_f64(),
                        };
                        report(&bar, opts, job, &outcome);
                        outcome
                    })
                    .collect::<Vec<_>>()
            })
            .collect()
    });
    outcomes.sort_by_key(|o| o.index);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let t_tables = Instant::now();
    pool.install(|| write_outputs(plan, &outcomes, &opts.out))?;
    let tables_s = t_tables.elapsed().as_secs_f64();
    remove_stale_maps(plan, &opts.out)?;
    let failed: Vec<(String, String)> = outcomes
        .iter()
        .filter_map(|o| {
            o.result
                .as_ref()
                .err()
                .map(|e| (plan.jobs[o.index].id.clone(), e.clone()))
        })
        .collect();
    let elapsed_s = start.elapsed().as_secs_f64();
    if let Some(c) = &plan.spec.calibration {
        results::write_calibration(c, plan.calibration_seed(), &opts.out)?;
    }
    write_manifest(plan, &outcomes, opts, elapsed_s, tables_s)?;
    Ok(RunSummary {
        total: outcomes.len(),
        failed,
        out: opts.out.clone(),
        elapsed_s,
    })
}

/// Job indices grouped by the data they read (their data seed), groups in order of first
/// appearance, jobs in plan order.
fn data_groups(plan: &Plan) -> Vec<Vec<usize>> {
    let mut groups: Vec<(u64, Vec<usize>)> = vec![];
    for (i, job) in plan.jobs.iter().enumerate() {
        match groups.iter_mut().find(|(seed, _)| *seed == job.data_seed) {
            Some((_, g)) => g.push(i),
            None => groups.push((job.data_seed, vec![i])),
        }
    }
    groups.into_iter().map(|(_, g)| g).collect()
}

/// Datasets worth sharing between jobs: simulated or decoded ones (a mapped `.npy` is free and
/// synthetic filtered noise cheap next to its jobs).
fn expensive(d: &Dataset) -> bool {
    matches!(
        d,
        Dataset::Vegetation(_) | Dataset::Kspace(_) | Dataset::Netcdf(_)
    )
}

/// The job's data: the group's shared copy, or its own.
fn data_of<'a>(
    job: &Job,
    shared: Option<&'a Materialised>,
    owned: &'a mut Option<Materialised>,
) -> Result<&'a Materialised> {
    if let Some(d) = shared {
        return Ok(d);
    }
    let d = materialise(&job.dataset, job.data_seed)
        .with_context(|| format!("dataset {}", job.dataset_id))?;
    Ok(owned.insert(d))
}

fn progress(n: usize, opts: &RunOptions) -> Option<ProgressBar> {
    (opts.progress_bar && !opts.quiet).then(|| {
        let bar = ProgressBar::new(n as u64);
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} jobs [{elapsed_precise}] {msg}")
                .expect("valid template"),
        );
        bar
    })
}

fn report(bar: &Option<ProgressBar>, opts: &RunOptions, job: &Job, o: &JobOutcome) {
    let status = match &o.result {
        Ok(_) => "ok".to_string(),
        Err(e) => format!("FAILED: {e}"),
    };
    match bar {
        Some(b) => {
            if o.result.is_err() {
                b.println(format!("{}: {status}", job.id));
            }
            b.set_message(job.id.clone());
            b.inc(1);
        }
        None if !opts.quiet => eprintln!("{} {status} ({:.3} s)", job.id, o.elapsed_s),
        None => {}
    }
}

fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// Runs one job: materialise, analyse, compute the ground truth.
fn run_job(plan: &Plan, job: &Job, out: &Path, shared: Option<&Materialised>) -> Result<JobResult> {
    if let (Some(method), Some(syn)) = (job.method, &job.synthesis) {
        return run_synthesis_job(plan, job, method, syn, out, shared);
    }
    let t = Instant::now();
    let mut owned = None;
    let data = data_of(job, shared, &mut owned)?;
    let data_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let analysis = data
        .stack
        .analyse(data.hwn, job.analysis.levels)
        .with_context(|| format!("analysing dataset {}", job.dataset_id))?;
    let analysis_s = t.elapsed().as_secs_f64();
    let (mut expected, mut filter_rows) = (None, vec![]);
    if let Some((bank, std)) = &data.truth {
        let uniform = bank.is_uniform();
        if expected_maps_are_cheap(bank, std) || bank.height * bank.width <= MAX_EXACT_PIXELS {
            expected = Some(expected_maps(bank, std, job.analysis.levels));
        }
        if uniform {
            let lags = plan.spec.outputs.filter_lags.unwrap_or(bank.half_width);
            for (direction, taps) in [
                (Direction::H, &bank.horizontal[0]),
                (Direction::V, &bank.vertical[0]),
            ] {
                for lag in 0..=lags {
                    filter_rows.push(FilterRow {
                        direction,
                        lag,
                        coefficient: taps.get(bank.half_width + lag).copied().unwrap_or(0.0),
                        correlation: lag_correlation(taps, lag),
                    });
                }
            }
        }
    }
    // The complex128 copy of the stack, made once for the noise floor and the hypotheses.
    let original = (job.noise_floor.is_some() || plan.spec.hypotheses.is_some())
        .then(|| data.stack.to_complex128(data.hwn));
    let similarity = match (job.noise_floor, &original) {
        (Some(nf), Some(original)) => Some(
            noise_floor(plan, job, nf, data, original, &analysis)
                .with_context(|| format!("noise floor ({})", nf.as_str()))?,
        ),
        _ => None,
    };
    if let (Some(k), Dataset::Vegetation(v)) = (&data.kspace, &job.dataset) {
        let dir = out.join("kspace");
        let k64 = k.mapv(|z| num_complex::Complex::new(z.re as f32, z.im as f32));
        results::write_npy(&dir.join(format!("{}.npy", job.id)), &k64)?;
        let grid = v.measurement.grid()?;
        results::write_npy(
            &dir.join(format!("{}.freqs.npy", job.id)),
            &ndarray::Array1::from(grid.freqs.clone()),
        )?;
        let deg: Vec<f64> = grid.azimuths.iter().map(|a| a.to_degrees()).collect();
        results::write_npy(
            &dir.join(format!("{}.azimuths_deg.npy", job.id)),
            &ndarray::Array1::from(deg),
        )?;
    }
    let correlating = plan
        .spec
        .hypotheses
        .as_ref()
        .zip(original.as_ref())
        .map(|(hs, stack)| crate::hypotheses::correlating_function(stack.view(), hs.max_offset));
    drop(original);
    let (n, h, w) = job.dataset.shape();
    let result = JobResult {
        correlating,
        source: "original",
        analysis: Some(analysis),
        synthesis: None,
        expected,
        filter_rows,
        shape: (n, h, w),
        data_s,
        analysis_s,
        bytes: data.stack.bytes(),
        similarity,
    };
    Ok(result)
}

/// The metrics between two independent stacks of the original data: the original against an
/// independent draw of the synthetic model (`draws`), or one half against the other
/// (`original`: the stack as complex128).
fn noise_floor(
    plan: &Plan,
    job: &Job,
    nf: NoiseFloorPlan,
    data: &Materialised,
    original: &Array3<Complex64>,
    analysis: &Analysis,
) -> Result<SimilarityOutcome> {
    let t = Instant::now();
    let levels = job.analysis.levels;
    let rmse = plan.metrics.contains(&Metric::MultiscaleRmse);
    let analyse = |x: ArrayView3<Complex64>| -> Result<Option<Analysis>> {
        Ok(if rmse {
            Some(crate::analysis::analyse(x, levels)?)
        } else {
            None
        })
    };
    let comparison = match nf {
        NoiseFloorPlan::Draws { samples, seed } => {
            let draw = match (&job.dataset, &data.truth) {
                (Dataset::FilteredNoise(f), Some((bank, _))) => {
                    let mut spec = (**f).clone();
                    spec.samples = samples;
                    crate::data::generate(&spec, bank, seed)
                }
                (Dataset::Vegetation(v), _) => {
                    // An independent simulation of the same scene: new seed, no k-space kept.
                    let mut spec = (**v).clone();
                    spec.samples = samples;
                    spec.save_kspace = false;
                    crate::data::materialise(&Dataset::Vegetation(Box::new(spec)), seed)?
                        .stack
                        .to_complex128(false)
                }
                _ => anyhow::bail!("draws need a synthetic or simulated dataset"),
            };
            let draw_analysis = analyse(draw.view())?;
            let a = Side {
                stack: original.view(),
                analysis: Some(analysis),
            };
            let b = Side {
                stack: draw.view(),
                analysis: draw_analysis.as_ref(),
            };
            compare(a, b, &plan.metrics)
        }
        NoiseFloorPlan::Halves => {
            let half = original.dim().0 / 2;
            let first = original.slice(s![..half, .., ..]);
            let second = original.slice(s![half..2 * half, .., ..]);
            let (fa, sa) = (analyse(first)?, analyse(second)?);
            let a = Side {
                stack: first,
                analysis: fa.as_ref(),
            };
            let b = Side {
                stack: second,
                analysis: sa.as_ref(),
            };
            compare(a, b, &plan.metrics)
        }
    };
    Ok(SimilarityOutcome {
        compared: "noise_floor",
        noise_floor: Some(nf.as_str()),
        comparison,
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// Runs a synthesis job: analyses the original data (to the levels the method needs), fits the
/// method, generates the samples from the dataset's generation seed, saves them if asked and
/// analyses them.
fn run_synthesis_job(
    plan: &Plan,
    job: &Job,
    method: Method,
    syn: &SynthesisSpec,
    out: &Path,
    shared: Option<&Materialised>,
) -> Result<JobResult> {
    let t = Instant::now();
    let mut owned = None;
    let data = data_of(job, shared, &mut owned)?;
    let data_s = t.elapsed().as_secs_f64();
    let levels = match method {
        Method::Method2 => syn.dyadic_levels(&job.analysis),
        _ => 1,
    };
    let rmse = plan.metrics.contains(&Metric::MultiscaleRmse);
    let analysed = if rmse {
        levels.max(job.analysis.levels)
    } else {
        levels
    };
    let original = data
        .stack
        .analyse(data.hwn, analysed)
        .with_context(|| format!("analysing dataset {}", job.dataset_id))?;
    let t = Instant::now();
    let stack = (matches!(method, Method::FullCovariance | Method::FourthOrder)
        || !plan.metrics.is_empty())
    .then(|| data.stack.to_complex128(data.hwn));
    let opts = FitOptions {
        half_width: syn.half_width,
        levels,
    };
    let model = fit(method, &original, stack.as_ref().map(|s| s.view()), opts)
        .with_context(|| format!("fitting {}", method.as_str()))?;
    let fit_s = t.elapsed().as_secs_f64();
    let source = format!("job {} (dataset {})", job.id, job.dataset_id);
    let info = crate::model::ModelInfo::new(&model, &original, syn.half_width, levels, source);
    crate::model::save(&model, &info, &out.join("models").join(&job.id))?;
    let t = Instant::now();
    let generated = model.generate_c64(job.generation_seed, 0, syn.samples);
    let generate_s = t.elapsed().as_secs_f64();
    if syn.save_samples {
        results::write_npy(
            &out.join("samples").join(format!("{}.npy", job.id)),
            &generated,
        )?;
    }
    let t = Instant::now();
    let analysis = if syn.analyse_generated {
        Some(
            crate::analysis::analyse(generated.view(), job.analysis.levels)
                .context("analysing the generated samples")?,
        )
    } else {
        None
    };
    let analysis_s = t.elapsed().as_secs_f64();
    let similarity = stack.filter(|_| !plan.metrics.is_empty()).map(|stack| {
        let t = Instant::now();
        let a = Side {
            stack: stack.view(),
            analysis: Some(&original),
        };
        let b = Side {
            stack: generated.view(),
            analysis: analysis.as_ref(),
        };
        let comparison = compare(a, b, &plan.metrics);
        SimilarityOutcome {
            compared: method.as_str(),
            noise_floor: None,
            comparison,
            seconds: t.elapsed().as_secs_f64(),
        }
    });
    let (_, h, w) = job.dataset.shape();
    Ok(JobResult {
        source: method.as_str(),
        analysis,
        synthesis: Some(SynthesisOutcome {
            filter: model.filter,
            samples: syn.samples,
            fit_s,
            generate_s,
        }),
        expected: None,
        filter_rows: vec![],
        shape: (syn.samples, h, w),
        data_s,
        analysis_s,
        bytes: syn.samples * h * w * 8,
        similarity,
        correlating: None,
    })
}

/// One file (or folder of files) of the output phase.
enum Output<'a> {
    /// A Parquet table and its builder.
    Table(
        &'static str,
        fn(&Plan, &[JobOutcome]) -> Result<polars::prelude::DataFrame>,
    ),
    /// The `.npy` maps of one successful job.
    Maps(&'a str, &'a JobResult),
}

/// Writes the tables and every job's maps, in parallel.
fn write_outputs(plan: &Plan, outcomes: &[JobOutcome], out: &Path) -> Result<()> {
    let mut tasks = vec![
        Output::Table("analysis_maps.parquet", results::analysis_maps),
        Output::Table("analysis_summary.parquet", results::analysis_summary),
        Output::Table("pixel_stats.parquet", results::pixel_stats),
        Output::Table("filter_correlation.parquet", results::filter_correlation),
        Output::Table("jobs.parquet", results::jobs_table),
        Output::Table("synthesis_params.parquet", results::synthesis_params),
        Output::Table("similarity.parquet", results::similarity),
        Output::Table("model_order.parquet", results::model_order),
    ];
    if plan.spec.hypotheses.is_some() {
        tasks.push(Output::Table("hypotheses.parquet", results::hypotheses));
        tasks.push(Output::Table(
            "correlating_function.parquet",
            results::correlating_function,
        ));
    }
    if plan.spec.outputs.npy_maps {
        for o in outcomes {
            if let Ok(r) = &o.result {
                tasks.push(Output::Maps(&plan.jobs[o.index].id, r));
            }
        }
    }
    tasks.par_iter().try_for_each(|task| match task {
        Output::Table(name, build) => {
            let mut df = build(plan, outcomes).with_context(|| format!("building {name}"))?;
            results::write_parquet(&out.join(name), &mut df)
        }
        Output::Maps(id, r) => results::write_job_maps(&out.join("maps").join(id), r),
    })
}

/// Removes `maps/<job>` folders of jobs that are not in this plan (left by an earlier run of
/// an edited spec into the same folder), so `maps/` matches `jobs.parquet`.
fn remove_stale_maps(plan: &Plan, out: &Path) -> Result<()> {
    let ids: Vec<&str> = plan.jobs.iter().map(|j| j.id.as_str()).collect();
    results::remove_folders_except(&out.join("maps"), &ids)
}

/// Commit and dirty flag of the source tree when the binary was built (null outside git).
fn git_state() -> serde_json::Value {
    match (
        env!("ISAR_CLUTTER_GIT_COMMIT"),
        env!("ISAR_CLUTTER_GIT_DIRTY"),
    ) {
        ("", _) => serde_json::Value::Null,
        (commit, dirty) => {
            json!({ "commit": commit, "dirty": dirty == "true", "recorded": "at build time" })
        }
    }
}

fn write_manifest(
    plan: &Plan,
    outcomes: &[JobOutcome],
    opts: &RunOptions,
    total_s: f64,
    tables_s: f64,
) -> Result<()> {
    let jobs: Vec<serde_json::Value> = outcomes
        .iter()
        .map(|o| {
            let job = &plan.jobs[o.index];
            let timing = o.result.as_ref().ok().map(|r| {
                json!({
                    "data_s": r.data_s,
                    "analysis_s": r.analysis_s,
                    "input_bytes": r.bytes,
                    "analysis_gb_per_s": r.bytes as f64 / r.analysis_s / 1e9,
                    "shape": [r.shape.0, r.shape.1, r.shape.2],
                    "fit_s": r.synthesis.as_ref().map(|s| s.fit_s),
                    "generate_s": r.synthesis.as_ref().map(|s| s.generate_s),
                    "generated_samples_per_s": r.synthesis.as_ref().map(|s| s.samples as f64 / s.generate_s),
                    "metrics_s": r.similarity.as_ref().map(|s| s.seconds),
                })
            });
            json!({
                "job": job.id,
                "dataset": job.dataset_id,
                "method": job.method.map(Method::as_str),
                "generation_seed": job.generation_seed,
                "noise_floor": job.noise_floor,
                "identity": job.identity,
                "seed": job.seed,
                "data_seed": job.data_seed,
                "params": job.params,
                "status": if o.result.is_ok() { "ok" } else { "failed" },
                "error": o.result.as_ref().err(),
                "elapsed_s": o.elapsed_s,
                "timing": timing,
            })
        })
        .collect();
    let unix = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let manifest = json!({
        "format": "isar-clutter-manifest/1",
        "tool": { "name": env!("CARGO_PKG_NAME"), "version": env!("CARGO_PKG_VERSION") },
        "git": git_state(),
        "spec_file": plan.file.display().to_string(),
        "spec_hash_sha256": plan.spec_hash,
        "spec": plan.spec,
        "master_seed": plan.spec.seed,
        "seed_derivation": "first 8 bytes (LE) of SHA-256('isar-clutter/v1/<job|data>/<master seed>/<identity>'); samples use ChaCha20 seeded with data_seed, stream = sample index",
        "threads": opts.threads,
        "calibration_seed": plan.spec.calibration.as_ref().map(|_| plan.calibration_seed()),
        "finished_unix_s": unix,
        "timings": { "total_s": total_s, "tables_s": tables_s },
        "jobs": jobs,
    });
    results::atomic_write(&opts.out.join("manifest.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &manifest)?;
        Ok(())
    })
}
