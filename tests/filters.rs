//! Correlating filters: the fast separable convolution against the direct per-pixel sum
//! (eq. 33), the generated data's moments, exact expected maps (pair sums vs the 1-D group
//! correlations), dyadic taps and the sign-alternating filter.

mod common;

use common::max_diff;
use isar_clutter::experiment::{filter_bank, generate};
use isar_clutter::experiment::{FilterParams, FilteredNoise, Map, RampAxis};
use isar_clutter::seeds::white_seed;
use isar_clutter::stats::analysis::analyse;
use isar_clutter::stats::filters::*;
use ndarray::Array2;
use num_complex::Complex64;

fn dataset(filter: FilterParams, h: usize, w: usize, n: usize, k: usize) -> FilteredNoise {
    FilteredNoise::new(filter, (h, w), n, k)
}

fn direct(bank: &FilterBank, seed: &Array2<Complex64>) -> Vec<Complex64> {
    let s = seed.as_slice().unwrap();
    let sw = seed.dim().1;
    (0..bank.height * bank.width)
        .map(|p| filter_pixel_direct(bank, s, sw, p / bank.width, p % bank.width))
        .collect()
}

#[test]
fn separable_fast_path_matches_direct_sum() {
    let d = dataset(
        FilterParams::Exponential {
            alpha_h: Map::Constant(1.7),
            alpha_v: Map::Constant(-0.6),
        },
        9,
        13,
        1,
        5,
    );
    let bank = filter_bank(&d);
    assert!(bank.is_uniform());
    let seed = white_seed(99, 0, 9 + 10, 13 + 10);
    let mut fast = vec![Complex64::new(0.0, 0.0); 9 * 13];
    filter_seed(&bank, seed.view(), &mut fast);
    for (a, b) in fast.iter().zip(direct(&bank, &seed)) {
        assert!((a - b).norm() < 1e-12);
    }
}

#[test]
fn white_seed_is_unit_power_and_stream_separated() {
    let a = white_seed(5, 0, 200, 200);
    let power = a.iter().map(|z| z.norm_sqr()).sum::<f64>() / a.len() as f64;
    // 40,000 draws of |z|^2 (exponential, sd 1): standard error 0.005.
    assert!((power - 1.0).abs() < 0.025, "E|z|^2 = {power}");
    assert_ne!(white_seed(5, 1, 4, 4), white_seed(5, 0, 4, 4));
    assert_eq!(white_seed(5, 1, 4, 4), white_seed(5, 1, 4, 4));
}

#[test]
fn generated_data_has_the_requested_mean_and_variance() {
    let mut d = dataset(
        FilterParams::Exponential {
            alpha_h: Map::Constant(1.0),
            alpha_v: Map::Ramp(RampAxis::Vertical, 0.5, 2.0),
        },
        16,
        16,
        4000,
        8,
    );
    d.mean = Map::LeftRight(1.0, -2.0);
    d.std = Map::TopBottom(0.5, 3.0);
    let bank = filter_bank(&d);
    let stack = generate(&d, &bank, 3).unwrap();
    let a = analyse(stack.view(), 1).unwrap();
    let std = d.std.grid(16, 16);
    let mean = d.mean.grid(16, 16);
    for ((rc, m), v) in a.mean.indexed_iter().zip(a.variance.iter()) {
        let s2 = std[rc] * std[rc];
        // Variance of the sample variance of a complex Gaussian: s^4 / N -> relative sd 1.6 %.
        assert!(
            (v / s2 - 1.0).abs() < 0.08,
            "variance at {rc:?}: {v} vs {s2}"
        );
        // Sample mean sd: s / sqrt(N) <= 3 / 63 = 0.047 per component.
        assert!(
            (m.re - mean[rc]).abs() < 0.25 && m.im.abs() < 0.25,
            "mean at {rc:?}"
        );
    }
}

#[test]
fn exact_pair_sums_equal_group_correlations_for_uniform_filters() {
    let d = dataset(
        FilterParams::Exponential {
            alpha_h: Map::Constant(0.8),
            alpha_v: Map::Constant(2.0),
        },
        16,
        16,
        2,
        8,
    );
    let bank = filter_bank(&d);
    let std = Array2::from_elem((16, 16), 2.0);
    let fast = expected_maps(&bank, &std, 3);
    for (l, f) in fast.iter().enumerate() {
        let s = exact_level(&bank, &std, l + 1);
        assert!((f[0][[0, 0]] - group_correlation(&bank.horizontal[0], 1 << l)).abs() < 1e-15);
        for d in 0..3 {
            assert!(max_diff(&f[d], &s[d]) < 1e-12);
        }
    }
}

#[test]
fn spatially_varying_analysis_recovers_the_exact_maps() {
    let d = dataset(
        FilterParams::Exponential {
            alpha_h: Map::Ramp(RampAxis::Horizontal, 0.3, 3.0),
            alpha_v: Map::TopBottom(0.5, 2.0),
        },
        16,
        16,
        3000,
        8,
    );
    let bank = filter_bank(&d);
    assert!(!bank.is_uniform());
    let stack = generate(&d, &bank, 4).unwrap();
    let a = analyse(stack.view(), 2).unwrap();
    let exact = expected_maps(&bank, &d.std.grid(16, 16), 2);
    for (lm, e) in a.levels.iter().zip(&exact) {
        for (i, dir) in isar_clutter::stats::analysis::Direction::ALL
            .iter()
            .enumerate()
        {
            // Per-cell sd of a correlation estimate: (1 - rho^2) / sqrt(2N) <= 0.013; 5 sd.
            let diff = max_diff(lm.correlation(*dir), &e[i]);
            assert!(
                diff < 0.065,
                "level {} {dir}: max deviation {diff}",
                lm.level
            );
        }
    }
    // The map really varies: left and right of the ramp differ by more than the noise.
    let h1 = &exact[0][0];
    assert!(h1[[0, 7]] - h1[[0, 0]] > 0.3);
}

