//! Slow, obviously correct reference implementations that the fast kernels are tested
//! against (in the spirit of RustFFT's naive DFT): the multiscale analysis computed (a) from
//! direct two-pass pair covariances and (b) by solving the 4x4 linear system of eq. 52 built
//! from the sample variances of the four Haar coefficients of every cell.
//!
//! Both work on an owned `[N, H, W]` complex f64 stack, materialise every level's unit images
//! and loop plainly; they are meant for small inputs.

use crate::stats::analysis::cell_directions;
use ndarray::{Array2, Array3};
use num_complex::Complex64;

/// Unit images of level `level` (1 = pixels): block sums of `2^(level-1)` square blocks.
pub fn unit_images(stack: &Array3<Complex64>, level: usize) -> Array3<Complex64> {
    let (n, h, w) = stack.dim();
    let g = 1usize << (level - 1);
    let (uh, uw) = (h / g, w / g);
    Array3::from_shape_fn((n, uh, uw), |(s, r, c)| {
        let mut sum = Complex64::new(0.0, 0.0);
        for i in 0..g {
            for j in 0..g {
                sum += stack[[s, r * g + i, c * g + j]];
            }
        }
        sum
    })
}

/// Two-pass sample mean of unit `(r, c)`.
fn unit_mean(units: &Array3<Complex64>, r: usize, c: usize) -> Complex64 {
    let n = units.dim().0;
    (0..n).map(|s| units[[s, r, c]]).sum::<Complex64>() / n as f64
}

/// `Re E[(a - mu_a) conj(b - mu_b)]` with `1/N` normalisation, two-pass.
pub fn pair_covariance(units: &Array3<Complex64>, a: (usize, usize), b: (usize, usize)) -> f64 {
    let n = units.dim().0;
    let (ma, mb) = (unit_mean(units, a.0, a.1), unit_mean(units, b.0, b.1));
    let sum: f64 = (0..n)
        .map(|s| ((units[[s, a.0, a.1]] - ma) * (units[[s, b.0, b.1]] - mb).conj()).re)
        .sum();
    sum / n as f64
}

/// Correlation and covariance maps `[H, V, D]` of one level from direct pair covariances.
pub fn direct_level(
    stack: &Array3<Complex64>,
    level: usize,
) -> ([Array2<f64>; 3], [Array2<f64>; 3]) {
    let units = unit_images(stack, level);
    let (_, uh, uw) = units.dim();
    let shape = (uh / 2, uw / 2);
    let mut corr: [Array2<f64>; 3] = std::array::from_fn(|_| Array2::zeros(shape));
    let mut cov: [Array2<f64>; 3] = std::array::from_fn(|_| Array2::zeros(shape));
    for r in 0..shape.0 {
        for c in 0..shape.1 {
            let stats = cell_directions(r, c, |a, b| pair_covariance(&units, a, b));
            for (d, (rho, cv)) in stats.into_iter().enumerate() {
                corr[d][[r, c]] = rho;
                cov[d][[r, c]] = cv;
            }
        }
    }
    (corr, cov)
}

/// Sample variance `E|x - mu|^2` (1/N) of a sequence of complex values.
fn variance(values: &[Complex64]) -> f64 {
    let n = values.len() as f64;
    let mu: Complex64 = values.iter().sum::<Complex64>() / n;
    values.iter().map(|v| (v - mu).norm_sqr()).sum::<f64>() / n
}

/// Solves `A x = b` for a 4x4 system by Gaussian elimination with partial pivoting.
pub fn solve4(mut a: [[f64; 4]; 4], mut b: [f64; 4]) -> [f64; 4] {
    for col in 0..4 {
        let pivot = (col..4)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .expect("non-empty range");
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..4 {
            let f = a[row][col] / a[col][col];
            let pivot_row = a[col];
            for (x, p) in a[row].iter_mut().zip(pivot_row).skip(col) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 4];
    for row in (0..4).rev() {
        let tail: f64 = (row + 1..4).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - tail) / a[row][row];
    }
    x
}

/// Correlation maps `[H, V, D]` of one level by the explicit 4x4 solve of eq. 52.
///
/// Haar coefficients of a cell with units `u1..u4`: `A = u1+u2+u3+u4`, `H = u1-u2+u3-u4`,
/// `V = u1+u2-u3-u4`, `D = u1-u2-u3+u4`. With `vA = sum s_i^2`, `vH = 2(s1 s2 + s3 s4)`,
/// `vV = 2(s1 s3 + s2 s4)`, `vD = 2(s1 s4 + s2 s3)` the coefficient variances satisfy
///
/// ```text
/// var H = vA - vH rhoH + vV rhoV - vD rhoD
/// var V = vA + vH rhoH - vV rhoV - vD rhoD
/// var D = vA - vH rhoH - vV rhoV + vD rhoD
/// var A = vA + vH rhoH + vV rhoV + vD rhoD
/// ```
///
/// (the signs of the printed filters `W_H`, `W_V`; the dissertation's printed eqs. 43-44, 49
/// and 54 flip those of `H` and `V`; docs/definitions.md §3).
/// The unknown vector is `[1, rhoH, rhoV, rhoD]`; its first entry is solved too and returned
/// as the fourth element of each cell's check value (it must come out as 1).
pub fn haar_solve_level(
    stack: &Array3<Complex64>,
    level: usize,
) -> ([Array2<f64>; 3], Array2<f64>) {
    let units = unit_images(stack, level);
    let (n, uh, uw) = units.dim();
    let shape = (uh / 2, uw / 2);
    let mut corr: [Array2<f64>; 3] = std::array::from_fn(|_| Array2::zeros(shape));
    let mut one = Array2::zeros(shape);
    for r in 0..shape.0 {
        for c in 0..shape.1 {
            let u = |s: usize, i: usize, j: usize| units[[s, 2 * r + i, 2 * c + j]];
            let coef = |signs: [f64; 4]| -> Vec<Complex64> {
                (0..n)
                    .map(|s| {
                        u(s, 0, 0) * signs[0]
                            + u(s, 0, 1) * signs[1]
                            + u(s, 1, 0) * signs[2]
                            + u(s, 1, 1) * signs[3]
                    })
                    .collect()
            };
            let var_h = variance(&coef([1.0, -1.0, 1.0, -1.0]));
            let var_v = variance(&coef([1.0, 1.0, -1.0, -1.0]));
            let var_d = variance(&coef([1.0, -1.0, -1.0, 1.0]));
            let var_a = variance(&coef([1.0, 1.0, 1.0, 1.0]));
            let sd: Vec<f64> = [(0, 0), (0, 1), (1, 0), (1, 1)]
                .iter()
                .map(|&(i, j)| variance(&(0..n).map(|s| u(s, i, j)).collect::<Vec<_>>()).sqrt())
                .collect();
            let va: f64 = sd.iter().map(|s| s * s).sum();
            let vh = 2.0 * (sd[0] * sd[1] + sd[2] * sd[3]);
            let vv = 2.0 * (sd[0] * sd[2] + sd[1] * sd[3]);
            let vd = 2.0 * (sd[0] * sd[3] + sd[1] * sd[2]);
            let m = [
                [va, -vh, vv, -vd],
                [va, vh, -vv, -vd],
                [va, -vh, -vv, vd],
                [va, vh, vv, vd],
            ];
            let x = solve4(m, [var_h, var_v, var_d, var_a]);
            for d in 0..3 {
                corr[d][[r, c]] = x[d + 1];
            }
            one[[r, c]] = x[0];
        }
    }
    (corr, one)
}
