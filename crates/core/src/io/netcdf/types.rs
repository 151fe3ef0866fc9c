//! The values of a NetCDF-3 file's header: its errors ([`NcError`], each naming the file), the
//! external data types, dimensions, attribute values and variables, as the header parser
//! (`header.rs`) makes them and the reader (`mod.rs`) serves them.

use std::fmt;
use std::path::PathBuf;
use thiserror::Error;

/// Errors from opening or reading a NetCDF-3 file. Every variant names the file.
#[derive(Debug, Error)]
pub enum NcError {
    /// The file could not be read from disk.
    #[error("{path}: cannot read file: {cause}")]
    Io {
        /// File concerned.
        path: PathBuf,
        /// Underlying I/O error (in the message, not a `source()`, so that a chain printed
        /// with `{:#}` says it once).
        cause: std::io::Error,
    },
    /// The file does not start with "CDF" followed by a version byte. The message says what
    /// to do with an HDF5-based NetCDF-4 file (convert it) or a gzip-compressed one.
    #[error(
        "{path}: not a NetCDF-3 file (bad magic bytes {found:02x?}, expected \"CDF\\x01\" or \"CDF\\x02\"){}",
        magic_hint(.found)
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
    /// A variable read as an image stack has fewer than 3 dimensions.
    #[error(
        "{path}: variable {var:?} has shape {shape:?}; a stack is 3-D [time, rows, cols] (dimensions of length 1 between time and rows are dropped)"
    )]
    NotAStack {
        /// File concerned.
        path: PathBuf,
        /// Variable concerned.
        var: String,
        /// Its shape.
        shape: Vec<usize>,
    },
    /// A variable read as an image stack has a dimension of length other than 1 between its
    /// first (time) and its last two (rows, cols).
    #[error(
        "{path}: variable {var:?} (shape {shape:?}) has dimension {dim:?} of length {len} between its time (first) and image (last two) dimensions; only dimensions of length 1 are dropped, so keep one {dim} in a copy of the file (e.g. `ncks -d {dim},0 IN.nc OUT.nc`)"
    )]
    ExtraDimension {
        /// File concerned.
        path: PathBuf,
        /// Variable concerned.
        var: String,
        /// Name of the offending dimension.
        dim: String,
        /// Its length.
        len: usize,
        /// The variable's shape.
        shape: Vec<usize>,
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

/// What to do with a file whose first bytes are not a NetCDF-3 magic number, for the
/// formats recognisable from them (empty for others).
fn magic_hint(found: &[u8]) -> &'static str {
    if found.starts_with(b"\x89HDF") {
        "; it is an HDF5 file (NetCDF-4): convert it to the classic format with `nccopy -k classic IN.nc OUT.nc`"
    } else if found.starts_with(&[0x1f, 0x8b]) {
        "; it is gzip-compressed: decompress it first (`gunzip FILE.nc.gz`)"
    } else {
        ""
    }
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
