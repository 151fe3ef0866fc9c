//! Model files and streamed generation: a fitted [`Model`] saved as a self-describing folder
//! (`model.json` plus `.npy` arrays that numpy reads directly), loaded back, and used to write
//! any number of samples to a `[M, H, W]` complex64 `.npy` in constant memory.
//!
//! Folder layout (format `isar-clutter-model/1`): `model.json` (format, method, image size,
//! half-width, dyadic levels, samples fitted, unreachable-target counts, provenance, the sample
//! format (absent: 1; see [`crate::synthesis::SAMPLE_FORMAT`]) and the
//! fitted data's multiscale summary), `mean.npy` (complex128 `[H, W]`), `std.npy` (float64
//! `[H, W]`); Method 1: `alpha_h.npy`, `alpha_v.npy` (float64, level-1 cell grid); Method 2:
//! `r_h.npy`, `r_v.npy` (float64 `[L, rows, cols]`); Methods 1 and 2: `residual_h.npy`,
//! `residual_v.npy`, `clamped.npy` (uint8); full covariance: `deviations.npy` (complex128
//! `[N, H, W]`, the centred samples divided by `sqrt(N)`); fourth order: `fleishman.npy`
//! (float64 `[2, 4, H, W]`: component re/im, coefficients a, b, c, d), `component_sd.npy`
//! (`[2, H, W]`) and `infeasible.npy` (uint8 `[2, H, W]`).

use crate::io::atomic::{atomic_write, write_npy};
use crate::stats::analysis::{Analysis, Direction};
use crate::synthesis::{ArrayStore, Layout, Method, Model, Moments, NegativeSigns, ValueCheck};
use anyhow::{bail, Context, Result};
use ndarray_npy::ReadNpyExt;
use serde::{Deserialize, Serialize};
use serde_json::json;
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
    /// How samples are drawn from a seed ([`crate::synthesis::SAMPLE_FORMAT`]); absent in
    /// models written before it was recorded, which are format 1.
    #[serde(default = "format_one")]
    pub sample_format: u32,
    /// Method 1: how the filters of negative `alpha` are signed; absent in other methods' and
    /// in Method 1 models written before it was recorded, which are `alternating`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub negative_signs: Option<NegativeSigns>,
}

/// The sample format of a `model.json` that does not record one.
fn format_one() -> u32 {
    1
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
        let recorded = model.recorded();
        ModelInfo {
            format: FORMAT.into(),
            method: model.method(),
            height,
            width,
            half_width,
            levels,
            samples_fitted: analysis.samples,
            clamped: recorded.clamped,
            source,
            analysis: analysis_summary(analysis),
            sample_format: model.moments().sample_format,
            negative_signs: recorded.negative_signs,
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

/// The files every model folder holds: its description and the moments (each method adds
/// its own, [`Method::files`]).
pub const SHARED_FILES: &[&str] = &["model.json", "mean.npy", "std.npy"];

/// Whether `name` is a file some model folder holds: what [`save`] writes for some method.
pub fn is_model_file(name: &str) -> bool {
    SHARED_FILES
        .iter()
        .chain(Method::ALL.iter().flat_map(|m| m.files()))
        .any(|f| *f == name)
}

/// A model folder as its method's [`ArrayStore`]: arrays written atomically, read back with
/// their shapes and values checked.
struct Folder<'a>(&'a Path);

impl ArrayStore for Folder<'_> {
    fn write<A: ndarray_npy::WritableElement, D: ndarray::Dimension>(
        &mut self,
        name: &'static str,
        array: &ndarray::Array<A, D>,
    ) -> Result<()> {
        write_npy(&self.0.join(name), array)
    }

    fn read<A: ndarray_npy::ReadableElement + std::fmt::Debug, D: ndarray::Dimension>(
        &self,
        name: &'static str,
        (shape, why): (Vec<usize>, &'static str),
        (ok, rule): ValueCheck<'_, A>,
    ) -> Result<ndarray::Array<A, D>> {
        expect(self.0, name, shape, why).read_checked(ok, rule)
    }
}

/// Saves `model` into the folder `dir` (created; files written atomically).
///
/// # Errors
/// If a file cannot be written.
pub fn save(model: &Model, info: &ModelInfo, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    write_npy(&dir.join("mean.npy"), &model.moments().mean)?;
    write_npy(&dir.join("std.npy"), &model.moments().std)?;
    model.save(&mut Folder(dir))?;
    atomic_write(&dir.join("model.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, info)?;
        Ok(())
    })
}

/// What one array of a model folder must be: its file, its shape and why.
struct Expect<'a> {
    dir: &'a Path,
    name: &'static str,
    shape: Vec<usize>,
    why: &'static str,
}

