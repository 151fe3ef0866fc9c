//! Fast complex white noise, the random stream of sample format 2 (generation of new samples
//! from a fitted model): 32-bit words of ChaCha8 on one stream per sample turned into complex
//! circular normals (`E|z|^2 = 1`, real and imaginary parts `N(0, 1/2)`) by the Box-Muller
//! transform in `f32`, with its logarithm, sine and cosine written out here as short series,
//! so that the values are defined by this file alone (the same bits on every CPU: plain IEEE
//! multiplies and adds, no fused operations) and eight lanes are computed at once.
//!
//! Word layout: complex values come in blocks of 8; block `b` reads words `16 b .. 16 b + 16`
//! of the stream, the first 8 (`u`) giving the radii and the last 8 (`v`) the angles of its
//! 8 values. A request for `n` values reads `16 ceil(n / 8)` words.
//!
//! For one value, with `u` and `v` its two words:
//! - `x = ((u >> 1) + 1/2) 2^-31` in `(0, 1)`, `|z|^2 = -ln x` (an exponential variable of mean
//!   1, cut at `ln 2^32 = 22.2`, i.e. a real part beyond 4.7 standard deviations' worth of
//!   modulus occurs with probability below `2^-32` instead of `2^-32.1`);
//! - the angle `q pi/2 + psi`: `t = v + 2^29 (mod 2^32)`, `q` its top two bits and `psi` its low
//!   30 bits (centred) scaled to `[-pi/4, pi/4)`, where the sine and cosine series below are
//!   accurate to 2e-9.
//!
//! [`box_muller_reference`] is the same map in `f64` with the standard library's functions,
//! the oracle of the tests.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Complex values per block of the word layout.
pub const LANES: usize = 8;

/// Words of the stream a request for `n` complex values reads: `16 ceil(n / 8)`.
pub fn words_for(n: usize) -> usize {
    n.div_ceil(LANES) * 2 * LANES
}

/// Fills `re` and `im` (equal lengths `n`) with the first `n` complex normals of stream
/// `stream` of ChaCha8 seeded with `seed` (`seed_from_u64`), `words` being scratch space.
///
/// # Panics
/// If `re` and `im` differ in length.
pub fn complex_normals(
    seed: u64,
    stream: u64,
    words: &mut Vec<u32>,
    re: &mut [f32],
    im: &mut [f32],
) {
    assert_eq!(
        re.len(),
        im.len(),
        "one real and one imaginary part per value"
    );
    fill_words(seed, stream, words_for(re.len()), words);
    transform(words, re, im);
}

/// The first `count` words of stream `stream` of ChaCha8 seeded with `seed`, into `words`.
pub fn fill_words(seed: u64, stream: u64, count: usize, words: &mut Vec<u32>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    words.clear();
    words.resize(count, 0);
    rand::Rng::fill_bytes(&mut rng, bytemuck::cast_slice_mut(words.as_mut_slice()));
    for w in words.iter_mut() {
        *w = u32::from_le(*w);
    }
}

/// The Box-Muller map of the module's layout: `words` (at least `16 ceil(n / 8)`) to `n`
/// complex values in `re` and `im`.
///
/// # Panics
/// If there are too few words or `re` and `im` differ in length.
pub fn transform(words: &[u32], re: &mut [f32], im: &mut [f32]) {
    assert_eq!(re.len(), im.len());
    assert!(words.len() >= words_for(re.len()), "too few words");
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { transform_avx2(words, re, im) };
        }
    }
    transform_body(words, re, im)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn transform_avx2(words: &[u32], re: &mut [f32], im: &mut [f32]) {
    transform_body(words, re, im)
}

#[inline(always)]
fn transform_body(words: &[u32], re: &mut [f32], im: &mut [f32]) {
    let n = re.len();
    let full = n / LANES;
    for b in 0..full {
        let w: &[u32; 2 * LANES] = words[2 * LANES * b..][..2 * LANES]
            .try_into()
            .expect("a block");
        let r: &mut [f32; LANES] = (&mut re[LANES * b..][..LANES]).try_into().expect("a block");
        let m: &mut [f32; LANES] = (&mut im[LANES * b..][..LANES]).try_into().expect("a block");
        for k in 0..LANES {
            (r[k], m[k]) = lane(w[k], w[LANES + k]);
        }
    }
    for c in full * LANES..n {
        let b = c / LANES;
        let k = c % LANES;
        (re[c], im[c]) = lane(words[2 * LANES * b + k], words[2 * LANES * b + LANES + k]);
    }
}

