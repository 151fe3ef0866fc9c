//! Generation stages, one thread (`cargo bench --bench generate`): microseconds per 64 x 64
//! sample of a fitted Method 1 and Method 2 model for the format-2 stages (ChaCha8 words,
//! Box-Muller, the filter) and for a whole sample, the minimum over repeats.

use isar_clutter::seeds::normal;
use isar_clutter::synthesis::kernel::{FastFilter, Scratch};
use isar_clutter::synthesis::{fit, FitOptions, Method};

/// This thread's CPU time in seconds (not inflated when other processes share the core).
fn cpu_time() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec for the call to fill.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

fn per_sample(reps: usize, mut f: impl FnMut(usize)) -> f64 {
    let mut best = f64::INFINITY;
    for r in 0..7 {
        let t = cpu_time();
        for s in 0..reps {
            f(r * reps + s);
        }
        best = best.min((cpu_time() - t) / reps as f64);
    }
    best * 1e6
}

/// Peak f32 multiply-adds per ns on this thread: AVX2 FMA on 10 independent vectors.
fn peak_fma_per_ns() -> f64 {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn run(steps: u64) -> f32 {
        use std::arch::x86_64::*;
        let m = _mm256_set1_ps(std::hint::black_box(1.000_000_1));
        let a = _mm256_set1_ps(std::hint::black_box(1e-9));
        let mut acc = [_mm256_setzero_ps(); 10];
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
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        let steps = 20_000_000u64;
        let t = cpu_time();
        // SAFETY: the CPU has AVX2 and FMA, checked just above.
        std::hint::black_box(unsafe { run(steps) });
        return (steps * 10 * 8) as f64 / (cpu_time() - t) / 1e9;
    }
    0.0
}

fn main() {
    println!(
        "peak: {:.1} f32 FMA lanes per ns on one thread",
        peak_fma_per_ns()
    );
    let d = isar_clutter::experiment::FilteredNoise::new(
        isar_clutter::experiment::FilterParams::Exponential {
            alpha_h: isar_clutter::experiment::Map::Ramp(
                isar_clutter::experiment::RampAxis::Horizontal,
                0.5,
                2.0,
            ),
            alpha_v: isar_clutter::experiment::Map::Constant(1.0),
        },
        (64, 64),
        200,
        8,
    );
    let bank = isar_clutter::experiment::filter_bank(&d);
    let stack = isar_clutter::experiment::generate(&d, &bank, 2).unwrap();
    let a = isar_clutter::stats::analysis::analyse(stack.view(), 3).unwrap();
    let n = 80 * 80;
    let mut words = Vec::new();
    let (mut re, mut im) = (vec![0.0f32; n], vec![0.0f32; n]);
    let reps = 2000;
    let w = per_sample(reps, |s| {
        normal::fill_words(1, s as u64, normal::words_for(n), &mut words)
    });
    let t = per_sample(reps, |_| normal::transform(&words, &mut re, &mut im));
    println!("ChaCha8 words of one 80x80 seed: {w:.1} us; Box-Muller: {t:.1} us");
    for method in [Method::Method1, Method::Method2] {
        let model = fit(method, &a, Some(stack.view()), FitOptions::default()).unwrap();
        let m = model.moments();
        let fast = FastFilter::new(&model.filter().unwrap().bank, &m.mean, &m.std);
        let mut scratch = Scratch::default();
        let mut out = vec![num_complex::Complex32::new(0.0, 0.0); 64 * 64];
        let whole = per_sample(reps, |s| fast.sample(1, s, &mut scratch, &mut out));
        println!(
            "{}: whole sample {whole:.1} us, filter {:.1} us",
            method.as_str(),
            whole - w - t
        );
    }
}
