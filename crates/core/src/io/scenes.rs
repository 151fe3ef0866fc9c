//! A stack of coregistered radar scenes read in one window (the `geotiff` and `sicd` dataset
//! kinds and `isar_clutter.load`): any file format that opens a scene, knows its size and
//! reads a window of it as complex64 ([`Scene`]) makes a clutter stack of one sample per
//! scene ([`Scenes`]), or of one sample per patch and scene when the window is cut into
//! patches ([`Scenes::read_patches`]), its files and window checked at opening with errors
//! that name the field, the scene and the file ([`StackError`]).

use super::cut::{Size2, Window};
use super::mapping::{map_points, map_window, Georeference, MapWindow};
use num_complex::Complex32;
use std::path::{Path, PathBuf};

/// Why a scene file of a format read here (GeoTIFF, SICD) cannot be read: the file unreadable,
/// or a field of the format (a TIFF tag, a NITF field, a SICD XML element) missing, of a kind
/// the reader does not take, or inconsistent.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// A field of the format is at fault.
    #[error("{path}: {field}: {reason}")]
    Field {
        /// The file.
        path: PathBuf,
        /// The field: a TIFF tag (or `header`, or a block), a NITF field (`NROWS`, `PVTYPE`,
        /// ...) or a SICD XML element (`ImageData/PixelType`).
        field: String,
        /// What is wrong.
        reason: String,
    },
}

/// What a [`Scenes`] (or a UAVSAR stack) is refused for, and where: the field (`path`, `slc`,
/// `annotation` or `window`) and, for a list, the index of the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct StackError {
    /// The field at fault.
    pub field: &'static str,
    /// The index in the field's list (`None`: the field as a whole).
    pub index: Option<usize>,
    /// What is wrong, naming the file.
    pub message: String,
}

impl std::fmt::Display for StackError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.index {
            Some(i) => write!(f, "{}[{i}]: {}", self.field, self.message),
            None => write!(f, "{}: {}", self.field, self.message),
        }
    }
}

/// A scene of a format that a path alone names (a GeoTIFF, a SICD; not a dataset inside an
/// HDF5 file).
pub trait OpenScene: Scene {
    /// Opens and checks the scene in `path`.
    ///
    /// # Errors
    /// Naming the file and the field of the format at fault.
    fn open(path: &Path) -> Result<Self, Self::Error>;
}

/// One scene of a file format, checked, read a window at a time.
pub trait Scene: Sized {
    /// Why a scene cannot be opened or read.
    type Error: std::fmt::Display;
    /// Its file.
    fn path(&self) -> &Path;
    /// `(rows, columns)`.
    fn dims(&self) -> (usize, usize);
    /// Reads `window` (inside the scene) into `out` (its values, row after row).
    ///
    /// # Errors
    /// If the file cannot be read or its data do not decode.
    fn read_window(&self, window: &Window, out: &mut [Complex32]) -> Result<(), Self::Error>;
    /// What a run's manifest records of the file (its format's metadata).
    fn describe(&self) -> serde_json::Value;
    /// How its pixels lie in the file's map coordinates (an affine transform, ground control
    /// points, SICD's projection), where the format gives it.
    ///
    /// # Errors
    /// Why the file gives none, naming it.
    fn georeference(&self) -> Result<Georeference, String> {
        Err(no_georeference(self.path()))
    }
    /// Rows of the file's storage blocks (HDF5 chunks, GeoTIFF tiles or strips): a window is
    /// read in whole blocks, which compressed ones inflate, so reads as tall as a block waste
    /// the least ([`Scenes::read_patches`]).
    fn block_rows(&self) -> usize {
        1
    }
    /// Makes every later read give calibrated values of `quantity` (`sigma0`, `beta0`,
    /// `gamma0`, `rcs`: `|value|^2` is that quantity) from the file's own scale factors.
    ///
    /// # Errors
    /// Where the format or the file gives no such factors, naming the file.
    fn calibrate(&mut self, quantity: &str) -> Result<(), String> {
        Err(format!(
            "{}: its format gives no radiometric scale factors (asked for {quantity})",
            self.path().display()
        ))
    }
}

