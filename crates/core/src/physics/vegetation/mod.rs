//! Physical stand-in for the ISAR plant-clutter measurements
//! (docs/definitions.md §10): a plant is a set of point scatterers moved by wind, imaged
//! with the chain of [`crate::physics::isar`].
//!
//! Geometry (fixed by the seed). `n_stems` stems rise from bases on a circle
//! of radius `base_radius_m`, each a chain of point scatterers spaced
//! `scatterer_spacing_m` (amplitude `stem_amplitude` each; a vertical stem
//! is broadside at elevation 0, so its points add coherently in the top
//! view, like a cylinder of RCS `2 pi a L^2 / lambda`). Branches leave the
//! upper part of each stem, with leaves along their outer part. A leaf of
//! length `L` (lognormal spread) has area `A = 0.5 L^2` and is a cluster of
//! `leaf_points` scatterers spread over its plane; each carries
//! `a = leaf_gain * A * (floor + (1 - floor) |n . r_hat0|) / leaf_points`
//! (physical-optics plate law `sqrt(sigma) = sqrt(4 pi) A / lambda`, with the
//! incidence factor evaluated at the centre aspect `r_hat0 = x`), so the
//! cluster's coherent sum also has the plate-like specular pattern.
//! Optional double bounce: a leaf and its nearest stem/branch point at
//! distance `d < double_bounce_max_dist_m` give an equivalent scatterer at
//! the mid-point displaced `d/2` down-range (path `r_hat.r1 + d + r_hat.r2`),
//! amplitude `double_bounce_strength * sqrt(|a1 a2|)`.
//!
//! Wind (sequential, deterministic given the seed). A 2-D Ornstein-Uhlenbeck
//! gust `g` (along- and cross-wind, time constant `tau`, std
//! `turbulence_intensity * U`; a shared part with fraction
//! `gust_coherence` of the variance plus an independent part per stem):
//! `dg = -g dt / tau + sigma sqrt(2 / tau) dW`. Drag `~ |V| V` gives a
//! steady tip deflection `D0 = deflection_gain * flexibility * U^2` along the
//! wind and a fluctuating load `deflection_gain * flexibility * U (2 g_u, g_v)`
//! driving damped oscillators for every stem and branch:
//! `x'' + 2 zeta w x' + w^2 x = w^2 F(t)` (semi-implicit Euler, 40 steps per
//! period). A point at height fraction `s` of a stem moves by `D s^2`
//! (cantilever-like shape); branch points add their own oscillator times
//! `t^2` along the branch. Leaves flutter faster: two orientation angles and
//! a 2-D translation follow OU processes with correlation time
//! `1 / (2 pi f_flutter)` and stds `leaf_flutter_scale * U * (L / 0.1 m)` (rad,
//! capped at 1) and `0.3 L` times that (m). All scatterers also get an
//! independent residual jitter `residual_motion_m` per sample (non-zero even
//! without wind). Receiver noise is complex white Gaussian noise of power
//! `10^(noise_db/10) * P`, with `P = sum |a_k|^2` the static clutter power
//! (mean of `|E|^2` over k-space for resolved scatterers); the background
//! residual is a fixed set of 32 weak random points of total power
//! `background_residual * P` inside a 0.25 m radius.

use crate::physics::isar::{self, ImagingOptions, IsarError, Measurement};
use ndarray::{Array3, Axis};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

pub mod calibration;
mod plant;

use plant::*;