/// `2^-31`.
const TWO_M31: f32 = 1.0 / 2_147_483_648.0;

/// One complex value from its radius word `u` and angle word `v` (module documentation).
#[inline(always)]
fn lane(u: u32, v: u32) -> (f32, f32) {
    let r = neg_ln(u >> 1).sqrt();
    let t = v.wrapping_add(1 << 29);
    let q = t >> 30;
    let f = (t & ((1 << 30) - 1)) as i32 - (1 << 29);
    let psi = f as f32 * (std::f32::consts::FRAC_PI_2 / 1_073_741_824.0);
    let (c, s) = sin_cos(psi);
    let (c, s) = if q & 1 == 1 { (-s, c) } else { (c, s) };
    let (c, s) = if q & 2 == 2 { (-c, -s) } else { (c, s) };
    (r * c, r * s)
}

/// `n >= 2^31 sqrt(1/2)`, where `x >= sqrt(1/2)`.
const UPPER: u32 = 1_518_500_250;

/// `-ln x` for `x = (n + 1/2) 2^-31` in `(0, 1)`, `n < 2^31`: `x = m 2^e` with `m` in
/// `[sqrt(1/2), sqrt(2))`, `ln m = 2 atanh s`, `s = (m - 1) / (m + 1)`, `|s| < 0.172`, by its
/// series to `s^9` (truncation below 1e-9). For `x >= sqrt(1/2)` (`e = 0`), `m - 1 = -d` with
/// `d = 1 - x` formed from the integer, exact in `f32` near 1, where `x` itself is not.
#[inline(always)]
fn neg_ln(n: u32) -> f32 {
    let x = (n as i32 as f32 + 0.5) * TWO_M31;
    let d = (((1u32 << 31) - 1 - n) as i32 as f32 + 0.5) * TWO_M31;
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let big = m > std::f32::consts::SQRT_2;
    let m = if big { m * 0.5 } else { m };
    let e = if big { e + 1 } else { e };
    let upper = n >= UPPER;
    let (num, den) = if upper {
        (-d, 2.0 - d)
    } else {
        (m - 1.0, m + 1.0)
    };
    let e = if upper { 0 } else { e };
    let s = num / den;
    let s2 = s * s;
    let series = 1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0))));
    let ln = e as f32 * std::f32::consts::LN_2 + 2.0 * s * series;
    (-ln).max(0.0)
}

/// `(cos psi, sin psi)` for `|psi| <= pi/4` by their Taylor series to `psi^10` and `psi^9`
/// (truncation below 2e-9).
#[inline(always)]
fn sin_cos(psi: f32) -> (f32, f32) {
    let p2 = psi * psi;
    let sin = psi
        * (1.0
            - p2 * (1.0 / 6.0)
                * (1.0
                    - p2 * (1.0 / 20.0) * (1.0 - p2 * (1.0 / 42.0) * (1.0 - p2 * (1.0 / 72.0)))));
    let cos = 1.0
        - p2 * 0.5
            * (1.0
                - p2 * (1.0 / 12.0)
                    * (1.0
                        - p2 * (1.0 / 30.0)
                            * (1.0 - p2 * (1.0 / 56.0) * (1.0 - p2 * (1.0 / 90.0)))));
    (cos, sin)
}

