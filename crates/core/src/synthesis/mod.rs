//! Synthesis (dissertation ch. 4, docs/definitions.md §5): fit a model to a stack once, then
//! generate any number of new samples with its statistics. Each method is one file
//! implementing [`SynthesisMethod`] and one line of the registry (`registry.rs`), which makes
//! the [`Method`] and [`Model`] enums; this module fits (the moments, then the method).
//!
//! Every method outputs `mu + sigma * y / sd(y)` per pixel, `y` zero-mean with the exact
//! (analytic) standard deviation `sd(y)`, so mean and variance maps are reproduced by
//! construction:
//! - `method1`: spatially varying separable exponential filter, `alpha` per level-1 cell and
//!   direction from the level-1 correlation by inverting `g(alpha) = rho(1)`;
//! - `method2`: spatially varying separable dyadic filter, `r_1..r_L` per level-1 cell and
//!   direction, solved against the cell's level `1..L` ancestors;
//! - `full_covariance`: the Gaussian with the sample mean and covariance, sampled in `O(N P)`
//!   without forming the `P x P` matrix;
//! - `uncorrelated`: mean and variance only.
//!
//! Sample `s` of a generation with seed `seed` draws from its own stream of the seed (stream
//! `s`), so any sample can be regenerated alone and output never depends on threads. How the
//! stream becomes a sample is the model's *sample format* ([`SAMPLE_FORMAT`]): format 1
//! (models written before it was recorded) draws ChaCha20 normals by ziggurat in `f64`;
//! format 2 draws ChaCha8 words turned into normals by the Box-Muller transform of
//! [`crate::seeds::normal`] and filters in `f32` ([`kernel`]). Both give samples with the
//! model's statistics; format 2 is several times faster.

use crate::stats::analysis::Analysis;
use ndarray::ArrayView3;
use num_complex::Complex64;

mod filter;
mod fourth_order;
mod full_covariance;
mod generate;
pub mod kernel;
#[cfg(target_arch = "x86_64")]
mod kernel_avx512;
mod method;
mod method1;
mod method2;
mod options;
mod registry;
mod sampling;
mod uncorrelated;

use crate::resources::human_bytes;
pub use crate::stats::filters::NegativeSigns;
pub use filter::{CellParams, FilterModel, Filtered, MAX_WORK_BYTES};
pub use fourth_order::{FourthOrder, FourthOrderModel};
pub use full_covariance::FullCovariance;
pub use method::{
    ArrayStore, Cost, CostSize, Layout, Moments, Needs, Recorded, SynthesisMethod, ValueCheck,
};
pub use method1::{
    exponential_lag1, exponential_lag1_signed, exponential_peak, invert_alpha, invert_alpha_signed,
    negative_peak, AlphaInverter, Exponential,
};
pub use method2::{dyadic_correlations, solve_dyadic, Dyadic, UNREACHED};
pub use options::{
    check_finite, FitError, FitOptions, NON_FINITE_SHOWN, SAMPLE_FORMAT, SAMPLE_FORMATS,
};
pub use registry::{Method, Model, UnknownMethod};
pub use uncorrelated::Uncorrelated;

/// Fits `method` to a stack from its analysis (at [`Needs::depth`]; `stack` is needed where
/// [`Needs::stack`]).
///
/// # Errors
/// [`FitError`] if the stack has NaN or infinite values ([`check_finite`]: the model would
/// hold a mean or standard deviation that is not finite), the analysis lacks levels the method
/// needs, the model's estimated size is above [`fit_limit`] ([`FitError::Memory`], before
/// anything is allocated) or its arrays (the full-covariance deviations) do not fit in memory.
pub fn fit(
    method: Method,
    analysis: &Analysis,
    stack: Option<ArrayView3<Complex64>>,
    opts: FitOptions,
) -> Result<Model, FitError> {
    check_finite(analysis)?;
    check_fit_memory(method, analysis, &opts)?;
    let moments = Moments {
        mean: analysis.mean.clone(),
        std: analysis.variance.mapv(f64::sqrt),
        sample_format: SAMPLE_FORMAT,
    };
    method.fit_moments(moments, analysis, stack, &opts)
}

/// The most bytes a fitted model may take, in words: the machine's memory
/// ([`crate::resources::machine_memory`]), and never more than [`MAX_WORK_BYTES`], the most
/// a model folder's filter bank may need when it is loaded again.
pub fn fit_limit() -> (u64, String) {
    let cap = (
        MAX_WORK_BYTES,
        format!("the {} a model may hold", human_bytes(MAX_WORK_BYTES)),
    );
    match crate::resources::machine_memory() {
        Some(m) if m < MAX_WORK_BYTES => (m, format!("the machine's {}", human_bytes(m))),
        _ => cap,
    }
}

/// Refuses a fit whose model ([`Method::cost`]) would be larger than [`fit_limit`].
fn check_fit_memory(
    method: Method,
    analysis: &Analysis,
    opts: &FitOptions,
) -> Result<(), FitError> {
    let (height, width) = analysis.mean.dim();
    let cost = method.cost(&CostSize {
        fitted: analysis.samples as f64,
        generated: 0.0,
        pixels: (height * width) as f64,
        half_width: opts.half_width as f64,
    });
    let (limit, words) = fit_limit();
    let bytes = cost.model_bytes as u64; // saturates
    if bytes <= limit {
        return Ok(());
    }
    Err(FitError::Memory {
        method: method.as_str(),
        half_width: opts.half_width,
        height,
        width,
        bytes,
        limit: words,
    })
}

impl Model {
    /// The filters of a filter model (Methods 1 and 2).
    pub fn filter(&self) -> Option<&FilterModel> {
        match self {
            Model::Method1(m) => Some(&m.filtered.filter),
            Model::Method2(m) => Some(&m.filtered.filter),
            Model::FullCovariance(_) | Model::Uncorrelated(_) | Model::FourthOrder(_) => None,
        }
    }
}
