//! Synthesis (SPEC-NOTES section 4): Method 1's alpha inversion and recovery, Method 2's
//! dyadic solver, round trips through fit -> generate -> analyse, the full-covariance
//! sampler's second-order moments, and reproducibility.

mod common;

use isar_clutter::analysis::{analyse, Direction};
#[allow(unused_imports)]
use isar_clutter::filters::group_correlation;
use isar_clutter::data::{filter_bank, generate};
use isar_clutter::filters::{exponential_taps, lag_correlation};
use isar_clutter::spec::{FilterParams, FilteredNoise, Map, RampAxis};
use isar_clutter::synthesis::*;
use ndarray::{Array2, Array3};
use num_complex::Complex64;

fn noise(filter: FilterParams, h: usize, w: usize, n: usize, k: usize) -> FilteredNoise {
    FilteredNoise { filter, height: h, width: w, samples: n, half_width: k, mean: Map::Constant(0.0), mean_im: Map::Constant(0.0), std: Map::Constant(1.0) }
}

fn stack_of(d: &FilteredNoise, seed: u64) -> Array3<Complex64> {
    generate(d, &filter_bank(d), seed)
}

fn rmse(a: &Array2<f64>, b: &Array2<f64>) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

#[test]
fn alpha_inversion_round_trips() {
    for alpha in [0.2, 0.7, 1.0, 3.0, 5.5] {
        let rho = lag_correlation(&exponential_taps(alpha, 8), 1);
        let (a, clamped) = invert_alpha(rho, 8);
        assert!(!clamped, "alpha {alpha}: rho {rho}");
        assert!((a - alpha).abs() < 1e-6 * alpha, "alpha {alpha} -> {a}");
        assert!((invert_alpha(-rho, 8).0 + alpha).abs() < 1e-6 * alpha, "negative target");
        assert!((lag_correlation(&exponential_taps(a, 8), 1) - rho).abs() < 1e-6);
    }
    assert_eq!(invert_alpha(0.0, 8), (0.0, false));
    // Above the peak alpha* the same rho is reached on the monotone branch.
    let rho12 = exponential_lag1(12.0, 8);
    let (a, clamped) = invert_alpha(rho12, 8);
    assert!(!clamped && a < 12.0 && (exponential_lag1(a, 8) - rho12).abs() < 1e-9);
    // g is not monotone for finite K: it peaks above g(inf) = 2K/(2K+1) = 0.9412.
    let (peak_alpha, peak) = exponential_peak(8);
    assert!((5.0..8.0).contains(&peak_alpha) && peak > 0.974 && peak < 0.975, "{peak_alpha} {peak}");
    for alpha in [0.5, 2.0, peak_alpha * 0.999] {
        assert!(exponential_lag1(alpha, 8) < exponential_lag1(alpha * 1.001, 8), "monotone below the peak");
    }
    let (a, clamped) = invert_alpha(0.99, 8);
    assert!(clamped && (a - peak_alpha).abs() < 1e-9, "above the peak: clamped to alpha*");
    assert!(!invert_alpha(0.96, 8).1, "between g(inf) and the peak: reachable");
}

#[test]
fn dyadic_solver_reaches_spec_notes_targets() {
    // SPEC-NOTES section 4: (.3, -.2, .1) is reachable with r near (.175, -.142, .084).
    let (r, res) = solve_dyadic(&[0.3, -0.2, 0.1], 8);
    assert!(res < 1e-6, "residual {res}");
    for (got, want) in r.iter().zip([0.175, -0.142, 0.084]) {
        assert!((got - want).abs() < 0.005, "r = {r:?}");
    }
    // Table 4's exponential targets are reachable too.
    let (r, res) = solve_dyadic(&[0.6481, 0.4534, 0.2347], 8);
    assert!(res < 1e-6, "residual {res}, r = {r:?}");
    let got = dyadic_correlations(&r, 8);
    for (g, t) in got.iter().zip([0.6481, 0.4534, 0.2347]) {
        assert!((g - t).abs() < 1e-6);
    }
}

#[test]
fn method1_recovers_spatially_varying_alpha() {
    // Known alpha ramps, N = 1000: median relative error of the per-cell alpha below 5 %.
    let (ah, av) = (Map::Ramp(RampAxis::Horizontal, 0.5, 2.0), Map::TopBottom(0.8, 1.6));
    let d = noise(FilterParams::Exponential { alpha_h: ah.clone(), alpha_v: av.clone() }, 32, 32, 1000, 8);
    let stack = stack_of(&d, 11);
    let a = analyse(stack.view(), 1).unwrap();
    let model = fit(Method::Method1, &a, None, FitOptions::default()).unwrap();
    let Some(FilterModel { params: CellParams::Exponential { alpha_h, alpha_v }, clamped, .. }) = &model.filter else { panic!("method1 model") };
    let (truth_h, truth_v) = (ah.grid(32, 32), av.grid(32, 32));
    let mut rel: Vec<f64> = Vec::new();
    for ((r, c), &est) in alpha_h.indexed_iter() {
        // A cell spans two columns of the ramp: compare with their mean.
        let t = 0.5 * (truth_h[[2 * r, 2 * c]] + truth_h[[2 * r, 2 * c + 1]]);
        rel.push(((est - t) / t).abs());
        rel.push(((alpha_v[[r, c]] - truth_v[[2 * r, 2 * c]]) / truth_v[[2 * r, 2 * c]]).abs());
    }
    rel.sort_by(f64::total_cmp);
    let median = rel[rel.len() / 2];
    assert!(median < 0.05, "median relative error {median}");
    assert_eq!(clamped.sum(), 0);
}
