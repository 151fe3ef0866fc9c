//! Method 1 (4.2): a spatially varying separable exponential filter, `alpha` per level-1
//! cell and direction found by inverting the filter's lag-1 correlation `g(alpha) = rho(1)`
//! (docs/definitions.md §5). Holds `g`, its peaks and its inverse, and the method itself.

use super::filter::{self, delegate_to_filtered, CellParams, FilterModel, Filtered};
use super::method::{
    ArrayStore, Cost, CostSize, Layout, Moments, Needs, Recorded, SynthesisMethod,
};
use super::options::{FitError, FitOptions};
use crate::stats::analysis::{Analysis, Direction};
use crate::stats::filters::{
    bank_bytes, exponential_taps, exponential_taps_signed, filter_flops, lag_correlation,
    NegativeSigns,
};
use ndarray::{Array2, ArrayView3};
use num_complex::{Complex32, Complex64};

/// Lag-1 correlation `g(alpha)` of the exponential filter of half-width `K` (a negative
/// `alpha` sign-alternating).
pub fn exponential_lag1(alpha: f64, half_width: usize) -> f64 {
    lag_correlation(&exponential_taps(alpha, half_width), 1)
}

/// [`exponential_lag1`] of a negative `alpha` signed by `signs`.
pub fn exponential_lag1_signed(alpha: f64, half_width: usize, signs: NegativeSigns) -> f64 {
    lag_correlation(&exponential_taps_signed(alpha, half_width, signs), 1)
}

/// The first peak `(alpha*, |g(-alpha*)|)` of the magnitude of the lag-1 correlation of a
/// negative-`alpha` filter signed by `signs`: [`exponential_peak`] for
/// [`NegativeSigns::Alternating`] (the mirror image of the positive branch); for
/// [`NegativeSigns::Multiscale`] the first local maximum of `|g|` over `alpha` (it is not
/// unimodal: for `K = 8` it peaks at about 0.507 near `alpha = 1.20`, dips and rises again
/// to below that), found on a grid of `log(alpha)` and refined by golden-section search.
/// `|g|` increases on `(0, alpha*]`, the branch Method 1 inverts.
pub fn negative_peak(half_width: usize, signs: NegativeSigns) -> (f64, f64) {
    if signs == NegativeSigns::Alternating {
        return exponential_peak(half_width);
    }
    let g = |la: f64| -exponential_lag1_signed(-la.exp(), half_width, signs);
    let (lo, hi, steps) = (1e-3f64.ln(), 1e6f64.ln(), 400);
    let at = |i: usize| lo + (hi - lo) * i as f64 / steps as f64;
    // Past the flat start (for tiny alpha every tap but the centre underflows to 0), up to
    // the first grid point the next one does not exceed.
    let mut i = 1;
    while i < steps && (g(at(i)) < 1e-12 || g(at(i + 1)) > g(at(i))) {
        i += 1;
    }
    let (mut a, mut b) = (at(i - 1), at((i + 1).min(steps)));
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..200 {
        let (x1, x2) = (b - phi * (b - a), a + phi * (b - a));
        if g(x1) < g(x2) {
            a = x1;
        } else {
            b = x2;
        }
        if b - a < 1e-12 {
            break;
        }
    }
    let alpha = (0.5 * (a + b)).exp();
    (alpha, g(alpha.ln()))
}

/// The peak `(alpha*, g(alpha*))` of `g(alpha)` for half-width `K`.
///
/// `g` looks monotone with supremum `g(inf) = 2K/(2K+1)`, but for a finite `K` it is not: the
/// truncated exponential's lag-1 correlation rises above the constant filter's and falls back
/// to it (`K = 8`: peak 0.9744 near `alpha = 6.45`, `g(inf) = 0.9412`; docs/definitions.md
/// §5). `g` is
/// monotone on `(0, alpha*]`, which is the branch Method 1 inverts. Golden-section search on
/// `log(alpha)`.
pub fn exponential_peak(half_width: usize) -> (f64, f64) {
    let g = |la: f64| exponential_lag1(la.exp(), half_width);
    let (mut lo, mut hi) = (1e-3f64.ln(), 1e6f64.ln());
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
    let (mut g1, mut g2) = (g(x1), g(x2));
    for _ in 0..200 {
        if g1 < g2 {
            lo = x1;
            (x1, g1) = (x2, g2);
            x2 = lo + phi * (hi - lo);
            g2 = g(x2);
        } else {
            hi = x2;
            (x2, g2) = (x1, g1);
            x1 = hi - phi * (hi - lo);
            g1 = g(x1);
        }
        if hi - lo < 1e-12 {
            break;
        }
    }
    let alpha = (0.5 * (lo + hi)).exp();
    (alpha, exponential_lag1(alpha, half_width))
}

