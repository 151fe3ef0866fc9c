//! CNN training benchmark (`cargo bench --bench cnn`, or `make bench-cnn` beside PyTorch):
//! samples per second of forward + backward + SGD-momentum update at batch 128 for the
//! networks of Table 18 (4 classes) and Table 23 (25 classes) on 64 x 64 inputs, measured
//! through [`isar_clutter::apps::cnn::train::train`], the function every training job runs, as
//! each job reports it (`train_samples_per_second`): on a rayon pool of 1 and of 2 threads, and
//! two trainings side by side on 1 thread each (what a run of many trainings does); then the
//! prediction rate (forward only, inference mode: what validation and testing run) of the
//! trained network through [`isar_clutter::apps::cnn::train::Trained::evaluate`] on 1 and 2
//! threads. Prints one JSON object per line with `--json`; `CNN_BENCH_BATCHES` (default 32:
//! with 8, each timed stretch lasted a quarter of a second and repeats of one binary moved by
//! a fifth) and `CNN_BENCH_NETS` (`table18`, `table23`) shorten it. Figures go to
//! BENCHMARKS.md.

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

/// Multiply-add floating-point operations per sample of a training step and of a prediction
/// (`2 x` the multiply-adds of the convolutions and the fully connected layer, from the layer
/// table): forward, then the weight gradients of every layer and the input gradients of all but
/// the first convolution. Normalisation, ReLU and pooling are not counted.
fn flops(cfg: &NetConfig) -> (f64, f64) {
    let mut fwd = 0.0;
    let mut train = 0.0;
    for (b, l) in cfg
        .layers()
        .iter()
        .filter(|l| l.name.starts_with("conv"))
        .enumerate()
    {
        let f = l.activations[2];
        let macs = ((l.learnables - f) * l.activations[0] * l.activations[1]) as f64;
        fwd += 2.0 * macs;
        train += 2.0 * macs * if b == 0 { 2.0 } else { 3.0 };
    }
    let fc = 2.0 * (cfg.flat() * cfg.classes) as f64;
    (train + 3.0 * fc, fwd + fc)
}

/// Peak f32 GFLOP/s of one thread: AVX-512 fused multiply-adds on 12 independent vectors
/// (AVX2 where the processor has no AVX-512), counting a multiply-add as two operations.
fn peak_gflops() -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f")]
        fn run512(steps: u64) -> f32 {
            use std::arch::x86_64::*;
            let m = _mm512_set1_ps(std::hint::black_box(1.000_000_1));
            let a = _mm512_set1_ps(std::hint::black_box(1e-9));
            let mut acc = [_mm512_setzero_ps(); 12];
            for _ in 0..steps {
                for v in acc.iter_mut() {
                    *v = _mm512_fmadd_ps(*v, m, a);
                }
            }
            let sum = acc
                .iter()
                .fold(_mm512_setzero_ps(), |s, v| _mm512_add_ps(s, *v));
            _mm512_reduce_add_ps(sum)
        }
        #[target_feature(enable = "avx2,fma")]
        fn run256(steps: u64) -> f32 {
            use std::arch::x86_64::*;
            let m = _mm256_set1_ps(std::hint::black_box(1.000_000_1));
            let a = _mm256_set1_ps(std::hint::black_box(1e-9));
            let mut acc = [_mm256_setzero_ps(); 12];
            for _ in 0..steps {
                for v in acc.iter_mut() {
                    *v = _mm256_fmadd_ps(*v, m, a);
                }
            }
            let mut out = [0.0f32; 8];
            let sum = acc
                .iter()
                .fold(_mm256_setzero_ps(), |s, v| _mm256_add_ps(s, *v));
            // SAFETY: `out` holds eight f32, the width of the stored vector.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), sum) };
            out.iter().sum()
        }
        let steps = 20_000_000u64;
        let t = std::time::Instant::now();
        let lanes = if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the processor has AVX-512 F, checked just above.
            std::hint::black_box(unsafe { run512(steps) });
            16
        } else if std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the processor has AVX2 and FMA, checked just above.
            std::hint::black_box(unsafe { run256(steps) });
            8
        } else {
            return 0.0;
        };
        return (steps * 12 * lanes * 2) as f64 / t.elapsed().as_secs_f64() / 1e9;
    }
    #[allow(unreachable_code)]
    0.0
}