/// Why `path` places no map box: it gives no georeferencing ([`Scene::georeference`]).
pub fn no_georeference(path: &Path) -> String {
    format!(
        "{} gives no georeferencing (no map transform, no ground control points)",
        path.display()
    )
}

/// Where the window lies: in pixels, or a box in the files' map coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Place {
    /// Pixels of every scene.
    Pixels(Window),
    /// The pixels that cover the box `x` x `y` of map coordinates (the reference system of
    /// the files' affine transform or ground control points: longitude and latitude for
    /// Sentinel-1's), every scene on the same grid.
    Map {
        /// `[x0, x1]`.
        x: [f64; 2],
        /// `[y0, y1]`.
        y: [f64; 2],
    },
}

/// Most bytes of one band of a scene's window read at once for a cut ([`Scenes::band_rows`]).
pub const BAND_BYTES: usize = 64 << 20;

/// Coregistered scenes of one format: the same window of each is one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenes<S> {
    /// The scenes, one sample each.
    pub scenes: Vec<S>,
    /// The window read from each.
    pub window: Window,
    /// For a window given as a map box over ground control points: the order of the
    /// polynomial fitted to them and its largest residual at them (pixels), of the first
    /// scene ([`crate::io::mapping`]).
    pub gcp_fit: Option<(usize, f64)>,
}

impl<S: OpenScene> Scenes<S> {
    /// Opens every file of `paths` and checks `window` against each ([`Scenes::new`]).
    ///
    /// # Errors
    /// A [`StackError`] naming the field (`path` with the file's index, or `window`) and the
    /// file.
    pub fn open(paths: &[PathBuf], window: Option<Place>) -> Result<Scenes<S>, StackError> {
        let scenes = paths
            .iter()
            .enumerate()
            .map(|(i, p)| {
                S::open(p).map_err(|e| StackError {
                    field: "path",
                    index: Some(i),
                    message: e.to_string(),
                })
            })
            .collect::<Result<Vec<S>, _>>()?;
        Scenes::new(scenes, window)
    }
}

impl<S: Scene> Scenes<S> {
    /// The opened `scenes`, `window` (default: the whole scene, every scene then of one size)
    /// checked against each; a window in map coordinates is the pixels that
    /// cover it in the first scene, which every scene must share.
    ///
    /// # Errors
    /// A [`StackError`] naming the field (`path` with the file's index, or `window`) and the
    /// file.
    pub fn new(scenes: Vec<S>, window: Option<Place>) -> Result<Scenes<S>, StackError> {
        let err = |field, index, message: String| StackError {
            field,
            index,
            message,
        };
        if scenes.is_empty() {
            return Err(err("path", None, "name at least one file".into()));
        }
        let dims = |i: usize| scenes[i].dims();
        let path = |i: usize| scenes[i].path().display();
        let mut gcp_fit = None;
        let window = match window {
            Some(Place::Pixels(w)) => w,
            Some(Place::Map { x, y }) => {
                let pixels = |i: usize| -> Result<MapWindow, StackError> {
                    let georef = scenes[i].georeference().map_err(|m| {
                        err(
                            "window",
                            None,
                            format!("{m}: give the window in pixels (row, col, size)"),
                        )
                    })?;
                    map_window(&georef, x, y)
                        .map_err(|m| err("window", None, format!("{}: {m}", path(i))))
                };
                let first = pixels(0)?;
                gcp_fit = first.fit;
                for i in 1..scenes.len() {
                    if pixels(i)?.window != first.window {
                        return Err(err(
                            "window",
                            None,
                            format!(
                                "the box lies on other pixels of {} than of {}: the scenes are \
                                 not on one grid; give the window in pixels",
                                path(i),
                                path(0)
                            ),
                        ));
                    }
                }
                first.window
            }
            None => {
                if let Some(i) = (0..scenes.len()).find(|&i| dims(i) != dims(0)) {
                    return Err(err(
                        "path",
                        Some(i),
                        format!(
                            "{} is {} x {} where {} is {} x {}: give a window inside every \
                             scene",
                            path(i),
                            dims(i).0,
                            dims(i).1,
                            path(0),
                            dims(0).0,
                            dims(0).1
                        ),
                    ));
                }
                Window::whole(dims(0).0, dims(0).1)
            }
        };
        if window.rows() == 0 || window.cols() == 0 {
            return Err(err(
                "window",
                None,
                "its size must be at least 1 x 1".into(),
            ));
        }
        if let Some(i) = (0..scenes.len()).find(|&i| !window.inside(dims(i).0, dims(i).1)) {
            return Err(err(
                "window",
                None,
                format!(
                    "rows {}..{} x columns {}..{} is outside {} ({} x {})",
                    window.r0,
                    window.r1,
                    window.c0,
                    window.c1,
                    path(i),
                    dims(i).0,
                    dims(i).1
                ),
            ));
        }
        Ok(Scenes {
            scenes,
            window,
            gcp_fit,
        })
    }

