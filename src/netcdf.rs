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
//! [`NcError::BadMagic`]. Malformed or truncated files give an [`NcError`]
//! naming the file, never a panic.

use std::fmt;
use std::path::{Path, PathBuf};

use ndarray::{ArrayD, IxDyn};
use thiserror::Error;

/// Errors from opening or reading a NetCDF-3 file. Every variant names the file.
#[derive(Debug, Error)]
pub enum NcError {
    /// The file could not be read from disk.
    #[error("{path}: cannot read file: {source}")]
    Io {
        /// File concerned.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The file does not start with "CDF" followed by a version byte.
    #[error(
        "{path}: not a NetCDF-3 file (bad magic bytes {found:02x?}, expected \"CDF\\x01\" or \"CDF\\x02\")"
    )]
    BadMagic {
        /// File concerned.
        path: PathBuf,
        /// The first (up to four) bytes found.
        found: Vec<u8>,
    },
    /// A NetCDF magic number with a version this reader does not handle (CDF-5 or unknown).
    #[error(
        "{path}: unsupported NetCDF format version {version} (only CDF-1 classic and CDF-2 64-bit offset are supported)"
    )]
    UnsupportedVersion {
        /// File concerned.
        path: PathBuf,
        /// The version byte found after "CDF".
        version: u8,
    },
    /// The header ends before a field it announces.
    #[error(
        "{path}: truncated header: need {needed} bytes at offset {offset} for {what}, file has {file_len} bytes"
    )]
    TruncatedHeader {
        /// File concerned.
        path: PathBuf,
        /// Byte offset where the field starts.
        offset: u64,
        /// Bytes needed for the field.
        needed: u64,
        /// Total file length.
        file_len: u64,
        /// Which field was being read.
        what: String,
    },
    /// The header is structurally invalid (wrong tag, bad dimension id, size overflow, ...).
    #[error("{path}: malformed header at offset {offset}: {msg}")]
    BadHeader {
        /// File concerned.
        path: PathBuf,
        /// Byte offset of the problem.
        offset: u64,
        /// Description of the problem.
        msg: String,
    },
    /// An `nc_type` code outside NC_BYTE..NC_DOUBLE (1..=6).
    #[error("{path}: unknown nc_type {code} for {context}")]
    UnknownType {
        /// File concerned.
        path: PathBuf,
        /// The type code found.
        code: u32,
        /// Attribute or variable that carries it.
        context: String,
    },
    /// No variable with the requested name.
    #[error("{path}: variable {name:?} not found")]
    VariableNotFound {
        /// File concerned.
        path: PathBuf,
        /// Name asked for.
        name: String,
    },
    /// The variable's data extends past the end of the file.
    #[error(
        "{path}: data of variable {var:?} extends to byte {end}, beyond the end of file ({file_len} bytes)"
    )]
    DataBeyondEof {
        /// File concerned.
        path: PathBuf,
        /// Variable concerned.
        var: String,
        /// One past the last byte the data needs.
        end: u64,
        /// Total file length.
        file_len: u64,
    },
    /// The variable is of type NC_CHAR and cannot be read as numbers.
    #[error("{path}: variable {var:?} is of type NC_CHAR, not numeric")]
    NotNumeric {
        /// File concerned.
        path: PathBuf,
        /// Variable concerned.
        var: String,
    },
}

/// External data types of NetCDF-3 (`nc_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NcType {
    /// NC_BYTE (1): signed 8-bit integer.
    Byte,
    /// NC_CHAR (2): 8-bit character.
    Char,
    /// NC_SHORT (3): signed 16-bit integer.
    Short,
    /// NC_INT (4): signed 32-bit integer.
    Int,
    /// NC_FLOAT (5): IEEE 754 single precision.
    Float,
    /// NC_DOUBLE (6): IEEE 754 double precision.
    Double,
}

impl NcType {
    /// Maps the on-disk code (1..=6) to a type; `None` for anything else
    /// (including the CDF-5 types 7..=11).
    pub fn from_code(code: u32) -> Option<NcType> {
        Some(match code {
            1 => NcType::Byte,
            2 => NcType::Char,
            3 => NcType::Short,
            4 => NcType::Int,
            5 => NcType::Float,
            6 => NcType::Double,
            _ => return None,
        })
    }

    /// The on-disk code of this type.
    pub fn code(self) -> u32 {
        match self {
            NcType::Byte => 1,
            NcType::Char => 2,
            NcType::Short => 3,
            NcType::Int => 4,
            NcType::Float => 5,
            NcType::Double => 6,
        }
    }

    /// Size in bytes of one value.
    pub fn size(self) -> usize {
        match self {
            NcType::Byte | NcType::Char => 1,
            NcType::Short => 2,
            NcType::Int | NcType::Float => 4,
            NcType::Double => 8,
        }
    }
}

impl fmt::Display for NcType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            NcType::Byte => "NC_BYTE",
            NcType::Char => "NC_CHAR",
            NcType::Short => "NC_SHORT",
            NcType::Int => "NC_INT",
            NcType::Float => "NC_FLOAT",
            NcType::Double => "NC_DOUBLE",
        };
        f.write_str(s)
    }
}

/// A dimension of the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Dimension {
    /// Dimension name.
    pub name: String,
    /// Length as stored in the header; 0 for the unlimited (record) dimension,
    /// whose current length is [`NcFile::numrecs`].
    pub len: usize,
    /// Whether this is the unlimited (record) dimension.
    pub unlimited: bool,
}

/// Value of an attribute, in its stored type.
#[derive(Debug, Clone, PartialEq)]
pub enum AttrValue {
    /// NC_CHAR attribute, decoded as UTF-8 (lossily) with trailing NUL bytes removed.
    Text(String),
    /// NC_BYTE values.
    Bytes(Vec<i8>),
    /// NC_SHORT values.
    Shorts(Vec<i16>),
    /// NC_INT values.
    Ints(Vec<i32>),
    /// NC_FLOAT values.
    Floats(Vec<f32>),
    /// NC_DOUBLE values.
    Doubles(Vec<f64>),
}

