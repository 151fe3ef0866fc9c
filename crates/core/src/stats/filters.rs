//! Correlating filters (dissertation eqs. 32-33, 65-68 and ch. 4; docs/definitions.md §4-5):
//! the exponential and dyadic tap families, the 1-D lag and group correlations a filter
//! induces on white noise, spatially varying separable filtering of a padded white seed, and
//! the exact expected multiscale maps of filtered noise (the "truth" an analysis is compared
//! with).
//!
//! Taps are stored as a vector of length `2K + 1`, index `K + d` holding `f(d)` for
//! `d = -K..=K`. Filters are real; the seed is complex circular with `E|w|^2 = 1`.

use crate::stats::analysis::cell_directions;
use ndarray::{Array2, ArrayView2};
use num_complex::Complex64;

/// How the exponential filter of a negative `alpha` is signed (dissertation §4.2.4;
/// docs/definitions.md §5, Method 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NegativeSigns {
    /// The dissertation's scheme: `s(d) = (-1)^popcount(|d|)` (the Thue-Morse signs), so
    /// that the shifts by 1, 2 and 4 pixels (the offsets of levels 1, 2 and 3) all correlate
    /// negatively. It is also what an exhaustive search over the symmetric sign patterns of
    /// half-width 8 finds closest to the negated correlations at those shifts, for every
    /// `alpha` from 0.5 to 16. Its lag-1 correlation is about the negated positive one for
    /// `|alpha| <= 0.5` and reaches at most about -0.507 (at `|alpha|` near 1.20).
    #[default]
    Multiscale,
    /// `s(d) = (-1)^d`: the lag-1 correlation is exactly the negated positive one, while the
    /// 2- and 4-pixel shifts correlate positively.
    Alternating,
}

impl NegativeSigns {
    /// The sign of tap `d` of a negative-`alpha` filter.
    pub fn sign(self, d: i64) -> f64 {
        let odd = match self {
            NegativeSigns::Multiscale => d.unsigned_abs().count_ones() % 2 == 1,
            NegativeSigns::Alternating => d % 2 != 0,
        };
        if odd {
            -1.0
        } else {
            1.0
        }
    }

    /// The scheme's name as a spec writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            NegativeSigns::Multiscale => "multiscale",
            NegativeSigns::Alternating => "alternating",
        }
    }
}

/// Exponential taps `f(d) = exp(-|d| / |alpha|)` on `|d| <= half_width` (eq. 65, 68).
///
/// A negative `alpha` gives the sign-alternating filter `(-1)^d exp(-|d| / |alpha|)` whose
/// lag-1 correlation is the negative of the positive filter's (docs/definitions.md §5,
/// Method 1; [`exponential_taps_signed`] for the other scheme). `alpha = +-inf` gives a
/// constant (or alternating) filter, `alpha = 0` the delta filter (the limit `alpha -> 0`:
/// white output).
///
/// # Panics
/// If `alpha` is NaN.
pub fn exponential_taps(alpha: f64, half_width: usize) -> Vec<f64> {
    exponential_taps_signed(alpha, half_width, NegativeSigns::Alternating)
}

/// [`exponential_taps`] with a negative `alpha` signed by `signs`.
///
/// # Panics
/// If `alpha` is NaN.
pub fn exponential_taps_signed(alpha: f64, half_width: usize, signs: NegativeSigns) -> Vec<f64> {
    assert!(!alpha.is_nan(), "alpha must not be NaN");
    let k = half_width as i64;
    (-k..=k)
        .map(|d| {
            let mag = if d == 0 {
                1.0
            } else {
                (-(d.abs() as f64) / alpha.abs()).exp()
            };
            if alpha < 0.0 {
                signs.sign(d) * mag
            } else {
                mag
            }
        })
        .collect()
}

