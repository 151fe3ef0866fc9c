//! The fast multiscale kernel against its slow oracles (direct two-pass pair covariances and
//! the explicit 4x4 solve of eq. 52) on seeded random stacks, plus its invariances and its
//! handling of NaN, zero variance, cropping and element types.

mod common;

use common::{max_diff, random_stack, REORDER_TOL};
use isar_clutter::stats::analysis::{analyse, AnalysisError, Direction};
use isar_clutter::stats::oracle;
use ndarray::{s, Array3};
use num_complex::{Complex, Complex64};

#[test]
fn closed_form_matches_direct_pair_covariance_and_4x4_solve() {
    // Sizes that are not multiples of 2^L exercise the cropping and the tail band.
    for (seed, n, h, w, levels) in [
        (1, 40, 16, 16, 3),
        (2, 25, 13, 22, 2),
        (3, 60, 35, 9, 3),
        (4, 2, 4, 4, 2),
    ] {
        let stack = random_stack(seed, n, h, w);
        let fast = analyse(stack.view(), levels).unwrap();
        for lm in &fast.levels {
            let (corr, cov) = oracle::direct_level(&stack, lm.level);
            let (solved, one) = oracle::haar_solve_level(&stack, lm.level);
            assert_eq!(lm.shape(), (h >> lm.level, w >> lm.level));
            for d in Direction::ALL {
                let i = d as usize;
                assert!(
                    max_diff(lm.correlation(d), &corr[i]) < REORDER_TOL,
                    "direct corr, level {} {d}",
                    lm.level
                );
                assert!(
                    max_diff(lm.correlation(d), &solved[i]) < 1e-7,
                    "4x4 solve, level {} {d}",
                    lm.level
                );
                // Covariances scale with the unit sums (up to 4^(L-1) pixels of variance ~10).
                let scale = cov[i].iter().fold(1.0f64, |m, v| m.max(v.abs()));
                assert!(
                    max_diff(lm.covariance(d), &cov[i]) < REORDER_TOL * scale,
                    "cov, level {} {d}",
                    lm.level
                );
            }
            assert!(
                one.iter().all(|v| (v - 1.0).abs() < 1e-9),
                "first unknown of eq. 52 must solve to 1"
            );
        }
    }
}

#[test]
fn pixel_mean_and_variance_match_two_pass() {
    // Odd heights and widths: pixels in an odd last row or column belong to no cell but still
    // have a mean and a variance (the tail band of 35 rows at 3 levels has 3 rows).
    for (seed, n, h, w, levels) in [(7, 30, 8, 6, 1), (8, 20, 13, 22, 2), (9, 25, 35, 9, 3)] {
        let stack = random_stack(seed, n, h, w);
        let a = analyse(stack.view(), levels).unwrap();
        for r in 0..h {
            for c in 0..w {
                let px = stack.slice(s![.., r, c]);
                let mu: Complex64 = px.iter().sum::<Complex64>() / n as f64;
                let var = px.iter().map(|v| (v - mu).norm_sqr()).sum::<f64>() / n as f64;
                assert!((a.mean[[r, c]] - mu).norm() < 1e-12, "{h}x{w} ({r}, {c})");
                assert!((a.variance[[r, c]] - var).abs() < 1e-12 * var.max(1.0));
            }
        }
    }
}

#[test]
fn correlations_are_invariant_to_a_complex_constant_factor() {
    let stack = random_stack(11, 50, 16, 16);
    let c = Complex64::new(-2.5, 7.0);
    let scaled = stack.mapv(|v| v * c);
    let (a, b) = (
        analyse(stack.view(), 3).unwrap(),
        analyse(scaled.view(), 3).unwrap(),
    );
    for (la, lb) in a.levels.iter().zip(&b.levels) {
        for d in Direction::ALL {
            assert!(
                max_diff(la.correlation(d), lb.correlation(d)) < 1e-12,
                "level {} {d}",
                la.level
            );
            let want = la.covariance(d).mapv(|v| v * c.norm_sqr());
            let scale = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            assert!(max_diff(&want, lb.covariance(d)) < 1e-12 * scale);
        }
    }
}