/// `CNN_BENCH_DEVICE=cuda` (a bench built with the `cuda` feature, on a machine with an
/// NVIDIA GPU): the training rate of `cfg` on the GPU, after one untimed training (kernel
/// compilation, cuDNN's set-up): the cuDNN route as `run` uses it (a step captured as a CUDA
/// graph), the same with every step issued call by call, with algorithms chosen by timing,
/// with TF32 convolutions (and timed algorithms), `N` = 4 and
/// 16 trainings of other seeds at once on one GPU (threads, a stream each; aggregate samples
/// per second over the wall time; ten epochs each), prediction on the GPU (staged samples, forward and arg-max,
/// timed over eight passes of 8 times the set), and burn's CUDA backend; steps only as
/// `samples_per_second` reports them, and the whole training's wall time.
#[cfg(feature = "cuda")]
fn cuda(
    cfg: &NetConfig,
    opts: &TrainingOptions,
    set: &Labelled,
    name: &str,
    flops: f64,
    json: bool,
) {
    use isar_clutter::apps::cnn::device::train_on_device;
    use isar_clutter::apps::cnn::gpu::{self, GpuOptions, Predictor};
    use isar_clutter::apps::cnn::train::Device;
    let empty = Labelled::default();
    // Ten epochs for the cuDNN route (a training of two lasts a few tens of milliseconds);
    // burn's backend keeps the CPU's two.
    let (opts, burn_opts) = (
        &TrainingOptions {
            epochs: 10,
            ..*opts
        },
        opts,
    );
    let report = |route: &str, steps: f64, wall: f64| {
        let gflops = steps * flops / 1e9;
        if json {
            println!(
                "{{\"net\":\"{name}\",\"device\":\"cuda\",\"route\":\"{route}\",\"batch_size\":{},\"samples_per_second\":{steps:.1},\"wall_samples_per_second\":{wall:.1},\"gflops\":{gflops:.1}}}",
                opts.batch_size
            );
        } else {
            println!("{name} {route}: {steps:.0} samples/s (steps; {gflops:.0} GFLOP/s), {wall:.0} samples/s over the whole training");
        }
    };
    let samples_of =
        |o: &TrainingOptions| (set.len() / o.batch_size * o.batch_size * o.epochs) as f64;
    let samples = samples_of(opts);
    let variants = [
        ("cudnn+graph", GpuOptions::default()),
        (
            "cudnn-eager",
            GpuOptions {
                graph: false,
                ..GpuOptions::default()
            },
        ),
        (
            "cudnn+graph+find",
            GpuOptions {
                find: true,
                ..GpuOptions::default()
            },
        ),
        (
            "cudnn+graph+tf32",
            GpuOptions {
                tf32: true,
                ..GpuOptions::default()
            },
        ),
        (
            "cudnn+graph+tf32+find",
            GpuOptions {
                tf32: true,
                find: true,
                ..GpuOptions::default()
            },
        ),
    ];
    let mut trained = None;
    for (route, g) in variants {
        let run = |seed| gpu::train(cfg, opts, set, &empty, seed, g).expect("a cuDNN training");
        run(7);
        let t = run(7);
        report(route, t.samples_per_second, samples / t.seconds);
        trained.get_or_insert(t);
    }
    for n in [4usize, 16] {
        let t = std::time::Instant::now();
        std::thread::scope(|s| {
            for k in 0..n {
                s.spawn(move || {
                    gpu::train(
                        cfg,
                        opts,
                        set,
                        &Labelled::default(),
                        100 + k as u64,
                        GpuOptions::default(),
                    )
                    .expect("a cuDNN training")
                });
            }
        });
        let rate = n as f64 * samples / t.elapsed().as_secs_f64();
        report(&format!("cudnn+graph x{n} at once"), rate, rate);
    }
    let trained = trained.expect("a training");
    let p = Predictor::new(&trained, GpuOptions::default()).expect("a predictor");
    let images: Vec<_> = (0..8).flat_map(|_| set.images.iter().copied()).collect();
    let staged = p.stage(&images).expect("staged");
    p.classes(&staged).expect("a prediction");
    let t = std::time::Instant::now();
    for _ in 0..8 {
        std::hint::black_box(p.classes(&staged).expect("a prediction"));
    }
    let rate = 8.0 * (images.len() / (cfg.height * cfg.width)) as f64 / t.elapsed().as_secs_f64();
    if json {
        println!("{{\"net\":\"{name}\",\"device\":\"cuda\",\"route\":\"cudnn\",\"predict_samples_per_second\":{rate:.1}}}");
    } else {
        println!("{name} cudnn prediction: {rate:.0} samples/s");
    }
    // burn's CUDA backend, the route before the cuDNN one.
    std::env::set_var("ISAR_CLUTTER_CUDA_ROUTE", "burn");
    let burn = TrainingOptions {
        device: Device::Cuda,
        ..*burn_opts
    };
    let run = || train_on_device(cfg, &burn, set, &empty, 7).expect("a CUDA training");
    run();
    let t = run();
    report("burn", t.samples_per_second, samples_of(&burn) / t.seconds);
    std::env::remove_var("ISAR_CLUTTER_CUDA_ROUTE");
}

