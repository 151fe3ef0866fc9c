//! The `classification` and `location` sections (the CNN applications of ch. 5.3,
//! docs/definitions.md §12): what a user writes and its validation against the datasets. Every
//! value that the networks, the splits or the data sets cannot take is refused here with its
//! YAML path, before anything runs.

use super::*;
use crate::apps::cnn::classification::{held_out, Normalise, Source};
use crate::apps::cnn::location::{TargetKind, MIN_SIDE};
use crate::apps::cnn::net::{Arch, NetConfig};
use crate::apps::cnn::train::TrainingOptions;

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

/// `classification:` section (5.3.2-5.3.7, Tables 19-22).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ClassificationSpec {
    /// Dataset ids, one per class (label order).
    pub classes: Vec<String>,
    /// `zero_mean` or `zero_mean_unit_variance`, or a list of both (default `zero_mean`).
    #[serde(default = "zero_mean")]
    pub normalise: OneOrMany<Normalise>,
    /// Fraction of each class's originals held out for prediction (default 0.2; 0 = the
    /// dissertation's protocol: fit on and predict on all originals).
    #[serde(default = "holdout")]
    pub holdout: f64,
    /// `original` and synthesis methods.
    pub methods: Vec<String>,
    /// Total training-set sizes (balanced over the classes).
    pub train_sizes: Vec<usize>,
    /// Fraction of originals in a generated training set (default 0.1).
    #[serde(default = "original_fraction")]
    pub original_fraction: f64,
    /// Trainings per method and size (default 5).
    #[serde(default = "repeats")]
    pub repeats: usize,
    /// Filter half-width of Methods 1 and 2 (default 8).
    #[serde(default = "half_width")]
    pub half_width: usize,
    /// How Method 1 signs the filter of a negative correlation (default `multiscale`; see
    /// `synthesis.negative_signs`).
    #[serde(default)]
    pub negative_signs: crate::synthesis::NegativeSigns,
    /// Dyadic levels of Method 2 (default 3).
    #[serde(default = "levels")]
    pub levels: usize,
    /// Training settings (MATLAB's `sgdm` defaults).
    #[serde(default)]
    pub training: TrainingOptions,
    /// Keep every trained network in `networks/<job>/` (default false).
    #[serde(default)]
    pub save_networks: bool,
}