/// Errors from the vegetation simulator; names the offending parameter.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VegError {
    /// A parameter is out of its valid range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// Error from the imaging chain.
    #[error(transparent)]
    Isar(#[from] IsarError),
    /// The k-space data or the images do not fit in memory.
    #[error(transparent)]
    Alloc(#[from] crate::alloc::AllocError),
}

fn bad(name: &'static str, reason: &str) -> VegError {
    VegError::InvalidParameter {
        name,
        reason: reason.to_string(),
    }
}

/// Physical description of one plant.
#[derive(serde::Deserialize, serde::Serialize, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlantParams {
    /// Number of main stems / canes / stalks (>= 1).
    pub n_stems: usize,
    /// Stem height (m).
    pub stem_height_m: f64,
    /// Radius (m) of the circle the stem bases stand on (sets stem spacing).
    pub base_radius_m: f64,
    /// Maximum random static lean of a stem from vertical (rad).
    pub stem_lean_rad: f64,
    /// Natural crookedness of a stem: std (m) at the stem top of a lateral
    /// random walk of its scatterers away from the straight line.
    pub stem_crookedness_m: f64,
    /// Spacing (m) of the point scatterers along stems and branches.
    pub scatterer_spacing_m: f64,
    /// Amplitude (m, i.e. sqrt of RCS in m^2) of one stem scatterer.
    pub stem_amplitude: f64,
    /// Branches per stem.
    pub branches_per_stem: usize,
    /// Fraction of the stem height (0..1) above which branches attach.
    pub branch_start_frac: f64,
    /// Branch length (m).
    pub branch_length_m: f64,
    /// Branch elevation above horizontal (rad).
    pub branch_elevation_rad: f64,
    /// Amplitude (m) of one branch scatterer.
    pub branch_amplitude: f64,
    /// Leaves per branch (placed from the branch tip inwards).
    pub leaves_per_branch: usize,
    /// Spacing (m) between successive leaves along a branch.
    pub leaf_spacing_m: f64,
    /// Median leaf length `L` (m); leaf area is `0.5 L^2`.
    pub leaf_size_m: f64,
    /// Lognormal sigma of the leaf length (dimensionless).
    pub leaf_size_spread: f64,
    /// Point scatterers per leaf cluster (>= 1).
    pub leaf_points: usize,
    /// Leaf amplitude per unit area at normal incidence (1/m); physical
    /// optics gives `sqrt(4 pi) / lambda` (~118 /m at 10 GHz).
    pub leaf_gain: f64,
    /// Diffuse floor of the incidence law `floor + (1-floor)|cos(incidence)|` (0..1).
    pub leaf_diffuse_floor: f64,
    /// Maximum tilt of a leaf normal from vertical (rad).
    pub leaf_max_tilt_rad: f64,
    /// Whether leaf/stem double-bounce scatterers are added.
    pub double_bounce: bool,
    /// Double-bounce amplitude relative to `sqrt(|a1 a2|)`.
    pub double_bounce_strength: f64,
    /// Maximum leaf-to-structure distance (m) for a double-bounce pair.
    pub double_bounce_max_dist_m: f64,
    /// Stem flexibility (dimensionless multiplier of the wind deflection gain).
    pub stem_flexibility: f64,
    /// Branch flexibility (dimensionless multiplier of the wind deflection gain).
    pub branch_flexibility: f64,
    /// Stem sway natural frequency (Hz).
    pub stem_sway_freq_hz: f64,
    /// Branch sway natural frequency (Hz).
    pub branch_sway_freq_hz: f64,
    /// Sway damping ratio zeta (dimensionless, > 0).
    pub sway_damping: f64,
    /// Leaf flutter frequency (Hz): the OU correlation time is `1/(2 pi f)`.
    pub leaf_flutter_freq_hz: f64,
    /// Leaf flutter angle std per (m/s of wind) per (0.1 m of leaf length) (rad s/m).
    pub leaf_flutter_scale: f64,
}

/// Wind conditions.
#[derive(serde::Deserialize, serde::Serialize, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WindParams {
    /// Mean wind speed U (m/s), >= 0.
    pub speed_mps: f64,
    /// Wind direction in the xy plane (rad from +x).
    pub direction_rad: f64,
    /// Steady tip deflection per (m/s)^2 for flexibility 1 (m s^2/m^2).
    pub deflection_gain: f64,
    /// OU gust time constant (s), > 0.
    pub gust_time_constant_s: f64,
    /// Gust std relative to the mean speed (dimensionless).
    pub turbulence_intensity: f64,
    /// Fraction (0..1) of the gust variance shared by all stems.
    pub gust_coherence: f64,
    /// Std (m) of the independent residual jitter of every scatterer per
    /// sample (present with or without wind).
    pub residual_motion_m: f64,
}

