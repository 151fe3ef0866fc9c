//! MAT v7.3 files (MATLAB's `save -v7.3`, hdf5storage, h5py in MATLAB's conventions), read and
//! written with libhdf5 through `hdf5-metno` (the cargo feature `mat73`). A v7.3 file is HDF5
//! behind a 512-byte user block whose first 128 bytes are the MAT header; each top-level
//! variable is a dataset (or, for structs and sparse matrices, a group) with a `MATLAB_class`
//! attribute; the dimensions are stored reversed (HDF5 is row-major, MATLAB column-major, so
//! the bytes are the same); complex values are a compound of `real` and `imag`; empty arrays
//! carry `MATLAB_empty` and store their dimensions as data; `#refs#` and `#subsystem#` hold
//! what cells and objects point to and are not variables. Errors are returned as text that
//! [`super::MatFile`] prefixes with the file and the variable; libhdf5's own error printing is
//! silenced by `hdf5-metno`.

use super::format::{Blocks, Part};
use super::variable::{numeric_class, Variable, CLASSES};
use anyhow::{Context, Result};
use hdf5_metno::types::{CompoundField, CompoundType, FixedAscii, TypeDescriptor};
use hdf5_metno::{H5Type, LocationType};
use ndarray::Array3;
use num_complex::{Complex, Complex64};
use std::path::Path;

/// A value's real and imaginary parts as MATLAB stores them: a compound of `real` and `imag`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct Parts<T> {
    /// The real part.
    pub real: T,
    /// The imaginary part.
    pub imag: T,
}

// SAFETY: the descriptor is the struct's `repr(C)` layout: two `T`, at 0 and `size_of::<T>()`.
unsafe impl<T: H5Type> H5Type for Parts<T> {
    fn type_descriptor() -> TypeDescriptor {
        let size = std::mem::size_of::<T>();
        TypeDescriptor::Compound(CompoundType {
            fields: vec![
                CompoundField::typed::<T>("real", 0, 0),
                CompoundField::typed::<T>("imag", size, 1),
            ],
            size: 2 * size,
        })
    }
}

// SAFETY: two `T: Pod` side by side in `repr(C)`: no padding (a type's size is a multiple of
// its alignment), and all-zero bytes are valid.
unsafe impl<T: bytemuck::Zeroable> bytemuck::Zeroable for Parts<T> {}
// SAFETY: as above.
unsafe impl<T: bytemuck::Pod> bytemuck::Pod for Parts<T> {}

/// MATLAB's name for a class as a static string (`object` for a class this list lacks, such
/// as `string`, `table` or a user's class).
fn class_name(name: &str) -> &'static str {
    match name {
        "logical" => "uint8",
        n => CLASSES
            .iter()
            .find(|c| **c == n)
            .copied()
            .unwrap_or("object"),
    }
}

/// An open v7.3 file.
pub struct V73File {
    file: hdf5_metno::File,
}

/// What a failed HDF5 call says, in one line.
fn h5(e: hdf5_metno::Error) -> String {
    e.to_string()
}

impl V73File {
    /// Opens `path` (whose header said v7.3) with libhdf5 and lists its variables.
    ///
    /// # Errors
    /// What is wrong, in words (not HDF5, truncated, an unreadable variable).
    pub fn open(path: &Path) -> Result<(V73File, Vec<Variable>), String> {
        let file = hdf5_metno::File::open(path).map_err(|e| {
            format!(
                "a MAT v7.3 header, but libhdf5 cannot open the HDF5 data behind it (truncated \
                 or corrupted?): {}",
                h5(e)
            )
        })?;
        let names = file
            .member_names()
            .map_err(|e| format!("cannot list the variables: {}", h5(e)))?;
        let mut variables = Vec::new();
        for name in names.into_iter().filter(|n| !n.starts_with('#')) {
            let v = variable(&file, &name).map_err(|e| format!("variable {name:?}: {e}"))?;
            variables.push(v);
        }
        Ok((V73File { file }, variables))
    }

