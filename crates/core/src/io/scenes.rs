//! A stack of coregistered radar scenes read in one window (the `geotiff` and `sicd` dataset
//! kinds and `isar_clutter.load`): any file format that opens a scene, knows its size and
//! reads a window of it as complex64 ([`Scene`]) makes a clutter stack of one sample per
//! scene ([`Scenes`]), or of one sample per patch and scene when the window is cut into
//! patches ([`Scenes::read_patches`]), its files and window checked at opening with errors
//! that name the field, the scene and the file ([`StackError`]).

use super::cut::{Size2, Window};
use num_complex::Complex32;
use std::path::{Path, PathBuf};

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

/// One scene of a file format: opened and checked, then read a window at a time.
pub trait Scene: Sized {
    /// Why a scene cannot be opened or read.
    type Error: std::fmt::Display;
    /// Opens and checks the scene in `path`.
    ///
    /// # Errors
    /// Naming the file and the field of the format at fault.
    fn open(path: &Path) -> Result<Self, Self::Error>;
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
}

/// Coregistered scenes of one format: the same window of each is one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenes<S> {
    /// The scenes, one sample each.
    pub scenes: Vec<S>,
    /// The window read from each.
    pub window: Window,
}

impl<S: Scene> Scenes<S> {
    /// Opens every file of `paths` and checks `window` (default: the whole scene, every scene
    /// then of one size) against each.
    ///
    /// # Errors
    /// A [`StackError`] naming the field (`path` with the file's index, or `window`) and the
    /// file.
    pub fn open(paths: &[PathBuf], window: Option<Window>) -> Result<Scenes<S>, StackError> {
        let err = |field, index, message: String| StackError {
            field,
            index,
            message,
        };
        if paths.is_empty() {
            return Err(err("path", None, "name at least one file".into()));
        }
        let scenes = paths
            .iter()
            .enumerate()
            .map(|(i, p)| S::open(p).map_err(|e| err("path", Some(i), e.to_string())))
            .collect::<Result<Vec<S>, _>>()?;
        let dims = |i: usize| scenes[i].dims();
        let window = match window {
            Some(w) => w,
            None => {
                if let Some(i) = (0..scenes.len()).find(|&i| dims(i) != dims(0)) {
                    return Err(err(
                        "path",
                        Some(i),
                        format!(
                            "{} is {} x {} where {} is {} x {}: give a window inside every \
                             scene",
                            paths[i].display(),
                            dims(i).0,
                            dims(i).1,
                            paths[0].display(),
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
                    paths[i].display(),
                    dims(i).0,
                    dims(i).1
                ),
            ));
        }
        Ok(Scenes { scenes, window })
    }

    /// `(N, H, W)`: the scenes and the window's size.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.scenes.len(), self.window.rows(), self.window.cols())
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

    /// Reads the `patch`-sized patches at `places` (top-left row and column, in the row-major
    /// order of [`super::cut::places`]) of every scene into `out`: sample `p N + t` is scene
    /// `t` at place `p`, the order of `isar-clutter cut`. Each row of places is one read of a
    /// band of `patch.rows` rows of each scene, so memory beyond `out` is one band.
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
        let mut i = 0;
        while i < places.len() {
            let r = places[i].0;
            let j = i + places[i..].iter().take_while(|p| p.0 == r).count();
            let c0 = places[i..j].iter().map(|p| p.1).min().expect("a place");
            let c1 = places[i..j].iter().map(|p| p.1).max().expect("a place") + pw;
            let band = Window::at(r, c0, ph, c1 - c0);
            let mut buf = vec![Complex32::default(); ph * band.cols()];
            for (t, scene) in self.scenes.iter().enumerate() {
                scene.read_window(&band, &mut buf)?;
                for (p, &(_, c)) in (i..j).zip(&places[i..j]) {
                    let dst = &mut out[(p * n + t) * px..][..px];
                    for (row, d) in dst.chunks_exact_mut(pw).enumerate() {
                        d.copy_from_slice(&buf[row * band.cols() + c - c0..][..pw]);
                    }
                }
            }
            i = j;
        }
        Ok(())
    }

    /// What the manifest records: the window and each file's description.
    pub fn describe(&self) -> serde_json::Value {
        let w = &self.window;
        serde_json::json!({
            "window": {"rows": [w.r0, w.r1], "cols": [w.c0, w.c1]},
            "files": self.scenes.iter().map(S::describe).collect::<Vec<_>>(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene held in memory whose pixel `(r, c)` is `r + i c` plus `1000 k` (scene `k`).
    #[derive(Debug, Clone, PartialEq)]
    struct Grid(usize, PathBuf);

    impl Scene for Grid {
        type Error = String;
        fn open(path: &Path) -> Result<Grid, String> {
            let k = path
                .to_string_lossy()
                .parse()
                .map_err(|_| "a number".to_string())?;
            Ok(Grid(k, path.to_path_buf()))
        }
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
    }

    #[test]
    fn patches_are_read_place_by_place_scene_by_scene_as_cut_orders_them() {
        let paths: Vec<PathBuf> = ["0", "1", "2"].iter().map(PathBuf::from).collect();
        let s = Scenes::<Grid>::open(&paths, Some(Window::at(2, 3, 15, 20))).unwrap();
        let patch = Size2 { rows: 4, cols: 5 };
        let o = super::super::cut::CutOptions {
            patch,
            stride: Size2 { rows: 3, cols: 7 },
            window: Some(s.window),
            avoid: vec![Window::at(8, 10, 1, 1)],
            avoid_mask: None,
        };
        let places = super::super::cut::places(20, 30, &o).unwrap();
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
                            "place {p}, scene {t}"
                        );
                    }
                }
            }
        }
        assert!(places.len() > 6 && !places.contains(&(8, 10)), "{places:?}");
    }
}
