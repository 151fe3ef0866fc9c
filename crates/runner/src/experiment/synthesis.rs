//! The `synthesis` section: methods, half-width, samples and what to do with them.

use super::context::{Ctx, SpecError};
use super::sections::{yes, AnalysisSpec};
use crate::stats::analysis::check_levels;
use serde::{Deserialize, Serialize};

/// `synthesis:` section (ch. 4): every dataset is fitted by every method; each fit generates
/// `samples` new samples, from a seed shared by the methods of one dataset (common random
/// numbers, so method comparisons are paired).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SynthesisSpec {
    /// Methods: `method1`, `method2`, `full_covariance`, `uncorrelated`.
    pub methods: Vec<crate::synthesis::Method>,
    /// Samples to generate per fit.
    pub samples: usize,
    /// Filter half-width `K` of Methods 1 and 2 (default 8).
    #[serde(default = "default_half_width")]
    pub half_width: usize,
    /// Dyadic parameters `L` of Method 2 (default: `analysis.levels`).
    #[serde(default)]
    pub levels: Option<usize>,
    /// How Method 1 signs the filter of a negative correlation: `multiscale` (default, the
    /// dissertation's §4.2.4: the 1-, 2- and 4-pixel shifts correlate negatively) or
    /// `alternating` (lag 1 exactly negated; docs/definitions.md §5).
    #[serde(default)]
    pub negative_signs: crate::synthesis::NegativeSigns,
    /// Write the generated samples to `samples/<job>.npy` (complex64 `[M, H, W]`).
    #[serde(default)]
    pub save_samples: bool,
    /// Analyse the generated samples too (rows with `source` = the method; default true).
    #[serde(default = "yes")]
    pub analyse_generated: bool,
    /// Also compare with originals no fit saw (default false; needs metrics): each method is
    /// fitted again on a seeded half of the originals and its samples compared with the other
    /// half, and the analysis job measures the floor of those two halves (`similarity` rows
    /// with `reference` = `held_out`; docs/definitions.md section 6).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub held_out: bool,
}

fn default_half_width() -> usize {
    8
}

impl SynthesisSpec {
    /// Method 2's `L` given the analysis levels.
    pub fn dyadic_levels(&self, analysis: &AnalysisSpec) -> usize {
        self.levels.unwrap_or(analysis.levels)
    }

    /// Validates the section for a dataset of size `h x w` (`at`: the YAML path).
    pub fn check(
        &self,
        ctx: &Ctx,
        analysis: &AnalysisSpec,
        h: usize,
        w: usize,
    ) -> Result<(), SpecError> {
        if self.methods.is_empty() {
            return Err(ctx.err("synthesis.methods", "name at least one method"));
        }
        for (i, m) in self.methods.iter().enumerate() {
            if self.methods[..i].contains(m) {
                return Err(ctx.err(
                    format!("synthesis.methods[{i}]"),
                    format!("{} is listed twice", m.as_str()),
                ));
            }
        }
        let min = if self.analyse_generated { 2 } else { 1 };
        if self.samples < min {
            return Err(ctx.err("synthesis.samples", format!("{} sample(s) requested; at least {min} (2 when the generated samples are analysed)", self.samples)));
        }
        if let Some(m) = self.methods.iter().find(|m| m.needs().levels) {
            let l = self.dyadic_levels(analysis);
            // The levels first: an absurd `levels` is named as such, not as a short half-width.
            check_levels(l, h, w).map_err(|e| ctx.err("synthesis.levels", format!("{m}: {e}")))?;
            let need = crate::stats::filters::dyadic_reach(l);
            if self.half_width < need {
                return Err(ctx.err("synthesis.half_width", format!("{m} with {l} level(s) reaches offset {need}; half_width {} would truncate it", self.half_width)));
            }
        }
        Ok(())
    }
}
