//! The sections of the CNN applications (ch. 5.3, docs/definitions.md §12), one file each
//! (`classification`, `location`): what a user writes and its validation against the datasets.
//! Every value that the networks, the splits or the data sets cannot take is refused with its
//! YAML path, before anything runs. This file holds what they share: the datasets they read,
//! the method list, the training settings and the ceiling on trainings.

use super::{Ctx, Dataset, RawSpec, SpecError};
mod classification;
mod location;

use crate::apps::cnn::classification::{Normalise, Source};
use crate::apps::cnn::train::TrainingOptions;
pub use classification::{ClassificationPlan, ClassificationSpec};
pub use location::{LocationPlan, LocationSpec};
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

fn zero_mean() -> OneOrMany<Normalise> {
    OneOrMany::One(Normalise::ZeroMean)
}
fn holdout() -> f64 {
    0.2
}
fn original_fraction() -> f64 {
    0.1
}
fn repeats() -> usize {
    5
}
fn location_repeats() -> usize {
    3
}
fn half_width() -> usize {
    8
}
fn levels() -> usize {
    3
}
fn fit_samples() -> usize {
    100
}
fn generated_samples() -> usize {
    5000
}

/// The validated CNN sections of a spec, one field per application. A new application is a
/// field here (its section's plan); the compiler then names the two places that list the
/// applications: [`Applications::validate`] below and the runner's `run::jobs::cnn::jobs`.
#[derive(Debug, Clone, Default)]
pub struct Applications {
    /// The validated `classification` section.
    pub classification: Option<ClassificationPlan>,
    /// The validated `location` section.
    pub location: Option<LocationPlan>,
}

impl Applications {
    /// Validates the spec's CNN sections against the stacks of the plan's analysis jobs
    /// (`stacks` lists them; called once, and only when a section is present).
    ///
    /// # Errors
    /// A [`SpecError`] with the YAML path of the first problem.
    pub fn validate(
        spec: &RawSpec,
        ctx: &Ctx,
        stacks: impl Fn() -> Vec<DataRef>,
    ) -> Result<Self, SpecError> {
        let listed = std::cell::OnceCell::new();
        let stacks = || listed.get_or_init(&stacks).as_slice();
        Ok(Applications {
            classification: spec
                .classification
                .as_ref()
                .map(|c| c.validate(ctx, stacks()))
                .transpose()?,
            location: spec
                .location
                .as_ref()
                .map(|l| l.validate(ctx, stacks()))
                .transpose()?,
        })
    }
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
fn check_methods(ctx: &Ctx, at: &str, methods: &[String]) -> Result<Vec<Source>, SpecError> {
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
fn check_common(
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
fn too_many_trainings(ctx: &Ctx, at: &str, trainings: usize, repeats: usize) -> SpecError {
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
fn data_ref(ctx: &Ctx, at: String, id: &str, stacks: &[DataRef]) -> Result<DataRef, SpecError> {
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
