//! The full-covariance sampler's kernel: `Y = Z D`, a batch of `M` draws `Z` (`M x N`, real
//! standard normals) times the `N` scaled deviations `D` (`N x 2P`, real and imaginary parts
//! interleaved), as an f32 GEMM. Every output element is one fused multiply-add chain over the
//! deviations in ascending order, starting from zero, whatever the batch size, the blocking or
//! the code path (AVX2+FMA micro-kernel or the portable `f32::mul_add` loop), so a sample has
//! the same bits whether it is generated alone or in a batch, on any thread count and on CPUs
//! with or without FMA. [`combine_oracle`] is the slow, obviously correct reference.

use ndarray::ArrayView3;
use num_complex::Complex64;

/// Columns of a packed panel (two AVX registers of f32).
const NR: usize = 16;
/// Rows (samples) of the micro-kernel's tile.
const MR: usize = 6;
/// Deviations per pass over the panels: a panel block (16 KiB) and a row block's draws stay in
/// L1 while the tile's sums run.
const KC: usize = 256;

/// The deviations packed for [`combine`]: panels of 16 columns, each holding all `N`
/// deviations in order (see `slot`), columns beyond `2P` zero.
#[derive(Clone)]
pub struct Panels {
    n: usize,
    cols: usize,
    data: Vec<f32>,
}

impl std::fmt::Debug for Panels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Panels")
            .field("n", &self.n)
            .field("cols", &self.cols)
            .finish_non_exhaustive()
    }
}

/// Where column `c` of deviation `k` sits in a packing of `n` deviations.
fn slot(n: usize, k: usize, c: usize) -> usize {
    ((c / NR) * n + k) * NR + c % NR
}

impl Panels {
    /// Packs deviations `[N, H, W]` (complex) as `N x 2HW` real columns, rounded to f32.
    pub fn new(dev: ArrayView3<Complex64>) -> Panels {
        let (n, h, w) = dev.dim();
        let cols = 2 * h * w;
        let npanels = cols.div_ceil(NR);
        let mut data = vec![0.0f32; npanels * n * NR];
        for (k, d) in dev.outer_iter().enumerate() {
            for (p, z) in d.iter().enumerate() {
                for (c, v) in [(2 * p, z.re), (2 * p + 1, z.im)] {
                    data[slot(n, k, c)] = v as f32;
                }
            }
        }
        Panels { n, cols, data }
    }

    /// Number of deviations `N`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of real columns `2P`.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Deviation `k`'s column `c`, as packed.
    fn at(&self, k: usize, c: usize) -> f32 {
        self.data[slot(self.n, k, c)]
    }
}

/// `out = z D` for `rows` draws: `z` is `rows x N` row-major, `out` is `rows x 2P` row-major
/// (complex samples as interleaved f32 pairs). Each element is `fma(z_k, d_k, acc)` for
/// `k = 0..N` in order from `acc = 0`, so the result equals [`combine_oracle`] bit for bit.
///
/// # Panics
/// If `z` or `out` is not of the stated size.
pub fn combine(panels: &Panels, z: &[f32], rows: usize, out: &mut [f32]) {
    combine_then(panels, z, rows, out, |_, _| {});
}