/// Full scene: plant, wind, receiver noise, background and sampling.
#[derive(serde::Deserialize, serde::Serialize, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneParams {
    /// The plant.
    pub plant: PlantParams,
    /// The wind.
    pub wind: WindParams,
    /// Receiver noise power relative to the mean clutter power (dB).
    pub noise_db: f64,
    /// Static background residual power relative to the clutter power (linear, >= 0).
    pub background_residual: f64,
    /// Time between successive samples (s), > 0.
    pub sample_interval_s: f64,
}

/// The plant and the wind of a dataset id `plant_<plant>_<wind>` (e.g. `plant_A_light`), the
/// naming the hypothesis tests and the report's plant figures read a spec's datasets by; `None`
/// for any other id.
pub fn parse_dataset_id(id: &str) -> Option<(String, String)> {
    let mut parts = id.split('_');
    match (parts.next(), parts.next(), parts.next(), parts.next()) {
        (Some("plant"), Some(p), Some(w), None) => Some((p.to_string(), w.to_string())),
        _ => None,
    }
}

impl PlantParams {
    /// Presets "A".."E" (docs/definitions.md §10): A two large canes, very large
    /// leaves, wide spacing, large leaf motion; B medium leaves, smaller
    /// spacing and motion; C small dense leaves, little leaf motion, whole
    /// plant sways; D many small leaves on many small branches; E few large
    /// leaves on few large stalks. Sized to fit the 0.593 m default image. Calibrated: the
    /// physical preset ([`PlantParams::uncalibrated`]) with the amplitude and wind-response
    /// factors fitted to the dissertation's Table 16 ([`calibration`]).
    pub fn preset(name: &str) -> Option<PlantParams> {
        Some(calibration::calibrate(name, Self::uncalibrated(name)?))
    }

    /// The physical preset before calibration: the geometry, amplitudes and wind response as
    /// designed (see [`PlantParams::preset`]).
    ///
    /// Long because it lists the presets' parameters (plants A-E) as data.
    pub fn uncalibrated(name: &str) -> Option<PlantParams> {
        let base = PlantParams {
            n_stems: 2,
            stem_height_m: 1.0,
            base_radius_m: 0.08,
            stem_lean_rad: 0.04,
            stem_crookedness_m: 0.01,
            scatterer_spacing_m: 0.01,
            stem_amplitude: 0.008,
            branches_per_stem: 4,
            branch_start_frac: 0.4,
            branch_length_m: 0.07,
            branch_elevation_rad: 0.6,
            branch_amplitude: 0.004,
            leaves_per_branch: 1,
            leaf_spacing_m: 0.02,
            leaf_size_m: 0.13,
            leaf_size_spread: 0.15,
            leaf_points: 8,
            leaf_gain: 100.0,
            leaf_diffuse_floor: 0.2,
            leaf_max_tilt_rad: 1.0,
            double_bounce: true,
            double_bounce_strength: 0.3,
            double_bounce_max_dist_m: 0.05,
            stem_flexibility: 0.6,
            branch_flexibility: 0.5,
            stem_sway_freq_hz: 1.2,
            branch_sway_freq_hz: 3.0,
            sway_damping: 0.15,
            leaf_flutter_freq_hz: 3.0,
            leaf_flutter_scale: 0.05,
        };
        Some(match name {
            "A" => base,
            "B" => PlantParams {
                n_stems: 3,
                stem_height_m: 0.8,
                base_radius_m: 0.05,
                stem_amplitude: 0.006,
                branches_per_stem: 4,
                branch_length_m: 0.07,
                leaves_per_branch: 2,
                leaf_size_m: 0.08,
                leaf_points: 6,
                stem_flexibility: 0.5,
                leaf_flutter_freq_hz: 4.0,
                leaf_flutter_scale: 0.03,
                ..base
            },
            "C" => PlantParams {
                n_stems: 3,
                stem_height_m: 0.7,
                base_radius_m: 0.04,
                stem_amplitude: 0.004,
                branches_per_stem: 6,
                branch_length_m: 0.08,
                branch_amplitude: 0.003,
                leaves_per_branch: 4,
                leaf_spacing_m: 0.015,
                leaf_size_m: 0.035,
                leaf_points: 3,
                stem_flexibility: 1.0,
                branch_flexibility: 0.2,
                stem_sway_freq_hz: 0.8,
                leaf_flutter_freq_hz: 6.0,
                leaf_flutter_scale: 0.01,
                ..base
            },
            "D" => PlantParams {
                n_stems: 4,
                stem_height_m: 0.7,
                base_radius_m: 0.06,
                stem_amplitude: 0.004,
                branches_per_stem: 8,
                branch_start_frac: 0.3,
                branch_length_m: 0.06,
                branch_amplitude: 0.003,
                leaves_per_branch: 4,
                leaf_spacing_m: 0.012,
                leaf_size_m: 0.04,
                leaf_points: 3,
                branch_flexibility: 1.0,
                branch_sway_freq_hz: 4.0,
                leaf_flutter_freq_hz: 5.0,
                leaf_flutter_scale: 0.025,
                ..base
            },
            "E" => PlantParams {
                n_stems: 3,
                stem_height_m: 0.9,
                base_radius_m: 0.08,
                stem_amplitude: 0.012,
                branches_per_stem: 2,
                branch_length_m: 0.05,
                branch_amplitude: 0.006,
                leaves_per_branch: 1,
                leaf_size_m: 0.15,
                leaf_points: 8,
                stem_flexibility: 0.3,
                leaf_flutter_scale: 0.035,
                ..base
            },
            _ => return None,
        })
    }