    /// `(N, H, W)`: the scenes and the window's size.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.scenes.len(), self.window.rows(), self.window.cols())
    }

    /// Makes every scene's reads calibrated values of `quantity` ([`Scene::calibrate`]).
    ///
    /// # Errors
    /// The first scene's that cannot be, naming its file.
    pub fn calibrate(&mut self, quantity: &str) -> Result<(), String> {
        self.scenes
            .iter_mut()
            .try_for_each(|s| s.calibrate(quantity))
    }

    /// The files, in order.
    pub fn paths(&self) -> Vec<PathBuf> {
        self.scenes.iter().map(|s| s.path().to_path_buf()).collect()
    }

    /// Reads the window of every scene into `out` (`N x H x W` values, sample after sample).
    ///
    /// # Errors
    /// The format's error if a file cannot be read or its data do not decode.
    pub fn read_into(&self, out: &mut [Complex32]) -> Result<(), S::Error> {
        let pixels = self.window.rows() * self.window.cols();
        assert_eq!(out.len(), self.scenes.len() * pixels, "the stack's values");
        for (scene, sample) in self.scenes.iter().zip(out.chunks_exact_mut(pixels.max(1))) {
            scene.read_window(&self.window, sample)?;
        }
        Ok(())
    }

    /// The rows of a band read at once for patches of `patch_rows` rows: the patch's, or the
    /// tallest storage block's of the scenes where taller ([`Scene::block_rows`]), as long as
    /// a band of the window stays within [`BAND_BYTES`] (a file stored in blocks as tall as
    /// the scene is then read a patch's rows at a time, memory bounded whatever its size).
    pub fn band_rows(&self, patch_rows: usize) -> usize {
        let blocks = self.scenes.iter().map(S::block_rows).max().unwrap_or(1);
        let fit = BAND_BYTES / (8 * self.window.cols()).max(1);
        blocks.min(fit).max(patch_rows)
    }

    /// Reads the `patch`-sized patches at `places` (top-left row and column, in the row-major
    /// order of [`super::cut::places`]) of every scene into `out`: sample `p N + t` is scene
    /// `t` at place `p`, the order of `isar-clutter cut`. Consecutive rows of places are one
    /// read of a band of each scene, as tall as the patch or, where taller, as the scenes'
    /// storage blocks ([`Scene::block_rows`]: each compressed block is then inflated once or
    /// twice, not once a row of places), so memory beyond `out` is one band.
    ///
    /// # Errors
    /// The format's error if a file cannot be read or its data do not decode.
    pub fn read_patches(
        &self,
        places: &[(usize, usize)],
        patch: Size2,
        out: &mut [Complex32],
    ) -> Result<(), S::Error> {
        let (n, (ph, pw)) = (self.scenes.len(), (patch.rows, patch.cols));
        let px = ph * pw;
        assert_eq!(out.len(), places.len() * n * px, "the patches' values");
        let tall = self.band_rows(ph);
        let mut i = 0;
        while i < places.len() {
            let r = places[i].0;
            let j = i + places[i..]
                .iter()
                .take_while(|p| p.0 + ph <= r + tall)
                .count();
            let c0 = places[i..j].iter().map(|p| p.1).min().expect("a place");
            let c1 = places[i..j].iter().map(|p| p.1).max().expect("a place") + pw;
            let r1 = places[i..j].iter().map(|p| p.0).max().expect("a place") + ph;
            let band = Window::at(r, c0, r1 - r, c1 - c0);
            let mut buf = vec![Complex32::default(); band.rows() * band.cols()];
            for (t, scene) in self.scenes.iter().enumerate() {
                scene.read_window(&band, &mut buf)?;
                for (p, &(pr, c)) in (i..j).zip(&places[i..j]) {
                    let dst = &mut out[(p * n + t) * px..][..px];
                    for (row, d) in dst.chunks_exact_mut(pw).enumerate() {
                        let at = (pr - r + row) * band.cols() + c - c0;
                        d.copy_from_slice(&buf[at..][..pw]);
                    }
                }
            }
            i = j;
        }
        Ok(())
    }

    /// The places of the patches `o` cuts from the window ([`super::cut::masked_places`] in
    /// the first scene, the window this stack's).
    ///
    /// # Errors
    /// As there, naming the first scene's file.
    pub fn cut_places(&self, o: &super::cut::CutOptions) -> anyhow::Result<Vec<(usize, usize)>> {
        let within = super::cut::CutOptions {
            window: Some(self.window),
            ..o.clone()
        };
        let first = &self.scenes[0];
        super::cut::masked_places(first.dims(), &within, first.path())
    }

    /// The pixel vertices `[row, column]` of the polygon `vertices` (`[x, y]` in map
    /// coordinates) through every scene's georeferencing, which must agree (scenes on one
    /// grid).
    ///
    /// # Errors
    /// A scene without georeferencing (naming it), a georeferencing that maps nothing, or
    /// scenes that put the polygon on different pixels.
    pub fn map_polygon(&self, vertices: &[[f64; 2]]) -> Result<Vec<[f64; 2]>, String> {
        let mut first: Option<Vec<[f64; 2]>> = None;
        for s in &self.scenes {
            let g = s
                .georeference()
                .map_err(|m| format!("{m}: give the polygon in pixels"))?;
            let (pixels, _) =
                map_points(&g, vertices).map_err(|m| format!("{}: {m}", s.path().display()))?;
            match &first {
                None => first = Some(pixels),
                Some(f) => {
                    let apart = f
                        .iter()
                        .zip(&pixels)
                        .any(|(a, b)| (a[0] - b[0]).abs() > 1e-6 || (a[1] - b[1]).abs() > 1e-6);
                    if apart {
                        return Err(format!(
                            "the polygon lies on other pixels of {} than of {}: the scenes are \
                             not on one grid; give the polygon in pixels",
                            s.path().display(),
                            self.scenes[0].path().display()
                        ));
                    }
                }
            }
        }
        Ok(first.unwrap_or_default())
    }

    /// What the manifest records: the window and each file's description.
    pub fn describe(&self) -> serde_json::Value {
        let w = &self.window;
        let mut window = serde_json::json!({"rows": [w.r0, w.r1], "cols": [w.c0, w.c1]});
        if let Some((order, residual)) = self.gcp_fit {
            window["gcp_fit"] = serde_json::json!({
                "order": order,
                "max_residual_pixels": residual,
            });
        }
        serde_json::json!({
            "window": window,
            "files": self.scenes.iter().map(S::describe).collect::<Vec<_>>(),
        })
    }
}

