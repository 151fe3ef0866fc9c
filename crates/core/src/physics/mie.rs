//! Mie series for the monostatic backscatter of a perfectly electrically
//! conducting (PEC) sphere: the reference target whose exactly known complex
//! response (amplitude and phase versus frequency) a radar calibration
//! divides by.
//!
//! # Conventions
//!
//! Time dependence is **e^{+jωt}** (engineering / VNA convention: a delay τ
//! gives a phase factor e^{-jωτ}). The phase reference is the sphere's
//! centre. For a plane wave of amplitude E₀ (at the centre) and the co-polar
//! far field E_s scattered back towards the source at range r,
//!
//! ```text
//! s(ka) = lim_{r→∞} 2 r e^{+jkr} E_s / (a E₀),      |s|² = σ / (π a²)
//! ```
//!
//! With the Bohren & Huffman (1983, ch. 4) coefficients in the
//! perfect-conductor limit m → ∞, a_n = ψ_n'(x)/ξ_n'(x) and
//! b_n = ψ_n(x)/ξ_n(x) (ψ_n = x j_n, ξ_n = x h_n⁽¹⁾, x = ka), this is
//!
//! ```text
//! s = conj( (j/x) Σ_{n≥1} (-1)^(n+1) (2n+1) (a_n − b_n) ) = conj( 2j S₁(π) / x )
//! ```
//!
//! where S₁(π) is B&H's backscatter amplitude (their e^{-iωt} convention, hence
//! the complex conjugate). So σ/(πa²) = (1/x²)|Σ (-1)^n (2n+1)(a_n − b_n)|²,
//! B&H's backscattering efficiency Q_b. Ruck et al. (1970) and Balanis (1989,
//! ch. 11) label the coefficients the other way round (a_n = j_n/h_n⁽¹⁾,
//! b_n = [x j_n]'/[x h_n⁽¹⁾]'), which flips only the overall sign of the sum;
//! their S = Σ (-1)^n (n + 1/2)(b_n − a_n) gives s = conj(−2j S / x). Checks built into the tests: the Rayleigh limit
//! s → 3(ka)² (real, positive: σ = 9πa²(ka)⁴), and the optical limit
//! s → −e^{+2jka} (specular return from the front of the sphere, a distance
//! a closer than the centre, with the −1 reflection of a conductor).
//!
//! To use the e^{-iωt} (physics) convention instead, take the complex
//! conjugate of the results.
//!
//! # Numerics
//!
//! ψ_n is obtained by Miller's downward recurrence (started well above the
//! last term and normalised with ψ₀ = sin x or ψ₁), χ_n = −x y_n by the
//! (stable) upward recurrence, and the series is truncated at
//! N = x + 6 x^{1/3} + 8 (Wiscombe's x + 4.05 x^{1/3} + 2 with a margin). Below ka = 0.01 a
//! low-frequency expansion exact through (ka)⁹ is used instead.

use num_complex::Complex64;

/// Speed of light in vacuum, m/s.
pub const C0: f64 = 299_792_458.0;

/// Below this ka the low-frequency expansion [`small_ka_series`] is used: the
/// Riccati-Neumann functions would overflow for extremely small ka.
const SMALL_KA: f64 = 0.01;

/// Expansion of s(ka) for small ka, exact through (ka)⁹ (orders n ≤ 4 of the
/// series expanded symbolically with sympy; order n = 5 starts at (ka)¹⁰), so
/// its relative error below ka = 0.01 is below 1e-16.
fn small_ka_series(x: f64) -> Complex64 {
    let x2 = x * x;
    let re =
        x2 * (3.0 + x2 * (-5.0 / 18.0 + x2 * (17.0 / 300.0 + x2 * (-6_651_923.0 / 3_969_000.0))));
    let im = -x2 * x2 * x * (1.0 + x2 * (6.0 / 5.0 - x2 * (1951.0 / 2268.0)));
    Complex64::new(re, im)
}

