//! What a synthesis method is: the [`SynthesisMethod`] trait every method's file implements
//! (its name, what its fit needs, fit, generate, its model folder's arrays, its cost), the
//! per-pixel moments every model holds, and the narrow interfaces a method sees of the world
//! around it (an [`ArrayStore`] to save and load its arrays, the [`Layout`] `model.json`
//! records). The registry in [`super`] lists the methods; nothing else names one.

use super::options::{FitError, FitOptions};
use crate::stats::analysis::Analysis;
use crate::stats::filters::NegativeSigns;
use ndarray::{Array, Array2, ArrayView3, Dimension};
use num_complex::{Complex32, Complex64};

/// The per-pixel mean and standard deviation every model reproduces by construction, and how
/// its samples are drawn from a seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Moments {
    /// Per-pixel mean.
    pub mean: Array2<Complex64>,
    /// Per-pixel standard deviation.
    pub std: Array2<f64>,
    /// How samples are drawn from a seed (1 or 2, see [`super`]); models fitted now use
    /// [`super::SAMPLE_FORMAT`].
    pub sample_format: u32,
}

/// What a method's fit reads besides the analysis's level-1 statistics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Needs {
    /// The analysis to the spec's `levels` (Method 2's dyadic parameters), not one level.
    pub levels: bool,
    /// The stack itself (full covariance, fourth order).
    pub stack: bool,
    /// The filter half-width (Methods 1 and 2).
    pub half_width: bool,
}

impl Needs {
    /// The analysis depth a fit with `levels` dyadic levels reads: `levels` if the method
    /// reads them, one level otherwise.
    pub fn depth(self, levels: usize) -> usize {
        if self.levels {
            levels
        } else {
            1
        }
    }
}

/// The sizes a method's cost depends on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostSize {
    /// Samples fitted, `N`.
    pub fitted: f64,
    /// Samples generated, `M`.
    pub generated: f64,
    /// Pixels of an image, `P`.
    pub pixels: f64,
    /// Filter half-width, `K`.
    pub half_width: f64,
}

/// What fitting and generating cost (the runner's estimates; docs/spec.md, estimates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cost {
    /// Bytes of the fitted model.
    pub model_bytes: f64,
    /// Operations of the fit.
    pub fit_flops: f64,
    /// Operations of generating the `M` samples.
    pub generate_flops: f64,
}

/// What `model.json` records that a method's arrays are checked against when loaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Image height.
    pub height: usize,
    /// Image width.
    pub width: usize,
    /// Filter half-width.
    pub half_width: usize,
    /// Dyadic levels.
    pub levels: usize,
    /// Samples fitted.
    pub samples_fitted: usize,
    /// Method 1: how the filters of negative `alpha` are signed (absent: alternating).
    pub negative_signs: Option<NegativeSigns>,
}

/// What a model tells `model.json` beyond its method and moments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Recorded {
    /// Directions of cells whose target was unreachable (Methods 1 and 2; 0 otherwise).
    pub clamped: u64,
    /// Method 1: how its filters of negative `alpha` are signed.
    pub negative_signs: Option<NegativeSigns>,
}

/// A check of every value of an array read back: the test and the rule it states.
pub type ValueCheck<'a, A> = (&'a dyn Fn(&A) -> bool, &'a str);

/// Where a model's named arrays are written and read back (a model folder's `.npy` files:
/// `crate::io::model` implements it).
pub trait ArrayStore {
    /// Writes `array` as `name`.
    ///
    /// # Errors
    /// If it cannot be written.
    fn write<A: ndarray_npy::WritableElement, D: Dimension>(
        &mut self,
        name: &'static str,
        array: &Array<A, D>,
    ) -> anyhow::Result<()>;

    /// Reads `name`, refusing it unless its shape is the expected one (with where that shape
    /// comes from) and every value passes `check`.
    ///
    /// # Errors
    /// If it is missing, mis-shaped, truncated or holds a value `check` refuses; the message
    /// names the file.
    fn read<A: ndarray_npy::ReadableElement + std::fmt::Debug, D: Dimension>(
        &self,
        name: &'static str,
        expected: (Vec<usize>, &'static str),
        check: ValueCheck<'_, A>,
    ) -> anyhow::Result<Array<A, D>>;
}

/// One synthesis method: a fitted model of it and everything the tool does with one. Each
/// method is one file implementing this trait and one line of the registry in [`super`]; no
/// function has a default, so a new method states every answer.
pub trait SynthesisMethod: Sized + Clone + std::fmt::Debug + Send + Sync {
    /// The name in specs, job ids, tables and `model.json`.
    const NAME: &'static str;
    /// The arrays its model folder holds besides `mean.npy` and `std.npy`.
    const FILES: &'static [&'static str];

    /// What its fit reads.
    fn needs() -> Needs;

    /// The per-pixel model a KL model-order test reads it as (`model_order` 2: mean and
    /// variance; 4: up to kurtosis), or `None` for a correlated model.
    fn model_order() -> Option<i64>;

    /// Fits it to a stack from its `analysis` (at [`Needs::depth`]) and `moments`; `stack` is
    /// given when [`Needs::stack`].
    ///
    /// # Errors
    /// [`FitError`] if the analysis lacks levels it needs, the options cannot hold its filter,
    /// or its arrays do not fit in memory.
    fn fit(
        moments: Moments,
        analysis: &Analysis,
        stack: Option<ArrayView3<Complex64>>,
        opts: &FitOptions,
    ) -> Result<Self, FitError>;

    /// Its moments.
    fn moments(&self) -> &Moments;

    /// Draws later samples in sample format `format` (1 or 2).
    fn set_sample_format(&mut self, format: u32);

    /// Samples `first ..` (as many as `out` holds, `H * W` each) as complex128, in parallel
    /// on the caller's rayon pool.
    fn generate_c128(&self, seed: u64, first: usize, out: &mut [Complex64]);

    /// Samples `first ..` as complex64 (the format of saved samples), in parallel on the
    /// caller's rayon pool.
    fn generate_c64(&self, seed: u64, first: usize, out: &mut [Complex32]);

    /// What `model.json` records of it.
    fn recorded(&self) -> Recorded;

    /// Writes its arrays ([`SynthesisMethod::FILES`]).
    ///
    /// # Errors
    /// If an array cannot be written.
    fn save(&self, store: &mut impl ArrayStore) -> anyhow::Result<()>;

    /// Checks the sizes `model.json` records before any array is read (a forged size is
    /// refused before anything is allocated).
    ///
    /// # Errors
    /// If the sizes cannot belong to a model of it.
    fn check(layout: &Layout) -> anyhow::Result<()>;

    /// Reads its arrays back, checked against `layout`.
    ///
    /// # Errors
    /// If an array is missing, mis-shaped or holds a value the model cannot hold.
    fn load(moments: Moments, layout: &Layout, store: &impl ArrayStore) -> anyhow::Result<Self>;

    /// What fitting it and generating from it cost.
    fn cost(size: &CostSize) -> Cost;
}
