//! The HDF5 side of [`super::H5Stack`] (the `mat73` feature): the checks of a stack's dataset
//! and the read of its samples: a contiguous, unfiltered dataset whose elements are complex64,
//! complex128 or real floats byte for byte is mapped as a `.npy` file's data is; any other is
//! read in blocks of whole chunks, in single precision where its numbers fit.

use super::chunks;
use super::product::{ancestors, h5};
use super::types::{Form, H5Stack, OpenError, Storage};
use crate::io::mat::v73::{is_number, Parts};
use crate::io::npy::{Dtype, NpyHeader, Stack};
use hdf5_metno::plist::dataset_create::Layout;
use hdf5_metno::types::{CompoundField, CompoundType, TypeDescriptor};
use hdf5_metno::Conversion;
use hdf5_metno::H5Type;
use ndarray::{s, Array2, Array3, Array4, ArrayViewMut3, Axis};
use num_complex::{Complex, Complex32, Complex64};
use std::ops::Range;
use std::path::Path;

/// A compound of two numbers of type `F` with the field names `$re`, `$im`: the memory type
/// a file's complex compound of those names is read as (libhdf5 converts other widths);
/// MATLAB's `{real, imag}` is the MAT v7.3 reader's [`Parts`].
macro_rules! pair_type {
    ($name:ident, $re:literal, $im:literal) => {
        #[doc = concat!("A complex value as the compound `{", $re, ", ", $im, "}` holds it.")]
        #[derive(Debug, Clone, Copy, Default, PartialEq)]
        #[repr(C)]
        struct $name<F> {
            re: F,
            im: F,
        }

        // SAFETY: the descriptor is the struct's `repr(C)` layout: two `F`, at 0 and
        // `size_of::<F>()`.
        unsafe impl<F: H5Type> H5Type for $name<F> {
            fn type_descriptor() -> TypeDescriptor {
                let size = std::mem::size_of::<F>();
                TypeDescriptor::Compound(CompoundType {
                    fields: vec![
                        CompoundField::typed::<F>($re, 0, 0),
                        CompoundField::typed::<F>($im, size, 1),
                    ],
                    size: 2 * size,
                })
            }
        }

        // SAFETY: two `F: Pod` side by side in `repr(C)`: no padding, all-zero bytes valid.
        unsafe impl<F: bytemuck::Zeroable> bytemuck::Zeroable for $name<F> {}
        // SAFETY: as above.
        unsafe impl<F: bytemuck::Pod> bytemuck::Pod for $name<F> {}
    };
}

pair_type!(PairRI, "r", "i");
pair_type!(PairReIm, "re", "im");

/// The field names of the complex compounds read.
const COMPOUND_NAMES: [(&str, &str); 3] = [("r", "i"), ("real", "imag"), ("re", "im")];

/// The georeference of a single scene: affine from the coordinate vectors beside it
/// ([`super::coords`]), else its NISAR product's geolocation grid ([`super::geolocation`]);
/// and what it came from, in words.
pub(super) fn scene_georeference(
    st: &H5Stack,
) -> Result<(crate::io::mapping::Georeference, String), String> {
    let at = |what: String| format!("{}: {what}", st.path.display());
    let file = hdf5_metno::File::open(&st.path).map_err(|e| at(h5(e)))?;
    let group = &ancestors(&st.dataset)[0];
    let g = file.group(group).map_err(|e| at(h5(e)))?;
    for (xn, yn) in super::coords::NAMES {
        let (Ok(x), Ok(y)) = (g.dataset(xn), g.dataset(yn)) else {
            continue;
        };
        let read = |d: hdf5_metno::Dataset, n: &str| {
            d.read_raw::<f64>()
                .map_err(|e| at(format!("{group}/{n}: {}", h5(e))))
        };
        let (x, y) = (read(x, xn)?, read(y, yn)?);
        let a = super::coords::affine(&x, &y, (st.dims[1], st.dims[2]))
            .map_err(|m| at(format!("{}: {m}", st.dataset)))?;
        let by = format!("coordinate vectors {group}/{xn}, {group}/{yn}");
        return Ok((crate::io::mapping::Georeference::Affine(a), by));
    }
    if let Some((nodes, by)) = super::geolocation::nisar_grid(st)? {
        return Ok((crate::io::mapping::Georeference::Nodes(Box::new(nodes)), by));
    }
    Err(at(format!(
        "{} has no coordinate vectors beside it in {group} (x_coordinates/y_coordinates, \
         xCoordinates/yCoordinates or x/y: its column and row centres) and no group above it \
         holds NISAR's metadata/geolocationGrid",
        st.dataset
    )))
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
    let ds = file.dataset(dataset).map_err(|e| ("dataset", at(h5(e))))?;
    let storage = storage(&ds, form, imag.is_some()).map_err(|e| ("dataset", at(e)))?;
    // The image rows' axis: the first of a scene, the second of a stack `[N, H, W]`, the
    // first of `[H, W, N]`.
    let row_axis = usize::from(!scene && !hwn);
    let chunk_rows = ds
        .chunk()
        .map_or(1, |c| c.get(row_axis).copied().unwrap_or(1).max(1));
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
        storage,
        chunk_rows,
        scene,
    })
}