    /// Checks ranges; the error names the first offending parameter.
    ///
    /// Long because each parameter's range is checked in turn, with its name.
    pub fn validate(&self) -> Result<(), VegError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if self.n_stems == 0 || self.n_stems > 1000 {
            return Err(bad("n_stems", "must be in 1..=1000"));
        }
        let checks: [(&'static str, bool); 23] = [
            ("stem_height_m", pos(self.stem_height_m)),
            ("base_radius_m", nonneg(self.base_radius_m)),
            ("stem_lean_rad", nonneg(self.stem_lean_rad)),
            ("stem_crookedness_m", nonneg(self.stem_crookedness_m)),
            ("scatterer_spacing_m", pos(self.scatterer_spacing_m)),
            ("stem_amplitude", nonneg(self.stem_amplitude)),
            (
                "branch_start_frac",
                (0.0..=1.0).contains(&self.branch_start_frac),
            ),
            ("branch_length_m", nonneg(self.branch_length_m)),
            (
                "branch_elevation_rad",
                self.branch_elevation_rad.is_finite(),
            ),
            ("branch_amplitude", nonneg(self.branch_amplitude)),
            ("leaf_spacing_m", nonneg(self.leaf_spacing_m)),
            ("leaf_size_m", pos(self.leaf_size_m)),
            ("leaf_size_spread", nonneg(self.leaf_size_spread)),
            ("leaf_gain", nonneg(self.leaf_gain)),
            (
                "leaf_diffuse_floor",
                (0.0..=1.0).contains(&self.leaf_diffuse_floor),
            ),
            ("leaf_max_tilt_rad", nonneg(self.leaf_max_tilt_rad)),
            (
                "double_bounce_strength",
                nonneg(self.double_bounce_strength),
            ),
            (
                "double_bounce_max_dist_m",
                nonneg(self.double_bounce_max_dist_m),
            ),
            ("stem_flexibility", nonneg(self.stem_flexibility)),
            ("branch_flexibility", nonneg(self.branch_flexibility)),
            (
                "stem_sway_freq_hz",
                pos(self.stem_sway_freq_hz) && pos(self.branch_sway_freq_hz),
            ),
            ("sway_damping", pos(self.sway_damping)),
            (
                "leaf_flutter_freq_hz",
                pos(self.leaf_flutter_freq_hz) && nonneg(self.leaf_flutter_scale),
            ),
        ];
        for (name, ok) in checks {
            if !ok {
                return Err(bad(name, "out of range (non-finite, negative or zero)"));
            }
        }
        if self.leaf_points == 0 || self.leaf_points > 10_000 {
            return Err(bad("leaf_points", "must be in 1..=10000"));
        }
        // Counted with saturation: an absurd count is refused, never wrapped around.
        let n_branches = self.n_stems.saturating_mul(self.branches_per_stem);
        if n_branches > 1_000_000 {
            return Err(bad(
                "branches_per_stem",
                "too many branches in total (n_stems x branches_per_stem > 1000000)",
            ));
        }
        if n_branches.saturating_mul(self.leaves_per_branch) > 1_000_000 {
            return Err(bad(
                "leaves_per_branch",
                "too many leaves in total (> 1000000)",
            ));
        }
        // At most 1e5 scatterers a stem or a branch, the one further above its usual value
        // (1 m, 0.08 m; spacing 0.01 m) named.
        for (name, length, usual) in [
            ("stem_height_m", self.stem_height_m, 1.0),
            ("branch_length_m", self.branch_length_m, 0.08),
        ] {
            if length / self.scatterer_spacing_m >= 1e5 {
                let culprit = if length / usual >= 0.01 / self.scatterer_spacing_m {
                    name
                } else {
                    "scatterer_spacing_m"
                };
                return Err(bad(
                    culprit,
                    &format!(
                        "{name} / scatterer_spacing_m gives 1e5 or more scatterers along one {}",
                        if name == "stem_height_m" {
                            "stem"
                        } else {
                            "branch"
                        }
                    ),
                ));
            }
        }
        Ok(())
    }
}

