//! Synthesis (dissertation ch. 4, SPEC-NOTES section 4): fit a model to a stack once, then
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
//! Sample `s` of a generation with seed `seed` draws from ChaCha20 seeded with `seed` on
//! stream `s`, so any sample can be regenerated alone and output never depends on threads.

use crate::stats::analysis::{Analysis, Direction};
use crate::stats::filters::{
    dyadic_taps, exponential_taps, filter_seed, group_correlation, lag_correlation, FilterBank,
};
use ndarray::{Array2, Array3, ArrayView3};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

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
    /// Method 1: `alpha` per direction (negative: sign-alternating; 0: delta; inf: constant).
    Exponential {
        /// Horizontal alpha per cell.
        alpha_h: Array2<f64>,
        /// Vertical alpha per cell.
        alpha_v: Array2<f64>,
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
                    CellParams::Exponential { alpha_h, alpha_v } => (
                        exponential_taps(alpha_v[c], k),
                        exponential_taps(alpha_h[c], k),
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
    /// Full covariance: `deviations` packed for the sampler's kernel, made on first use.
    pub(crate) packed: std::sync::OnceLock<crate::stats::lowrank::Panels>,
}

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
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            half_width: 8,
            levels: 3,
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
}

/// Lag-1 correlation `g(alpha)` of the exponential filter of half-width `K`.
pub fn exponential_lag1(alpha: f64, half_width: usize) -> f64 {
    lag_correlation(&exponential_taps(alpha, half_width), 1)
}