/// What a cut of scene files takes beyond a cut's pixel options: a window and a polygon in
/// the scenes' map coordinates (`isar-clutter cut --map-box`, `--map-polygon`), turned into
/// pixels through their georeferencing, and the quantity to calibrate to (`--calibration`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneOptions {
    /// The box `x` x `y` ([`Place::Map`]), instead of the options' pixel window.
    pub window: Option<([f64; 2], [f64; 2])>,
    /// The vertices `[x, y]` of a region patches must lie inside, instead of the options'
    /// pixel polygon.
    pub polygon: Option<Vec<[f64; 2]>>,
    /// Calibrate the values to this quantity with the files' scale factors
    /// ([`Scene::calibrate`]).
    pub calibration: Option<String>,
}

/// Cuts the scenes `paths` of format `S` (one, or a time stack of coregistered ones) into the
/// complex64 stack `out` as [`super::cut::cut_npy`] cuts an `.npy` scene: the same places,
/// order (sample `p T + t` is scene `t` at place `p`), record and streaming, `chunk` samples a
/// block (rounded to whole places), a band of patch rows of each scene read at a time.
///
/// # Errors
/// Naming the input and the field at fault (a file's format, the window), when no patch
/// fits, or when a file cannot be read or the output written.
pub fn cut_scenes<S: OpenScene + Sync>(
    paths: &[PathBuf],
    out: &Path,
    options: (&super::cut::CutOptions, &SceneOptions),
    chunk: usize,
    progress: impl Fn(usize),
) -> anyhow::Result<super::cut::Cut> {
    let open = |place| Scenes::<S>::open(paths, place);
    cut_opened(open, paths, out, options, chunk, progress)
}

