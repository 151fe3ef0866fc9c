//! Dataset kinds of radar scenes in a file format of the field ([`SceneFormat`]: `geotiff`,
//! `sicd`): one scene is one sample, so a list of coregistered scenes (a stack over time or
//! aspect) is a clutter stack, each read in the same window (`window`, default the whole
//! scene). The files are checked at validation by the format's reader (the core's
//! `io::scenes`), which names the file and the format's field at fault; only the window is
//! read, and each file's metadata goes into the manifest.

use super::cost::{file_sizes, Cost, Sizes, C64};
use super::kind::{DataError, DatasetKind, Materialised};
use super::uavsar::{Paths, WindowSpec};
use crate::alloc::try_zeros;
use crate::experiment::context::{Ctx, SpecError};
use crate::io::cut::Window;
use crate::io::npy::Stack;
use crate::io::scenes::{Scene, Scenes};
use ndarray::Array3;
use num_complex::{Complex32, Complex64};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A file format of radar scenes, as a dataset kind.
pub trait SceneFormat: Clone + std::fmt::Debug + PartialEq + Send + Sync {
    /// The kind's name.
    const NAME: &'static str;
    /// The format's scene.
    type Scene: Scene<Error: Into<DataError>> + Clone + std::fmt::Debug + PartialEq + Send + Sync;
}

/// The fields of a scene dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// The file, or a list of coregistered ones (one sample each), relative to the
    /// spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<Paths>,
    /// The window read from every scene (default: the whole scene, every scene then of one
    /// size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<WindowSpec>,
}

/// A validated scene dataset of format `F`.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneDataset<F: SceneFormat> {
    /// The scenes, checked, and the window read from each.
    pub stack: Scenes<F::Scene>,
}

impl<F: SceneFormat> DatasetKind for SceneDataset<F> {
    const NAME: &'static str = F::NAME;
    const FIELDS: &'static [&'static str] = &["path", "window"];
    const SAMPLES_FIELD: &'static str = "path";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    /// Opens every file with its format's checks, and checks the window.
    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let path = spec.path.as_ref().ok_or_else(|| {
            ctx.err(
                format!("{at}.path"),
                format!("kind {} needs `path` (a file or a list)", F::NAME),
            )
        })?;
        let files: Vec<PathBuf> = path.list().iter().map(|p| ctx.resolve(p)).collect();
        let window = spec
            .window
            .map(|w| Window::at(w.row, w.col, w.size[0], w.size[1]));
        let stack = Scenes::open(&files, window).map_err(|e| {
            let path = match e.index.filter(|_| matches!(path, Paths::Many(_))) {
                Some(i) => format!("{at}.{}[{i}]", e.field),
                None => format!("{at}.{}", e.field),
            };
            ctx.err(path, e.message)
        })?;
        Ok(SceneDataset { stack })
    }

    fn shape(&self) -> (usize, usize, usize) {
        self.stack.shape()
    }

    fn input_files(&self) -> Vec<PathBuf> {
        self.stack.paths()
    }

    fn worth_sharing(&self) -> bool {
        true
    }

    fn redrawable(&self) -> Option<bool> {
        None
    }

    fn kspace_grid(&self) -> Option<(usize, usize)> {
        None
    }

    fn known_filter(&self) -> Option<usize> {
        None
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        file_sizes(at, self.shape(), s);
    }

    fn cost(&self) -> Cost {
        let (n, h, w) = self.shape();
        let np = n as f64 * h as f64 * w as f64;
        // The complex64 stack, filled a window at a time.
        Cost {
            peak: C64 * np,
            kept: C64 * np,
            flops: 4.0 * np,
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, _: usize) -> Cost {
        Cost::default()
    }

    fn materialise(&self, _: u64) -> Result<Materialised, DataError> {
        let what = format!("the {} stack", F::NAME);
        let mut out: Array3<Complex32> = try_zeros(self.shape(), &what)?;
        self.stack
            .read_into(out.as_slice_mut().expect("standard layout"))
            .map_err(Into::into)?;
        Ok(Materialised::plain(Stack::Single(out), false))
    }

    fn redraw(
        &self,
        _: usize,
        _: u64,
        _: &Materialised,
    ) -> Option<Result<Array3<Complex64>, DataError>> {
        None
    }

    fn metadata(&self) -> Option<serde_json::Value> {
        Some(self.stack.describe())
    }
}
