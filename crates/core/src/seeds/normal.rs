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

/// The first `count` words of stream `stream` of ChaCha8 seeded with `seed`, into `words`:
/// `rand_chacha`'s stream, 16 blocks at a time with AVX-512 where the CPU has it (the same
/// words, tested against `rand_chacha`; its own AVX2 path makes 4 blocks at a time and needs
/// three instructions per rotation where AVX-512 has one).
pub fn fill_words(seed: u64, stream: u64, count: usize, words: &mut Vec<u32>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    words.clear();
    words.resize(count, 0);
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            let key = key_words(&rng.get_seed());
            let whole = count / 256 * 256;
            // SAFETY: the CPU has AVX-512F, checked just above; the slices hold whole groups.
            unsafe { chacha8_avx512(&key, stream, 0, &mut words[..whole]) };
            if whole < count {
                let mut last = [0u32; 256];
                // SAFETY: as above.
                unsafe { chacha8_avx512(&key, stream, (whole / 16) as u64, &mut last) };
                words[whole..].copy_from_slice(&last[..count - whole]);
            }
            return;
        }
    }
    rand::Rng::fill_bytes(&mut rng, bytemuck::cast_slice_mut(words.as_mut_slice()));
    for w in words.iter_mut() {
        *w = u32::from_le(*w);
    }
}

/// The eight key words of a `rand_chacha` generator's 32-byte seed (`get_seed`), little
/// endian, as the ChaCha state holds them.
#[cfg(target_arch = "x86_64")]
pub(crate) fn key_words(seed: &[u8; 32]) -> [u32; 8] {
    std::array::from_fn(|i| u32::from_le_bytes(seed[4 * i..4 * i + 4].try_into().expect("4 bytes")))
}

/// ChaCha8 blocks of the key and stream: [`chacha_avx512`] with 4 double rounds.
///
/// # Safety
/// As [`chacha_avx512`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn chacha8_avx512(key: &[u32; 8], stream: u64, first: u64, out: &mut [u32]) {
    // SAFETY: the caller's guarantees are those of `chacha_avx512`.
    unsafe { chacha_avx512::<4>(key, stream, first, out) }
}