    /// Reads the data of the numeric variable `v` into `data`, column-major.
    ///
    /// # Errors
    /// What is malformed, in words.
    pub fn read(&self, v: &Variable, data: &mut [Complex64]) -> Result<(), String> {
        if data.is_empty() {
            return Ok(());
        }
        let ds = self.file.dataset(&v.name).map_err(h5)?;
        let shape: Vec<usize> = ds.shape().into_iter().rev().collect();
        if shape != v.dims {
            return Err(format!(
                "its data have dimensions {shape:?}, not {:?}",
                v.dims
            ));
        }
        let reader = ds.as_reader();
        match descriptor(&ds)? {
            TypeDescriptor::Compound(c) if is_complex(&c) => {
                let parts: &mut [Parts<f64>] = bytemuck::cast_slice_mut(data);
                reader.read_into_raw(parts).map_err(h5)?;
            }
            TypeDescriptor::Float(_) | TypeDescriptor::Integer(_) | TypeDescriptor::Unsigned(_) => {
                // The real parts are read into the second half of the buffer, then spread
                // forward into place: value `i` takes f64 slots `2i, 2i + 1`, read from slot
                // `n + i` >= `2i + 1`, which no earlier value has overwritten.
                let n = data.len();
                let flat: &mut [f64] = bytemuck::cast_slice_mut(data);
                reader.read_into_raw(&mut flat[n..]).map_err(h5)?;
                for i in 0..n {
                    let re = flat[n + i];
                    flat[2 * i] = re;
                    flat[2 * i + 1] = 0.0;
                }
            }
            t => return Err(format!("its data are stored as {t}, not as numbers")),
        }
        Ok(())
    }
}

/// The element type of a dataset.
fn descriptor(ds: &hdf5_metno::Dataset) -> Result<TypeDescriptor, String> {
    ds.dtype()
        .and_then(|t| t.to_descriptor())
        .map_err(|e| format!("an unreadable data type: {}", h5(e)))
}

/// Whether an element type is a number: an integer or a float (HDF5 stacks read these too).
pub(crate) fn is_number(t: &TypeDescriptor) -> bool {
    matches!(
        t,
        TypeDescriptor::Float(_) | TypeDescriptor::Integer(_) | TypeDescriptor::Unsigned(_)
    )
}

/// Whether a compound type is MATLAB's complex: numeric fields `real` and `imag`.
fn is_complex(c: &CompoundType) -> bool {
    let numeric = |name: &str| c.fields.iter().any(|f| f.name == name && is_number(&f.ty));
    c.fields.len() == 2 && numeric("real") && numeric("imag")
}

/// Whether an element type holds numbers: integers, floats, or MATLAB's complex compound.
fn is_numeric(t: &TypeDescriptor) -> bool {
    match t {
        TypeDescriptor::Compound(c) => is_complex(c),
        t => is_number(t),
    }
}

/// An element type in words: `string (len 4)`, `bool`, `a compound of re, im`.
fn storage(t: &TypeDescriptor) -> String {
    match t {
        TypeDescriptor::Compound(c) => {
            let names: Vec<&str> = c.fields.iter().map(|f| f.name.as_str()).collect();
            format!("a compound of {}", names.join(", "))
        }
        t => t.to_string(),
    }
}

/// A string attribute's value (fixed or variable length, ASCII or UTF-8), `None` if absent.
pub(crate) fn string_attr(
    loc: &hdf5_metno::Location,
    name: &str,
) -> Result<Option<String>, String> {
    if !loc.attr_names().map_err(h5)?.iter().any(|n| n == name) {
        return Ok(None);
    }
    let a = loc.attr(name).map_err(h5)?;
    let t = a
        .dtype()
        .and_then(|t| t.to_descriptor())
        .map_err(|e| format!("attribute {name}: {}", h5(e)))?;
    let text = match t {
        TypeDescriptor::FixedAscii(_) | TypeDescriptor::FixedUnicode(_) => a
            .read_raw::<FixedAscii<64>>()
            .map(|v| v.first().map(|s| s.as_str().to_string())),
        TypeDescriptor::VarLenAscii => a
            .read_raw::<hdf5_metno::types::VarLenAscii>()
            .map(|v| v.first().map(|s| s.as_str().to_string())),
        TypeDescriptor::VarLenUnicode => a
            .read_raw::<hdf5_metno::types::VarLenUnicode>()
            .map(|v| v.first().map(|s| s.as_str().to_string())),
        t => return Err(format!("attribute {name} is {t}, not text")),
    }
    .map_err(|e| format!("attribute {name}: {}", h5(e)))?;
    Ok(Some(text.unwrap_or_default()))
}

