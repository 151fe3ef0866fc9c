//! The `classification` section: clutter classification with CNNs trained on generated clutter
//! (ch. 5.3.2-5.3.7, Tables 18-22), its fields and their check against the class datasets.

use super::common::{
    check_common, check_methods, data_ref, half_width, holdout, levels, original_fraction, repeats,
    too_many_trainings, zero_mean, DataRef, OneOrMany, MAX_TRAININGS,
};
use crate::apps::cnn::classification::{held_out, Normalise, Source};
use crate::apps::cnn::net::{Arch, NetConfig};
use crate::apps::cnn::train::TrainingOptions;
use crate::experiment::context::{Ctx, SpecError};
use serde::{Deserialize, Serialize};

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
    /// The training settings every training runs under (`training` with the steps of
    /// `equal_steps` resolved from the largest training size).
    pub training: TrainingOptions,
}

impl ClassificationSpec {
    /// Validates the section against the stacks of the plan's analysis jobs (`stacks`: one per
    /// dataset and sweep point).
    ///
    /// # Errors
    /// A [`SpecError`] with the YAML path of the first problem.
    pub fn validate(&self, ctx: &Ctx, stacks: &[DataRef]) -> Result<ClassificationPlan, SpecError> {
        let at = "classification";
        let classes = self.check_classes(ctx, at, stacks)?;
        let (_, h, w) = classes[0].dataset.shape();
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
        self.check_train_sizes(ctx, at, &classes, &sources)?;
        let trainings =
            (normalise.len() * sources.len() * self.train_sizes.len()).saturating_mul(self.repeats);
        if trainings > MAX_TRAININGS {
            return Err(too_many_trainings(ctx, at, trainings, self.repeats));
        }
        let largest = self.train_sizes.iter().copied().max().unwrap_or(0);
        Ok(ClassificationPlan {
            training: self.training.for_largest(largest),
            spec: self.clone(),
            classes,
            normalise,
            sources,
            net,
        })
    }

    /// The classes (dataset ids, at least 2, each once) resolved to the plan's stacks, of one
    /// image size and at least 4 samples each.
    fn check_classes(
        &self,
        ctx: &Ctx,
        at: &str,
        stacks: &[DataRef],
    ) -> Result<Vec<DataRef>, SpecError> {
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
        Ok(classes)
    }

    /// Each training size: listed once, at least one sample per class, at most 1000000, and
    /// (for a generated training set) mixing no more originals per class than the smallest
    /// fit part holds.
    fn check_train_sizes(
        &self,
        ctx: &Ctx,
        at: &str,
        classes: &[DataRef],
        sources: &[Source],
    ) -> Result<(), SpecError> {
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
        Ok(())
    }
}
