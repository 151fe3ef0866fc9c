//! Tests against the f64 oracle (accuracy of each term and of the
//! distance for every form), identities (d(R, R) = 0, invariance to a
//! complex scale), the cost model, and bitwise determinism across rayon
//! pool sizes.

use super::kernel::kernel_portable;
use super::*;
use num_complex::Complex;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const TOL: f64 = 1e-5;
const FORM_SETS: [[Form; 3]; 5] = [
    [Form::Gram, Form::Gram, Form::Gram],
    [Form::Full, Form::Gram, Form::Gram],
    [Form::Gram, Form::Full, Form::Gram],
    [Form::Full, Form::Full, Form::Gram],
    [Form::Full, Form::Full, Form::Full],
];

/// Seeded random stack (row-major n x p) with correlated pixels: a moving
/// average of white noise along the pixels plus a component shared by
/// all pixels, then a per-pixel complex offset and scale (so centring and
/// normalisation matter).
fn stack(n: usize, p: usize, seed: u64) -> Vec<Complex<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let c = |rng: &mut ChaCha8Rng| {
        Complex::new(
            rng.random::<f64>() * 2.0 - 1.0,
            rng.random::<f64>() * 2.0 - 1.0,
        )
    };
    let offset: Vec<Complex<f64>> = (0..p).map(|_| c(&mut rng) * 5.0).collect();
    let scale: Vec<f64> = (0..p).map(|_| 0.5 + 3.0 * rng.random::<f64>()).collect();
    let mut x = Vec::with_capacity(n * p);
    for _ in 0..n {
        let common = c(&mut rng);
        let white: Vec<Complex<f64>> = (0..p + 2).map(|_| c(&mut rng)).collect();
        for q in 0..p {
            let v = white[q] + white[q + 1] * 0.8 + white[q + 2] * 0.5 + common * 0.7;
            x.push(offset[q] + v * scale[q]);
        }
    }
    x
}

