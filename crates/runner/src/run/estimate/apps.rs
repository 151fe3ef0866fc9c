//! The estimates of the jobs of the run as a whole: the calibration (its frequency points and
//! the Mie series of its sphere), the hypothesis tests (the correlating functions they read)
//! and the CNN trainings (their datasets as materialised, the models fitted to them, the
//! training, validation and test sets, a mini-batch's activations, and the epochs).

use super::dataset::{dataset_at, generate_flops, model};
use super::{Estimate, Sizes};
use crate::apps::cnn::classification::{held_out, Source};
use crate::apps::cnn::net::NetConfig;
use crate::apps::cnn::train::{Device, TrainingOptions};
use crate::experiment::datasets::{chain_sizes, mie, C128, C64, USUAL_SAMPLES};
use crate::experiment::DataRef;
use crate::physics::calibration::ChainParams;
use crate::run::jobs::cnn::{ClassificationJob, LocationJob};
use crate::run::plan::Plan;
use crate::synthesis::Method;

/// The estimate of the `calibration` section's job: about 256 bytes a frequency point (the
/// grid, the four measurements, the gated differences, the rows and the FFTs' buffers), three
/// Mie series of the sphere, the chamber clutter of four measurements and the time gates'
/// FFTs.
pub fn calibration(chain: &ChainParams) -> Estimate {
    let n = chain.points as f64;
    let (mie_bytes, mie_flops) = mie(chain, 3.0);
    let clutter = chain.clutter.len() as f64;
    let mut sizes = Sizes::default();
    chain_sizes("calibration", chain, &mut sizes);
    Estimate::new(
        Estimate::SMALL.bytes as f64 + 256.0 * n + mie_bytes,
        Estimate::SMALL.flops
            + mie_flops
            + 4.0 * n * (30.0 * clutter + 60.0)
            + 40.0 * n * n.max(2.0).log2(),
    )
    .blaming(&sizes)
}

/// The estimate of the hypotheses job over `inputs` plant datasets: each one's correlating
/// function (`(2 max_offset + 1)^2` cells) read back from its rows.
pub fn hypotheses(plan: &Plan, inputs: usize) -> Estimate {
    let Some(hs) = &plan.spec.hypotheses else {
        return Estimate::SMALL;
    };
    let r = hs.max_offset as f64;
    let mut sizes = Sizes::default();
    sizes.add("hypotheses.max_offset", hs.max_offset, r / 4.0);
    let cells = inputs as f64 * (2.0 * r + 1.0).powi(2);
    Estimate::new(
        Estimate::SMALL.bytes as f64 + 48.0 * cells,
        Estimate::SMALL.flops + 10.0 * cells,
    )
    .blaming(&sizes)
}

/// Bytes and work of one training on `train_n` samples with `other_n` more kept (validation
/// and test): the sets as complex64 and prepared float32 (the training set twice, as composed
/// and as shuffled batches), a mini-batch's activations with their gradients, and `6 x` the
/// forward multiply-adds per trained sample and epoch.
fn training(net: &NetConfig, t: &TrainingOptions, train_n: f64, other_n: f64) -> (f64, f64) {
    let pixels = net.height as f64 * net.width as f64;
    let prepared = net.prepared_len() as f64 * 4.0;
    let sets = (2.0 * train_n + other_n) * (pixels * C64 + prepared);
    let f = net.arch.filters().map(|x| x as f64);
    let batch = (t.batch_size as f64).min(train_n).max(1.0);
    let activations = batch * pixels * f[0] * 8.0;
    let macs = pixels / 4.0 * f[0] * 2.0 * 64.0
        + pixels / 64.0 * f[1] * f[0] * 16.0
        + pixels / 1024.0 * f[2] * f[1] * 4.0;
    // A GPU trains about 30 times faster than the reference core.
    let device = match t.device {
        Device::Cpu => 1.0,
        Device::Cuda => 1.0 / 30.0,
    };
    (
        sets + activations + (64u64 << 20) as f64,
        6.0 * macs * train_n * t.epochs as f64 * device,
    )
}

/// Records a training block's sizes at `at` (`classification.training`).
fn training_sizes(at: &str, t: &TrainingOptions, train_n: f64, s: &mut Sizes) {
    s.add(format!("{at}.epochs"), t.epochs, t.epochs as f64 / 30.0);
    let batch = t.batch_size as f64;
    s.add(
        format!("{at}.batch_size"),
        t.batch_size,
        batch.min(train_n) / 128.0,
    );
}

/// What a training's datasets cost: the largest materialisation's peak, every stack as
/// complex128 twice (the stacks, then their concatenation), the work, and the samples of each.
struct Stacks {
    bytes: f64,
    flops: f64,
    samples: Vec<f64>,
}

