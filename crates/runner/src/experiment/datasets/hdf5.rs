//! The `hdf5` dataset kind: a stack in an HDF5 file (h5py's files; NISAR, ICEYE or OPERA
//! products), one dataset at a path in the file: complex compounds, real numbers (with the
//! imaginary parts in `imag`, or none) or float pairs, `[N, H, W]` or `[H, W, N]` with
//! `layout: hwn`; checked at validation (the dataset, its element type and shape), read a
//! sample at a time by the core's `io::h5stack` (a build with the `mat73` feature, which links
//! libhdf5). A single scene `[H, W]` (a NISAR RSLC or OPERA CSLC frame) is cut into patches
//! (`cut`, inside `window`), each patch a sample, read a band of patch rows at a time, and may
//! be calibrated with the product's own scale factors (`calibration: sigma0`): NISAR's
//! calibration tables (beta0, sigma0, gamma0), or ICEYE's `calibration_factor` (beta0).

use super::cost::{file_sizes, Cost, Sizes, C64};
use super::kind::{DataError, DatasetKind, Layout, Materialised};
use super::scenes::{CutScenes, CutSpec, SceneWindow};
use crate::experiment::context::{Ctx, SpecError};
use crate::io::h5stack::{H5Scene, H5Stack, Storage};
use crate::io::npy::NpyError;
use crate::io::scenes::Scenes;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of an `hdf5` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Path of the file, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// The stack's dataset in the file (`/science/LSAR/SLC/HH`, or a top-level name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
    /// The dataset of the imaginary parts, for a real `dataset`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imag: Option<String>,
    /// Axis order (`nhw` default, `hwn`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
    /// For a single scene `[H, W]`: where patches may lie (default: the whole scene).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<SceneWindow>,
    /// For a single scene `[H, W]`: how it is cut into patches, each patch a sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cut: Option<CutSpec>,
    /// For a single scene: calibrate its values so that `|value|^2` is this quantity, with
    /// NISAR's calibration tables (`beta0`, `sigma0`, `gamma0`) or ICEYE's
    /// `calibration_factor` (`beta0`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<String>,
}

/// A validated `hdf5` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct Hdf5Dataset {
    /// The stack, checked.
    pub stack: H5Stack,
    /// A single scene, its window and the patches cut from it (`None`: a stack).
    pub scene: Option<CutScenes<H5Scene>>,
}

impl DatasetKind for Hdf5Dataset {
    const NAME: &'static str = "hdf5";
    const FIELDS: &'static [&'static str] = &[
        "path",
        "dataset",
        "imag",
        "layout",
        "window",
        "cut",
        "calibration",
    ];
    const SAMPLES_FIELD: &'static str = "dataset";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let need = |key: &str, what: &str| {
            ctx.err(
                format!("{at}.{key}"),
                format!("kind hdf5 needs `{key}` ({what})"),
            )
        };
        let rel = spec.path.as_ref().ok_or_else(|| need("path", "the file"))?;
        let dataset = spec
            .dataset
            .as_deref()
            .ok_or_else(|| need("dataset", "the stack's path in the file"))?;
        let hwn = spec.layout.unwrap_or_default() == Layout::Hwn;
        let path = ctx.resolve(rel);
        let stack = H5Stack::open(&path, dataset, spec.imag.as_deref(), hwn)
            .map_err(|(field, message)| ctx.err(format!("{at}.{field}"), message))?;
        let scene = match (&spec.cut, stack.scene) {
            (Some(cut), true) => {
                let window = match &spec.window {
                    Some(w) => Some(w.place().map_err(|m| ctx.err(format!("{at}.window"), m))?),
                    None => None,
                };
                let mut scenes = Scenes::new(vec![H5Scene::new(stack.clone())], window)
                    .map_err(|e| ctx.err(format!("{at}.{}", e.field), e.message))?;
                if let Some(q) = &spec.calibration {
                    scenes
                        .calibrate(q)
                        .map_err(|m| ctx.err(format!("{at}.calibration"), m))?;
                }
                Some(CutScenes::new(
                    scenes,
                    Some(cut),
                    ctx,
                    &format!("{at}.cut"),
                )?)
            }
            (None, true) => {
                return Err(ctx.err(
                    format!("{at}.dataset"),
                    format!(
                        "{dataset:?} in {} is a single scene {:?}: give `cut` ({{patch: 64}}, \
                         ...) to cut it into a stack of patches",
                        path.display(),
                        [stack.dims[1], stack.dims[2]]
                    ),
                ))
            }
            (_, false)
                if spec.cut.is_some() || spec.window.is_some() || spec.calibration.is_some() =>
            {
                let key = if spec.cut.is_some() {
                    "cut"
                } else if spec.window.is_some() {
                    "window"
                } else {
                    "calibration"
                };
                return Err(ctx.err(
                    format!("{at}.{key}"),
                    format!("`{key}` applies to a single scene [H, W]; {dataset:?} is a stack"),
                ));
            }
            (_, false) => None,
        };
        Ok(Hdf5Dataset { stack, scene })
    }

    fn shape(&self) -> (usize, usize, usize) {
        match &self.scene {
            Some(scene) => scene.shape(),
            None => self.stack.shape(),
        }
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![self.stack.path.clone()]
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        file_sizes(at, self.shape(), s);
    }

    fn cost(&self) -> Cost {
        let (n, h, w) = self.shape();
        let np = n as f64 * h as f64 * w as f64;
        if self.scene.is_some() {
            // The complex64 patches and a band of patch rows of the scene.
            return Cost {
                peak: C64 * np,
                kept: C64 * np,
                flops: 2.0 * np,
                ..Cost::default()
            };
        }
        // The stack as read (nothing where the file is mapped) and one block of samples as
        // libhdf5 hands it over; a mapped stack's complex128 copy widens from the file.
        let kept = self.stack.loaded_bytes();
        Cost {
            peak: kept
                + if kept > 0.0 {
                    (32u64 << 20) as f64
                } else {
                    0.0
                },
            kept,
            flops: 2.0 * np,
            widen: match self.stack.storage {
                Storage::Mapped { dtype, .. } => dtype.size() as f64 * np,
                _ => 0.0,
            },
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, _: usize) -> Cost {
        Cost::default()
    }

    fn materialise(&self, _: u64) -> Result<Materialised, DataError> {
        let error = |reason| NpyError::Data {
            path: self.stack.path.clone(),
            reason,
        };
        if let Some(scene) = &self.scene {
            return scene.materialise("the hdf5 patches", |e| error(e).into());
        }
        let stack = self.stack.load().map_err(error)?;
        Ok(Materialised::plain(stack, self.stack.loaded_hwn()))
    }

    fn metadata(&self) -> Option<serde_json::Value> {
        self.scene.as_ref().map(CutScenes::metadata)
    }

    fn redraw(
        &self,
        _: usize,
        _: u64,
        _: &Materialised,
    ) -> Option<Result<ndarray::Array3<num_complex::Complex64>, DataError>> {
        None
    }
}
