//! Pure-Rust reader for NetCDF-3 files (the "classic" CDF-1 format and the
//! "64-bit offset" CDF-2 format), used to load gridded geophysical fields
//! (winds, sea state, ...) that drive the clutter model without any binding to
//! the NetCDF C library.
//!
//! The whole file is read into memory once; the big-endian header (numrecs,
//! dimensions, global attributes, variables) is parsed and validated by
//! [`NcFile::open`], and variables are decoded on demand by
//! [`NcFile::read_f64`], which applies `scale_factor` / `add_offset` and maps
//! `_FillValue` / `missing_value` to NaN. Record variables (whose first
//! dimension is the unlimited one) are de-interleaved record by record.
//! CDF-5 (64-bit data, "CDF\x05") files are refused with
//! [`NcError::UnsupportedVersion`]; HDF5-based NetCDF-4 files are refused with
//! [`NcError::BadMagic`], whose message says how to convert them (`nccopy -k
//! classic`), as it says to decompress a gzip-compressed file. Malformed or
//! truncated files give an [`NcError`] naming the file, never a panic.
//!
//! [`NcFile::read_stack`] reads a variable as a stack of images `[samples,
//! rows, cols]`: the first dimension is the samples (time), the last two the
//! image, and dimensions of length 1 between them are dropped, so OSCAR's
//! `u(time, depth, latitude, longitude)` with its single depth is a stack.

use std::path::{Path, PathBuf};

use ndarray::{Array3, ArrayD, IxDyn};

mod header;
pub mod time;
mod types;

use header::{parse_header, Raw};
pub use types::{AttrValue, Dimension, NcError, NcType, Variable};

/// An open NetCDF-3 file: parsed header plus the file's bytes.
#[derive(Debug, Clone)]
pub struct NcFile {
    path: PathBuf,
    version: u8,
    numrecs: usize,
    dims: Vec<Dimension>,
    gattrs: Vec<(String, AttrValue)>,
    vars: Vec<Variable>,
    /// Bytes between two consecutive records.
    recsize: u64,
    bytes: Vec<u8>,
}

impl NcFile {
    /// Reads and parses a NetCDF-3 file (CDF-1 or CDF-2). The whole file is
    /// kept in memory. Fails on I/O errors, wrong magic, CDF-5, malformed or
    /// truncated headers, and on variables whose data would lie beyond the end
    /// of the file.
    pub fn open(path: &Path) -> Result<NcFile, NcError> {
        let bytes = std::fs::read(path).map_err(|cause| NcError::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        Self::from_bytes(path, bytes)
    }

    /// Parses a NetCDF-3 file already in memory; `path` is only used in error
    /// messages and by [`NcFile::path`].
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<NcFile, NcError> {
        let (version, numrecs, dims, gattrs, vars, recsize) = parse_header(path, &bytes)?;
        let file = NcFile {
            path: path.to_path_buf(),
            version,
            numrecs,
            dims,
            gattrs,
            vars,
            recsize,
            bytes,
        };
        for v in &file.vars {
            file.check_extent(v)?;
        }
        Ok(file)
    }

    /// Path the file was opened from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Format version: 1 (classic) or 2 (64-bit offset).
    pub fn version(&self) -> u8 {
        self.version
    }

    /// Number of records (length of the unlimited dimension). For files
    /// written in streaming mode (numrecs = 0xFFFFFFFF) it is computed from
    /// the file size.
    pub fn numrecs(&self) -> usize {
        self.numrecs
    }

    /// All dimensions, in file order (variables refer to them by index).
    pub fn dimensions(&self) -> &[Dimension] {
        &self.dims
    }

    /// All variables, in file order.
    pub fn variables(&self) -> &[Variable] {
        &self.vars
    }

    /// Global attributes, in file order.
    pub fn global_attrs(&self) -> &[(String, AttrValue)] {
        &self.gattrs
    }

    /// The variable with this exact name, if any.
    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.vars.iter().find(|v| v.name == name)
    }

    /// The variable `name`, or [`NcError::VariableNotFound`] naming the file.
    fn required(&self, name: &str) -> Result<&Variable, NcError> {
        self.variable(name)
            .ok_or_else(|| NcError::VariableNotFound {
                path: self.path.clone(),
                name: name.to_string(),
            })
    }

    /// Shape of a variable, slowest-varying first; the record dimension has
    /// length [`NcFile::numrecs`]. A scalar variable has an empty shape.
    pub fn shape(&self, var: &Variable) -> Vec<usize> {
        var.dims
            .iter()
            .map(|&d| {
                let dim = &self.dims[d];
                if dim.unlimited {
                    self.numrecs
                } else {
                    dim.len
                }
            })
            .collect()
    }