#[test]
fn large_mean_does_not_cancel_the_variance() {
    // A mean 1e6 times the spread: the naive one-pass formula loses ~12 digits here.
    let stack = random_stack(12, 100, 8, 8);
    let shifted = stack.mapv(|v| v + Complex64::new(1e6, -3e6));
    let (a, b) = (
        analyse(stack.view(), 2).unwrap(),
        analyse(shifted.view(), 2).unwrap(),
    );
    for (la, lb) in a.levels.iter().zip(&b.levels) {
        for d in Direction::ALL {
            assert!(max_diff(la.correlation(d), lb.correlation(d)) < 1e-8);
        }
    }
}

#[test]
fn nan_pixels_poison_exactly_the_cells_that_touch_them() {
    let mut stack = random_stack(13, 20, 16, 16);
    stack[[5, 9, 3]] = Complex64::new(f64::NAN, 0.0);
    let a = analyse(stack.view(), 3).unwrap();
    assert!(a.mean[[9, 3]].re.is_nan() && a.variance[[9, 3]].is_nan());
    assert!(!a.variance[[9, 2]].is_nan());
    for lm in &a.levels {
        let cell = (9 >> lm.level, 3 >> lm.level);
        for d in Direction::ALL {
            let m = lm.correlation(d);
            assert!(
                m[cell].is_nan(),
                "level {} {d}: the cell holding the NaN pixel",
                lm.level
            );
            let s = lm.summary(d);
            assert_eq!(s.nan_cells, 1, "level {} {d}: only that cell", lm.level);
            assert!(
                s.mean_correlation.is_finite(),
                "NaN cells are excluded from the mean"
            );
        }
    }
}

#[test]
fn zero_variance_cells_have_nan_correlation_and_zero_covariance() {
    let mut stack = random_stack(14, 10, 8, 8);
    stack
        .slice_mut(s![.., 0..2, 0..2])
        .fill(Complex64::new(3.0, 1.0));
    let a = analyse(stack.view(), 1).unwrap();
    let lm = &a.levels[0];
    for d in Direction::ALL {
        assert!(lm.correlation(d)[[0, 0]].is_nan());
        assert_eq!(lm.covariance(d)[[0, 0]], 0.0);
        assert_eq!(lm.summary(d).nan_cells, 1);
    }
    assert_eq!(a.variance[[0, 0]], 0.0);
}

#[test]
fn element_types_agree() {
    let stack = random_stack(15, 30, 8, 8);
    let c64: Array3<Complex<f32>> = stack.mapv(|v| Complex::new(v.re as f32, v.im as f32));
    let back: Array3<Complex64> = c64.mapv(|v| Complex64::new(v.re as f64, v.im as f64));
    let (a, b) = (
        analyse(c64.view(), 2).unwrap(),
        analyse(back.view(), 2).unwrap(),
    );
    assert_eq!(a, b, "complex64 input is widened exactly to f64");
    let real: Array3<f64> = stack.mapv(|v| v.re);
    let as_complex = real.mapv(|v| Complex64::new(v, 0.0));
    assert_eq!(
        analyse(real.view(), 2).unwrap(),
        analyse(as_complex.view(), 2).unwrap()
    );
}

#[test]
fn hwn_views_give_the_same_result_as_nhw() {
    let stack = random_stack(16, 12, 8, 8);
    let hwn = stack
        .view()
        .permuted_axes([1, 2, 0])
        .as_standard_layout()
        .into_owned();
    let back = hwn.view().permuted_axes([2, 0, 1]);
    assert_eq!(analyse(stack.view(), 2).unwrap(), analyse(back, 2).unwrap());
}

#[test]
fn bad_inputs_are_refused() {
    let stack = random_stack(17, 1, 8, 8);
    assert_eq!(
        analyse(stack.view(), 1).unwrap_err(),
        AnalysisError::TooFewSamples(1)
    );
    let stack = random_stack(17, 3, 8, 8);
    assert_eq!(
        analyse(stack.view(), 0).unwrap_err(),
        AnalysisError::NoLevels
    );
    assert!(matches!(
        analyse(stack.view(), 4).unwrap_err(),
        AnalysisError::TooDeep { need: 16, .. }
    ));
}

#[test]
fn thread_count_does_not_change_a_bit() {
    let stack = random_stack(18, 64, 40, 24);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| analyse(stack.view(), 3).unwrap())
    };
    assert_eq!(run(1), run(2));
    assert_eq!(run(1), run(3));
}
