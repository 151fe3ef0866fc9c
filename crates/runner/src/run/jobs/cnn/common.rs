//! What the CNN training jobs share: the names of their tables, the materialisation of their
//! datasets, their seeds, and the rows every training leaves (its status, its per-epoch record
//! and its confusion matrix).

use crate::apps::cnn::net::NetConfig;
use crate::apps::cnn::train::Trained;
use crate::experiment::DataRef;
use crate::experiment::{materialise, Materialised};
use crate::io::npy::Stack;
use crate::io::results;
use crate::run::jobs::Status;
use crate::seeds::derive_seed;
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
        let m =
            materialise(&d.dataset, d.data_seed).with_context(|| format!("dataset {}", d.id))?;
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
        Column::new("job".into(), vec![id; e.len()]),
        Column::new(
            "epoch".into(),
            e.iter().map(|x| x.epoch as i64).collect::<Vec<_>>(),
        ),
        Column::new("loss".into(), e.iter().map(|x| x.loss).collect::<Vec<_>>()),
        Column::new(
            "batch_accuracy".into(),
            e.iter().map(|x| x.batch_accuracy).collect::<Vec<_>>(),
        ),
        Column::new(
            "validation_accuracy".into(),
            e.iter()
                .map(|x| nan_none(x.validation_accuracy))
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
        Column::new("job".into(), vec![id; k * k]),
        Column::new("true_class".into(), truth),
        Column::new("predicted_class".into(), pred),
        Column::new("count".into(), count),
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
        Column::new("job".into(), [id]),
        Column::new("dataset".into(), [dataset]),
        Column::new("kind".into(), [kind]),
        Column::new("method".into(), [method]),
        Column::new(
            "status".into(),
            [if status.error.is_none() {
                "ok"
            } else {
                "failed"
            }],
        ),
        Column::new("error".into(), [status.error]),
        Column::new("seed".into(), [seed]),
        Column::new("samples".into(), [samples as i64]),
        Column::new("height".into(), [net.height as i64]),
        Column::new("width".into(), [net.width as i64]),
        Column::new("elapsed_s".into(), [status.elapsed_s]),
    ])?)
}
