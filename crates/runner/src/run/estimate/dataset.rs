//! The model of a dataset job (analysis or synthesis): its dataset as materialised, the
//! analysis, the synthesis model and its samples, the metrics, the noise floor, the filter's lag
//! rows and the hypotheses' correlating function (the terms of [`super`]'s model), and the
//! sizes of the spec these terms read, each with its usual value, for the blame.

use super::{Estimate, Sizes};
use crate::experiment::datasets::{C128, C64, USUAL_HALF_WIDTH, USUAL_SAMPLES};
use crate::run::plan::{Job, NoiseFloorPlan, Plan};
use crate::stats::cmd::{choose_forms, Form};
use crate::stats::metrics::{KlOptions, Metric};
use crate::synthesis::CostSize;

/// KL histogram bands counted in flight at once (one per worker thread of a large machine).
const KL_BANDS: f64 = 16.0;

/// The estimate of a dataset job (analysis or synthesis) of `plan`.
pub fn dataset_job(plan: &Plan, job: &Job) -> Estimate {
    let (n, h, w) = job.dataset.shape();
    let (n, p) = (n as f64, h as f64 * w as f64);
    let mut sizes = Sizes::default();
    job.dataset
        .sizes(&dataset_at(plan, &job.dataset_id), &mut sizes);
    let data = job.dataset.cost();
    let maps = 96.0 * p;
    let analysis_flops = 20.0 * n * p;
    let copy = C128 * n * p + data.widen;
    let (bytes, flops) = match (job.method, &job.synthesis) {
        (Some(method), Some(syn)) => {
            let m = syn.samples as f64;
            let k = syn.half_width as f64;
            sizes.add("synthesis.samples", syn.samples, m / USUAL_SAMPLES);
            if method.needs().half_width {
                sizes.add("synthesis.half_width", syn.half_width, k / USUAL_HALF_WIDTH);
            }
            metric_sizes(plan, &mut sizes);
            let needs_copy = method.needs().stack || !plan.metrics.is_empty();
            let cost = method.cost(&CostSize {
                fitted: n,
                generated: m,
                pixels: p,
                half_width: k,
            });
            let generated = C64 * m * p;
            let (cmp, cmp_flops) = compare(&plan.metrics, n, m, h, w);
            let bytes = data.kept
                + maps * 2.0
                + if needs_copy { copy } else { 0.0 }
                + cost.model_bytes
                + generated
                + cmp;
            let flops = data.flops
                + analysis_flops * 2.0
                + cost.fit_flops
                + cost.generate_flops
                + cmp_flops;
            (bytes.max(data.peak), flops)
        }
        _ => {
            let original = job.noise_floor.is_some() || plan.spec.hypotheses.is_some();
            let (floor, floor_flops) = noise_floor(plan, job, n, h, w, &mut sizes);
            let (lags, lags_flops) = filter_lags(plan, job, &mut sizes);
            let (corr, corr_flops) = correlating(plan, n, h, w, &mut sizes);
            let bytes = data.kept
                + maps
                + if original { copy } else { 0.0 }
                + floor.max(data.saved_kspace)
                + lags
                + corr;
            (
                bytes.max(data.peak),
                data.flops + analysis_flops + floor_flops + lags_flops + corr_flops,
            )
        }
    };
    Estimate::new(bytes, flops).blaming(&sizes)
}

/// YAML path of the dataset `id` (`datasets[i]`; `datasets` when the spec lacks it).
pub fn dataset_at(plan: &Plan, id: &str) -> String {
    match plan.spec.datasets.iter().position(|d| d.id == id) {
        Some(i) => format!("datasets[{i}]"),
        None => "datasets".into(),
    }
}

/// Records the bins of the KL metrics (`metrics[j].kl_pixel.bins`).
fn metric_sizes(plan: &Plan, s: &mut Sizes) {
    let usual = KlOptions::default().bins as f64;
    for (j, m) in plan.metrics.iter().enumerate() {
        let (name, bins) = match *m {
            Metric::KlPixel(o) | Metric::KlArea(o, _) => (m.name(), o.bins),
            Metric::Cmd | Metric::MultiscaleRmse => continue,
        };
        s.add(
            format!("metrics[{j}].{name}.bins"),
            bins,
            bins as f64 / usual,
        );
    }
}

/// Bytes and work of the rows of `filter_correlation` (two directions, lags `0..=L`) that the
/// analysis of uniform filtered noise writes.
fn filter_lags(plan: &Plan, job: &Job, s: &mut Sizes) -> (f64, f64) {
    let Some(half_width) = job.dataset.known_filter() else {
        return (0.0, 0.0);
    };
    let k = half_width as f64;
    let lags = match plan.spec.outputs.filter_lags {
        Some(l) => {
            s.add("outputs.filter_lags", l, l as f64 / k.max(USUAL_HALF_WIDTH));
            l as f64
        }
        None => k,
    };
    let rows = 2.0 * (lags + 1.0);
    (200.0 * rows, rows * 8.0 * (2.0 * k + 1.0))
}