/// ChaCha blocks with `DOUBLE_ROUNDS` double rounds (4 for ChaCha8, 10 for ChaCha20), blocks
/// `first, first + 1, ...` (16 words each, in order) of the key and stream into `out` (whole
/// groups of 16 blocks), 16 blocks at once: lane `j` of vector `i` is word `i` of block `j`,
/// transposed back to block order before the store. The state is that of `rand_chacha`:
/// constants, key, 64-bit block counter, 64-bit stream.
///
/// # Safety
/// The CPU has AVX-512F; `out.len()` is a multiple of 256.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn chacha_avx512<const DOUBLE_ROUNDS: usize>(
    key: &[u32; 8],
    stream: u64,
    first: u64,
    out: &mut [u32],
) {
    use std::arch::x86_64::*;
    assert_eq!(out.len() % 256, 0);
    let set = |x: u32| _mm512_set1_epi32(x as i32);
    let lanes = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
    for (g, group) in out.chunks_exact_mut(256).enumerate() {
        let base = first + 16 * g as u64;
        let lo0 = set(base as u32);
        let lo = _mm512_add_epi32(lo0, lanes);
        let carry = _mm512_cmplt_epu32_mask(lo, lo0);
        let hi = _mm512_mask_add_epi32(
            set((base >> 32) as u32),
            carry,
            set((base >> 32) as u32),
            set(1),
        );
        let init: [__m512i; 16] = [
            set(0x6170_7865),
            set(0x3320_646e),
            set(0x7962_2d32),
            set(0x6b20_6574),
            set(key[0]),
            set(key[1]),
            set(key[2]),
            set(key[3]),
            set(key[4]),
            set(key[5]),
            set(key[6]),
            set(key[7]),
            lo,
            hi,
            set(stream as u32),
            set((stream >> 32) as u32),
        ];
        let mut x = init;
        let qr = |x: &mut [__m512i; 16], a: usize, b: usize, c: usize, d: usize| {
            x[a] = _mm512_add_epi32(x[a], x[b]);
            x[d] = _mm512_rol_epi32::<16>(_mm512_xor_si512(x[d], x[a]));
            x[c] = _mm512_add_epi32(x[c], x[d]);
            x[b] = _mm512_rol_epi32::<12>(_mm512_xor_si512(x[b], x[c]));
            x[a] = _mm512_add_epi32(x[a], x[b]);
            x[d] = _mm512_rol_epi32::<8>(_mm512_xor_si512(x[d], x[a]));
            x[c] = _mm512_add_epi32(x[c], x[d]);
            x[b] = _mm512_rol_epi32::<7>(_mm512_xor_si512(x[b], x[c]));
        };
        for _ in 0..DOUBLE_ROUNDS {
            qr(&mut x, 0, 4, 8, 12);
            qr(&mut x, 1, 5, 9, 13);
            qr(&mut x, 2, 6, 10, 14);
            qr(&mut x, 3, 7, 11, 15);
            qr(&mut x, 0, 5, 10, 15);
            qr(&mut x, 1, 6, 11, 12);
            qr(&mut x, 2, 7, 8, 13);
            qr(&mut x, 3, 4, 9, 14);
        }
        for i in 0..16 {
            x[i] = _mm512_add_epi32(x[i], init[i]);
        }
        // Transpose the 16 x 16 words: 32-bit, then 64-bit interleaves within 128-bit lanes,
        // then two rounds of 128-bit lane shuffles.
        let mut a = [_mm512_setzero_si512(); 16];
        for i in (0..16).step_by(2) {
            a[i] = _mm512_unpacklo_epi32(x[i], x[i + 1]);
            a[i + 1] = _mm512_unpackhi_epi32(x[i], x[i + 1]);
        }
        let mut b = [_mm512_setzero_si512(); 16];
        for g4 in (0..16).step_by(4) {
            for i in [g4, g4 + 1] {
                b[i] = _mm512_unpacklo_epi64(a[i], a[i + 2]);
                b[i + 2] = _mm512_unpackhi_epi64(a[i], a[i + 2]);
            }
        }
        // In row group G (rows 4G..4G+3), column 4L + q sits in 128-bit lane L of
        // b[4G + [0, 2, 1, 3][q]].
        for (q, off) in [0usize, 2, 1, 3].into_iter().enumerate() {
            let v = |gr: usize| b[4 * gr + off];
            let p01 = _mm512_shuffle_i32x4::<0x44>(v(0), v(1));
            let p01h = _mm512_shuffle_i32x4::<0xEE>(v(0), v(1));
            let p23 = _mm512_shuffle_i32x4::<0x44>(v(2), v(3));
            let p23h = _mm512_shuffle_i32x4::<0xEE>(v(2), v(3));
            let cols = [
                _mm512_shuffle_i32x4::<0x88>(p01, p23),
                _mm512_shuffle_i32x4::<0xDD>(p01, p23),
                _mm512_shuffle_i32x4::<0x88>(p01h, p23h),
                _mm512_shuffle_i32x4::<0xDD>(p01h, p23h),
            ];
            for (l, col) in cols.into_iter().enumerate() {
                let block = 4 * l + q;
                // SAFETY: block < 16 and the group holds 16 blocks of 16 words.
                unsafe { _mm512_storeu_si512(group.as_mut_ptr().add(16 * block).cast(), col) };
            }
        }
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
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx2")
        {
            // SAFETY: the CPU supports AVX-512 F and VL and AVX2, checked just above.
            return unsafe { transform_avx512(words, re, im) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { transform_avx2(words, re, im) };
        }
    }
    transform_body(words, re, im)
}

/// [`transform`] on AVX-512: two blocks at a time as 16 lanes (each lane the same function of
/// its two words, so the same values), then the rest as on AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2")]
fn transform_avx512(words: &[u32], re: &mut [f32], im: &mut [f32]) {
    const W: usize = 2 * LANES;
    let pairs = re.len() / W;
    for b in 0..pairs {
        let w: &[u32; 2 * W] = words[2 * W * b..][..2 * W].try_into().expect("two blocks");
        // Radius words of both blocks, then their angle words.
        let u: [u32; W] = std::array::from_fn(|k| w[(k / LANES) * W + k % LANES]);
        let v: [u32; W] = std::array::from_fn(|k| w[(k / LANES) * W + LANES + k % LANES]);
        let r: &mut [f32; W] = (&mut re[W * b..][..W]).try_into().expect("two blocks");
        let m: &mut [f32; W] = (&mut im[W * b..][..W]).try_into().expect("two blocks");
        for k in 0..W {
            (r[k], m[k]) = lane(u[k], v[k]);
        }
    }
    let done = pairs * W;
    transform_body(&words[2 * done..], &mut re[done..], &mut im[done..]);
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

    /// The words are `rand_chacha`'s ChaCha8 stream, whichever path makes them (seeds, streams
    /// and lengths around the 256-word groups of the AVX-512 path, and a counter near 2^32).
    #[test]
    fn words_are_rand_chacha_words() {
        for (seed, stream, count) in [
            (0u64, 0u64, 1usize),
            (5, 3, 255),
            (5, 3, 256),
            (9, 1 << 40, 12800),
            (77, 2, 1000),
        ] {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(stream);
            let want: Vec<u32> = (0..count).map(|_| rng.next_u32()).collect();
            let mut got = Vec::new();
            fill_words(seed, stream, count, &mut got);
            assert_eq!(got, want, "seed {seed}, stream {stream}, {count} words");
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            let mut rng = ChaCha8Rng::seed_from_u64(4);
            rng.set_stream(6);
            let first = (1u64 << 32) - 3;
            rng.set_word_pos(u128::from(first) * 16);
            let want: Vec<u32> = (0..512).map(|_| rng.next_u32()).collect();
            let key = key_words(&rng.get_seed());
            let mut got = vec![0u32; 512];
            // SAFETY: AVX-512F is present, checked just above; 512 words are two groups.
            unsafe { chacha8_avx512(&key, 6, first, &mut got) };
            assert_eq!(got, want, "the block counter carries into its high word");
        }
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
