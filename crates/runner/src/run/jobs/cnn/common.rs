//! What the CNN training jobs share: the names of their tables, the materialisation of their
//! datasets, their seeds, and the rows every training leaves (its status, its per-epoch record
//! and its confusion matrix).

use crate::apps::cnn::net::NetConfig;
use crate::apps::cnn::train::Trained;
use crate::apps::cnn::train::{Device, TrainingOptions};
use crate::experiment::datasets::{C128, C64};
use crate::experiment::DataRef;
use crate::experiment::Materialised;
use crate::io::npy::Stack;
use crate::io::results::{self, col};
use crate::run::estimate::dataset::dataset_at;
use crate::run::estimate::Sizes;
use crate::run::jobs::Status;
use crate::run::plan::Plan;
use crate::seeds::derive_seed;
use crate::synthesis::Method;
use anyhow::{Context, Result};
use ndarray::{Array3, Axis};
use num_complex::Complex64;
use polars::prelude::*;

/// Table of classification trainings.
pub const CLASSIFICATION: &str = results::CLASSIFICATION.name;
/// Table of location trainings.
pub const LOCATION: &str = results::LOCATION.name;
/// Table of the location summary.
pub const LOCATION_SUMMARY: &str = results::LOCATION_SUMMARY.name;
/// Per-epoch records of every training.
pub const HISTORY: &str = results::TRAINING_HISTORY.name;
/// Confusion matrices of every training (test set).
pub const CONFUSION: &str = results::CONFUSION.name;

/// The stacks of several datasets concatenated along the sample axis (as complex128), with
/// their sample counts.
pub(super) fn materialise_all(data: &[DataRef]) -> Result<Materialised> {
    let mut planes: Vec<Array3<Complex64>> = vec![];
    for d in data {
        let m = d
            .dataset
            .materialise(d.data_seed)
            .with_context(|| format!("dataset {}", d.id))?;
        planes.push(m.stack.try_to_complex128(m.hwn)?);
    }
    let views: Vec<_> = planes.iter().map(|p| p.view()).collect();
    let all = ndarray::concatenate(Axis(0), &views).context("stacks of one image size")?;
    Ok(Materialised {
        stack: Stack::Generated(all),
        hwn: false,
        truth: None,
        kspace: None,
        mean_kspace: None,
    })
}

/// The group key of jobs reading `data`: a hash of their data seeds.
pub(super) fn group_seed(domain: &str, data: &[DataRef]) -> u64 {
    let ids: Vec<String> = data.iter().map(|d| format!("{}", d.data_seed)).collect();
    derive_seed(0, domain, &ids.join(","))
}

/// The concatenated stacks of a job (shared by the scheduler, or made here).
pub(super) fn stacks_of<'a>(
    shared: Option<&'a Materialised>,
    data: &[DataRef],
    owned: &'a mut Option<Array3<Complex64>>,
) -> Result<std::borrow::Cow<'a, Array3<Complex64>>> {
    if let Some(Materialised {
        stack: Stack::Generated(a),
        ..
    }) = shared
    {
        return Ok(std::borrow::Cow::Borrowed(a));
    }
    let m = materialise_all(data)?;
    let Stack::Generated(a) = m.stack else {
        unreachable!("materialise_all makes a generated stack")
    };
    *owned = Some(a);
    Ok(std::borrow::Cow::Borrowed(
        owned.as_ref().expect("just set"),
    ))
}

/// The fragments every training leaves besides its own table: its epochs and its confusion
/// matrix.
pub(super) fn record_tables(
    id: &str,
    t: &Trained,
    confusion: &[Vec<usize>],
) -> Result<Vec<(&'static str, DataFrame)>> {
    let e = &t.epochs;
    let history = DataFrame::new_infer_height(vec![
        Column::new(col::JOB.into(), vec![id; e.len()]),
        Column::new(
            "epoch".into(),
            e.iter().map(|x| x.epoch as i64).collect::<Vec<_>>(),
        ),
        Column::new(
            col::LOSS.into(),
            e.iter().map(|x| x.loss).collect::<Vec<_>>(),
        ),
        Column::new(
            "batch_accuracy".into(),
            e.iter().map(|x| x.batch_accuracy).collect::<Vec<_>>(),
        ),
        Column::new(
            col::VALIDATION_ACCURACY.into(),
            e.iter()
                .map(|x| x.validation_accuracy.and_then(nan_none))
                .collect::<Vec<_>>(),
        ),
    ])?;
    let k = confusion.len();
    let (mut truth, mut pred, mut count) = (vec![], vec![], vec![]);
    for (a, row) in confusion.iter().enumerate() {
        for (b, &c) in row.iter().enumerate() {
            truth.push(a as i64);
            pred.push(b as i64);
            count.push(c as i64);
        }
    }
    let conf = DataFrame::new_infer_height(vec![
        Column::new(col::JOB.into(), vec![id; k * k]),
        Column::new(col::TRUE_CLASS.into(), truth),
        Column::new(col::PREDICTED_CLASS.into(), pred),
        Column::new(col::COUNT.into(), count),
    ])?;
    Ok(vec![(HISTORY, history), (CONFUSION, conf)])
}

