//! The stand-in plants calibrated to the dissertation's published statistics, committed in
//! `reproduction/plant_calibration.json` (compiled in), which [`super::PlantParams::preset`]
//! and [`super::SceneParams::preset`] apply to the physical presets.
//!
//! - `gain` multiplies every scatterer's amplitude (stems, branches, leaves; the double bounce,
//!   the receiver noise and the background follow, being set relative to the clutter power),
//!   so every image, and so the pixel variance, scales by `gain^2` exactly.
//! - `motion` multiplies the plant's response to wind (stem and branch flexibility and leaf
//!   flutter; for plant D leaf flutter alone, [`MotionScales`]),
//!   so the light-wind variance grows with it while the no-wind variance does not (without
//!   wind only the residual jitter moves the scatterers).
//! - `noise_db` (plants D and E) is the receiver noise relative to the static clutter power
//!   (the preset's -40 dB where the record has none).
//!
//! Plants A-C are fitted to Table 16 (mean pixel variance, no and light wind) by
//! [`fit_variance`]: `motion` by bisection in `ln motion` until the ratio light / none of the
//! simulated variances is the printed one, then `gain` from the no-wind variance. Plants D and
//! E, which Table 16 does not cover, are fitted to the similarity tables of their
//! measurements (Tables 29-36: the correlation matrix distance and the multiscale correlation
//! RMSE of the three generation methods, light and medium wind) by the reproduction's
//! `calibrate-plants` ([`SimilarityFit`]: `motion` and `noise_db`, gain 1, every fitted
//! statistic being scale-free). The CNN tables (20, 22) and Figs. 73-74 are never fitted: they
//! check how far the calibration carries over.

use super::params::{PlantParams, SceneParams, WindParams};
use crate::physics::isar::{ImagingOptions, Measurement};
use serde::{Deserialize, Serialize};

/// The seeds of a record that does not say: one.
fn one_seed() -> usize {
    1
}

/// The committed fit record.
pub const RECORD: &str = include_str!("../../../../../reproduction/plant_calibration.json");

/// One plant's fitted factors and what they achieve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlantFit {
    /// The preset ("A".."C").
    pub plant: String,
    /// Amplitude factor.
    pub gain: f64,
    /// Wind-response factor.
    pub motion: f64,
    /// The printed no-wind and light-wind variances (Table 16).
    pub target: [f64; 2],
    /// The simulated ones with the fitted factors (mean over the fit's seeds and samples).
    pub achieved: [f64; 2],
    /// Simulations the fit ran (each of `samples` images).
    pub evaluations: usize,
    /// Per seed of the fit (in [`fit_seeds`] order), the no-wind and light-wind variances with
    /// the fitted factors: `achieved` is their mean, and a check can simulate one seed instead
    /// of all (empty in records before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_seed: Vec<[f64; 2]>,
}

/// The whole record: how the fit ran and its result per plant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitRecord {
    /// What was fitted to.
    pub source: String,
    /// The command that regenerates the record.
    pub command: String,
    /// Seed of the simulations.
    pub seed: u64,
    /// Simulations averaged per evaluation of plants A-C (their seeds: [`fit_seeds`]);
    /// absent in records fitted at one seed.
    #[serde(default = "one_seed")]
    pub seeds: usize,
    /// Samples per simulation.
    pub samples: usize,
    /// Image size of the simulations.
    pub image_size: usize,
    /// Per plant A-C: the fit to Table 16.
    pub fits: Vec<PlantFit>,
    /// Per plant D-E: the fit to the similarity tables (absent in records written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub similarity: Vec<SimilarityFit>,
}

/// How one table's cells compare with the printed ones: the root mean square of the cells'
/// log residuals (see [`SimilarityFit`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableResidual {
    /// The dissertation's table.
    pub table: u32,
    /// Cells compared.
    pub cells: usize,
    /// With the physical preset (motion 1, noise -40 dB).
    pub before: f64,
    /// With the fitted factors.
    pub after: f64,
}