/// Without the `cuda` feature there is no GPU route to measure.
#[cfg(not(feature = "cuda"))]
fn cuda(_: &NetConfig, _: &TrainingOptions, _: &Labelled, name: &str, _: f64, _: bool) {
    eprintln!("{name}: CNN_BENCH_DEVICE=cuda needs a bench built with the `cuda` feature");
}

fn main() {
    isar_clutter::alloc::tune_malloc();
    let json = std::env::args().any(|a| a == "--json");
    let batches: usize = std::env::var("CNN_BENCH_BATCHES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(32);
    let n = 128 * batches;
    let peak = peak_gflops();
    if json {
        println!("{{\"peak_gflops_per_thread\":{peak:.1}}}");
    } else {
        println!("peak: {peak:.1} GFLOP/s f32 on one thread (fused multiply-adds)");
    }
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
        let (train_flops, predict_flops) = flops(&cfg);
        let set = data(n, classes, 1);
        let empty = Labelled::default();
        let opts = TrainingOptions {
            epochs: 2,
            ..TrainingOptions::default()
        };
        if std::env::var("CNN_BENCH_DEVICE").as_deref() == Ok("cuda") {
            cuda(&cfg, &opts, &set, name, train_flops, json);
            continue;
        }
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
            let gflops = per_training * train_flops / 1e9;
            let share = 100.0 * gflops / (peak * threads as f64);
            let total = (side_by_side * n * opts.epochs) as f64 / wall;
            let label = if side_by_side > 1 {
                format!("{side_by_side} trainings x 1 thread")
            } else {
                format!("{threads} thread(s)")
            };
            if json {
                println!(
                    "{{\"net\":\"{name}\",\"threads\":{threads},\"trainings\":{side_by_side},\"batch_size\":128,\"samples_per_second\":{per_training:.1},\"machine_samples_per_second\":{total:.1},\"gflops\":{gflops:.1},\"peak_share_percent\":{share:.1}}}"
                );
            } else {
                println!(
                    "burn flex {name}: {label}: {per_training:.0} samples/s per training (steps only; {gflops:.0} GFLOP/s, {share:.0} % of the threads' peak), {total:.0} samples/s for the machine (wall, with data preparation)"
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
            let gflops = rate * predict_flops / 1e9;
            let share = 100.0 * gflops / (peak * threads as f64);
            if json {
                println!(
                    "{{\"net\":\"{name}\",\"threads\":{threads},\"mode\":\"predict\",\"samples_per_second\":{rate:.1},\"gflops\":{gflops:.1},\"peak_share_percent\":{share:.1}}}"
                );
            } else {
                println!(
                    "burn flex {name}: {threads} thread(s): {rate:.0} samples/s predicted (forward only, inference mode; {gflops:.0} GFLOP/s, {share:.0} % of the threads' peak)"
                );
            }
        }
    }
}
