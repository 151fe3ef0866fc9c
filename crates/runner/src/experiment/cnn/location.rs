//! The `location` section: target location with CNNs trained on generated clutter
//! (ch. 5.3.8-5.3.9, Table 23, Figs. 73-74), its fields and their check against the clutter
//! dataset.

use super::common::{
    check_common, check_methods, data_ref, fit_samples, generated_samples, half_width, levels,
    location_repeats, too_many_trainings, DataRef, MAX_TRAININGS,
};
use crate::apps::cnn::classification::Source;
use crate::apps::cnn::location::{TargetKind, TestSet};
use crate::apps::cnn::net::{Arch, NetConfig};
use crate::apps::cnn::train::{Protocol, TrainingOptions};
use crate::experiment::context::{Ctx, SpecError};
use crate::location_grid::MIN_SIDE;
use serde::{Deserialize, Serialize};

/// `location:` section (5.3.8-5.3.9, Figs. 68-74).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LocationSpec {
    /// Dataset id of the clutter stack.
    pub clutter: String,
    /// Clutter samples the models are fitted on (default 100); the rest are the test set.
    #[serde(default = "fit_samples")]
    pub fit_samples: usize,
    /// Originals the `original` network trains (half) and validates (half) on, the fit part
    /// first (default: `fit_samples`, the originals the methods see); under
    /// `training.protocol: equal_steps` it trains on all of them (the validation is a record,
    /// it does not pick the network). The test set is the
    /// samples after both, the same for every method: a larger number (the dissertation's
    /// 5.3.9.1 compares with "500 samples of the original data") shrinks it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub original_samples: Option<usize>,
    /// The originals every network is tested on, each a row of `location.parquet` and of its
    /// summary (column `test_set`): `held_out`, the samples after those the methods were
    /// fitted on and `original` trained and validated on (the default), and/or `all`, every
    /// clutter sample, those seen included (the dissertation's protocol, 5.3.8: its networks
    /// were tested on all 1000 originals). One training serves every test set.
    #[serde(default = "test_sets")]
    pub test_sets: Vec<TestSet>,
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
    /// The training settings every training runs under (`training` with the steps of
    /// `equal_steps` resolved from the largest training set).
    pub training: TrainingOptions,
}

/// The default of [`LocationSpec::test_sets`]: the held-out originals.
fn test_sets() -> Vec<TestSet> {
    vec![TestSet::HeldOut]
}

/// `items` (the list at YAML path `at`) names at least one of `choices` and none twice.
fn listed_once<T: PartialEq>(
    ctx: &Ctx,
    at: &str,
    items: &[T],
    choices: &str,
    name: impl Fn(&T) -> &'static str,
) -> Result<(), SpecError> {
    if items.is_empty() {
        return Err(ctx.err(at, format!("name at least one of {choices}")));
    }
    for (i, t) in items.iter().enumerate() {
        if items[..i].contains(t) {
            return Err(ctx.err(format!("{at}[{i}]"), format!("{} is listed twice", name(t))));
        }
    }
    Ok(())
}

impl LocationSpec {
    /// `original_samples`, if given: at least `fit_samples` and 4, and fewer than the `n`
    /// samples of the clutter dataset `id` (the test set is the rest).
    fn check_original_samples(&self, ctx: &Ctx, n: usize, id: &str) -> Result<(), SpecError> {
        let Some(o) = self.original_samples else {
            return Ok(());
        };
        let at = "location.original_samples";
        if o < self.fit_samples || o < 4 {
            return Err(ctx.err(
                at,
                format!(
                    "must be at least fit_samples ({}) and 4, got {o}",
                    self.fit_samples
                ),
            ));
        }
        if n <= o {
            return Err(ctx.err(
                at,
                format!("dataset {id} has {n} samples; training on {o} originals leaves none to test on"),
            ));
        }
        Ok(())
    }

    /// The originals `original` trains and validates on ([`LocationSpec::original_samples`],
    /// else [`LocationSpec::fit_samples`]); the test set starts after them.
    pub fn originals(&self) -> usize {
        self.original_samples.unwrap_or(self.fit_samples)
    }

    /// The originals `original`'s network trains on: all of [`LocationSpec::originals`] under
    /// `equal_steps` (validating on none), half of them otherwise (validating on the other
    /// half).
    pub fn original_training(&self) -> usize {
        match self.training.protocol {
            Protocol::EqualSteps => self.originals(),
            Protocol::Matlab => self.originals() / 2,
        }
    }

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
            classes: crate::location_grid::LOCATIONS,
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
        self.check_original_samples(ctx, n, &clutter.id)?;
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
        let targets = "constant, stochastic";
        listed_once(ctx, &format!("{at}.targets"), &self.targets, targets, |t| {
            t.as_str()
        })?;
        let sets = "held_out, all";
        listed_once(
            ctx,
            &format!("{at}.test_sets"),
            &self.test_sets,
            sets,
            |t| t.as_str(),
        )?;
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
        let largest = (self.generated_samples / 2).max(self.original_training());
        Ok(LocationPlan {
            training: self.training.for_largest(largest),
            spec: self.clone(),
            clutter,
            sources,
            net,
        })
    }
}