/// One plant's fit to the similarity tables of its measurements (D: Tables 29-32, E: 33-36).
/// The objective is the mean square over the tables' cells, both winds, of the log residual:
/// `ln(tool / printed)`, and for a correlation matrix distance printed above 1/2
/// `ln((1 - tool) / (1 - printed))` (its distance from 1, where it lies), minimised by
/// Nelder-Mead in `(ln motion, noise_db / 10)` with the same seed at every step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimilarityFit {
    /// The preset ("D", "E").
    pub plant: String,
    /// Wind-response factor.
    pub motion: f64,
    /// Receiver noise relative to the static clutter power (dB).
    pub noise_db: f64,
    /// The objective with the physical preset and with the fit.
    pub objective: [f64; 2],
    /// Per table fitted (and Tables 11-12, which summarise them), the residual.
    pub tables: Vec<TableResidual>,
    /// Runs of the similarity experiment the fit made.
    pub evaluations: usize,
    /// Samples each generation method drew per run.
    pub generated_samples: usize,
    /// Runs averaged per evaluation, from the record's seed ([`fit_seeds`]); records before
    /// it ran one.
    #[serde(default = "one_seed")]
    pub seeds: usize,
    /// What `motion` multiplies (absent: everything, as records before it).
    #[serde(default)]
    pub scales: MotionScales,
}

/// What the wind-response factor of a similarity fit multiplies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionScales {
    /// Stem and branch flexibility and leaf flutter ([`apply`]).
    #[default]
    All,
    /// Leaf flutter alone ([`apply_leaf_motion`]).
    Leaves,
}

impl MotionScales {
    /// The similarity fit's choice for `plant`: the leaves alone for plant D, whose stems swept
    /// over many pixels at the factor fitted with everything scaled (heavy-tailed medium-wind
    /// pixels where the measured plant's are not); everything for plant E, whose few large
    /// leaves did the same at the factor fitted with the leaves alone (docs/definitions.md
    /// section 10).
    pub fn for_plant(plant: &str) -> MotionScales {
        if plant == "D" {
            MotionScales::Leaves
        } else {
            MotionScales::All
        }
    }

    /// `p` with its wind response times `motion` as this says.
    pub fn apply(self, p: PlantParams, motion: f64) -> PlantParams {
        match self {
            MotionScales::All => apply(p, 1.0, motion),
            MotionScales::Leaves => apply_leaf_motion(p, motion),
        }
    }
}

/// The committed record, parsed once.
pub fn record() -> &'static FitRecord {
    static PARSED: std::sync::OnceLock<FitRecord> = std::sync::OnceLock::new();
    PARSED.get_or_init(|| {
        serde_json::from_str(RECORD).expect("reproduction/plant_calibration.json parses")
    })
}

/// The factors the presets use: `(gain, motion)` of `plant` from the committed record, `(1,
/// 1)` where it has none.
pub fn factors(plant: &str) -> (f64, f64) {
    let record = record();
    if let Some(f) = record.fits.iter().find(|f| f.plant == plant) {
        return (f.gain, f.motion);
    }
    record
        .similarity
        .iter()
        .find(|f| f.plant == plant)
        .map_or((1.0, 1.0), |f| (1.0, f.motion))
}

/// The receiver noise (dB relative to the static clutter power) the committed record fits for
/// `plant`, if any.
pub fn noise_db(plant: &str) -> Option<f64> {
    record()
        .similarity
        .iter()
        .find(|f| f.plant == plant)
        .map(|f| f.noise_db)
}

/// `p` with its amplitudes times `gain` and its wind response times `motion`.
pub fn apply(mut p: PlantParams, gain: f64, motion: f64) -> PlantParams {
    p.stem_amplitude *= gain;
    p.branch_amplitude *= gain;
    p.leaf_gain *= gain;
    p.stem_flexibility *= motion;
    p.branch_flexibility *= motion;
    p.leaf_flutter_scale *= motion;
    p
}

