//! What the CMD computes on: a stack centred, normalised per pixel and packed as planar f32
//! ([`Normalised`]), the forms a term may take ([`Form`]) and the three sums of squares the
//! distance is made of ([`CmdTerms`]).

use rayon::prelude::*;

/// Centred, per-pixel normalised, 1/sqrt(N)-scaled data of one stack, planar
/// f32 (`re` and `im`), row-major N x P: `A[n, p] = re[n * p_count + p] + i
/// im[...]`, with `A[n, p] = (x_np - mu_p) / (s_p sqrt(N))`, so that
/// `R = A^H A` is the sample correlation matrix (unit diagonal).
#[derive(Debug, Clone)]
pub struct Normalised {
    /// Number of samples N (rows).
    pub n: usize,
    /// Number of pixels P kept (columns).
    pub p: usize,
    /// Real parts, row-major N x P.
    pub re: Vec<f32>,
    /// Imaginary parts, row-major N x P.
    pub im: Vec<f32>,
}

impl Normalised {
    /// Builds A from samples given by a closure; means and variances are
    /// computed in f64 (one pass of sums shifted by each pixel's first
    /// sample, then one pass to write A), the result is stored in f32.
    ///
    /// `get(n, p)` returns (re, im) of sample `n` (0..n) at pixel index `p`;
    /// `pixels` lists the pixel indices to keep, in order (column j of A is
    /// pixel `pixels[j]`). `get` may be called several times for the same
    /// arguments and from several threads (of the current rayon pool).
    ///
    /// # Panics
    /// If `n == 0`, or if a kept pixel has zero or non-finite variance (the
    /// caller must exclude those; with `n == 1` every pixel has zero
    /// variance).
    pub fn from_fn(
        n: usize,
        pixels: &[usize],
        get: impl Fn(usize, usize) -> (f64, f64) + Sync,
    ) -> Self {
        assert!(n > 0, "a stack needs at least one sample");
        let p = pixels.len();
        const GROUP: usize = 256;
        // Per pixel: (mean re, mean im, 1 / (s sqrt(N))), in f64, one pass
        // over the samples with sums shifted by the pixel's first sample (so
        // a large mean does not cancel the variance). Pixel groups in
        // parallel; within a group the samples are visited in order, so the
        // sums do not depend on the thread count.
        let stats: Vec<(f64, f64, f64)> = pixels
            .par_chunks(GROUP)
            .flat_map_iter(|grp| {
                let shift: Vec<(f64, f64)> = grp.iter().map(|&px| get(0, px)).collect();
                let mut sr = [0.0f64; GROUP];
                let mut si = [0.0f64; GROUP];
                let mut ss = [0.0f64; GROUP];
                for s in 1..n {
                    for (j, &px) in grp.iter().enumerate() {
                        let (r, i) = get(s, px);
                        let (dr, di) = (r - shift[j].0, i - shift[j].1);
                        sr[j] += dr;
                        si[j] += di;
                        ss[j] += dr * dr + di * di;
                    }
                }
                let nf = n as f64;
                (0..grp.len())
                    .map(|j| {
                        let (mr, mi) = (sr[j] / nf, si[j] / nf);
                        // N s^2 = sum |x - mu|^2 = sum |d|^2 - N |mean d|^2,
                        // so 1 / (s sqrt(N)) = 1 / sqrt(that).
                        let css = ss[j] - nf * (mr * mr + mi * mi);
                        assert!(
                            css > 0.0 && css.is_finite(),
                            "pixel {} has zero or non-finite variance",
                            grp[j]
                        );
                        (shift[j].0 + mr, shift[j].1 + mi, 1.0 / css.sqrt())
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut re = vec![0.0f32; n * p];
        let mut im = vec![0.0f32; n * p];
        if p > 0 {
            re.par_chunks_mut(p)
                .zip(im.par_chunks_mut(p))
                .enumerate()
                .for_each(|(s, (rrow, irow))| {
                    for (j, &px) in pixels.iter().enumerate() {
                        let (r, i) = get(s, px);
                        let (mr, mi, sc) = stats[j];
                        rrow[j] = ((r - mr) * sc) as f32;
                        irow[j] = ((i - mi) * sc) as f32;
                    }
                });
        }
        Normalised { n, p, re, im }
    }
}

/// Which form computed a quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// Sample-pair form: `||A A^H||_F^2` (N x N) for a norm, `||A1 A2^H||_F^2`
    /// (N1 x N2) for the cross term.
    Gram,
    /// Pixel-pair form: `||A^H A||_F^2` (P x P) for a norm; for the cross term
    /// `sum_pq Re(R1[p,q] conj(R2[p,q]))` from the blocks of R1 and R2 that
    /// the two Full norms form anyway.
    Full,
}

/// The three terms of eq. 24 and the form each was computed with.
#[derive(Debug, Clone)]
pub struct CmdTerms {
    /// `||R1||_F^2`.
    pub norm1_sq: f64,
    /// `||R2||_F^2`.
    pub norm2_sq: f64,
    /// `tr(R1 R2)`.
    pub cross: f64,
    /// Form used for `norm1_sq`.
    pub form1: Form,
    /// Form used for `norm2_sq`.
    pub form2: Form,
    /// Form used for `cross`.
    pub form_cross: Form,
}

impl CmdTerms {
    /// The correlation matrix distance `1 - tr(R1 R2) / (||R1||_F ||R2||_F)`,
    /// in [0, 1].
    pub fn distance(&self) -> f64 {
        1.0 - self.cross / (self.norm1_sq.sqrt() * self.norm2_sq.sqrt())
    }
}