    /// Attribute `name` of variable `var`, or a global attribute when `var`
    /// is `None`. `None` when the variable or attribute does not exist.
    pub fn attr(&self, var: Option<&str>, name: &str) -> Option<&AttrValue> {
        let list = match var {
            Some(v) => &self.variable(v)?.attrs,
            None => &self.gattrs,
        };
        list.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }

    /// Whole variable as f64 in C order, with `scale_factor`/`add_offset` applied if present, and values equal to `_FillValue` or `missing_value` (compared in the stored type, before scaling) turned into NaN.
    ///
    /// Details: every value of a multi-valued `missing_value` counts as
    /// missing; fill/missing attributes of another numeric type are converted
    /// to the variable's type before comparing (values that do not fit are
    /// ignored). The NetCDF default fill values are *not* treated as missing
    /// unless declared by one of these attributes; `valid_range`/`_Unsigned`
    /// are not interpreted. The result is `value * scale_factor + add_offset`
    /// (each defaulting to 1 and 0). NC_CHAR variables give
    /// [`NcError::NotNumeric`].
    pub fn read_f64(&self, name: &str) -> Result<ArrayD<f64>, NcError> {
        let var = self.required(name)?;
        let shape = self.shape(var);
        let raw = self.read_raw(var)?;

        let missing: Vec<f64> = ["_FillValue", "missing_value"]
            .iter()
            .filter_map(|a| var.attr(a))
            .filter_map(|a| a.as_f64_vec())
            .flatten()
            .collect();
        let scale = var
            .attr("scale_factor")
            .and_then(|a| a.as_f64_vec())
            .and_then(|v| v.first().copied())
            .unwrap_or(1.0);
        let offset = var
            .attr("add_offset")
            .and_then(|a| a.as_f64_vec())
            .and_then(|v| v.first().copied())
            .unwrap_or(0.0);
        let tr = |x: f64| x * scale + offset;

        // Compare in the stored type: convert each missing value to it.
        fn int_missing<T: TryFrom<i64> + PartialEq + Copy>(m: &[f64]) -> Vec<T> {
            m.iter()
                .filter(|x| x.fract() == 0.0 && x.is_finite())
                .filter_map(|&x| T::try_from(x as i64).ok())
                .collect()
        }
        // Missing values compared in the stored type, the rest scaled.
        fn decode<T: Copy + PartialEq + Into<f64>>(
            v: &[T],
            missing: &[T],
            tr: impl Fn(f64) -> f64,
        ) -> Vec<f64> {
            v.iter()
                .map(|x| {
                    if missing.contains(x) {
                        f64::NAN
                    } else {
                        tr((*x).into())
                    }
                })
                .collect()
        }
        let data: Vec<f64> = match raw {
            Raw::Bytes(v) => decode(&v, &int_missing::<i8>(&missing), tr),
            Raw::Shorts(v) => decode(&v, &int_missing::<i16>(&missing), tr),
            Raw::Ints(v) => decode(&v, &int_missing::<i32>(&missing), tr),
            Raw::Floats(v) => {
                let m: Vec<f32> = missing.iter().map(|&x| x as f32).collect();
                decode(&v, &m, tr)
            }
            Raw::Doubles(v) => decode(&v, &missing, tr),
        };
        ArrayD::from_shape_vec(IxDyn(&shape), data).map_err(|e| NcError::BadHeader {
            path: self.path.clone(),
            offset: 0,
            msg: format!("variable {name:?}: shape {shape:?} inconsistent with data: {e}"),
        })
    }

    /// The shape `(samples, rows, cols)` of variable `name` read as an image stack by
    /// [`NcFile::read_stack`]: its first dimension gives the samples (time), its last two the
    /// rows and columns, and every dimension between them must have length 1 (it is dropped:
    /// OSCAR's `u(time, depth, latitude, longitude)` with one depth is `(time, latitude,
    /// longitude)`).
    ///
    /// # Errors
    /// [`NcError::VariableNotFound`]; [`NcError::NotAStack`] for fewer than 3 dimensions;
    /// [`NcError::ExtraDimension`] naming the first dimension between the first and the last
    /// two whose length is not 1.
    pub fn stack_shape(&self, name: &str) -> Result<(usize, usize, usize), NcError> {
        let var = self.required(name)?;
        let shape = self.shape(var);
        let k = shape.len();
        if k < 3 {
            return Err(NcError::NotAStack {
                path: self.path.clone(),
                var: name.to_string(),
                shape,
            });
        }
        if let Some(m) = (1..k - 2).find(|&m| shape[m] != 1) {
            return Err(NcError::ExtraDimension {
                path: self.path.clone(),
                var: name.to_string(),
                dim: self.dims[var.dims[m]].name.clone(),
                len: shape[m],
                shape,
            });
        }
        Ok((shape[0], shape[k - 2], shape[k - 1]))
    }

