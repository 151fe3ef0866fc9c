//! CNN training benchmark (`cargo bench --bench cnn`, or `make bench-cnn` beside PyTorch):
//! samples per second of forward + backward + SGD-momentum update at batch 128 for the
//! networks of Table 18 (4 classes) and Table 23 (25 classes) on 64 x 64 inputs, measured
//! through [`isar_clutter::apps::cnn::train::train`], the function every training job runs, as
//! each job reports it (`train_samples_per_second`): on a rayon pool of 1 and of 2 threads, and
//! two trainings side by side on 1 thread each (what a run of many trainings does); then the
//! prediction rate (forward only, inference mode: what validation and testing run) of the
//! trained network through [`isar_clutter::apps::cnn::train::Trained::evaluate`] on 1 and 2
//! threads. Prints one JSON object per line with `--json`; `CNN_BENCH_BATCHES` (default 8)
//! and `CNN_BENCH_NETS` (`table18`, `table23`) shorten it. Figures go to BENCHMARKS.md.

/// The binary's allocator, so that figures match what `isar-clutter` does.
#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

use isar_clutter::apps::cnn::net::{Arch, NetConfig};
use isar_clutter::apps::cnn::train::{train, Labelled, TrainingOptions};
use num_complex::Complex32;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};

/// `n` random 64 x 64 images with labels cycling through `classes`.
fn data(n: usize, classes: usize, seed: u64) -> Labelled {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    let mut set = Labelled::default();
    for k in 0..n {
        let img: Vec<Complex32> = (0..64 * 64)
            .map(|_| {
                let (a, b): (f64, f64) = (
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                Complex32::new(a as f32, b as f32)
            })
            .collect();
        set.push(&img, k % classes);
    }
    set
}

fn main() {
    isar_clutter::alloc::tune_malloc();
    let json = std::env::args().any(|a| a == "--json");
    let batches: usize = std::env::var("CNN_BENCH_BATCHES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(8);
    let n = 128 * batches;
    // `CNN_BENCH_NETS=table18` (or `table23`) measures one network alone (for profiles).
    let only = std::env::var("CNN_BENCH_NETS").ok();
    for (arch, classes, name) in [
        (Arch::Table18, 4, "table18"),
        (Arch::Table23, 25, "table23"),
    ] {
        if only
            .as_deref()
            .is_some_and(|o| !o.split(',').any(|x| x == name))
        {
            continue;
        }
        let cfg = NetConfig {
            arch,
            height: 64,
            width: 64,
            classes,
        };
        let set = data(n, classes, 1);
        let empty = Labelled::default();
        let opts = TrainingOptions {
            epochs: 2,
            ..TrainingOptions::default()
        };
        let mut trained = None;
        for (threads, side_by_side) in [(1, 1), (2, 1), (1, 2)] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let t = std::time::Instant::now();
            let rates: Vec<f64> = if side_by_side == 1 {
                let t = pool.install(|| train(&cfg, &opts, &set, &empty, 7));
                let rate = t.samples_per_second;
                trained = Some(t);
                vec![rate]
            } else {
                std::thread::scope(|s| {
                    let hs: Vec<_> = (0..side_by_side)
                        .map(|k| {
                            let (cfg, opts, set, empty) = (&cfg, &opts, &set, &empty);
                            s.spawn(move || {
                                rayon::ThreadPoolBuilder::new()
                                    .num_threads(1)
                                    .build()
                                    .expect("a pool")
                                    .install(|| {
                                        train(cfg, opts, set, empty, 7 + k as u64)
                                            .samples_per_second
                                    })
                            })
                        })
                        .collect();
                    hs.into_iter()
                        .map(|h| h.join().expect("a training"))
                        .collect()
                })
            };
            let wall = t.elapsed().as_secs_f64();
            let per_training: f64 = rates.iter().sum::<f64>() / rates.len() as f64;
            let total = (side_by_side * n * opts.epochs) as f64 / wall;
            let label = if side_by_side > 1 {
                format!("{side_by_side} trainings x 1 thread")
            } else {
                format!("{threads} thread(s)")
            };
            if json {
                println!(
                    "{{\"net\":\"{name}\",\"threads\":{threads},\"trainings\":{side_by_side},\"batch_size\":128,\"samples_per_second\":{per_training:.1},\"machine_samples_per_second\":{total:.1}}}"
                );
            } else {
                println!(
                    "burn flex {name}: {label}: {per_training:.0} samples/s per training (steps only), {total:.0} samples/s for the machine (wall, with data preparation)"
                );
            }
        }
        let trained = trained.expect("a training on one pool");
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            // One untimed pass (buffers, caches), then the timed ones.
            pool.install(|| trained.evaluate(&set));
            let passes = 3;
            let t = std::time::Instant::now();
            for _ in 0..passes {
                std::hint::black_box(pool.install(|| trained.evaluate(&set)));
            }
            let rate = (passes * n) as f64 / t.elapsed().as_secs_f64();
            if json {
                println!(
                    "{{\"net\":\"{name}\",\"threads\":{threads},\"mode\":\"predict\",\"batch_size\":128,\"samples_per_second\":{rate:.1}}}"
                );
            } else {
                println!(
                    "burn flex {name}: {threads} thread(s): {rate:.0} samples/s predicted (forward only, inference mode)"
                );
            }
        }
    }
}
