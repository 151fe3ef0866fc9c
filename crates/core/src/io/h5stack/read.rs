//! The HDF5 side of [`super::H5Stack`] (the `mat73` feature): the checks of a stack's dataset
//! and the read of its samples, one hyperslab each, converted by libhdf5 to `f64`.

use super::types::{Form, H5Stack, OpenError};
use crate::io::mat::v73::{is_number, Parts};
use hdf5_metno::types::{CompoundField, CompoundType, TypeDescriptor};
use hdf5_metno::H5Type;
use ndarray::{s, Array2, Array3};
use num_complex::Complex64;
use std::path::Path;

/// A compound of two `f64` with the field names `$re`, `$im`, read from a file's complex
/// compound of those names (libhdf5 converts the numbers' widths); MATLAB's `{real, imag}`
/// is the MAT v7.3 reader's [`Parts`].
macro_rules! pair_type {
    ($name:ident, $re:literal, $im:literal) => {
        #[doc = concat!("A complex value as the compound `{", $re, ", ", $im, "}` holds it.")]
        #[derive(Debug, Clone, Copy, Default, PartialEq)]
        #[repr(C)]
        struct $name {
            re: f64,
            im: f64,
        }

        // SAFETY: the descriptor is the struct's `repr(C)` layout: two f64 at 0 and 8.
        unsafe impl H5Type for $name {
            fn type_descriptor() -> TypeDescriptor {
                TypeDescriptor::Compound(CompoundType {
                    fields: vec![
                        CompoundField::typed::<f64>($re, 0, 0),
                        CompoundField::typed::<f64>($im, 8, 1),
                    ],
                    size: 16,
                })
            }
        }
    };
}

pair_type!(PairRI, "r", "i");
pair_type!(PairReIm, "re", "im");

/// The field names of the complex compounds read.
const COMPOUND_NAMES: [(&str, &str); 3] = [("r", "i"), ("real", "imag"), ("re", "im")];

/// What a failed HDF5 call says.
fn h5(e: hdf5_metno::Error) -> String {
    e.to_string()
}

/// See [`H5Stack::open`].
pub(super) fn open(
    path: &Path,
    dataset: &str,
    imag: Option<&str>,
    hwn: bool,
) -> Result<H5Stack, OpenError> {
    let at = |what: String| format!("{}: {what}", path.display());
    let file = hdf5_metno::File::open(path).map_err(|e| {
        (
            "path",
            at(format!(
                "libhdf5 cannot open it (not HDF5, or truncated?): {}",
                h5(e)
            )),
        )
    })?;
    let (form, dims, scene) = shape_of(&file, dataset).map_err(|e| ("dataset", at(e)))?;
    if let Some(im) = imag {
        let (f, d, _) = shape_of(&file, im).map_err(|e| ("imag", at(e)))?;
        if form != Form::Real || f != Form::Real {
            return Err((
                "imag",
                at(format!(
                    "with `imag` {im:?}, {dataset:?} and {im:?} must both hold real numbers"
                )),
            ));
        }
        if d != dims {
            return Err((
                "imag",
                at(format!(
                    "{im:?} has dimensions {d:?}, {dataset:?} {dims:?}: the real and imaginary \
                     parts must have one shape"
                )),
            ));
        }
    }
    Ok(H5Stack {
        path: path.to_path_buf(),
        dataset: dataset.to_string(),
        imag: imag.map(str::to_string),
        form,
        dims,
        hwn,
        scene,
    })
}

/// Sample `k` of `ds` (samples last with `hwn`) as `[H, W]` elements of type `T`.
fn sample<T: H5Type>(
    ds: &hdf5_metno::Dataset,
    k: usize,
    hwn: bool,
) -> hdf5_metno::Result<Array2<T>> {
    if hwn {
        ds.read_slice(s![.., .., k])
    } else {
        ds.read_slice(s![k, .., ..])
    }
}

/// Sample `k` of the compound dataset `ds` of element type `T`, as complex values.
fn compound<T: H5Type + Copy>(
    ds: &hdf5_metno::Dataset,
    k: usize,
    hwn: bool,
    parts: impl Fn(T) -> Complex64,
) -> hdf5_metno::Result<Array2<Complex64>> {
    Ok(sample::<T>(ds, k, hwn)?.mapv(parts))
}