/// Dyadic taps (docs/definitions.md §4-5, Method 2): `f(0) = 1`, `f(d) = r[l-1]` for
/// `2^(l-1) <= |d| < 2^l`, zero beyond `2^L - 1`.
///
/// # Panics
/// If `half_width < 2^L - 1` (the filter would be truncated).
pub fn dyadic_taps(r: &[f64], half_width: usize) -> Vec<f64> {
    let reach = dyadic_reach(r.len());
    assert!(
        half_width >= reach,
        "half_width {half_width} truncates a {}-level dyadic filter (needs {reach})",
        r.len()
    );
    let k = half_width as i64;
    (-k..=k)
        .map(|d| {
            let a = d.unsigned_abs() as usize;
            if a == 0 {
                1.0
            } else if a <= reach {
                r[(usize::BITS - a.leading_zeros()) as usize - 1]
            } else {
                0.0
            }
        })
        .collect()
}

/// Largest offset with a non-zero tap for an `levels`-parameter dyadic filter: `2^L - 1`
/// (`usize::MAX` from `L = 64` on, where `2^L` passes `usize`).
pub fn dyadic_reach(levels: usize) -> usize {
    if levels >= usize::BITS as usize {
        usize::MAX
    } else {
        (1usize << levels) - 1
    }
}

/// Autocorrelation sum `R(d) = sum_n f(n) f(n + d)` of centred taps.
pub fn autocovariance(taps: &[f64], lag: usize) -> f64 {
    if lag >= taps.len() {
        return 0.0;
    }
    taps.iter().zip(&taps[lag..]).map(|(a, b)| a * b).sum()
}

/// Lag-`d` correlation `rho(d) = sum_n f(n) f(n+d) / sum_n f(n)^2` (eq. 66-67, Table 3).
pub fn lag_correlation(taps: &[f64], lag: usize) -> f64 {
    autocovariance(taps, lag) / autocovariance(taps, 0)
}

/// Group correlation of filtered white noise: the correlation between the sum of `g`
/// consecutive samples and the sum of the next `g` (what level `L = log2(g) + 1` measures).
pub fn group_correlation(taps: &[f64], g: usize) -> f64 {
    let r = |d: i64| autocovariance(taps, d.unsigned_abs() as usize);
    let g = g as i64;
    let mut cov = 0.0;
    let mut var = 0.0;
    for a in 0..g {
        for b in 0..g {
            cov += r(g + b - a);
            var += r(b - a);
        }
    }
    cov / var
}

/// Per-pixel separable filter bank: vertical and horizontal taps for every output pixel. The
/// taps are not changed after [`FilterBank::new`]: the bank keeps what it derives from them
/// (uniformity, output standard deviations, the row kernel's layout) once found.
#[derive(Clone, Debug)]
pub struct FilterBank {
    /// Half-width `K` shared by all taps.
    pub half_width: usize,
    /// Output height.
    pub height: usize,
    /// Output width.
    pub width: usize,
    /// Vertical taps, `height * width` rows of `2K + 1`, row-major by pixel.
    pub vertical: Vec<Vec<f64>>,
    /// Horizontal taps, same layout.
    pub horizontal: Vec<Vec<f64>>,
    /// Taps rearranged for the vectorised spatially varying kernel, built on first use.
    planar: std::sync::OnceLock<PlanarTaps>,
    /// Analytic output standard deviation per pixel, built on first use.
    sds: std::sync::OnceLock<Vec<f64>>,
    /// Whether every pixel has the same taps, found on first use (a comparison of every
    /// pixel's taps, which filtering each sample asks for).
    uniform: std::sync::OnceLock<bool>,
}

/// Taps of a spatially varying bank laid out for the row kernel: for output row `i`, tap `a`
/// (vertical) or `b` (horizontal), the `W` pixels' coefficients are contiguous.
#[derive(Clone, Debug)]
struct PlanarTaps {
    /// `[H][2K+1][W]` vertical taps.
    vertical: Vec<f64>,
    /// `[H][2K+1][W]` horizontal taps.
    horizontal: Vec<f64>,
    /// Runs `[start, end)` of at most `MAX_GROUP` consecutive output rows whose horizontal
    /// taps are identical (Methods 1 and 2 share them within a level-1 cell): their
    /// horizontal sums over the seed rows they have in common are formed once.
    groups: Vec<(usize, usize)>,
}

/// Longest run of output rows that share one set of horizontal sums.
const MAX_GROUP: usize = 4;