/// Bytes of stack values read per hyperslab (rounded to whole chunks of samples): few calls
/// into libhdf5 (a hyperslab a sample cost ~0.4 ms, 13 s for 32,768 samples of 64 x 64) and a
/// bounded buffer beside the stack.
const BLOCK_BYTES: usize = 32 << 20;

/// Samples `k` of `ds` (samples last with `hwn`) as `[B, H, W]` elements of type `T`.
fn slab<T: H5Type>(
    ds: &hdf5_metno::Dataset,
    k: Range<usize>,
    hwn: bool,
) -> hdf5_metno::Result<Array3<T>> {
    if hwn {
        ds.read_slice(s![.., .., k])
            .map(|a: Array3<T>| a.permuted_axes([2, 0, 1]))
    } else {
        ds.read_slice(s![k, .., ..])
    }
}

/// The stored element is one of `.npy`'s types byte for byte (libhdf5 reads it into that
/// memory type without a conversion): which, for `form` (real data with a separate
/// imaginary dataset never is).
fn native_dtype(ds: &hdf5_metno::Dataset, form: Form, imag: bool) -> Option<Dtype> {
    let t = ds.dtype().ok()?;
    let same = |c: Option<Conversion>| c == Some(Conversion::NoOp);
    let pick = |single: Option<Conversion>, double: Option<Conversion>, dtypes: [Dtype; 2]| {
        if same(single) {
            Some(dtypes[0])
        } else if same(double) {
            Some(dtypes[1])
        } else {
            None
        }
    };
    let complex = [Dtype::Complex64, Dtype::Complex128];
    match form {
        Form::Compound(0) => pick(
            t.conv_to::<PairRI<f32>>(),
            t.conv_to::<PairRI<f64>>(),
            complex,
        ),
        Form::Compound(1) => pick(
            t.conv_to::<Parts<f32>>(),
            t.conv_to::<Parts<f64>>(),
            complex,
        ),
        Form::Compound(_) => pick(
            t.conv_to::<PairReIm<f32>>(),
            t.conv_to::<PairReIm<f64>>(),
            complex,
        ),
        Form::Pairs => pick(t.conv_to::<f32>(), t.conv_to::<f64>(), complex),
        Form::Real if !imag => pick(
            t.conv_to::<f32>(),
            t.conv_to::<f64>(),
            [Dtype::Float32, Dtype::Float64],
        ),
        Form::Real => None,
    }
}

/// Whether every number of the element type `t` fits a `f32` exactly (floats of 4 bytes or
/// fewer, integers of 2 bytes or fewer): such a stack is read in single precision.
fn single(t: &TypeDescriptor) -> bool {
    use hdf5_metno::types::{FloatSize, IntSize};
    match t {
        TypeDescriptor::Float(FloatSize::U8) => false,
        TypeDescriptor::Float(_) => true,
        TypeDescriptor::Integer(s) | TypeDescriptor::Unsigned(s) => {
            matches!(s, IntSize::U1 | IntSize::U2)
        }
        TypeDescriptor::Compound(c) => c.fields.iter().all(|f| single(&f.ty)),
        _ => false,
    }
}

