//! The parameters of the vegetation model and their checks: a plant's geometry, amplitudes
//! and wind response ([`PlantParams`], with the physical presets A-E before calibration), the
//! wind ([`WindParams`]) and the scene ([`SceneParams`]); the calibrated presets are in
//! [`super::calibration`].

use crate::physics::isar::IsarError;

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

pub(super) fn bad(name: &'static str, reason: &str) -> VegError {
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
