//! The `vegetation_isar` dataset kind: simulated ISAR images of a wind-blown plant (the
//! physical forward model of `crate::physics::vegetation`), a plant and wind preset with the
//! spec's overrides, measured on a stepped-frequency turntable grid, optionally through a
//! simulated measurement chain calibrated with a sphere; its analysis jobs write the mean
//! k-space image, and the simulated k-space data with `save_kspace`.

use super::cost::{
    chain_sizes, imaging_flops, mie, plant, scene_sizes, Cost, Sizes, C128, C64, USUAL_GRID,
    USUAL_IMAGE_SIZE, USUAL_SAMPLES,
};
use super::kind::{DataError, DatasetKind, Materialised, SavedKspace};
use crate::alloc::try_zeros;
use crate::experiment::context::{merge, Ctx, SpecError};
use crate::io::npy::{NpyError, Stack};
use ndarray::Array3;
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of a `vegetation_isar` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Plant preset `A`..`E`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plant: Option<String>,
    /// Wind preset `none`, `light` or `medium`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wind: Option<String>,
    /// Number of samples `N`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Overrides of the preset's scene parameters (`plant`, `wind`, `noise_db`,
    /// `background_residual`, `sample_interval_s`), merged key by key.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<serde_yaml_ng::Value>,
    /// The stepped-frequency measurement (default 2-18 GHz x 51 degrees, 256 x 256 points).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measurement: Option<MeasurementSpec>,
    /// Image size in pixels (default 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image_size: Option<usize>,
    /// Write the simulated k-space data to `kspace/<job>.npy` (with `kspace/<job>.freqs.npy`
    /// in Hz and `kspace/<job>.azimuths_deg.npy`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub save_kspace: Option<bool>,
    /// Pass the simulated k-space data through a simulated measurement chain (system
    /// response, chamber clutter, background subtraction, noise) and calibrate them with a
    /// sphere (`a(f)`), as real measurements are; the chain's `f_start`, `f_stop` and `points`
    /// replace the measurement's frequencies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<crate::physics::calibration::ChainParams>,
}

/// `measurement:` of a `vegetation_isar` dataset: a uniform stepped-frequency, turntable
/// azimuth grid.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MeasurementSpec {
    /// First frequency (Hz).
    #[serde(default = "f_start")]
    pub f_start: f64,
    /// Last frequency (Hz).
    #[serde(default = "f_stop")]
    pub f_stop: f64,
    /// Frequency points.
    #[serde(default = "grid_points")]
    pub frequencies: usize,
    /// Azimuth span (degrees, centred on 0).
    #[serde(default = "span")]
    pub azimuth_span_deg: f64,
    /// Azimuth points.
    #[serde(default = "grid_points")]
    pub azimuths: usize,
}

pub(super) fn f_start() -> f64 {
    2e9
}
pub(super) fn f_stop() -> f64 {
    18e9
}
fn grid_points() -> usize {
    256
}
fn span() -> f64 {
    51.0
}

impl Default for MeasurementSpec {
    fn default() -> Self {
        MeasurementSpec {
            f_start: f_start(),
            f_stop: f_stop(),
            frequencies: grid_points(),
            azimuth_span_deg: span(),
            azimuths: grid_points(),
        }
    }
}

impl MeasurementSpec {
    /// The measurement grid.
    ///
    /// # Errors
    /// The imaging chain's error naming the bad parameter.
    pub fn grid(
        &self,
    ) -> Result<crate::physics::isar::Measurement, crate::physics::isar::IsarError> {
        crate::physics::isar::Measurement::uniform(
            self.f_start,
            self.f_stop,
            self.frequencies,
            self.azimuth_span_deg.to_radians(),
            self.azimuths,
        )
    }

    /// Checks the grid's parameters without building it: its size is the job's to estimate
    /// (a grid of 10^12 points is refused by the estimate, not allocated by the check).
    ///
    /// # Errors
    /// The imaging chain's error naming the bad parameter.
    pub fn check(&self) -> Result<(), crate::physics::isar::IsarError> {
        // Four points of each axis meet every rule a larger grid meets.
        crate::physics::isar::Measurement::uniform(
            self.f_start,
            self.f_stop,
            self.frequencies.min(4),
            self.azimuth_span_deg.to_radians(),
            self.azimuths.min(4),
        )
        .map(|_| ())
    }
}

/// A validated `vegetation_isar` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct VegetationDataset {
    /// Plant preset name.
    pub plant: String,
    /// Wind preset name.
    pub wind: String,
    /// The scene: the presets with the spec's overrides.
    pub scene: crate::physics::vegetation::SceneParams,
    /// The measurement.
    pub measurement: MeasurementSpec,
    /// Image size.
    pub image_size: usize,
    /// Samples.
    pub samples: usize,
    /// Write the simulated k-space data to `kspace/<job>.npy`.
    pub save_kspace: bool,
    /// The measurement chain and calibration applied to the k-space data.
    pub calibration: Option<crate::physics::calibration::ChainParams>,
}

