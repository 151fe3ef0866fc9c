//! The slow, literal f64 reference of the CMD: the full P x P correlation matrices and the
//! distance from them, used by the tests of the fast path.

use super::terms::{CmdTerms, Form};
use num_complex::Complex;
/// Sample correlation matrix (P x P, row-major) of a row-major N x P stack,
/// literally: `R[p,q] = (1/N) sum_n conj(x_np - mu_p)(x_nq - mu_q) / (s_p s_q)`.
fn oracle_corr(x: &[Complex<f64>], n: usize, p: usize) -> Vec<Complex<f64>> {
    assert_eq!(x.len(), n * p);
    let nf = n as f64;
    let mu: Vec<Complex<f64>> = (0..p)
        .map(|q| (0..n).map(|s| x[s * p + q]).sum::<Complex<f64>>() / nf)
        .collect();
    let sd: Vec<f64> = (0..p)
        .map(|q| {
            ((0..n)
                .map(|s| (x[s * p + q] - mu[q]).norm_sqr())
                .sum::<f64>()
                / nf)
                .sqrt()
        })
        .collect();
    let mut r = vec![Complex::new(0.0, 0.0); p * p];
    for a in 0..p {
        for b in 0..p {
            let acc: Complex<f64> = (0..n)
                .map(|s| (x[s * p + a] - mu[a]).conj() * (x[s * p + b] - mu[b]))
                .sum();
            r[a * p + b] = acc / (nf * sd[a] * sd[b]);
        }
    }
    r
}

/// Oracle terms: forms R1 and R2 (P x P, f64 complex) directly from the raw
/// row-major samples (`x1`: n1 x p, `x2`: n2 x p) and evaluates `||R1||_F^2`,
/// `||R2||_F^2` and `tr(R1 R2)` literally. O(P^2 (N1 + N2)) in f64 with P x P
/// matrices; test-sized inputs only.
pub fn cmd_oracle_terms(
    x1: &[Complex<f64>],
    n1: usize,
    x2: &[Complex<f64>],
    n2: usize,
    p: usize,
) -> CmdTerms {
    let r1 = oracle_corr(x1, n1, p);
    let r2 = oracle_corr(x2, n2, p);
    let fro = |r: &[Complex<f64>]| r.iter().map(|z| z.norm_sqr()).sum::<f64>();
    let mut tr = Complex::new(0.0, 0.0);
    for a in 0..p {
        for b in 0..p {
            tr += r1[a * p + b] * r2[b * p + a];
        }
    }
    CmdTerms {
        norm1_sq: fro(&r1),
        norm2_sq: fro(&r2),
        cross: tr.re,
        form1: Form::Full,
        form2: Form::Full,
        form_cross: Form::Full,
    }
}

/// Slow, obviously correct oracle for the distance: forms R1 and R2 (P x P,
/// f64 complex) directly from the raw row-major samples and evaluates eq. 24
/// literally. Test-sized inputs only.
pub fn cmd_oracle(x1: &[Complex<f64>], n1: usize, x2: &[Complex<f64>], n2: usize, p: usize) -> f64 {
    cmd_oracle_terms(x1, n1, x2, n2, p).distance()
}
