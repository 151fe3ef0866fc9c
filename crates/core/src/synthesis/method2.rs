//! Method 2 (4.3): a spatially varying separable dyadic filter, `r_1..r_L` per level-1 cell
//! and direction solved against the cell's level `1..L` ancestors' correlations
//! (Levenberg-Marquardt from several starts). Holds the dyadic filter's group correlations,
//! the solver and the method itself.

use super::filter::{self, delegate_to_filtered, CellParams, FilterModel, Filtered};
use super::method::{
    ArrayStore, Cost, CostSize, Layout, Moments, Needs, Recorded, SynthesisMethod,
};
use super::options::{FitError, FitOptions};
use crate::stats::analysis::{Analysis, Direction};
use crate::stats::filters::{bank_bytes, dyadic_taps, filter_flops, group_correlation};
use anyhow::Context;
use ndarray::{Array2, Array3, ArrayView3, Axis};
use num_complex::{Complex32, Complex64};
use rayon::prelude::*;

/// RMS misfit above which Method 2 counts a cell's target as unreached.
pub const UNREACHED: f64 = 1e-6;

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

/// A fitted Method 2 model.
#[derive(Debug, Clone)]
pub struct Dyadic {
    /// The filters (cell parameters [`CellParams::Dyadic`]) and moments.
    pub filtered: Filtered,
}

/// `r_1..r_L` per level-1 cell of one direction (`[L][rows][cols]`), with the residuals and
/// the unreached flags.
fn solve_cells(
    analysis: &Analysis,
    dir: Direction,
    l: usize,
    k: usize,
) -> (Vec<Array2<f64>>, Array2<f64>, Array2<u8>) {
    let cells = analysis.levels[0].shape();
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
}

impl SynthesisMethod for Dyadic {
    const NAME: &'static str = "method2";
    const FILES: &'static [&'static str] = &[
        "r_h.npy",
        "r_v.npy",
        "residual_h.npy",
        "residual_v.npy",
        "clamped.npy",
    ];

    fn needs() -> Needs {
        Needs {
            levels: true,
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
        let l = opts.levels;
        if analysis.levels.len() < l {
            return Err(FitError::Levels {
                method: Self::NAME,
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
        let (r_h, residual_h, ch) = solve_cells(analysis, Direction::H, l, k);
        let (r_v, residual_v, cv) = solve_cells(analysis, Direction::V, l, k);
        let params = CellParams::Dyadic { r_h, r_v };
        let (h, w) = moments.mean.dim();
        let filter = FilterModel::new(params, (residual_h, residual_v), ch + cv, (k, h, w));
        Ok(Dyadic {
            filtered: Filtered::new(moments, filter),
        })
    }

    delegate_to_filtered!();

    fn recorded(&self) -> Recorded {
        self.filtered.recorded(None)
    }

    fn save(&self, store: &mut impl ArrayStore) -> anyhow::Result<()> {
        let CellParams::Dyadic { r_h, r_v } = &self.filtered.filter.params else {
            unreachable!("a Method 2 model holds dyadic cells")
        };
        let stack = |p: &[Array2<f64>]| {
            ndarray::stack(Axis(0), &p.iter().map(|m| m.view()).collect::<Vec<_>>())
                .expect("equal cell grids")
        };
        store.write("r_h.npy", &stack(r_h))?;
        store.write("r_v.npy", &stack(r_v))?;
        self.filtered.save_fit(store)
    }

    fn check(layout: &Layout) -> anyhow::Result<()> {
        Filtered::check_image(Self::NAME, layout)?;
        let (h, w, k, levels) = (
            layout.height,
            layout.width,
            layout.half_width,
            layout.levels,
        );
        crate::stats::analysis::check_levels(levels, h, w)
            .with_context(|| format!("levels {levels}"))?;
        let reach = crate::stats::filters::dyadic_reach(levels);
        if k < reach {
            anyhow::bail!(
                "half_width {k} truncates a {levels}-level dyadic filter (needs {reach})"
            );
        }
        Filtered::check_work(layout)
    }

    fn load(moments: Moments, layout: &Layout, store: &impl ArrayStore) -> anyhow::Result<Self> {
        let (cells, _) = filter::cells(layout);
        let shape = vec![layout.levels, cells[0], cells[1]];
        let r = |name| -> anyhow::Result<Vec<Array2<f64>>> {
            let a: Array3<f64> = store.read(
                name,
                (
                    shape.clone(),
                    "levels and cell grid of model.json: [levels, height / 2, width / 2]",
                ),
                (&|r: &f64| r.is_finite(), "r must be finite"),
            )?;
            Ok(a.outer_iter().map(|m| m.to_owned()).collect())
        };
        let params = CellParams::Dyadic {
            r_h: r("r_h.npy")?,
            r_v: r("r_v.npy")?,
        };
        Ok(Dyadic {
            filtered: Filtered::load_fit(moments, params, layout, store)?,
        })
    }

    fn cost(size: &CostSize) -> Cost {
        let (p, k) = (size.pixels, size.half_width);
        Cost {
            model_bytes: 24.0 * p + bank_bytes(p, k, true),
            // Per level-1 cell (P / 4) and direction, the dyadic solve.
            fit_flops: p / 4.0 * 2.0 * 5e6,
            generate_flops: size.generated * p * filter_flops(k, true),
        }
    }
}