/// The peak `(alpha*, g(alpha*))` of `g(alpha)` for half-width `K`.
///
/// SPEC-NOTES calls `g` monotone with supremum `g(inf) = 2K/(2K+1)`; for a finite `K` it is
/// not: the truncated exponential's lag-1 correlation rises above the constant filter's and
/// falls back to it (`K = 8`: peak 0.9743 near `alpha = 6.2`, `g(inf) = 0.9412`). `g` is
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
/// `1e-13`, far inside the `1e-6` error SPEC-NOTES asks for.
pub fn invert_alpha(rho: f64, half_width: usize) -> (f64, bool) {
    if rho.is_nan() || rho == 0.0 || half_width == 0 {
        return (0.0, rho.is_nan() || (half_width == 0 && rho != 0.0));
    }
    let (peak_alpha, peak_rho) = exponential_peak(half_width);
    let target = rho.abs();
    if target >= peak_rho {
        return (peak_alpha.copysign(rho), target > peak_rho);
    }
    let g = |la: f64| exponential_lag1(la.exp(), half_width);
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

/// Group correlations of a dyadic filter at levels `1..=L` (`g = 2^(l-1)`).
pub fn dyadic_correlations(r: &[f64], half_width: usize) -> Vec<f64> {
    let taps = dyadic_taps(r, half_width);
    (0..r.len())
        .map(|l| group_correlation(&taps, 1 << l))
        .collect()
}

/// Solves the dyadic parameters `r` whose group correlations at levels `1..=L` match
/// `targets` (Method 2): damped Gauss-Newton (Levenberg-Marquardt) with a finite-difference
/// Jacobian and bounds `|r_l| <= bound`, from several starts; among solutions within `tol` of
/// the targets the one with the smallest `|r|` wins, otherwise the best fit. Returns
/// `(r, rms residual)`.
pub fn solve_dyadic(targets: &[f64], half_width: usize) -> (Vec<f64>, f64) {
    const BOUND: f64 = 8.0;
    const TOL: f64 = 1e-9;
    let l = targets.len();
    let residual = |r: &[f64]| -> Vec<f64> {
        dyadic_correlations(r, half_width)
            .iter()
            .zip(targets)
            .map(|(g, t)| g - t)
            .collect()
    };
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
    let mut starts: Vec<Vec<f64>> = vec![vec![0.0; l]];
    // A start shaped like the targets, and a few scaled/sign-flipped variants.
    for scale in [0.5, 1.0, 2.0] {
        starts.push(
            targets
                .iter()
                .map(|t| (t * scale).clamp(-BOUND, BOUND))
                .collect(),
        );
    }
    starts.push(targets.iter().map(|t| -t).collect());
    let mut best: Option<(Vec<f64>, f64)> = None;
    let mut best_ok: Option<(Vec<f64>, f64)> = None;
    for start in starts {
        let (r, res) = levenberg_marquardt(start, &residual, BOUND);
        let rms = (norm(&res) / l as f64).sqrt();
        if rms < TOL.sqrt() && best_ok.as_ref().is_none_or(|(b, _)| norm(&r) < norm(b)) {
            best_ok = Some((r.clone(), rms));
        }
        if best.as_ref().is_none_or(|(_, b)| rms < *b) {
            best = Some((r, rms));
        }
    }
    best_ok.or(best).expect("at least one start")
}

/// Box-bounded Levenberg-Marquardt on a small residual vector.
fn levenberg_marquardt(
    mut x: Vec<f64>,
    f: &impl Fn(&[f64]) -> Vec<f64>,
    bound: f64,
) -> (Vec<f64>, Vec<f64>) {
    let n = x.len();
    let mut res = f(&x);
    let cost = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let mut lambda = 1e-3;
    for _ in 0..200 {
        let c0 = cost(&res);
        if c0 < 1e-24 {
            break;
        }
        // Forward-difference Jacobian.
        let jac: Vec<Vec<f64>> = (0..n)
            .map(|k| {
                let h = 1e-7 * (1.0 + x[k].abs());
                let mut xp = x.clone();
                xp[k] += h;
                f(&xp).iter().zip(&res).map(|(a, b)| (a - b) / h).collect()
            })
            .collect();
        // Normal equations (J^T J + lambda diag) dx = -J^T r.
        let m = res.len();
        let mut a = vec![vec![0.0; n]; n];
        let mut g = vec![0.0; n];
        for i in 0..n {
            for j in 0..n {
                a[i][j] = (0..m).map(|k| jac[i][k] * jac[j][k]).sum();
            }
            g[i] = -(0..m).map(|k| jac[i][k] * res[k]).sum::<f64>();
        }
        let mut improved = false;
        for _ in 0..20 {
            let mut damped = a.clone();
            for i in 0..n {
                damped[i][i] += lambda * (a[i][i] + 1e-12);
            }
            let Some(dx) = solve_small(damped, g.clone()) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = x
                .iter()
                .zip(&dx)
                .map(|(v, d)| (v + d).clamp(-bound, bound))
                .collect();
            let tr = f(&trial);
            if cost(&tr) < c0 {
                x = trial;
                res = tr;
                lambda = (lambda / 10.0).max(1e-12);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (x, res)
}

/// Samples per task of the full-covariance sampler: each deviation panel serves this many
/// samples while it is in L1.
const FULL_COVARIANCE_BATCH: usize = 48;

/// Gaussian elimination with partial pivoting for a small dense system.
fn solve_small(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let p = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[p][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, p);
        b.swap(col, p);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            let pivot = a[col].clone();
            for (x, y) in a[row].iter_mut().zip(pivot).skip(col) {
                *x -= f * y;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let tail: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - tail) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Fits Fleishman's power method per pixel and component (real, imaginary) to the stack's
/// mean, variance, skewness and excess kurtosis.
fn fit_fourth_order(stack: ArrayView3<Complex64>) -> FourthOrderModel {
    let (_, h, w) = stack.dim();
    let mut coefficients = ndarray::Array4::zeros((2, 4, h, w));
    let mut component_sd = Array3::zeros((2, h, w));
    let mut infeasible = Array3::zeros((2, h, w));
    for i in 0..h {
        for j in 0..w {
            let px = stack.slice(ndarray::s![.., i, j]);
            for comp in 0..2 {
                let values = px.iter().map(move |z| if comp == 0 { z.re } else { z.im });
                let (_, var, g1, g2) = crate::stats::fleishman::sample_moments(values);
                let (coef, moved) = if var > 0.0 {
                    crate::stats::fleishman::coefficients(g1, g2)
                } else {
                    ([0.0, 1.0, 0.0, 0.0], false)
                };
                for (k, c) in coef.iter().enumerate() {
                    coefficients[[comp, k, i, j]] = *c;
                }
                component_sd[[comp, i, j]] = var.sqrt();
                infeasible[[comp, i, j]] = u8::from(moved);
            }
        }
    }
    FourthOrderModel {
        coefficients,
        component_sd,
        infeasible,
    }
}

/// The level-1 cell whose parameters pixel `(i, j)` takes (the nearest complete cell for an
/// odd last row or column).
fn cell_of(i: usize, j: usize, cells: (usize, usize)) -> (usize, usize) {
    ((i / 2).min(cells.0 - 1), (j / 2).min(cells.1 - 1))
}

/// Fits `method` to a stack from its analysis (`stack` is needed by `full_covariance` only).
///
/// # Errors
/// [`FitError`] if the analysis lacks levels the method needs.
pub fn fit(
    method: Method,
    analysis: &Analysis,
    stack: Option<ArrayView3<Complex64>>,
    opts: FitOptions,
) -> Result<Model, FitError> {
    let mean = analysis.mean.clone();
    let std = analysis.variance.mapv(f64::sqrt);
    let (h, w) = mean.dim();
    let mut model = Model {
        method,
        mean,
        std,
        filter: None,
        deviations: None,
        fourth: None,
        packed: Default::default(),
    };
    match method {
        Method::Uncorrelated => {}
        Method::FourthOrder => {
            let stack = stack.expect("fourth_order is fitted from the stack itself");
            model.fourth = Some(fit_fourth_order(stack));
        }
        Method::FullCovariance => {
            let stack = stack.expect("full_covariance is fitted from the stack itself");
            let n = stack.dim().0;
            let scale = 1.0 / (n as f64).sqrt();
            let mu = &model.mean;
            model.deviations = Some(Array3::from_shape_fn(stack.dim(), |(s, i, j)| {
                (stack[[s, i, j]] - mu[[i, j]]) * scale
            }));
        }
        Method::Method1 => {
            let lm = analysis.levels.first().ok_or(FitError::Levels {
                method: "method1",
                need: 1,
                have: 0,
            })?;
            let cells = lm.shape();
            let k = opts.half_width;
            let invert = |dir: Direction| {
                let fitted: Vec<(f64, bool)> = lm
                    .correlation(dir)
                    .iter()
                    .map(|&rho| invert_alpha(rho, k))
                    .collect();
                let alpha = Array2::from_shape_vec(cells, fitted.iter().map(|p| p.0).collect())
                    .expect("cell grid");
                let clamped =
                    Array2::from_shape_vec(cells, fitted.iter().map(|p| p.1 as u8).collect())
                        .expect("cell grid");
                let residual = Array2::from_shape_fn(cells, |rc| {
                    let target = lm.correlation(dir)[rc];
                    if target.is_nan() {
                        f64::NAN
                    } else {
                        (exponential_lag1(alpha[rc], k) - target).abs()
                    }
                });
                (alpha, clamped, residual)
            };
            let (alpha_h, ch, residual_h) = invert(Direction::H);
            let (alpha_v, cv, residual_v) = invert(Direction::V);
            let params = CellParams::Exponential { alpha_h, alpha_v };
            model.filter = Some(FilterModel::new(
                params,
                (residual_h, residual_v),
                ch + cv,
                (k, h, w),
            ));
        }
        Method::Method2 => {
            let l = opts.levels;
            if analysis.levels.len() < l {
                return Err(FitError::Levels {
                    method: "method2",
                    need: l,
                    have: analysis.levels.len(),
                });
            }
            let need = crate::stats::filters::dyadic_reach(l);
            if opts.half_width < need {
                return Err(FitError::HalfWidth {
                    half_width: opts.half_width,
                    levels: l,
                    need,
                });
            }
            let k = opts.half_width;
            let cells = analysis.levels[0].shape();
            let solve = |dir: Direction| {
                let fits: Vec<(Vec<f64>, f64)> = (0..cells.0 * cells.1)
                    .into_par_iter()
                    .map(|idx| {
                        let (r, c) = (idx / cells.1, idx % cells.1);
                        let targets: Vec<f64> = (0..l)
                            .map(|lv| {
                                let m = analysis.levels[lv].correlation(dir);
                                let (mr, mc) = m.dim();
                                m[[(r >> lv).min(mr - 1), (c >> lv).min(mc - 1)]]
                            })
                            .collect();
                        if targets.iter().any(|t| t.is_nan()) {
                            return (vec![0.0; l], f64::NAN);
                        }
                        solve_dyadic(&targets, k)
                    })
                    .collect();
                let params: Vec<Array2<f64>> = (0..l)
                    .map(|lv| Array2::from_shape_fn(cells, |(r, c)| fits[r * cells.1 + c].0[lv]))
                    .collect();
                let residual = Array2::from_shape_fn(cells, |(r, c)| fits[r * cells.1 + c].1);
                let clamped = residual.mapv(|e| u8::from(e.is_nan() || e >= UNREACHED));
                (params, residual, clamped)
            };
            let (r_h, residual_h, ch) = solve(Direction::H);
            let (r_v, residual_v, cv) = solve(Direction::V);
            let params = CellParams::Dyadic { r_h, r_v };
            model.filter = Some(FilterModel::new(
                params,
                (residual_h, residual_v),
                ch + cv,
                (k, h, w),
            ));
        }
    }
    Ok(model)
}

impl Model {
    /// Image size `(H, W)`.
    pub fn shape(&self) -> (usize, usize) {
        self.mean.dim()
    }

    /// Writes sample `index` of the generation seeded by `seed` into `out` (`H * W`).
    pub fn sample_into(&self, seed: u64, index: usize, out: &mut [Complex64]) {
        let (h, w) = self.shape();
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        rng.set_stream(index as u64);
        match (&self.filter, &self.deviations) {
            (Some(f), _) => {
                let k = f.bank.half_width;
                let white = crate::seeds::white_seed(seed, index, h + 2 * k, w + 2 * k);
                filter_seed(&f.bank, white.view(), out);
                let (mean, std) = (
                    self.mean.as_slice().expect("standard layout"),
                    self.std.as_slice().expect("standard layout"),
                );
                for (((x, sd), mu), s) in out.iter_mut().zip(f.bank.output_sds()).zip(mean).zip(std)
                {
                    *x = mu + *x * (s / sd);
                }
            }
            (None, Some(_)) => self.full_covariance_c128(seed, index, out),
            (None, None) if self.fourth.is_some() => {
                let f = self.fourth.as_ref().expect("checked");
                for (p, x) in out.iter_mut().enumerate() {
                    let (i, j) = (p / w, p % w);
                    let part = |comp: usize, z: f64| {
                        let coef = [0, 1, 2, 3].map(|k| f.coefficients[[comp, k, i, j]]);
                        f.component_sd[[comp, i, j]] * crate::stats::fleishman::transform(&coef, z)
                    };
                    let (zr, zi): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    *x = self.mean[[i, j]] + Complex64::new(part(0, zr), part(1, zi));
                }
            }
            (None, None) => {
                let scale = std::f64::consts::FRAC_1_SQRT_2;
                for (p, x) in out.iter_mut().enumerate() {
                    let (re, im): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    let s = self.std[[p / w, p % w]] * scale;
                    *x = self.mean[[p / w, p % w]] + Complex64::new(re * s, im * s);
                }
            }
        }
    }

    /// Full covariance: the deviation sums `sum_k z_k d_k` of samples `first .. first + count`
    /// into `acc` (`count x 2P` f32, real and imaginary parts interleaved), `z_k` the sample's
    /// normals drawn in order from its ChaCha20 stream (see [`crate::stats::lowrank`] for the
    /// arithmetic, which does not depend on `count`).
    fn full_covariance_sums(
        &self,
        seed: u64,
        first: usize,
        count: usize,
        acc: &mut [f32],
        finish: impl Fn(usize, &mut [f32]),
    ) {
        let dev = self.deviations.as_ref().expect("a full-covariance model");
        let panels = self
            .packed
            .get_or_init(|| crate::stats::lowrank::Panels::new(dev.view()));
        let n = panels.n();
        let mut z = vec![0.0f32; count * n];
        for (c, zc) in z.chunks_exact_mut(n.max(1)).enumerate() {
            let mut rng = ChaCha20Rng::seed_from_u64(seed);
            rng.set_stream((first + c) as u64);
            for v in zc {
                let x: f64 = StandardNormal.sample(&mut rng);
                *v = x as f32;
            }
        }
        crate::stats::lowrank::combine_then(panels, &z, count, acc, finish);
    }

    /// Full covariance: samples `first ..` (as many as `out` holds, `H * W` each) in complex128,
    /// the mean plus the f32 deviation sums.
    fn full_covariance_c128(&self, seed: u64, first: usize, out: &mut [Complex64]) {
        let p = self.mean.len();
        let mut acc = vec![0.0f32; 2 * out.len()];
        self.full_covariance_sums(seed, first, out.len() / p, &mut acc, |_, _| {});
        let mean = self.mean.as_slice().expect("standard layout");
        for (i, (x, a)) in out.iter_mut().zip(acc.chunks_exact(2)).enumerate() {
            *x = mean[i % p] + Complex64::new(f64::from(a[0]), f64::from(a[1]));
        }
    }

    /// Generates samples `first .. first + count` as complex64 (the format of saved samples),
    /// in parallel on the caller's rayon pool; each sample is computed in f64 and rounded.
    pub fn generate_c64(
        &self,
        seed: u64,
        first: usize,
        count: usize,
    ) -> Array3<num_complex::Complex<f32>> {
        let (h, w) = self.shape();
        let mut out = Array3::from_elem((count, h, w), num_complex::Complex::new(0.0f32, 0.0));
        if let (None, Some(_)) = (&self.filter, &self.deviations) {
            let mean: &[f64] = bytemuck::cast_slice(self.mean.as_slice().expect("standard layout"));
            let flat: &mut [f32] =
                bytemuck::cast_slice_mut(out.as_slice_mut().expect("standard layout"));
            flat.par_chunks_mut(FULL_COVARIANCE_BATCH * 2 * h * w)
                .enumerate()
                .for_each(|(b, block)| {
                    let count = block.len() / (2 * h * w);
                    self.full_covariance_sums(
                        seed,
                        first + b * FULL_COVARIANCE_BATCH,
                        count,
                        block,
                        |c0, values| {
                            for (x, mu) in values.iter_mut().zip(&mean[c0..]) {
                                *x = (mu + f64::from(*x)) as f32;
                            }
                        },
                    );
                });
            return out;
        }
        out.as_slice_mut()
            .expect("standard layout")
            .par_chunks_mut(h * w)
            .enumerate()
            .for_each_init(
                || vec![Complex64::new(0.0, 0.0); h * w],
                |buf, (s, plane)| {
                    self.sample_into(seed, first + s, buf);
                    for (o, x) in plane.iter_mut().zip(buf.iter()) {
                        *o = num_complex::Complex::new(x.re as f32, x.im as f32);
                    }
                },
            );
        out
    }

    /// Generates samples `first .. first + count` of the generation seeded by `seed`, in
    /// parallel on the caller's rayon pool.
    pub fn generate(&self, seed: u64, first: usize, count: usize) -> Array3<Complex64> {
        let (h, w) = self.shape();
        let mut out = Array3::zeros((count, h, w));
        if let (None, Some(_)) = (&self.filter, &self.deviations) {
            out.as_slice_mut()
                .expect("standard layout")
                .par_chunks_mut(FULL_COVARIANCE_BATCH * h * w)
                .enumerate()
                .for_each(|(b, block)| {
                    self.full_covariance_c128(seed, first + b * FULL_COVARIANCE_BATCH, block)
                });
            return out;
        }
        out.as_slice_mut()
            .expect("standard layout")
            .par_chunks_mut(h * w)
            .enumerate()
            .for_each(|(s, plane)| self.sample_into(seed, first + s, plane));
        out
    }
}
