//! Model files and streamed generation: a fitted [`Model`] saved as a self-describing folder
//! (`model.json` plus `.npy` arrays that numpy reads directly), loaded back, and used to write
//! any number of samples to a `[M, H, W]` complex64 `.npy` in constant memory.
//!
//! Folder layout (format `isar-clutter-model/1`): `model.json` (format, method, image size,
//! half-width, dyadic levels, samples fitted, unreachable-target counts, provenance and the
//! fitted data's multiscale summary), `mean.npy` (complex128 `[H, W]`), `std.npy` (float64
//! `[H, W]`); Method 1: `alpha_h.npy`, `alpha_v.npy` (float64, level-1 cell grid); Method 2:
//! `r_h.npy`, `r_v.npy` (float64 `[L, rows, cols]`); Methods 1 and 2: `residual_h.npy`,
//! `residual_v.npy`, `clamped.npy` (uint8); full covariance: `deviations.npy` (complex128
//! `[N, H, W]`, the centred samples divided by `sqrt(N)`); fourth order: `fleishman.npy`
//! (float64 `[2, 4, H, W]`: component re/im, coefficients a, b, c, d), `component_sd.npy`
//! (`[2, H, W]`) and `infeasible.npy` (uint8 `[2, H, W]`).

use crate::io::atomic::{atomic_write, write_npy};
use crate::stats::analysis::{Analysis, Direction};
use crate::synthesis::{CellParams, FilterModel, Method, Model};
use anyhow::{bail, Context, Result};
use ndarray::{Array2, Array3, Axis};
use ndarray_npy::ReadNpyExt;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// Format tag of `model.json`.
pub const FORMAT: &str = "isar-clutter-model/1";

/// The metadata of `model.json`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ModelInfo {
    /// Always [`FORMAT`].
    pub format: String,
    /// The method.
    pub method: Method,
    /// Image height.
    pub height: usize,
    /// Image width.
    pub width: usize,
    /// Filter half-width (Methods 1 and 2).
    pub half_width: usize,
    /// Dyadic levels (Method 2).
    pub levels: usize,
    /// Samples the model was fitted on.
    pub samples_fitted: usize,
    /// Directions of cells whose target was unreachable (Methods 1 and 2).
    pub clamped: u64,
    /// Where the fitted data came from (a file or a spec job).
    pub source: String,
    /// Mean correlation of the fitted data per level and direction (`level`, `direction`,
    /// `mean_correlation`, `nan_cells`).
    pub analysis: serde_json::Value,
}

impl ModelInfo {
    /// The description of `model`, fitted to data whose analysis is `analysis`.
    pub fn new(
        model: &Model,
        analysis: &Analysis,
        half_width: usize,
        levels: usize,
        source: String,
    ) -> Self {
        let (height, width) = model.shape();
        ModelInfo {
            format: FORMAT.into(),
            method: model.method,
            height,
            width,
            half_width,
            levels,
            samples_fitted: analysis.samples,
            clamped: model
                .filter
                .as_ref()
                .map_or(0, |f| f.clamped.iter().map(|&c| c as u64).sum()),
            source,
            analysis: analysis_summary(analysis),
        }
    }
}

/// Summary of an analysis for `model.json`.
pub fn analysis_summary(a: &Analysis) -> serde_json::Value {
    let rows: Vec<serde_json::Value> = a
        .levels
        .iter()
        .flat_map(|lm| {
            Direction::ALL.map(|d| {
                let s = lm.summary(d);
                json!({"level": lm.level, "direction": d.as_str(), "mean_correlation": s.mean_correlation, "nan_cells": s.nan_cells})
            })
        })
        .collect();
    serde_json::Value::Array(rows)
}

/// Saves `model` into the folder `dir` (created; files written atomically).
///
/// # Errors
/// If a file cannot be written.
pub fn save(model: &Model, info: &ModelInfo, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    write_npy(&dir.join("mean.npy"), &model.mean)?;
    write_npy(&dir.join("std.npy"), &model.std)?;
    if let Some(f) = &model.filter {
        match &f.params {
            CellParams::Exponential { alpha_h, alpha_v } => {
                write_npy(&dir.join("alpha_h.npy"), alpha_h)?;
                write_npy(&dir.join("alpha_v.npy"), alpha_v)?;
            }
            CellParams::Dyadic { r_h, r_v } => {
                let stack = |p: &[Array2<f64>]| {
                    ndarray::stack(Axis(0), &p.iter().map(|m| m.view()).collect::<Vec<_>>())
                        .expect("equal cell grids")
                };
                write_npy(&dir.join("r_h.npy"), &stack(r_h))?;
                write_npy(&dir.join("r_v.npy"), &stack(r_v))?;
            }
        }
        write_npy(&dir.join("residual_h.npy"), &f.residual_h)?;
        write_npy(&dir.join("residual_v.npy"), &f.residual_v)?;
        write_npy(&dir.join("clamped.npy"), &f.clamped)?;
    }
    if let Some(d) = &model.deviations {
        write_npy(&dir.join("deviations.npy"), d)?;
    }
    if let Some(f) = &model.fourth {
        write_npy(&dir.join("fleishman.npy"), &f.coefficients)?;
        write_npy(&dir.join("component_sd.npy"), &f.component_sd)?;
        write_npy(&dir.join("infeasible.npy"), &f.infeasible)?;
    }
    atomic_write(&dir.join("model.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, info)?;
        Ok(())
    })
}

