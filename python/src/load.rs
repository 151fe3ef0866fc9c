//! The native readers behind `isar_clutter.load`: radar scenes in the field's formats as numpy
//! arrays, checked as the command line's dataset kinds check them (UAVSAR `.slc` stacks:
//! `load_uavsar`, the `uavsar` kind's checks in the core's `io::uavsar`; complex GeoTIFF
//! scenes: `load_geotiff`, the `geotiff` kind's reader in the core's `io::geotiff`; SICD
//! images: `load_sicd`, the core's `io::sicd`).

use isar_clutter_core::io::cut::Window;
use isar_clutter_core::io::geotiff::{GeoTiff, TiffError};
use isar_clutter_core::io::scenes::{OpenScene, Place, Scene, Scenes};
use isar_clutter_core::io::sicd::{Sicd, SicdError};
use isar_clutter_core::io::uavsar::open_stack;
use ndarray::Array3;
use num_complex::Complex32;
use numpy::{IntoPyArray, PyArray3};
use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;

/// load_uavsar(slcs, annotations, window=None, map_box=None)
/// --
///
/// The same window `(row, col, rows, cols)` of every UAVSAR scene in `slcs` (default: the
/// whole scene), or the pixels covering `map_box` `((lon0, lon1), (lat0, lat1))` through the
/// flight line's `.llh` grid (as the `uavsar` kind's map `window`), as a complex64 `[N, H, W]`
/// array, sizes from `annotations` (none: each scene's own; one: for all; else one per
/// scene). A bad file is a `ValueError` naming the field, the scene and the file; an
/// unreadable one an `OSError`.
#[pyfunction]
#[pyo3(signature = (slcs, annotations, window = None, map_box = None))]
pub fn load_uavsar<'py>(
    py: Python<'py>,
    slcs: Vec<PathBuf>,
    annotations: Vec<PathBuf>,
    window: Option<(usize, usize, usize, usize)>,
    map_box: Option<([f64; 2], [f64; 2])>,
) -> PyResult<Bound<'py, PyArray3<Complex32>>> {
    let stack = open_stack(&slcs, &annotations, place(window, map_box)?)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    // The annotations are checked at opening: what fails later is the reading.
    read_stack(py, &stack, "UAVSAR", |_| true)
}

/// load_geotiff(paths, window=None, map_box=None, calibration=None)
/// --
///
/// The same window `(row, col, rows, cols)` of every complex GeoTIFF scene in `paths`
/// (default: the whole scene), or the pixels covering `map_box` `((x0, x1), (y0, y1))` in the
/// files' map coordinates (their affine transform or ground control points, as the `geotiff`
/// kind's map `window`), as a complex64 `[N, H, W]` array, calibrated to `calibration`
/// (`sigma0`, `beta0`, `gamma0`) by each Sentinel-1 measurement's calibration annotation in
/// its SAFE product. A bad file is a `ValueError` naming the field, the scene, the file and
/// the TIFF tag; an unreadable one an `OSError`.
#[pyfunction]
#[pyo3(signature = (paths, window = None, map_box = None, calibration = None))]
pub fn load_geotiff<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    window: Option<(usize, usize, usize, usize)>,
    map_box: Option<([f64; 2], [f64; 2])>,
    calibration: Option<String>,
) -> PyResult<Bound<'py, PyArray3<Complex32>>> {
    let place = place(window, map_box)?;
    load_scenes::<GeoTiff>(py, &paths, place, calibration, "GeoTIFF", |e| {
        matches!(e, TiffError::Io { .. })
    })
}

/// The window in pixels, or the box in map coordinates (not both).
fn place(
    window: Option<(usize, usize, usize, usize)>,
    map_box: Option<([f64; 2], [f64; 2])>,
) -> PyResult<Option<Place>> {
    match (window, map_box) {
        (Some(_), Some(_)) => Err(PyValueError::new_err(
            "window: give the window in pixels (window=) or in map coordinates (map_box=), not \
             both",
        )),
        (None, Some((x, y))) => Ok(Some(Place::Map { x, y })),
        (w, None) => Ok(pixels(w)),
    }
}

/// A window `(row, col, rows, cols)` in pixels.
fn pixels(window: Option<(usize, usize, usize, usize)>) -> Option<Place> {
    window.map(|(row, col, rows, cols)| Place::Pixels(Window::at(row, col, rows, cols)))
}

/// load_sicd(paths, window=None, calibration=None, map_box=None)
/// --
///
/// The same window `(row, col, rows, cols)` of every SICD image in `paths` (default: the whole
/// image), or the pixels covering `map_box` `((lon0, lon1), (lat0, lat1))` through SICD's image
/// projection (at the scene centre's height), as a complex64 `[N, H, W]` array, calibrated to
/// `calibration` (`sigma0`, `beta0`,
/// `gamma0`, `rcs`) with each file's `Radiometric` polynomial where given. A bad file is a
/// `ValueError` naming the field, the image, the file and the NITF field or XML element; an
/// unreadable one an `OSError`.
#[pyfunction]
#[pyo3(signature = (paths, window = None, calibration = None, map_box = None))]
pub fn load_sicd<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    window: Option<(usize, usize, usize, usize)>,
    calibration: Option<String>,
    map_box: Option<([f64; 2], [f64; 2])>,
) -> PyResult<Bound<'py, PyArray3<Complex32>>> {
    let place = place(window, map_box)?;
    load_scenes::<Sicd>(py, &paths, place, calibration, "SICD", |e| {
        matches!(e, SicdError::Io { .. })
    })
}

/// The window of every scene of format `S` in `paths`, calibrated to `calibration` (`what`
/// names the format; `is_io`: an error that is the file's reading, an `OSError`, rather than
/// its content's).
fn load_scenes<'py, S: OpenScene + Sync>(
    py: Python<'py>,
    paths: &[PathBuf],
    window: Option<Place>,
    calibration: Option<String>,
    what: &str,
    is_io: fn(&S::Error) -> bool,
) -> PyResult<Bound<'py, PyArray3<Complex32>>>
where
    S::Error: Send,
{
    let mut stack =
        Scenes::<S>::open(paths, window).map_err(|e| PyValueError::new_err(e.to_string()))?;
    if let Some(q) = &calibration {
        stack
            .calibrate(q)
            .map_err(|m| PyValueError::new_err(format!("calibration: {m}")))?;
    }
    read_stack(py, &stack, what, is_io)
}

/// The window of every scene of `stack` as a complex64 `[N, H, W]` array, read with the GIL
/// released (`what` names the format; `is_io` as for [`load_scenes`]).
fn read_stack<'py, S: Scene + Sync>(
    py: Python<'py>,
    stack: &Scenes<S>,
    what: &str,
    is_io: fn(&S::Error) -> bool,
) -> PyResult<Bound<'py, PyArray3<Complex32>>>
where
    S::Error: Send,
{
    let mut out: Array3<Complex32> =
        isar_clutter_core::alloc::try_zeros(stack.shape(), &format!("the {what} stack"))
            .map_err(|e| PyMemoryError::new_err(e.to_string()))?;
    let values = out.as_slice_mut().expect("standard layout");
    py.detach(|| stack.read_into(values)).map_err(|e| {
        if is_io(&e) {
            PyOSError::new_err(e.to_string())
        } else {
            PyValueError::new_err(e.to_string())
        }
    })?;
    Ok(out.into_pyarray(py))
}