/// [`combine`], then `finish(c0, values)` on every finished run of a row's values (columns
/// `c0 .. c0 + values.len()`, at most 16) while it is still in L1, before it is stored: what
/// a caller would otherwise do in a second pass over `out` (add the mean, round).
///
/// # Panics
/// If `z` or `out` is not of the stated size.
pub fn combine_then(
    panels: &Panels,
    z: &[f32],
    rows: usize,
    out: &mut [f32],
    finish: impl Fn(usize, &mut [f32]),
) {
    let (n, cols) = (panels.n, panels.cols);
    assert_eq!(z.len(), rows * n, "z must be rows x N");
    assert_eq!(out.len(), rows * cols, "out must be rows x 2P");
    let kernel = select_kernel();
    let nrb = rows.div_ceil(MR);
    let npanels = cols.div_ceil(NR);
    let mut zt = vec![0.0f32; nrb * KC * MR];
    for k0 in (0..n).step_by(KC) {
        let kc = KC.min(n - k0);
        // The draws of this deviation block, per row block k-major (`zt[(rb * kc + k) * MR + r]`),
        // rows beyond `rows` zero.
        for rb in 0..nrb {
            for k in 0..kc {
                for r in 0..MR {
                    let row = rb * MR + r;
                    zt[(rb * kc + k) * MR + r] = if row < rows { z[row * n + k0 + k] } else { 0.0 };
                }
            }
        }
        for j in 0..npanels {
            let c0 = j * NR;
            let panel = &panels.data[slot(n, k0, c0)..slot(n, k0 + kc, c0)];
            let cw = NR.min(cols - c0);
            for rb in 0..nrb {
                let rh = MR.min(rows - rb * MR);
                let mut tile = [0.0f32; MR * NR];
                if k0 > 0 {
                    for r in 0..rh {
                        let o = (rb * MR + r) * cols + c0;
                        tile[r * NR..r * NR + cw].copy_from_slice(&out[o..o + cw]);
                    }
                }
                kernel(kc, &zt[rb * kc * MR..(rb + 1) * kc * MR], panel, &mut tile);
                for r in 0..rh {
                    let o = (rb * MR + r) * cols + c0;
                    let values = &mut tile[r * NR..r * NR + cw];
                    if k0 + kc == n {
                        finish(c0, values);
                    }
                    out[o..o + cw].copy_from_slice(values);
                }
            }
        }
    }
}

/// The slow reference for [`combine`]: per element, a fused multiply-add chain over the
/// deviations in ascending order, read from the packed panels one by one.
pub fn combine_oracle(panels: &Panels, z: &[f32], rows: usize, out: &mut [f32]) {
    let (n, cols) = (panels.n, panels.cols);
    for r in 0..rows {
        for c in 0..cols {
            let mut acc = 0.0f32;
            for k in 0..n {
                acc = z[r * n + k].mul_add(panels.at(k, c), acc);
            }
            out[r * cols + c] = acc;
        }
    }
}

/// A micro-kernel: `tile[r][c] = fma(zt[k][r], panel[k][c], tile[r][c])` for `k = 0..kc`.
type Kernel = fn(usize, &[f32], &[f32], &mut [f32; MR * NR]);

/// The portable micro-kernel (`f32::mul_add`, fused on every CPU).
fn kernel_portable(kc: usize, zt: &[f32], panel: &[f32], tile: &mut [f32; MR * NR]) {
    for k in 0..kc {
        let b = &panel[k * NR..(k + 1) * NR];
        for r in 0..MR {
            let a = zt[k * MR + r];
            for (t, &v) in tile[r * NR..(r + 1) * NR].iter_mut().zip(b) {
                *t = a.mul_add(v, *t);
            }
        }
    }
}

/// The AVX2+FMA micro-kernel: the 6 x 16 tile in 12 registers; per deviation 2 loads,
/// 6 broadcasts and 12 fused multiply-adds.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn kernel_fma(kc: usize, zt: &[f32], panel: &[f32], tile: &mut [f32; MR * NR]) {
    use std::arch::x86_64::*;
    assert!(zt.len() >= kc * MR && panel.len() >= kc * NR);
    let tp = tile.as_mut_ptr();
    // SAFETY: every tile offset is below MR * NR; every zt and panel offset is below kc * MR
    // and kc * NR, checked above.
    unsafe {
        let mut acc = [[_mm256_setzero_ps(); 2]; MR];
        for (r, a) in acc.iter_mut().enumerate() {
            a[0] = _mm256_loadu_ps(tp.add(r * NR));
            a[1] = _mm256_loadu_ps(tp.add(r * NR + 8));
        }
        let (zp, pp) = (zt.as_ptr(), panel.as_ptr());
        for k in 0..kc {
            let b0 = _mm256_loadu_ps(pp.add(k * NR));
            let b1 = _mm256_loadu_ps(pp.add(k * NR + 8));
            for (r, a) in acc.iter_mut().enumerate() {
                let z = _mm256_broadcast_ss(&*zp.add(k * MR + r));
                a[0] = _mm256_fmadd_ps(z, b0, a[0]);
                a[1] = _mm256_fmadd_ps(z, b1, a[1]);
            }
        }
        for (r, a) in acc.iter().enumerate() {
            _mm256_storeu_ps(tp.add(r * NR), a[0]);
            _mm256_storeu_ps(tp.add(r * NR + 8), a[1]);
        }
    }
}

