//! Sine and cosine of many phases at once, for the ISAR forward model's phase factors
//! ([`super::isar::point_response`]), where glibc's scalar `sincos` was 42-45 % of a vegetation
//! dataset's CPU.
//!
//! [`sincos`] reduces `x` by multiples of `pi / 2` (Cody-Waite: `pi / 2` in three parts, each
//! product subtracted with one fused multiply-add) and evaluates fdlibm's minimax polynomials of
//! `sin` and `cos` on `[-pi/4, pi/4]` (`__kernel_sin`, `__kernel_cos` coefficients) by Horner's
//! rule with fused multiply-adds, then picks the quadrant without branches. Every operation is
//! an IEEE add, multiply or fused multiply-add, so a value is the same bits on every machine and
//! in every lane width: [`sincos_slice`] compiles the same loop for AVX-512 or AVX2 (and FMA)
//! where the CPU has them, and results never depend on glibc's version. Arguments beyond
//! [`REDUCED`] in magnitude, infinities and NaN go to `f64::sin_cos`.
//!
//! Accuracy (tested against `f64::sin_cos` on seeded random phases up to [`REDUCED`], and at
//! multiples of `pi / 4`): at most 2.3e-16 from libm's values (about one unit in the last place
//! of 1), far below the 1e-14 that the phase recurrence of the forward model already allows.

/// `pi / 2` in three parts whose sum is `pi / 2` to about 160 bits.
const PIO2_HI: f64 = std::f64::consts::FRAC_PI_2;
const PIO2_MID: f64 = 6.123_233_995_736_766e-17;
const PIO2_LO: f64 = -1.497_384_904_859_169_8e-33;
/// `2 / pi`.
const TWO_OVER_PI: f64 = std::f64::consts::FRAC_2_PI;
/// `1.5 * 2^52`: added to a value of magnitude below `2^51`, it rounds it to the nearest integer
/// (ties to even), which then sits in the low bits of the sum's mantissa.
const ROUNDER: f64 = 6_755_399_441_055_744.0;

/// Largest `|x|` reduced here (`2^20 pi / 2`); beyond it, `f64::sin_cos`.
pub const REDUCED: f64 = 1_647_099.319_067_339_2;

/// fdlibm `__kernel_sin`: `sin(r) = r + r^3 (S1 + r^2 (S2 + ...))` on `[-pi/4, pi/4]`.
const S: [f64; 6] = [
    -0.16666666666666632,
    0.00833333333332249,
    -0.0001984126982985795,
    2.7557313707070068e-06,
    -2.5050760253406863e-08,
    1.58969099521155e-10,
];
/// fdlibm `__kernel_cos`: `cos(r) = 1 - r^2 / 2 + r^4 (C1 + r^2 (C2 + ...))`.
const C: [f64; 6] = [
    0.0416666666666666,
    -0.001388888888887411,
    2.480158728947673e-05,
    -2.7557314351390663e-07,
    2.087572321298175e-09,
    -1.1359647557788195e-11,
];

/// `k[0] + w (k[1] + w (... + w k[5]))` by Horner's rule with fused multiply-adds.
#[inline(always)]
fn horner(w: f64, k: &[f64; 6]) -> f64 {
    k[5].mul_add(w, k[4])
        .mul_add(w, k[3])
        .mul_add(w, k[2])
        .mul_add(w, k[1])
        .mul_add(w, k[0])
}

/// `(sin x, cos x)` for `|x| <= REDUCED` (the caller checks); branch-free, so that loops over
/// it vectorise.
#[inline(always)]
fn reduced(x: f64) -> (f64, f64) {
    let t = x * TWO_OVER_PI + ROUNDER;
    let n = t.to_bits();
    let q = t - ROUNDER;
    let r = (-q).mul_add(PIO2_HI, x);
    let r = (-q).mul_add(PIO2_MID, r);
    let r = (-q).mul_add(PIO2_LO, r);
    let w = r * r;
    let s = (r * w).mul_add(horner(w, &S), r);
    let c = (w * w).mul_add(horner(w, &C), (-0.5f64).mul_add(w, 1.0));
    // Quadrant q mod 4 (the low bits of `t`'s mantissa): 0 (s, c), 1 (c, -s), 2 (-s, -c),
    // 3 (-c, s).
    let swap = n & 1 != 0;
    let (sv, cv) = if swap { (c, s) } else { (s, c) };
    let sin_sign = (n & 2) << 62;
    let cos_sign = (n.wrapping_add(1) & 2) << 62;
    (
        f64::from_bits(sv.to_bits() ^ sin_sign),
        f64::from_bits(cv.to_bits() ^ cos_sign),
    )
}