    /// Variable `name` as an image stack `[samples, rows, cols]`, decoded as by
    /// [`NcFile::read_f64`] (packing applied, fill and missing values NaN, NaN kept) with the
    /// dimensions of length 1 between the first and the last two dropped
    /// ([`NcFile::stack_shape`]).
    ///
    /// # Errors
    /// Those of [`NcFile::stack_shape`] and [`NcFile::read_f64`].
    pub fn read_stack(&self, name: &str) -> Result<Array3<f64>, NcError> {
        let (n, h, w) = self.stack_shape(name)?;
        let a = self.read_f64(name)?;
        let shape = a.shape().to_vec();
        a.into_shape_with_order((n, h, w))
            .map_err(|e| NcError::BadHeader {
                path: self.path.clone(),
                offset: 0,
                msg: format!("variable {name:?}: shape {shape:?} is not a stack: {e}"),
            })
    }

    /// Number of values in one record (record variables) or in the whole
    /// variable (fixed variables), computed from the dimensions.
    fn slab_len(&self, var: &Variable) -> Option<u64> {
        let skip = usize::from(var.is_record);
        var.dims[skip..]
            .iter()
            .try_fold(1u64, |acc, &d| acc.checked_mul(self.dims[d].len as u64))
    }

    /// Checks that all of the variable's data lies within the file.
    fn check_extent(&self, var: &Variable) -> Result<(), NcError> {
        let overflow = || NcError::BadHeader {
            path: self.path.clone(),
            offset: 0,
            msg: format!("size of variable {:?} overflows", var.name),
        };
        let slab = self
            .slab_len(var)
            .and_then(|n| n.checked_mul(var.nc_type.size() as u64))
            .ok_or_else(overflow)?;
        let nrec = if var.is_record {
            self.numrecs as u64
        } else {
            1
        };
        if nrec == 0 || slab == 0 {
            // Nothing to read: `begin` may legitimately point at the end of file.
            return Ok(());
        }
        let end = (nrec - 1)
            .checked_mul(self.recsize)
            .and_then(|x| x.checked_add(var.begin))
            .and_then(|x| x.checked_add(slab))
            .ok_or_else(overflow)?;
        if end > self.bytes.len() as u64 {
            return Err(NcError::DataBeyondEof {
                path: self.path.clone(),
                var: var.name.clone(),
                end,
                file_len: self.bytes.len() as u64,
            });
        }
        Ok(())
    }

    /// The raw bytes of the variable, concatenated over records.
    fn raw_bytes(&self, var: &Variable) -> Result<Vec<u8>, NcError> {
        self.check_extent(var)?;
        // check_extent keeps every slice below inside the file; the sizes are still computed
        // with checked arithmetic, so that a header can never make them wrap.
        let overflow = || NcError::BadHeader {
            path: self.path.clone(),
            offset: 0,
            msg: format!("size of variable {:?} overflows", var.name),
        };
        let slab = self
            .slab_len(var)
            .and_then(|n| n.checked_mul(var.nc_type.size() as u64))
            .and_then(|n| usize::try_from(n).ok())
            .ok_or_else(overflow)?;
        let nrec = if var.is_record { self.numrecs } else { 1 };
        if slab == 0 {
            return Ok(Vec::new());
        }
        let mut out = Vec::with_capacity(slab.checked_mul(nrec).ok_or_else(overflow)?);
        for r in 0..nrec {
            let start = (r as u64)
                .checked_mul(self.recsize)
                .and_then(|x| x.checked_add(var.begin))
                .and_then(|x| usize::try_from(x).ok())
                .ok_or_else(overflow)?;
            out.extend_from_slice(&self.bytes[start..start + slab]);
        }
        Ok(out)
    }

    fn read_raw(&self, var: &Variable) -> Result<Raw, NcError> {
        Raw::decode(var.nc_type, &self.raw_bytes(var)?).ok_or_else(|| NcError::NotNumeric {
            path: self.path.clone(),
            var: var.name.clone(),
        })
    }
}
#[cfg(test)]
mod oscar_tests;
#[cfg(test)]
mod tests;
