//! Physical stand-in for the ISAR plant-clutter measurements (SPEC-NOTES
//! section 7): a plant is a set of point scatterers moved by wind, imaged
//! with the chain of [`crate::isar`].
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

use crate::isar::{self, ImagingOptions, IsarError, Measurement};
use ndarray::{Array3, Axis};
use num_complex::Complex64;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

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

impl PlantParams {
    /// Presets "A".."E" (see SPEC-NOTES 7): A two large canes, very large
    /// leaves, wide spacing, large leaf motion; B medium leaves, smaller
    /// spacing and motion; C small dense leaves, little leaf motion, whole
    /// plant sways; D many small leaves on many small branches; E few large
    /// leaves on few large stalks. Sized to fit the 0.593 m default image.
    pub fn preset(name: &str) -> Option<PlantParams> {
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
            (
                "scatterer_spacing_m",
                pos(self.scatterer_spacing_m)
                    && self.stem_height_m / self.scatterer_spacing_m < 1e5,
            ),
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
        let n_leaves = self.n_stems * self.branches_per_stem * self.leaves_per_branch;
        if n_leaves > 1_000_000 {
            return Err(bad("leaves_per_branch", "too many leaves in total"));
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
    /// ("none", "light", "medium"), with -40 dB receiver noise, a -30 dB
    /// background residual and 2 s between samples.
    pub fn preset(plant: &str, wind: &str) -> Option<SceneParams> {
        Some(SceneParams {
            plant: PlantParams::preset(plant)?,
            wind: WindParams::preset(wind)?,
            noise_db: -40.0,
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

type V3 = [f64; 3];

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
fn unit(a: V3) -> V3 {
    scale(a, 1.0 / norm(a))
}
/// Rodrigues rotation of `v` about the unit axis `k` by `th`.
fn rotate(v: V3, k: V3, th: f64) -> V3 {
    let (s, c) = th.sin_cos();
    add(
        add(scale(v, c), scale(cross(k, v), s)),
        scale(k, dot(k, v) * (1.0 - c)),
    )
}

/// A structural point scatterer (stem or branch).
#[derive(Clone, Debug)]
struct StructPoint {
    pos: V3,
    amp: f64,
    stem: usize,
    /// height fraction along the stem of the point (or of the branch root)
    s: f64,
    /// branch index and fraction along it, if on a branch
    branch: Option<(usize, f64)>,
}

#[derive(Clone, Debug)]
struct Leaf {
    centre: V3,
    axis: V3,
    side: V3,
    normal: V3,
    area: f64,
    size: f64,
    /// in-plane offsets (along axis, along side) of the cluster points
    offsets: Vec<(f64, f64)>,
    stem: usize,
    s: f64,
    branch: usize,
    t: f64,
    /// nearest structural point for double bounce
    db_partner: Option<usize>,
}

/// Static plant geometry built from the seed.
#[derive(Clone, Debug)]
struct Plant {
    points: Vec<StructPoint>,
    leaves: Vec<Leaf>,
    n_branches: usize,
    background: Vec<(Complex64, V3)>,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

fn build_plant(p: &PlantParams, rng: &mut ChaCha8Rng) -> Plant {
    let tau = 2.0 * std::f64::consts::PI;
    let mut points = vec![];
    let mut leaves = vec![];
    let mut n_branches = 0;
    let z = [0.0, 0.0, 1.0];
    for st in 0..p.n_stems {
        let a0 = tau * st as f64 / p.n_stems as f64 + 0.3 * rng.random::<f64>();
        let base = [p.base_radius_m * a0.cos(), p.base_radius_m * a0.sin(), 0.0];
        let lean = p.stem_lean_rad * rng.random::<f64>();
        let lean_az = tau * rng.random::<f64>();
        let dir = [
            lean.sin() * lean_az.cos(),
            lean.sin() * lean_az.sin(),
            lean.cos(),
        ];
        let n_pts = (p.stem_height_m / p.scatterer_spacing_m).ceil().max(1.0) as usize;
        let step_sd = p.stem_crookedness_m / (n_pts as f64).sqrt();
        let mut wiggle = [0.0f64; 3];
        let mut wiggles = Vec::with_capacity(n_pts + 1);
        for i in 0..=n_pts {
            let s = i as f64 / n_pts as f64;
            if i > 0 {
                wiggle[0] += step_sd * normal(rng);
                wiggle[1] += step_sd * normal(rng);
            }
            wiggles.push(wiggle);
            points.push(StructPoint {
                pos: add(add(base, scale(dir, s * p.stem_height_m)), wiggle),
                amp: p.stem_amplitude,
                stem: st,
                s,
                branch: None,
            });
        }
        for b in 0..p.branches_per_stem {
            let s = p.branch_start_frac
                + (1.0 - p.branch_start_frac) * (b as f64 + rng.random::<f64>())
                    / p.branches_per_stem as f64;
            let wi = wiggles[((s * n_pts as f64).round() as usize).min(n_pts)];
            let root = add(add(base, scale(dir, s * p.stem_height_m)), wi);
            let az = tau * rng.random::<f64>();
            let el = p.branch_elevation_rad * (0.7 + 0.6 * rng.random::<f64>());
            let bdir = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
            let bi = n_branches;
            n_branches += 1;
            let nb = (p.branch_length_m / p.scatterer_spacing_m).ceil() as usize;
            for i in 1..=nb {
                let t = i as f64 / nb as f64;
                points.push(StructPoint {
                    pos: add(root, scale(bdir, t * p.branch_length_m)),
                    amp: p.branch_amplitude,
                    stem: st,
                    s,
                    branch: Some((bi, t)),
                });
            }
            for l in 0..p.leaves_per_branch {
                let dist = (p.branch_length_m - l as f64 * p.leaf_spacing_m).max(0.0);
                let t = if p.branch_length_m > 0.0 {
                    dist / p.branch_length_m
                } else {
                    0.0
                };
                let attach = add(root, scale(bdir, dist));
                let size = p.leaf_size_m * (p.leaf_size_spread * normal(rng)).exp();
                // leaf normal: tilted from vertical, random azimuth
                let tilt = p.leaf_max_tilt_rad * rng.random::<f64>();
                let naz = tau * rng.random::<f64>();
                let n = [tilt.sin() * naz.cos(), tilt.sin() * naz.sin(), tilt.cos()];
                // leaf axis: branch direction projected onto the leaf plane
                let mut ax = add(bdir, scale(n, -dot(bdir, n)));
                if norm(ax) < 1e-6 {
                    ax = cross(n, z);
                    if norm(ax) < 1e-6 {
                        ax = [1.0, 0.0, 0.0];
                    }
                }
                let ax = unit(ax);
                let side = cross(n, ax);
                let offsets = (0..p.leaf_points)
                    .map(|_| {
                        (
                            size * (rng.random::<f64>() - 0.5),
                            0.6 * size * (rng.random::<f64>() - 0.5),
                        )
                    })
                    .collect();
                leaves.push(Leaf {
                    centre: add(attach, scale(ax, 0.5 * size)),
                    axis: ax,
                    side,
                    normal: n,
                    area: 0.5 * size * size,
                    size,
                    offsets,
                    stem: st,
                    s,
                    branch: bi,
                    t,
                    db_partner: None,
                });
            }
        }
    }
    if p.double_bounce {
        for leaf in leaves.iter_mut() {
            let mut best: Option<(usize, f64)> = None;
            for (i, sp) in points.iter().enumerate() {
                let d = norm(add(sp.pos, scale(leaf.centre, -1.0)));
                if d < p.double_bounce_max_dist_m && best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((i, d));
                }
            }
            leaf.db_partner = best.map(|(i, _)| i);
        }
    }
    // background residual: 32 fixed random points (power scaled later)
    let background = (0..32)
        .map(|_| {
            let r = 0.25 * rng.random::<f64>().sqrt();
            let a = tau * rng.random::<f64>();
            let amp = Complex64::new(normal(rng), normal(rng));
            (amp, [r * a.cos(), r * a.sin(), 0.0])
        })
        .collect();
    Plant {
        points,
        leaves,
        n_branches,
        background,
    }
}

/// Dynamic wind state: gusts, stem and branch oscillators, leaf flutter.
struct WindState {
    g_shared: [f64; 2],
    g_stem: Vec<[f64; 2]>,
    stem_x: Vec<[f64; 2]>,
    stem_v: Vec<[f64; 2]>,
    br_x: Vec<[f64; 2]>,
    br_v: Vec<[f64; 2]>,
    /// per leaf: two angles (rad) and a 2-D translation (m)
    leaf: Vec<[f64; 4]>,
}

/// Positions/orientation deviations of one sample.
struct Pose {
    stem_d: Vec<[f64; 2]>,
    br_d: Vec<[f64; 2]>,
    leaf: Vec<[f64; 4]>,
}

struct WindSim<'a> {
    p: &'a PlantParams,
    w: &'a WindParams,
    st: WindState,
    leaf_sigma: Vec<[f64; 2]>,
    stem_of_branch: Vec<usize>,
}

impl<'a> WindSim<'a> {
    fn new(p: &'a PlantParams, w: &'a WindParams, plant: &Plant, rng: &mut ChaCha8Rng) -> Self {
        let ns = p.n_stems;
        let nb = plant.n_branches;
        let u = w.speed_mps;
        let leaf_sigma: Vec<[f64; 2]> = plant
            .leaves
            .iter()
            .map(|l| {
                let ang = (p.leaf_flutter_scale * u * l.size / 0.1).min(1.0);
                [ang, 0.3 * l.size * ang]
            })
            .collect();
        let mut stem_of_branch = vec![0; nb];
        for sp in &plant.points {
            if let Some((b, _)) = sp.branch {
                stem_of_branch[b] = sp.stem;
            }
        }
        for l in &plant.leaves {
            stem_of_branch[l.branch] = l.stem;
        }
        // leaf flutter starts in its stationary distribution
        let leaf = leaf_sigma
            .iter()
            .map(|s| {
                [
                    s[0] * normal(rng),
                    s[0] * normal(rng),
                    s[1] * normal(rng),
                    s[1] * normal(rng),
                ]
            })
            .collect();
        let sg = w.turbulence_intensity * u;
        let shared = w.gust_coherence.sqrt() * sg;
        let local = (1.0 - w.gust_coherence).sqrt() * sg;
        let mut s = WindSim {
            p,
            w,
            st: WindState {
                g_shared: [shared * normal(rng), 0.7 * shared * normal(rng)],
                g_stem: (0..ns)
                    .map(|_| [local * normal(rng), 0.7 * local * normal(rng)])
                    .collect(),
                stem_x: vec![[0.0; 2]; ns],
                stem_v: vec![[0.0; 2]; ns],
                br_x: vec![[0.0; 2]; nb],
                br_v: vec![[0.0; 2]; nb],
                leaf,
            },
            leaf_sigma,
            stem_of_branch,
        };
        // burn-in so the oscillators reach their stationary regime
        let t_osc = 1.0 / (p.sway_damping * 2.0 * std::f64::consts::PI * p.stem_sway_freq_hz);
        let burn = 5.0 * w.gust_time_constant_s.max(t_osc);
        s.advance(burn.min(600.0), rng);
        s
    }

    /// Advances the whole wind state by `dt_total` seconds.
    fn advance(&mut self, dt_total: f64, rng: &mut ChaCha8Rng) {
        let (p, w) = (self.p, self.w);
        let u = w.speed_mps;
        let tau = w.gust_time_constant_s;
        let sg = w.turbulence_intensity * u;
        let shared = w.gust_coherence.sqrt() * sg;
        let local = (1.0 - w.gust_coherence).sqrt() * sg;
        let f_max = p.stem_sway_freq_hz.max(p.branch_sway_freq_hz);
        let n_sub = ((dt_total * 40.0 * f_max).ceil() as usize).max(1);
        let dt = dt_total / n_sub as f64;
        let rho = (-dt / tau).exp();
        let q = (1.0 - rho * rho).sqrt();
        let ws = 2.0 * std::f64::consts::PI * p.stem_sway_freq_hz;
        let wb = 2.0 * std::f64::consts::PI * p.branch_sway_freq_hz;
        let (sd, cd) = w.direction_rad.sin_cos();
        let st = &mut self.st;
        for _ in 0..n_sub {
            st.g_shared[0] = rho * st.g_shared[0] + q * shared * normal(rng);
            st.g_shared[1] = rho * st.g_shared[1] + q * 0.7 * shared * normal(rng);
            for g in st.g_stem.iter_mut() {
                g[0] = rho * g[0] + q * local * normal(rng);
                g[1] = rho * g[1] + q * 0.7 * local * normal(rng);
            }
            // load in the xy frame from the along/cross-wind gusts
            let load = |g: [f64; 2], flex: f64| -> [f64; 2] {
                let a = w.deflection_gain * flex * u * 2.0 * g[0];
                let c = w.deflection_gain * flex * u * g[1];
                [a * cd - c * sd, a * sd + c * cd]
            };
            let step = |x: &mut [f64; 2], v: &mut [f64; 2], f: [f64; 2], om: f64| {
                for k in 0..2 {
                    let acc = om * om * (f[k] - x[k]) - 2.0 * p.sway_damping * om * v[k];
                    v[k] += dt * acc;
                    x[k] += dt * v[k];
                }
            };
            for i in 0..st.stem_x.len() {
                let g = [
                    st.g_shared[0] + st.g_stem[i][0],
                    st.g_shared[1] + st.g_stem[i][1],
                ];
                let f = load(g, p.stem_flexibility);
                step(&mut st.stem_x[i], &mut st.stem_v[i], f, ws);
            }
            for b in 0..st.br_x.len() {
                let i = self.stem_of_branch[b];
                let g = [
                    st.g_shared[0] + st.g_stem[i][0],
                    st.g_shared[1] + st.g_stem[i][1],
                ];
                let f = load(g, p.branch_flexibility);
                step(&mut st.br_x[b], &mut st.br_v[b], f, wb);
            }
        }
        // leaf flutter: exact OU transition over the whole interval
        let tl = 1.0 / (2.0 * std::f64::consts::PI * p.leaf_flutter_freq_hz);
        let r = (-dt_total / tl).exp();
        let qq = (1.0 - r * r).sqrt();
        for (l, s) in st.leaf.iter_mut().zip(&self.leaf_sigma) {
            for (k, v) in l.iter_mut().enumerate() {
                let sig = if k < 2 { s[0] } else { s[1] };
                *v = r * *v + qq * sig * normal(rng);
            }
        }
    }

    /// Current deviations (steady deflection included).
    fn pose(&self) -> Pose {
        let (p, w) = (self.p, self.w);
        let u2 = w.speed_mps * w.speed_mps;
        let (sd, cd) = w.direction_rad.sin_cos();
        let steady = |flex: f64| {
            let d = w.deflection_gain * flex * u2;
            [d * cd, d * sd]
        };
        let s0 = steady(p.stem_flexibility);
        let b0 = steady(p.branch_flexibility);
        Pose {
            stem_d: self
                .st
                .stem_x
                .iter()
                .map(|x| [s0[0] + x[0], s0[1] + x[1]])
                .collect(),
            br_d: self
                .st
                .br_x
                .iter()
                .map(|x| [b0[0] + x[0], b0[1] + x[1]])
                .collect(),
            leaf: self.st.leaf.clone(),
        }
    }
}

/// Scatterers of the plant in a given pose: `(amplitude, position)`.
fn scatterers(p: &PlantParams, plant: &Plant, pose: &Pose) -> Vec<(Complex64, V3)> {
    let disp = |stem: usize, s: f64, br: Option<(usize, f64)>| -> V3 {
        let d = pose.stem_d[stem];
        let mut v = [d[0] * s * s, d[1] * s * s, 0.0];
        if let Some((b, t)) = br {
            let e = pose.br_d[b];
            v[0] += e[0] * t * t;
            v[1] += e[1] * t * t;
        }
        v
    };
    let mut out = Vec::with_capacity(plant.points.len() + plant.leaves.len() * p.leaf_points);
    let struct_pos: Vec<V3> = plant
        .points
        .iter()
        .map(|sp| add(sp.pos, disp(sp.stem, sp.s, sp.branch)))
        .collect();
    for (sp, pos) in plant.points.iter().zip(&struct_pos) {
        if sp.amp != 0.0 {
            out.push((Complex64::new(sp.amp, 0.0), *pos));
        }
    }
    let rhat0 = [1.0, 0.0, 0.0];
    for (li, leaf) in plant.leaves.iter().enumerate() {
        let f = pose.leaf[li];
        // flutter: rotate about the leaf axis then about the side vector
        let n1 = rotate(leaf.normal, leaf.axis, f[0]);
        let side1 = rotate(leaf.side, leaf.axis, f[0]);
        let n2 = rotate(n1, side1, f[1]);
        let ax2 = rotate(leaf.axis, side1, f[1]);
        let centre = add(
            add(
                leaf.centre,
                disp(leaf.stem, leaf.s, Some((leaf.branch, leaf.t))),
            ),
            [f[2], f[3], 0.0],
        );
        let inc = dot(n2, rhat0).abs();
        let a_leaf =
            p.leaf_gain * leaf.area * (p.leaf_diffuse_floor + (1.0 - p.leaf_diffuse_floor) * inc);
        let a_pt = a_leaf / leaf.offsets.len() as f64;
        for &(da, ds) in &leaf.offsets {
            let pos = add(centre, add(scale(ax2, da), scale(side1, ds)));
            out.push((Complex64::new(a_pt, 0.0), pos));
        }
        if let Some(j) = leaf.db_partner {
            let r2 = struct_pos[j];
            let d = norm(add(centre, scale(r2, -1.0)));
            let mid = scale(add(centre, r2), 0.5);
            let amp = p.double_bounce_strength * (a_leaf * plant.points[j].amp).abs().sqrt();
            out.push((Complex64::new(amp, 0.0), add(mid, [0.5 * d, 0.0, 0.0])));
        }
    }
    out
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
    let mut kdata = Array3::<Complex64>::zeros((n, nf, np));
    let mut images = Array3::<Complex64>::zeros((n, sz, sz));
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
mod tests {
    use super::*;
    use crate::isar::Window;

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
}
