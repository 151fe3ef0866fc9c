//! The `raw` dataset kind: a headerless file of little-endian complex64 values (real,
//! imaginary), `samples x size` of them in C order, `[N, H, W]` or `[H, W, N]` with
//! `layout: hwn`; its length is checked against the shape at validation.

use super::cost::{file_sizes, Cost, Sizes, C128};
use super::kind::{DataError, DatasetKind, Layout, Materialised};
use crate::alloc::try_zeros;
use crate::experiment::context::{Ctx, SpecError};
use crate::io::npy::{NpyError, Stack};
use ndarray::Array3;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of a `raw` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Path of the file, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// Number of samples `N`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Image size `[H, W]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[usize; 2]>,
    /// Axis order of the stored values (`nhw` default, `hwn`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
}

/// A validated `raw` dataset: little-endian complex64 values (real, imaginary), C order.
#[derive(Debug, Clone, PartialEq)]
pub struct RawDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// Axis order of the stored values.
    pub layout: Layout,
    /// `(N, H, W)`: `samples` and `size`.
    pub shape: (usize, usize, usize),
}

impl DatasetKind for RawDataset {
    const NAME: &'static str = "raw";
    const FIELDS: &'static [&'static str] = &["path", "samples", "size", "layout"];
    const SAMPLES_FIELD: &'static str = "samples";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    /// Checks a raw complex64 file: its size is `samples x size` values of 8 bytes.
    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let need = |key: &str| ctx.err(format!("{at}.{key}"), format!("kind raw needs `{key}`"));
        let rel = spec.path.as_ref().ok_or_else(|| need("path"))?;
        let n = spec.samples.ok_or_else(|| need("samples"))?;
        let [h, w] = spec.size.ok_or_else(|| need("size"))?;
        let path = ctx.resolve(rel);
        let bytes = std::fs::metadata(&path)
            .map_err(|e| ctx.err(format!("{at}.path"), format!("{}: {e}", path.display())))?
            .len();
        let want = [n, h, w, 8]
            .iter()
            .try_fold(1u64, |a, &b| a.checked_mul(b as u64));
        if want != Some(bytes) {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} holds {bytes} bytes; {n} samples of {h} x {w} complex64 values are {} \
                     bytes (check samples and size)",
                    path.display(),
                    want.map_or("more than 2^64".into(), |b| b.to_string())
                ),
            ));
        }
        let layout = spec.layout.unwrap_or_default();
        Ok(RawDataset {
            path,
            layout,
            shape: (n, h, w),
        })
    }

    fn shape(&self) -> (usize, usize, usize) {
        self.shape
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![self.path.clone()]
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        file_sizes(at, self.shape, s);
    }

    fn cost(&self) -> Cost {
        let (n, h, w) = self.shape;
        let np = n as f64 * h as f64 * w as f64;
        // The complex128 stack, filled a block of the file at a time.
        Cost {
            peak: C128 * np,
            kept: C128 * np,
            flops: 2.0 * np,
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, _: usize) -> Cost {
        Cost::default()
    }

    fn materialise(&self, _: u64) -> Result<Materialised, DataError> {
        Ok(Materialised::plain(
            Stack::Generated(read_raw(self)?),
            self.layout == Layout::Hwn,
        ))
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

/// The values of a raw dataset's file as complex128, in their stored order (`[N, H, W]`, or
/// `[H, W, N]` with `layout: hwn`), read a block at a time.
fn read_raw(r: &RawDataset) -> Result<Array3<Complex64>, DataError> {
    use std::io::Read;
    let (n, h, w) = r.shape;
    let dims = match r.layout {
        Layout::Nhw => (n, h, w),
        Layout::Hwn => (h, w, n),
    };
    let data_err = |e: std::io::Error| NpyError::Data {
        path: r.path.clone(),
        reason: e.to_string(),
    };
    let mut out: Array3<Complex64> = try_zeros(dims, "the raw stack")?;
    let mut file = std::io::BufReader::new(std::fs::File::open(&r.path).map_err(data_err)?);
    let mut block = vec![0u8; 8 << 13];
    for chunk in out
        .as_slice_mut()
        .expect("standard layout")
        .chunks_mut(1 << 13)
    {
        let bytes = &mut block[..8 * chunk.len()];
        file.read_exact(bytes).map_err(data_err)?;
        for (z, b) in chunk.iter_mut().zip(bytes.chunks_exact(8)) {
            let re = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            let im = f32::from_le_bytes([b[4], b[5], b[6], b[7]]);
            *z = Complex64::new(re.into(), im.into());
        }
    }
    Ok(out)
}
