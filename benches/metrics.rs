//! Similarity metrics benchmark (`cargo bench --bench metrics`): the correlation matrix
//! distance between 1000 and 5000 samples of 64 x 64 (issue goal: under 5 s on 2 cores), its
//! Gram/P x P forms and GFLOP/s, and the per-pixel and per-area KL maps of the same stacks, on a
//! rayon pool of 2 threads. Figures go to BENCHMARKS.md.

/// The binary's allocator, so that figures match what `isar-clutter` does.
#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

use isar_clutter::experiment::{filter_bank, generate};
use isar_clutter::experiment::{FilterParams, FilteredNoise, Map};
use isar_clutter::stats::metrics::{kl_maps, KlOptions};
use isar_clutter::stats::similarity::{normalised, usable_pixels};
use ndarray::Array3;
use num_complex::{Complex, Complex64};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn stack(n: usize, seed: u64) -> Array3<Complex64> {
    let d = FilteredNoise::new(
        FilterParams::Exponential {
            alpha_h: Map::Constant(1.0),
            alpha_v: Map::Constant(1.0),
        },
        (64, 64),
        n,
        8,
    );
    generate(&d, &filter_bank(&d), seed).unwrap()
}

fn main() {
    isar_clutter::alloc::tune_malloc();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let repeats = 3;
    let a = stack(1000, 1);
    // The generated side is complex64, as a synthesis job's samples are.
    let b = stack(5000, 2).mapv(|z| Complex::new(z.re as f32, z.im as f32));
    pool.install(|| {
        let mut times = vec![];
        let mut distance = 0.0;
        let mut form = String::new();
        for _ in 0..repeats {
            let t = Instant::now();
            let px = usable_pixels(a.view(), b.view());
            let terms = isar_clutter::stats::cmd::cmd_terms(&normalised(a.view(), &px), &normalised(b.view(), &px));
            times.push(t.elapsed().as_secs_f64());
            distance = terms.distance();
            form = format!("{:?}/{:?}/{:?}", terms.form1, terms.form2, terms.form_cross);
        }
        println!(
            "cmd 1000 vs 5000 x 64x64 (forms {form}): median {:.2} s of {repeats} ({}), distance {distance:.6}",
            median(times.clone()),
            times.iter().map(|t| format!("{t:.2}")).collect::<Vec<_>>().join(", ")
        );
        for (name, block) in [("kl_pixel", 1), ("kl_area", 8)] {
            let mut times = vec![];
            for _ in 0..repeats {
                let t = Instant::now();
                std::hint::black_box(kl_maps(a.view(), b.view(), block, &KlOptions::default()));
                times.push(t.elapsed().as_secs_f64());
            }
            println!(
                "{name} 1000 vs 5000 x 64x64, 32 bins: median {:.3} s of {repeats}",
                median(times)
            );
        }
    });
}
