//! Tests of the ISAR forward model and imaging: the kernels against their serial oracles, bit
//! for bit where they promise it, and the imaging against known point targets.

use super::*;

fn small() -> (Measurement, ImagingOptions) {
    (
        Measurement::default_full(),
        ImagingOptions {
            size: 64,
            window: Window::Hann,
            extent_m: None,
        },
    )
}

fn argmax(img: &Array2<Complex64>) -> ((usize, usize), f64) {
    let mut best = ((0, 0), -1.0);
    for ((r, c), v) in img.indexed_iter() {
        if v.norm() > best.1 {
            best = ((r, c), v.norm());
        }
    }
    best
}

#[test]
fn default_geometry() {
    let m = Measurement::default_full();
    let ext = m.full_resolution_extent(64);
    assert!((ext - 0.593).abs() < 0.005, "extent {ext}");
    let df = m.freqs[1] - m.freqs[0];
    assert!(C0 / (2.0 * df) > 2.0 * ext);
}

#[test]
fn point_at_origin_peaks_at_centre() {
    let (m, o) = small();
    let e = point_response(&[(Complex64::new(1.0, 0.0), [0.0, 0.0, 0.3])], &m);
    let img = image(e.view(), &m, &o);
    let ((r, c), v) = argmax(&img);
    assert_eq!((r, c), (32, 32));
    assert!((v - 1.0).abs() < 1e-9, "peak {v}");
}

#[test]
fn offset_points_land_on_predicted_pixel_with_stable_peak() {
    let (m, o) = small();
    let dx = m.full_resolution_extent(64) / 64.0;
    let mut peaks = vec![];
    for &(px, py) in &[
        (10i32, 0i32),
        (0, 12),
        (-20, 7),
        (15, -22),
        (25, 25),
        (-27, -5),
    ] {
        let (x, y) = (px as f64 * dx, py as f64 * dx);
        let e = point_response(&[(Complex64::new(1.0, 0.0), [x, y, 0.0])], &m);
        let img = image(e.view(), &m, &o);
        let ((r, c), v) = argmax(&img);
        assert!((c as i32 - 32 - px).abs() <= 1, "col {c} for px {px}");
        assert!((r as i32 - 32 - py).abs() <= 1, "row {r} for py {py}");
        peaks.push(v);
    }
    for v in &peaks {
        assert!((v - 1.0).abs() < 0.04, "peaks {peaks:?}");
    }
}

#[test]
fn two_points_resolved() {
    let (m, o) = small();
    let dx = m.full_resolution_extent(64) / 64.0;
    // 4 pixels (~37 mm) apart in x, well above the ~10-20 mm resolution
    let pts = [
        (Complex64::new(1.0, 0.0), [-2.0 * dx, 0.0, 0.0]),
        (Complex64::new(1.0, 0.0), [2.0 * dx, 0.0, 0.0]),
    ];
    let img = image(point_response(&pts, &m).view(), &m, &o);
    let a = img[[32, 30]].norm();
    let b = img[[32, 34]].norm();
    let mid = img[[32, 32]].norm();
    assert!(a > 0.9 && b > 0.9, "{a} {b}");
    assert!(mid < 0.5 * a.min(b), "dip {mid} vs {a} {b}");
    // and in y (cross-range)
    let pts = [
        (Complex64::new(1.0, 0.0), [0.0, -2.0 * dx, 0.0]),
        (Complex64::new(1.0, 0.0), [0.0, 2.0 * dx, 0.0]),
    ];
    let img = image(point_response(&pts, &m).view(), &m, &o);
    assert!(img[[32, 32]].norm() < 0.5 * img[[30, 32]].norm().min(img[[34, 32]].norm()));
}

#[test]
fn fft_matches_direct_inverse_dft() {
    let m = Measurement::uniform(2e9, 18e9, 40, 51f64.to_radians(), 40).unwrap();
    for &n in &[8usize, 9, 12] {
        let o = ImagingOptions {
            size: n,
            window: Window::Hamming,
            extent_m: Some(0.3),
        };
        let pts = [
            (Complex64::new(1.0, 0.5), [0.03, -0.02, 0.0]),
            (Complex64::new(-0.3, 0.2), [-0.07, 0.05, 0.1]),
        ];
        let e = point_response(&pts, &m);
        let g = polar_to_cartesian(e.view(), &m, &o).unwrap();
        let fast = centred_ifft2(&g.data, g.norm);
        let h = (n / 2) as f64;
        let tp = 2.0 * std::f64::consts::PI / n as f64;
        for p in 0..n {
            for q in 0..n {
                let mut acc = Complex64::new(0.0, 0.0);
                for r in 0..n {
                    for c in 0..n {
                        let ph = tp
                            * ((r as f64 - h) * (p as f64 - h) + (c as f64 - h) * (q as f64 - h));
                        acc += g.data[[r, c]] * Complex64::from_polar(1.0, ph);
                    }
                }
                acc /= g.norm;
                assert!((acc - fast[[p, q]]).norm() < 1e-10, "{p} {q}");
            }
        }
    }
}

