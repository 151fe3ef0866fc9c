//! The `npy` dataset kind: a stack read from a `.npy` file (`[N, H, W]`, or `[H, W, N]` with
//! `layout: hwn`), mapped from the file rather than copied.

use super::cost::{file_sizes, Cost, Sizes};
use super::kind::{DataError, DatasetKind, Layout, Materialised};
use crate::experiment::context::{Ctx, SpecError};
use crate::io::npy::{self, NpyHeader, Stack};
use ndarray::Array3;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of an `npy` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Path of the file, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// Axis order (`nhw` default, `hwn`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
}

/// A validated `npy` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// Axis order.
    pub layout: Layout,
    /// Header of the file.
    pub header: NpyHeader,
}

impl NpyDataset {
    /// `(N, H, W)` after applying the layout.
    pub fn stack_shape(&self) -> (usize, usize, usize) {
        let s = &self.header.shape;
        self.layout.stack_shape([s[0], s[1], s[2]])
    }
}

impl DatasetKind for NpyDataset {
    const NAME: &'static str = "npy";
    const FIELDS: &'static [&'static str] = &["path", "layout"];
    const SAMPLES_FIELD: &'static str = "path";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let rel = spec
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind npy needs `path`"))?;
        let path = ctx.resolve(rel);
        let header =
            npy::read_header(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        if header.shape.len() != 3 {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} has shape {:?}; a stack is 3-D ([N, H, W], or [H, W, N] with layout: hwn)",
                    path.display(),
                    header.shape
                ),
            ));
        }
        Ok(NpyDataset {
            path,
            layout: spec.layout.unwrap_or_default(),
            header,
        })
    }

    fn shape(&self) -> (usize, usize, usize) {
        self.stack_shape()
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![self.path.clone()]
    }

    fn worth_sharing(&self) -> bool {
        false
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        file_sizes(at, self.shape(), s);
    }

    fn cost(&self) -> Cost {
        let (n, h, w) = self.shape();
        let elem = self.header.dtype.size() as f64;
        // Mapped: nothing allocated; its complex128 copy widens from the file's elements.
        Cost {
            widen: elem * n as f64 * h as f64 * w as f64,
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, _: usize) -> Cost {
        Cost::default()
    }

    fn materialise(&self, _: u64) -> Result<Materialised, DataError> {
        Ok(Materialised::plain(
            Stack::load(&self.path)?,
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