/// `location:` section (5.3.8-5.3.9, Figs. 68-74).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LocationSpec {
    /// Dataset id of the clutter stack.
    pub clutter: String,
    /// Clutter samples the models are fitted on (default 100); the rest are the test set.
    #[serde(default = "fit_samples")]
    pub fit_samples: usize,
    /// `original` and synthesis methods.
    pub methods: Vec<String>,
    /// Samples each method generates, half for training and half for validation (default 5000).
    #[serde(default = "generated_samples")]
    pub generated_samples: usize,
    /// `constant` and/or `stochastic`.
    pub targets: Vec<TargetKind>,
    /// Signal-to-clutter ratios in dB.
    pub scr_db: Vec<f64>,
    /// Trainings per target, method and SCR (default 3).
    #[serde(default = "location_repeats")]
    pub repeats: usize,
    /// Filter half-width of Methods 1 and 2 (default 8).
    #[serde(default = "half_width")]
    pub half_width: usize,
    /// How Method 1 signs the filter of a negative correlation (default `multiscale`; see
    /// `synthesis.negative_signs`).
    #[serde(default)]
    pub negative_signs: crate::synthesis::NegativeSigns,
    /// Dyadic levels of Method 2 (default 3).
    #[serde(default = "levels")]
    pub levels: usize,
    /// Training settings (MATLAB's `sgdm` defaults).
    #[serde(default)]
    pub training: TrainingOptions,
    /// Keep every trained network in `networks/<job>/` (default false).
    #[serde(default)]
    pub save_networks: bool,
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
                    "unknown method {m:?}: use original, method1, method2, full_covariance, uncorrelated or fourth_order"
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
    if sources.contains(&Source::Generated(crate::synthesis::Method::Method2)) {
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

/// The validated `classification` section.
#[derive(Debug, Clone)]
pub struct ClassificationPlan {
    /// The section as written.
    pub spec: ClassificationSpec,
    /// The class datasets in label order.
    pub classes: Vec<DataRef>,
    /// Normalisations.
    pub normalise: Vec<Normalise>,
    /// Methods.
    pub sources: Vec<Source>,
    /// The network's geometry.
    pub net: NetConfig,
}

impl ClassificationSpec {
    /// Validates the section against the stacks of the plan's analysis jobs (`stacks`: one per
    /// dataset and sweep point).
    ///
    /// # Errors
    /// A [`SpecError`] with the YAML path of the first problem.
    ///
    /// Long because each field of the CNN sections is checked in turn, each with its YAML path and
    /// message.
    pub fn validate(&self, ctx: &Ctx, stacks: &[DataRef]) -> Result<ClassificationPlan, SpecError> {
        let at = "classification";
        if self.classes.len() < 2 {
            return Err(ctx.err(
                format!("{at}.classes"),
                "name at least 2 classes (dataset ids)",
            ));
        }
        let mut classes: Vec<DataRef> = vec![];
        for (i, id) in self.classes.iter().enumerate() {
            if self.classes[..i].contains(id) {
                return Err(ctx.err(
                    format!("{at}.classes[{i}]"),
                    format!("{id} is listed twice"),
                ));
            }
            classes.push(data_ref(ctx, format!("{at}.classes[{i}]"), id, stacks)?);
        }
        let (_, h, w) = classes[0].dataset.shape();
        for (i, c) in classes.iter().enumerate() {
            let (n, hc, wc) = c.dataset.shape();
            if (hc, wc) != (h, w) {
                return Err(ctx.err(
                    format!("{at}.classes[{i}]"),
                    format!(
                        "class {} has {hc}x{wc} images, class {} has {h}x{w}: every class needs one image size",
                        c.id, classes[0].id
                    ),
                ));
            }
            if n < 4 {
                return Err(ctx.err(
                    format!("{at}.classes[{i}]"),
                    format!(
                        "class {} has {n} samples; a fit part and a test part need at least 4",
                        c.id
                    ),
                ));
            }
        }
        let net = NetConfig {
            arch: Arch::Table18,
            height: h,
            width: w,
            classes: classes.len(),
        };
        net.check()
            .map_err(|e| ctx.err(format!("{at}.classes"), e.to_string()))?;
        if !(0.0..1.0).contains(&self.holdout) {
            return Err(ctx.err(
                format!("{at}.holdout"),
                format!("must be in [0, 1), got {}", self.holdout),
            ));
        }
        if !(0.0..=1.0).contains(&self.original_fraction) {
            return Err(ctx.err(
                format!("{at}.original_fraction"),
                format!("must be in [0, 1], got {}", self.original_fraction),
            ));
        }
        let normalise = self.normalise.to_vec();
        if normalise.is_empty() {
            return Err(ctx.err(format!("{at}.normalise"), "name at least one normalisation"));
        }
        for (i, n) in normalise.iter().enumerate() {
            if normalise[..i].contains(n) {
                return Err(ctx.err(
                    format!("{at}.normalise[{i}]"),
                    format!("{} is listed twice", n.as_str()),
                ));
            }
        }
        let sources = check_methods(ctx, at, &self.methods)?;
        check_common(
            ctx,
            at,
            &self.training,
            self.repeats,
            self.half_width,
            self.levels,
            &sources,
        )?;
        if self.train_sizes.is_empty() {
            return Err(ctx.err(format!("{at}.train_sizes"), "name at least one size"));
        }
        let k = classes.len();
        // The smallest fit part bounds what `original` can train on.
        let min_fit = classes
            .iter()
            .map(|c| {
                let n = c.dataset.shape().0;
                n - held_out(n, self.holdout)
            })
            .min()
            .unwrap_or(0);
        for (i, &n) in self.train_sizes.iter().enumerate() {
            let at_i = format!("{at}.train_sizes[{i}]");
            if self.train_sizes[..i].contains(&n) {
                // Two trainings would share a job id and the table would count them twice.
                return Err(ctx.err(at_i, format!("{n} is listed twice")));
            }
            if n < k {
                return Err(ctx.err(
                    at_i,
                    format!("{n} is fewer than one sample per class ({k} classes)"),
                ));
            }
            if n > 1_000_000 {
                return Err(ctx.err(at_i, format!("{n} is more than 1000000")));
            }
            let needed = (self.original_fraction * (n.div_ceil(k)) as f64).round() as usize;
            if sources.iter().any(|s| *s != Source::Original) && needed > min_fit {
                return Err(ctx.err(
                    at_i,
                    format!(
                        "{n} samples over {k} classes mix {needed} originals per class into a generated training set, but the smallest fit part holds {min_fit} (lower the size, `original_fraction` or `holdout`)"
                    ),
                ));
            }
        }
        let trainings =
            (normalise.len() * sources.len() * self.train_sizes.len()).saturating_mul(self.repeats);
        if trainings > MAX_TRAININGS {
            return Err(too_many_trainings(ctx, at, trainings, self.repeats));
        }
        Ok(ClassificationPlan {
            spec: self.clone(),
            classes,
            normalise,
            sources,
            net,
        })
    }
}

/// The validated `location` section.
#[derive(Debug, Clone)]
pub struct LocationPlan {
    /// The section as written.
    pub spec: LocationSpec,
    /// The clutter dataset.
    pub clutter: DataRef,
    /// Methods.
    pub sources: Vec<Source>,
    /// The network's geometry.
    pub net: NetConfig,
}

impl LocationSpec {
    /// Validates the section against the stacks of the plan's analysis jobs (`stacks`: one per
    /// dataset and sweep point).
    ///
    /// # Errors
    /// A [`SpecError`] with the YAML path of the first problem.
    pub fn validate(&self, ctx: &Ctx, stacks: &[DataRef]) -> Result<LocationPlan, SpecError> {
        let at = "location";
        let clutter = data_ref(ctx, format!("{at}.clutter"), &self.clutter, stacks)?;
        let (n, h, w) = clutter.dataset.shape();
        if h < MIN_SIDE || w < MIN_SIDE {
            return Err(ctx.err(
                format!("{at}.clutter"),
                format!(
                    "dataset {} has {h}x{w} images; the 5x5 target grid needs at least {MIN_SIDE}x{MIN_SIDE}",
                    clutter.id
                ),
            ));
        }
        let net = NetConfig {
            arch: Arch::Table23,
            height: h,
            width: w,
            classes: crate::apps::cnn::location::LOCATIONS,
        };
        net.check()
            .map_err(|e| ctx.err(format!("{at}.clutter"), e.to_string()))?;
        if self.fit_samples < 4 {
            return Err(ctx.err(format!("{at}.fit_samples"), "must be at least 4"));
        }
        if n <= self.fit_samples {
            return Err(ctx.err(
                format!("{at}.fit_samples"),
                format!(
                    "dataset {} has {n} samples; fitting on {} leaves none to test on (it needs at least {})",
                    clutter.id,
                    self.fit_samples,
                    self.fit_samples.saturating_add(1)
                ),
            ));
        }
        let sources = check_methods(ctx, at, &self.methods)?;
        check_common(
            ctx,
            at,
            &self.training,
            self.repeats,
            self.half_width,
            self.levels,
            &sources,
        )?;
        if self.generated_samples < 2 || self.generated_samples > 1_000_000 {
            return Err(ctx.err(
                format!("{at}.generated_samples"),
                "must be in 2..=1000000 (half train, half validate)",
            ));
        }
        if self.targets.is_empty() {
            return Err(ctx.err(
                format!("{at}.targets"),
                "name at least one of constant, stochastic",
            ));
        }
        for (i, t) in self.targets.iter().enumerate() {
            if self.targets[..i].contains(t) {
                return Err(ctx.err(
                    format!("{at}.targets[{i}]"),
                    format!("{} is listed twice", t.as_str()),
                ));
            }
        }
        if self.scr_db.is_empty() {
            return Err(ctx.err(
                format!("{at}.scr_db"),
                "name at least one signal-to-clutter ratio",
            ));
        }
        for (i, s) in self.scr_db.iter().enumerate() {
            if !(-100.0..=100.0).contains(s) {
                return Err(ctx.err(
                    format!("{at}.scr_db[{i}]"),
                    format!("{s} dB is outside -100..=100"),
                ));
            }
            if self.scr_db[..i].contains(s) {
                return Err(ctx.err(
                    format!("{at}.scr_db[{i}]"),
                    format!("{s} dB is listed twice"),
                ));
            }
        }
        let trainings =
            (self.targets.len() * sources.len() * self.scr_db.len()).saturating_mul(self.repeats);
        if trainings > MAX_TRAININGS {
            return Err(too_many_trainings(ctx, at, trainings, self.repeats));
        }
        Ok(LocationPlan {
            spec: self.clone(),
            clutter,
            sources,
            net,
        })
    }
}
