//! The `uavsar` dataset kind: UAVSAR single-look complex scenes (`.slc`, little-endian
//! complex64) with their sizes from the flight line's annotation (`.ann`); one scene is one
//! sample, so a list of coregistered scenes (a time stack) is a clutter stack, each read in the
//! same window (`window`, default the whole scene), or cut into patches (`cut`, as for
//! `geotiff`: one scene, or a few, then make a stack). The files are checked against their
//! annotations at validation: a truncated file, a wrong or missing annotation field, or a
//! window outside a scene is refused naming the file and the field.

use super::cost::{file_sizes, Cost, Sizes, C64};
use super::kind::{DataError, DatasetKind, Materialised};
use super::scenes::{CutScenes, CutSpec, Paths, SceneWindow};
use crate::experiment::context::{Ctx, SpecError};
use crate::io::uavsar::{llh_file, open_stack, UavsarScene};
use ndarray::Array3;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The fields of a `uavsar` dataset as written.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// The `.slc` file, or a list of coregistered ones (a stack over time: one sample each),
    /// relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slc: Option<Paths>,
    /// The annotation file: one for every scene, or a list with one per scene (default: each
    /// scene's own, `<name>.ann` beside `<name>_s<k>_1x1.slc`, else `<stem>.ann`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub annotation: Option<Paths>,
    /// The window read from every scene (default: the whole scene, every scene then of one
    /// size): in pixels, or a box of longitude and latitude through the flight line's `.llh`
    /// grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<SceneWindow>,
    /// Cut the window into patches, each patch of each scene a sample (as for `geotiff`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cut: Option<CutSpec>,
}

/// A validated `uavsar` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct UavsarDataset {
    /// The scenes, checked against their annotations, and their cut.
    pub data: CutScenes<UavsarScene>,
    /// The `.llh` files a map window or a map polygon was placed through (inputs too: their
    /// content decides the pixels).
    pub llh: Vec<PathBuf>,
}

impl DatasetKind for UavsarDataset {
    const NAME: &'static str = "uavsar";
    const FIELDS: &'static [&'static str] = &["slc", "annotation", "window", "cut"];
    const SAMPLES_FIELD: &'static str = "slc";
    type Spec = Spec;

    fn applies(_: &Spec) -> &'static [&'static str] {
        Self::FIELDS
    }

    /// Reads every scene's annotation, checks its file's length against it and the window
    /// against every scene.
    fn check(spec: &Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError> {
        let slc = spec.slc.as_ref().ok_or_else(|| {
            ctx.err(
                format!("{at}.slc"),
                "kind uavsar needs `slc` (a file or a list)",
            )
        })?;
        let resolved =
            |p: &Paths| -> Vec<PathBuf> { p.list().iter().map(|p| ctx.resolve(p)).collect() };
        let window = spec
            .window
            .map(|w| w.place())
            .transpose()
            .map_err(|m| ctx.err(format!("{at}.window"), m))?;
        let annotations = spec.annotation.as_ref().map(resolved).unwrap_or_default();
        let stack = open_stack(&resolved(slc), &annotations, window).map_err(|e| {
            // An index into a field written as one path names the field.
            let listed = match e.field {
                "slc" => matches!(slc, Paths::Many(_)),
                "annotation" => matches!(spec.annotation, Some(Paths::Many(_))),
                _ => false,
            };
            let path = match e.index.filter(|_| listed) {
                Some(i) => format!("{at}.{}[{i}]", e.field),
                None => format!("{at}.{}", e.field),
            };
            ctx.err(path, e.message)
        })?;
        // The field that asked for a map: the window's box, else the cut's map polygon.
        let asked = if spec.window.is_some_and(|w| w.x.is_some()) {
            Some("window")
        } else if spec.cut.as_ref().is_some_and(|c| c.polygon_map.is_some()) {
            Some("cut.polygon_map")
        } else {
            None
        };
        let mut llh = vec![];
        if let Some(field) = asked {
            for scene in &stack.scenes {
                let f = llh_file(scene).map_err(|m| ctx.err(format!("{at}.{field}"), m))?;
                if !llh.contains(&f) {
                    llh.push(f);
                }
            }
        }
        let data = CutScenes::new(stack, spec.cut.as_ref(), ctx, &format!("{at}.cut"))?;
        Ok(UavsarDataset { data, llh })
    }

    fn shape(&self) -> (usize, usize, usize) {
        self.data.shape()
    }

    fn input_files(&self) -> Vec<PathBuf> {
        let s = &self.data.stack.scenes;
        let annotations = s.iter().map(|s| s.annotation.clone());
        s.iter()
            .map(|s| s.slc.clone())
            .chain(annotations)
            .chain(self.llh.iter().cloned())
            .collect()
    }

    fn sizes(&self, at: &str, s: &mut Sizes) {
        file_sizes(at, self.shape(), s);
    }

    fn cost(&self) -> Cost {
        let (n, h, w) = self.shape();
        let np = n as f64 * h as f64 * w as f64;
        // The complex64 stack, filled a row of a window at a time.
        Cost {
            peak: C64 * np,
            kept: C64 * np,
            flops: 2.0 * np,
            ..Cost::default()
        }
    }

    fn redraw_cost(&self, _: usize) -> Cost {
        Cost::default()
    }

    fn materialise(&self, _: u64) -> Result<Materialised, DataError> {
        // complex64 as stored: half the memory of complex128, analysed as a mapped `.npy`.
        self.data.materialise("the uavsar stack", Into::into)
    }

    fn metadata(&self) -> Option<serde_json::Value> {
        self.data.cut.as_ref()?;
        Some(self.data.metadata())
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