/// Number of series terms. Wiscombe's (1980) N = x + 4.05 x^{1/3} + 2 leaves
/// a truncation error of ~3e-9 at ka = 1000; this wider margin keeps the
/// deviation from a 40-digit reference below 1e-12 up to ka = 1000.
fn n_terms(x: f64) -> usize {
    (x + 6.0 * x.cbrt() + 8.0).ceil() as usize
}

/// ψ_n(x) = x j_n(x) for n = 0..=nmax by Miller's downward recurrence.
fn riccati_psi(x: f64, nmax: usize) -> Vec<f64> {
    // Start far enough above nmax (and above x) that the contamination by the
    // dominant solution has died out by the time n ≤ nmax is reached.
    let nstart = nmax.max(x as usize) + 20 + (2.0 * x.cbrt()).ceil() as usize + nmax / 8;
    let mut psi = vec![0.0; nstart + 2];
    psi[nstart + 1] = 0.0;
    psi[nstart] = 1e-300;
    for n in (1..=nstart).rev() {
        let v = (2 * n + 1) as f64 / x * psi[n] - psi[n + 1];
        psi[n - 1] = v;
        if v.abs() > 1e250 {
            // Rescale everything computed so far (higher orders may underflow
            // to zero, which is harmless: they are negligible).
            for p in psi[n - 1..].iter_mut() {
                *p *= 1e-250;
            }
        }
    }
    // Normalise with whichever of ψ₀ = sin x, ψ₁ = sin x / x − cos x is larger
    // (ψ₁ is only evaluated directly where that is accurate).
    let s0 = x.sin();
    let s1 = x.sin() / x - x.cos();
    let scale = if s0.abs() >= s1.abs() || x < 1.0 {
        s0 / psi[0]
    } else {
        s1 / psi[1]
    };
    psi.truncate(nmax + 1);
    for p in psi.iter_mut() {
        *p *= scale;
    }
    psi
}

/// χ_n(x) = −x y_n(x) for n = 0..=nmax by upward recurrence.
fn riccati_chi(x: f64, nmax: usize) -> Vec<f64> {
    let mut chi = Vec::with_capacity(nmax + 1);
    chi.push(x.cos());
    chi.push(x.cos() / x + x.sin());
    for n in 1..nmax {
        let v = (2 * n + 1) as f64 / x * chi[n] - chi[n - 1];
        chi.push(v);
    }
    chi.truncate(nmax + 1);
    chi
}

/// Complex monostatic backscatter of a PEC sphere, normalised so that |s|^2 = sigma / (pi a^2); phase referenced to the sphere's centre, e^{+j omega t} convention (see the module docs; conjugate for e^{-i omega t}).
///
/// Tends to 3(ka)² for ka → 0 and to −e^{+2j ka} for ka → ∞.
/// `ka = 0` gives 0; a negative or non-finite `ka` gives NaN (no panic).
pub fn pec_sphere_backscatter(ka: f64) -> Complex64 {
    if ka == 0.0 {
        return Complex64::new(0.0, 0.0);
    }
    if !(ka.is_finite() && ka > 0.0) {
        return Complex64::new(f64::NAN, f64::NAN);
    }
    let x = ka;
    if x < SMALL_KA {
        return small_ka_series(x);
    }
    let nmax = n_terms(x);
    let psi = riccati_psi(x, nmax);
    let chi = riccati_chi(x, nmax);
    // ξ_n = ψ_n − i χ_n = x h_n^(1)(x)  (B&H, e^{-iωt}).
    let xi = |n: usize| Complex64::new(psi[n], -chi[n]);
    let mut sum = Complex64::new(0.0, 0.0);
    for n in 1..=nmax {
        let nf = n as f64;
        let dpsi = psi[n - 1] - nf * psi[n] / x;
        let dxi = xi(n - 1) - xi(n) * (nf / x);
        let a = Complex64::new(dpsi, 0.0) / dxi; // B&H a_n, m → ∞
        let b = Complex64::new(psi[n], 0.0) / xi(n); // B&H b_n, m → ∞
        let sign = if n % 2 == 1 { 1.0 } else { -1.0 }; // (-1)^(n+1)
        sum += (a - b) * (sign * (2.0 * nf + 1.0));
    }
    // e^{-iωt}: s = (i/x) Σ (-1)^(n+1)(2n+1)(a_n − b_n); conjugate for e^{+jωt}.
    (Complex64::new(0.0, 1.0) * sum / x).conj()
}

