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
use crate::seeds::derive_seed;
use crate::stats::analysis::{Analysis, Direction, Sample};
use crate::stats::filters::{expected_maps, expected_maps_are_cheap, lag_correlation};
use crate::stats::metrics::{Metric, Parts};
use crate::stats::similarity::{compare, Comparison, Side};
use crate::synthesis::{fit, FitOptions, Method};
use anyhow::{Context, Result};
use ndarray::{s, Array3, ArrayView3, Axis};
use num_complex::Complex64;
use polars::prelude::DataFrame;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
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
        crate::run::estimate::dataset::dataset_job(plan, self)
    }

    fn key_material(&self, plan: &Plan) -> String {
        // The job in full (dataset with any maps read from files, analysis, synthesis, seeds)
        // and the plan-wide settings its rows read; `held_out` only when set (an analysis job
        // measures the held-out floor then), so that the keys of plans without it stay as they
        // were.
        let held_out = if held_out_wanted(plan) {
            "\nheld_out"
        } else {
            ""
        };
        format!(
            "{self:?}\nmetrics={:?}\nhypotheses={}\noutputs={:?}\nparam_keys={:?}{held_out}",
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
            let dir = crate::io::results::files::maps(cx.out, &self.id);
            crate::run::result::write_job_maps(&dir, &result)?;
            files.push(dir);
        }
        if plan.spec.outputs.zarr_maps {
            // Not among the job's files: the merge packs it into maps.zarr.
            let staged = crate::io::results::files::staged_maps(cx.out, &self.id);
            crate::run::result::stage_job_maps(&staged, &result)?;
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
        let mut entry = json!({
            "dataset": self.dataset_id,
            "method": self.method.map(Method::as_str),
            "generation_seed": self.generation_seed,
            "noise_floor": self.noise_floor,
            "data_seed": self.data_seed,
            "params": self.params,
        });
        // What the kind tells of its files (a GeoTIFF's georeferencing), where it tells any.
        if let Some(files) = self.dataset.metadata() {
            entry["dataset_files"] = files;
        }
        entry
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
    let held_out = held_out_wanted(plan);
    let original = (job.noise_floor.is_some() || plan.spec.hypotheses.is_some() || held_out)
        .then(|| data.stack.try_to_complex128(data.hwn))
        .transpose()?;
    let similarity = match (job.noise_floor, &original) {
        (Some(nf), Some(original)) => Some(
            noise_floor(plan, job, nf, data, original, &analysis)
                .with_context(|| format!("noise floor ({})", nf.as_str()))?,
        ),
        _ => None,
    };
    let held_out = match (held_out, &original) {
        (true, Some(original)) => {
            Some(held_out_floor(plan, job, original).context("held-out floor (halves)")?)
        }
        _ => None,
    };
    let mut files = vec![];
    if let Some(k) = &data.kspace {
        let k64 = k
            .data
            .mapv(|z| num_complex::Complex::new(z.re as f32, z.im as f32));
        let path = |suffix: &str| crate::io::results::files::kspace(out, &job.id, suffix);
        files = vec![path(""), path(".freqs"), path(".azimuths_deg")];
        write_npy(&files[0], &k64)?;
        write_npy(&files[1], &ndarray::Array1::from(k.freqs.clone()))?;
        write_npy(&files[2], &ndarray::Array1::from(k.azimuths_deg.clone()))?;
    }
    if let (Some(m), true) = (&data.mean_kspace, plan.spec.outputs.npy_maps) {
        // The mean k-space image (Fig. 48): rows frequency, columns azimuth.
        let path =
            crate::io::results::files::kspace(out, &job.id, crate::io::results::files::KSPACE_MEAN);
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
        held_out,
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
    let analyse = |x: ArrayView3<Complex64>| analysed_for(plan, x, levels);
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
            compare_stacks(plan, levels, first, second)?
        }
    };
    Ok(SimilarityOutcome {
        compared: crate::io::results::value::NOISE_FLOOR,
        noise_floor: Some(nf.as_str()),
        comparison,
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// The analysis `compare` needs of `x` (the multiscale RMSE reads one; other metrics none).
fn analysed_for<T: Sample>(
    plan: &Plan,
    x: ArrayView3<T>,
    levels: usize,
) -> Result<Option<Analysis>> {
    Ok(if plan.metrics.contains(&Metric::MultiscaleRmse) {
        Some(crate::stats::analysis::analyse(x, levels)?)
    } else {
        None
    })
}

/// The plan's metrics between stacks `a` (the reference) and `b`, each analysed to `levels`
/// where a metric needs it.
fn compare_stacks<A: Sample + Parts, B: Sample + Parts>(
    plan: &Plan,
    levels: usize,
    a: ArrayView3<A>,
    b: ArrayView3<B>,
) -> Result<Comparison> {
    let (aa, ba) = (
        analysed_for(plan, a, levels)?,
        analysed_for(plan, b, levels)?,
    );
    let a = Side {
        stack: a,
        analysis: aa.as_ref(),
    };
    let b = Side {
        stack: b,
        analysis: ba.as_ref(),
    };
    Ok(compare(a, b, &plan.metrics))
}

/// Whether the plan compares with held-out originals (`synthesis.held_out` with metrics).
fn held_out_wanted(plan: &Plan) -> bool {
    plan.spec.synthesis.as_ref().is_some_and(|s| s.held_out) && !plan.metrics.is_empty()
}

/// The seeded split of `n` originals for `synthesis.held_out`: a half to fit on and another
/// half, as large and disjoint, that no fit sees (one sample of an odd `n` in neither), each in
/// index order. Seeded by the job's data seed, so every method of a dataset and its floor split
/// alike.
pub fn held_out_split(data_seed: u64, n: usize) -> (Vec<usize>, Vec<usize>) {
    let mut p: Vec<usize> = (0..n).collect();
    p.shuffle(&mut ChaCha20Rng::seed_from_u64(derive_seed(
        data_seed, "held_out", "",
    )));
    let half = n / 2;
    let (mut fit, mut held) = (p[..half].to_vec(), p[half..2 * half].to_vec());
    fit.sort_unstable();
    held.sort_unstable();
    (fit, held)
}

/// The two halves of [`held_out_split`] of `stack`'s samples: (fit half, held-out half).
fn held_out_halves(
    data_seed: u64,
    stack: &Array3<Complex64>,
) -> (Array3<Complex64>, Array3<Complex64>) {
    let (fit, held) = held_out_split(data_seed, stack.dim().0);
    (stack.select(Axis(0), &fit), stack.select(Axis(0), &held))
}

/// The floor of the held-out comparisons: the metrics between the two halves of
/// [`held_out_split`] (`noise_floor` = `halves`, `reference` = `held_out`).
fn held_out_floor(
    plan: &Plan,
    job: &Job,
    original: &Array3<Complex64>,
) -> Result<SimilarityOutcome> {
    let t = Instant::now();
    let (fit, held) = held_out_halves(job.data_seed, original);
    let comparison = compare_stacks(plan, job.analysis.levels, held.view(), fit.view())?;
    Ok(SimilarityOutcome {
        compared: crate::io::results::value::NOISE_FLOOR,
        noise_floor: Some("halves"),
        comparison,
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// `method` fitted on the fit half of [`held_out_split`] (analysed to `levels`), its samples
/// (the job's generation seed, as many as in sample) against the held-out half.
fn held_out_similarity(
    plan: &Plan,
    job: &Job,
    method: Method,
    samples: usize,
    opts: FitOptions,
    stack: &Array3<Complex64>,
) -> Result<SimilarityOutcome> {
    let t = Instant::now();
    let (fit_part, held) = held_out_halves(job.data_seed, stack);
    let analysis = crate::stats::analysis::analyse(fit_part.view(), opts.levels)
        .context("analysing the fit half")?;
    let model = fit(method, &analysis, Some(fit_part.view()), opts)
        .with_context(|| format!("fitting {} on the fit half", method.as_str()))?;
    let generated = model.try_generate_c64(job.generation_seed, 0, samples)?;
    let comparison = compare_stacks(plan, job.analysis.levels, held.view(), generated.view())?;
    Ok(SimilarityOutcome {
        compared: method.as_str(),
        noise_floor: None,
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
    let levels = method.needs().depth(syn.dyadic_levels(&job.analysis));
    let analysed = match plan.metrics.contains(&Metric::MultiscaleRmse) {
        true => levels.max(job.analysis.levels),
        false => levels,
    };
    let original = data
        .stack
        .analyse(data.hwn, analysed)
        .with_context(|| format!("analysing dataset {}", job.dataset_id))?;
    let t = Instant::now();
    let stack = (method.needs().stack || !plan.metrics.is_empty())
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
    let mut files = vec![crate::io::results::files::model(out, &job.id)];
    crate::io::model::save(&model, &info, &files[0])?;
    let t = Instant::now();
    let generated = model.try_generate_c64(job.generation_seed, 0, syn.samples)?;
    let generate_s = t.elapsed().as_secs_f64();
    if syn.save_samples {
        let path = crate::io::results::files::samples(out, &job.id);
        write_npy(&path, &generated)?;
        files.push(path);
    }
    let t = Instant::now();
    let analysis = (syn.analyse_generated)
        .then(|| crate::stats::analysis::analyse(generated.view(), job.analysis.levels))
        .transpose()
        .context("analysing the generated samples")?;
    let analysis_s = t.elapsed().as_secs_f64();
    let stack = stack.filter(|_| !plan.metrics.is_empty());
    let similarity = stack.as_ref().map(|stack| {
        let t = Instant::now();
        let original = Side {
            stack: stack.view(),
            analysis: Some(&original),
        };
        let generated = Side {
            stack: generated.view(),
            analysis: analysis.as_ref(),
        };
        SimilarityOutcome {
            compared: method.as_str(),
            noise_floor: None,
            comparison: compare(original, generated, &plan.metrics),
            seconds: t.elapsed().as_secs_f64(),
        }
    });
    let held_out = (stack.as_ref())
        .filter(|_| held_out_wanted(plan))
        .map(|stack| held_out_similarity(plan, job, method, syn.samples, opts, stack))
        .transpose()
        .context("held-out comparison")?;
    let (_, h, w) = job.dataset.shape();
    Ok(JobResult {
        source: method.as_str(),
        analysis,
        synthesis: Some(SynthesisOutcome {
            filter: model.filter().cloned(),
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
        held_out,
        correlating: None,
        files,
    })
}

#[cfg(test)]
mod tests {
    use super::held_out_split;

    /// The two halves are disjoint, equally large, sorted, and the same for the same seed;
    /// another seed splits otherwise.
    #[test]
    fn held_out_halves_are_disjoint_and_seeded() {
        let (fit, held) = held_out_split(7, 101);
        assert_eq!((fit.len(), held.len()), (50, 50));
        assert!(fit.windows(2).all(|w| w[0] < w[1]) && held.windows(2).all(|w| w[0] < w[1]));
        assert!(fit.iter().all(|i| !held.contains(i) && *i < 101));
        assert_eq!(held_out_split(7, 101), (fit.clone(), held));
        assert_ne!(held_out_split(8, 101).0, fit);
    }
}
