//! The `kspace` dataset kind: measured k-space data `E(f, phi)`, an `[N, n_f, n_phi]` `.npy`
//! stack with its frequencies (Hz) and azimuths (degrees) given as lists or 1-D `.npy` files,
//! imaged by the ISAR chain into `image_size` squared images; its analysis jobs also write
//! the mean k-space image.

use super::cost::{imaging_flops, Cost, Sizes, C128, USUAL_GRID, USUAL_IMAGE_SIZE, USUAL_SAMPLES};
use super::kind::{DataError, DatasetKind, Materialised};
use crate::alloc::try_zeros;
use crate::experiment::context::{Ctx, SpecError};
use crate::io::npy::{self, NpyError, NpyHeader, Stack};
use ndarray::Array3;
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of a `kspace` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Path of the `[N, n_f, n_phi]` `.npy`, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// Frequencies in Hz (a list, or a 1-D `.npy`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub freqs: Option<Vector>,
    /// Azimuths in degrees (a list, or a 1-D `.npy`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub azimuths_deg: Option<Vector>,
    /// Image size in pixels (default 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image_size: Option<usize>,
}

/// A vector of numbers: a list in the spec, or a 1-D `.npy` file.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Vector {
    /// Values written in the spec.
    List(Vec<f64>),
    /// A 1-D `.npy` of real values, relative to the spec file.
    File(PathBuf),
}

/// A validated `kspace` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct KspaceDataset {
    /// The `[N, n_f, n_phi]` stack of `E(f, phi)`.
    pub path: PathBuf,
    /// Its header.
    pub header: NpyHeader,
    /// The measurement grid (frequencies in Hz, azimuths in radians).
    pub measurement: crate::physics::isar::Measurement,
    /// Image size.
    pub image_size: usize,
    /// Samples `N`.
    pub samples: usize,
}

impl DatasetKind for KspaceDataset {
    const NAME: &'static str = "kspace";
    const FIELDS: &'static [&'static str] = &["path", "freqs", "azimuths_deg", "image_size"];
    const SAMPLES_FIELD: &'static str = "path";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let rel = spec
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind kspace needs `path`"))?;
        let path = ctx.resolve(rel);
        let header =
            npy::read_header(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let [n, nf, nphi] = header.shape[..] else {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} has shape {:?}; k-space data are [N, n_f, n_phi]",
                    path.display(),
                    header.shape
                ),
            ));
        };
        let vector = |v: &Option<Vector>, name: &str, len: usize| -> Result<Vec<f64>, SpecError> {
            let at = format!("{at}.{name}");
            let values = match v {
                None => return Err(ctx.err(&at, format!("kind kspace needs `{name}`"))),
                Some(Vector::List(l)) => l.clone(),
                Some(Vector::File(f)) => {
                    // Names the file, and the shape where it is not 1-D.
                    let f = ctx.resolve(f);
                    let m = npy::read_real_vector(&f).map_err(|e| ctx.err(&at, e.to_string()))?;
                    m.iter().copied().collect()
                }
            };
            if values.len() != len {
                return Err(ctx.err(
                    &at,
                    format!(
                        "{} values; the data have {len} along this axis",
                        values.len()
                    ),
                ));
            }
            Ok(values)
        };
        let freqs = vector(&spec.freqs, "freqs", nf)?;
        let azimuths = vector(&spec.azimuths_deg, "azimuths_deg", nphi)?
            .iter()
            .map(|d| d.to_radians())
            .collect();
        let measurement = crate::physics::isar::Measurement { freqs, azimuths };
        measurement.validate().map_err(|e| {
            let field = match &e {
                crate::physics::isar::IsarError::InvalidParameter {
                    name: "azimuths", ..
                } => "azimuths_deg",
                _ => "freqs",
            };
            ctx.err(format!("{at}.{field}"), e.to_string())
        })?;
        let image_size = spec.image_size.unwrap_or(64);
        if image_size < 2 {
            return Err(ctx.err(format!("{at}.image_size"), "image_size must be at least 2"));
        }
        Ok(KspaceDataset {
            path,
            header,
            measurement,
            image_size,
            samples: n,
        })
    }

    fn shape(&self) -> (usize, usize, usize) {
        (self.samples, self.image_size, self.image_size)
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![self.path.clone()]
    }

    fn kspace_grid(&self) -> Option<(usize, usize)> {
        Some((
            self.measurement.freqs.len(),
            self.measurement.azimuths.len(),
        ))
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        let file: f64 = self.header.shape.iter().map(|&v| v as f64).product();
        let shape = format!("a {:?} k-space stack", self.header.shape);
        s.add(
            format!("{at}.path"),
            shape,
            file / (USUAL_SAMPLES * USUAL_GRID * USUAL_GRID),
        );
        let side = self.image_size;
        s.add(
            format!("{at}.image_size"),
            side,
            side as f64 / USUAL_IMAGE_SIZE,
        );
    }

    fn cost(&self) -> Cost {
        let n = self.samples as f64;
        let file: f64 = self.header.shape.iter().map(|&s| s as f64).product();
        let elem = self.header.dtype.size() as f64;
        let k = self.measurement.n_f() as f64 * self.measurement.n_phi() as f64;
        let s2 = self.image_size as f64 * self.image_size as f64;
        let widen = (elem + C128) * file;
        Cost {
            peak: widen.max(C128 * file + 2.0 * C128 * n * s2),
            kept: C128 * n * s2,
            flops: n * imaging_flops(k, s2),
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, _: usize) -> Cost {
        Cost::default()
    }

    fn materialise(&self, _: u64) -> Result<Materialised, DataError> {
        let k = self;
        let e = Stack::load(&k.path)?.to_complex128(false);
        let opts = crate::physics::isar::ImagingOptions {
            size: k.image_size,
            ..Default::default()
        };
        let planes: Vec<Result<ndarray::Array2<Complex64>, String>> = (0..k.samples)
            .into_par_iter()
            .map(|s| {
                crate::physics::isar::try_image(
                    e.index_axis(ndarray::Axis(0), s),
                    &k.measurement,
                    &opts,
                )
                .map_err(|e| e.to_string())
            })
            .collect();
        let mut images = try_zeros(
            (k.samples, k.image_size, k.image_size),
            "the images of the k-space data",
        )?;
        for (s, p) in planes.into_iter().enumerate() {
            let p = p.map_err(|reason| NpyError::Data {
                path: k.path.clone(),
                reason,
            })?;
            images.index_axis_mut(ndarray::Axis(0), s).assign(&p);
        }
        Ok(Materialised {
            mean_kspace: e
                .slice(ndarray::s![..k.samples, .., ..])
                .mean_axis(ndarray::Axis(0)),
            ..Materialised::plain(Stack::Generated(images), false)
        })
    }

    fn redraw(
        &self,
        _: usize,
        _: u64,
        _: &Materialised,
    ) -> Option<Result<Array3<Complex64>, DataError>> {
        None
    }
}