fn read<A: ndarray_npy::ReadableElement, D: ndarray::Dimension>(
    dir: &Path,
    name: &str,
) -> Result<ndarray::Array<A, D>> {
    let path = dir.join(name);
    let file =
        std::fs::File::open(&path).with_context(|| format!("cannot open {}", path.display()))?;
    ndarray::Array::<A, D>::read_npy(std::io::BufReader::new(file))
        .with_context(|| format!("cannot read {}", path.display()))
}

/// Loads a model folder written by [`save`].
///
/// # Errors
/// If `model.json` is missing or of another format, or an array is missing or mis-shaped.
pub fn load(dir: &Path) -> Result<(Model, ModelInfo)> {
    let meta = dir.join("model.json");
    let info: ModelInfo = serde_json::from_reader(
        std::fs::File::open(&meta).with_context(|| format!("cannot open {}", meta.display()))?,
    )
    .with_context(|| format!("{} is not a model description", meta.display()))?;
    if info.format != FORMAT {
        bail!(
            "{}: format {:?}, this version reads {FORMAT:?}",
            meta.display(),
            info.format
        );
    }
    let mean: Array2<num_complex::Complex64> = read(dir, "mean.npy")?;
    let std: Array2<f64> = read(dir, "std.npy")?;
    let shape = (info.height, info.width);
    if mean.dim() != shape || std.dim() != shape {
        bail!(
            "{}: mean.npy and std.npy must be {}x{}",
            dir.display(),
            info.height,
            info.width
        );
    }
    let filter = match info.method {
        Method::Method1 | Method::Method2 => {
            let params = if info.method == Method::Method1 {
                CellParams::Exponential {
                    alpha_h: read(dir, "alpha_h.npy")?,
                    alpha_v: read(dir, "alpha_v.npy")?,
                }
            } else {
                let split =
                    |a: Array3<f64>| a.outer_iter().map(|m| m.to_owned()).collect::<Vec<_>>();
                CellParams::Dyadic {
                    r_h: split(read(dir, "r_h.npy")?),
                    r_v: split(read(dir, "r_v.npy")?),
                }
            };
            let residuals = (read(dir, "residual_h.npy")?, read(dir, "residual_v.npy")?);
            let shape = (info.half_width, info.height, info.width);
            Some(FilterModel::new(
                params,
                residuals,
                read(dir, "clamped.npy")?,
                shape,
            ))
        }
        _ => None,
    };
    let deviations = match info.method {
        Method::FullCovariance => Some(read::<num_complex::Complex64, ndarray::Ix3>(
            dir,
            "deviations.npy",
        )?),
        _ => None,
    };
    let fourth = match info.method {
        Method::FourthOrder => Some(crate::synthesis::FourthOrderModel {
            coefficients: read(dir, "fleishman.npy")?,
            component_sd: read(dir, "component_sd.npy")?,
            infeasible: read(dir, "infeasible.npy")?,
        }),
        _ => None,
    };
    Ok((
        Model {
            method: info.method,
            mean,
            std,
            filter,
            deviations,
            fourth,
            packed: Default::default(),
        },
        info,
    ))
}

/// The header of a version-1.0 `.npy` file of complex64 `[m, h, w]`, padded to 64 bytes.
pub fn npy_header_c64(m: usize, h: usize, w: usize) -> Vec<u8> {
    let dict = format!("{{'descr': '<c8', 'fortran_order': False, 'shape': ({m}, {h}, {w}), }}");
    let unpadded = 10 + dict.len() + 1;
    let total = unpadded.div_ceil(64) * 64;
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend(((total - 10) as u16).to_le_bytes());
    out.extend(dict.as_bytes());
    out.extend(std::iter::repeat_n(b' ', total - unpadded));
    out.push(b'\n');
    out
}

/// Streams samples `0..samples` of the generation seeded by `seed` into a `[M, H, W]`
/// complex64 `.npy` at `path`, `chunk` samples at a time (memory: one chunk), calling
/// `progress` with the number of samples written so far. Written atomically.
///
/// # Errors
/// If the file cannot be written.
pub fn generate_to_npy(
    model: &Model,
    seed: u64,
    samples: usize,
    chunk: usize,
    path: &Path,
    progress: impl Fn(usize),
) -> Result<()> {
    let (h, w) = model.shape();
    atomic_write(path, |out| {
        out.write_all(&npy_header_c64(samples, h, w))?;
        let mut done = 0;
        while done < samples {
            let count = chunk.max(1).min(samples - done);
            let block = model.generate_c64(seed, done, count);
            out.write_all(bytemuck::cast_slice(
                block.as_slice().expect("standard layout"),
            ))?;
            done += count;
            progress(done);
        }
        Ok(())
    })
}