/// How `ds` (of `form`, with a separate imaginary dataset or not) is brought into memory:
/// mapped where it is contiguous, unfiltered, in the file itself and of an `.npy` element
/// type byte for byte; else read in the precision its numbers need.
fn storage(ds: &hdf5_metno::Dataset, form: Form, imag: bool) -> Result<Storage, String> {
    let plain = ds.layout() == Layout::Contiguous
        && ds.filters().is_empty()
        && ds.dcpl().map(|p| p.external().is_empty()).unwrap_or(false);
    if let (true, Some(offset), Some(dtype)) = (plain, ds.offset(), native_dtype(ds, form, imag)) {
        return Ok(Storage::Mapped { offset, dtype });
    }
    let element = ds
        .dtype()
        .and_then(|t| t.to_descriptor())
        .map_err(|e| format!("an unreadable element type: {}", h5(e)))?;
    Ok(if single(&element) {
        Storage::Single
    } else {
        Storage::Double
    })
}

/// See [`H5Stack::load`].
pub(super) fn load(st: &H5Stack) -> Result<Stack, String> {
    if let Storage::Mapped { offset, dtype } = st.storage {
        let header = NpyHeader {
            data_offset: usize::try_from(offset).map_err(|e| e.to_string())?,
            dtype,
            fortran_order: false,
            shape: st.dims.to_vec(),
        };
        return Stack::map_at(&st.path, header).map_err(|e| e.to_string());
    }
    let at = |e: hdf5_metno::Error| format!("dataset {:?}: {}", st.dataset, h5(e));
    let file = hdf5_metno::File::open(&st.path).map_err(at)?;
    let ds = file.dataset(&st.dataset).map_err(at)?;
    let imag = match &st.imag {
        Some(name) => Some(file.dataset(name).map_err(at)?),
        None => None,
    };
    let plan = match (st.hwn, &imag, native_dtype(&ds, st.form, false)) {
        (false, None, Some(dtype)) => chunks::plan(&ds, dtype, st.form == Form::Pairs),
        _ => None,
    };
    let sets = (&ds, imag.as_ref(), st);
    let alloc = |e: crate::alloc::AllocError| e.to_string();
    if st.storage == Storage::Single {
        let mut out = crate::alloc::try_zeros(st.shape(), "the hdf5 stack").map_err(alloc)?;
        read_into::<f32>(sets, plan.as_ref(), &mut out)?;
        Ok(Stack::Single(out))
    } else {
        let mut out = crate::alloc::try_zeros(st.shape(), "the hdf5 stack").map_err(alloc)?;
        read_into::<f64>(sets, plan.as_ref(), &mut out)?;
        Ok(Stack::Generated(out))
    }
}

/// The stack into `out` (`[N, H, W]`) as numbers of type `F`: plain chunks of complex values
/// inflated on every core, straight into place (`plan`); other complex values stored `[N, H,
/// W]` in one libhdf5 read (each chunk copied into place, or converted); the rest in blocks
/// of whole chunks of samples, so that no chunk is inflated twice.
fn read_into<F>(
    (ds, imag, st): (&hdf5_metno::Dataset, Option<&hdf5_metno::Dataset>, &H5Stack),
    plan: Option<&chunks::ChunkPlan>,
    out: &mut Array3<Complex<F>>,
) -> Result<(), String>
where
    F: H5Type + Copy + Default + bytemuck::Pod,
    Complex<F>: bytemuck::Pod,
{
    let slice = out.as_slice_mut().expect("standard layout");
    if let Some(plan) = plan {
        return plan.read(&st.path, bytemuck::cast_slice_mut(slice));
    }
    let at = |e: hdf5_metno::Error| format!("dataset {:?}: {}", st.dataset, h5(e));
    if !st.hwn && matches!(st.form, Form::Compound(_) | Form::Pairs) {
        return read_whole(ds, st.form, slice).map_err(at);
    }
    let (n, h, w) = st.shape();
    let chunk = ds
        .chunk()
        .map_or(1, |c| c[if st.hwn { 2 } else { 0 }])
        .max(1);
    let per = (BLOCK_BYTES / (16 * h * w).max(1)).max(1).div_ceil(chunk) * chunk;
    for k in (0..n).step_by(per).map(|k| k..(k + per).min(n)) {
        read_block((ds, imag, st), k.clone(), out.slice_mut(s![k, .., ..])).map_err(at)?;
    }
    Ok(())
}