#[test]
fn dyadic_taps_follow_the_octaves() {
    let t = dyadic_taps(&[0.5, -0.25, 0.125], 9);
    let want = [0.0, 0.0, 0.125, 0.125, 0.125, 0.125, -0.25, -0.25, 0.5, 1.0];
    assert_eq!(&t[..10], &want);
    assert_eq!(t.len(), 19);
    assert_eq!(
        t[10..],
        t[..9].iter().rev().copied().collect::<Vec<_>>()[..]
    );
}

#[test]
fn sign_alternating_filter_negates_odd_lag_correlations() {
    let (p, n) = (exponential_taps(1.3, 8), exponential_taps(-1.3, 8));
    for lag in 0..=8 {
        let sign = if lag % 2 == 1 { -1.0 } else { 1.0 };
        assert!((lag_correlation(&n, lag) - sign * lag_correlation(&p, lag)).abs() < 1e-12);
    }
}

#[test]
fn spatially_varying_kernel_matches_the_direct_sum_bit_for_bit() {
    // Per-pixel random taps: every pixel its own filter (the general case of eq. 33).
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let (h, w, k) = (7, 13, 3);
    let mut rng = rand_chacha::ChaCha20Rng::seed_from_u64(8);
    let mut taps = || -> Vec<Vec<f64>> {
        (0..h * w)
            .map(|_| {
                (0..2 * k + 1)
                    .map(|_| StandardNormal.sample(&mut rng))
                    .collect()
            })
            .collect()
    };
    let bank = FilterBank::new(k, h, w, taps(), taps());
    assert!(!bank.is_uniform());
    let seed = white_seed(21, 0, h + 2 * k, w + 2 * k);
    let mut fast = vec![Complex64::new(0.0, 0.0); h * w];
    filter_seed(&bank, seed.view(), &mut fast);
    assert_eq!(fast, direct(&bank, &seed));
}

#[test]
fn cell_shared_filters_match_the_direct_sum_bit_for_bit() {
    // Method 1/2 banks share taps within 2x2 cells: the kernel forms the horizontal sums of a
    // cell's two rows once. Odd sizes exercise the tail columns and a lone last row.
    use isar_clutter::synthesis::CellParams;
    let (h, w, k) = (11, 21, 8);
    let alpha = |s: f64| {
        ndarray::Array2::from_shape_fn((h / 2, w / 2), |(r, c)| {
            s * (0.3 + ((r * 7 + c * 3) % 11) as f64 * 0.25)
                * if (r + c) % 5 == 0 { -1.0 } else { 1.0 }
        })
    };
    let bank = CellParams::Exponential {
        alpha_h: alpha(1.0),
        alpha_v: alpha(0.7),
        signs: NegativeSigns::Multiscale,
    }
    .bank(k, h, w);
    let seed = white_seed(22, 3, h + 2 * k, w + 2 * k);
    let mut fast = vec![Complex64::new(0.0, 0.0); h * w];
    filter_seed(&bank, seed.view(), &mut fast);
    assert_eq!(fast, direct(&bank, &seed));
}

/// The uniform path's two passes, each output summed in tap order from zero with
/// `iter().sum()` (the definition every format-1 dataset was generated with).
fn separable_by_sums(bank: &FilterBank, seed: &Array2<Complex64>) -> Vec<Complex64> {
    let (h, w, k) = (bank.height, bank.width, bank.half_width);
    let (fv, fh) = (&bank.vertical[0], &bank.horizontal[0]);
    let s = seed.as_slice().unwrap();
    let sw = w + 2 * k;
    let mut rows = vec![Complex64::new(0.0, 0.0); (h + 2 * k) * w];
    for r in 0..h + 2 * k {
        for j in 0..w {
            let src = &s[r * sw + j..r * sw + j + 2 * k + 1];
            rows[r * w + j] = src.iter().zip(fh).map(|(z, f)| z * f).sum();
        }
    }
    (0..h * w)
        .map(|p| {
            let (i, j) = (p / w, p % w);
            (0..=2 * k).map(|a| rows[(i + a) * w + j] * fv[a]).sum()
        })
        .collect()
}

/// The uniform path (taps outside, columns inside) gives the same bits as the sums in tap order,
/// on random taps of several sizes, odd ones included; an output buffer holding old values is
/// overwritten.
#[test]
fn separable_path_equals_the_tap_order_sums_bit_for_bit() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
    for (h, w, k, index) in [
        (9, 13, 5, 0),
        (64, 64, 8, 1),
        (7, 3, 1, 2),
        (1, 17, 0, 3),
        (5, 37, 3, 4),
        (3, 100, 8, 5),
    ] {
        let mut taps = || -> Vec<f64> {
            (0..2 * k + 1)
                .map(|_| StandardNormal.sample(&mut rng))
                .collect()
        };
        let bank = FilterBank::uniform(taps(), taps(), h, w);
        let seed = white_seed(42, index, h + 2 * k, w + 2 * k);
        let mut fast = vec![Complex64::new(3.0, -1.0); h * w];
        filter_seed(&bank, seed.view(), &mut fast);
        let want = separable_by_sums(&bank, &seed);
        assert!(
            fast.iter()
                .zip(&want)
                .all(|(a, b)| a.re.to_bits() == b.re.to_bits() && a.im.to_bits() == b.im.to_bits()),
            "{h}x{w}, half-width {k}"
        );
    }
}
