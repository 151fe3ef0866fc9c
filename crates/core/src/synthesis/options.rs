//! The settings and failures every method shares: the fit options, the errors a fit reports
//! (the finite-values check first), and the sample formats this version generates.

use crate::stats::analysis::Analysis;
use crate::stats::filters::NegativeSigns;

/// The sample format of newly fitted models: 2 (ChaCha8 words, `f32` Box-Muller normals and
/// `f32` filtering; see [`super`]).
pub const SAMPLE_FORMAT: u32 = 2;

/// The sample formats this version generates.
pub const SAMPLE_FORMATS: [u32; 2] = [1, 2];

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
    /// The model's estimated size is above the memory limit: refused before fitting.
    #[error(
        "{method} with half_width {half_width} on a {height}x{width} image needs a model of \
         about {} (estimated before fitting), more than {limit}: lower half_width",
        crate::resources::human_bytes(*bytes)
    )]
    Memory {
        /// Method name.
        method: &'static str,
        /// Given half-width.
        half_width: usize,
        /// Image height.
        height: usize,
        /// Image width.
        width: usize,
        /// The model's estimated bytes.
        bytes: u64,
        /// The limit crossed, in words (`the machine's 23.4 GiB`).
        limit: String,
    },
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
