//! Correlation matrix distance (Herdin, eq. 24) through the Gram identity. PLACEHOLDER: a
//! straightforward implementation with the final API, replaced by the blocked kernel.

use num_complex::Complex;
use rayon::prelude::*;

/// Centred, per-pixel normalised, `1/sqrt(N)`-scaled data of one stack, planar f32, row-major
/// `N x P`.
pub struct Normalised {
    /// Samples `N`.
    pub n: usize,
    /// Pixels `P`.
    pub p: usize,
    /// Real parts.
    pub re: Vec<f32>,
    /// Imaginary parts.
    pub im: Vec<f32>,
}

impl Normalised {
    /// Builds `A` from `get(n, p) -> (re, im)` for the pixels listed in `pixels`.
    pub fn from_fn(
        n: usize,
        pixels: &[usize],
        get: impl Fn(usize, usize) -> (f64, f64) + Sync,
    ) -> Self {
        let p = pixels.len();
        let mut re = vec![0f32; n * p];
        let mut im = vec![0f32; n * p];
        for (k, &px) in pixels.iter().enumerate() {
            let (mut sr, mut si) = (0.0, 0.0);
            for s in 0..n {
                let (a, b) = get(s, px);
                sr += a;
                si += b;
            }
            let (mr, mi) = (sr / n as f64, si / n as f64);
            let mut v = 0.0;
            for s in 0..n {
                let (a, b) = get(s, px);
                v += (a - mr).powi(2) + (b - mi).powi(2);
            }
            let scale = 1.0 / (v / n as f64).sqrt() / (n as f64).sqrt();
            for s in 0..n {
                let (a, b) = get(s, px);
                re[s * p + k] = ((a - mr) * scale) as f32;
                im[s * p + k] = ((b - mi) * scale) as f32;
            }
        }
        Normalised { n, p, re, im }
    }
}

/// Which form computed a quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// The `N x N` (or `N1 x N2`) Gram form.
    Gram,
    /// The `P x P` form.
    Full,
}

/// The three terms of eq. 24.
#[derive(Debug, Clone, Copy)]
pub struct CmdTerms {
    /// `||R1||_F^2`.
    pub norm1_sq: f64,
    /// `||R2||_F^2`.
    pub norm2_sq: f64,
    /// `tr(R1 R2)`.
    pub cross: f64,
    /// Form of `norm1_sq`.
    pub form1: Form,
    /// Form of `norm2_sq`.
    pub form2: Form,
    /// Form of `cross`.
    pub form_cross: Form,
}

impl CmdTerms {
    /// Eq. 24.
    pub fn distance(&self) -> f64 {
        1.0 - self.cross / (self.norm1_sq.sqrt() * self.norm2_sq.sqrt())
    }
}

fn gram_sq(a: &Normalised, b: &Normalised) -> f64 {
    let p = a.p;
    (0..a.n)
        .into_par_iter()
        .map(|i| {
            let mut s = 0.0;
            for j in 0..b.n {
                let (mut re, mut im) = (0.0f64, 0.0f64);
                for k in 0..p {
                    let (ar, ai) = (a.re[i * p + k] as f64, a.im[i * p + k] as f64);
                    let (br, bi) = (b.re[j * p + k] as f64, b.im[j * p + k] as f64);
                    re += ar * br + ai * bi;
                    im += ai * br - ar * bi;
                }
                s += re * re + im * im;
            }
            s
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum()
}

/// The three terms (placeholder: Gram form throughout).
pub fn cmd_terms(a1: &Normalised, a2: &Normalised) -> CmdTerms {
    CmdTerms {
        norm1_sq: gram_sq(a1, a1),
        norm2_sq: gram_sq(a2, a2),
        cross: gram_sq(a1, a2),
        form1: Form::Gram,
        form2: Form::Gram,
        form_cross: Form::Gram,
    }
}

/// Slow oracle: forms `R1`, `R2` (`P x P`) and evaluates eq. 24 literally.
pub fn cmd_oracle(x1: &[Complex<f64>], n1: usize, x2: &[Complex<f64>], n2: usize, p: usize) -> f64 {
    let corr = |x: &[Complex<f64>], n: usize| {
        let mu: Vec<Complex<f64>> = (0..p)
            .map(|k| (0..n).map(|s| x[s * p + k]).sum::<Complex<f64>>() / n as f64)
            .collect();
        let mut r = vec![Complex::new(0.0, 0.0); p * p];
        for i in 0..p {
            for j in 0..p {
                r[i * p + j] = (0..n)
                    .map(|s| (x[s * p + i] - mu[i]).conj() * (x[s * p + j] - mu[j]))
                    .sum::<Complex<f64>>()
                    / n as f64;
            }
        }
        let d: Vec<f64> = (0..p).map(|i| r[i * p + i].re.sqrt()).collect();
        for i in 0..p {
            for j in 0..p {
                r[i * p + j] /= d[i] * d[j];
            }
        }
        r
    };
    let (r1, r2) = (corr(x1, n1), corr(x2, n2));
    let mut tr = Complex::new(0.0, 0.0);
    for i in 0..p {
        for j in 0..p {
            tr += r1[i * p + j] * r2[j * p + i];
        }
    }
    let f = |r: &[Complex<f64>]| r.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt();
    1.0 - tr.re / (f(&r1) * f(&r2))
}