/// The whole dataset `ds` of complex values (`form`: a compound or float pairs), stored
/// `[N, H, W]`, read into `out` in one call, as numbers of type `F`.
fn read_whole<F: H5Type + bytemuck::Pod>(
    ds: &hdf5_metno::Dataset,
    form: Form,
    out: &mut [Complex<F>],
) -> hdf5_metno::Result<()>
where
    Complex<F>: bytemuck::Pod,
{
    let r = ds.as_reader();
    let n = match form {
        Form::Compound(0) => r.read_into_raw(bytemuck::cast_slice_mut::<_, PairRI<F>>(out))?,
        Form::Compound(1) => r.read_into_raw(bytemuck::cast_slice_mut::<_, Parts<F>>(out))?,
        Form::Compound(_) => r.read_into_raw(bytemuck::cast_slice_mut::<_, PairReIm<F>>(out))?,
        Form::Pairs => r.read_into_raw(bytemuck::cast_slice_mut::<_, F>(out))? / 2,
        Form::Real => unreachable!("real data are read a block at a time"),
    };
    debug_assert_eq!(n, out.len());
    Ok(())
}

/// Samples `k` of the stack into `out` (`[B, H, W]`), read as numbers of type `F`.
fn read_block<F: H5Type + Copy + Default>(
    (ds, imag, st): (&hdf5_metno::Dataset, Option<&hdf5_metno::Dataset>, &H5Stack),
    k: Range<usize>,
    mut out: ArrayViewMut3<Complex<F>>,
) -> hdf5_metno::Result<()> {
    let hwn = st.hwn;
    let zero = F::default();
    match st.form {
        Form::Compound(0) => out.zip_mut_with(&slab::<PairRI<F>>(ds, k, hwn)?, |o, p| {
            *o = Complex::new(p.re, p.im)
        }),
        Form::Compound(1) => out.zip_mut_with(&slab::<Parts<F>>(ds, k, hwn)?, |o, p| {
            *o = Complex::new(p.real, p.imag)
        }),
        Form::Compound(_) => out.zip_mut_with(&slab::<PairReIm<F>>(ds, k, hwn)?, |o, p| {
            *o = Complex::new(p.re, p.im)
        }),
        Form::Real => {
            out.zip_mut_with(&slab::<F>(ds, k.clone(), hwn)?, |o, &re| {
                *o = Complex::new(re, zero)
            });
            if let Some(im) = imag {
                out.zip_mut_with(&slab::<F>(im, k, hwn)?, |o, &im| o.im = im);
            }
        }
        Form::Pairs => {
            let p: Array4<F> = if hwn {
                ds.read_slice::<F, _, _>(s![.., .., k, ..])?
                    .permuted_axes([2, 0, 1, 3])
            } else {
                ds.read_slice(s![k, .., .., ..])?
            };
            ndarray::Zip::from(&mut out)
                .and(p.index_axis(Axis(3), 0))
                .and(p.index_axis(Axis(3), 1))
                .for_each(|o, &re, &im| *o = Complex::new(re, im));
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
    out: &mut [Complex32],
) -> Result<(), String> {
    assert_eq!(out.len(), win.rows() * win.cols(), "the window's values");
    let at = |e: hdf5_metno::Error| format!("dataset {:?}: {}", st.dataset, h5(e));
    let file = hdf5_metno::File::open(&st.path).map_err(at)?;
    let ds = file.dataset(&st.dataset).map_err(at)?;
    // Plain chunks of complex64: read and inflated on every core, straight into place.
    if st.imag.is_none()
        && matches!(st.form, Form::Compound(_))
        && native_dtype(&ds, st.form, false) == Some(Dtype::Complex64)
    {
        if let Some(done) = chunks::read_scene_window(&ds, &st.path, win, out) {
            return done;
        }
    }
    let slab = s![win.r0..win.r1, win.c0..win.c1];
    let values: Array2<Complex64> = match st.form {
        Form::Compound(0) => ds
            .read_slice::<PairRI<f64>, _, _>(slab)
            .map(|a| a.mapv(|p| Complex64::new(p.re, p.im))),
        Form::Compound(1) => ds
            .read_slice::<Parts<f64>, _, _>(slab)
            .map(|a| a.mapv(|p| Complex64::new(p.real, p.imag))),
        Form::Compound(_) => ds
            .read_slice::<PairReIm<f64>, _, _>(slab)
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
        *o = Complex32::new(v.re as f32, v.im as f32);
    }
    Ok(())
}