/// Whether `loc` has the attribute `name`.
fn has_attr(loc: &hdf5_metno::Location, name: &str) -> Result<bool, String> {
    Ok(loc.attr_names().map_err(h5)?.iter().any(|n| n == name))
}

/// Describes the top-level object `name` as a MATLAB variable.
fn variable(file: &hdf5_metno::File, name: &str) -> Result<Variable, String> {
    let mut v = Variable {
        name: name.to_string(),
        class: "unknown",
        dims: Vec::new(),
        complex: false,
        logical: false,
        stored_as: None,
    };
    match file.loc_type_by_name(name).map_err(h5)? {
        LocationType::Group => {
            let g = file.group(name).map_err(h5)?;
            let class = string_attr(&g, "MATLAB_class")?;
            if has_attr(&g, "MATLAB_sparse")? {
                v.class = "sparse";
                let rows = g
                    .attr("MATLAB_sparse")
                    .and_then(|a| a.read_raw::<u64>())
                    .map_err(h5)?;
                let cols = g.dataset("jc").map_or(0, |jc| jc.size().saturating_sub(1));
                v.dims = vec![rows.first().copied().unwrap_or(0) as usize, cols];
            } else {
                v.class = match class.as_deref() {
                    None | Some("struct") => "struct",
                    Some(_) => "object",
                };
            }
        }
        LocationType::Dataset => {
            let ds = file.dataset(name).map_err(h5)?;
            let t = descriptor(&ds)?;
            v.dims = match ds.shape() {
                s if s.is_empty() => vec![1, 1],
                s => s.into_iter().rev().collect(),
            };
            if let TypeDescriptor::Compound(c) = &t {
                v.complex = is_complex(c);
            }
            let class = string_attr(&ds, "MATLAB_class")?;
            v.class = match class.as_deref() {
                Some(c) => class_name(c),
                None => inferred_class(&t),
            };
            v.logical = class.as_deref() == Some("logical");
            if numeric_class(v.class) && !is_numeric(&t) {
                // A numeric MATLAB_class over strings, booleans or another compound: refused
                // when the variable is listed (at `validate`), not when its data are read.
                v.stored_as = Some(storage(&t));
            }
            if has_attr(&ds, "MATLAB_empty")? {
                // An empty array stores its dimensions as its data.
                v.dims = ds
                    .read_raw::<u64>()
                    .map_err(|e| format!("an empty array without its dimensions: {}", h5(e)))?
                    .into_iter()
                    .map(|d| d as usize)
                    .collect();
                v.complex = false;
            }
        }
        LocationType::NamedDatatype => v.class = "object",
    }
    Ok(v)
}

/// The class of a dataset without a `MATLAB_class` attribute, from its element type.
fn inferred_class(t: &TypeDescriptor) -> &'static str {
    use hdf5_metno::types::{FloatSize, IntSize};
    match t {
        TypeDescriptor::Float(FloatSize::U4) => "single",
        TypeDescriptor::Float(FloatSize::U8) => "double",
        TypeDescriptor::Integer(s) | TypeDescriptor::Unsigned(s) => {
            let signed = matches!(t, TypeDescriptor::Integer(_));
            match (s, signed) {
                (IntSize::U1, true) => "int8",
                (IntSize::U1, false) => "uint8",
                (IntSize::U2, true) => "int16",
                (IntSize::U2, false) => "uint16",
                (IntSize::U4, true) => "int32",
                (IntSize::U4, false) => "uint32",
                (IntSize::U8, true) => "int64",
                (IntSize::U8, false) => "uint64",
            }
        }
        TypeDescriptor::Compound(c) if is_complex(c) => {
            let real = c.fields.iter().find(|f| f.name == "real").expect("checked");
            inferred_class(&real.ty)
        }
        TypeDescriptor::Reference(_) => "cell",
        TypeDescriptor::FixedAscii(_)
        | TypeDescriptor::FixedUnicode(_)
        | TypeDescriptor::VarLenAscii
        | TypeDescriptor::VarLenUnicode => "char",
        _ => "unknown",
    }
}

