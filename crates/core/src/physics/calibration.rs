//! Radar calibration with a reference sphere (dissertation 2.3, docs/definitions.md §9): from a
//! stepped-frequency measurement of a perfectly conducting sphere and of the empty scene
//! (background), the correction factor `a(f) = Mie(f) / s(f)`, where `s(f)` is the sphere's
//! measurement after background subtraction and time gating (inverse FFT to the range profile,
//! a window around the sphere's range, FFT back); calibrated data are `d_c(f) = a(f) d(f)`.
//!
//! [`simulate`] builds a synthetic measurement chain to exercise it: a system response
//! `H(f) = g (1 + r cos(2 pi f tau_r)) e^{-j 2 pi f tau}` (gain, ripple from a reflection
//! `tau_r` apart, cable delay `tau`), chamber clutter as point scatterers at other ranges, a
//! background residual (clutter that changed between the two measurements) and receiver
//! noise. Conventions follow [`crate::physics::mie`]: `e^{+j omega t}`, a scatterer at range offset `d`
//! behind the reference contributes `e^{-2 j k d}`.

use crate::physics::mie::pec_sphere_response;
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use rustfft::FftPlanner;
use serde::{Deserialize, Serialize};

/// Speed of light (m/s).
pub const C: f64 = 299_792_458.0;

/// A simulated calibration measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainParams {
    /// Sphere radius (m); default 1 inch.
    #[serde(default = "inch")]
    pub sphere_radius: f64,
    /// First frequency (Hz).
    #[serde(default = "f_lo")]
    pub f_start: f64,
    /// Last frequency (Hz).
    #[serde(default = "f_hi")]
    pub f_stop: f64,
    /// Frequency points.
    #[serde(default = "points")]
    pub points: usize,
    /// System gain `g`.
    #[serde(default = "one")]
    pub gain: f64,
    /// Relative gain ripple `r`.
    #[serde(default = "ripple")]
    pub ripple: f64,
    /// Delay between the ripple's two paths (s).
    #[serde(default = "ripple_delay")]
    pub ripple_delay_s: f64,
    /// Cable delay `tau` (s).
    #[serde(default = "cable")]
    pub cable_delay_s: f64,
    /// Chamber clutter: `(range offset from the sphere in m, amplitude in m)` point scatterers.
    #[serde(default = "clutter")]
    pub clutter: Vec<(f64, f64)>,
    /// Background residual: relative change of the clutter between the two measurements.
    #[serde(default = "residual")]
    pub background_residual: f64,
    /// Receiver noise, complex standard deviation (m, same units as the sphere response).
    #[serde(default = "noise")]
    pub noise: f64,
    /// Half-width of the time gate around the sphere (m of range).
    #[serde(default = "gate")]
    pub gate_half_width_m: f64,
}

fn inch() -> f64 {
    0.0254 / 2.0
}
fn f_lo() -> f64 {
    2e9
}
fn f_hi() -> f64 {
    18e9
}
fn points() -> usize {
    801
}
fn one() -> f64 {
    1.0
}
fn ripple() -> f64 {
    0.2
}
fn ripple_delay() -> f64 {
    1.5e-9
}
fn cable() -> f64 {
    20e-9
}
fn clutter() -> Vec<(f64, f64)> {
    vec![(-0.9, 0.05), (0.35, 0.02), (1.6, 0.08)]
}
fn residual() -> f64 {
    0.01
}
fn noise() -> f64 {
    1e-5
}
fn gate() -> f64 {
    // Wide enough to keep the system ripple's echoes (+-c ripple_delay_s / 2 = +-0.22 m), so
    // that a(f) corrects the whole system response, not only the part near the sphere.
    0.4
}

impl Default for ChainParams {
    fn default() -> Self {
        serde_json::from_str("{}").expect("every field has a default")
    }
}

