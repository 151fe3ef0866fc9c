//! Reproduces the dissertation's Table 3 (lag correlations of the exponential filter) and
//! Table 4 (multiscale correlations of exponentially filtered noise) with the exact values of
//! docs/definitions.md §4.

use isar_clutter::experiment::{filter_bank, generate};
use isar_clutter::experiment::{FilterParams, FilteredNoise, Map};
use isar_clutter::stats::analysis::{analyse, Direction};
use isar_clutter::stats::filters::{
    exponential_taps, group_correlation, lag_correlation, FilterBank,
};

/// Table 3: pixel offset, f(d) and correlation for f(d) = exp(-|d|), K = 8 (4 d.p.).
const TABLE_3: [(usize, f64, f64); 9] = [
    (0, 1.0, 1.0),
    (1, 0.3679, 0.6481),
    (2, 0.1353, 0.3415),
    (3, 0.0498, 0.1635),
    (4, 0.0183, 0.0741),
    (5, 0.0067, 0.0324),
    (6, 0.0025, 0.0138),
    (7, 0.0009, 0.0057),
    (8, 0.0003, 0.0023),
];

/// Table 4 as exact expected values (docs/definitions.md §4): level -> (H, V, D).
const TABLE_4_EXACT: [(f64, f64, f64); 3] = [
    (0.6481, 0.6481, 0.4200),
    (0.4534, 0.4534, 0.2056),
    (0.2347, 0.2347, 0.0551),
];

fn round4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

#[test]
fn table_3_lag_correlations_to_4_decimals() {
    let taps = exponential_taps(1.0, 8);
    for (lag, f, rho) in TABLE_3 {
        assert_eq!(round4(taps[8 + lag]), f, "f({lag})");
        assert_eq!(round4(lag_correlation(&taps, lag)), rho, "rho({lag})");
    }
}

#[test]
fn table_4_exact_group_correlations() {
    let taps = exponential_taps(1.0, 8);
    for (l, (h, _v, d)) in TABLE_4_EXACT.iter().enumerate() {
        let g = group_correlation(&taps, 1 << l);
        assert_eq!(round4(g), *h, "level {} H", l + 1);
        assert_eq!(round4(g * g), *d, "level {} D = H * V", l + 1);
    }
}

fn table4_dataset() -> FilteredNoise {
    let alpha_1 = FilterParams::Exponential {
        alpha_h: Map::Constant(1.0),
        alpha_v: Map::Constant(1.0),
    };
    FilteredNoise::new(alpha_1, (64, 64), 1000, 8)
}

#[test]
fn table_4_estimates_within_0_01_of_exact() {
    // 1000 samples of 64x64: the standard error of a mean over >= 64 cells is ~0.003.
    let d = table4_dataset();
    let bank: FilterBank = filter_bank(&d);
    let stack = generate(&d, &bank, 20200403).unwrap();
    let a = analyse(stack.view(), 3).unwrap();
    for (lm, (h, v, dg)) in a.levels.iter().zip(TABLE_4_EXACT) {
        for (dir, want) in [(Direction::H, h), (Direction::V, v), (Direction::D, dg)] {
            let got = lm.summary(dir).mean_correlation;
            assert!(
                (got - want).abs() < 0.01,
                "level {} {dir}: {got:.4} vs {want}",
                lm.level
            );
        }
    }
}
