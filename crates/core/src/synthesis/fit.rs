//! Fitting a model to a stack: the exponential filter's lag-1 correlation and its inverse
//! (Method 1), the dyadic filter's correlations solved against the multiscale targets
//! (Method 2, Levenberg-Marquardt), the fourth-order moments, and [`fit`] itself.

use super::*;

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
pub(super) fn cell_of(i: usize, j: usize, cells: (usize, usize)) -> (usize, usize) {
    ((i / 2).min(cells.0 - 1), (j / 2).min(cells.1 - 1))
}

/// Fits `method` to a stack from its analysis (`stack` is needed by `full_covariance` only).
///
/// # Errors
/// [`FitError`] if the stack has NaN or infinite values ([`check_finite`]: the model would
/// hold a mean or standard deviation that is not finite), the analysis lacks levels the method
/// needs, or the model's arrays (the full-covariance deviations) do not fit in memory.
///
/// Long because it is the one match over the five methods, each arm a few lines.
pub fn fit(
    method: Method,
    analysis: &Analysis,
    stack: Option<ArrayView3<Complex64>>,
    opts: FitOptions,
) -> Result<Model, FitError> {
    super::check_finite(analysis)?;
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
        sample_format: SAMPLE_FORMAT,
        packed: Default::default(),
        fast: Default::default(),
        fourth_f32: Default::default(),
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
            let mut dev: Array3<Complex64> =
                crate::alloc::try_zeros(stack.dim(), "the full-covariance deviations")?;
            ndarray::Zip::indexed(&mut dev)
                .and(&stack)
                .for_each(|(_, i, j), d, &x| *d = (x - mu[[i, j]]) * scale);
            model.deviations = Some(dev);
        }
        Method::Method1 => {
            let lm = analysis.levels.first().ok_or(FitError::Levels {
                method: "method1",
                need: 1,
                have: 0,
            })?;
            let cells = lm.shape();
            let k = opts.half_width;
            let signs = opts.negative_signs;
            let inverter = AlphaInverter::new(k, signs);
            let invert = |dir: Direction| {
                let fitted: Vec<(f64, bool)> = lm
                    .correlation(dir)
                    .iter()
                    .map(|&rho| inverter.invert(rho))
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
                        (exponential_lag1_signed(alpha[rc], k, signs) - target).abs()
                    }
                });
                (alpha, clamped, residual)
            };
            let (alpha_h, ch, residual_h) = invert(Direction::H);
            let (alpha_v, cv, residual_v) = invert(Direction::V);
            let params = CellParams::Exponential {
                alpha_h,
                alpha_v,
                signs,
            };
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