impl ChainParams {
    /// Validates the parameters: `(field, message)` for the first bad one.
    ///
    /// # Errors
    /// Non-positive radius, frequencies, gate or gain, `f_stop <= f_start`, fewer than 16
    /// points, negative noise or residual, non-finite values.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let pos = |name: &'static str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err((name, format!("{name} {v} must be finite and > 0")))
            }
        };
        pos("sphere_radius", self.sphere_radius)?;
        pos("f_start", self.f_start)?;
        pos("gain", self.gain)?;
        pos("gate_half_width_m", self.gate_half_width_m)?;
        if !(self.f_stop > self.f_start && self.f_stop.is_finite()) {
            return Err((
                "f_stop",
                format!(
                    "f_stop {} must exceed f_start {}",
                    self.f_stop, self.f_start
                ),
            ));
        }
        if self.points < 16 {
            return Err((
                "points",
                format!("{} frequency points; at least 16", self.points),
            ));
        }
        for (name, v) in [
            ("noise", self.noise),
            ("background_residual", self.background_residual),
            ("ripple", self.ripple),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err((name, format!("{name} {v} must be finite and >= 0")));
            }
        }
        Ok(())
    }

    /// The frequency grid (Hz).
    pub fn freqs(&self) -> Vec<f64> {
        let n = self.points.max(2);
        (0..n)
            .map(|i| self.f_start + (self.f_stop - self.f_start) * i as f64 / (n - 1) as f64)
            .collect()
    }

    /// The chamber clutter's response at `f`, amplitudes scaled by `scale`.
    fn clutter(&self, f: f64, scale: f64) -> Complex64 {
        self.clutter
            .iter()
            .map(|&(d, a)| two_way(f, d) * (a * scale))
            .sum()
    }

    /// One draw of complex receiver noise.
    fn noise(&self, rng: &mut ChaCha20Rng) -> Complex64 {
        let z: f64 = StandardNormal.sample(rng);
        let w: f64 = StandardNormal.sample(rng);
        Complex64::new(z, w) * (self.noise / std::f64::consts::SQRT_2)
    }

    /// The system response `H(f)`.
    pub fn system(&self, f: f64) -> Complex64 {
        let mag = self.gain
            * (1.0 + self.ripple * (2.0 * std::f64::consts::PI * f * self.ripple_delay_s).cos());
        Complex64::from_polar(mag, -2.0 * std::f64::consts::PI * f * self.cable_delay_s)
    }
}

/// The measurements of one calibration: sphere, background, and (to verify) the sphere again
/// with fresh noise, all as raw complex samples over `freqs`.
#[derive(Debug, Clone)]
pub struct Measurements {
    /// Frequencies (Hz).
    pub freqs: Vec<f64>,
    /// The sphere in the chamber.
    pub sphere: Vec<Complex64>,
    /// The empty chamber.
    pub background: Vec<Complex64>,
    /// The sphere measured again (independent noise, same residual), to verify the calibration.
    pub verify: Vec<Complex64>,
    /// The background for `verify`.
    pub verify_background: Vec<Complex64>,
}

/// Two-way phase of a range offset `d` (m) at frequency `f`.
fn two_way(f: f64, d: f64) -> Complex64 {
    Complex64::from_polar(1.0, -4.0 * std::f64::consts::PI * f * d / C)
}

/// Simulates the measurements from `seed` (ChaCha20; each measurement its own stream).
pub fn simulate(p: &ChainParams, seed: u64) -> Measurements {
    let freqs = p.freqs();
    let mie = pec_sphere_response(p.sphere_radius, &freqs);
    let measure = |stream: u64, with_sphere: bool, scale: f64| -> Vec<Complex64> {
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        freqs
            .iter()
            .zip(&mie)
            .map(|(&f, &s)| {
                let target = if with_sphere {
                    s
                } else {
                    Complex64::new(0.0, 0.0)
                };
                let n = p.noise(&mut rng);
                p.system(f) * (target + p.clutter(f, scale)) + n
            })
            .collect()
    };
    let r = 1.0 + p.background_residual;
    Measurements {
        sphere: measure(0, true, r),
        background: measure(1, false, 1.0),
        verify: measure(2, true, r),
        verify_background: measure(3, false, 1.0),
        freqs,
    }
}