fn normalise(x: &[Complex<f64>], n: usize, p: usize) -> Normalised {
    let pixels: Vec<usize> = (0..p).collect();
    Normalised::from_fn(n, &pixels, |s, q| (x[s * p + q].re, x[s * p + q].im))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Max relative errors of the three terms and absolute error of the
/// distance, against the oracle terms.
fn errors(t: &CmdTerms, o: &CmdTerms) -> [f64; 4] {
    [
        rel(t.norm1_sq, o.norm1_sq),
        rel(t.norm2_sq, o.norm2_sq),
        rel(t.cross, o.cross),
        (t.distance() - o.distance()).abs(),
    ]
}

fn check_shapes(shapes: &[(usize, usize, usize)], kern: Kernel, what: &str) {
    let mut worst = [0.0f64; 4];
    for (case, &(n1, n2, p)) in shapes.iter().enumerate() {
        let x1 = stack(n1, p, 100 + case as u64);
        let x2 = stack(n2, p, 200 + case as u64);
        let o = cmd_oracle_terms(&x1, n1, &x2, n2, p);
        let (a1, a2) = (normalise(&x1, n1, p), normalise(&x2, n2, p));
        let mut sets = FORM_SETS.to_vec();
        sets.push(choose_forms(n1, n2, p));
        for forms in sets {
            let t = cmd_terms_impl(&a1, &a2, forms, kern);
            let e = errors(&t, &o);
            for (w, x) in worst.iter_mut().zip(e) {
                *w = w.max(x);
            }
            assert!(
                e.iter().all(|&x| x < TOL),
                "{what}: n1={n1} n2={n2} p={p} forms={forms:?}: errors {e:?}, \
                     terms {t:?} vs oracle {o:?}"
            );
        }
    }
    println!(
        "{what}: max rel err norm1 {:.2e}, norm2 {:.2e}, cross {:.2e}; max abs err d {:.2e}",
        worst[0], worst[1], worst[2], worst[3]
    );
}

#[test]
fn matches_oracle_all_forms() {
    // N in {50, 300}, P in {64, 256}: N < P and N > P, both cross forms.
    let mut shapes = Vec::new();
    for &p in &[64, 256] {
        for &(n1, n2) in &[(50, 50), (50, 300), (300, 50), (300, 300)] {
            shapes.push((n1, n2, p));
        }
    }
    check_shapes(
        &shapes,
        select_kernel(),
        "oracle, N in {50,300}, P in {64,256}",
    );
}

#[test]
fn matches_oracle_ragged_and_multi_chunk() {
    // Sizes that are not multiples of MR, NR or BLOCK, tiny ones, and
    // inner dimensions longer than KC_MAX (several f32 chunks).
    let shapes = [
        (2, 3, 1),
        (7, 13, 5),
        (13, 101, 61),
        (97, 193, 200),
        (40, 700, 600),
    ];
    check_shapes(&shapes, select_kernel(), "oracle, ragged shapes");
}

#[test]
fn matches_oracle_long_inner_dimension() {
    // K = 2000 samples in the P x P form: 8 f32 chunks summed in f64.
    check_shapes(&[(100, 2000, 512)], select_kernel(), "oracle, N2 = 2000");
}

#[test]
fn no_pixels_gives_nan() {
    let a = Normalised::from_fn(5, &[], |_, _| (0.0, 0.0));
    let t = cmd_terms(&a, &a);
    assert_eq!((t.norm1_sq, t.norm2_sq, t.cross), (0.0, 0.0, 0.0));
    assert!(t.distance().is_nan());
}

#[test]
fn portable_kernel_matches_oracle() {
    check_shapes(
        &[(50, 300, 64), (37, 45, 130)],
        kernel_portable,
        "portable kernel",
    );
}

#[test]
fn oracle_distance_matches_terms() {
    let (n1, n2, p) = (30, 40, 20);
    let (x1, x2) = (stack(n1, p, 1), stack(n2, p, 2));
    let d = cmd_oracle(&x1, n1, &x2, n2, p);
    assert_eq!(d, cmd_oracle_terms(&x1, n1, &x2, n2, p).distance());
    assert!(d > 0.0 && d < 1.0, "{d}");
    assert!(cmd_oracle(&x1, n1, &x1, n1, p).abs() < 1e-12);
}

#[test]
fn identical_stacks_have_zero_distance() {
    for &(n, p) in &[(50, 64), (300, 64), (50, 256), (300, 256)] {
        let x = stack(n, p, 7);
        let a = normalise(&x, n, p);
        for forms in FORM_SETS {
            let d = cmd_terms_with_forms(&a, &a, forms).distance();
            assert!(d.abs() < 1e-6, "n={n} p={p} {forms:?}: d = {d}");
        }
    }
}

#[test]
fn invariant_to_complex_scaling() {
    for &(n1, n2, p) in &[(50, 300, 64), (300, 50, 256), (50, 50, 256)] {
        let (x1, x2) = (stack(n1, p, 11), stack(n2, p, 12));
        let c = Complex::new(-3.7, 12.25);
        let x1c: Vec<Complex<f64>> = x1.iter().map(|&z| z * c).collect();
        let (a1, a1c, a2) = (
            normalise(&x1, n1, p),
            normalise(&x1c, n1, p),
            normalise(&x2, n2, p),
        );
        let (t, tc) = (cmd_terms(&a1, &a2), cmd_terms(&a1c, &a2));
        let e = errors(&tc, &t);
        assert!(e[..3].iter().all(|&x| x < TOL) && e[3] < 1e-6, "{e:?}");
    }
}

#[test]
fn pixel_subset_matches_oracle_on_subset() {
    let (n1, n2, p) = (60, 80, 50);
    let (x1, x2) = (stack(n1, p, 21), stack(n2, p, 22));
    let keep: Vec<usize> = (0..p).filter(|q| q % 3 != 1).collect();
    let sub = |x: &[Complex<f64>], n: usize| -> Vec<Complex<f64>> {
        (0..n)
            .flat_map(|s| keep.iter().map(move |&q| x[s * p + q]))
            .collect()
    };
    let o = cmd_oracle_terms(&sub(&x1, n1), n1, &sub(&x2, n2), n2, keep.len());
    let get = |x: &[Complex<f64>]| {
        let x = x.to_vec();
        move |s: usize, q: usize| (x[s * p + q].re, x[s * p + q].im)
    };
    let a1 = Normalised::from_fn(n1, &keep, get(&x1));
    let a2 = Normalised::from_fn(n2, &keep, get(&x2));
    assert_eq!((a1.n, a1.p), (n1, keep.len()));
    let e = errors(&cmd_terms(&a1, &a2), &o);
    assert!(e.iter().all(|&x| x < TOL), "{e:?}");
}

#[test]
fn normalised_has_unit_diagonal_and_zero_mean() {
    let (n, p) = (40, 9);
    let a = normalise(&stack(n, p, 5), n, p);
    for q in 0..p {
        let (mut sr, mut si, mut ss) = (0.0f64, 0.0f64, 0.0f64);
        for s in 0..n {
            let (r, i) = (a.re[s * p + q] as f64, a.im[s * p + q] as f64);
            sr += r;
            si += i;
            ss += r * r + i * i;
        }
        assert!(sr.abs() < 1e-5 && si.abs() < 1e-5 && (ss - 1.0).abs() < 1e-5);
    }
}

#[test]
fn cost_model_picks_expected_forms() {
    use Form::{Full, Gram};
    assert_eq!(choose_forms(1000, 5000, 4096), [Full, Full, Full]);
    assert_eq!(choose_forms(1000, 1000, 4096), [Gram, Gram, Gram]);
    assert_eq!(choose_forms(50, 50, 256), [Gram, Gram, Gram]);
    assert_eq!(choose_forms(300, 300, 64), [Full, Full, Full]);
    assert_eq!(choose_forms(50, 300, 64), [Full, Full, Full]);
    // N1 <= P < N2 always goes joint: the P x P blocks of R2 are formed
    // anyway, R1's cost P^2 N1 / 2 is below Gram norm + Gram cross.
    assert_eq!(choose_forms(100, 300, 256), [Full, Full, Full]);
}

#[test]
#[should_panic(expected = "Full cross term")]
fn full_cross_needs_full_norms() {
    let a = normalise(&stack(10, 8, 3), 10, 8);
    cmd_terms_with_forms(&a, &a, [Form::Gram, Form::Full, Form::Full]);
}

#[test]
fn bitwise_identical_across_thread_counts() {
    // Enough blocks and strips for real parallelism in every form.
    let cases = [(200, 700, 300), (150, 250, 700), (500, 90, 200)];
    for (case, &(n1, n2, p)) in cases.iter().enumerate() {
        let (x1, x2) = (
            stack(n1, p, 31 + case as u64),
            stack(n2, p, 41 + case as u64),
        );
        let run = |threads: usize, forms: [Form; 3]| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let (a1, a2) = (normalise(&x1, n1, p), normalise(&x2, n2, p));
                let t = cmd_terms_with_forms(&a1, &a2, forms);
                let d = t.distance();
                (
                    a1.re,
                    a1.im,
                    a2.re,
                    [t.norm1_sq, t.norm2_sq, t.cross, d].map(f64::to_bits),
                )
            })
        };
        let mut sets = FORM_SETS.to_vec();
        sets.push(choose_forms(n1, n2, p));
        for forms in sets {
            let one = run(1, forms);
            for threads in [2, 3, 8] {
                assert!(
                    run(threads, forms) == one,
                    "{n1} {n2} {p} {forms:?} {threads} threads"
                );
            }
        }
    }
}
