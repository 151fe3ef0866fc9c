//! Synthesis (dissertation ch. 4, docs/definitions.md §5): fit a model to a stack once, then
//! generate any number of new samples with its statistics.
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

use crate::stats::analysis::{Analysis, Direction};
pub use crate::stats::filters::NegativeSigns;
use crate::stats::filters::{
    dyadic_taps, exponential_taps, exponential_taps_signed, filter_seed, group_correlation,
    lag_correlation, FilterBank,
};
use ndarray::{Array2, Array3, ArrayView3};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

mod fit;
mod generate;
pub mod kernel;
#[cfg(target_arch = "x86_64")]
mod kernel_avx512;

pub use fit::*;

/// Synthesis methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Spatially varying exponential filter (4.2).
    Method1,
    /// Spatially varying dyadic filter (4.3).
    Method2,
    /// Exact low-rank Gaussian sampler with the sample covariance (4.1).
    FullCovariance,
    /// Mean and variance only (5.3.8.2 item 5).
    Uncorrelated,
    /// Per pixel and component: mean, variance, skewness and excess kurtosis by Fleishman's
    /// power method, no spatial correlation (the fourth-order model of 3.2).
    FourthOrder,
}

impl Method {
    /// The name used in specs, job ids and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            Method::Method1 => "method1",
            Method::Method2 => "method2",
            Method::FullCovariance => "full_covariance",
            Method::Uncorrelated => "uncorrelated",
            Method::FourthOrder => "fourth_order",
        }
    }
}

/// Per-cell filter parameters of Methods 1 and 2 (level-1 cell grid).
#[derive(Debug, Clone, PartialEq)]
pub enum CellParams {
    /// Method 1: `alpha` per direction (negative: signed by `signs`; 0: delta; inf: constant).
    Exponential {
        /// Horizontal alpha per cell.
        alpha_h: Array2<f64>,
        /// Vertical alpha per cell.
        alpha_v: Array2<f64>,
        /// How the filters of negative `alpha` are signed.
        signs: NegativeSigns,
    },
    /// Method 2: `r_1..r_L` per direction, `[L][rows][cols]`.
    Dyadic {
        /// Horizontal parameters per level and cell.
        r_h: Vec<Array2<f64>>,
        /// Vertical parameters per level and cell.
        r_v: Vec<Array2<f64>>,
    },
}

impl CellParams {
    /// Level-1 cell grid `(rows, cols)`.
    pub fn cells(&self) -> (usize, usize) {
        match self {
            CellParams::Exponential { alpha_h, .. } => alpha_h.dim(),
            CellParams::Dyadic { r_h, .. } => r_h[0].dim(),
        }
    }

    /// The per-pixel filter bank of an `h x w` image with half-width `k`: every pixel takes the
    /// parameters of the level-1 cell it lies in (the nearest complete cell for an odd last
    /// row or column).
    pub fn bank(&self, k: usize, h: usize, w: usize) -> FilterBank {
        let cells = self.cells();
        let (mut vertical, mut horizontal) = (Vec::with_capacity(h * w), Vec::with_capacity(h * w));
        for i in 0..h {
            for j in 0..w {
                let c = cell_of(i, j, cells);
                let (v, hz) = match self {
                    CellParams::Exponential {
                        alpha_h,
                        alpha_v,
                        signs,
                    } => (
                        exponential_taps_signed(alpha_v[c], k, *signs),
                        exponential_taps_signed(alpha_h[c], k, *signs),
                    ),
                    CellParams::Dyadic { r_h, r_v } => {
                        let at = |p: &[Array2<f64>]| p.iter().map(|m| m[c]).collect::<Vec<_>>();
                        (dyadic_taps(&at(r_v), k), dyadic_taps(&at(r_h), k))
                    }
                };
                vertical.push(v);
                horizontal.push(hz);
            }
        }
        FilterBank::new(k, h, w, vertical, horizontal)
    }
}

/// A fitted spatially varying filter model (Methods 1 and 2).
#[derive(Debug, Clone)]
pub struct FilterModel {
    /// Per-cell parameters.
    pub params: CellParams,
    /// RMS misfit of the reached correlations per cell, horizontal.
    pub residual_h: Array2<f64>,
    /// RMS misfit per cell, vertical.
    pub residual_v: Array2<f64>,
    /// Cells whose target could not be reached (clamped or best fit), per cell 0, 1 or 2
    /// (one per direction).
    pub clamped: Array2<u8>,
    /// The per-pixel filter bank.
    pub bank: FilterBank,
}

impl FilterModel {
    /// A model from fitted cell parameters, their residuals and unreached counts; builds the
    /// per-pixel bank of an `h x w` image with half-width `k`.
    pub fn new(
        params: CellParams,
        (residual_h, residual_v): (Array2<f64>, Array2<f64>),
        clamped: Array2<u8>,
        (k, h, w): (usize, usize, usize),
    ) -> Self {
        let bank = params.bank(k, h, w);
        FilterModel {
            params,
            residual_h,
            residual_v,
            clamped,
            bank,
        }
    }
}