/// sigma / (pi a^2): the monostatic radar cross section of a PEC sphere of
/// electrical size `ka`, normalised by its geometric cross section
/// (→ 9 (ka)⁴ in the Rayleigh region, → 1 in the optical region).
pub fn pec_sphere_rcs_normalised(ka: f64) -> f64 {
    pec_sphere_backscatter(ka).norm_sqr()
}

/// Complex backscatter for radius `a` metres at frequencies `f` (Hz): the quantity a calibration divides by (sqrt of RCS in metres with phase), documented.
///
/// Returns √π · a · s(ka) in metres, with k = 2πf/c and s from
/// [`pec_sphere_backscatter`], so that |value|² is the radar cross section σ
/// in m². Phase: e^{+jωt} convention, referenced to the sphere's centre; a
/// measurement referenced elsewhere needs the two-way propagation factor
/// e^{−2jkd} (d = range offset of the reference plane behind the centre).
/// A calibration forms `measured_target × (sphere_response / measured_sphere)`.
pub fn pec_sphere_response(a: f64, f: &[f64]) -> Vec<Complex64> {
    let root_area = std::f64::consts::PI.sqrt() * a;
    f.iter()
        .map(|&fi| {
            let ka = 2.0 * std::f64::consts::PI * fi / C0 * a;
            pec_sphere_backscatter(ka) * root_area
        })
        .collect()
}

#[cfg(test)]
mod tests {
    //! References:
    //! - Bohren & Huffman, *Absorption and Scattering of Light by Small
    //!   Particles* (1983), ch. 4: coefficients, backscattering efficiency.
    //! - Ruck, Barrick, Stuart & Krichbaum, *Radar Cross Section Handbook*
    //!   (1970), ch. 3 (sphere): Rayleigh limit σ = 9πa²(ka)⁴, optical limit πa².
    //! - Balanis, *Advanced Engineering Electromagnetics* (1989), ch. 11
    //!   (monostatic RCS of a PEC sphere against ka): first resonance peak
    //!   ≈ 3.65 πa² (≈ 5.6 dB above πa²) near ka ≈ 1, read from the curve.
    //! - Independent 40-digit mpmath evaluation (and miepython 3.3.0 with m = 0)
    //!   in `tests/mie_crosscheck.py` → `tests/data/mie_pec_reference.txt`.

    use super::*;