/// Bytes and work of the hypotheses' mean correlating function of an analysis job:
/// `(2 R + 1)^2` offsets, each a pass over the pixels (pairs inside the image: a sum over the
/// samples).
fn correlating(plan: &Plan, n: f64, h: usize, w: usize, s: &mut Sizes) -> (f64, f64) {
    let Some(hs) = &plan.spec.hypotheses else {
        return (0.0, 0.0);
    };
    let r = hs.max_offset as f64;
    s.add("hypotheses.max_offset", hs.max_offset, r / 4.0);
    let cells = (2.0 * r + 1.0).powi(2);
    let (h, w) = (h as f64, w as f64);
    let inside = cells.min((2.0 * h - 1.0) * (2.0 * w - 1.0));
    (
        100.0 * cells,
        cells * h * w * 3.0 + inside * h * w * 8.0 * n,
    )
}

/// Bytes and work of comparing `n1` with `n2` samples of `h x w` under `metrics`.
fn compare(metrics: &[Metric], n1: f64, n2: f64, h: usize, w: usize) -> (f64, f64) {
    let p = h as f64 * w as f64;
    let (mut bytes, mut flops) = (0.0f64, 0.0);
    for m in metrics {
        let (b, f) = match *m {
            Metric::KlPixel(o) => kl(o.bins, 1, n1 + n2, h, w),
            Metric::KlArea(o, block) => kl(o.bins, block, n1 + n2, h, w),
            // The normalised stacks (f32 pairs) and their V-side packings.
            Metric::Cmd => (2.0 * C64 * (n1 + n2) * p, cmd_flops(n1, n2, p)),
            Metric::MultiscaleRmse => (0.0, 10.0 * p),
        };
        // Metrics run one after the other: the largest is the peak.
        bytes = bytes.max(b);
        flops += f;
    }
    (bytes, flops)
}

/// Bytes (histograms of the bands in flight, and the maps) and work of a KL metric.
fn kl(bins: usize, block: usize, samples: f64, h: usize, w: usize) -> (f64, f64) {
    let block = block.max(1) as f64;
    let (rows, units) = ((h as f64 / block).floor(), (w as f64 / block).floor());
    let band = 2.0 * 4.0 * 2.0 * units * bins as f64;
    (
        band * rows.min(KL_BANDS) + 16.0 * rows * units,
        12.0 * samples * h as f64 * w as f64,
    )
}

/// Work of the CMD with the forms [`choose_forms`] picks (8 operations per complex
/// multiply-add).
fn cmd_flops(n1: f64, n2: f64, p: f64) -> f64 {
    let forms = choose_forms(n1 as usize, n2 as usize, p as usize);
    let norm = |n: f64, f: Form| match f {
        Form::Gram => n * n * p / 2.0,
        Form::Full => p * p * n / 2.0,
    };
    let cross = match forms[2] {
        Form::Gram => n1 * n2 * p,
        Form::Full => 0.0,
    };
    8.0 * (norm(n1, forms[0]) + norm(n2, forms[1]) + cross)
}

/// Bytes and work of an analysis job's noise floor (beyond the original's copy).
fn noise_floor(plan: &Plan, job: &Job, n: f64, h: usize, w: usize, s: &mut Sizes) -> (f64, f64) {
    let p = h as f64 * w as f64;
    match job.noise_floor {
        None => (0.0, 0.0),
        Some(NoiseFloorPlan::Halves) => {
            metric_sizes(plan, s);
            let half = (n / 2.0).floor();
            let (b, f) = compare(&plan.metrics, half, half, h, w);
            (b + 192.0 * p, f + 20.0 * n * p)
        }
        Some(NoiseFloorPlan::Draws { samples, .. }) => {
            let m = samples as f64;
            s.add("synthesis.samples", samples, m / USUAL_SAMPLES);
            metric_sizes(plan, s);
            let draw = job.dataset.redraw_cost(samples);
            let (b, f) = compare(&plan.metrics, n, m, h, w);
            (
                draw.peak.max(draw.kept + 96.0 * p + b),
                draw.flops + 20.0 * m * p + f,
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cmd_work_follows_the_cheaper_form() {
        // 100 samples of 4096 pixels: Gram norms (N^2 P / 2 each) and the Gram cross term.
        let (n, p) = (100.0, 4096.0);
        assert_eq!(
            cmd_flops(n, n, p),
            8.0 * (n * n * p / 2.0 * 2.0 + n * n * p)
        );
        // 10^5 samples of 16 pixels: the joint Full form, P^2 (N1 + N2) / 2.
        let (n, p) = (1e5, 16.0);
        assert_eq!(cmd_flops(n, n, p), 8.0 * p * p * n);
    }
}
