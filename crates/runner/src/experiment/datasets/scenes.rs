//! Dataset kinds of radar scenes in a file format of the field ([`SceneFormat`]: `geotiff`,
//! `sicd`): one scene is one sample, so a list of coregistered scenes (a stack over time or
//! aspect) is a clutter stack, each read in the same window (`window`, default the whole
//! scene); with `cut`, the window is cut into patches and every patch of every scene is one
//! sample (one scene, or a few, then make a stack). The files are checked at validation by
//! the format's reader (the core's `io::scenes`), which names the file and the format's field
//! at fault; only the window is read (with `cut`, a band of patch rows at a time), and each
//! file's metadata goes into the manifest.

use super::cost::{file_sizes, Cost, Sizes, C64};
use super::kind::{DataError, DatasetKind, Materialised};
use crate::alloc::try_zeros;
use crate::experiment::context::{Ctx, SpecError};
use crate::io::cut::{CutOptions, Size2, Window};
use crate::io::npy::Stack;
use crate::io::polygon::Polygon;
use crate::io::scenes::{OpenScene, Place, Scene, Scenes};
use ndarray::Array3;
use num_complex::{Complex32, Complex64};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// One path, or a list of them.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Paths {
    /// One file.
    One(PathBuf),
    /// Several files, in order.
    Many(Vec<PathBuf>),
}

impl Paths {
    /// The paths, in order.
    pub(crate) fn list(&self) -> Vec<PathBuf> {
        match self {
            Paths::One(p) => vec![p.clone()],
            Paths::Many(v) => v.clone(),
        }
    }
}

/// The window of every scene read: its first row (along track) and column (across track), and
/// its size `[H, W]`.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub struct WindowSpec {
    /// First row.
    pub row: usize,
    /// First column.
    pub col: usize,
    /// `[rows, columns]`.
    pub size: [usize; 2],
}

/// A file format of radar scenes, as a dataset kind.
pub trait SceneFormat: Clone + std::fmt::Debug + PartialEq + Send + Sync {
    /// The kind's name.
    const NAME: &'static str;
    /// The format's scene.
    type Scene: OpenScene<Error: Into<DataError>>
        + Clone
        + std::fmt::Debug
        + PartialEq
        + Send
        + Sync;
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
    /// size): in pixels, or a box in map coordinates.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<SceneWindow>,
    /// Calibrate the values to `sigma0`, `beta0`, `gamma0` or `rcs` with the files' own scale
    /// factors (SICD's `Radiometric` polynomials).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<String>,
    /// Cut the window into patches, each patch of each scene a sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cut: Option<CutSpec>,
}

/// A scene window as written: `{row, col, size: [H, W]}` in pixels, or `{x: [x0, x1], y:
/// [y0, y1]}` in the map coordinates of the files' affine transform (a GeoTIFF on a grid).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneWindow {
    /// First row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row: Option<usize>,
    /// First column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub col: Option<usize>,
    /// `[rows, columns]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[usize; 2]>,
    /// Map x range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<[f64; 2]>,
    /// Map y range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<[f64; 2]>,
}

impl SceneWindow {
    /// The core's place, or what is wrong with the fields.
    pub(super) fn place(&self) -> Result<Place, &'static str> {
        match (self.row, self.col, self.size, self.x, self.y) {
            (Some(row), Some(col), Some([h, w]), None, None) => {
                Ok(Place::Pixels(Window::at(row, col, h, w)))
            }
            (None, None, None, Some(x), Some(y)) if x[0] < x[1] && y[0] < y[1] => {
                Ok(Place::Map { x, y })
            }
            (None, None, None, Some(_), Some(_)) => {
                Err("a map box's ranges must be [low, high] with low < high")
            }
            _ => Err(
                "a window is {row, col, size: [H, W]} in pixels or {x: [x0, x1], y: [y0, \
                      y1]} in map coordinates",
            ),
        }
    }
}

