//! The `mat` dataset kind: a stack read from a variable of a MATLAB `.mat` file (v5, or v7.3
//! with the `mat73` feature), `[H, W, N]` by default; the variable is checked from its header
//! at validation and decoded into memory when materialised.

use super::cost::{file_sizes, Cost, Sizes, C128};
use super::kind::{DataError, DatasetKind, Layout, Materialised};
use crate::experiment::context::{Ctx, SpecError};
use ndarray::Array3;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of a `mat` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Path of the file, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// The variable holding the stack (default: the file's only numeric 3-D array).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variable: Option<String>,
    /// Axis order of the variable's MATLAB dimensions (`hwn` default, `nhw`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
}

/// A validated `mat` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct MatDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// The variable read (named in the spec, or the file's only numeric 3-D array).
    pub variable: String,
    /// Axis order of the variable's MATLAB dimensions.
    pub layout: Layout,
    /// The variable's MATLAB dimensions, e.g. `[H, W, N]`.
    pub dims: [usize; 3],
    /// Its MATLAB class (`single`, `double`, `int16`, ...).
    pub class: &'static str,
    /// Whether it is complex.
    pub complex: bool,
}

impl MatDataset {
    /// `(N, H, W)` after applying the layout.
    pub fn stack_shape(&self) -> (usize, usize, usize) {
        self.layout.stack_shape(self.dims)
    }
}

impl DatasetKind for MatDataset {
    const NAME: &'static str = "mat";
    const FIELDS: &'static [&'static str] = &["path", "variable", "layout"];
    const SAMPLES_FIELD: &'static str = "variable";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    /// Opens the `.mat` file and checks the variable (named, or the only numeric 3-D array)
    /// from the variables' headers, without reading the data.
    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        use crate::io::mat::{MatError, MatFile};
        let rel = spec
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind mat needs `path`"))?;
        let path = ctx.resolve(rel);
        let file =
            MatFile::open(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let v = file.stack_variable(spec.variable.as_deref()).map_err(|e| {
            let field = match e {
                MatError::Missing { .. }
                | MatError::Ambiguous { .. }
                | MatError::NotStack { .. } => "variable",
                _ => "path",
            };
            ctx.err(format!("{at}.{field}"), e.to_string())
        })?;
        Ok(MatDataset {
            path,
            variable: v.name.clone(),
            layout: spec.layout.unwrap_or(Layout::Hwn),
            dims: [v.dims[0], v.dims[1], v.dims[2]],
            class: v.class,
            complex: v.complex,
        })
    }

    fn shape(&self) -> (usize, usize, usize) {
        self.stack_shape()
    }

    fn input_files(&self) -> Vec<PathBuf> {
        vec![self.path.clone()]
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        file_sizes(at, self.shape(), s);
    }

    fn cost(&self) -> Cost {
        let (n, h, w) = self.shape();
        let np = n as f64 * h as f64 * w as f64;
        // The complex128 stack, filled in place (v5 inflates in small blocks, libhdf5
        // converts through its own small buffer).
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
            crate::io::mat::load_stack(&self.path, Some(&self.variable))?,
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
