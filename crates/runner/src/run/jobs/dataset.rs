//! The jobs of a dataset: the analysis of the original stack (with its expected maps, filter
//! lags, noise floor and correlating function) and, with a `synthesis` section, one job per
//! method that fits the method, generates samples and compares them with the original. Both
//! are [`crate::run::plan::Job`]s; the method (or its absence) is the one place that tells
//! them apart.

use super::{Context as JobContext, Inputs, JobKind, Rows, Status};
use crate::experiment::Materialised;
use crate::experiment::SynthesisSpec;
use crate::io::atomic::write_npy;
use crate::run::plan::{Job, NoiseFloorPlan, Plan};
use crate::run::tables::{self, FilterRow, JobResult, SimilarityOutcome, SynthesisOutcome};
use crate::stats::analysis::{Analysis, Direction};
use crate::stats::filters::{expected_maps, expected_maps_are_cheap, lag_correlation};
use crate::stats::metrics::Metric;
use crate::stats::similarity::{compare, Side};
use crate::synthesis::{fit, FitOptions, Method};
use anyhow::{Context, Result};
use ndarray::{s, Array3, ArrayView3};
use num_complex::Complex64;
use polars::prelude::DataFrame;
use serde_json::json;
use std::path::Path;
use std::time::Instant;

impl JobKind for Job {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        if self.method.is_some() {
            "synthesis"
        } else {
            "analysis"
        }
    }

    fn identity(&self) -> std::borrow::Cow<'_, str> {
        Job::identity(self).into()
    }

    fn seed(&self) -> Option<u64> {
        Some(self.seed)
    }

    fn inputs(&self) -> Inputs {
        Inputs::Dataset {
            data_seed: self.data_seed,
            shared: self.dataset.worth_sharing(),
        }
    }

    fn estimate(&self, plan: &Plan) -> crate::run::estimate::Estimate {
        crate::run::estimate::dataset_job(plan, self)
    }

    fn key_material(&self, plan: &Plan) -> String {
        // The job in full (dataset with any maps read from files, analysis, synthesis, seeds)
        // and the plan-wide settings its rows read.
        format!(
            "{self:?}\nmetrics={:?}\nhypotheses={}\noutputs={:?}\nparam_keys={:?}",
            plan.metrics,
            plan.spec.hypotheses.is_some(),
            plan.spec.outputs,
            plan.param_keys
        )
    }

    fn input_files(&self) -> Vec<std::path::PathBuf> {
        self.dataset.input_files()
    }

    fn materialise(&self) -> Result<Materialised> {
        self.dataset
            .materialise(self.data_seed)
            .with_context(|| format!("dataset {}", self.dataset_id))
    }

    fn run(&self, cx: &JobContext) -> Result<Rows> {
        let plan = cx.plan;
        let result = match (self.method, &self.synthesis) {
            (Some(method), Some(syn)) => {
                run_synthesis_job(plan, self, method, syn, cx.out, cx.shared)?
            }
            _ => run_job(plan, self, cx.out, cx.shared)?,
        };
        let mut files = result.files.clone();
        if plan.spec.outputs.npy_maps {
            let dir = cx.out.join("maps").join(&self.id);
            crate::run::result::write_job_maps(&dir, &result)?;
            files.push(dir);
        }
        let mut tables = tables::fragments(plan, self, &result)?;
        if plan.spec.hypotheses.is_some() {
            if let Some(stats) = super::hypotheses::plant_stats(self, &result)? {
                tables.push((super::hypotheses::PLANT_STATS, stats));
            }
        }
        Ok(Rows {
            tables,
            files,
            timing: Some(timing(&result)),
        })
    }

    fn status_row(&self, plan: &Plan, status: &Status) -> Option<Result<DataFrame>> {
        Some(tables::status_rows(
            plan,
            &[(self, status.error, status.elapsed_s)],
        ))
    }

    fn manifest(&self) -> serde_json::Value {
        json!({
            "dataset": self.dataset_id,
            "method": self.method.map(Method::as_str),
            "generation_seed": self.generation_seed,
            "noise_floor": self.noise_floor,
            "data_seed": self.data_seed,
            "params": self.params,
        })
    }
}