/// The array `name` of the folder `dir`, expected of `shape` (`why`: where the shape comes
/// from).
fn expect<'a>(
    dir: &'a Path,
    name: &'static str,
    shape: Vec<usize>,
    why: &'static str,
) -> Expect<'a> {
    Expect {
        dir,
        name,
        shape,
        why,
    }
}

impl Expect<'_> {
    /// Reads the array after checking its header's shape against the expected one and the
    /// file's size against the shape (so nothing is allocated for a forged header).
    fn read<A: ndarray_npy::ReadableElement, D: ndarray::Dimension>(
        &self,
    ) -> Result<ndarray::Array<A, D>> {
        let path = self.dir.join(self.name);
        let header = crate::io::npy::read_raw_header(&path)?;
        if header.shape != self.shape {
            bail!(
                "{}: shape {:?}, expected {:?} ({})",
                path.display(),
                header.shape,
                self.shape,
                self.why
            );
        }
        let need = header
            .data_bytes(std::mem::size_of::<A>())
            .and_then(|n| n.checked_add(header.data_offset))
            .with_context(|| format!("{}: shape {:?} overflows", path.display(), header.shape))?;
        let len = std::fs::metadata(&path)
            .with_context(|| format!("cannot read {}", path.display()))?
            .len();
        if len < need as u64 {
            bail!(
                "{}: truncated: shape {:?} needs {need} bytes, the file has {len}",
                path.display(),
                header.shape
            );
        }
        let file = std::fs::File::open(&path)
            .with_context(|| format!("cannot open {}", path.display()))?;
        ndarray::Array::<A, D>::read_npy(std::io::BufReader::new(file))
            .with_context(|| format!("cannot read {}", path.display()))
    }

    /// [`Expect::read`], then every value checked by `ok` (`rule` says what it requires).
    fn read_checked<A, D>(
        &self,
        ok: impl Fn(&A) -> bool,
        rule: &str,
    ) -> Result<ndarray::Array<A, D>>
    where
        A: ndarray_npy::ReadableElement + std::fmt::Debug,
        D: ndarray::Dimension,
    {
        let a: ndarray::Array<A, D> = self.read()?;
        if let Some((at, v)) = a.indexed_iter().find(|(_, v)| !ok(v)) {
            let at = ndarray::IntoDimension::into_dimension(at);
            bail!(
                "{}: value {v:?} at {:?}; {rule}",
                self.dir.join(self.name).display(),
                ndarray::Dimension::slice(&at)
            );
        }
        Ok(a)
    }
}

/// Reads `model.json` (a leading UTF-8 byte-order mark is ignored) and checks its format.
fn read_info(dir: &Path) -> Result<ModelInfo> {
    let meta = dir.join("model.json");
    let bytes = std::fs::read(&meta).with_context(|| format!("cannot open {}", meta.display()))?;
    let text = bytes.strip_prefix("\u{feff}".as_bytes()).unwrap_or(&bytes);
    let info: ModelInfo = serde_json::from_slice(text)
        .with_context(|| format!("{} is not a model description", meta.display()))?;
    if info.format != FORMAT {
        bail!(
            "{}: format {:?}, this version reads {FORMAT:?}",
            meta.display(),
            info.format
        );
    }
    check_info(&info).with_context(|| format!("{}", meta.display()))?;
    Ok(info)
}

/// The sizes of `model.json` that every array is checked against: an image of at least one
/// pixel (2x2 for the filter methods, which need a level-1 cell), Method 2's levels within the
/// image and the half-width, and a filter bank and padded seed of bounded size.
fn check_info(info: &ModelInfo) -> Result<()> {
    let (h, w) = (info.height, info.width);
    if h == 0 || w == 0 {
        bail!("height {h} and width {w} must be at least 1");
    }
    if !crate::synthesis::SAMPLE_FORMATS.contains(&info.sample_format) {
        bail!(
            "sample_format {}: this version generates formats {:?}",
            info.sample_format,
            crate::synthesis::SAMPLE_FORMATS
        );
    }
    info.method.check(&layout(info))
}