/// `p`, the physical preset of `plant`, with the committed record's factors: plants A-C
/// ([`FitRecord::fits`]) by [`apply`], plants D and E ([`FitRecord::similarity`]) as their
/// fit's [`MotionScales`] says, others unchanged.
pub fn calibrate(plant: &str, p: PlantParams) -> PlantParams {
    let record = record();
    if let Some(f) = record.fits.iter().find(|f| f.plant == plant) {
        return apply(p, f.gain, f.motion);
    }
    match record.similarity.iter().find(|f| f.plant == plant) {
        Some(f) => f.scales.apply(p, f.motion),
        None => p,
    }
}

/// `p` with its leaves' flutter times `motion`, stems and branches as designed
/// ([`MotionScales::Leaves`]).
pub fn apply_leaf_motion(mut p: PlantParams, motion: f64) -> PlantParams {
    p.leaf_flutter_scale *= motion;
    p
}

/// The seeds of a fit from `seed` with `count` simulations per evaluation: `seed` itself
/// first (so a one-seed fit is the fit of earlier records), then seeds derived from it.
pub fn fit_seeds(seed: u64, count: usize) -> Vec<u64> {
    (0..count)
        .map(|k| match k {
            0 => seed,
            k => crate::seeds::derive_seed(seed, "plant-calibration", &k.to_string()),
        })
        .collect()
}

/// The mean pixel variance of `samples` simulated images of `plant` under `wind`, with the
/// uncalibrated preset scaled by `(gain, motion)`, averaged over the simulations of `seeds`
/// (the fit's objective is the expectation over seeds, not one draw).
fn variance(
    plant: &str,
    wind: &str,
    factors: (f64, f64),
    at: (&Measurement, &ImagingOptions),
    samples: usize,
    seeds: &[u64],
) -> Result<f64, super::VegError> {
    let mut sum = 0.0;
    for &seed in seeds {
        sum += variance_at(plant, wind, factors, at, samples, seed)?;
    }
    Ok(sum / seeds.len().max(1) as f64)
}

/// [`variance`] of one simulation.
fn variance_at(
    plant: &str,
    wind: &str,
    (gain, motion): (f64, f64),
    (grid, opts): (&Measurement, &ImagingOptions),
    samples: usize,
    seed: u64,
) -> Result<f64, super::VegError> {
    let mut scene =
        SceneParams::preset(plant, wind).ok_or_else(|| super::VegError::InvalidParameter {
            name: "plant",
            reason: format!("no preset {plant:?}"),
        })?;
    scene.plant = apply(
        PlantParams::uncalibrated(plant).expect("preset exists"),
        gain,
        motion,
    );
    let (_, images) = super::try_simulate(&scene, grid, opts, samples, seed)?;
    Ok(super::mean_pixel_variance(&images))
}

