//! Reading the stack a Python caller passes: a 3-D numpy array of complex64, complex128,
//! float32 or float64, `[N, H, W]` (or `[H, W, N]` with `layout="hwn"`), borrowed without a
//! copy and checked (finite values, at least two samples) before the core sees it; every
//! refusal is a Python exception naming the argument.

use isar_clutter_core::io::npy::{nhw_view, widen};
use isar_clutter_core::stats::analysis::{analyse, Analysis, Sample};
use ndarray::{ArrayView3, Axis};
use num_complex::{Complex32, Complex64};
use numpy::{PyReadonlyArray3, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyTypeError, PyValueError};
use pyo3::prelude::*;

/// A borrowed stack of one of the element types the analysis reads.
pub enum Stack<'py> {
    /// complex64.
    C64(PyReadonlyArray3<'py, Complex32>),
    /// complex128.
    C128(PyReadonlyArray3<'py, Complex64>),
    /// float32.
    F32(PyReadonlyArray3<'py, f32>),
    /// float64.
    F64(PyReadonlyArray3<'py, f64>),
}

/// The stack `obj` as the argument `name`: a numpy array of 3 dimensions and a supported
/// dtype.
///
/// # Errors
/// `TypeError` naming `name` for anything else (another type, dtype or number of dimensions).
pub fn stack<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Stack<'py>> {
    let Ok(arr) = obj.cast::<PyUntypedArray>() else {
        return Err(PyTypeError::new_err(format!(
            "{name} must be a numpy array, not {}",
            obj.get_type().name()?
        )));
    };
    if arr.ndim() != 3 {
        return Err(PyTypeError::new_err(format!(
            "{name} must have 3 dimensions ([samples, height, width]), not {} (shape {:?})",
            arr.ndim(),
            arr.shape()
        )));
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray3<Complex32>>() {
        return Ok(Stack::C64(a));
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray3<Complex64>>() {
        return Ok(Stack::C128(a));
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray3<f32>>() {
        return Ok(Stack::F32(a));
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray3<f64>>() {
        return Ok(Stack::F64(a));
    }
    Err(PyTypeError::new_err(format!(
        "{name} must be complex64, complex128, float32 or float64, not {}",
        arr.dtype().str()?
    )))
}

/// Whether `layout` is `[H, W, N]`.
///
/// # Errors
/// `ValueError` for a layout other than `nhw` and `hwn`.
pub fn is_hwn(layout: &str) -> PyResult<bool> {
    match layout {
        "nhw" => Ok(false),
        "hwn" => Ok(true),
        other => Err(PyValueError::new_err(format!(
            "layout must be \"nhw\" or \"hwn\", not {other:?}"
        ))),
    }
}

/// Checks that every value of `a` is finite and that there are at least two samples.
fn check<T: Sample>(a: ArrayView3<'_, T>, name: &str) -> PyResult<()> {
    if a.len_of(Axis(0)) < 2 {
        return Err(PyValueError::new_err(format!(
            "{name} needs at least 2 samples, has {} (shape [samples, height, width] = {:?})",
            a.len_of(Axis(0)),
            a.shape()
        )));
    }
    if let Some((i, _)) = a
        .indexed_iter()
        .find(|(_, v)| !T::components(**v).iter().all(|c| c.is_finite()))
    {
        return Err(PyValueError::new_err(format!(
            "{name} holds a NaN or infinite value at index {:?} ([sample, row, column])",
            [i.0, i.1, i.2]
        )));
    }
    Ok(())
}

impl Stack<'_> {
    /// Runs `f` on the checked view in `[N, H, W]` order, whatever the element type.
    fn with<R>(&self, hwn: bool, name: &str, f: impl WithView<R>) -> PyResult<R> {
        match self {
            Stack::C64(a) => f.call(checked(a.as_array(), hwn, name)?),
            Stack::C128(a) => f.call(checked(a.as_array(), hwn, name)?),
            Stack::F32(a) => f.call(checked(a.as_array(), hwn, name)?),
            Stack::F64(a) => f.call(checked(a.as_array(), hwn, name)?),
        }
    }

    /// The multiscale analysis of the stack to `levels` levels, with the GIL released.
    ///
    /// # Errors
    /// `ValueError` naming `name` for a stack the analysis refuses (too small for the levels).
    pub fn analyse(
        &self,
        py: Python<'_>,
        hwn: bool,
        levels: usize,
        name: &str,
    ) -> PyResult<Analysis> {
        struct Analyse<'a>(Python<'a>, usize);
        impl WithView<Result<Analysis, String>> for Analyse<'_> {
            fn call<T: Sample>(self, a: ArrayView3<'_, T>) -> PyResult<Result<Analysis, String>> {
                let levels = self.1;
                Ok(self
                    .0
                    .detach(|| analyse(a, levels).map_err(|e| e.to_string())))
            }
        }
        self.with(hwn, name, Analyse(py, levels))?
            .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))
    }

    /// The stack as complex128 `[N, H, W]` (a copy; the full-covariance fit needs it).
    ///
    /// # Errors
    /// As [`Stack::analyse`]'s checks; `MemoryError` naming `name` if the copy does not fit.
    pub fn to_complex128(&self, hwn: bool, name: &str) -> PyResult<ndarray::Array3<Complex64>> {
        struct Widen<'a>(&'a str);
        impl WithView<ndarray::Array3<Complex64>> for Widen<'_> {
            fn call<T: Sample>(self, a: ArrayView3<'_, T>) -> PyResult<ndarray::Array3<Complex64>> {
                widen(a).map_err(|e| PyMemoryError::new_err(format!("{}: {e}", self.0)))
            }
        }
        self.with(hwn, name, Widen(name))
    }
}

/// The view in `[N, H, W]` order, checked.
fn checked<'a, T: Sample>(
    a: ArrayView3<'a, T>,
    hwn: bool,
    name: &str,
) -> PyResult<ArrayView3<'a, T>> {
    let a = nhw_view(a, hwn);
    check(a, name)?;
    Ok(a)
}

/// Something to do with a stack view of any element type (a generic closure).
trait WithView<R> {
    /// Does it.
    fn call<T: Sample>(self, a: ArrayView3<'_, T>) -> PyResult<R>;
}