/// Whether [`reduced`] takes `x` (not NaN, `|x| <= REDUCED`).
#[inline(always)]
fn in_range(x: f64) -> bool {
    x.abs() <= REDUCED
}

/// `(sin x, cos x)`: [`reduced`] for `|x| <= REDUCED`, `f64::sin_cos` otherwise (and for
/// infinities and NaN).
#[inline]
pub fn sincos(x: f64) -> (f64, f64) {
    if in_range(x) {
        reduced(x)
    } else {
        x.sin_cos()
    }
}

/// `sin[i], cos[i] = sincos(x[i])` for every `i` (the three slices have one length), the
/// same bits as [`sincos`] one value at a time, vectorised where the CPU allows.
///
/// # Panics
/// If the lengths differ.
pub fn sincos_slice(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    assert!(x.len() == sin.len() && x.len() == cos.len(), "one length");
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports AVX-512F and FMA, checked just above.
            return unsafe { slice_avx512(x, sin, cos) };
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports AVX2 and FMA, checked just above.
            return unsafe { slice_avx2(x, sin, cos) };
        }
    }
    slice_body(x, sin, cos)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
fn slice_avx512(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    slice_body(x, sin, cos)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn slice_avx2(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    slice_body(x, sin, cos)
}

/// The loop of [`sincos_slice`]: every value reduced (vectorised), then the few out of range
/// redone by `f64::sin_cos`.
#[inline(always)]
fn slice_body(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    for ((&x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        (*s, *c) = reduced(x);
    }
    for ((&x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        if !in_range(x) {
            (*s, *c) = x.sin_cos();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Largest absolute difference from `f64::sin_cos` over `xs`.
    fn worst(xs: &[f64]) -> f64 {
        let (mut s, mut c) = (vec![0.0; xs.len()], vec![0.0; xs.len()]);
        sincos_slice(xs, &mut s, &mut c);
        xs.iter()
            .zip(s.iter().zip(&c))
            .map(|(&x, (&s, &c))| {
                let (es, ec) = x.sin_cos();
                (s - es).abs().max((c - ec).abs())
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn agrees_with_libm_to_a_unit_in_the_last_place_of_one() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for scale in [1.0, 10.0, 1e3, 1e5, REDUCED] {
            let xs: Vec<f64> = (0..200_000)
                .map(|_| rng.random_range(-scale..=scale))
                .collect();
            let e = worst(&xs);
            assert!(e <= 2.3e-16, "scale {scale}: {e:e}");
        }
        // Near the quadrant boundaries, where the reduction cancels most.
        let xs: Vec<f64> = (-4000..4000)
            .flat_map(|k| {
                let x = k as f64 * std::f64::consts::FRAC_PI_4;
                [x, x.next_up(), x.next_down()]
            })
            .collect();
        assert!(worst(&xs) <= 2.3e-16);
    }

    #[test]
    fn the_slice_and_the_scalar_form_are_the_same_bits_and_extremes_go_to_libm() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let mut xs: Vec<f64> = (0..1001).map(|_| rng.random_range(-3e3..3e3)).collect();
        xs.extend([
            0.0,
            -0.0,
            1e-300,
            REDUCED,
            -REDUCED,
            REDUCED.next_up(),
            1e10,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ]);
        let (mut s, mut c) = (vec![0.0; xs.len()], vec![0.0; xs.len()]);
        sincos_slice(&xs, &mut s, &mut c);
        let (mut ps, mut pc) = (vec![0.0; xs.len()], vec![0.0; xs.len()]);
        slice_body(&xs, &mut ps, &mut pc);
        for (i, &x) in xs.iter().enumerate() {
            let (es, ec) = sincos(x);
            for (got, want) in [(s[i], es), (c[i], ec), (ps[i], es), (pc[i], ec)] {
                assert!(
                    got.to_bits() == want.to_bits() || got.is_nan() && want.is_nan(),
                    "x = {x:e}: {got:e} vs {want:e}"
                );
            }
            if !in_range(x) {
                let (ls, lc) = x.sin_cos();
                assert!(es.to_bits() == ls.to_bits() || es.is_nan() && ls.is_nan());
                assert!(ec.to_bits() == lc.to_bits() || ec.is_nan() && lc.is_nan());
            }
        }
        assert_eq!(sincos(0.0), (0.0, 1.0));
    }
}