impl FilterBank {
    /// A bank from per-pixel taps (`height * width` vectors of `2 half_width + 1` taps each,
    /// row-major by pixel).
    ///
    /// # Panics
    /// If the numbers of pixels or taps do not match.
    pub fn new(
        half_width: usize,
        height: usize,
        width: usize,
        vertical: Vec<Vec<f64>>,
        horizontal: Vec<Vec<f64>>,
    ) -> Self {
        let n = 2 * half_width + 1;
        assert!(
            vertical.len() == height * width && horizontal.len() == height * width,
            "one filter per pixel"
        );
        assert!(
            vertical.iter().chain(&horizontal).all(|t| t.len() == n),
            "every filter has 2K + 1 taps"
        );
        FilterBank {
            half_width,
            height,
            width,
            vertical,
            horizontal,
            planar: std::sync::OnceLock::new(),
            sds: std::sync::OnceLock::new(),
            uniform: std::sync::OnceLock::new(),
        }
    }

    /// A bank where every pixel uses the same taps.
    pub fn uniform(vertical: Vec<f64>, horizontal: Vec<f64>, height: usize, width: usize) -> Self {
        let half_width = horizontal.len() / 2;
        assert_eq!(
            vertical.len(),
            horizontal.len(),
            "taps must share a half-width"
        );
        FilterBank::new(
            half_width,
            height,
            width,
            vec![vertical; height * width],
            vec![horizontal; height * width],
        )
    }

    /// Whether every pixel has the same taps (enables the fast separable path).
    pub fn is_uniform(&self) -> bool {
        *self.uniform.get_or_init(|| {
            let same = |v: &Vec<Vec<f64>>| v.iter().all(|t| t == &v[0]);
            same(&self.vertical) && same(&self.horizontal)
        })
    }

    /// [`FilterBank::output_sd`] of every pixel, computed once.
    pub fn output_sds(&self) -> &[f64] {
        self.sds.get_or_init(|| {
            (0..self.height * self.width)
                .map(|p| self.output_sd(p))
                .collect()
        })
    }

    /// Analytic standard deviation of the output at pixel `p` for a unit seed:
    /// `sqrt(sum fV^2 * sum fH^2)`.
    pub fn output_sd(&self, p: usize) -> f64 {
        (autocovariance(&self.vertical[p], 0) * autocovariance(&self.horizontal[p], 0)).sqrt()
    }

    /// Exact covariance `E[y_p conj(y_q)]` of the (unnormalised) outputs at pixels
    /// `p = (i, j)` and `q = (i2, j2)` for a unit white seed:
    /// `[sum_a fV_p(a) fV_q(a + i - i2)] [sum_b fH_p(b) fH_q(b + j - j2)]`.
    pub fn output_covariance(&self, p: (usize, usize), q: (usize, usize)) -> f64 {
        let ip = p.0 * self.width + p.1;
        let iq = q.0 * self.width + q.1;
        let cross = |fp: &[f64], fq: &[f64], shift: i64| -> f64 {
            let k = self.half_width as i64;
            (-k..=k)
                .filter_map(|a| {
                    let b = a + shift;
                    (b.abs() <= k).then(|| fp[(a + k) as usize] * fq[(b + k) as usize])
                })
                .sum()
        };
        let dv = p.0 as i64 - q.0 as i64;
        let dh = p.1 as i64 - q.1 as i64;
        cross(&self.vertical[ip], &self.vertical[iq], dv)
            * cross(&self.horizontal[ip], &self.horizontal[iq], dh)
    }
}

/// Filters one padded white seed (`(H + 2K) x (W + 2K)`, 'valid' mode) with the bank.
///
/// Uniform banks use the two-pass separable convolution; spatially varying banks the direct
/// per-pixel double sum of eq. 33. `scratch` holds the horizontal pass of the uniform path.
pub fn filter_seed(bank: &FilterBank, seed: ArrayView2<Complex64>, out: &mut [Complex64]) {
    let (h, w, k) = (bank.height, bank.width, bank.half_width);
    assert_eq!(
        seed.dim(),
        (h + 2 * k, w + 2 * k),
        "seed must be padded by the half-width"
    );
    assert_eq!(out.len(), h * w);
    let seed = seed.as_standard_layout();
    let s = seed.as_slice().expect("standard layout");
    let sw = w + 2 * k;
    if bank.is_uniform() {
        filter_uniform(&bank.vertical[0], &bank.horizontal[0], s, sw, out);
    } else {
        filter_varying(bank, s, out);
    }
}