    const FIXTURE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/mie_pec_reference.txt"
    );

    /// (ka, s) pairs and the (ka, value) of the first peak from the fixture.
    fn fixture() -> (Vec<(f64, Complex64)>, (f64, f64)) {
        let text = std::fs::read_to_string(FIXTURE).expect("tests/data/mie_pec_reference.txt");
        let mut pts = vec![];
        let mut peak = (f64::NAN, f64::NAN);
        for line in text.lines().filter(|l| !l.starts_with('#')) {
            let w: Vec<&str> = line.split_whitespace().collect();
            if w[0] == "PEAK" {
                peak = (w[1].parse().unwrap(), w[2].parse().unwrap());
            } else {
                let v: Vec<f64> = w.iter().map(|x| x.parse().unwrap()).collect();
                pts.push((v[0], Complex64::new(v[1], v[2])));
            }
        }
        (pts, peak)
    }

    #[test]
    fn matches_mpmath_reference_to_1e_9() {
        let (pts, _) = fixture();
        assert!(pts.len() >= 200);
        let mut worst: f64 = 0.0;
        for (ka, want) in pts {
            let got = pec_sphere_backscatter(ka);
            let rel = (got - want).norm() / want.norm();
            worst = worst.max(rel);
            assert!(
                rel < 1e-9,
                "ka = {ka}: {got} vs mpmath {want} (rel {rel:e})"
            );
        }
        eprintln!("max relative deviation from mpmath over ka 0.01..1000: {worst:.2e}");
    }

    #[test]
    fn rayleigh_limit() {
        // Ruck et al. ch. 3: σ/(πa²) → 9 (ka)⁴, and s → 3(ka)² (real, positive).
        for (ka, tol) in [(0.01, 0.01), (0.05, 0.05)] {
            let r = pec_sphere_rcs_normalised(ka);
            let ray = 9.0 * ka.powi(4);
            assert!((r / ray - 1.0).abs() < tol, "ka = {ka}: {r} vs {ray}");
            // Much tighter in fact: next term is O((ka)²).
            assert!((r / ray - 1.0).abs() < 2.0 * ka * ka, "ka = {ka}");
        }
        for ka in [1e-6, 1e-4, 1e-3] {
            let s = pec_sphere_backscatter(ka);
            let want = 3.0 * ka * ka;
            assert!((s.re / want - 1.0).abs() < 1e-5, "ka = {ka}: {s}");
            assert!(s.im.abs() < 1e-3 * want, "ka = {ka}: {s}");
        }
    }

    #[test]
    fn optical_limit() {
        // Ruck et al. ch. 3: σ → πa² for ka → ∞; phase of the specular return −e^{+2jka}.
        let r = pec_sphere_rcs_normalised(100.0);
        assert!((r - 1.0).abs() < 0.03, "ka = 100: {r}");
        let s = pec_sphere_backscatter(100.0);
        let spec = -Complex64::new(0.0, 200.0).exp();
        assert!((s - spec).norm() < 0.02, "ka = 100: {s} vs {spec}");
        // Mean over [50, 60]: the creeping-wave ripple averages out.
        let n = 2001;
        let mean = (0..n)
            .map(|i| pec_sphere_rcs_normalised(50.0 + 10.0 * i as f64 / (n - 1) as f64))
            .sum::<f64>()
            / n as f64;
        assert!((mean - 1.0).abs() < 0.01, "mean over [50, 60]: {mean}");
        // Very large spheres stay finite and close to the optical value.
        for ka in [1e3, 1e4] {
            let r = pec_sphere_rcs_normalised(ka);
            assert!((r - 1.0).abs() < 0.01, "ka = {ka}: {r}");
        }
    }

    #[test]
    fn first_resonance_peak() {
        // Golden-section search for the maximum of σ/(πa²) in [0.8, 1.3].
        let (mut lo, mut hi) = (0.8f64, 1.3f64);
        let g = (5f64.sqrt() - 1.0) / 2.0;
        while hi - lo > 1e-10 {
            let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if pec_sphere_rcs_normalised(x1) > pec_sphere_rcs_normalised(x2) {
                hi = x2;
            } else {
                lo = x1;
            }
        }
        let ka = 0.5 * (lo + hi);
        let peak = pec_sphere_rcs_normalised(ka);
        eprintln!("first resonance: ka = {ka:.8}, sigma/(pi a^2) = {peak:.8}");
        // Textbook curves (Balanis ch. 11, Ruck et al. ch. 3): ≈ 3.65 near ka ≈ 1.
        assert!((3.6..3.7).contains(&peak) && (0.95..1.1).contains(&ka));
        // mpmath, 40 digits (tests/mie_crosscheck.py).
        let (_, (ka_ref, peak_ref)) = fixture();
        assert!((peak - peak_ref).abs() < 1e-9, "{peak} vs {peak_ref}");
        assert!((ka - ka_ref).abs() < 1e-4, "{ka} vs {ka_ref}");
    }

    #[test]
    fn response_in_metres_and_one_inch_sphere() {
        let a = 0.0127;
        let f: Vec<f64> = (0..=160).map(|i| 2e9 + 1e8 * f64::from(i)).collect();
        let resp = pec_sphere_response(a, &f);
        assert_eq!(resp.len(), f.len());
        let area = std::f64::consts::PI * a * a;
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for (&fi, r) in f.iter().zip(&resp) {
            let ka = 2.0 * std::f64::consts::PI * fi / C0 * a;
            let s = pec_sphere_backscatter(ka);
            assert!((r / area.sqrt() - s).norm() < 1e-15);
            assert!((r.norm_sqr() / area - pec_sphere_rcs_normalised(ka)).abs() < 1e-12);
            lo = lo.min(s.norm());
            hi = hi.max(s.norm());
        }
        let ka = |fi: f64| 2.0 * std::f64::consts::PI * fi / C0 * a;
        eprintln!(
            "1-inch sphere (a = 12.7 mm), 2-18 GHz (ka {:.4}..{:.4}): |s| in [{lo:.4}, {hi:.4}], \
             sigma in [{:.3e}, {:.3e}] m^2",
            ka(2e9),
            ka(18e9),
            lo * lo * area,
            hi * hi * area
        );
        assert!(lo > 0.3 && hi < 2.0);
        assert!(pec_sphere_response(a, &[]).is_empty());
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        assert_eq!(pec_sphere_backscatter(0.0), Complex64::new(0.0, 0.0));
        assert!(pec_sphere_backscatter(-1.0).re.is_nan());
        assert!(pec_sphere_backscatter(f64::NAN).re.is_nan());
        assert!(pec_sphere_backscatter(f64::INFINITY).re.is_nan());
        assert!(pec_sphere_rcs_normalised(1e-200).is_finite());
        // Zeros of sin x: normalisation switches to ψ₁.
        for m in 1..=20 {
            let x = std::f64::consts::PI * f64::from(m);
            let r = pec_sphere_rcs_normalised(x);
            assert!(r.is_finite() && r > 0.1, "ka = {x}: {r}");
        }
    }

    #[test]
    fn riccati_bessel_values() {
        // Closed forms for n = 0..2 (B&H ch. 4): ψ₂ = (3/x² − 1) sin x − 3 cos x / x,
        // χ₂ = (3/x² − 1) cos x + 3 sin x / x.
        for x in [1.0f64, 2.5, 7.0, 31.0, 150.0, 1000.0] {
            let psi = riccati_psi(x, n_terms(x));
            let chi = riccati_chi(x, n_terms(x));
            let (s, c) = x.sin_cos();
            let p2 = (3.0 / (x * x) - 1.0) * s - 3.0 * c / x;
            let c2 = (3.0 / (x * x) - 1.0) * c + 3.0 * s / x;
            assert!((psi[0] - s).abs() < 1e-13, "x = {x}");
            assert!((psi[1] - (s / x - c)).abs() < 1e-13, "x = {x}");
            assert!((psi[2] - p2).abs() < 1e-12, "x = {x}");
            assert!((chi[2] - c2).abs() < 1e-12, "x = {x}");
        }
        // Small x: leading terms of the power series, ψ_n ≈ x^(n+1)/(2n+1)!! ·
        // (1 − x²/(2(2n+3))), where the closed forms above lose all accuracy.
        for x in [1e-2f64, 1e-1] {
            let psi = riccati_psi(x, n_terms(x));
            let mut dfact = 1.0;
            for (n, &p) in psi.iter().enumerate() {
                dfact *= (2 * n + 1) as f64;
                let nf = n as f64;
                let t = x.powi(n as i32 + 1) / dfact
                    * (1.0 - x * x / (2.0 * (2.0 * nf + 3.0))
                        + x.powi(4) / (8.0 * (2.0 * nf + 3.0) * (2.0 * nf + 5.0)));
                assert!(
                    (p / t - 1.0).abs() < 1e-5 * x.powi(2),
                    "x = {x}, n = {n}: {p} vs {t}"
                );
            }
        }
    }

    #[test]
    fn small_ka_series_joins_the_full_series() {
        let x = SMALL_KA;
        let a = small_ka_series(x);
        let b = pec_sphere_backscatter(x); // full series at the threshold itself
        assert!((a - b).norm() / b.norm() < 1e-12, "{a} vs {b}");
        let x = 0.03;
        let c = small_ka_series(x);
        let d = pec_sphere_backscatter(x);
        assert!((c - d).norm() / d.norm() < 1e-12, "{c} vs {d}");
    }
}