#[cfg(target_arch = "x86_64")]
fn kernel_fma_checked(kc: usize, zt: &[f32], panel: &[f32], tile: &mut [f32; MR * NR]) {
    // SAFETY: only selected by `select_kernel` after runtime detection.
    unsafe { kernel_fma(kc, zt, panel, tile) }
}

/// The fastest micro-kernel this CPU supports.
fn select_kernel() -> Kernel {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            return kernel_fma_checked;
        }
    }
    kernel_portable
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(seed: u64, n: usize, h: usize, w: usize, rows: usize) -> (Panels, Vec<f32>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let dev = Array3::from_shape_fn((n, h, w), |_| {
            Complex64::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5)
        });
        let z = (0..rows * n)
            .map(|_| rng.random::<f32>() * 4.0 - 2.0)
            .collect();
        (Panels::new(dev.view()), z)
    }

    #[test]
    fn combine_equals_the_oracle_bit_for_bit() {
        // N across the deviation block (256), 2P not a multiple of 16, rows not a multiple of 6.
        for (seed, n, h, w, rows) in [
            (1, 1, 1, 1, 1),
            (2, 5, 3, 7, 7),
            (3, 100, 8, 8, 13),
            (4, 300, 5, 9, 6),
            (5, 513, 4, 4, 2),
        ] {
            let (panels, z) = random(seed, n, h, w, rows);
            let mut fast = vec![f32::NAN; rows * panels.cols()];
            let mut slow = fast.clone();
            combine(&panels, &z, rows, &mut fast);
            combine_oracle(&panels, &z, rows, &mut slow);
            assert!(
                fast.iter()
                    .zip(&slow)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "N = {n}, {h}x{w}, {rows} rows"
            );
            // The portable kernel path gives the same bits as the selected one.
            let mut tile_fast = [0.5f32; MR * NR];
            let mut tile_port = tile_fast;
            let kc = n.min(KC);
            let zt: Vec<f32> = z.iter().cycle().take(kc * MR).copied().collect();
            let panel = &panels.data[..kc * NR];
            select_kernel()(kc, &zt, panel, &mut tile_fast);
            kernel_portable(kc, &zt, panel, &mut tile_port);
            assert_eq!(tile_fast.map(f32::to_bits), tile_port.map(f32::to_bits));
        }
    }

    #[test]
    fn finish_sees_every_final_value_once() {
        // Adding a per-column offset in `finish` equals adding it after `combine`.
        let (panels, z) = random(12, 300, 3, 7, 8);
        let cols = panels.cols();
        let offset: Vec<f32> = (0..cols).map(|c| c as f32 * 0.25).collect();
        let mut plain = vec![0.0f32; 8 * cols];
        combine(&panels, &z, 8, &mut plain);
        let mut fused = vec![0.0f32; 8 * cols];
        combine_then(&panels, &z, 8, &mut fused, |c0, v| {
            for (x, o) in v.iter_mut().zip(&offset[c0..]) {
                *x += o;
            }
        });
        for (i, (f, p)) in fused.iter().zip(&plain).enumerate() {
            assert_eq!(*f, p + offset[i % cols]);
        }
    }

    #[test]
    fn a_row_alone_equals_the_same_row_in_a_batch() {
        let (panels, z) = random(9, 40, 6, 5, 11);
        let cols = panels.cols();
        let mut batch = vec![0.0f32; 11 * cols];
        combine(&panels, &z, 11, &mut batch);
        for r in [0, 5, 6, 10] {
            let mut one = vec![0.0f32; cols];
            combine(&panels, &z[r * 40..(r + 1) * 40], 1, &mut one);
            assert_eq!(one, batch[r * cols..(r + 1) * cols]);
        }
    }

    #[test]
    fn combine_is_the_product_of_draws_and_deviations() {
        // Against an f64 product: f32 rounding of inputs and sums, |error| << 1e-4 for N = 64.
        let (panels, z) = random(11, 64, 4, 4, 3);
        let mut out = vec![0.0f32; 3 * panels.cols()];
        combine(&panels, &z, 3, &mut out);
        for r in 0..3 {
            for c in 0..panels.cols() {
                let want: f64 = (0..64)
                    .map(|k| f64::from(z[r * 64 + k]) * f64::from(panels.at(k, c)))
                    .sum();
                assert!((f64::from(out[r * panels.cols() + c]) - want).abs() < 1e-4);
            }
        }
    }
}