impl WindParams {
    /// Presets "none" (U = 0: only residual motion), "light" (1.5 m/s) and
    /// "medium" (4 m/s).
    pub fn preset(name: &str) -> Option<WindParams> {
        let base = WindParams {
            speed_mps: 0.0,
            direction_rad: 0.5,
            deflection_gain: 0.0015,
            gust_time_constant_s: 1.5,
            turbulence_intensity: 0.35,
            gust_coherence: 0.6,
            residual_motion_m: 1e-4,
        };
        Some(match name {
            "none" => base,
            "light" => WindParams {
                speed_mps: 1.5,
                ..base
            },
            "medium" => WindParams {
                speed_mps: 4.0,
                ..base
            },
            _ => return None,
        })
    }

    /// Checks ranges; the error names the first offending parameter.
    pub fn validate(&self) -> Result<(), VegError> {
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !nonneg(self.speed_mps) {
            return Err(bad("speed_mps", "must be finite and >= 0"));
        }
        if !self.direction_rad.is_finite() {
            return Err(bad("direction_rad", "must be finite"));
        }
        if !nonneg(self.deflection_gain) {
            return Err(bad("deflection_gain", "must be finite and >= 0"));
        }
        if !(self.gust_time_constant_s.is_finite() && self.gust_time_constant_s > 0.0) {
            return Err(bad("gust_time_constant_s", "must be finite and > 0"));
        }
        if !nonneg(self.turbulence_intensity) {
            return Err(bad("turbulence_intensity", "must be finite and >= 0"));
        }
        if !(0.0..=1.0).contains(&self.gust_coherence) {
            return Err(bad("gust_coherence", "must be in [0, 1]"));
        }
        if !nonneg(self.residual_motion_m) {
            return Err(bad("residual_motion_m", "must be finite and >= 0"));
        }
        Ok(())
    }
}

impl SceneParams {
    /// Scene from a plant preset ("A".."E") and a wind preset
    /// ("none", "light", "medium"), with -40 dB receiver noise (or the plant's calibrated
    /// noise, [`calibration::noise_db`]), a -30 dB background residual and 2 s between samples.
    pub fn preset(plant: &str, wind: &str) -> Option<SceneParams> {
        Some(SceneParams {
            plant: PlantParams::preset(plant)?,
            wind: WindParams::preset(wind)?,
            noise_db: calibration::noise_db(plant).unwrap_or(-40.0),
            background_residual: 1e-3,
            sample_interval_s: 2.0,
        })
    }