/// `exp(i x)` from the forward model's sine and cosine, one phase at a time.
fn polar(x: f64) -> Complex64 {
    let (s, c) = crate::physics::trig::sincos(x);
    Complex64::new(c, s)
}

/// [`point_response`] as first written (one recurrence after another, complex
/// arithmetic, each phase factor on its own): the oracle of the lane-parallel form, bit for
/// bit.
fn point_response_serial(points: &[(Complex64, [f64; 3])], m: &Measurement) -> Array2<Complex64> {
    let (nf, np) = (m.n_f(), m.n_phi());
    let mut out = Array2::<Complex64>::zeros((nf, np));
    let (cs, k2, uniform) = response_geometry(m);
    for b in 0..nf.div_ceil(F_BLOCK) {
        let i0 = b * F_BLOCK;
        let nb = F_BLOCK.min(nf - i0);
        let dk2 = if nf >= 2 { k2[1] - k2[0] } else { 0.0 };
        for (a, r) in points {
            for (j, &(c, s)) in cs.iter().enumerate() {
                let u = r[0] * c + r[1] * s;
                let mut ph = *a * polar(-k2[i0] * u);
                let st = polar(-dk2 * u);
                for ii in 0..nb {
                    out[[i0 + ii, j]] += if uniform {
                        let v = ph;
                        ph *= st;
                        v
                    } else {
                        *a * polar(-k2[i0 + ii] * u)
                    };
                }
            }
        }
    }
    out
}

#[test]
fn lane_parallel_response_equals_the_serial_recurrence_bit_for_bit() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let uniform = |nf: usize, np: usize| {
        Measurement::uniform(2e9, 18e9, nf, 0.9, np).expect("valid measurement")
    };
    let mut cases = vec![
        uniform(40, 64),
        uniform(100, 7),
        uniform(33, 17),
        uniform(4, 5),
        uniform(64, 40),
    ];
    let mut uneven = uniform(45, 20);
    uneven.freqs[3] *= 1.01;
    cases.push(uneven);
    for m in &cases {
        let pts: Vec<(Complex64, [f64; 3])> = (0..25)
            .map(|_| {
                (
                    Complex64::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)),
                    [
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                        rng.random_range(0.0..1.0),
                    ],
                )
            })
            .collect();
        let slow = point_response_serial(&pts, m);
        // The dispatched kernel, and each lane count on the baseline instruction set.
        let fills: [(&str, Array2<Complex64>); 3] = [
            ("dispatched", point_response(&pts, m)),
            (
                "8 lanes",
                point_response_with(&pts, m, |b, c| b.fill::<AZ_LANES>(c)),
            ),
            (
                "32 lanes",
                point_response_with(&pts, m, |b, c| b.fill::<AZ_LANES_512>(c)),
            ),
        ];
        for (what, fast) in fills {
            assert!(
                fast.iter()
                    .zip(slow.iter())
                    .all(|(a, b)| a.re.to_bits() == b.re.to_bits()
                        && a.im.to_bits() == b.im.to_bits()),
                "{what}: {} x {}",
                m.n_f(),
                m.n_phi()
            );
        }
    }
}

#[test]
fn recurrence_matches_direct_sum() {
    let m = Measurement::uniform(2e9, 18e9, 100, 0.9, 7).unwrap();
    let pts = [
        (Complex64::new(1.0, 0.0), [0.25, -0.2, 0.0]),
        (Complex64::new(0.5, -0.1), [-0.1, 0.3, 0.5]),
    ];
    let e = point_response(&pts, &m);
    for (i, f) in m.freqs.iter().enumerate() {
        for (j, p) in m.azimuths.iter().enumerate() {
            let k2 = 4.0 * std::f64::consts::PI * f / C0;
            let d: Complex64 = pts
                .iter()
                .map(|(a, r)| {
                    *a * Complex64::from_polar(1.0, -k2 * (r[0] * p.cos() + r[1] * p.sin()))
                })
                .sum();
            assert!((d - e[[i, j]]).norm() < 1e-12);
        }
    }
}

#[test]
fn bad_inputs_are_errors() {
    let (m, o) = small();
    let e = Array2::<Complex64>::zeros((3, 3));
    assert!(matches!(
        try_image(e.view(), &m, &o),
        Err(IsarError::Shape { .. })
    ));
    let o2 = ImagingOptions {
        extent_m: Some(-1.0),
        ..o.clone()
    };
    let e = Array2::<Complex64>::zeros((256, 256));
    assert!(try_image(e.view(), &m, &o2).is_err());
    assert!(Measurement::uniform(2e9, 1e9, 10, 0.5, 10).is_err());
}
