//! The AVX-512 forms of [`super::kernel`]'s three inner blocks (the class sums of a seed row,
//! the horizontal sums, the output pixels): twice the columns of the AVX2 blocks per call, the
//! same operations per lane in the same order (a product, then fused multiply-adds class by
//! class; the pair sums added in class order), so the same bits as the AVX2 and portable
//! paths (`kernel::tests` compares them). `tile` is the kernel's tile width (its `T`): the
//! distance between a slot's components and classes.

use num_complex::Complex32;
use std::arch::x86_64::*;

/// The class sums of 16 columns of one seed row and component (see `kernel::basis_avx2`).
///
/// # Safety
/// The CPU has AVX-512 F; `src - k .. src + 16 + k` is valid for every class offset up to `k`,
/// and `dst + 2 t tile + 16` for every class `t`.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn basis(src: *const f32, hclass: &[Vec<usize>], dst: *mut f32, tile: usize) {
    // SAFETY (whole body): every offset stays within the ranges the caller guarantees.
    unsafe {
        _mm512_storeu_ps(dst, _mm512_loadu_ps(src));
        for (t, class) in hclass.iter().enumerate() {
            let pair =
                |d: usize| _mm512_add_ps(_mm512_loadu_ps(src.add(d)), _mm512_loadu_ps(src.sub(d)));
            let mut acc = pair(class[0]);
            for &d in &class[1..] {
                acc = _mm512_add_ps(acc, pair(d));
            }
            _mm512_storeu_ps(dst.add((1 + t) * 2 * tile), acc);
        }
    }
}

/// The horizontal sums of 32 columns of two rows (the second written only if `pair`; see
/// `kernel::horizontal_avx2`): 8 independent accumulators.
///
/// # Safety
/// The CPU has AVX-512 F; 32 columns from each pointer are valid, for `nt` classes
/// (`coef + t w`, `basis + (2 t + comp) tile`) and both components of the H rows (`+ tile`).
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn horizontal(
    coef: *const f32,
    basis: [*const f32; 2],
    (w, nt, tile): (usize, usize, usize),
    hrow: [*mut f32; 2],
    pair: bool,
) {
    // SAFETY (whole body): every offset stays within the ranges the caller guarantees.
    unsafe {
        let c = [_mm512_loadu_ps(coef), _mm512_loadu_ps(coef.add(16))];
        let mut acc = [[_mm512_setzero_ps(); 4]; 2];
        for r in 0..2 {
            for comp in 0..2 {
                for v in 0..2 {
                    let b = _mm512_loadu_ps(basis[r].add(comp * tile + 16 * v));
                    acc[r][2 * comp + v] = _mm512_mul_ps(c[v], b);
                }
            }
        }
        for t in 1..nt {
            let ct = coef.add(t * w);
            let c = [_mm512_loadu_ps(ct), _mm512_loadu_ps(ct.add(16))];
            for r in 0..2 {
                for comp in 0..2 {
                    for v in 0..2 {
                        let b = _mm512_loadu_ps(basis[r].add((2 * t + comp) * tile + 16 * v));
                        acc[r][2 * comp + v] = _mm512_fmadd_ps(c[v], b, acc[r][2 * comp + v]);
                    }
                }
            }
        }
        for r in 0..1 + usize::from(pair) {
            for comp in 0..2 {
                for v in 0..2 {
                    _mm512_storeu_ps(hrow[r].add(comp * tile + 16 * v), acc[r][2 * comp + v]);
                }
            }
        }
    }
}

/// 32 output pixels from the H rows (see `kernel::vertical_avx2`), the mean added, written as
/// complex values.
///
/// # Safety
/// The CPU has AVX-512 F; 32 columns from each pointer are valid: coefficient rows
/// `0 ..= vclass.len()` (`+ t w`), H rows `centre - d ..= centre + d` for every class offset
/// `d` (`+ r 2 tile`, both components), the mean rows and 32 output values.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn vertical(
    vc: *const f32,
    hsum: *const f32,
    (w, centre, tile): (usize, usize, usize),
    vclass: &[Vec<usize>],
    (mean_re, mean_im): (*const f32, *const f32),
    out: *mut Complex32,
) {
    // SAFETY (whole body): every offset stays within the ranges the caller guarantees.
    unsafe {
        let load4 = |p: *const f32| {
            [
                _mm512_loadu_ps(p),
                _mm512_loadu_ps(p.add(16)),
                _mm512_loadu_ps(p.add(tile)),
                _mm512_loadu_ps(p.add(tile + 16)),
            ]
        };
        let row = |r: usize| hsum.add(r * 2 * tile);
        let c = [_mm512_loadu_ps(vc), _mm512_loadu_ps(vc.add(16))];
        let hc = load4(row(centre));
        let mut acc: [__m512; 4] = std::array::from_fn(|x| _mm512_mul_ps(c[x % 2], hc[x]));
        for (t, class) in vclass.iter().enumerate() {
            let mut s = [_mm512_setzero_ps(); 4];
            for (n, &d) in class.iter().enumerate() {
                let (u, l) = (load4(row(centre + d)), load4(row(centre - d)));
                for x in 0..4 {
                    let p = _mm512_add_ps(u[x], l[x]);
                    s[x] = if n == 0 { p } else { _mm512_add_ps(s[x], p) };
                }
            }
            let ct = vc.add((1 + t) * w);
            let c = [_mm512_loadu_ps(ct), _mm512_loadu_ps(ct.add(16))];
            for x in 0..4 {
                acc[x] = _mm512_fmadd_ps(c[x % 2], s[x], acc[x]);
            }
        }
        // Interleave real and imaginary parts: lanes 0..8 of each, then 8..16.
        let lo = _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23);
        let hi = _mm512_setr_epi32(8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31);
        let o = out as *mut f32;
        for v in 0..2 {
            let re = _mm512_add_ps(_mm512_loadu_ps(mean_re.add(16 * v)), acc[v]);
            let im = _mm512_add_ps(_mm512_loadu_ps(mean_im.add(16 * v)), acc[2 + v]);
            _mm512_storeu_ps(o.add(32 * v), _mm512_permutex2var_ps(re, lo, im));
            _mm512_storeu_ps(o.add(32 * v + 16), _mm512_permutex2var_ps(re, hi, im));
        }
    }
}
