//! The `metrics`, `noise_floor` and `hypotheses` sections: similarity metrics by name or with
//! parameters, validated into [`crate::stats::metrics::Metric`]s, and the noise floor to measure.

use super::context::{Ctx, SpecError};
use super::synthesis::SynthesisSpec;
use serde::{Deserialize, Serialize};

/// `hypotheses:` section.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HypothesesSpec {
    /// Largest offset (pixels, each axis) of the mean 2-D correlating function (default 4).
    #[serde(default = "four")]
    pub max_offset: usize,
}

fn four() -> usize {
    4
}

/// The reference comparison that shows which metric differences are real: the same metrics
/// between two independent stacks of the original data.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum NoiseFloor {
    /// `draws` for synthetic datasets, `halves` for stacks read from files.
    #[default]
    Auto,
    /// The original against an independent draw of `synthesis.samples` samples from the same
    /// synthetic model (the comparison a perfect method would give).
    Draws,
    /// The first half of the original samples against the second half.
    Halves,
    /// No noise floor.
    None,
}

/// Parameters of one `metrics:` entry, as written (all optional; defaults in
/// [`crate::stats::metrics`]).
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MetricParams {
    /// KL: number of bins.
    pub bins: Option<usize>,
    /// KL: pseudo-count of empty bins.
    pub smoothing: Option<f64>,
    /// KL: symmetric (eq. 23).
    pub symmetric: Option<bool>,
    /// KL: statistics in dB.
    pub db: Option<bool>,
    /// KL: the sum over bins divided by their count.
    pub mean_over_bins: Option<bool>,
    /// KL: how the sampling floor is removed (`none`, `resplit`).
    pub bias_correction: Option<crate::stats::metrics::BiasCorrection>,
    /// `kl_area`: block edge in pixels.
    pub block: Option<usize>,
}

/// The KL options of one entry at `at` (`block_ok`: the metric takes `block`).
fn kl_options(
    params: &MetricParams,
    at: &str,
    ctx: &Ctx,
    block_ok: bool,
) -> Result<crate::stats::metrics::KlOptions, SpecError> {
    use crate::stats::metrics::KlOptions;
    if params.block.is_some() && !block_ok {
        return Err(ctx.err(format!("{at}.block"), "only kl_area takes `block`"));
    }
    let d = KlOptions::default();
    let o = KlOptions {
        bins: params.bins.unwrap_or(d.bins),
        smoothing: params.smoothing.unwrap_or(d.smoothing),
        symmetric: params.symmetric.unwrap_or(d.symmetric),
        db: params.db.unwrap_or(d.db),
        mean_over_bins: params.mean_over_bins.unwrap_or(d.mean_over_bins),
        bias_correction: params.bias_correction.unwrap_or(d.bias_correction),
    };
    if o.bins == 0 {
        return Err(ctx.err(format!("{at}.bins"), "bins must be at least 1"));
    }
    if !(o.smoothing >= 0.0 && o.smoothing.is_finite()) {
        return Err(ctx.err(
            format!("{at}.smoothing"),
            format!("smoothing {} must be finite and >= 0", o.smoothing),
        ));
    }
    Ok(o)
}

/// Validates the `metrics:` section (`metrics`, beside the spec's `synthesis` section) into
/// typed metrics.
///
/// # Errors
/// A [`SpecError`] naming `metrics[i]` (and the parameter) for an unknown name, a parameter
/// the metric does not take, a bad value, a metric listed twice, or metrics without a
/// `synthesis` section.
pub fn check_metrics(
    metrics: &[serde_yaml_ng::Value],
    synthesis: Option<&SynthesisSpec>,
    ctx: &Ctx,
) -> Result<Vec<crate::stats::metrics::Metric>, SpecError> {
    use crate::stats::metrics::{Metric, MetricKind};
    if !metrics.is_empty() && synthesis.is_none() {
        return Err(ctx.err(
            "metrics",
            "metrics compare generated samples with the original: add a `synthesis` section",
        ));
    }
    let names = MetricKind::names();
    let mut out: Vec<Metric> = Vec::new();
    for (i, entry) in metrics.iter().enumerate() {
        let at = format!("metrics[{i}]");
        let (name, params) = match entry {
            serde_yaml_ng::Value::String(s) => (s.clone(), MetricParams::default()),
            serde_yaml_ng::Value::Mapping(m) if m.len() == 1 => {
                let (k, v) = m.iter().next().expect("one entry");
                let name = k.as_str().unwrap_or_default().to_string();
                let v = if v.is_null() {
                    serde_yaml_ng::Value::Mapping(Default::default())
                } else {
                    v.clone()
                };
                let params: MetricParams = serde_yaml_ng::from_value(v)
                    .map_err(|e| ctx.err(format!("{at}.{name}"), e.to_string()))?;
                (name, params)
            }
            _ => {
                return Err(ctx.err(
                    at,
                    format!("a metric is a name ({names}) or `{{name: {{parameters}}}}`"),
                ))
            }
        };
        let at = format!("{at}.{name}");
        let kl = |block_ok: bool| kl_options(&params, &at, ctx, block_ok);
        let kind: MetricKind = name.parse().map_err(|e: String| ctx.err(&at, e))?;
        let no_parameters = || {
            if params != MetricParams::default() {
                return Err(ctx.err(&at, format!("{name} takes no parameters")));
            }
            Ok(())
        };
        // Exhaustive: a new metric kind is a compile error here until it is parsed.
        let metric = match kind {
            MetricKind::KlPixel => Metric::KlPixel(kl(false)?),
            MetricKind::KlArea => {
                let block = params.block.unwrap_or(crate::stats::metrics::DEFAULT_BLOCK);
                if block == 0 {
                    return Err(ctx.err(format!("{at}.block"), "block must be at least 1"));
                }
                Metric::KlArea(kl(true)?, block)
            }
            MetricKind::Cmd => {
                no_parameters()?;
                Metric::Cmd
            }
            MetricKind::MultiscaleRmse => {
                no_parameters()?;
                Metric::MultiscaleRmse
            }
        };
        if out.iter().any(|m| m.name() == metric.name()) {
            return Err(ctx.err(at, format!("{name} is listed twice")));
        }
        if metric == Metric::MultiscaleRmse && synthesis.is_some_and(|s| !s.analyse_generated) {
            return Err(ctx.err(
                at,
                "multiscale_rmse needs synthesis.analyse_generated: true",
            ));
        }
        out.push(metric);
    }
    Ok(out)
}