/// The sizes of `model.json` a method's arrays are checked against.
fn layout(info: &ModelInfo) -> Layout {
    Layout {
        height: info.height,
        width: info.width,
        half_width: info.half_width,
        levels: info.levels,
        samples_fitted: info.samples_fitted,
        negative_signs: info.negative_signs,
    }
}

/// Loads a model folder written by [`save`], validating it as a whole: `model.json`'s sizes,
/// every array's shape against them (image `[H, W]`, level-1 cell grid `[H/2, W/2]`, Method 2's
/// `levels`, the samples fitted), and every value (finite where generation needs it, flags in
/// range). A leading UTF-8 byte-order mark in `model.json` is ignored.
///
/// # Errors
/// If `model.json` is missing, of another format or inconsistent, or an array is missing,
/// mis-shaped, truncated or holds a value the model cannot hold; the message names the file.
pub fn load(dir: &Path) -> Result<(Model, ModelInfo)> {
    let info = read_info(dir)?;
    let (h, w) = (info.height, info.width);
    let at = |name, shape, why| expect(dir, name, shape, why);
    const IMAGE: &str = "height and width of model.json";
    let mean = at("mean.npy", vec![h, w], IMAGE).read_checked(
        |z: &num_complex::Complex64| z.is_finite(),
        "the mean must be finite",
    )?;
    let std = at("std.npy", vec![h, w], IMAGE).read_checked(
        |s: &f64| s.is_finite() && *s >= 0.0,
        "the standard deviation must be finite and >= 0",
    )?;
    let moments = Moments {
        mean,
        std,
        sample_format: info.sample_format,
    };
    let model = info.method.load(moments, &layout(&info), &Folder(dir))?;
    Ok((model, info))
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

/// Format tag of a generation record.
pub const GENERATION_FORMAT: &str = "isar-clutter-generation/1";

/// What `generate` writes beside a `.npy` it made, as `NAME.npy.json`: the model, seed and
/// sample format its samples come from (enough to write the same bytes again), and the mark
/// by which a later `generate` knows the `.npy` is one it may replace (a user's complex64
/// stack looks the same inside).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct GenerationRecord {
    /// Always [`GENERATION_FORMAT`].
    pub format: String,
    /// The `.npy`'s file name.
    pub file: String,
    /// `[M, H, W]` of the complex64 samples.
    pub shape: [usize; 3],
    /// The model folder, as an absolute path.
    pub model: String,
    /// SHA-256 (hex) of the model's `model.json` when the samples were written: a model
    /// fitted again into the same folder from other data has another.
    pub model_json_sha256: String,
    /// The model's method.
    pub method: Method,
    /// The generation's seed.
    pub seed: u64,
    /// How the samples were drawn from the seed ([`crate::synthesis::SAMPLE_FORMAT`]).
    pub sample_format: u32,
    /// The tool's version.
    pub version: String,
}

impl GenerationRecord {
    /// The record of samples `0..samples` of `model` (loaded from the folder `dir`, whose
    /// `model.json` is hashed now, before any sample is drawn) seeded by `seed`, for the `.npy`
    /// at `npy`.
    pub fn new(dir: &Path, model: &Model, seed: u64, samples: usize, npy: &Path) -> Self {
        let (h, w) = model.shape();
        GenerationRecord {
            format: GENERATION_FORMAT.into(),
            file: npy
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned(),
            shape: [samples, h, w],
            model: std::path::absolute(dir)
                .unwrap_or_else(|_| dir.to_path_buf())
                .display()
                .to_string(),
            model_json_sha256: std::fs::read(dir.join("model.json"))
                .map(|b| crate::seeds::sha256_hex(&b))
                .unwrap_or_default(),
            method: model.method(),
            seed,
            sample_format: model.moments().sample_format,
            version: env!("CARGO_PKG_VERSION").into(),
        }
    }
}

/// Where the [`GenerationRecord`] of the `.npy` `npy` is: `NAME.npy.json` beside it.
pub fn record_path(npy: &Path) -> std::path::PathBuf {
    let mut name = npy.file_name().unwrap_or_default().to_os_string();
    name.push(".json");
    npy.with_file_name(name)
}