/// Inverts `g(alpha) = rho(1)` of the exponential filter of half-width `K` on its monotone
/// branch (Method 1): returns `(alpha, clamped)`. Negative targets give negative alpha (the
/// sign-alternating filter), zero gives the delta filter (`alpha = 0`), NaN (masked data) the
/// delta filter, counted as clamped; `|rho|` above the peak of [`exponential_peak`] is
/// unreachable and clamps to `alpha*`. Bisection on `log(alpha)` to a relative width of
/// `1e-13` (docs/definitions.md §5).
pub fn invert_alpha(rho: f64, half_width: usize) -> (f64, bool) {
    invert_alpha_signed(rho, half_width, NegativeSigns::Alternating)
}

/// [`invert_alpha`] with negative targets inverted on the branch of filters signed by
/// `signs` ([`negative_peak`]): for [`NegativeSigns::Multiscale`], a target below about
/// -0.507 (`K = 8`) is unreachable and clamps.
pub fn invert_alpha_signed(rho: f64, half_width: usize, signs: NegativeSigns) -> (f64, bool) {
    AlphaInverter::new(half_width, signs).invert(rho)
}

/// Method 1's inversion of `g(alpha) = rho(1)` for one half-width and sign scheme, with the
/// peaks of both branches found once.
#[derive(Debug, Clone, Copy)]
pub struct AlphaInverter {
    half_width: usize,
    signs: NegativeSigns,
    /// `(alpha*, g(alpha*))` of the positive branch ([`exponential_peak`]).
    positive: (f64, f64),
    /// `(alpha*, |g(-alpha*)|)` of the negative branch ([`negative_peak`]).
    negative: (f64, f64),
}

impl AlphaInverter {
    /// The inverter of half-width `K` (the peaks are found when `K > 0`).
    pub fn new(half_width: usize, signs: NegativeSigns) -> AlphaInverter {
        let (positive, negative) = if half_width == 0 {
            ((0.0, 0.0), (0.0, 0.0))
        } else {
            let positive = exponential_peak(half_width);
            // The alternating branch mirrors the positive one: its peak is the same search.
            let negative = match signs {
                NegativeSigns::Alternating => positive,
                NegativeSigns::Multiscale => negative_peak(half_width, signs),
            };
            (positive, negative)
        };
        AlphaInverter {
            half_width,
            signs,
            positive,
            negative,
        }
    }

    /// `(alpha, clamped)` of target `rho` (see [`invert_alpha`]).
    pub fn invert(&self, rho: f64) -> (f64, bool) {
        let half_width = self.half_width;
        if rho.is_nan() || rho == 0.0 || half_width == 0 {
            return (0.0, rho.is_nan() || (half_width == 0 && rho != 0.0));
        }
        let (peak_alpha, peak_rho) = if rho > 0.0 {
            self.positive
        } else {
            self.negative
        };
        let target = rho.abs();
        if target >= peak_rho {
            return (peak_alpha.copysign(rho), target > peak_rho);
        }
        let g =
            |la: f64| exponential_lag1_signed(la.exp().copysign(rho), half_width, self.signs).abs();
        let (mut lo, mut hi) = (1e-3f64.ln(), peak_alpha.ln());
        if g(lo) >= target {
            return (lo.exp().copysign(rho), false);
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if g(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo < 1e-13 {
                break;
            }
        }
        ((0.5 * (lo + hi)).exp().copysign(rho), false)
    }
}

/// A fitted Method 1 model.
#[derive(Debug, Clone)]
pub struct Exponential {
    /// The filters (cell parameters [`CellParams::Exponential`]) and moments.
    pub filtered: Filtered,
}

impl Exponential {
    /// How its filters of negative `alpha` are signed.
    fn signs(&self) -> NegativeSigns {
        match &self.filtered.filter.params {
            CellParams::Exponential { signs, .. } => *signs,
            CellParams::Dyadic { .. } => unreachable!("a Method 1 model holds exponential cells"),
        }
    }
}

/// `alpha` per level-1 cell of one direction, with the unreached flags and the residuals.
fn invert_cells(
    analysis: &Analysis,
    dir: Direction,
    inverter: &AlphaInverter,
    k: usize,
    signs: NegativeSigns,
) -> (Array2<f64>, Array2<u8>, Array2<f64>) {
    let lm = &analysis.levels[0];
    let cells = lm.shape();
    let fitted: Vec<(f64, bool)> = lm
        .correlation(dir)
        .iter()
        .map(|&rho| inverter.invert(rho))
        .collect();
    let alpha =
        Array2::from_shape_vec(cells, fitted.iter().map(|p| p.0).collect()).expect("cell grid");
    let clamped = Array2::from_shape_vec(cells, fitted.iter().map(|p| p.1 as u8).collect())
        .expect("cell grid");
    let residual = Array2::from_shape_fn(cells, |rc| {
        let target = lm.correlation(dir)[rc];
        if target.is_nan() {
            f64::NAN
        } else {
            (exponential_lag1_signed(alpha[rc], k, signs) - target).abs()
        }
    });
    (alpha, clamped, residual)
}

impl SynthesisMethod for Exponential {
    const NAME: &'static str = "method1";
    const FILES: &'static [&'static str] = &[
        "alpha_h.npy",
        "alpha_v.npy",
        "residual_h.npy",
        "residual_v.npy",
        "clamped.npy",
    ];

