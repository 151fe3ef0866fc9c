//! The micro-kernels of the CMD products: an AVX2+FMA kernel (runtime-detected) and its
//! portable body, both accumulating f32 products over at most `KC_MAX` terms.

use super::layout::{MR, NR, TILE};
// ---------------------------------------------------------------------------
// Micro-kernels
// ---------------------------------------------------------------------------

/// `out[j*2*MR + l] += Re S[l, j]`, `out[j*2*MR + MR + l] += Im S[l, j]` with
/// `S[l, j] = sum_{k < kc} conj(u_lk) v_jk`, for an MR-wide U micro-panel and
/// an NR-wide V micro-panel (f32 products and sums, f64 accumulation in out).
pub(super) type Kernel = fn(usize, &[f32], &[f32], &mut [f64]);

/// Portable micro-kernel (same contract and summation structure as the AVX2
/// one, but plain multiply and add, so not bitwise identical to it).
pub(super) fn kernel_portable(kc: usize, u: &[f32], v: &[f32], out: &mut [f64]) {
    let u = &u[..kc * 2 * MR];
    let v = &v[..kc * 2 * NR];
    let out = &mut out[..TILE];
    let mut re = [[0.0f32; MR]; NR];
    let mut im = [[0.0f32; MR]; NR];
    for (uk, vk) in u.chunks_exact(2 * MR).zip(v.chunks_exact(2 * NR)) {
        let (ur, ui) = uk.split_at(MR);
        for j in 0..NR {
            let (vr, vi) = (vk[j], vk[NR + j]);
            for l in 0..MR {
                re[j][l] += ur[l] * vr + ui[l] * vi;
                im[j][l] += ur[l] * vi - ui[l] * vr;
            }
        }
    }
    for j in 0..NR {
        for l in 0..MR {
            out[j * 2 * MR + l] += re[j][l] as f64;
            out[j * 2 * MR + MR + l] += im[j][l] as f64;
        }
    }
}

/// AVX2+FMA micro-kernel: 6 x 2 accumulator registers (re and im of 8 rows
/// for each of the 6 columns), 2 vector loads and 12 broadcasts per k for 24
/// FMAs, i.e. FMA-bound on Zen 3.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn kernel_avx2(kc: usize, u: &[f32], v: &[f32], out: &mut [f64]) {
    use std::arch::x86_64::*;
    assert!(u.len() >= kc * 2 * MR && v.len() >= kc * 2 * NR && out.len() >= TILE);
    let mut re = [_mm256_setzero_ps(); NR];
    let mut im = [_mm256_setzero_ps(); NR];
    let up = u.as_ptr();
    let vp = v.as_ptr();
    // Per k: 2 vector loads, 12 broadcasts, 24 FMAs.
    for k in 0..kc {
        // SAFETY: k < kc and the lengths were checked above.
        unsafe {
            let ur = _mm256_loadu_ps(up.add(k * 2 * MR));
            let ui = _mm256_loadu_ps(up.add(k * 2 * MR + MR));
            let vk = vp.add(k * 2 * NR);
            for j in 0..NR {
                let vr = _mm256_broadcast_ss(&*vk.add(j));
                re[j] = _mm256_fmadd_ps(ur, vr, re[j]);
                im[j] = _mm256_fnmadd_ps(ui, vr, im[j]);
                let vi = _mm256_broadcast_ss(&*vk.add(NR + j));
                re[j] = _mm256_fmadd_ps(ui, vi, re[j]);
                im[j] = _mm256_fmadd_ps(ur, vi, im[j]);
            }
        }
    }
    let op = out.as_mut_ptr();
    for j in 0..NR {
        for (h, acc) in [re[j], im[j]].into_iter().enumerate() {
            // SAFETY: j * 2 * MR + h * MR + 8 <= TILE <= out.len().
            unsafe {
                let o = op.add(j * 2 * MR + h * MR);
                let lo = _mm256_cvtps_pd(_mm256_castps256_ps128(acc));
                let hi = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(acc));
                _mm256_storeu_pd(o, _mm256_add_pd(_mm256_loadu_pd(o), lo));
                _mm256_storeu_pd(o.add(4), _mm256_add_pd(_mm256_loadu_pd(o.add(4)), hi));
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
fn kernel_avx2_checked(kc: usize, u: &[f32], v: &[f32], out: &mut [f64]) {
    // SAFETY: only selected by `select_kernel` after runtime detection.
    unsafe { kernel_avx2(kc, u, v, out) }
}

/// The fastest micro-kernel this CPU supports.
pub(super) fn select_kernel() -> Kernel {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            return kernel_avx2_checked;
        }
    }
    kernel_portable
}
