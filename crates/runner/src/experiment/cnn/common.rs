//! What the CNN sections share: the datasets they read ([`DataRef`]), one value or a list
//! ([`OneOrMany`]), the method list and the training block's checks, the defaults of their
//! fields and the ceiling on trainings.

use super::super::context::{Ctx, SpecError};
use super::super::datasets::Dataset;
use crate::apps::cnn::classification::{Normalise, Source};
use crate::apps::cnn::train::TrainingOptions;
use serde::{Deserialize, Serialize};

/// One value or a list of values.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum OneOrMany<T> {
    /// A single value.
    One(T),
    /// A list.
    Many(Vec<T>),
}

impl<T: Clone> OneOrMany<T> {
    /// The values as a list.
    pub fn to_vec(&self) -> Vec<T> {
        match self {
            OneOrMany::One(v) => vec![v.clone()],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}

pub(super) fn zero_mean() -> OneOrMany<Normalise> {
    OneOrMany::One(Normalise::ZeroMean)
}
pub(super) fn holdout() -> f64 {
    0.2
}
pub(super) fn original_fraction() -> f64 {
    0.1
}
pub(super) fn repeats() -> usize {
    5
}
pub(super) fn location_repeats() -> usize {
    3
}
pub(super) fn half_width() -> usize {
    8
}
pub(super) fn levels() -> usize {
    3
}
pub(super) fn fit_samples() -> usize {
    100
}
pub(super) fn generated_samples() -> usize {
    5000
}

/// Most trainings one section may ask for.
pub const MAX_TRAININGS: usize = 100_000;

/// A dataset as the CNN sections see it: id, validated dataset and data seed.
#[derive(Debug, Clone)]
pub struct DataRef {
    /// Dataset id.
    pub id: String,
    /// The validated dataset.
    pub dataset: Dataset,
    /// Its data seed (the same stack its analysis job reads).
    pub data_seed: u64,
}

/// Checks a method list: known names, no repeats.
pub(super) fn check_methods(
    ctx: &Ctx,
    at: &str,
    methods: &[String],
) -> Result<Vec<Source>, SpecError> {
    if methods.is_empty() {
        return Err(ctx.err(format!("{at}.methods"), "name at least one method"));
    }
    let mut out = vec![];
    for (i, m) in methods.iter().enumerate() {
        let s = Source::parse(m).ok_or_else(|| {
            ctx.err(
                format!("{at}.methods[{i}]"),
                format!(
                    "unknown method {m:?}: use original, {}",
                    crate::synthesis::Method::listed()
                ),
            )
        })?;
        if out.contains(&s) {
            return Err(ctx.err(format!("{at}.methods[{i}]"), format!("{m} is listed twice")));
        }
        out.push(s);
    }
    Ok(out)
}

/// Checks the training block, the fit settings and the repeats.
pub(super) fn check_common(
    ctx: &Ctx,
    at: &str,
    training: &TrainingOptions,
    repeats: usize,
    half_width: usize,
    levels: usize,
    sources: &[Source],
) -> Result<(), SpecError> {
    training
        .check()
        .map_err(|(k, m)| ctx.err(format!("{at}.training.{k}"), m))?;
    if repeats == 0 {
        return Err(ctx.err(format!("{at}.repeats"), "must be at least 1"));
    }
    if !(1..=64).contains(&half_width) {
        return Err(ctx.err(format!("{at}.half_width"), "must be in 1..=64"));
    }
    let reads_levels = |s: &Source| matches!(s, Source::Generated(m) if m.needs().levels);
    if sources.iter().any(reads_levels) {
        if !(1..=6).contains(&levels) {
            return Err(ctx.err(format!("{at}.levels"), "must be in 1..=6"));
        }
        if half_width < (1 << levels) - 1 {
            return Err(ctx.err(
                format!("{at}.half_width"),
                format!(
                    "half_width {half_width} truncates a {levels}-level dyadic filter (needs {})",
                    (1 << levels) - 1
                ),
            ));
        }
    }
    Ok(())
}

/// The error of a section asking for more than [`MAX_TRAININGS`] trainings: at `repeats` when
/// the repeats alone pass the limit, at the section otherwise.
pub(super) fn too_many_trainings(
    ctx: &Ctx,
    at: &str,
    trainings: usize,
    repeats: usize,
) -> SpecError {
    let path = if repeats > MAX_TRAININGS {
        format!("{at}.repeats")
    } else {
        at.to_string()
    };
    let count = if trainings == usize::MAX {
        format!("{} or more", usize::MAX)
    } else {
        trainings.to_string()
    };
    ctx.err(path, format!("{count} trainings; at most {MAX_TRAININGS}"))
}

/// The dataset `id` among the stacks the plan's analysis jobs read (one per dataset and sweep
/// point), refused when it is missing or swept.
pub(super) fn data_ref(
    ctx: &Ctx,
    at: String,
    id: &str,
    stacks: &[DataRef],
) -> Result<DataRef, SpecError> {
    let found: Vec<&DataRef> = stacks.iter().filter(|d| d.id == id).collect();
    match found.as_slice() {
        [] => Err(ctx.err(at, format!("{id:?} is not the id of a dataset in `datasets`"))),
        [d] => Ok((*d).clone()),
        _ => Err(ctx.err(
            at,
            format!("dataset {id} is swept ({} sweep points): a CNN section needs one stack per dataset", found.len()),
        )),
    }
}
