//! Method 1's filter of a negative correlation (dissertation §4.2.4; docs/definitions.md §5):
//! the multiscale (Thue-Morse) signs against an exhaustive search over sign patterns (the
//! slow, obviously correct oracle of the scheme's definition), negative correlations at the
//! 1-, 2- and 4-pixel shifts, the inversion on the signed branch and its clamp, and a fit of a
//! negatively correlated stack that signs its filters as asked and keeps the scheme through a
//! model folder.

use isar_clutter::experiment::{filter_bank, generate};
use isar_clutter::experiment::{FilterParams, FilteredNoise, Map};
use isar_clutter::stats::analysis::analyse;
use isar_clutter::stats::filters::{
    exponential_taps, exponential_taps_signed, group_correlation, lag_correlation,
};
use isar_clutter::synthesis::*;

/// Lag-`k` correlation of `taps`.
fn lag(taps: &[f64], k: usize) -> f64 {
    lag_correlation(taps, k)
}

/// The symmetric sign pattern (centre positive) of half-width `k` whose exponential filter of
/// `alpha` comes closest to the negated correlations of the positive filter at the shifts 1, 2
/// and 4 (least squares), by trying all `2^k` patterns.
fn searched_signs(alpha: f64, k: usize) -> Vec<f64> {
    let positive = exponential_taps(alpha, k);
    let want: Vec<f64> = [1, 2, 4].iter().map(|&s| -lag(&positive, s)).collect();
    let mut best = (f64::INFINITY, vec![]);
    for bits in 0u32..(1 << k) {
        let sign = |d: usize| {
            if d > 0 && bits >> (d - 1) & 1 == 1 {
                -1.0
            } else {
                1.0
            }
        };
        let taps: Vec<f64> = positive
            .iter()
            .enumerate()
            .map(|(i, &t)| sign((i as i64 - k as i64).unsigned_abs() as usize) * t)
            .collect();
        let err: f64 = [1, 2, 4]
            .iter()
            .zip(&want)
            .map(|(&s, w)| (lag(&taps, s) - w).powi(2))
            .sum();
        if err < best.0 - 1e-15 {
            best = (err, (0..=k).map(sign).collect());
        }
    }
    best.1
}

#[test]
fn multiscale_signs_are_what_an_exhaustive_search_finds() {
    // Half-width 7: every pattern tried (at 8 the search differs from the scheme only in the
    // sign of the outermost tap, of weight exp(-8 / alpha)).
    for alpha in [0.5, 1.0, 2.0] {
        let taps = exponential_taps_signed(-alpha, 7, NegativeSigns::Multiscale);
        let scheme: Vec<f64> = taps[7..].iter().map(|t| t.signum()).collect();
        assert_eq!(scheme, searched_signs(alpha, 7), "alpha {alpha}");
    }
    // The scheme written out: + - - + - + + - for d = 0..7.
    let taps = exponential_taps_signed(-1.0, 7, NegativeSigns::Multiscale);
    let signs: String = taps[7..]
        .iter()
        .map(|t| if *t > 0.0 { '+' } else { '-' })
        .collect();
    assert_eq!(signs, "+--+-++-");
}

#[test]
fn multiscale_filters_correlate_negatively_at_1_2_and_4_pixels() {
    for alpha in [0.3, 0.5, 1.0, 2.0, 4.0] {
        let m = exponential_taps_signed(-alpha, 8, NegativeSigns::Multiscale);
        for s in [1, 2, 4] {
            assert!(lag(&m, s) < 0.0, "alpha {alpha}, shift {s}: {}", lag(&m, s));
        }
        // What the levels measure (sums of 1, 2 and 4 pixels against the next) too.
        for g in [1, 2, 4] {
            assert!(group_correlation(&m, g) < 0.0, "alpha {alpha}, group {g}");
        }
        // The alternating filter negates lag 1 exactly, and correlates positively at 2.
        let a = exponential_taps_signed(-alpha, 8, NegativeSigns::Alternating);
        let p = exponential_taps(alpha, 8);
        assert_eq!(lag(&a, 1), -lag(&p, 1));
        assert!(lag(&a, 2) > 0.0);
        assert_eq!(a, exponential_taps(-alpha, 8));
    }
}