/// The [`GenerationRecord`] at `path`, if it is one.
fn read_record(path: &Path) -> Option<GenerationRecord> {
    let rec: GenerationRecord = serde_json::from_slice(&std::fs::read(path).ok()?).ok()?;
    (rec.format == GENERATION_FORMAT).then_some(rec)
}

/// Whether `path` is a generation record (so that `generate` may replace it).
pub fn is_generation_record(path: &Path) -> bool {
    read_record(path).is_some()
}

/// Whether `path` is a `.npy` that `generate` wrote: a complex64 `[M, H, W]` whose record
/// beside it names this file and this shape (a file written over it since has another record,
/// or a shape the record does not give, or no record).
pub fn is_generated_npy(path: &Path) -> bool {
    let (Some(name), Ok(h)) = (
        path.file_name().and_then(|n| n.to_str()),
        crate::io::npy::read_raw_header(path),
    ) else {
        return false;
    };
    read_record(&record_path(path)).is_some_and(|rec| {
        h.descr == "<c8" && rec.file == name && h.shape.as_slice() == rec.shape.as_slice()
    })
}

/// Writes the record of the `.npy` at `npy` (atomically), once the `.npy` is in place.
///
/// # Errors
/// If the record cannot be written.
pub fn write_generation_record(npy: &Path, rec: &GenerationRecord) -> Result<()> {
    atomic_write(&record_path(npy), |w| {
        serde_json::to_writer_pretty(&mut *w, rec)?;
        Ok(std::io::Write::write_all(w, b"\n")?)
    })
}

/// Streams samples `0..samples` of the generation seeded by `seed` into a `[M, H, W]`
/// complex64 `.npy` at `path`, `chunk` samples at a time (memory: two chunks, one being
/// generated while the other is written, with direct I/O where the file system allows it and
/// `mode` asks for it: [`crate::io::stream`]), calling `progress` with the number of samples
/// generated so far. Written atomically. Returns the write mode used.
///
/// # Errors
/// If the blocks do not fit in memory or the file cannot be written.
pub fn generate_to_npy(
    model: &Model,
    seed: u64,
    (samples, chunk): (usize, usize),
    path: &Path,
    mode: crate::io::stream::WriteMode,
    progress: impl Fn(usize),
) -> Result<crate::io::stream::WriteMode> {
    let (h, w) = model.shape();
    let mut used = mode;
    crate::io::atomic::atomic_write_path(path, |tmp| {
        used = crate::io::stream::write_samples(
            tmp,
            &npy_header_c64(samples, h, w),
            (samples, h * w, chunk),
            mode,
            |first, out| model.generate_c64_into(seed, first, out),
            progress,
        )?;
        Ok(())
    })?;
    Ok(used)
}

/// Streams samples `0..samples` of the generation seeded by `seed` into the MAT file `path` as
/// the variable `out.variable`, MATLAB `H x W x M` of `out.class` complex, `chunk` samples at
/// a time (memory: one chunk; see [`crate::io::mat::write::write_stack`]). `single` values are
/// those `generate_to_npy` writes; `double` values are the generator's own (sample format 2
/// computes in `f32`, so they are the same values widened; format 1's are its `f64` values).
///
/// # Errors
/// If the output is refused ([`crate::io::mat::write::check_output`]), a block does not fit in
/// memory, or the file cannot be written.
pub fn generate_to_mat(
    model: &Model,
    seed: u64,
    samples: usize,
    chunk: usize,
    path: &Path,
    out: &crate::io::mat::MatOutput,
    progress: impl FnMut(usize),
) -> Result<()> {
    use crate::io::mat::{write::write_stack, MatClass};
    let (h, w) = model.shape();
    let dims = (h, w, samples);
    match out.class {
        MatClass::Single => write_stack::<f32>(
            path,
            out,
            dims,
            chunk,
            |first, count| Ok(model.try_generate_c64(seed, first, count)?),
            progress,
        ),
        MatClass::Double => write_stack::<f64>(
            path,
            out,
            dims,
            chunk,
            |first, count| Ok(model.try_generate(seed, first, count)?),
            progress,
        ),
    }
}