impl DatasetKind for VegetationDataset {
    const NAME: &'static str = "vegetation_isar";
    const FIELDS: &'static [&'static str] = &[
        "plant",
        "wind",
        "samples",
        "scene",
        "measurement",
        "image_size",
        "save_kspace",
        "calibration",
    ];
    const SAMPLES_FIELD: &'static str = "samples";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        use crate::physics::vegetation::SceneParams;
        let plant = spec.plant.clone().ok_or_else(|| {
            ctx.err(
                format!("{at}.plant"),
                "kind vegetation_isar needs `plant` (A, B, C, D or E)",
            )
        })?;
        let wind = spec.wind.clone().unwrap_or_else(|| "none".into());
        let preset = SceneParams::preset(&plant, &wind).ok_or_else(|| {
            let (field, what) = if crate::physics::vegetation::PlantParams::preset(&plant).is_none()
            {
                (
                    "plant",
                    format!("unknown plant {plant:?}; presets: A, B, C, D, E"),
                )
            } else {
                (
                    "wind",
                    format!("unknown wind {wind:?}; presets: none, light, medium"),
                )
            };
            ctx.err(format!("{at}.{field}"), what)
        })?;
        let scene = match &spec.scene {
            None => preset,
            Some(over) => {
                let mut base = serde_yaml_ng::to_value(&preset).expect("scene serialises");
                merge(&mut base, over);
                let s: SceneParams = serde_path_to_error::deserialize(base).map_err(|e| {
                    let path = e.path().to_string();
                    let at = match path.as_str() {
                        "." => format!("{at}.scene"),
                        p => format!("{at}.scene.{p}"),
                    };
                    ctx.err(at, e.inner().to_string())
                })?;
                s
            }
        };
        // Each parameter's error at its own path (`scene.plant.n_stems`).
        let located = |part: &str, e: crate::physics::vegetation::VegError| match e {
            crate::physics::vegetation::VegError::InvalidParameter { name, .. } => {
                ctx.err(format!("{at}.scene.{part}{name}"), e.to_string())
            }
            _ => ctx.err(format!("{at}.scene"), e.to_string()),
        };
        scene.plant.validate().map_err(|e| located("plant.", e))?;
        scene.wind.validate().map_err(|e| located("wind.", e))?;
        scene.validate().map_err(|e| located("", e))?;
        let mut measurement = spec.measurement.clone().unwrap_or_default();
        if let Some(c) = &spec.calibration {
            c.check()
                .map_err(|(field, msg)| ctx.err(format!("{at}.calibration.{field}"), msg))?;
            measurement.f_start = c.f_start;
            measurement.f_stop = c.f_stop;
            measurement.frequencies = c.points;
        }
        measurement
            .check()
            .map_err(|e| ctx.err(format!("{at}.measurement"), e.to_string()))?;
        let samples = spec.samples.ok_or_else(|| {
            ctx.err(
                format!("{at}.samples"),
                "kind vegetation_isar needs `samples`",
            )
        })?;
        let image_size = spec.image_size.unwrap_or(64);
        if image_size < 2 {
            return Err(ctx.err(format!("{at}.image_size"), "image_size must be at least 2"));
        }
        Ok(VegetationDataset {
            plant,
            wind,
            scene,
            measurement,
            image_size,
            samples,
            save_kspace: spec.save_kspace.unwrap_or(false),
            calibration: spec.calibration.clone(),
        })
    }

    fn shape(&self) -> (usize, usize, usize) {
        (self.samples, self.image_size, self.image_size)
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![]
    }

    fn redrawable(&self) -> Option<bool> {
        Some(false)
    }

    fn kspace_grid(&self) -> Option<(usize, usize)> {
        Some((self.measurement.frequencies, self.measurement.azimuths))
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        let n = self.samples;
        s.add(format!("{at}.samples"), n, n as f64 / USUAL_SAMPLES);
        let side = self.image_size;
        s.add(
            format!("{at}.image_size"),
            side,
            side as f64 / USUAL_IMAGE_SIZE,
        );
        let m = &self.measurement;
        match &self.calibration {
            Some(c) => chain_sizes(&format!("{at}.calibration"), c, s),
            None => s.add(
                format!("{at}.measurement.frequencies"),
                m.frequencies,
                m.frequencies as f64 / USUAL_GRID,
            ),
        }
        s.add(
            format!("{at}.measurement.azimuths"),
            m.azimuths,
            m.azimuths as f64 / USUAL_GRID,
        );
        scene_sizes(&format!("{at}.scene"), &self.scene, s);
    }

    fn cost(&self) -> Cost {
        let n = self.samples as f64;
        let azimuths = self.measurement.azimuths as f64;
        let k = self.measurement.frequencies as f64 * azimuths;
        let s2 = self.image_size as f64 * self.image_size as f64;
        let both = C128 * n * (k + s2);
        let kept = C128 * n * s2 + if self.save_kspace { C128 * n * k } else { 0.0 };
        let plant = plant(&self.scene, n, azimuths);
        // With a chain: its factor a(f) (two Mie series), then every azimuth of every sample
        // measured through the chain's clutter.
        let (chain, chain_bytes, chain_flops) = match &self.calibration {
            Some(c) => {
                let (bytes, flops) = mie(c, 2.0);
                let clutter = 30.0 * c.clutter.len() as f64 + 60.0;
                (2.0, bytes, flops + n * k * clutter)
            }
            None => (1.0, 0.0, 0.0),
        };
        Cost {
            peak: chain * both + plant.bytes + chain_bytes,
            kept,
            widen: 0.0,
            flops: n * (8.0 * plant.scatterers * k + imaging_flops(k, s2))
                + plant.flops
                + chain_flops,
            // The k-space copy a job keeps to save it.
            saved_kspace: if self.save_kspace { C64 * n * k } else { 0.0 },
        }
    }

    fn redraw_cost(&self, samples: usize) -> Cost {
        let d = self.redrawn(samples).cost();
        let p = self.image_size as f64 * self.image_size as f64;
        Cost {
            peak: d.peak.max(2.0 * C128 * samples as f64 * p),
            ..d
        }
    }

    fn materialise(&self, data_seed: u64) -> Result<Materialised, DataError> {
        let v = self;
        let opts = crate::physics::isar::ImagingOptions {
            size: v.image_size,
            ..Default::default()
        };
        let grid = v.measurement.grid().map_err(|e| NpyError::Data {
            path: "vegetation_isar".into(),
            reason: e.to_string(),
        })?;
        let (mut kspace, mut images) =
            crate::physics::vegetation::try_simulate(&v.scene, &grid, &opts, v.samples, data_seed)
                .map_err(|e| NpyError::Data {
                    path: "vegetation_isar".into(),
                    reason: e.to_string(),
                })?;
        if let Some(chain) = &v.calibration {
            (kspace, images) = calibrated(chain, &kspace, &grid, &opts, data_seed)?;
        }
        Ok(Materialised {
            mean_kspace: kspace.mean_axis(ndarray::Axis(0)),
            kspace: v.save_kspace.then(|| SavedKspace {
                data: kspace,
                azimuths_deg: grid.azimuths.iter().map(|a| a.to_degrees()).collect(),
                freqs: grid.freqs,
            }),
            ..Materialised::plain(Stack::Generated(images), false)
        })
    }

    fn redraw(
        &self,
        samples: usize,
        seed: u64,
        _: &Materialised,
    ) -> Option<Result<Array3<Complex64>, DataError>> {
        // An independent simulation of the same scene: new seed, no k-space kept.
        Some(
            self.redrawn(samples)
                .materialise(seed)
                .and_then(|m| Ok(m.stack.try_to_complex128(false)?)),
        )
    }
}