#[test]
fn inversion_on_the_multiscale_branch_round_trips_and_clamps() {
    let signs = NegativeSigns::Multiscale;
    let (peak_alpha, peak) = negative_peak(8, signs);
    // scipy's bounded minimisation of the same lag-1 correlation (K = 8): -0.50679835 at
    // alpha = 1.19857.
    assert!((peak_alpha - 1.19857).abs() < 1e-4, "{peak_alpha}");
    assert!((peak - 0.506_798_35).abs() < 1e-8, "{peak}");
    for rho in [-0.01, -0.1, -0.3, -0.45, -0.5] {
        let (a, clamped) = invert_alpha_signed(rho, 8, signs);
        assert!(!clamped && a < 0.0 && -a <= peak_alpha, "rho {rho}: {a}");
        assert!(
            (exponential_lag1_signed(a, 8, signs) - rho).abs() < 1e-9,
            "rho {rho}"
        );
    }
    // Beyond the scheme's reach: the peak, counted as clamped.
    assert_eq!(invert_alpha_signed(-0.6, 8, signs), (-peak_alpha, true));
    // Positive targets and the alternating scheme are Method 1 as it was, bit for bit.
    for rho in [0.3, -0.3, -0.9, 0.99] {
        let old = invert_alpha(rho, 8);
        assert_eq!(invert_alpha_signed(rho, 8, NegativeSigns::Alternating), old);
        if rho > 0.0 {
            assert_eq!(invert_alpha_signed(rho, 8, signs), old);
        }
    }
}

#[test]
fn a_fit_signs_its_filters_as_asked_and_the_model_folder_keeps_it() {
    // Negatively correlated rows (alternating filter of alpha -0.5: lag 1 about -0.27).
    let d = FilteredNoise::new(
        FilterParams::Exponential {
            alpha_h: Map::Constant(-0.5),
            alpha_v: Map::Constant(0.5),
        },
        (16, 16),
        400,
        8,
    );
    let stack = generate(&d, &filter_bank(&d), 5).unwrap();
    let a = analyse(stack.view(), 1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for signs in [NegativeSigns::Multiscale, NegativeSigns::Alternating] {
        let opts = FitOptions {
            negative_signs: signs,
            ..FitOptions::default()
        };
        let model = fit(Method::Method1, &a, None, opts).unwrap();
        let Some(CellParams::Exponential {
            alpha_h, signs: s, ..
        }) = model.filter().map(|f| &f.params)
        else {
            panic!("a Method 1 model")
        };
        assert_eq!(*s, signs);
        assert!(alpha_h.iter().all(|&x| x < 0.0), "{alpha_h}");
        // Each fitted filter reaches its cell's level-1 correlation under its own signs.
        let residual = &model.filter().unwrap().residual_h;
        assert!(residual.iter().all(|&r| r < 1e-9), "{residual}");
        let folder = dir.path().join(signs.as_str());
        let info = isar_clutter::io::model::ModelInfo::new(&model, &a, 8, 1, "test".into());
        isar_clutter::io::model::save(&model, &info, &folder).unwrap();
        let (back, info) = isar_clutter::io::model::load(&folder).unwrap();
        assert_eq!(info.negative_signs, Some(signs));
        assert_eq!(
            back.filter().unwrap().params,
            model.filter().unwrap().params
        );
    }
    // A Method 1 folder written before the scheme was recorded is alternating.
    let folder = dir.path().join("multiscale");
    let json = folder.join("model.json");
    let text = std::fs::read_to_string(&json).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v.as_object_mut().unwrap().remove("negative_signs");
    std::fs::write(&json, serde_json::to_string(&v).unwrap()).unwrap();
    let (old, _) = isar_clutter::io::model::load(&folder).unwrap();
    let Some(CellParams::Exponential { signs, .. }) = old.filter().map(|f| &f.params) else {
        panic!("a Method 1 model")
    };
    assert_eq!(*signs, NegativeSigns::Alternating);
}
