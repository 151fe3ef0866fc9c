//! Synthesis benchmark (`cargo bench --bench synthesis`): generated 64 x 64 complex samples per
//! second per method on a rayon pool of 2 threads, the spatially varying filter kernel's
//! GFLOP/s, and this machine's measured peak for comparison (a fused multiply-add loop over
//! registers on every thread). Figures go to BENCHMARKS.md.

/// The binary's allocator, so that figures match what `isar-clutter` does.
#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

use isar_clutter::experiment::{filter_bank, generate};
use isar_clutter::experiment::{FilterParams, FilteredNoise, Map, RampAxis};
use isar_clutter::seeds::white_seed;
use isar_clutter::stats::analysis::analyse;
use isar_clutter::stats::filters::filter_seed;
use isar_clutter::synthesis::{fit, FitOptions, Method};
use num_complex::Complex64;
use rayon::prelude::*;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Peak f64 throughput: fused multiply-adds (AVX2 + FMA) on 10 independent 4-lane
/// accumulators per thread, 2 flops per lane and step; 0 where the CPU lacks FMA.
fn peak_gflops(threads: usize) -> f64 {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn fast(k: usize, steps: u64) -> f64 {
        use std::arch::x86_64::*;
        let m = _mm256_set1_pd(std::hint::black_box(1.000_000_1));
        let a = _mm256_set1_pd(std::hint::black_box(1e-9 * (k + 1) as f64));
        let mut acc = [_mm256_setzero_pd(); 10];
        for _ in 0..steps {
            for v in acc.iter_mut() {
                *v = _mm256_fmadd_pd(*v, m, a);
            }
        }
        let mut out = [0.0f64; 4];
        let sum = acc
            .iter()
            .fold(_mm256_setzero_pd(), |s, v| _mm256_add_pd(s, *v));
        // SAFETY: `out` holds four f64, the width of the stored vector.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), sum) };
        out.iter().sum()
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        let steps = 20_000_000u64;
        let t = Instant::now();
        // SAFETY: the CPU has AVX2 and FMA, checked just above.
        let s: f64 = (0..threads)
            .into_par_iter()
            .map(|k| unsafe { fast(k, steps) })
            .sum();
        std::hint::black_box(s);
        return (threads as u64 * steps * 10 * 4 * 2) as f64 / t.elapsed().as_secs_f64() / 1e9;
    }
    0.0
}

fn main() {
    isar_clutter::alloc::tune_malloc();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| {
        println!(
            "peak (AVX2 FMA loop, 2 threads): {:.1} GFLOP/s",
            peak_gflops(2)
        );
        let ramp = FilterParams::Exponential { alpha_h: Map::Ramp(RampAxis::Horizontal, 0.5, 2.0), alpha_v: Map::Constant(1.0) };
        let d = FilteredNoise::new(ramp, (64, 64), 1000, 8);
        let bank = filter_bank(&d);
        // Kernel alone, on a Method 1 bank (taps shared within 2 x 2 cells, as every fitted
        // model has): per pair of rows and column, (2 + 2K) horizontal sums of 2K+1 taps and
        // 2 x (2K+1) vertical terms, each a multiply and an add per component.
        let stack = generate(&d, &bank, 2).unwrap();
        let a1 = analyse(stack.view(), 1).unwrap();
        let m1 = fit(Method::Method1, &a1, None, FitOptions::default()).unwrap();
        let cell_bank = &m1.filter().unwrap().bank;
        let seeds: Vec<_> = (0..64).map(|s| white_seed(1, s, 80, 80)).collect();
        let reps: Vec<f64> = (0..5)
            .map(|_| {
                let t = Instant::now();
                seeds.par_iter().for_each(|s| {
                    let mut out = vec![Complex64::new(0.0, 0.0); 64 * 64];
                    filter_seed(cell_bank, s.view(), &mut out);
                    std::hint::black_box(out);
                });
                t.elapsed().as_secs_f64()
            })
            .collect();
        let (n, rows) = (17.0, 32.0);
        let flops_per_sample = rows * 64.0 * ((2.0 + n - 1.0) * n + 2.0 * n) * 2.0 * 2.0;
        let t = median(reps);
        println!("spatially varying filter kernel (Method 1 bank), 64x64, K = 8: {:.0} samples/s, {:.1} GFLOP/s executed", 64.0 / t, 64.0 * flops_per_sample / t / 1e9);
        let t = Instant::now();
        let seeds_only: Vec<_> = (0..256)
            .into_par_iter()
            .map(|s| white_seed(1, s, 80, 80))
            .collect();
        std::hint::black_box(seeds_only);
        println!(
            "white seeds (80 x 80 complex, ChaCha20): {:.0} per s",
            256.0 / t.elapsed().as_secs_f64()
        );

        for n_fit in [100, 1000] {
            let mut dd = d.clone();
            dd.samples = n_fit;
            let stack = generate(&dd, &bank, 2).unwrap();
            let a = analyse(stack.view(), 3).unwrap();
            for method in [
                Method::Method1,
                Method::Method2,
                Method::FullCovariance,
                Method::Uncorrelated,
            ] {
                let model = fit(method, &a, Some(stack.view()), FitOptions::default()).unwrap();
                let m = 2000;
                let reps: Vec<f64> = (0..3)
                    .map(|_| {
                        let t = Instant::now();
                        std::hint::black_box(model.generate_c64(3, 0, m));
                        t.elapsed().as_secs_f64()
                    })
                    .collect();
                let rate = m as f64 / median(reps);
                // Full covariance: 2 N flops (a fused multiply-add) per real output column.
                let gemm = if method == Method::FullCovariance {
                    format!(", kernel {:.1} GFLOP/s of f32 FMA", rate * 2.0 * n_fit as f64 * 2.0 * 4096.0 / 1e9)
                } else {
                    String::new()
                };
                println!(
                    "fitted on {n_fit}: {:<16} {:>8.0} samples/s{gemm}",
                    method.as_str(),
                    rate
                );
            }
        }
    });
}