    fn needs() -> Needs {
        Needs {
            levels: false,
            stack: false,
            half_width: true,
        }
    }

    fn model_order() -> Option<i64> {
        None
    }

    fn fit(
        moments: Moments,
        analysis: &Analysis,
        _stack: Option<ArrayView3<Complex64>>,
        opts: &FitOptions,
    ) -> Result<Self, FitError> {
        if analysis.levels.is_empty() {
            return Err(FitError::Levels {
                method: Self::NAME,
                need: 1,
                have: 0,
            });
        }
        let (k, signs) = (opts.half_width, opts.negative_signs);
        let inverter = AlphaInverter::new(k, signs);
        let (alpha_h, ch, residual_h) = invert_cells(analysis, Direction::H, &inverter, k, signs);
        let (alpha_v, cv, residual_v) = invert_cells(analysis, Direction::V, &inverter, k, signs);
        let params = CellParams::Exponential {
            alpha_h,
            alpha_v,
            signs,
        };
        let (h, w) = moments.mean.dim();
        let filter = FilterModel::new(params, (residual_h, residual_v), ch + cv, (k, h, w));
        Ok(Exponential {
            filtered: Filtered::new(moments, filter),
        })
    }

    delegate_to_filtered!();

    fn recorded(&self) -> Recorded {
        self.filtered.recorded(Some(self.signs()))
    }

    fn save(&self, store: &mut impl ArrayStore) -> anyhow::Result<()> {
        let CellParams::Exponential {
            alpha_h, alpha_v, ..
        } = &self.filtered.filter.params
        else {
            unreachable!("a Method 1 model holds exponential cells")
        };
        store.write("alpha_h.npy", alpha_h)?;
        store.write("alpha_v.npy", alpha_v)?;
        self.filtered.save_fit(store)
    }

    fn check(layout: &Layout) -> anyhow::Result<()> {
        Filtered::check_image(Self::NAME, layout)?;
        Filtered::check_work(layout)
    }

    fn load(moments: Moments, layout: &Layout, store: &impl ArrayStore) -> anyhow::Result<Self> {
        let alpha = |name| {
            store.read(
                name,
                filter::cells(layout),
                (&|a: &f64| !a.is_nan(), "alpha must not be NaN"),
            )
        };
        let params = CellParams::Exponential {
            alpha_h: alpha("alpha_h.npy")?,
            alpha_v: alpha("alpha_v.npy")?,
            signs: layout.negative_signs.unwrap_or(NegativeSigns::Alternating),
        };
        Ok(Exponential {
            filtered: Filtered::load_fit(moments, params, layout, store)?,
        })
    }

    fn cost(size: &CostSize) -> Cost {
        let (p, k) = (size.pixels, size.half_width);
        Cost {
            model_bytes: 24.0 * p + bank_bytes(p, k, true),
            // Per level-1 cell (P / 4) and direction, the inversion.
            fit_flops: p / 4.0 * 2.0 * 2e4,
            generate_flops: size.generated * p * filter_flops(k, true),
        }
    }
}