impl VegetationDataset {
    /// The same scene with `samples` samples and no k-space kept (a noise floor's draw).
    fn redrawn(&self, samples: usize) -> VegetationDataset {
        VegetationDataset {
            samples,
            save_kspace: false,
            ..self.clone()
        }
    }
}

/// Measures simulated k-space data through the calibration chain and calibrates them (one
/// measurement per sample and azimuth, each with its own noise stream), then images them.
fn calibrated(
    chain: &crate::physics::calibration::ChainParams,
    kspace: &Array3<Complex64>,
    grid: &crate::physics::isar::Measurement,
    opts: &crate::physics::isar::ImagingOptions,
    data_seed: u64,
) -> Result<(Array3<Complex64>, Array3<Complex64>), DataError> {
    use crate::physics::calibration::{factor, measure_and_calibrate};
    let seed = crate::seeds::derive_seed(data_seed, "calibration", "");
    let a = factor(chain, seed);
    let (n, nf, nphi) = kspace.dim();
    let mut out = try_zeros((n, nf, nphi), "the calibrated k-space data")?;
    out.as_slice_mut()
        .expect("standard layout")
        .par_chunks_mut(nf * nphi)
        .enumerate()
        .for_each(|(s, plane)| {
            for j in 0..nphi {
                let e: Vec<Complex64> = (0..nf).map(|i| kspace[[s, i, j]]).collect();
                // Streams 0-3 are the sphere's; each (sample, azimuth) measurement gets its own.
                let stream = 4 + (s * nphi + j) as u64;
                let c = measure_and_calibrate(chain, &e, &a, seed, stream);
                for i in 0..nf {
                    plane[i * nphi + j] = c[i];
                }
            }
        });
    let mut images = try_zeros((n, opts.size, opts.size), "the calibrated images")?;
    for s in 0..n {
        let img = crate::physics::isar::try_image(out.index_axis(ndarray::Axis(0), s), grid, opts)
            .map_err(|e| NpyError::Data {
                path: "vegetation_isar".into(),
                reason: e.to_string(),
            })?;
        images.index_axis_mut(ndarray::Axis(0), s).assign(&img);
    }
    Ok((out, images))
}