/// The oracle: the value of words `u`, `v` by the module's definition in `f64` with the
/// standard library's `ln`, `sqrt`, `cos` and `sin`.
pub fn box_muller_reference(u: u32, v: u32) -> (f64, f64) {
    let x = ((u >> 1) as f64 + 0.5) / 2_147_483_648.0;
    let r = (-x.ln()).sqrt();
    let theta = (v as f64 / 4_294_967_296.0) * std::f64::consts::TAU;
    (r * theta.cos(), r * theta.sin())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    /// Every value of a block agrees with the f64 oracle: the transform's own error is below
    /// 2e-6 relative to the modulus (f32 rounding of a handful of operations; the angle is
    /// quantised to 2^-30 of a quarter turn before f32 rounding).
    #[test]
    fn agrees_with_the_oracle_on_seeded_words_and_at_the_ends() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut words: Vec<u32> = (0..16 * 4000).map(|_| rng.next_u32()).collect();
        // The extremes of both words.
        words[..16].copy_from_slice(&[
            0,
            1,
            2,
            u32::MAX,
            u32::MAX - 1,
            1 << 31,
            3,
            1 << 29,
            0,
            u32::MAX,
            1 << 29,
            (1 << 29) - 1,
            1 << 30,
            3 << 30,
            1 << 31,
            (3 << 29) + 1,
        ]);
        let n = words.len() / 2 - 3; // a partial last block
        let (mut re, mut im) = (vec![0.0f32; n], vec![0.0f32; n]);
        transform(&words, &mut re, &mut im);
        for c in 0..n {
            let (b, k) = (c / LANES, c % LANES);
            let (u, v) = (words[16 * b + k], words[16 * b + 8 + k]);
            let (er, ei) = box_muller_reference(u, v);
            let modulus = er.hypot(ei);
            let err = (re[c] as f64 - er).hypot(im[c] as f64 - ei);
            assert!(
                err <= 2e-6 * modulus.max(1e-3),
                "value {c} (u {u}, v {v}): ({}, {}) vs ({er}, {ei})",
                re[c],
                im[c]
            );
        }
        // Bitwise the same through the portable path.
        let (mut re2, mut im2) = (vec![0.0f32; n], vec![0.0f32; n]);
        transform_body(&words, &mut re2, &mut im2);
        assert_eq!(
            (
                bytemuck::cast_slice::<f32, u32>(&re),
                bytemuck::cast_slice::<f32, u32>(&im)
            ),
            (
                bytemuck::cast_slice::<f32, u32>(&re2),
                bytemuck::cast_slice::<f32, u32>(&im2)
            )
        );
    }

    /// Moments of 2 million values: mean 0, E|z|^2 = 1, parts of variance 1/2 and
    /// uncorrelated, E|z|^4 = 2 (a complex circular normal), within 6 standard errors.
    #[test]
    fn moments_are_those_of_a_complex_circular_normal() {
        let n = 1 << 21;
        let (mut re, mut im) = (vec![0.0f32; n], vec![0.0f32; n]);
        let mut words = Vec::new();
        complex_normals(3, 9, &mut words, &mut re, &mut im);
        let nf = n as f64;
        let mean = |f: &dyn Fn(f64, f64) -> f64| {
            re.iter()
                .zip(&im)
                .map(|(&a, &b)| f(a as f64, b as f64))
                .sum::<f64>()
                / nf
        };
        let se = |var: f64| 6.0 * (var / nf).sqrt();
        assert!(mean(&|a, _| a).abs() < se(0.5));
        assert!(mean(&|_, b| b).abs() < se(0.5));
        assert!((mean(&|a, _| a * a) - 0.5).abs() < se(0.5), "var re");
        assert!((mean(&|_, b| b * b) - 0.5).abs() < se(0.5), "var im");
        assert!(mean(&|a, b| a * b).abs() < se(0.25), "re-im correlation");
        assert!(
            (mean(&|a, b| a * a + b * b) - 1.0).abs() < se(1.0),
            "E|z|^2"
        );
        assert!(
            (mean(&|a, b| (a * a + b * b).powi(2)) - 2.0).abs() < se(20.0),
            "E|z|^4"
        );
        // Tail of the real part: P(|Re z| > 2 / sqrt 2) = P(|N(0,1)| > 2) = 0.0455.
        let tail = re
            .iter()
            .filter(|&&a| (a as f64).abs() > std::f64::consts::SQRT_2)
            .count();
        let p = 0.045_500_263_896_358_4;
        assert!((tail as f64 / nf - p).abs() < se(p * (1.0 - p)), "tail");
    }

    /// Streams differ, the same stream repeats, and a request of `n` values is the first `n`
    /// of a longer one.
    #[test]
    fn streams_are_separate_and_prefixes_agree() {
        let draw = |stream, n| {
            let (mut re, mut im) = (vec![0.0f32; n], vec![0.0f32; n]);
            complex_normals(11, stream, &mut Vec::new(), &mut re, &mut im);
            (re, im)
        };
        assert_eq!(draw(4, 100), draw(4, 100));
        assert_ne!(draw(4, 100), draw(5, 100));
        let (a, b) = draw(4, 37);
        let (c, d) = draw(4, 100);
        assert_eq!((&a[..], &b[..]), (&c[..37], &d[..37]));
    }
}