/// [`cut_scenes`] of scenes that `open` opens (with the window it is given) from `paths`: for
/// a format whose scenes a path alone does not name (a dataset in an HDF5 file).
///
/// # Errors
/// As [`cut_scenes`].
pub fn cut_opened<S: Scene + Sync>(
    open: impl FnOnce(Option<Place>) -> Result<Scenes<S>, StackError>,
    paths: &[PathBuf],
    out: &Path,
    (o, map): (&super::cut::CutOptions, &SceneOptions),
    chunk: usize,
    progress: impl Fn(usize),
) -> anyhow::Result<super::cut::Cut> {
    use anyhow::bail;
    let place = match map.window {
        Some((x, y)) => Some(Place::Map { x, y }),
        None => o.window.map(Place::Pixels),
    };
    let mut stack = open(place).map_err(|e| anyhow::anyhow!("--input {e}"))?;
    if let Some(q) = &map.calibration {
        stack
            .calibrate(q)
            .map_err(|e| anyhow::anyhow!("--calibration: {e}"))?;
    }
    let (rows, cols) = stack.scenes[0].dims();
    let mut options = o.clone();
    if map.window.is_some() {
        options.window = Some(stack.window);
    }
    if let Some(v) = &map.polygon {
        let pixels = stack
            .map_polygon(v)
            .map_err(|e| anyhow::anyhow!("--map-polygon: {e}"))?;
        options.polygon = Some(
            super::polygon::Polygon::new(pixels)
                .ok_or_else(|| anyhow::anyhow!("--map-polygon: not a polygon in pixels"))?,
        );
    }
    let o = &options;
    let places = stack.cut_places(o)?;
    let t = stack.scenes.len();
    let samples = places.len() * t;
    let (ph, pw) = (o.patch.rows, o.patch.cols);
    super::cut::check_room(out, samples, o.patch)?;
    let failed = std::sync::Mutex::new(None::<String>);
    let fill = |first: usize, dst: &mut [Complex32]| {
        let p = first / t;
        let n = dst.len() / (ph * pw * t);
        if let Err(e) = stack.read_patches(&places[p..p + n], o.patch, dst) {
            failed
                .lock()
                .expect("not poisoned")
                .get_or_insert(e.to_string());
        }
    };
    // At least the places of one band as tall as the scenes' storage blocks a block, so that
    // a compressed block is inflated once or twice, not once a block of patches.
    let tall = stack.band_rows(ph);
    let first = places.first().map_or(0, |p| p.0);
    let per_band = places
        .iter()
        .take_while(|p| p.0 + ph <= first + tall)
        .count();
    let chunk = (chunk / t).max(1).max(per_band) * t;
    let after = || match failed.lock().expect("not poisoned").take() {
        Some(e) => bail!("{e}"),
        None => Ok(()),
    };
    super::cut::write_patches(out, (samples, o.patch, chunk), fill, progress, after)?;
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let input = (names.join(", "), map.calibration.as_deref());
    let record = super::cut::write_record(out, input, &[t, rows, cols], o, &places)?;
    Ok(super::cut::Cut {
        scenes: t,
        places: places.len(),
        record,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene held in memory whose pixel `(r, c)` is `r + i c` plus `1000 k` (scene `k`),
    /// stored in blocks of the third field's rows.
    #[derive(Debug, Clone, PartialEq)]
    struct Grid(usize, PathBuf, usize);

    impl OpenScene for Grid {
        fn open(path: &Path) -> Result<Grid, String> {
            let k = path
                .to_string_lossy()
                .parse()
                .map_err(|_| "a number".to_string())?;
            Ok(Grid(k, path.to_path_buf(), 1))
        }
    }

    impl Scene for Grid {
        type Error = String;
        fn path(&self) -> &Path {
            &self.1
        }
        fn dims(&self) -> (usize, usize) {
            (20, 30)
        }
        fn read_window(&self, w: &Window, out: &mut [Complex32]) -> Result<(), String> {
            for (i, row) in out.chunks_exact_mut(w.cols()).enumerate() {
                for (j, z) in row.iter_mut().enumerate() {
                    *z = Complex32::new((w.r0 + i + 1000 * self.0) as f32, (w.c0 + j) as f32);
                }
            }
            Ok(())
        }
        fn describe(&self) -> serde_json::Value {
            serde_json::Value::Null
        }
        fn block_rows(&self) -> usize {
            self.2
        }
    }

    #[test]
    fn patches_are_read_place_by_place_scene_by_scene_as_cut_orders_them() {
        let paths: Vec<PathBuf> = ["0", "1", "2"].iter().map(PathBuf::from).collect();
        let s =
            Scenes::<Grid>::open(&paths, Some(Place::Pixels(Window::at(2, 3, 15, 20)))).unwrap();
        let patch = Size2 { rows: 4, cols: 5 };
        let o = super::super::cut::CutOptions {
            patch,
            stride: Size2 { rows: 3, cols: 7 },
            window: Some(s.window),
            avoid: vec![Window::at(8, 10, 1, 1)],
            polygon: None,
            avoid_mask: None,
        };
        let places = super::super::cut::places(20, 30, &o).unwrap();
        // Bands of one row of places, and (blocks of 11 rows in one scene) bands of several
        // overlapping rows of places.
        for blocks in [[1, 1, 1], [1, 11, 2]] {
            let mut s = s.clone();
            for (g, b) in s.scenes.iter_mut().zip(blocks) {
                g.2 = b;
            }
            let mut out = vec![Complex32::default(); places.len() * 3 * 20];
            s.read_patches(&places, patch, &mut out).unwrap();
            // The slow oracle: each sample's pixels by their definition.
            for (p, &(r, c)) in places.iter().enumerate() {
                for t in 0..3 {
                    for i in 0..4 {
                        for j in 0..5 {
                            let want = Complex32::new((r + i + 1000 * t) as f32, (c + j) as f32);
                            assert_eq!(
                                out[((p * 3 + t) * 4 + i) * 5 + j],
                                want,
                                "place {p}, scene {t}, blocks {blocks:?}"
                            );
                        }
                    }
                }
            }
        }
        assert!(places.len() > 6 && !places.contains(&(8, 10)), "{places:?}");
        // A band: the patch's rows, a taller block's, but never more than BAND_BYTES of the
        // window (20 columns of 8 bytes here).
        let mut s = s.clone();
        for (b, want) in [(1, 4), (11, 11), (1 << 40, BAND_BYTES / 160)] {
            s.scenes[1].2 = b;
            assert_eq!(s.band_rows(4), want, "blocks of {b} rows");
        }
    }
}
