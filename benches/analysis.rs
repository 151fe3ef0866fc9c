//! In-process benchmark of the multiscale analysis kernel (`cargo bench --bench analysis`):
//! median time and input throughput of a 3-level analysis of a 1000 x 64 x 64 complex64
//! stack on rayon pools of 1 and 2 threads, after warm-up. Figures go to BENCHMARKS.md.

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

fn main() {
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