/// The uniform bank's two-pass separable convolution of a padded seed `s` (rows of `sw`
/// values) into `out` (rows of `w = sw - 2K`): a horizontal pass into rows of `w`, then the
/// vertical pass. Each output is the sum of its products in tap order from zero, as
/// `iter().sum()` forms it (the oracle in the tests), so the result is the same bits on every
/// path; the real taps act on the real and imaginary parts alike, so both passes run over the
/// parts as one row of `f64` and a block of outputs stays in registers across the taps.
fn filter_uniform(fv: &[f64], fh: &[f64], s: &[Complex64], sw: usize, out: &mut [Complex64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { filter_uniform_avx512(fv, fh, s, sw, out) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { filter_uniform_avx2(fv, fh, s, sw, out) };
        }
    }
    filter_uniform_body(fv, fh, s, sw, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn filter_uniform_avx512(
    fv: &[f64],
    fh: &[f64],
    s: &[Complex64],
    sw: usize,
    out: &mut [Complex64],
) {
    filter_uniform_body(fv, fh, s, sw, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn filter_uniform_avx2(fv: &[f64], fh: &[f64], s: &[Complex64], sw: usize, out: &mut [Complex64]) {
    filter_uniform_body(fv, fh, s, sw, out)
}

#[inline(always)]
fn filter_uniform_body(fv: &[f64], fh: &[f64], s: &[Complex64], sw: usize, out: &mut [Complex64]) {
    let k = fh.len() / 2;
    let w = sw - 2 * k;
    let padded_rows = s.len() / sw;
    let s: &[f64] = bytemuck::cast_slice(s);
    let out: &mut [f64] = bytemuck::cast_slice_mut(out);
    let mut rows = vec![0.0f64; padded_rows * 2 * w];
    for (dst, src) in rows.chunks_exact_mut(2 * w).zip(s.chunks_exact(2 * sw)) {
        tap_sums(fh, 2, src, dst);
    }
    for (i, dst) in out.chunks_exact_mut(2 * w).enumerate() {
        tap_sums(fv, 2 * w, &rows[i * 2 * w..], dst);
    }
}

/// `dst[m] = 0 + f[0] src[m] + f[1] src[m + step] + ...` in that order, for every `m`.
#[inline(always)]
fn tap_sums(f: &[f64], step: usize, src: &[f64], dst: &mut [f64]) {
    const B: usize = 32;
    let done = dst.len() / B * B;
    let mut blocks = dst.chunks_exact_mut(B);
    for (b, block) in blocks.by_ref().enumerate() {
        let mut acc = [0.0f64; B];
        for (a, &fa) in f.iter().enumerate() {
            let x = &src[b * B + a * step..][..B];
            for (y, &x) in acc.iter_mut().zip(x) {
                *y += x * fa;
            }
        }
        block.copy_from_slice(&acc);
    }
    for (m, y) in blocks.into_remainder().iter_mut().enumerate() {
        let mut acc = 0.0;
        for (a, &fa) in f.iter().enumerate() {
            acc += src[done + m + a * step] * fa;
        }
        *y = acc;
    }
}

impl FilterBank {
    fn planar(&self) -> &PlanarTaps {
        self.planar.get_or_init(|| {
            let (h, w, n) = (self.height, self.width, 2 * self.half_width + 1);
            let arrange = |taps: &Vec<Vec<f64>>| {
                let mut out = vec![0.0; h * n * w];
                for i in 0..h {
                    for t in 0..n {
                        for j in 0..w {
                            out[(i * n + t) * w + j] = taps[i * w + j][t];
                        }
                    }
                }
                out
            };
            let horizontal = arrange(&self.horizontal);
            let row = |i: usize| &horizontal[i * n * w..(i + 1) * n * w];
            let mut groups: Vec<(usize, usize)> = Vec::new();
            for i in 0..h {
                match groups.last_mut() {
                    Some((g0, g1)) if *g1 - *g0 < MAX_GROUP && row(*g0) == row(i) => *g1 = i + 1,
                    _ => groups.push((i, i + 1)),
                }
            }
            PlanarTaps {
                vertical: arrange(&self.vertical),
                horizontal,
                groups,
            }
        })
    }
}

/// Spatially varying separable filtering of one padded seed, vectorised across the pixels of
/// an output row: for each row `i` and vertical tap `a`, the horizontal sums of all `W` pixels
/// are formed together from contiguous taps and seed values, then weighted by their vertical
/// taps. Per pixel the operations and their order are those of [`filter_pixel_direct`] (its
/// oracle), so the two agree bit for bit.
fn filter_varying(bank: &FilterBank, seed: &[Complex64], out: &mut [Complex64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { filter_varying_avx2(bank, seed, out) };
        }
    }
    filter_varying_body(bank, seed, out)
}

/// The varying kernel with explicit AVX2 vectors: blocks of 8 pixels of a row as two 4-lane
/// vectors per component, multiply then add (no fused multiply-add), so that every pixel's
/// arithmetic is that of [`filter_pixel_direct`] and the result is bitwise identical.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn filter_varying_avx2(bank: &FilterBank, seed: &[Complex64], out: &mut [Complex64]) {
    use std::arch::x86_64::*;
    let (h, w, n) = (bank.height, bank.width, 2 * bank.half_width + 1);
    let sw = w + n - 1;
    let taps = bank.planar();
    let (re, im): (Vec<f64>, Vec<f64>) = seed.iter().map(|z| (z.re, z.im)).unzip();
    assert!(
        re.len() >= (h + n - 1) * sw
            && taps.horizontal.len() == h * n * w
            && taps.vertical.len() == h * n * w
    );
    let zero = _mm256_setzero_pd();
    let mut hbuf = vec![[zero; 4]; MAX_GROUP + n - 1];
    for &(g0, g1) in &taps.groups {
        let mut j = 0;
        while j + 8 <= w {
            // SAFETY: every pointer below stays inside its slice: seed rows g0 + r < g1 + n - 1
            // <= h + n - 1, columns j + b + 8 <= w + n - 1 = sw, taps (i * n + t) * w + j + 8
            // <= h n w, all checked by the assertion above and the loop bounds.
            unsafe {
                // Horizontal sums over the seed rows the group's output rows need, with the
                // group's shared taps (those of row g0), b ascending.
                for (r, hs) in hbuf.iter_mut().take(g1 - g0 + n - 1).enumerate() {
                    let (mut hr0, mut hr1, mut hi0, mut hi1) = (zero, zero, zero, zero);
                    let row = (g0 + r) * sw + j;
                    for b in 0..n {
                        let f = taps.horizontal.as_ptr().add((g0 * n + b) * w + j);
                        let (f0, f1) = (_mm256_loadu_pd(f), _mm256_loadu_pd(f.add(4)));
                        let (p, m) = (re.as_ptr().add(row + b), im.as_ptr().add(row + b));
                        hr0 = _mm256_add_pd(hr0, _mm256_mul_pd(_mm256_loadu_pd(p), f0));
                        hr1 = _mm256_add_pd(hr1, _mm256_mul_pd(_mm256_loadu_pd(p.add(4)), f1));
                        hi0 = _mm256_add_pd(hi0, _mm256_mul_pd(_mm256_loadu_pd(m), f0));
                        hi1 = _mm256_add_pd(hi1, _mm256_mul_pd(_mm256_loadu_pd(m.add(4)), f1));
                    }
                    *hs = [hr0, hr1, hi0, hi1];
                }
                // Each output row weights its n horizontal sums by its vertical taps, a ascending.
                for i in g0..g1 {
                    let (mut ar0, mut ar1, mut ai0, mut ai1) = (zero, zero, zero, zero);
                    for a in 0..n {
                        let [hr0, hr1, hi0, hi1] = hbuf[i - g0 + a];
                        let v = taps.vertical.as_ptr().add((i * n + a) * w + j);
                        let (v0, v1) = (_mm256_loadu_pd(v), _mm256_loadu_pd(v.add(4)));
                        ar0 = _mm256_add_pd(ar0, _mm256_mul_pd(hr0, v0));
                        ar1 = _mm256_add_pd(ar1, _mm256_mul_pd(hr1, v1));
                        ai0 = _mm256_add_pd(ai0, _mm256_mul_pd(hi0, v0));
                        ai1 = _mm256_add_pd(ai1, _mm256_mul_pd(hi1, v1));
                    }
                    let (mut r, mut m) = ([0.0f64; 8], [0.0f64; 8]);
                    _mm256_storeu_pd(r.as_mut_ptr(), ar0);
                    _mm256_storeu_pd(r.as_mut_ptr().add(4), ar1);
                    _mm256_storeu_pd(m.as_mut_ptr(), ai0);
                    _mm256_storeu_pd(m.as_mut_ptr().add(4), ai1);
                    for k in 0..8 {
                        out[i * w + j + k] = Complex64::new(r[k], m[k]);
                    }
                }
            }
            j += 8;
        }
        for i in g0..g1 {
            for j in j..w {
                filter_block::<1>(
                    taps,
                    &re,
                    &im,
                    (i, j),
                    (w, n, sw),
                    &mut out[i * w + j..][..1],
                );
            }
        }
    }
}

/// Pixels per register block of the varying kernel (two 256-bit vectors per component).
const BLOCK: usize = 8;

#[inline(always)]
fn filter_varying_body(bank: &FilterBank, seed: &[Complex64], out: &mut [Complex64]) {
    let (h, w, n) = (bank.height, bank.width, 2 * bank.half_width + 1);
    let sw = w + n - 1;
    let taps = bank.planar();
    let (re, im): (Vec<f64>, Vec<f64>) = seed.iter().map(|z| (z.re, z.im)).unzip();
    for i in 0..h {
        let mut j = 0;
        while j + BLOCK <= w {
            filter_block::<BLOCK>(
                taps,
                &re,
                &im,
                (i, j),
                (w, n, sw),
                &mut out[i * w + j..][..BLOCK],
            );
            j += BLOCK;
        }
        for j in j..w {
            filter_block::<1>(
                taps,
                &re,
                &im,
                (i, j),
                (w, n, sw),
                &mut out[i * w + j..][..1],
            );
        }
    }
}

/// `B` adjacent output pixels `(i, j..j+B)`, accumulated in registers: for each vertical tap
/// `a`, the horizontal sums over `b` in order, then weighted by the vertical tap.
#[inline(always)]
fn filter_block<const B: usize>(
    taps: &PlanarTaps,
    re: &[f64],
    im: &[f64],
    (i, j): (usize, usize),
    (w, n, sw): (usize, usize, usize),
    out: &mut [Complex64],
) {
    let (mut acc_re, mut acc_im) = ([0.0f64; B], [0.0f64; B]);
    for a in 0..n {
        let (mut h_re, mut h_im) = ([0.0f64; B], [0.0f64; B]);
        let row = (i + a) * sw + j;
        for b in 0..n {
            let f: &[f64; B] = taps.horizontal[(i * n + b) * w + j..][..B]
                .try_into()
                .expect("block");
            let sr: &[f64; B] = re[row + b..][..B].try_into().expect("block");
            let si: &[f64; B] = im[row + b..][..B].try_into().expect("block");
            for k in 0..B {
                h_re[k] += sr[k] * f[k];
                h_im[k] += si[k] * f[k];
            }
        }
        let fv: &[f64; B] = taps.vertical[(i * n + a) * w + j..][..B]
            .try_into()
            .expect("block");
        for k in 0..B {
            acc_re[k] += h_re[k] * fv[k];
            acc_im[k] += h_im[k] * fv[k];
        }
    }
    for (k, o) in out.iter_mut().enumerate() {
        *o = Complex64::new(acc_re[k], acc_im[k]);
    }
}

/// Direct double sum of eq. 33 for one output pixel (also the oracle of the uniform path).
pub fn filter_pixel_direct(
    bank: &FilterBank,
    seed: &[Complex64],
    seed_width: usize,
    i: usize,
    j: usize,
) -> Complex64 {
    let p = i * bank.width + j;
    let (fv, fh) = (&bank.vertical[p], &bank.horizontal[p]);
    let n = 2 * bank.half_width + 1;
    let mut acc = Complex64::new(0.0, 0.0);
    for a in 0..n {
        let row = &seed[(i + a) * seed_width + j..(i + a) * seed_width + j + n];
        let t: Complex64 = row.iter().zip(fh).map(|(z, f)| z * f).sum();
        acc += t * fv[a];
    }
    acc
}

/// Whether [`expected_maps`] takes its closed-form path (uniform filter and uniform `std`),
/// whose cost does not grow with the image or the level.
pub fn expected_maps_are_cheap(bank: &FilterBank, std: &Array2<f64>) -> bool {
    bank.is_uniform() && std.iter().all(|&s| s == std[[0, 0]])
}

/// Exact expected multiscale correlation maps (`[H, V, D]` per level) of
/// `x_p = mu_p + std_p y_p / sd(y_p)` where `y` is the bank's output for a unit white seed.
///
/// Uniform banks with uniform `std` use the 1-D group correlations (`rho_D = rho_H rho_V`);
/// otherwise every unit covariance is summed over its pixel pairs.
pub fn expected_maps(bank: &FilterBank, std: &Array2<f64>, levels: usize) -> Vec<[Array2<f64>; 3]> {
    let (h, w) = (bank.height, bank.width);
    let cheap = expected_maps_are_cheap(bank, std);
    (1..=levels)
        .map(|level| {
            let shape = (h >> level, w >> level);
            if cheap {
                let g = 1usize << (level - 1);
                let rh = group_correlation(&bank.horizontal[0], g);
                let rv = group_correlation(&bank.vertical[0], g);
                [
                    Array2::from_elem(shape, rh),
                    Array2::from_elem(shape, rv),
                    Array2::from_elem(shape, rh * rv),
                ]
            } else {
                exact_level(bank, std, level)
            }
        })
        .collect()
}

/// Pixel-pair summation of [`expected_maps`] for one level (`[H, V, D]`), valid for any bank
/// and `std` map; the oracle of the uniform fast path.
pub fn exact_level(bank: &FilterBank, std: &Array2<f64>, level: usize) -> [Array2<f64>; 3] {
    let g = 1usize << (level - 1);
    let shape = (bank.height >> level, bank.width >> level);
    let scale = |i: usize, j: usize| std[[i, j]] / bank.output_sd(i * bank.width + j);
    let unit_cov = |a: (usize, usize), b: (usize, usize)| -> f64 {
        let mut sum = 0.0;
        for i1 in 0..g {
            for j1 in 0..g {
                let p = (a.0 * g + i1, a.1 * g + j1);
                for i2 in 0..g {
                    for j2 in 0..g {
                        let q = (b.0 * g + i2, b.1 * g + j2);
                        sum += scale(p.0, p.1) * scale(q.0, q.1) * bank.output_covariance(p, q);
                    }
                }
            }
        }
        sum
    };
    let mut maps: [Array2<f64>; 3] = std::array::from_fn(|_| Array2::zeros(shape));
    for r in 0..shape.0 {
        for c in 0..shape.1 {
            for (d, (rho, _)) in cell_directions(r, c, unit_cov).into_iter().enumerate() {
                maps[d][[r, c]] = rho;
            }
        }
    }
    maps
}

/// Bytes of a per-pixel filter bank: two tap vectors of `2K + 1` per pixel (with their
/// headers), plus the planar copy a spatially varying bank builds for its kernel.
pub fn bank_bytes(p: f64, k: f64, varying: bool) -> f64 {
    let taps = 8.0 * (2.0 * k + 1.0);
    2.0 * p * (taps + 48.0) + if varying { 2.0 * p * taps } else { 0.0 }
}

/// Operations per output pixel of the separable filter: two passes of `2K + 1` complex
/// multiply-adds (uniform), or `(2K + 1)^2` for a spatially varying bank.
pub fn filter_flops(k: f64, varying: bool) -> f64 {
    let taps = 2.0 * k + 1.0;
    if varying {
        8.0 * taps * taps
    } else {
        16.0 * taps
    }
}