/// Fits `(gain, motion)` of each `(plant, [none, light])` target: `motion` by bisection of
/// `ln motion` in `[ln 1/64, ln 64]` (40 halvings at most, stopping when the ratio is within
/// 0.1 % of its target), then `gain = sqrt(target_none / variance_none)`; every variance is
/// the mean over the simulations of `seeds` ([`fit_seeds`]), the same seeds at every step.
///
/// # Errors
/// If a simulation fails (an unknown plant).
pub fn fit_variance(
    targets: &[(String, [f64; 2])],
    (grid, opts): (&Measurement, &ImagingOptions),
    samples: usize,
    seeds: &[u64],
) -> Result<Vec<PlantFit>, super::VegError> {
    let mut fits = Vec::new();
    for (plant, [none, light]) in targets {
        let at = (grid, opts);
        let base_none = variance(plant, "none", (1.0, 1.0), at, samples, seeds)?;
        let want = light / none;
        let ratio = |m: f64| -> Result<f64, super::VegError> {
            Ok(variance(plant, "light", (1.0, m), at, samples, seeds)? / base_none)
        };
        let (mut lo, mut hi) = ((1.0f64 / 64.0).ln(), 64f64.ln());
        let mut evaluations = 1;
        let mut motion = 1.0;
        for _ in 0..40 {
            motion = (0.5 * (lo + hi)).exp();
            let r = ratio(motion)?;
            evaluations += 1;
            if (r / want - 1.0).abs() < 1e-3 {
                break;
            }
            if r < want {
                lo = motion.ln();
            } else {
                hi = motion.ln();
            }
        }
        let gain = (none / base_none).sqrt();
        let mut per_seed = Vec::with_capacity(seeds.len());
        for &seed in seeds {
            per_seed.push([
                variance_at(plant, "none", (gain, motion), at, samples, seed)?,
                variance_at(plant, "light", (gain, motion), at, samples, seed)?,
            ]);
        }
        // Summed in seed order and divided, as `variance` does.
        let mean = |w: usize| per_seed.iter().map(|v| v[w]).sum::<f64>() / seeds.len() as f64;
        let achieved = [mean(0), mean(1)];
        fits.push(PlantFit {
            plant: plant.clone(),
            gain,
            motion,
            target: [*none, *light],
            achieved,
            evaluations: (evaluations + 2) * seeds.len(),
            per_seed,
        });
    }
    Ok(fits)
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
        Some(calibrate(name, Self::uncalibrated(name)?))
    }
}

impl SceneParams {
    /// Scene from a plant preset ("A".."E") and a wind preset
    /// ("none", "light", "medium"), with -40 dB receiver noise (or the plant's calibrated
    /// noise, [`noise_db`]), a -30 dB background residual and 2 s between samples.
    pub fn preset(plant: &str, wind: &str) -> Option<SceneParams> {
        Some(SceneParams {
            plant: PlantParams::preset(plant)?,
            wind: WindParams::preset(wind)?,
            noise_db: noise_db(plant).unwrap_or(-40.0),
            background_residual: 1e-3,
            sample_interval_s: 2.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fit_starts_from_its_seed_and_derives_distinct_others() {
        assert_eq!(fit_seeds(16, 1), [16]);
        let five = fit_seeds(16, 5);
        assert_eq!(five[0], 16);
        assert_eq!(five[..3], fit_seeds(16, 3)[..]);
        let mut sorted = five.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), 5);
    }

    #[test]
    fn the_committed_record_parses_and_plants_without_a_fit_keep_factors_one() {
        let record = record();
        for f in &record.fits {
            assert!(f.gain > 0.0 && f.motion > 0.0, "{f:?}");
        }
        for f in &record.similarity {
            assert!(f.motion > 0.0 && f.noise_db.is_finite(), "{f:?}");
            assert_eq!(factors(&f.plant), (1.0, f.motion));
            assert_eq!(noise_db(&f.plant), Some(f.noise_db));
        }
        assert_eq!(factors("Z"), (1.0, 1.0));
        assert_eq!(noise_db("A"), None);
    }

    #[test]
    fn gain_scales_amplitudes_and_motion_the_wind_response() {
        let p = PlantParams::uncalibrated("A").unwrap();
        let q = apply(p.clone(), 2.0, 3.0);
        assert_eq!(q.stem_amplitude, 2.0 * p.stem_amplitude);
        assert_eq!(q.leaf_gain, 2.0 * p.leaf_gain);
        assert_eq!(q.leaf_flutter_scale, 3.0 * p.leaf_flutter_scale);
        assert_eq!(q.stem_flexibility, 3.0 * p.stem_flexibility);
        assert_eq!(q.leaf_size_m, p.leaf_size_m);
        let r = apply_leaf_motion(p.clone(), 3.0);
        assert_eq!(r.leaf_flutter_scale, 3.0 * p.leaf_flutter_scale);
        assert_eq!(r.stem_flexibility, p.stem_flexibility);
        assert_eq!(r.branch_flexibility, p.branch_flexibility);
    }
}