/// A patch size or stride: `64` (square) or `[rows, columns]`.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(untagged)]
pub enum Side {
    /// Square.
    Square(usize),
    /// `[rows, columns]`.
    Rect([usize; 2]),
}

impl Side {
    /// As the core's size.
    fn size(self) -> Size2 {
        let [rows, cols] = match self {
            Side::Square(n) => [n, n],
            Side::Rect(rc) => rc,
        };
        Size2 { rows, cols }
    }
}

/// How the window is cut into patches (`isar-clutter cut`'s options).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CutSpec {
    /// Patch size.
    pub patch: Side,
    /// Step between patches (default: the patch size, patches that touch).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stride: Option<Side>,
    /// Boxes no patch may overlap (targets, buildings), in scene pixels.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub avoid: Vec<WindowSpec>,
    /// A region patches must lie wholly inside: its vertices `[row, column]` in scene pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polygon: Option<Vec<[f64; 2]>>,
    /// The same region given by its vertices `[x, y]` in the scenes' map coordinates
    /// (longitude and latitude for Sentinel-1's ground control points), turned into scene
    /// pixels through their georeferencing (`io::mapping`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polygon_map: Option<Vec<[f64; 2]>>,
    /// A mask of the first scene's size (`.npy`, `bool` or `uint8`): no patch may cover a
    /// non-zero pixel. Relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub avoid_mask: Option<PathBuf>,
}

/// A validated cut: the patch size and the places of the patches (top-left row, column).
#[derive(Debug, Clone, PartialEq)]
pub struct Patches {
    /// Patch size.
    pub patch: Size2,
    /// The options, as the manifest records them.
    pub options: CutOptions,
    /// Top-left row and column of every patch, row-major.
    pub places: Vec<(usize, usize)>,
}

/// Scenes and the patches their window is cut into (`None`: one sample a scene): what the
/// scene kinds (`geotiff`, `sicd`, `uavsar`, a single `hdf5` scene) read.
#[derive(Debug, Clone, PartialEq)]
pub struct CutScenes<S> {
    /// The scenes, checked, and the window read from each.
    pub stack: Scenes<S>,
    /// The patches the window is cut into.
    pub cut: Option<Patches>,
}

impl<S: Scene> CutScenes<S> {
    /// `stack`, cut as `cut` says (`at`: the cut's YAML path) or whole.
    ///
    /// # Errors
    /// A [`SpecError`] at `at` where the cut's sizes, polygon or mask are bad or no patch
    /// fits.
    pub(super) fn new(
        stack: Scenes<S>,
        cut: Option<&CutSpec>,
        ctx: &Ctx,
        at: &str,
    ) -> Result<Self, SpecError> {
        let cut = match cut {
            Some(c) => Some(patches(c, &stack, ctx, at)?),
            None => None,
        };
        Ok(CutScenes { stack, cut })
    }

    /// `(N, H, W)`: a sample per place and scene, or per scene.
    pub fn shape(&self) -> (usize, usize, usize) {
        match &self.cut {
            Some(c) => (
                c.places.len() * self.stack.scenes.len(),
                c.patch.rows,
                c.patch.cols,
            ),
            None => self.stack.shape(),
        }
    }

    /// Reads the samples into a complex64 stack (`what` names it where memory is refused;
    /// `error` makes the format's error a dataset's).
    ///
    /// # Errors
    /// If the stack does not fit in memory or a file cannot be read.
    pub fn materialise(
        &self,
        what: &str,
        error: impl Fn(S::Error) -> DataError,
    ) -> Result<Materialised, DataError> {
        let mut out: Array3<Complex32> = try_zeros(self.shape(), what)?;
        let values = out.as_slice_mut().expect("standard layout");
        match &self.cut {
            Some(c) => self.stack.read_patches(&c.places, c.patch, values),
            None => self.stack.read_into(values),
        }
        .map_err(error)?;
        Ok(Materialised::plain(Stack::Single(out), false))
    }