    /// Checks ranges of all parameters.
    pub fn validate(&self) -> Result<(), VegError> {
        self.plant.validate()?;
        self.wind.validate()?;
        if !(self.noise_db.is_finite() && self.noise_db < 100.0) {
            return Err(bad("noise_db", "must be finite and < 100"));
        }
        if !(self.background_residual.is_finite() && self.background_residual >= 0.0) {
            return Err(bad("background_residual", "must be finite and >= 0"));
        }
        if !(self.sample_interval_s.is_finite()
            && self.sample_interval_s > 0.0
            && self.sample_interval_s < 1e4)
        {
            return Err(bad("sample_interval_s", "must be in (0, 1e4) s"));
        }
        Ok(())
    }
}

fn rng_stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// Fallible version of [`simulate`]: validates all parameters first.
pub fn try_simulate(
    p: &SceneParams,
    m: &Measurement,
    opts: &ImagingOptions,
    n: usize,
    seed: u64,
) -> Result<(Array3<Complex64>, Array3<Complex64>), VegError> {
    p.validate()?;
    m.validate()?;
    if opts.size < 2 {
        return Err(bad("size", "image size must be >= 2"));
    }
    let (nf, np, sz) = (m.n_f(), m.n_phi(), opts.size);
    let mut geo_rng = rng_stream(seed, 0);
    let mut plant = build_plant(&p.plant, &mut geo_rng);
    // clutter reference power of the static plant
    let still = Pose {
        stem_d: vec![[0.0; 2]; p.plant.n_stems],
        br_d: vec![[0.0; 2]; plant.n_branches],
        leaf: vec![[0.0; 4]; plant.leaves.len()],
    };
    let p_ref: f64 = scatterers(&p.plant, &plant, &still)
        .iter()
        .map(|(a, _)| a.norm_sqr())
        .sum();
    let bg_pow: f64 = plant.background.iter().map(|(a, _)| a.norm_sqr()).sum();
    let bg_scale = if bg_pow > 0.0 {
        (p.background_residual * p_ref / bg_pow).sqrt()
    } else {
        0.0
    };
    for b in plant.background.iter_mut() {
        b.0 *= bg_scale;
    }
    let noise_sigma = (10f64.powf(p.noise_db / 10.0) * p_ref / 2.0).sqrt();
    // wind process: sequential, one stream
    let mut wind_rng = rng_stream(seed, 1);
    let mut sim = WindSim::new(&p.plant, &p.wind, &plant, &mut wind_rng);
    let mut kdata: Array3<Complex64> =
        crate::alloc::try_zeros((n, nf, np), "the simulated k-space data")?;
    let mut images: Array3<Complex64> =
        crate::alloc::try_zeros((n, sz, sz), "the simulated images")?;
    for s in 0..n {
        if s > 0 {
            sim.advance(p.sample_interval_s, &mut wind_rng);
        }
        let pose = sim.pose();
        let mut pts = scatterers(&p.plant, &plant, &pose);
        // per-sample stream: residual jitter and receiver noise
        let mut srng = rng_stream(seed, 2 + s as u64);
        if p.wind.residual_motion_m > 0.0 {
            for (_, r) in pts.iter_mut() {
                for c in r.iter_mut() {
                    *c += p.wind.residual_motion_m * normal(&mut srng);
                }
            }
        }
        pts.extend(plant.background.iter().cloned());
        let mut e = isar::point_response(&pts, m);
        if noise_sigma > 0.0 {
            for v in e.iter_mut() {
                *v += Complex64::new(
                    noise_sigma * normal(&mut srng),
                    noise_sigma * normal(&mut srng),
                );
            }
        }
        let img = isar::try_image(e.view(), m, opts)?;
        images.index_axis_mut(Axis(0), s).assign(&img);
        kdata.index_axis_mut(Axis(0), s).assign(&e);
    }
    Ok((kdata, images))
}