/// Time gating: inverse FFT of `x` (Hann-tapered across the band, to keep range sidelobes low),
/// keep the range bins within `half_width_m` of the strongest return (a rectangular gate),
/// FFT back and undo the taper (bins where the taper is below 0.1 keep the ungated data). Returns the gated data and the gate's centre (m of range).
pub fn time_gate(x: &[Complex64], freqs: &[f64], half_width_m: f64) -> (Vec<Complex64>, f64) {
    let n = x.len();
    let df = (freqs[n - 1] - freqs[0]) / (n - 1) as f64;
    let taper: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * (i as f64 + 0.5) / n as f64).cos())
        .collect();
    let mut buf: Vec<Complex64> = x.iter().zip(&taper).map(|(v, t)| v * t).collect();
    let mut planner = FftPlanner::new();
    planner.plan_fft_inverse(n).process(&mut buf);
    // Bin b is a two-way delay of b / (n df): range b c / (2 n df).
    let bin_m = C / (2.0 * n as f64 * df);
    let peak = (0..n)
        .max_by(|&a, &b| buf[a].norm().total_cmp(&buf[b].norm()))
        .unwrap_or(0);
    let half = (half_width_m / bin_m).round() as isize;
    for (b, v) in buf.iter_mut().enumerate() {
        let mut d = b as isize - peak as isize;
        let n = n as isize;
        d = ((d % n) + n + n / 2) % n - n / 2; // circular distance
        if d.abs() > half {
            *v = Complex64::new(0.0, 0.0);
        }
    }
    planner.plan_fft_forward(n).process(&mut buf);
    // Undo the taper; where it is below 0.1 (the outer ~10 % of the band) the division would
    // amplify the gate's transient, so those bins keep the ungated data.
    let out = buf
        .iter()
        .zip(&taper)
        .zip(x)
        .map(|((v, &t), &raw)| if t >= 0.1 { v / (n as f64 * t) } else { raw })
        .collect();
    (out, peak as f64 * bin_m)
}

/// The calibration factor `a(f) = Mie(f) / gate(sphere - background)` of the chain `p`, from
/// measurements simulated with `seed`, over `p`'s frequencies.
pub fn factor(p: &ChainParams, seed: u64) -> Vec<Complex64> {
    factor_of(p, &simulate(p, seed))
}

/// `a(f)` from given measurements.
fn factor_of(p: &ChainParams, m: &Measurements) -> Vec<Complex64> {
    let mie = pec_sphere_response(p.sphere_radius, &m.freqs);
    let s = gated_difference(p, &m.sphere, &m.background, &m.freqs);
    mie.iter().zip(&s).map(|(m, s)| m / s).collect()
}

/// A measurement minus its background, time-gated around the strongest return.
fn gated_difference(
    p: &ChainParams,
    x: &[Complex64],
    background: &[Complex64],
    freqs: &[f64],
) -> Vec<Complex64> {
    let d: Vec<Complex64> = x.iter().zip(background).map(|(a, b)| a - b).collect();
    time_gate(&d, freqs, p.gate_half_width_m).0
}

/// Passes one azimuth's scene response `e(f)` (over `p`'s frequencies) through the chain
/// (system response, chamber clutter, noise), subtracts a background measurement and applies
/// the calibration factor `a`: the calibrated measurement of the scene. `stream` selects the
/// noise of this measurement (two ChaCha20 streams: scene and background).
pub fn measure_and_calibrate(
    p: &ChainParams,
    e: &[Complex64],
    a: &[Complex64],
    seed: u64,
    stream: u64,
) -> Vec<Complex64> {
    let freqs = p.freqs();
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    let r = 1.0 + p.background_residual;
    freqs
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            let h = p.system(f);
            let scene = h * (e[i] + p.clutter(f, r)) + p.noise(&mut rng);
            let background = h * p.clutter(f, 1.0) + p.noise(&mut rng);
            a[i] * (scene - background)
        })
        .collect()
}

/// One row of the calibration table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationRow {
    /// Frequency (Hz).
    pub freq: f64,
    /// `20 log10 |Mie|` (dBsm).
    pub mie_db: f64,
    /// The raw sphere measurement, `20 log10 |d|`.
    pub raw_db: f64,
    /// The calibrated verification measurement, `20 log10 |a d|` (dBsm).
    pub calibrated_db: f64,
    /// `calibrated_db - mie_db`.
    pub error_db: f64,
    /// Phase error of the calibrated data against Mie (degrees).
    pub phase_error_deg: f64,
}