    /// What the manifest records: the window, each file's description and the cut.
    pub fn metadata(&self) -> serde_json::Value {
        let mut m = self.stack.describe();
        if let Some(c) = &self.cut {
            m["cut"] = serde_json::json!({
                "options": c.options,
                "places": c.places.len(),
                "order": "sample p * scenes + t is scene t at place p (row-major places)",
            });
        }
        m
    }
}

/// A validated scene dataset of format `F`.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneDataset<F: SceneFormat> {
    /// The scenes and their cut.
    pub data: CutScenes<F::Scene>,
}

impl<F: SceneFormat> DatasetKind for SceneDataset<F> {
    const NAME: &'static str = F::NAME;
    const FIELDS: &'static [&'static str] = &["path", "window", "calibration", "cut"];
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
        let window = match &spec.window {
            Some(w) => Some(w.place().map_err(|m| ctx.err(format!("{at}.window"), m))?),
            None => None,
        };
        let mut stack = Scenes::<F::Scene>::open(&files, window).map_err(|e| {
            let path = match e.index.filter(|_| matches!(path, Paths::Many(_))) {
                Some(i) => format!("{at}.{}[{i}]", e.field),
                None => format!("{at}.{}", e.field),
            };
            ctx.err(path, e.message)
        })?;
        if let Some(q) = &spec.calibration {
            stack
                .calibrate(q)
                .map_err(|m| ctx.err(format!("{at}.calibration"), m))?;
        }
        let data = CutScenes::new(stack, spec.cut.as_ref(), ctx, &format!("{at}.cut"))?;
        Ok(SceneDataset { data })
    }

    fn shape(&self) -> (usize, usize, usize) {
        self.data.shape()
    }

    fn input_files(&self) -> Vec<PathBuf> {
        self.data.stack.paths()
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
        self.data.materialise(&what, Into::into)
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
        Some(self.data.metadata())
    }
}

/// The places of the cut `c` of `stack`'s window (`at`: the cut's YAML path).
fn patches<S: Scene>(
    c: &CutSpec,
    stack: &Scenes<S>,
    ctx: &Ctx,
    at: &str,
) -> Result<Patches, SpecError> {
    let (patch, stride) = (c.patch.size(), c.stride.unwrap_or(c.patch).size());
    for (name, s) in [("patch", patch), ("stride", stride)] {
        if s.rows == 0 || s.cols == 0 {
            return Err(ctx.err(format!("{at}.{name}"), "must be at least 1 x 1"));
        }
    }
    let (vertices, key) = match (&c.polygon, &c.polygon_map) {
        (Some(_), Some(_)) => return Err(ctx.err(
            format!("{at}.polygon_map"),
            "give the region as `polygon` (pixels) or `polygon_map` (map coordinates), not both",
        )),
        (Some(v), None) => (Some(v.clone()), "polygon"),
        (None, Some(v)) => (
            Some(
                stack
                    .map_polygon(v)
                    .map_err(|m| ctx.err(format!("{at}.polygon_map"), m))?,
            ),
            "polygon_map",
        ),
        (None, None) => (None, "polygon"),
    };
    let polygon = match vertices {
        Some(v) => Some(Polygon::new(v).ok_or_else(|| {
            ctx.err(
                format!("{at}.{key}"),
                "a polygon is 3 vertices or more, finite",
            )
        })?),
        None => None,
    };
    let options = CutOptions {
        patch,
        stride,
        window: Some(stack.window),
        avoid: c
            .avoid
            .iter()
            .map(|w| Window::at(w.row, w.col, w.size[0], w.size[1]))
            .collect(),
        polygon,
        avoid_mask: c.avoid_mask.as_ref().map(|p| ctx.resolve(p)),
    };
    let places = stack
        .cut_places(&options)
        .map_err(|e| ctx.err(at.to_string(), format!("{e:#}")))?;
    Ok(Patches {
        patch,
        options,
        places,
    })
}