impl AttrValue {
    /// Numeric values as f64 (`None` for text).
    pub fn as_f64_vec(&self) -> Option<Vec<f64>> {
        Some(match self {
            AttrValue::Text(_) => return None,
            AttrValue::Bytes(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Shorts(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Ints(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Floats(v) => v.iter().map(|&x| f64::from(x)).collect(),
            AttrValue::Doubles(v) => v.clone(),
        })
    }

    /// The text of an NC_CHAR attribute (`None` for numeric ones).
    pub fn as_text(&self) -> Option<&str> {
        match self {
            AttrValue::Text(s) => Some(s),
            _ => None,
        }
    }

    /// The stored type of this attribute.
    pub fn nc_type(&self) -> NcType {
        match self {
            AttrValue::Text(_) => NcType::Char,
            AttrValue::Bytes(_) => NcType::Byte,
            AttrValue::Shorts(_) => NcType::Short,
            AttrValue::Ints(_) => NcType::Int,
            AttrValue::Floats(_) => NcType::Float,
            AttrValue::Doubles(_) => NcType::Double,
        }
    }
}

/// A variable described by the header.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Variable name.
    pub name: String,
    /// Indices into [`NcFile::dimensions`], slowest-varying first.
    pub dims: Vec<usize>,
    /// Variable attributes in file order.
    pub attrs: Vec<(String, AttrValue)>,
    /// Stored type.
    pub nc_type: NcType,
    /// Byte offset of the data (of the first record for record variables).
    pub begin: u64,
    /// `vsize` from the header: bytes of the variable (of one record for a
    /// record variable), rounded up to 4. Informational: the reader recomputes
    /// sizes from the dimensions.
    pub vsize: u64,
    /// Whether the first dimension is the unlimited one.
    pub is_record: bool,
}

impl Variable {
    /// Looks up one of this variable's attributes.
    pub fn attr(&self, name: &str) -> Option<&AttrValue> {
        self.attrs.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }
}

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

const NC_DIMENSION: u32 = 0x0A;
const NC_VARIABLE: u32 = 0x0B;
const NC_ATTRIBUTE: u32 = 0x0C;
const STREAMING: u32 = 0xFFFF_FFFF;

fn pad4(n: u64) -> u64 {
    n.div_ceil(4) * 4
}

/// Cursor over the header bytes that turns every short read into an error.
struct Header<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Header<'a> {
    fn truncated(&self, needed: usize, what: &str) -> NcError {
        NcError::TruncatedHeader {
            path: self.path.to_path_buf(),
            offset: self.pos as u64,
            needed: needed as u64,
            file_len: self.bytes.len() as u64,
            what: what.to_string(),
        }
    }

    fn bad(&self, msg: impl Into<String>) -> NcError {
        NcError::BadHeader {
            path: self.path.to_path_buf(),
            offset: self.pos as u64,
            msg: msg.into(),
        }
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], NcError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| self.truncated(n, what))?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, NcError> {
        let b = self.take(4, what)?;
        Ok(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self, what: &str) -> Result<u64, NcError> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_be_bytes(a))
    }

    /// Element count, checked against the bytes left so that a corrupt count
    /// cannot trigger a huge allocation (`min_each` = minimal bytes per element).
    fn count(&mut self, min_each: usize, what: &str) -> Result<usize, NcError> {
        let n = self.u32(what)? as usize;
        let left = self.bytes.len() - self.pos;
        if n.saturating_mul(min_each) > left {
            return Err(self.truncated(n.saturating_mul(min_each), what));
        }
        Ok(n)
    }

    fn name(&mut self, what: &str) -> Result<String, NcError> {
        let n = self.count(1, what)?;
        let padded = pad4(n as u64) as usize;
        let b = self.take(padded, what)?;
        Ok(String::from_utf8_lossy(&b[..n]).into_owned())
    }

    /// Reads a list header: returns the number of elements, 0 for ABSENT.
    fn list(&mut self, tag: u32, min_each: usize, what: &str) -> Result<usize, NcError> {
        let start = self.pos;
        let t = self.u32(what)?;
        let n = self.count(min_each, what)?;
        if t == 0 {
            if n != 0 {
                self.pos = start;
                return Err(self.bad(format!("{what}: ABSENT tag with non-zero count {n}")));
            }
            return Ok(0);
        }
        if t != tag {
            self.pos = start;
            return Err(self.bad(format!("{what}: expected tag {tag:#x}, found {t:#x}")));
        }
        Ok(n)
    }

    fn attrs(&mut self, context: &str) -> Result<Vec<(String, AttrValue)>, NcError> {
        let what = format!("attribute list of {context}");
        // Minimal attribute: name length + name + type + count = 12 bytes.
        let n = self.list(NC_ATTRIBUTE, 12, &what)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let name = self.name(&format!("attribute name in {context}"))?;
            let ctx = format!("attribute {name:?} of {context}");
            let code = self.u32(&ctx)?;
            let ty = NcType::from_code(code).ok_or_else(|| NcError::UnknownType {
                path: self.path.to_path_buf(),
                code,
                context: ctx.clone(),
            })?;
            let count = self.count(ty.size(), &ctx)?;
            let nbytes = count * ty.size();
            let raw = self.take(pad4(nbytes as u64) as usize, &ctx)?;
            let raw = &raw[..nbytes];
            let value = match Raw::decode(ty, raw) {
                None => {
                    // NC_CHAR.
                    let mut end = raw.len();
                    while end > 0 && raw[end - 1] == 0 {
                        end -= 1;
                    }
                    AttrValue::Text(String::from_utf8_lossy(&raw[..end]).into_owned())
                }
                Some(Raw::Bytes(v)) => AttrValue::Bytes(v),
                Some(Raw::Shorts(v)) => AttrValue::Shorts(v),
                Some(Raw::Ints(v)) => AttrValue::Ints(v),
                Some(Raw::Floats(v)) => AttrValue::Floats(v),
                Some(Raw::Doubles(v)) => AttrValue::Doubles(v),
            };
            out.push((name, value));
        }
        Ok(out)
    }
}

/// Decoded raw values of a variable, in stored type.
enum Raw {
    Bytes(Vec<i8>),
    Shorts(Vec<i16>),
    Ints(Vec<i32>),
    Floats(Vec<f32>),
    Doubles(Vec<f64>),
}