/// Simulates `n` samples of the scene: builds the plant geometry from
/// `seed` (fixed over samples), advances the wind state sequentially
/// (OU gusts + damped oscillators + leaf flutter; its own ChaCha stream),
/// and for each sample computes `E(f, phi)` with residual jitter and receiver
/// noise from that sample's own ChaCha stream, plus the static background
/// residual, then the image. Returns `(k-space [n, n_f, n_phi], images
/// [n, size, size])`. Bitwise independent of the rayon thread count.
///
/// # Panics
/// On invalid parameters (use [`try_simulate`] to get an error instead).
pub fn simulate(
    p: &SceneParams,
    m: &Measurement,
    opts: &ImagingOptions,
    n: usize,
    seed: u64,
) -> (Array3<Complex64>, Array3<Complex64>) {
    try_simulate(p, m, opts, n, seed).unwrap_or_else(|e| panic!("vegetation::simulate: {e}"))
}

/// Mean over pixels of the sample variance over the stack,
/// `mean_pixels( mean_s |I_s - mean_s I|^2 )`, of images `[n, size, size]`.
pub fn mean_pixel_variance(images: &Array3<Complex64>) -> f64 {
    let n = images.dim().0;
    if n < 2 {
        return 0.0;
    }
    let mean = images.mean_axis(Axis(0)).expect("n >= 1");
    let mut acc = 0.0;
    for s in 0..n {
        let d = &images.index_axis(Axis(0), s) - &mean;
        acc += d.iter().map(|v| v.norm_sqr()).sum::<f64>();
    }
    acc / (n as f64 * mean.len() as f64)
}

/// Mean image over the stack `[n, size, size]` -> `[size, size]`.
pub fn mean_image(images: &Array3<Complex64>) -> ndarray::Array2<Complex64> {
    images
        .mean_axis(Axis(0))
        .unwrap_or_else(|| ndarray::Array2::zeros((images.dim().1, images.dim().2)))
}

/// Excess kurtosis of the real and imaginary parts of the mean-removed pixel
/// values, each pixel standardised by its own std, pooled over pixels whose
/// variance exceeds `frac` of the largest pixel variance (0 for a Gaussian).
pub fn pixel_excess_kurtosis(images: &Array3<Complex64>, frac: f64) -> f64 {
    let (n, h, w) = images.dim();
    let mean = mean_image(images);
    let mut vars = vec![0.0; h * w];
    for r in 0..h {
        for c in 0..w {
            vars[r * w + c] = (0..n)
                .map(|s| (images[[s, r, c]] - mean[[r, c]]).norm_sqr())
                .sum::<f64>()
                / n as f64;
        }
    }
    let vmax = vars.iter().cloned().fold(0.0, f64::max);
    let (mut m4, mut cnt) = (0.0, 0.0);
    for r in 0..h {
        for c in 0..w {
            let v = vars[r * w + c];
            if v <= frac * vmax || v == 0.0 {
                continue;
            }
            let sd = (v / 2.0).sqrt(); // per real component
            for s in 0..n {
                let d = images[[s, r, c]] - mean[[r, c]];
                m4 += (d.re / sd).powi(4) + (d.im / sd).powi(4);
                cnt += 2.0;
            }
        }
    }
    if cnt == 0.0 {
        0.0
    } else {
        m4 / cnt - 3.0
    }
}

/// Bounding box `[x_min, x_max, y_min, y_max]` (m) of the plant's static
/// scatterers for `seed` (the footprint used by the structure test).
pub fn plant_footprint(p: &PlantParams, seed: u64) -> Result<[f64; 4], VegError> {
    p.validate()?;
    let mut geo_rng = rng_stream(seed, 0);
    let plant = build_plant(p, &mut geo_rng);
    let still = Pose {
        stem_d: vec![[0.0; 2]; p.n_stems],
        br_d: vec![[0.0; 2]; plant.n_branches],
        leaf: vec![[0.0; 4]; plant.leaves.len()],
    };
    let pts = scatterers(p, &plant, &still);
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for (_, r) in pts {
        b[0] = b[0].min(r[0]);
        b[1] = b[1].max(r[0]);
        b[2] = b[2].min(r[1]);
        b[3] = b[3].max(r[1]);
    }
    Ok(b)
}

#[cfg(test)]
mod tests;
