//! Generation stages, one thread (`cargo bench --bench generate`): microseconds per 64 x 64
//! sample of a fitted Method 1 and Method 2 model for the format-2 stages (ChaCha8 words,
//! Box-Muller, the filter) and for a whole sample, the minimum over repeats.

use isar_clutter::seeds::normal;
use isar_clutter::synthesis::{fit, kernel::Scratch, FitOptions, Method};
use std::time::Instant;

fn per_sample(reps: usize, mut f: impl FnMut(usize)) -> f64 {
    let mut best = f64::INFINITY;
    for r in 0..7 {
        let t = Instant::now();
        for s in 0..reps {
            f(r * reps + s);
        }
        best = best.min(t.elapsed().as_secs_f64() / reps as f64);
    }
    best * 1e6
}

fn main() {
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
    let bank = isar_clutter::data::filter_bank(&d);
    let stack = isar_clutter::data::generate(&d, &bank, 2).unwrap();
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
        let mut scratch = Scratch::default();
        let mut out = vec![num_complex::Complex32::new(0.0, 0.0); 64 * 64];
        let whole = per_sample(reps, |s| model.sample_c32(1, s, &mut scratch, &mut out));
        println!(
            "{}: whole sample {whole:.1} us, filter {:.1} us",
            method.as_str(),
            whole - w - t
        );
    }
}
