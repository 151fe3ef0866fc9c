//! Fleishman's power method (Fleishman, 1978, "A method for simulating non-normal
//! distributions", Psychometrika 43): `Y = a + b Z + c Z^2 + d Z^3` with `Z ~ N(0, 1)` and
//! `a = -c` has mean 0, variance 1, skewness `g1` and excess kurtosis `g2` when
//!
//! ```text
//! b^2 + 6 b d + 2 c^2 + 15 d^2                                   = 1
//! 2 c (b^2 + 24 b d + 105 d^2 + 2)                               = g1
//! 24 [b d + c^2 (1 + b^2 + 28 b d) + d^2 (12 + 48 b d + 141 c^2 + 225 d^2)] = g2
//! ```
//!
//! The fourth-order model of the dissertation (ch. 3.2) fits it per pixel and component. Not
//! every `(g1, g2)` is reachable (roughly `g2 < 1.5 g1^2 - 1.2` is not): such a pair takes the
//! nearest feasible one found by raising `g2`, and is counted.

/// Coefficients `[a, b, c, d]`.
pub type Coefficients = [f64; 4];

/// Skewness and excess kurtosis of `Y` for coefficients `b, c, d` (and `a = -c`), with the
/// variance: `(variance, g1, g2)`.
pub fn moments(b: f64, c: f64, d: f64) -> (f64, f64, f64) {
    let var = b * b + 6.0 * b * d + 2.0 * c * c + 15.0 * d * d;
    let g1 = 2.0 * c * (b * b + 24.0 * b * d + 105.0 * d * d + 2.0);
    let g2 = 24.0
        * (b * d
            + c * c * (1.0 + b * b + 28.0 * b * d)
            + d * d * (12.0 + 48.0 * b * d + 141.0 * c * c + 225.0 * d * d));
    (var, g1, g2)
}

/// Newton's method on the three equations from `(b, c, d) = (1, 0, 0)`; `None` if it does
/// not converge to `1e-12`.
fn newton(g1: f64, g2: f64) -> Option<(f64, f64, f64)> {
    let mut x = [1.0, 0.0, 0.0];
    let f = |x: &[f64; 3]| {
        let (v, s, k) = moments(x[0], x[1], x[2]);
        [v - 1.0, s - g1, k - g2]
    };
    for _ in 0..100 {
        let r = f(&x);
        if r.iter().map(|v| v * v).sum::<f64>() < 1e-24 {
            return Some((x[0], x[1], x[2]));
        }
        let mut jac = [[0.0; 3]; 3];
        for k in 0..3 {
            let h = 1e-7 * (1.0 + x[k].abs());
            let mut xp = x;
            xp[k] += h;
            let rp = f(&xp);
            for i in 0..3 {
                jac[i][k] = (rp[i] - r[i]) / h;
            }
        }
        let dx = solve3(jac, [-r[0], -r[1], -r[2]])?;
        // Damped step: halve until the residual decreases.
        let norm = |r: &[f64; 3]| r.iter().map(|v| v * v).sum::<f64>();
        let mut t = 1.0;
        loop {
            let trial = [x[0] + t * dx[0], x[1] + t * dx[1], x[2] + t * dx[2]];
            if norm(&f(&trial)) < norm(&r) || t < 1e-6 {
                x = trial;
                break;
            }
            t *= 0.5;
        }
    }
    let r = f(&x);
    (r.iter().map(|v| v * v).sum::<f64>() < 1e-20).then_some((x[0], x[1], x[2]))
}

fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-300 || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *xk = det(m) / d;
    }
    Some(x)
}

/// Coefficients for skewness `g1` and excess kurtosis `g2`, and whether the pair had to be
/// moved to the feasible region (then `g2` is raised in steps until Newton converges).
pub fn coefficients(g1: f64, g2: f64) -> (Coefficients, bool) {
    if !(g1.is_finite() && g2.is_finite()) {
        return ([0.0, 1.0, 0.0, 0.0], true);
    }
    let mut k = g2;
    for step in 0..200 {
        if let Some((b, c, d)) = newton(g1, k) {
            return ([-c, b, c, d], step > 0);
        }
        k = k.max(1.5 * g1 * g1 - 1.2) + 0.05 * (1.0 + step as f64);
    }
    ([0.0, 1.0, 0.0, 0.0], true)
}

/// `Y = a + b z + c z^2 + d z^3`.
#[inline]
pub fn transform(coef: &Coefficients, z: f64) -> f64 {
    coef[0] + z * (coef[1] + z * (coef[2] + z * coef[3]))
}

/// Sample mean, variance (`1/N`), skewness and excess kurtosis of a sequence.
pub fn sample_moments(x: impl Iterator<Item = f64> + Clone) -> (f64, f64, f64, f64) {
    let n = x.clone().count() as f64;
    let mean = x.clone().sum::<f64>() / n;
    let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
    for v in x {
        let d = v - mean;
        m2 += d * d;
        m3 += d * d * d;
        m4 += d * d * d * d;
    }
    let (m2, m3, m4) = (m2 / n, m3 / n, m4 / n);
    if m2 == 0.0 {
        return (mean, 0.0, 0.0, 0.0);
    }
    (mean, m2, m3 / m2.powf(1.5), m4 / (m2 * m2) - 3.0)
}