/// Materialising and concatenating `data`, recording their sizes.
fn stacks(plan: &Plan, data_refs: &[DataRef], s: &mut Sizes) -> Stacks {
    let (mut peak, mut flops, mut all) = (0.0f64, 0.0, 0.0);
    let mut samples = vec![];
    for d in data_refs {
        d.dataset.sizes(&dataset_at(plan, &d.id), s);
        let (n, h, w) = d.dataset.shape();
        let m = d.dataset.cost();
        peak = peak.max(m.peak);
        flops += m.flops;
        all += n as f64 * h as f64 * w as f64;
        samples.push(n as f64);
    }
    Stacks {
        bytes: peak + 2.0 * C128 * all,
        flops,
        samples,
    }
}

/// Records the fit settings of a section at `at` when `method` reads them.
fn fit_sizes(at: &str, method: Method, half_width: usize, s: &mut Sizes) {
    if matches!(method, Method::Method1 | Method::Method2) {
        s.add(
            format!("{at}.half_width"),
            half_width,
            half_width as f64 / 8.0,
        );
    }
}

/// The estimate of one classification training of `plan`.
pub fn classification(plan: &Plan, job: &ClassificationJob) -> Estimate {
    let Some(cp) = &plan.classification else {
        return Estimate::SMALL;
    };
    let spec = &cp.spec;
    let mut sizes = Sizes::default();
    let stacks = stacks(plan, &job.classes, &mut sizes);
    let pixels = cp.net.height as f64 * cp.net.width as f64;
    let originals: f64 = stacks.samples.iter().sum();
    let size = job.train_size as f64;
    if let Some(i) = spec.train_sizes.iter().position(|&n| n == job.train_size) {
        let at = format!("classification.train_sizes[{i}]");
        sizes.add(at, job.train_size, size / USUAL_SAMPLES);
    }
    // Per class, one after the other: its normalised split, its model and its generated part.
    let k = cp.classes.len().max(1) as f64;
    let (mut per_class, mut fit_flops) = (0.0f64, 0.0);
    for &n in &stacks.samples {
        let fit = n - held_out(n as usize, spec.holdout) as f64;
        let (model_bytes, flops) = match job.source {
            Source::Original => (0.0, 0.0),
            Source::Generated(m) => {
                let (b, f) = model(m, fit, pixels, spec.half_width as f64);
                let generated = (size / k).ceil();
                let g = generate_flops(m, fit, generated, pixels, spec.half_width as f64);
                (b + C64 * generated * pixels, f + g)
            }
        };
        per_class = per_class.max(C128 * n * pixels + model_bytes);
        fit_flops += flops;
    }
    if let Source::Generated(m) = job.source {
        fit_sizes("classification", m, spec.half_width, &mut sizes);
    }
    // `original` trains on the fit originals at most.
    let train_n = match job.source {
        Source::Original => size.min(originals),
        Source::Generated(_) => size,
    };
    training_sizes(
        "classification.training",
        &spec.training,
        train_n,
        &mut sizes,
    );
    let (bytes, flops) = training(&cp.net, &spec.training, train_n, originals);
    Estimate::new(
        stacks.bytes + per_class + bytes,
        stacks.flops + fit_flops + flops,
    )
    .blaming(&sizes)
}

/// The estimate of one location training of `plan`.
pub fn location(plan: &Plan, job: &LocationJob) -> Estimate {
    let Some(lp) = &plan.location else {
        return Estimate::SMALL;
    };
    let spec = &lp.spec;
    let mut sizes = Sizes::default();
    let stacks = stacks(plan, &job.clutter, &mut sizes);
    let pixels = lp.net.height as f64 * lp.net.width as f64;
    let n: f64 = stacks.samples.iter().sum();
    let fit = spec.fit_samples as f64;
    sizes.add("location.fit_samples", spec.fit_samples, fit / 100.0);
    let (train_n, model_bytes, fit_flops) = match job.source {
        Source::Original => (fit / 2.0, 0.0, 0.0),
        Source::Generated(m) => {
            let g = spec.generated_samples as f64;
            sizes.add(
                "location.generated_samples",
                spec.generated_samples,
                g / 5000.0,
            );
            fit_sizes("location", m, spec.half_width, &mut sizes);
            let (b, f) = model(m, fit, pixels, spec.half_width as f64);
            let generate = generate_flops(m, fit, g, pixels, spec.half_width as f64);
            (g / 2.0, b + C64 * g * pixels, f + generate)
        }
    };
    training_sizes("location.training", &spec.training, train_n, &mut sizes);
    // The fit and test clutter as complex128 selections, the training sets with targets.
    let (bytes, flops) = training(&lp.net, &spec.training, train_n, n);
    Estimate::new(
        stacks.bytes + C128 * n * pixels + model_bytes + bytes,
        stacks.flops + fit_flops + flops,
    )
    .blaming(&sizes)
}