/// Calibrates: `a(f) = Mie(f) / gate(sphere - background)`, applied to
/// `gate(verify - verify_background)`; one row per frequency.
pub fn calibrate(p: &ChainParams, m: &Measurements) -> Vec<CalibrationRow> {
    let mie = pec_sphere_response(p.sphere_radius, &m.freqs);
    let a = factor_of(p, m);
    let v = gated_difference(p, &m.verify, &m.verify_background, &m.freqs);
    let db = |z: Complex64| 20.0 * z.norm().log10();
    (0..m.freqs.len())
        .map(|i| {
            let c = a[i] * v[i];
            CalibrationRow {
                freq: m.freqs[i],
                mie_db: db(mie[i]),
                raw_db: db(m.sphere[i]),
                calibrated_db: db(c),
                error_db: db(c) - db(mie[i]),
                phase_error_deg: (c / mie[i]).arg().to_degrees(),
            }
        })
        .collect()
}

/// Summary statistics of a calibration over a band: `(band, statistic, value)` with bands
/// `full` and `inner` (the central 90 % of the points, away from the gate's edge transients),
/// statistics `max_abs_error_db`, `rms_error_db`, `max_abs_phase_error_deg`,
/// `max_abs_raw_error_db` (the uncalibrated data against Mie).
pub fn summary(rows: &[CalibrationRow]) -> Vec<(&'static str, &'static str, f64)> {
    let edge = rows.len() / 20;
    let mut out = vec![];
    for (band, r) in [("full", rows), ("inner", &rows[edge..rows.len() - edge])] {
        let max = |f: &dyn Fn(&CalibrationRow) -> f64| r.iter().map(f).fold(0.0, f64::max);
        let rms = (r.iter().map(|x| x.error_db * x.error_db).sum::<f64>() / r.len() as f64).sqrt();
        out.push((band, "max_abs_error_db", max(&|x| x.error_db.abs())));
        out.push((band, "rms_error_db", rms));
        out.push((
            band,
            "max_abs_phase_error_deg",
            max(&|x| x.phase_error_deg.abs()),
        ));
        out.push((
            band,
            "max_abs_raw_error_db",
            max(&|x| (x.raw_db - x.mie_db).abs()),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inner(rows: &[CalibrationRow], p: &ChainParams) -> Vec<CalibrationRow> {
        // The gate's transient spoils a few per cent of the band at each edge.
        let edge = p.points / 20;
        rows[edge..rows.len() - edge].to_vec()
    }

    #[test]
    fn noiseless_chain_calibrates_exactly() {
        let p = ChainParams {
            noise: 0.0,
            background_residual: 0.0,
            ..ChainParams::default()
        };
        let rows = calibrate(&p, &simulate(&p, 1));
        for r in &rows {
            // Identical sphere and verification data: a d = Mie to rounding.
            assert!(
                r.error_db.abs() < 1e-9 && r.phase_error_deg.abs() < 1e-7,
                "{r:?}"
            );
        }
    }

    #[test]
    fn noisy_chain_with_a_residual_calibrates_within_a_fraction_of_a_db() {
        let p = ChainParams::default();
        let rows = calibrate(&p, &simulate(&p, 7));
        let mid = inner(&rows, &p);
        let worst = mid.iter().map(|r| r.error_db.abs()).fold(0.0, f64::max);
        assert!(worst < 0.5, "worst in-band error {worst} dB");
        // Without calibration the raw data are far off (system gain, ripple, clutter).
        let raw = mid
            .iter()
            .map(|r| (r.raw_db - r.mie_db).abs())
            .fold(0.0, f64::max);
        assert!(raw > 3.0, "raw error {raw} dB");
    }

    #[test]
    fn the_gate_finds_the_sphere_behind_the_cable_delay() {
        let p = ChainParams {
            noise: 0.0,
            ..ChainParams::default()
        };
        let m = simulate(&p, 3);
        let d: Vec<Complex64> = m
            .sphere
            .iter()
            .zip(&m.background)
            .map(|(a, b)| a - b)
            .collect();
        let (_, centre) = time_gate(&d, &m.freqs, p.gate_half_width_m);
        // Two-way cable delay tau puts the sphere's centre at range c tau / 2 (modulo the
        // unambiguous range c / (2 df)); its specular return comes from the front face, one
        // radius closer.
        let df = (p.f_stop - p.f_start) / (p.points - 1) as f64;
        let want = (C * p.cable_delay_s / 2.0) % (C / (2.0 * df)) - p.sphere_radius;
        let bin = C / (2.0 * p.points as f64 * df);
        assert!((centre - want).abs() <= bin, "{centre} vs {want}");
    }
}