/// See [`H5Stack::read_into`].
pub(super) fn read_into(st: &H5Stack, out: &mut [Complex64]) -> Result<(), String> {
    let (n, h, w) = st.shape();
    assert_eq!(out.len(), n * h * w, "the stack's values");
    let at = |e: hdf5_metno::Error| format!("dataset {:?}: {}", st.dataset, h5(e));
    let file = hdf5_metno::File::open(&st.path).map_err(at)?;
    let ds = file.dataset(&st.dataset).map_err(at)?;
    let imag = match &st.imag {
        Some(name) => Some(file.dataset(name).map_err(at)?),
        None => None,
    };
    let hwn = st.hwn;
    for (k, sample_out) in out.chunks_exact_mut((h * w).max(1)).enumerate().take(n) {
        let values: Array2<Complex64> = match st.form {
            Form::Compound(0) => compound(&ds, k, hwn, |p: PairRI| Complex64::new(p.re, p.im)),
            Form::Compound(1) => {
                compound(&ds, k, hwn, |p: Parts<f64>| Complex64::new(p.real, p.imag))
            }
            Form::Compound(_) => compound(&ds, k, hwn, |p: PairReIm| Complex64::new(p.re, p.im)),
            Form::Real => {
                let re = sample::<f64>(&ds, k, hwn).map_err(at)?;
                match &imag {
                    Some(im) => {
                        let im = sample::<f64>(im, k, hwn).map_err(at)?;
                        Ok(ndarray::Zip::from(&re)
                            .and(&im)
                            .map_collect(|&a, &b| Complex64::new(a, b)))
                    }
                    None => Ok(re.mapv(|a| Complex64::new(a, 0.0))),
                }
            }
            Form::Pairs => {
                let p: hdf5_metno::Result<Array3<f64>> = if hwn {
                    ds.read_slice(s![.., .., k, ..])
                } else {
                    ds.read_slice(s![k, .., .., ..])
                };
                p.map(|p| {
                    Array2::from_shape_fn((h, w), |(r, c)| {
                        Complex64::new(p[[r, c, 0]], p[[r, c, 1]])
                    })
                })
            }
        }
        .map_err(at)?;
        for (o, v) in sample_out.iter_mut().zip(values.iter()) {
            *o = *v;
        }
    }
    Ok(())
}

/// The form and stored dimensions of the stack `name` in `file`, and whether it is a single
/// scene `[H, W]` (dimensions `[1, H, W]`).
fn shape_of(file: &hdf5_metno::File, name: &str) -> Result<(Form, [usize; 3], bool), String> {
    let ds = file.dataset(name).map_err(|_| {
        let members = file.member_names().unwrap_or_default();
        format!(
            "no dataset {name:?} (the file's top level holds: {}; give the full path, as \
             /group/dataset)",
            if members.is_empty() {
                "nothing".to_string()
            } else {
                members.join(", ")
            }
        )
    })?;
    let t = ds
        .dtype()
        .and_then(|t| t.to_descriptor())
        .map_err(|e| format!("{name:?}: an unreadable element type: {}", h5(e)))?;
    let shape = ds.shape();
    let form = match &t {
        TypeDescriptor::Compound(c) => {
            let names: Vec<&str> = c.fields.iter().map(|f| f.name.as_str()).collect();
            let i = COMPOUND_NAMES
                .iter()
                .position(|(re, im)| names == [*re, *im])
                .filter(|_| c.fields.iter().all(|f| is_number(&f.ty)));
            Form::Compound(i.ok_or_else(|| {
                format!(
                    "{name:?} holds a compound of {}; complex data are a compound of two \
                     numbers named r and i, real and imag, or re and im",
                    names.join(", ")
                )
            })?)
        }
        t if is_number(t) && shape.len() == 4 && shape[3] == 2 => Form::Pairs,
        t if is_number(t) => Form::Real,
        t => return Err(format!("{name:?} holds {t}, not numbers")),
    };
    let dims: Vec<usize> = match form {
        Form::Pairs => shape[..3].to_vec(),
        _ => shape.clone(),
    };
    if let [h, w] = dims[..] {
        return Ok((form, [1, h, w], true));
    }
    let dims: [usize; 3] = dims.try_into().map_err(|_| {
        format!(
            "{name:?} has dimensions {shape:?}: a stack is [N, H, W] (or [H, W, N]; float pairs \
             [N, H, W, 2]), a scene [H, W]"
        )
    })?;
    Ok((form, dims, false))
}

/// See [`H5Stack::read_window`].
pub(super) fn read_window(
    st: &H5Stack,
    win: &crate::io::cut::Window,
    out: &mut [num_complex::Complex32],
) -> Result<(), String> {
    assert_eq!(out.len(), win.rows() * win.cols(), "the window's values");
    let at = |e: hdf5_metno::Error| format!("dataset {:?}: {}", st.dataset, h5(e));
    let file = hdf5_metno::File::open(&st.path).map_err(at)?;
    let ds = file.dataset(&st.dataset).map_err(at)?;
    let slab = s![win.r0..win.r1, win.c0..win.c1];
    let values: Array2<Complex64> = match st.form {
        Form::Compound(0) => ds
            .read_slice::<PairRI, _, _>(slab)
            .map(|a| a.mapv(|p| Complex64::new(p.re, p.im))),
        Form::Compound(1) => ds
            .read_slice::<Parts<f64>, _, _>(slab)
            .map(|a| a.mapv(|p| Complex64::new(p.real, p.imag))),
        Form::Compound(_) => ds
            .read_slice::<PairReIm, _, _>(slab)
            .map(|a| a.mapv(|p| Complex64::new(p.re, p.im))),
        Form::Real | Form::Pairs => {
            let re: Array2<f64> = ds.read_slice(slab).map_err(at)?;
            match &st.imag {
                Some(name) => {
                    let im: Array2<f64> = file
                        .dataset(name)
                        .and_then(|d| d.read_slice(slab))
                        .map_err(at)?;
                    Ok(ndarray::Zip::from(&re)
                        .and(&im)
                        .map_collect(|&a, &b| Complex64::new(a, b)))
                }
                None => Ok(re.mapv(|a| Complex64::new(a, 0.0))),
            }
        }
    }
    .map_err(at)?;
    for (o, v) in out.iter_mut().zip(values.iter()) {
        *o = num_complex::Complex32::new(v.re as f32, v.im as f32);
    }
    Ok(())
}