/// A fitted model, ready to generate samples.
#[derive(Debug, Clone)]
pub struct Model {
    /// The method.
    pub method: Method,
    /// Per-pixel mean.
    pub mean: Array2<Complex64>,
    /// Per-pixel standard deviation.
    pub std: Array2<f64>,
    /// Methods 1 and 2: the filters.
    pub filter: Option<FilterModel>,
    /// Full covariance: the centred samples scaled by `1/sqrt(N)`, `[N, H, W]`.
    pub deviations: Option<Array3<Complex64>>,
    /// Fourth order: Fleishman coefficients.
    pub fourth: Option<FourthOrderModel>,
    /// How samples are drawn from a seed (1 or 2, see the module documentation); models
    /// fitted now use [`SAMPLE_FORMAT`].
    pub sample_format: u32,
    /// Full covariance: `deviations` packed for the sampler's kernel, made on first use.
    pub(crate) packed: std::sync::OnceLock<crate::stats::lowrank::Panels>,
    /// Methods 1 and 2 in format 2: the bank prepared for the kernel, made on first use.
    pub(crate) fast: std::sync::OnceLock<kernel::FastFilter>,
    /// Fourth order in format 2: per component the mean and the four Fleishman coefficients
    /// times the standard deviation, `[2][5][H W]` in `f32`, made on first use.
    pub(crate) fourth_f32: std::sync::OnceLock<Vec<f32>>,
}

/// The sample format of newly fitted models: 2 (ChaCha8 words, `f32` Box-Muller normals and
/// `f32` filtering; see the module documentation).
pub const SAMPLE_FORMAT: u32 = 2;

/// The sample formats this version generates.
pub const SAMPLE_FORMATS: [u32; 2] = [1, 2];

/// The fourth-order model's per-pixel parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct FourthOrderModel {
    /// `[component (re, im), coefficient (a, b, c, d), row, col]`.
    pub coefficients: ndarray::Array4<f64>,
    /// Standard deviation per component, `[component, row, col]`.
    pub component_sd: Array3<f64>,
    /// Moment pairs moved to the feasible region, `[component, row, col]` (0 or 1).
    pub infeasible: Array3<u8>,
}

/// RMS misfit above which Method 2 counts a cell's target as unreached.
pub const UNREACHED: f64 = 1e-6;

/// Fit settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Filter half-width `K` (Method 1; Method 2 needs at least `2^L - 1`).
    pub half_width: usize,
    /// Method 2: number of dyadic parameters `L` (levels of the analysis used).
    pub levels: usize,
    /// Method 1: how the filters of negative correlations are signed (dissertation §4.2.4).
    pub negative_signs: NegativeSigns,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            half_width: 8,
            levels: 3,
            negative_signs: NegativeSigns::default(),
        }
    }
}

/// Why a model cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// The analysis has fewer levels than the method needs.
    #[error("{method} needs an analysis with {need} level(s), this one has {have}")]
    Levels {
        /// Method name.
        method: &'static str,
        /// Levels needed.
        need: usize,
        /// Levels present.
        have: usize,
    },
    /// A model's arrays do not fit in memory.
    #[error(transparent)]
    Alloc(#[from] crate::alloc::AllocError),
    /// The half-width truncates the dyadic filter.
    #[error("half_width {half_width} truncates a {levels}-level dyadic filter (needs {need})")]
    HalfWidth {
        /// Given half-width.
        half_width: usize,
        /// Dyadic levels.
        levels: usize,
        /// Needed half-width.
        need: usize,
    },
    /// Pixels whose mean or variance is NaN or infinite: a sample there is NaN or infinite (or
    /// the values are so large that their variance overflows), so no model can be fitted (a
    /// model's mean and standard deviation are finite everywhere, as `generate` requires).
    #[error(
        "the stack has NaN or infinite values at {count} of {total} pixel(s) ([row, column] \
         from 0: {}); a model needs a finite mean and variance at every pixel: replace \
         those values or crop them out of the stack before fitting",
        list_pixels(.pixels, .count)
    )]
    NonFinite {
        /// The first bad pixels, `(row, column)`, in row-major order (at most
        /// [`NON_FINITE_SHOWN`]).
        pixels: Vec<(usize, usize)>,
        /// How many pixels are bad.
        count: usize,
        /// The pixels of an image, `H * W`.
        total: usize,
    },
}

/// How many bad pixels [`FitError::NonFinite`] lists.
pub const NON_FINITE_SHOWN: usize = 10;

/// `[2, 5], [3, 1]`, and `, ...` when `count` pixels are more than those listed.
fn list_pixels(pixels: &[(usize, usize)], count: &usize) -> String {
    let mut text = pixels
        .iter()
        .map(|(i, j)| format!("[{i}, {j}]"))
        .collect::<Vec<_>>()
        .join(", ");
    if *count > pixels.len() {
        text.push_str(", ...");
    }
    text
}

/// Refuses an analysis with a NaN or infinite mean or variance at some pixel, naming the
/// pixels ([`FitError::NonFinite`]): the check [`fit`] makes first, so that `fit`, a run's
/// synthesis jobs and the CNN applications never write or use a model that `generate` (which
/// requires a finite mean and standard deviation) refuses.
///
/// # Errors
/// [`FitError::NonFinite`].
pub fn check_finite(analysis: &Analysis) -> Result<(), FitError> {
    let bad = ndarray::Zip::from(&analysis.mean)
        .and(&analysis.variance)
        .map_collect(|m, v| !(m.is_finite() && v.is_finite()));
    let count = bad.iter().filter(|&&b| b).count();
    if count == 0 {
        return Ok(());
    }
    let pixels = bad
        .indexed_iter()
        .filter(|&(_, &b)| b)
        .map(|(ij, _)| ij)
        .take(NON_FINITE_SHOWN)
        .collect();
    Err(FitError::NonFinite {
        pixels,
        count,
        total: bad.len(),
    })
}

/// Samples per task of the full-covariance sampler: each deviation panel serves this many
/// samples while it is in L1.
const FULL_COVARIANCE_BATCH: usize = 48;
