//! Unit tests of the parent module.

use super::*;
use crate::physics::isar::Window;

/// Reduced measurement for fast tests (128 x 128 points: unambiguous
/// extent ~1.2 m, still twice the 0.593 m image).
fn setup() -> (Measurement, ImagingOptions) {
    (
        Measurement::uniform(2e9, 18e9, 128, 51f64.to_radians(), 128).unwrap(),
        ImagingOptions {
            size: 64,
            window: Window::Hann,
            extent_m: None,
        },
    )
}

fn var(plant: &str, wind: &str, n: usize, seed: u64) -> (f64, Array3<Complex64>) {
    let (m, o) = setup();
    let p = SceneParams::preset(plant, wind).unwrap();
    let (_, imgs) = simulate(&p, &m, &o, n, seed);
    (mean_pixel_variance(&imgs), imgs)
}

#[test]
fn presets_exist_and_validate() {
    for pl in ["A", "B", "C", "D", "E"] {
        for w in ["none", "light", "medium"] {
            SceneParams::preset(pl, w).unwrap().validate().unwrap();
        }
    }
    assert!(PlantParams::preset("F").is_none());
    assert!(WindParams::preset("storm").is_none());
}

#[test]
fn serde_round_trip_and_unknown_fields() {
    let p = SceneParams::preset("B", "light").unwrap();
    let y = serde_yaml_ng::to_string(&p).unwrap();
    let q: SceneParams = serde_yaml_ng::from_str(&y).unwrap();
    assert_eq!(p, q);
    let bad = y.replace("noise_db", "noise_dbx");
    assert!(serde_yaml_ng::from_str::<SceneParams>(&bad).is_err());
}

#[test]
fn bad_parameters_are_named_errors() {
    let (m, o) = setup();
    let mut p = SceneParams::preset("A", "light").unwrap();
    p.plant.sway_damping = -1.0;
    match try_simulate(&p, &m, &o, 2, 0) {
        Err(VegError::InvalidParameter { name, .. }) => assert_eq!(name, "sway_damping"),
        other => panic!("{other:?}"),
    }
    let mut p = SceneParams::preset("A", "light").unwrap();
    p.wind.gust_time_constant_s = 0.0;
    assert!(matches!(
        try_simulate(&p, &m, &o, 2, 0),
        Err(VegError::InvalidParameter {
            name: "gust_time_constant_s",
            ..
        })
    ));
}

#[test]
fn no_wind_variance_is_tiny_and_alike() {
    let n = 30;
    let (va_none, _) = var("A", "none", n, 7);
    let (va_light, _) = var("A", "light", n, 7);
    let (vc_none, _) = var("C", "none", n, 7);
    assert!(va_none < 0.02 * va_light, "{va_none} vs {va_light}");
    // no-wind variances are small and of the same order for all plants
    assert!(va_none / vc_none < 30.0 && vc_none / va_none < 30.0);
}

#[test]
fn light_wind_ordering_a_b_c_and_medium_above_light() {
    let n = 40;
    for seed in [1u64, 2] {
        let (a, _) = var("A", "light", n, seed);
        let (b, _) = var("B", "light", n, seed);
        let (c, _) = var("C", "light", n, seed);
        assert!(a > b && b > c, "seed {seed}: A {a} B {b} C {c}");
        for (pl, light) in [("A", a), ("C", c)] {
            let (med, _) = var(pl, "medium", n, seed);
            assert!(med > light, "{pl} seed {seed}: medium {med} light {light}");
        }
    }
}

#[test]
fn mean_image_shows_plant_footprint() {
    let (m, o) = setup();
    let seed = 3;
    for pl in ["A", "D"] {
        let p = SceneParams::preset(pl, "light").unwrap();
        let (_, imgs) = simulate(&p, &m, &o, 20, seed);
        let mean = mean_image(&imgs);
        let fp = plant_footprint(&p.plant, seed).unwrap();
        let dx = m.full_resolution_extent(64) / 64.0;
        let px = |v: f64| (v / dx).round() as i64 + 32;
        let (c0, c1, r0, r1) = (px(fp[0]) - 2, px(fp[1]) + 2, px(fp[2]) - 2, px(fp[3]) + 2);
        let (mut inside, mut total) = (0.0, 0.0);
        for ((r, c), v) in mean.indexed_iter() {
            let e = v.norm_sqr();
            total += e;
            let (r, c) = (r as i64, c as i64);
            if r >= r0 && r <= r1 && c >= c0 && c <= c1 {
                inside += e;
            }
        }
        let frac = inside / total;
        let box_frac = ((c1 - c0 + 1) * (r1 - r0 + 1)) as f64 / 4096.0;
        assert!(frac > 0.8, "{pl}: {frac} inside (box {box_frac})");
        assert!(box_frac < 0.7, "{pl}: footprint box too large {box_frac}");
    }
}

#[test]
fn deterministic_across_thread_counts() {
    let (m, o) = setup();
    let p = SceneParams::preset("B", "medium").unwrap();
    let run = |t: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| simulate(&p, &m, &o, 4, 11))
    };
    let (k1, i1) = run(1);
    let (k2, i2) = run(2);
    let (k3, i3) = run(2);
    let bits = |a: &Array3<Complex64>| {
        a.iter()
            .flat_map(|v| [v.re.to_bits(), v.im.to_bits()])
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&k1), bits(&k2));
    assert_eq!(bits(&i1), bits(&i2));
    assert_eq!(bits(&i2), bits(&i3));
    assert_eq!(bits(&k2), bits(&k3));
    // different seed, different stack
    let (_, i4) = simulate(&p, &m, &o, 4, 12);
    assert_ne!(bits(&i1), bits(&i4));
}

#[test]
fn medium_wind_a_pixels_not_gaussian() {
    let (_, imgs) = var("A", "medium", 60, 5);
    let k = pixel_excess_kurtosis(&imgs, 0.05);
    eprintln!("plant A, medium wind: pooled excess kurtosis = {k:.3}");
    assert!(k.is_finite());
}