/// Writes the v7.3 file: an HDF5 file with a 512-byte user block and one contiguous dataset of
/// `Parts<T>`, HDF5 shape `[M, W, H]` (MATLAB's `H x W x M` reversed) with `MATLAB_class`,
/// filled block by block; then the MAT header into the user block. Through a temporary name.
pub(crate) fn write<T: Part, B, P>(path: &Path, name: &str, mut blocks: Blocks<B, P>) -> Result<()>
where
    B: FnMut(usize, usize) -> Result<Array3<Complex<T>>>,
    P: FnMut(usize),
{
    let (h, w, m) = blocks.dims;
    crate::io::atomic::atomic_write_path(path, |tmp| {
        let file = hdf5_metno::File::with_options()
            .with_fcpl(|p| p.userblock(512).obj_track_times(false))
            .create(tmp)
            .context("creating the HDF5 file")?;
        let ds = file
            .new_dataset::<Parts<T>>()
            .shape([m, w, h])
            .create(name)
            .context("creating the dataset")?;
        let class = FixedAscii::<6>::from_ascii(T::CLASS.name().as_bytes())?;
        ds.new_attr::<FixedAscii<6>>()
            .create("MATLAB_class")
            .and_then(|a| a.write_scalar(&class))
            .context("writing MATLAB_class")?;
        blocks.each(|first, count, x| {
            // `Complex<T>` is `Parts<T>` byte for byte: no copy.
            let parts: &[Parts<T>] = bytemuck::cast_slice(x);
            let view = ndarray::ArrayView3::from_shape((count, w, h), parts)?;
            ds.write_slice(view, ndarray::s![first..first + count, .., ..])
                .with_context(|| format!("writing samples {first}..{}", first + count))?;
            Ok(())
        })?;
        drop(ds);
        file.close().context("closing the HDF5 file")?;
        let mut f = std::fs::OpenOptions::new().write(true).open(tmp)?;
        std::io::Write::write_all(
            &mut f,
            &super::format::header(super::format::MatVersion::V73),
        )?;
        Ok(())
    })
    .with_context(|| format!("writing the MAT v7.3 file {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_are_named() {
        assert_eq!(class_name("single"), "single");
        assert_eq!(class_name("logical"), "uint8");
        assert_eq!(class_name("table"), "object");
        let c = |fields: &[(&str, TypeDescriptor)]| CompoundType {
            fields: fields
                .iter()
                .enumerate()
                .map(|(i, (n, t))| CompoundField::new(n, t.clone(), 8 * i, i))
                .collect(),
            size: 8 * fields.len(),
        };
        let f8 = TypeDescriptor::Float(hdf5_metno::types::FloatSize::U8);
        assert!(is_complex(&c(&[
            ("real", f8.clone()),
            ("imag", f8.clone())
        ])));
        assert!(!is_complex(&c(&[("re", f8.clone()), ("im", f8.clone())])));
        assert!(!is_complex(&c(&[
            ("real", f8.clone()),
            ("imag", TypeDescriptor::VarLenAscii)
        ])));
        assert_eq!(
            inferred_class(&TypeDescriptor::Compound(c(&[
                ("real", f8.clone()),
                ("imag", f8)
            ]))),
            "double"
        );
        assert_eq!(
            inferred_class(&TypeDescriptor::Integer(hdf5_metno::types::IntSize::U2)),
            "int16"
        );
    }

    #[test]
    fn parts_are_the_layout_of_complex() {
        let z = [num_complex::Complex64::new(1.5, -2.0)];
        let p: &[Parts<f64>] = bytemuck::cast_slice(&z);
        assert_eq!(
            p[0],
            Parts {
                real: 1.5,
                imag: -2.0
            }
        );
        let TypeDescriptor::Compound(c) = Parts::<f32>::type_descriptor() else {
            panic!("a compound")
        };
        assert_eq!(
            (c.size, c.fields[1].name.as_str(), c.fields[1].offset),
            (8, "imag", 4)
        );
    }
}
