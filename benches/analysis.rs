//! In-process benchmark of the multiscale analysis kernel (`cargo bench --bench analysis`):
//! median time and input throughput of a 3-level analysis of a 1000 x 64 x 64 complex64
//! stack on rayon pools of 1 and 2 threads, after warm-up, next to this machine's memory
//! bandwidth measured in the same run (reading, and copying, 1 GiB on the same threads), the
//! limit for a kernel that reads its input once. Figures go to BENCHMARKS.md.

/// The binary's allocator, so that figures match what `isar-clutter` does.
#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

use isar_clutter::stats::analysis::analyse;
use ndarray::Array3;
use num_complex::Complex;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use std::time::Instant;

/// Memory bandwidth on `threads` threads, GB/s: (read, copy), the median of 5 passes over
/// 1 GiB (far beyond the caches): the sum of every f32 (each thread its own contiguous part,
/// 8 independent accumulators so that it vectorises), and `copy_from_slice` of the same bytes
/// into a second buffer (counted once, as bytes read).
fn bandwidth(threads: usize) -> (f64, f64) {
    use rayon::prelude::*;
    let n = 1usize << 28;
    let a = vec![1.0f32; n];
    let mut b = vec![0.0f32; n];
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let part = n / threads;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let read = median(
        (0..5)
            .map(|_| {
                let t = Instant::now();
                let s: f32 = pool.install(|| {
                    a.par_chunks(part)
                        .map(|c| {
                            let mut acc = [0.0f32; 8];
                            for x in c.chunks_exact(8) {
                                for k in 0..8 {
                                    acc[k] += x[k];
                                }
                            }
                            acc.iter().sum::<f32>()
                        })
                        .sum()
                });
                std::hint::black_box(s);
                (n * 4) as f64 / t.elapsed().as_secs_f64() / 1e9
            })
            .collect(),
    );
    let copy = median(
        (0..5)
            .map(|_| {
                let t = Instant::now();
                pool.install(|| {
                    b.par_chunks_mut(part)
                        .zip(a.par_chunks(part))
                        .for_each(|(d, s)| d.copy_from_slice(s))
                });
                std::hint::black_box(&b);
                (n * 4) as f64 / t.elapsed().as_secs_f64() / 1e9
            })
            .collect(),
    );
    (read, copy)
}

fn main() {
    isar_clutter::alloc::tune_malloc();
    for threads in [1, 2] {
        let (read, copy) = bandwidth(threads);
        println!(
            "memory bandwidth, {threads} thread(s), 1 GiB: read {read:.1} GB/s, copy {copy:.1} GB/s (bytes read)"
        );
    }
    let args: Vec<String> = std::env::args().collect();
    let reps: usize = args
        .iter()
        .position(|a| a == "--reps")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(41);
    for (n, h, w, levels) in [(1000, 64, 64, 3), (100, 256, 256, 3)] {
        let mut rng = ChaCha20Rng::seed_from_u64(1);
        let stack: Array3<Complex<f32>> = Array3::from_shape_simple_fn((n, h, w), || {
            let (re, im): (f32, f32) = (
                StandardNormal.sample(&mut rng),
                StandardNormal.sample(&mut rng),
            );
            Complex::new(re, im)
        });
        let bytes = (n * h * w * 8) as f64;
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut times: Vec<f64> = (0..reps)
                .map(|_| {
                    let t = Instant::now();
                    let a = pool.install(|| analyse(stack.view(), levels).unwrap());
                    std::hint::black_box(a);
                    t.elapsed().as_secs_f64()
                })
                .collect();
            times.sort_by(f64::total_cmp);
            let median = times[reps / 2];
            println!(
                "analyse {n}x{h}x{w} complex64, {levels} levels, {threads} thread(s): median {:.2} ms, min {:.2} ms, {:.2} GB/s of input",
                median * 1e3,
                times[0] * 1e3,
                bytes / median / 1e9
            );
        }
    }
}