/// The timings of a job for the manifest.
fn timing(r: &JobResult) -> serde_json::Value {
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
}

/// Largest image (pixels) for which exact expected maps of spatially varying filters are
/// computed; above it `expected_correlation` is null (the pair sums grow as `4^L` per pixel).
pub const MAX_EXACT_PIXELS: usize = 256 * 256;

/// The job's data: the group's shared copy, or its own.
fn data_of<'a>(
    job: &Job,
    shared: Option<&'a Materialised>,
    owned: &'a mut Option<Materialised>,
) -> Result<&'a Materialised> {
    if let Some(d) = shared {
        return Ok(d);
    }
    let d = job
        .dataset
        .materialise(job.data_seed)
        .with_context(|| format!("dataset {}", job.dataset_id))?;
    Ok(owned.insert(d))
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
        .then(|| data.stack.try_to_complex128(data.hwn))
        .transpose()?;
    let similarity = match (job.noise_floor, &original) {
        (Some(nf), Some(original)) => Some(
            noise_floor(plan, job, nf, data, original, &analysis)
                .with_context(|| format!("noise floor ({})", nf.as_str()))?,
        ),
        _ => None,
    };
    let mut files = vec![];
    if let Some(k) = &data.kspace {
        let dir = out.join("kspace");
        let k64 = k
            .data
            .mapv(|z| num_complex::Complex::new(z.re as f32, z.im as f32));
        let path = |suffix: &str| dir.join(format!("{}{suffix}.npy", job.id));
        files = vec![path(""), path(".freqs"), path(".azimuths_deg")];
        write_npy(&files[0], &k64)?;
        write_npy(&files[1], &ndarray::Array1::from(k.freqs.clone()))?;
        write_npy(&files[2], &ndarray::Array1::from(k.azimuths_deg.clone()))?;
    }
    if let (Some(m), true) = (&data.mean_kspace, plan.spec.outputs.npy_maps) {
        // The mean k-space image (Fig. 48): rows frequency, columns azimuth.
        let path = out.join("kspace").join(format!("{}.mean.npy", job.id));
        write_npy(&path, m)?;
        files.push(path);
    }
    let correlating = plan
        .spec
        .hypotheses
        .as_ref()
        .zip(original.as_ref())
        .map(|(hs, stack)| {
            crate::apps::hypotheses::correlating_function(stack.view(), hs.max_offset)
        });
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
        files,
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
            Some(crate::stats::analysis::analyse(x, levels)?)
        } else {
            None
        })
    };
    let comparison = match nf {
        NoiseFloorPlan::Draws { samples, seed } => {
            let draw = job
                .dataset
                .redraw(samples, seed, data)
                .ok_or_else(|| anyhow::anyhow!("draws need a synthetic or simulated dataset"))??;
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
    .then(|| data.stack.try_to_complex128(data.hwn))
    .transpose()?;
    let opts = FitOptions {
        half_width: syn.half_width,
        levels,
        negative_signs: syn.negative_signs,
    };
    let model = fit(method, &original, stack.as_ref().map(|s| s.view()), opts)
        .with_context(|| format!("fitting {}", method.as_str()))?;
    let fit_s = t.elapsed().as_secs_f64();
    let source = format!("job {} (dataset {})", job.id, job.dataset_id);
    let info = crate::io::model::ModelInfo::new(&model, &original, syn.half_width, levels, source);
    let mut files = vec![out.join("models").join(&job.id)];
    crate::io::model::save(&model, &info, &files[0])?;
    let t = Instant::now();
    let generated = model.try_generate_c64(job.generation_seed, 0, syn.samples)?;
    let generate_s = t.elapsed().as_secs_f64();
    if syn.save_samples {
        let path = out.join("samples").join(format!("{}.npy", job.id));
        write_npy(&path, &generated)?;
        files.push(path);
    }
    let t = Instant::now();
    let analysis = if syn.analyse_generated {
        Some(
            crate::stats::analysis::analyse(generated.view(), job.analysis.levels)
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
        files,
    })
}