pub(super) fn nan_none(x: f64) -> Option<f64> {
    (!x.is_nan()).then_some(x)
}

/// What a training's row of `jobs.parquet` says about it.
pub(super) struct TrainingRow<'a> {
    pub(super) id: &'a str,
    pub(super) kind: &'a str,
    pub(super) dataset: &'a str,
    pub(super) method: &'a str,
    pub(super) seed: u64,
    pub(super) samples: usize,
}

/// A row of `jobs.parquet` for a training (the columns that apply; the others are null).
pub(super) fn training_status(
    row: TrainingRow,
    net: &NetConfig,
    status: &Status,
) -> Result<DataFrame> {
    let TrainingRow {
        id,
        kind,
        dataset,
        method,
        seed,
        samples,
    } = row;
    Ok(DataFrame::new_infer_height(vec![
        Column::new(col::JOB.into(), [id]),
        Column::new(col::DATASET.into(), [dataset]),
        Column::new(col::KIND.into(), [kind]),
        Column::new(col::METHOD.into(), [method]),
        Column::new(
            "status".into(),
            [if status.error.is_none() {
                "ok"
            } else {
                "failed"
            }],
        ),
        Column::new(col::ERROR.into(), [status.error]),
        Column::new(col::SEED.into(), [seed]),
        Column::new(col::SAMPLES.into(), [samples as i64]),
        Column::new(col::HEIGHT.into(), [net.height as i64]),
        Column::new(col::WIDTH.into(), [net.width as i64]),
        Column::new(col::ELAPSED_S.into(), [status.elapsed_s]),
    ])?)
}

/// Bytes and work of one training on `train_n` samples with `other_n` more kept (validation
/// and test): the sets as complex64 and prepared float32 (the training set twice, as composed
/// and as shuffled batches), a mini-batch's activations with their gradients, and `6 x` the
/// forward multiply-adds per sample of each mini-batch step.
pub(super) fn training(
    net: &NetConfig,
    t: &TrainingOptions,
    train_n: f64,
    other_n: f64,
) -> (f64, f64) {
    let pixels = net.height as f64 * net.width as f64;
    let prepared = net.prepared_len() as f64 * 4.0;
    let sets = (2.0 * train_n + other_n) * (pixels * C64 + prepared);
    let f = net.arch.filters().map(|x| x as f64);
    let batch = (t.batch_size as f64).min(train_n).max(1.0);
    let steps = t.steps_for(train_n as usize) as f64;
    let activations = batch * pixels * f[0] * 8.0;
    let macs = pixels / 4.0 * f[0] * 2.0 * 64.0
        + pixels / 64.0 * f[1] * f[0] * 16.0
        + pixels / 1024.0 * f[2] * f[1] * 4.0;
    // A GPU trains about 30 times faster than the reference core.
    let device = match t.device {
        Device::Cpu => 1.0,
        Device::Cuda => 1.0 / 30.0,
        // Counted as the CPU until the run resolves it (`run` does before it plans).
        Device::Auto => 1.0,
    };
    (
        sets + activations + (64u64 << 20) as f64,
        6.0 * macs * steps * batch * device,
    )
}

/// Records a training block's sizes at `at` (`classification.training`).
pub(super) fn training_sizes(at: &str, t: &TrainingOptions, train_n: f64, s: &mut Sizes) {
    match t.steps {
        Some(steps) => s.add(format!("{at}.steps"), steps, steps as f64 / 210.0),
        None => s.add(format!("{at}.epochs"), t.epochs, t.epochs as f64 / 30.0),
    }
    let batch = t.batch_size as f64;
    s.add(
        format!("{at}.batch_size"),
        t.batch_size,
        batch.min(train_n) / 128.0,
    );
}

/// What a training's datasets cost: the largest materialisation's peak, every stack as
/// complex128 twice (the stacks, then their concatenation), the work, and the samples of each.
pub(super) struct Stacks {
    pub(super) bytes: f64,
    pub(super) flops: f64,
    pub(super) samples: Vec<f64>,
}

/// Materialising and concatenating `data`, recording their sizes.
pub(super) fn stacks(plan: &Plan, data_refs: &[DataRef], s: &mut Sizes) -> Stacks {
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
pub(super) fn fit_sizes(at: &str, method: Method, half_width: usize, s: &mut Sizes) {
    if method.needs().half_width {
        s.add(
            format!("{at}.half_width"),
            half_width,
            half_width as f64 / 8.0,
        );
    }
}