impl Raw {
    /// Decodes big-endian values of a numeric type (`None` for NC_CHAR).
    fn decode(ty: NcType, b: &[u8]) -> Option<Raw> {
        Some(match ty {
            NcType::Char => return None,
            NcType::Byte => Raw::Bytes(b.iter().map(|&x| x as i8).collect()),
            NcType::Short => Raw::Shorts(
                b.chunks_exact(2)
                    .map(|c| i16::from_be_bytes([c[0], c[1]]))
                    .collect(),
            ),
            NcType::Int => Raw::Ints(
                b.chunks_exact(4)
                    .map(|c| i32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                    .collect(),
            ),
            NcType::Float => Raw::Floats(
                b.chunks_exact(4)
                    .map(|c| f32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                    .collect(),
            ),
            NcType::Double => Raw::Doubles(
                b.chunks_exact(8)
                    .map(|c| {
                        let mut a = [0u8; 8];
                        a.copy_from_slice(c);
                        f64::from_be_bytes(a)
                    })
                    .collect(),
            ),
        })
    }
}

impl NcFile {
    /// Reads and parses a NetCDF-3 file (CDF-1 or CDF-2). The whole file is
    /// kept in memory. Fails on I/O errors, wrong magic, CDF-5, malformed or
    /// truncated headers, and on variables whose data would lie beyond the end
    /// of the file.
    pub fn open(path: &Path) -> Result<NcFile, NcError> {
        let bytes = std::fs::read(path).map_err(|source| NcError::Io {
            path: path.to_path_buf(),
            source,
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
        let var = self
            .variable(name)
            .ok_or_else(|| NcError::VariableNotFound {
                path: self.path.clone(),
                name: name.to_string(),
            })?;
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
        // check_extent guarantees every slice below is in range and fits usize.
        let slab = (self.slab_len(var).unwrap_or(0) as usize) * var.nc_type.size();
        let nrec = if var.is_record { self.numrecs } else { 1 };
        if slab == 0 {
            return Ok(Vec::new());
        }
        let mut out = Vec::with_capacity(slab * nrec);
        for r in 0..nrec {
            let start = (var.begin + r as u64 * self.recsize) as usize;
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

type ParsedHeader = (
    u8,
    usize,
    Vec<Dimension>,
    Vec<(String, AttrValue)>,
    Vec<Variable>,
    u64,
);

fn parse_header(path: &Path, bytes: &[u8]) -> Result<ParsedHeader, NcError> {
    if bytes.len() < 4 || &bytes[..3] != b"CDF" {
        return Err(NcError::BadMagic {
            path: path.to_path_buf(),
            found: bytes[..bytes.len().min(4)].to_vec(),
        });
    }
    let version = bytes[3];
    if version != 1 && version != 2 {
        return Err(NcError::UnsupportedVersion {
            path: path.to_path_buf(),
            version,
        });
    }
    let mut h = Header {
        path,
        bytes,
        pos: 4,
    };
    let numrecs_raw = h.u32("numrecs")?;

    // Dimensions: minimal entry = name length (4) + name (0) + length (4).
    let ndims = h.list(NC_DIMENSION, 8, "dimension list")?;
    let mut dims = Vec::with_capacity(ndims);
    for _ in 0..ndims {
        let name = h.name("dimension name")?;
        let len = h.u32(&format!("length of dimension {name:?}"))? as usize;
        dims.push(Dimension {
            name,
            len,
            unlimited: len == 0,
        });
    }
    if dims.iter().filter(|d| d.unlimited).count() > 1 {
        return Err(h.bad("more than one unlimited dimension"));
    }

    let gattrs = h.attrs("global attributes")?;

    // Variables: minimal entry = name (4) + ndims (4) + attr list (8) + type (4) + vsize (4) + begin (4).
    let nvars = h.list(NC_VARIABLE, 28, "variable list")?;
    let mut vars = Vec::with_capacity(nvars);
    for _ in 0..nvars {
        let name = h.name("variable name")?;
        let ctx = format!("variable {name:?}");
        let nd = h.count(4, &format!("number of dimensions of {ctx}"))?;
        let mut vdims = Vec::with_capacity(nd);
        for k in 0..nd {
            let id = h.u32(&format!("dimension id of {ctx}"))? as usize;
            if id >= dims.len() {
                return Err(h.bad(format!(
                    "{ctx}: dimension id {id} out of range ({} dimensions)",
                    dims.len()
                )));
            }
            if k > 0 && dims[id].unlimited {
                return Err(h.bad(format!(
                    "{ctx}: unlimited dimension {:?} is not the first dimension",
                    dims[id].name
                )));
            }
            vdims.push(id);
        }
        let attrs = h.attrs(&ctx)?;
        let code = h.u32(&format!("type of {ctx}"))?;
        let nc_type = NcType::from_code(code).ok_or_else(|| NcError::UnknownType {
            path: path.to_path_buf(),
            code,
            context: ctx.clone(),
        })?;
        let vsize = u64::from(h.u32(&format!("vsize of {ctx}"))?);
        let begin = if version == 1 {
            u64::from(h.u32(&format!("begin of {ctx}"))?)
        } else {
            h.u64(&format!("begin of {ctx}"))?
        };
        let is_record = vdims.first().is_some_and(|&d| dims[d].unlimited);
        vars.push(Variable {
            name,
            dims: vdims,
            attrs,
            nc_type,
            begin,
            vsize,
            is_record,
        });
    }
    let header_end = h.pos as u64;

    // Record size: sum of the padded per-record sizes of all record
    // variables, except that a lone record variable is not padded.
    let rec_sizes: Vec<u64> = vars
        .iter()
        .filter(|v| v.is_record)
        .map(|v| {
            v.dims[1..]
                .iter()
                .try_fold(v.nc_type.size() as u64, |acc, &d| {
                    acc.checked_mul(dims[d].len as u64)
                })
        })
        .collect::<Option<Vec<u64>>>()
        .ok_or_else(|| h.bad("record size overflows"))?;
    let recsize = if rec_sizes.len() == 1 {
        rec_sizes[0]
    } else {
        rec_sizes
            .iter()
            .try_fold(0u64, |acc, &s| acc.checked_add(pad4(s)))
            .ok_or_else(|| h.bad("record size overflows"))?
    };

    let numrecs = if numrecs_raw == STREAMING {
        let first = vars.iter().filter(|v| v.is_record).map(|v| v.begin).min();
        match first {
            Some(b) if recsize > 0 => (bytes.len() as u64).saturating_sub(b) / recsize,
            _ => 0,
        }
    } else {
        u64::from(numrecs_raw)
    };
    let numrecs = usize::try_from(numrecs).map_err(|_| h.bad("numrecs too large"))?;

    // Data that will actually be read must not overlap the header.
    for v in &vars {
        let has_data = (!v.is_record || numrecs > 0)
            && v.dims
                .iter()
                .skip(usize::from(v.is_record))
                .all(|&d| dims[d].len > 0);
        if has_data && v.begin < header_end {
            return Err(NcError::BadHeader {
                path: path.to_path_buf(),
                offset: header_end,
                msg: format!(
                    "variable {:?} begins at {} inside the header (which ends at {header_end})",
                    v.name, v.begin
                ),
            });
        }
    }

    Ok((version, numrecs, dims, gattrs, vars, recsize))
}

#[cfg(test)]
mod tests {
    //! Round trips through a minimal NetCDF-3 writer (test-only), error
    //! handling on damaged files, and cross-checks against scipy on NOAA's
    //! `monthly_navy_winds.cdf` (fixtures made by `tests/netcdf_crosscheck.py`).

    use super::*;
    use std::path::PathBuf;

    // ------------------------------------------------------------------
    // Minimal NetCDF-3 writer, only for tests.
    // ------------------------------------------------------------------

    /// A variable to write: its data (all records, C order) in its type.
    struct WVar {
        name: &'static str,
        dims: Vec<usize>,
        attrs: Vec<(String, AttrValue)>,
        data: AttrValue,
    }

    /// A file to write. A dimension of length 0 is the unlimited one.
    struct WFile {
        version: u8,
        dims: Vec<(&'static str, usize)>,
        numrecs: usize,
        streaming: bool,
        gattrs: Vec<(String, AttrValue)>,
        vars: Vec<WVar>,
    }

    fn be_values(v: &AttrValue) -> Vec<u8> {
        match v {
            AttrValue::Text(s) => s.as_bytes().to_vec(),
            AttrValue::Bytes(x) => x.iter().map(|&b| b as u8).collect(),
            AttrValue::Shorts(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
            AttrValue::Ints(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
            AttrValue::Floats(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
            AttrValue::Doubles(x) => x.iter().flat_map(|b| b.to_be_bytes()).collect(),
        }
    }

    fn put_u32(out: &mut Vec<u8>, x: u32) {
        out.extend_from_slice(&x.to_be_bytes());
    }

    fn put_padded(out: &mut Vec<u8>, b: &[u8]) {
        out.extend_from_slice(b);
        out.resize(out.len() + (pad4(b.len() as u64) as usize - b.len()), 0);
    }

    fn put_name(out: &mut Vec<u8>, s: &str) {
        put_u32(out, s.len() as u32);
        put_padded(out, s.as_bytes());
    }

    fn put_attrs(out: &mut Vec<u8>, attrs: &[(String, AttrValue)]) {
        if attrs.is_empty() {
            put_u32(out, 0);
            put_u32(out, 0);
            return;
        }
        put_u32(out, NC_ATTRIBUTE);
        put_u32(out, attrs.len() as u32);
        for (name, v) in attrs {
            put_name(out, name);
            put_u32(out, v.nc_type().code());
            let b = be_values(v);
            put_u32(out, (b.len() / v.nc_type().size()) as u32);
            put_padded(out, &b);
        }
    }

    impl WFile {
        fn is_record(&self, v: &WVar) -> bool {
            v.dims.first().is_some_and(|&d| self.dims[d].1 == 0)
        }

        /// Bytes of one record (record variables) or of the whole variable.
        fn slab_bytes(&self, v: &WVar) -> usize {
            let skip = usize::from(self.is_record(v));
            v.dims[skip..]
                .iter()
                .map(|&d| self.dims[d].1)
                .product::<usize>()
                * v.data.nc_type().size()
        }

        fn header(&self, begins: &[u64]) -> Vec<u8> {
            let mut out = b"CDF".to_vec();
            out.push(self.version);
            put_u32(
                &mut out,
                if self.streaming {
                    STREAMING
                } else {
                    self.numrecs as u32
                },
            );
            if self.dims.is_empty() {
                put_u32(&mut out, 0);
                put_u32(&mut out, 0);
            } else {
                put_u32(&mut out, NC_DIMENSION);
                put_u32(&mut out, self.dims.len() as u32);
                for (n, l) in &self.dims {
                    put_name(&mut out, n);
                    put_u32(&mut out, *l as u32);
                }
            }
            put_attrs(&mut out, &self.gattrs);
            if self.vars.is_empty() {
                put_u32(&mut out, 0);
                put_u32(&mut out, 0);
            } else {
                put_u32(&mut out, NC_VARIABLE);
                put_u32(&mut out, self.vars.len() as u32);
                for (v, &begin) in self.vars.iter().zip(begins) {
                    put_name(&mut out, v.name);
                    put_u32(&mut out, v.dims.len() as u32);
                    for &d in &v.dims {
                        put_u32(&mut out, d as u32);
                    }
                    put_attrs(&mut out, &v.attrs);
                    put_u32(&mut out, v.data.nc_type().code());
                    put_u32(&mut out, pad4(self.slab_bytes(v) as u64) as u32);
                    if self.version == 1 {
                        put_u32(&mut out, begin as u32);
                    } else {
                        out.extend_from_slice(&begin.to_be_bytes());
                    }
                }
            }
            out
        }

        fn encode(&self) -> Vec<u8> {
            let header_len = self.header(&vec![0; self.vars.len()]).len() as u64;
            let mut begins = vec![0u64; self.vars.len()];
            let mut off = header_len;
            for (k, v) in self.vars.iter().enumerate() {
                if !self.is_record(v) {
                    begins[k] = off;
                    off += pad4(self.slab_bytes(v) as u64);
                }
            }
            let nrecvars = self.vars.iter().filter(|v| self.is_record(v)).count();
            for (k, v) in self.vars.iter().enumerate() {
                if self.is_record(v) {
                    begins[k] = off;
                    off += if nrecvars == 1 {
                        self.slab_bytes(v) as u64
                    } else {
                        pad4(self.slab_bytes(v) as u64)
                    };
                }
            }
            let mut out = self.header(&begins);
            for v in self.vars.iter().filter(|v| !self.is_record(v)) {
                put_padded(&mut out, &be_values(&v.data));
            }
            for r in 0..self.numrecs {
                for v in self.vars.iter().filter(|v| self.is_record(v)) {
                    let n = self.slab_bytes(v);
                    let chunk = &be_values(&v.data)[r * n..(r + 1) * n];
                    if nrecvars == 1 {
                        out.extend_from_slice(chunk);
                    } else {
                        put_padded(&mut out, chunk);
                    }
                }
            }
            out
        }
    }

    fn write_tmp(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    fn s(x: &str) -> String {
        x.to_string()
    }

    fn text(x: &str) -> AttrValue {
        AttrValue::Text(x.to_string())
    }

    /// A file with fixed and record variables of every type, attributes of
    /// every type, fill/missing values and packing.
    fn sample(version: u8) -> WFile {
        // dims: 0 time (unlimited), 1 y = 2, 2 x = 3, 3 odd = 5
        WFile {
            version,
            dims: vec![("time", 0), ("y", 2), ("x", 3), ("odd", 5)],
            numrecs: 3,
            streaming: false,
            gattrs: vec![
                (s("title"), text("test file \u{e9}")),
                (s("gb"), AttrValue::Bytes(vec![-128, 0, 127])),
                (s("gs"), AttrValue::Shorts(vec![-32768, 1, 32767])),
                (s("gi"), AttrValue::Ints(vec![i32::MIN, 7, i32::MAX])),
                (s("gf"), AttrValue::Floats(vec![1.5, -0.25])),
                (s("gd"), AttrValue::Doubles(vec![std::f64::consts::PI])),
                (s("empty"), text("")),
            ],
            vars: vec![
                WVar {
                    name: "b",
                    dims: vec![1, 2],
                    attrs: vec![(s("_FillValue"), AttrValue::Bytes(vec![-127]))],
                    data: AttrValue::Bytes(vec![-128, -127, 0, 1, 2, 127]),
                },
                WVar {
                    name: "c",
                    dims: vec![3],
                    attrs: vec![(s("long_name"), text("chars"))],
                    data: text("hello"),
                },
                WVar {
                    name: "s",
                    dims: vec![2],
                    attrs: vec![
                        (s("scale_factor"), AttrValue::Floats(vec![0.5])),
                        (s("add_offset"), AttrValue::Doubles(vec![10.0])),
                        (s("_FillValue"), AttrValue::Shorts(vec![-32768])),
                    ],
                    data: AttrValue::Shorts(vec![-32768, 4, -4]),
                },
                WVar {
                    name: "i",
                    dims: vec![1, 2],
                    attrs: vec![(s("missing_value"), AttrValue::Ints(vec![-999, -998]))],
                    data: AttrValue::Ints(vec![1, -999, 3, -998, i32::MAX, i32::MIN]),
                },
                WVar {
                    name: "f",
                    dims: vec![3],
                    attrs: vec![
                        (s("_FillValue"), AttrValue::Floats(vec![9.969_21e36])),
                        // Declared as double: compared after conversion to float.
                        (s("missing_value"), AttrValue::Doubles(vec![-99.9])),
                        (s("units"), text("m/s")),
                    ],
                    data: AttrValue::Floats(vec![1.25, 9.969_21e36, -99.9, f32::MIN_POSITIVE, 3.0]),
                },
                WVar {
                    name: "d",
                    dims: vec![1, 2],
                    attrs: vec![(s("_FillValue"), AttrValue::Doubles(vec![-1e30]))],
                    data: AttrValue::Doubles(vec![0.1, -1e30, 1e300, -0.0, 5.5, 6.5]),
                },
                WVar {
                    name: "scalar",
                    dims: vec![],
                    attrs: vec![],
                    data: AttrValue::Doubles(vec![3.25]),
                },
                // Record variables.
                WVar {
                    name: "rb",
                    dims: vec![0, 2],
                    attrs: vec![],
                    data: AttrValue::Bytes(vec![1, 2, 3, 4, 5, 6, 7, 8, -9]),
                },
                WVar {
                    name: "rc",
                    dims: vec![0, 3],
                    attrs: vec![],
                    data: text("abcdefghijklmno"),
                },
                WVar {
                    name: "rs",
                    dims: vec![0],
                    attrs: vec![(s("_FillValue"), AttrValue::Shorts(vec![-1]))],
                    data: AttrValue::Shorts(vec![10, -1, 30]),
                },
                WVar {
                    name: "ri",
                    dims: vec![0, 2],
                    attrs: vec![(s("scale_factor"), AttrValue::Doubles(vec![2.0]))],
                    data: AttrValue::Ints(vec![1, 2, 3, 4, 5, 6, 7, 8, 9]),
                },
                WVar {
                    name: "rf",
                    dims: vec![0, 1, 2],
                    attrs: vec![(s("_FillValue"), AttrValue::Floats(vec![-1.0]))],
                    data: AttrValue::Floats(
                        (0..18)
                            .map(|k| if k == 7 { -1.0 } else { k as f32 * 0.5 })
                            .collect(),
                    ),
                },
                WVar {
                    name: "rd",
                    dims: vec![0],
                    attrs: vec![(s("units"), text("hours since 2000-01-01"))],
                    data: AttrValue::Doubles(vec![0.0, 6.0, 12.0]),
                },
            ],
        }
    }

    fn values(a: &ArrayD<f64>) -> Vec<f64> {
        a.iter().copied().collect()
    }

    /// Equality that treats NaN == NaN and distinguishes nothing else.
    fn same(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(x, y)| (x.is_nan() && y.is_nan()) || x == y)
    }

    fn check_sample(nc: &NcFile) {
        let nan = f64::NAN;
        assert_eq!(nc.numrecs(), 3);
        assert_eq!(nc.dimensions().len(), 4);
        assert!(nc.dimensions()[0].unlimited);
        assert_eq!(
            nc.dimensions()[3],
            Dimension {
                name: s("odd"),
                len: 5,
                unlimited: false
            }
        );
        let w = sample(nc.version());
        assert_eq!(nc.global_attrs(), &w.gattrs[..]);
        assert_eq!(nc.attr(None, "title"), Some(&text("test file \u{e9}")));
        assert_eq!(nc.attr(Some("f"), "units"), Some(&text("m/s")));
        assert_eq!(nc.attr(Some("nope"), "units"), None);
        assert_eq!(nc.attr(Some("f"), "nope"), None);
        for (v, wv) in nc.variables().iter().zip(&w.vars) {
            assert_eq!(v.name, wv.name);
            assert_eq!(v.dims, wv.dims);
            assert_eq!(v.attrs, wv.attrs);
            assert_eq!(v.nc_type, wv.data.nc_type());
            assert_eq!(v.is_record, w.is_record(wv));
        }
        let get = |n: &str| values(&nc.read_f64(n).unwrap());
        let shape = |n: &str| nc.shape(nc.variable(n).unwrap());
        assert_eq!(shape("b"), vec![2, 3]);
        assert_eq!(shape("scalar"), Vec::<usize>::new());
        assert_eq!(shape("rf"), vec![3, 2, 3]);
        assert_eq!(shape("rs"), vec![3]);
        assert!(same(&get("b"), &[-128.0, nan, 0.0, 1.0, 2.0, 127.0]));
        assert!(same(&get("s"), &[nan, 12.0, 8.0]));
        assert!(same(
            &get("i"),
            &[1.0, nan, 3.0, nan, f64::from(i32::MAX), f64::from(i32::MIN)]
        ));
        assert!(same(
            &get("f"),
            &[1.25, nan, nan, f64::from(f32::MIN_POSITIVE), 3.0]
        ));
        assert!(same(&get("d"), &[0.1, nan, 1e300, -0.0, 5.5, 6.5]));
        assert!(same(&get("scalar"), &[3.25]));
        assert!(same(&get("rb"), &[1., 2., 3., 4., 5., 6., 7., 8., -9.]));
        assert!(same(&get("rs"), &[10.0, nan, 30.0]));
        assert!(same(
            &get("ri"),
            &(1..=9).map(|k| 2.0 * f64::from(k)).collect::<Vec<_>>()
        ));
        let rf: Vec<f64> = (0..18)
            .map(|k| if k == 7 { nan } else { f64::from(k) * 0.5 })
            .collect();
        assert!(same(&get("rf"), &rf));
        assert_eq!(nc.read_f64("rf").unwrap().shape(), &[3, 2, 3]);
        assert!(same(&get("rd"), &[0.0, 6.0, 12.0]));
        assert!(matches!(nc.read_f64("c"), Err(NcError::NotNumeric { .. })));
        assert!(matches!(nc.read_f64("rc"), Err(NcError::NotNumeric { .. })));
        match nc.read_f64("missing") {
            Err(e @ NcError::VariableNotFound { .. }) => {
                let msg = e.to_string();
                assert!(msg.contains("missing") && msg.contains(".nc"), "{msg}");
            }
            other => panic!("expected VariableNotFound, got {other:?}"),
        }
    }

    #[test]
    fn roundtrip_cdf1_and_cdf2() {
        let dir = tempfile::tempdir().unwrap();
        for version in [1u8, 2] {
            let bytes = sample(version).encode();
            let p = write_tmp(&dir, &format!("sample{version}.nc"), &bytes);
            let nc = NcFile::open(&p).unwrap();
            assert_eq!(nc.version(), version);
            assert_eq!(nc.path(), p.as_path());
            check_sample(&nc);
        }
    }

    #[test]
    fn streaming_numrecs_is_computed_from_file_size() {
        let mut w = sample(1);
        w.streaming = true;
        let nc = NcFile::from_bytes(Path::new("stream.nc"), w.encode()).unwrap();
        check_sample(&nc);
    }

    #[test]
    fn single_record_variable_is_not_padded() {
        // A lone byte record variable of 3 values: records are 3 bytes apart.
        for (dims, data, shape) in [
            (
                vec![0, 1],
                AttrValue::Bytes(vec![1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]),
                vec![4, 3],
            ),
            (vec![0], AttrValue::Shorts(vec![-5, 6, -7, 8]), vec![4]),
        ] {
            let expect = data.as_f64_vec().unwrap();
            let w = WFile {
                version: 1,
                dims: vec![("rec", 0), ("three", 3)],
                numrecs: 4,
                streaming: false,
                gattrs: vec![],
                vars: vec![
                    WVar {
                        name: "fixed",
                        dims: vec![1],
                        attrs: vec![],
                        data: AttrValue::Bytes(vec![9, 8, 7]),
                    },
                    WVar {
                        name: "r",
                        dims,
                        attrs: vec![],
                        data,
                    },
                ],
            };
            let bytes = w.encode();
            let nc = NcFile::from_bytes(Path::new("single.nc"), bytes.clone()).unwrap();
            let r = nc.read_f64("r").unwrap();
            assert_eq!(r.shape(), &shape[..]);
            assert_eq!(values(&r), expect);
            assert_eq!(values(&nc.read_f64("fixed").unwrap()), vec![9.0, 8.0, 7.0]);
            // File ends right after the unpadded last record.
            let v = nc.variable("r").unwrap();
            let rec = shape.iter().skip(1).product::<usize>() * v.nc_type.size();
            assert_eq!(v.begin as usize + 4 * rec, bytes.len());
        }
    }

    #[test]
    fn empty_file_and_zero_records() {
        let w = WFile {
            version: 2,
            dims: vec![],
            numrecs: 0,
            streaming: false,
            gattrs: vec![],
            vars: vec![],
        };
        let nc = NcFile::from_bytes(Path::new("empty.nc"), w.encode()).unwrap();
        assert!(nc.dimensions().is_empty() && nc.variables().is_empty());
        let mut w = sample(1);
        w.numrecs = 0;
        for v in &mut w.vars {
            if v.dims.first() == Some(&0) {
                v.data = match &v.data {
                    AttrValue::Text(_) => text(""),
                    AttrValue::Bytes(_) => AttrValue::Bytes(vec![]),
                    AttrValue::Shorts(_) => AttrValue::Shorts(vec![]),
                    AttrValue::Ints(_) => AttrValue::Ints(vec![]),
                    AttrValue::Floats(_) => AttrValue::Floats(vec![]),
                    AttrValue::Doubles(_) => AttrValue::Doubles(vec![]),
                };
            }
        }
        let nc = NcFile::from_bytes(Path::new("norec.nc"), w.encode()).unwrap();
        assert_eq!(nc.read_f64("rf").unwrap().shape(), &[0, 2, 3]);
        assert_eq!(nc.read_f64("d").unwrap().len(), 6);
    }

    #[test]
    fn errors_name_the_file_and_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let good = sample(1).encode();

        let e = NcFile::open(&dir.path().join("absent.nc")).unwrap_err();
        assert!(matches!(e, NcError::Io { .. }) && e.to_string().contains("absent.nc"));

        let p = write_tmp(&dir, "hdf.nc", b"\x89HDF\r\n\x1a\n");
        let e = NcFile::open(&p).unwrap_err();
        assert!(matches!(e, NcError::BadMagic { .. }), "{e}");
        assert!(e.to_string().contains("hdf.nc"));
        assert!(matches!(
            NcFile::from_bytes(Path::new("x"), vec![]),
            Err(NcError::BadMagic { .. })
        ));

        let mut cdf5 = good.clone();
        cdf5[3] = 5;
        let e = NcFile::from_bytes(Path::new("five.nc"), cdf5).unwrap_err();
        assert!(
            matches!(e, NcError::UnsupportedVersion { version: 5, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("five.nc"));

        // Unknown type: patch the type code of variable "b" (NC_BYTE = 1) to 7 (CDF-5 NC_UBYTE).
        let nc = NcFile::from_bytes(Path::new("ok.nc"), good.clone()).unwrap();
        let b = nc.variable("b").unwrap();
        // In CDF-1 the type precedes vsize (4 bytes) and begin (4 bytes).
        let begin_bytes = (b.begin as u32).to_be_bytes();
        let mut pos = None;
        for k in 0..good.len() - 12 {
            if good[k..k + 4] == 1u32.to_be_bytes()
                && good[k + 4..k + 8] == 8u32.to_be_bytes()
                && good[k + 8..k + 12] == begin_bytes
            {
                pos = Some(k);
            }
        }
        let mut bad_type = good.clone();
        bad_type[pos.unwrap() + 3] = 7;
        let e = NcFile::from_bytes(Path::new("type.nc"), bad_type).unwrap_err();
        assert!(matches!(e, NcError::UnknownType { code: 7, .. }), "{e}");
        assert!(e.to_string().contains("\"b\""), "{e}");

        // Data beyond the end of file.
        let short = &good[..good.len() - 1];
        let e = NcFile::from_bytes(Path::new("cut.nc"), short.to_vec()).unwrap_err();
        assert!(matches!(e, NcError::DataBeyondEof { .. }), "{e}");
        assert!(e.to_string().contains("cut.nc"));

        // Every truncation of the header is an error, never a panic.
        let header_len = nc.variables().iter().map(|v| v.begin).min().unwrap() as usize;
        for n in 0..header_len {
            let e = NcFile::from_bytes(Path::new("trunc.nc"), good[..n].to_vec()).unwrap_err();
            if n >= 8 {
                assert!(
                    matches!(
                        e,
                        NcError::TruncatedHeader { .. } | NcError::BadHeader { .. }
                    ),
                    "prefix {n}: {e}"
                );
            }
        }
        // Truncation inside the data section.
        for n in header_len..good.len() {
            assert!(NcFile::from_bytes(Path::new("trunc.nc"), good[..n].to_vec()).is_err());
        }
    }

    #[test]
    fn corrupted_headers_never_panic() {
        let good = sample(2).encode();
        let header_len = 1200.min(good.len());
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..3000 {
            let mut b = good.clone();
            for _ in 0..1 + next() % 3 {
                let k = 4 + (next() as usize) % (header_len - 4);
                b[k] = match next() % 4 {
                    0 => 0xFF,
                    1 => 0,
                    _ => next() as u8,
                };
            }
            if let Ok(nc) = NcFile::from_bytes(Path::new("fuzz.nc"), b) {
                for v in nc.variables() {
                    let _ = nc.read_f64(&v.name);
                    let _ = nc.shape(v);
                }
            }
        }
    }

    // ------------------------------------------------------------------
    // NOAA monthly_navy_winds.cdf (ferret-datasets), cross-checked with scipy.
    // ------------------------------------------------------------------

    const FIXTURE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/navy_winds_values.txt"
    );
    const SLICE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/navy_winds_slice.nc"
    );

    /// Locations of the real file: `$NAVY_WINDS_CDF`, then where
    /// `dpkg -x ferret-datasets_*.deb /tmp/ferret` or an installed package puts it.
    fn real_file() -> Option<PathBuf> {
        let mut c: Vec<PathBuf> = std::env::var_os("NAVY_WINDS_CDF")
            .map(PathBuf::from)
            .into_iter()
            .collect();
        c.push(PathBuf::from(
            "/tmp/ferret/usr/share/ferret-vis/data/monthly_navy_winds.cdf",
        ));
        c.push(PathBuf::from(
            "/usr/share/ferret-vis/data/monthly_navy_winds.cdf",
        ));
        c.into_iter().find(|p| p.is_file())
    }

    struct Fixture {
        shapes: Vec<(String, Vec<usize>)>,
        /// (var, nan count, bit sum, weighted bit sum) for all records.
        check: Vec<(String, usize, u64, u64)>,
        /// Same for the first 3 records.
        slice_check: Vec<(String, usize, u64, u64)>,
        /// (var, [t, j, i], value) with value NaN for fill.
        values: Vec<(String, [usize; 3], f64)>,
    }

    fn fixture() -> Fixture {
        let text =
            std::fs::read_to_string(FIXTURE).expect("fixture tests/data/navy_winds_values.txt");
        let mut f = Fixture {
            shapes: vec![],
            check: vec![],
            slice_check: vec![],
            values: vec![],
        };
        for line in text.lines().filter(|l| !l.starts_with('#')) {
            let w: Vec<&str> = line.split_whitespace().collect();
            match w[0] {
                "SHAPE" => f
                    .shapes
                    .push((s(w[1]), w[2..].iter().map(|x| x.parse().unwrap()).collect())),
                "CHECK" | "SLICECHECK" => {
                    let row = (
                        s(w[1]),
                        w[2].parse().unwrap(),
                        w[3].parse().unwrap(),
                        w[4].parse().unwrap(),
                    );
                    if w[0] == "CHECK" {
                        f.check.push(row)
                    } else {
                        f.slice_check.push(row)
                    }
                }
                "V" => f.values.push((
                    s(w[1]),
                    [
                        w[2].parse().unwrap(),
                        w[3].parse().unwrap(),
                        w[4].parse().unwrap(),
                    ],
                    if w[5] == "nan" {
                        f64::NAN
                    } else {
                        w[5].parse().unwrap()
                    },
                )),
                _ => {}
            }
        }
        f
    }

    /// NaN count and the order-sensitive checksums of the float32 bit
    /// patterns, as computed by `tests/netcdf_crosscheck.py`.
    fn checksums(a: &ArrayD<f64>, nrec: usize) -> (usize, u64, u64) {
        let per_rec = a.len() / a.shape()[0];
        let (mut nan, mut s1, mut s2) = (0usize, 0u64, 0u64);
        for (k, &v) in a.iter().take(nrec * per_rec).enumerate() {
            let bits = if v.is_nan() {
                nan += 1;
                0
            } else {
                let f = v as f32;
                assert_eq!(f64::from(f), v, "value is not a float32");
                u64::from(f.to_bits())
            };
            s1 = s1.wrapping_add(bits);
            s2 = s2.wrapping_add(bits.wrapping_mul(k as u64 + 1));
        }
        (nan, s1, s2)
    }

    fn check_winds_attrs(nc: &NcFile) {
        for (v, long) in [("UWND", "ZONAL WIND"), ("VWND", "MERIDIONAL WIND")] {
            assert_eq!(nc.attr(Some(v), "units"), Some(&text("M/S")));
            assert_eq!(nc.attr(Some(v), "long_name"), Some(&text(long)));
            assert_eq!(
                nc.attr(Some(v), "_FillValue"),
                Some(&AttrValue::Floats(vec![-99.9]))
            );
            assert_eq!(
                nc.attr(Some(v), "missing_value"),
                Some(&AttrValue::Floats(vec![-99.9]))
            );
            assert_eq!(nc.variable(v).unwrap().nc_type, NcType::Float);
            assert!(nc.variable(v).unwrap().is_record);
        }
        assert_eq!(
            nc.attr(Some("TIME"), "units"),
            Some(&text("hour since 1980-01-14 14:00:00"))
        );
        assert_eq!(nc.attr(Some("FNOCX"), "units"), Some(&text("degrees_east")));
        assert_eq!(
            nc.attr(Some("FNOCY"), "units"),
            Some(&text("degrees_north"))
        );
        let lon = nc.read_f64("FNOCX").unwrap();
        let lat = nc.read_f64("FNOCY").unwrap();
        assert_eq!((lon[[0]], lon[[143]]), (20.0, 377.5));
        assert_eq!((lat[[0]], lat[[72]]), (-90.0, 90.0));
    }

    #[test]
    fn navy_winds_real_file_matches_scipy() {
        let Some(path) = real_file() else {
            eprintln!(
                "note: monthly_navy_winds.cdf not found (set NAVY_WINDS_CDF or run \
                 `cd /tmp && apt-get download ferret-datasets && dpkg -x ferret-datasets_*.deb /tmp/ferret`); skipping"
            );
            return;
        };
        let nc = NcFile::open(&path).unwrap();
        let fx = fixture();
        assert_eq!(nc.version(), 1);
        assert_eq!(nc.numrecs(), 132);
        assert_eq!(
            nc.attr(None, "history"),
            Some(&text("FERRET V4.45 (GUI) 22-May-97"))
        );
        for (name, shape) in &fx.shapes {
            assert_eq!(&nc.shape(nc.variable(name).unwrap()), shape, "{name}");
        }
        assert_eq!(nc.shape(nc.variable("UWND").unwrap()), vec![132, 73, 144]);
        let names: Vec<&str> = nc.dimensions().iter().map(|d| d.name.as_str()).collect();
        assert_eq!(names, ["FNOCX", "FNOCY", "TIME"]);
        check_winds_attrs(&nc);
        let time = nc.read_f64("TIME").unwrap();
        assert_eq!((time[[0]], time[[131]]), (17598.0, 113293.5));
        for (name, nan, s1, s2) in &fx.check {
            let a = nc.read_f64(name).unwrap();
            assert_eq!(checksums(&a, 132), (*nan, *s1, *s2), "{name}");
            let mut n = 0;
            for (_, idx, val) in fx.values.iter().filter(|(v, _, _)| v == name) {
                let got = a[&idx[..]];
                assert!(same(&[got], &[*val]), "{name}{idx:?}: {got} vs scipy {val}");
                n += 1;
            }
            assert!(n >= 200, "only {n} fixture values for {name}");
            eprintln!("{name}: {nan} fill/missing values (NaN), {n} values equal to scipy's");
        }
    }

    #[test]
    fn navy_winds_slice_fixture() {
        let nc = NcFile::open(Path::new(SLICE)).unwrap();
        let fx = fixture();
        assert_eq!(nc.numrecs(), 3);
        assert_eq!(nc.shape(nc.variable("UWND").unwrap()), vec![3, 73, 144]);
        assert_eq!(nc.shape(nc.variable("VWND").unwrap()), vec![3, 73, 144]);
        assert_eq!(nc.shape(nc.variable("TIME").unwrap()), vec![3]);
        check_winds_attrs(&nc);
        for (name, nan, s1, s2) in &fx.slice_check {
            let a = nc.read_f64(name).unwrap();
            assert_eq!(checksums(&a, 3), (*nan, *s1, *s2), "{name}");
        }
        let u = nc.read_f64("UWND").unwrap();
        let v = nc.read_f64("VWND").unwrap();
        let mut n = 0;
        for (name, idx, val) in fx.values.iter().filter(|(_, idx, _)| idx[0] < 3) {
            let got = if name == "UWND" {
                u[&idx[..]]
            } else {
                v[&idx[..]]
            };
            assert!(same(&[got], &[*val]), "{name}{idx:?}: {got} vs scipy {val}");
            n += 1;
        }
        assert!(n >= 100, "only {n} fixture values in the slice");
    }
}
