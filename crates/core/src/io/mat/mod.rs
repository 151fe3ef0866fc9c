//! MATLAB `.mat` files in and out. Reading: the file's top-level variables are listed without
//! reading their data, and one numeric 3-D array (single or double, any integer class, real or
//! complex) is loaded as a complex stack in MATLAB's index order, `a[[i, j, k]] = x(i+1, j+1,
//! k+1)`, from a MAT v5 file (`save -v6`/`-v7`, SciPy's `savemat`; [`v5`]) or, with the cargo
//! feature `mat73`, a MAT v7.3 file (HDF5 behind a 512-byte MATLAB header; `v73`). Everything
//! else is a clear error naming the file and the variable: a missing variable lists the file's
//! variables, and structs, cells, char arrays, sparse matrices, logical arrays, objects and
//! arrays that are not 3-D are refused by what they are, as are v7.3 datasets whose
//! `MATLAB_class` is numeric but whose data are stored as strings, booleans or another
//! compound (when the file is listed, so at `validate`, not when the data are read); malformed
//! input (truncated, corrupted, a MAT v4 file, an HDF5 file without the MATLAB header) is an
//! error, never a panic. Writing ([`write`]): streamed stacks of generated samples as MATLAB
//! `H x W x M` arrays, v7.3 (with the feature) or v5; a `.mat` that holds anything besides the
//! one variable the tool wrote is never replaced ([`write::is_ours`]).

use ndarray::Array3;
use num_complex::Complex64;
use std::io::Read;
use std::path::{Path, PathBuf};

pub mod format;
pub mod v5;
#[cfg(feature = "mat73")]
pub mod v73;
pub mod write;

pub use format::{MatClass, MatVersion};
pub use write::MatOutput;

/// Problems reading a `.mat` file; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MatError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (in the message, not a `source()`, so that a chain printed with `{:#}`
        /// says it once).
        cause: std::io::Error,
    },
    /// The file is not a MAT file this build reads, or its bytes are malformed.
    #[error("{path}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The requested variable is not in the file.
    #[error("{path} has no variable {name:?}; it holds: {}", list(.variables))]
    Missing {
        /// The file.
        path: PathBuf,
        /// The requested name.
        name: String,
        /// What the file holds.
        variables: Vec<Variable>,
    },
    /// No variable was named and the file does not hold exactly one numeric 3-D array.
    #[error("{path} holds {count} numeric 3-D arrays, so name the variable to read; it holds: {}", list(.variables))]
    Ambiguous {
        /// The file.
        path: PathBuf,
        /// How many numeric 3-D arrays the file holds.
        count: usize,
        /// What the file holds.
        variables: Vec<Variable>,
    },
    /// The variable exists but is not a numeric 3-D array.
    #[error("{path}: variable {name:?} is {what}; a stack is a numeric 3-D array (H x W x N)")]
    NotStack {
        /// The file.
        path: PathBuf,
        /// The variable.
        name: String,
        /// What it is instead.
        what: String,
    },
    /// A stack does not fit in memory.
    #[error(transparent)]
    Alloc(#[from] crate::alloc::AllocError),
}

fn list(v: &[Variable]) -> String {
    if v.is_empty() {
        return "no variables".into();
    }
    v.iter()
        .map(|v| format!("{} ({})", v.name, v.describe()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A top-level variable of a MAT file, as listed without reading its data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Variable {
    /// Its name.
    pub name: String,
    /// MATLAB's class name (`double`, `single`, `int16`, `struct`, `cell`, `char`, `sparse`,
    /// `object`, ...).
    pub class: &'static str,
    /// Its dimensions (MATLAB order); empty where the file does not say without reading more
    /// (a v7.3 struct, an object).
    pub dims: Vec<usize>,
    /// Whether it is complex.
    pub complex: bool,
    /// Whether it is a logical array.
    pub logical: bool,
    /// What the data are stored as where that is not numbers although the class is numeric
    /// (a v7.3 dataset of strings, booleans or an unknown compound whose `MATLAB_class` says
    /// `double`); `None` where the storage agrees with the class.
    pub stored_as: Option<String>,
}

impl Variable {
    /// Whether it is a numeric (not logical) array.
    pub fn is_numeric(&self) -> bool {
        numeric_class(self.class) && !self.logical && self.stored_as.is_none()
    }

    /// Whether it can be read as a stack.
    pub fn is_stack(&self) -> bool {
        self.is_numeric() && self.dims.len() == 3
    }

    /// `4x5x3 single complex` (the dimensions left out where unknown; `... stored as bool`
    /// where the data are not numbers).
    pub fn describe(&self) -> String {
        let dims: Vec<String> = self.dims.iter().map(usize::to_string).collect();
        let kind = if self.logical { "logical" } else { self.class };
        let cx = if self.complex { " complex" } else { "" };
        let stored = match &self.stored_as {
            Some(s) => format!(" stored as {s}"),
            None => String::new(),
        };
        if dims.is_empty() {
            format!("{kind}{cx}{stored}")
        } else {
            format!("{} {kind}{cx}{stored}", dims.join("x"))
        }
    }

    /// What the variable is, in words, where it is not a stack (`None` for a stack).
    pub fn not_stack_reason(&self) -> Option<String> {
        if self.is_stack() {
            return None;
        }
        Some(match self.class {
            "struct" => "a struct".to_string(),
            "cell" => "a cell array".to_string(),
            "char" => "a char array".to_string(),
            "sparse" => "a sparse matrix".to_string(),
            "object" | "opaque" | "function_handle" => format!("a MATLAB {} object", self.class),
            _ if self.stored_as.is_some() => format!(
                "stored as {}, not as numbers (its MATLAB_class says {})",
                self.stored_as.as_deref().unwrap_or_default(),
                if self.logical { "logical" } else { self.class }
            ),
            _ if self.logical => "a logical array".to_string(),
            _ if self.is_numeric() => format!("{}-D ({})", self.dims.len(), self.describe()),
            _ => format!("of class {}", self.class),
        })
    }
}

/// MATLAB's class names in the order of MAT v5's class codes (`mxCELL_CLASS` = 1, ...).
pub(crate) const CLASSES: [&str; 18] = [
    "unknown",
    "cell",
    "struct",
    "object",
    "char",
    "sparse",
    "double",
    "single",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
    "function_handle",
    "opaque",
];

fn numeric_class(c: &str) -> bool {
    CLASSES[6..16].contains(&c)
}

/// The `HDF5` signature that starts an HDF5 superblock.
const HDF5_MAGIC: &[u8; 8] = b"\x89HDF\r\n\x1a\n";

/// What a file's first 128 bytes say it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// MAT v5 (`-v6`/`-v7`), big- or little-endian.
    V5 { big: bool },
    /// MAT v7.3: HDF5 behind a 512-byte user block holding the MATLAB header.
    V73,
}

/// Reads the 128-byte header (`head`: the file's first bytes, up to 520 so that an HDF5
/// signature after a 512-byte user block shows; `len`: the file's length).
fn sniff(head: &[u8], len: u64) -> Result<Kind, String> {
    let hdf5 = head.starts_with(HDF5_MAGIC) || head.get(512..520) == Some(&HDF5_MAGIC[..]);
    let not_mat = "an HDF5 file without a MATLAB header: not a MAT file";
    if head.starts_with(HDF5_MAGIC) {
        return Err(not_mat.into());
    }
    if head.len() < 128 {
        return Err(format!(
            "not a MAT file: {len} bytes, shorter than the 128-byte MAT header"
        ));
    }
    let big = match &head[126..128] {
        b"IM" => false,
        b"MI" => true,
        _ if hdf5 => return Err(not_mat.into()),
        _ if head[..4].contains(&0) => {
            return Err("not a MAT v5 file (a MAT v4 file? save it with -v7 or -v7.3)".into())
        }
        _ => return Err("not a MAT file: no endian indicator at byte 126".into()),
    };
    let version = if big {
        u16::from_be_bytes([head[124], head[125]])
    } else {
        u16::from_le_bytes([head[124], head[125]])
    };
    match version {
        0x0100 => Ok(Kind::V5 { big }),
        0x0200 if !big => Ok(Kind::V73),
        v => Err(format!("unknown MAT version {v:#06x}")),
    }
}

/// The file's first 520 bytes (fewer if it is shorter) and its length.
fn head(path: &Path) -> Result<(Vec<u8>, u64), MatError> {
    let io = |cause| MatError::Io {
        path: path.to_path_buf(),
        cause,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let len = f.metadata().map_err(io)?.len();
    let mut head = Vec::with_capacity(520);
    f.take(520).read_to_end(&mut head).map_err(io)?;
    Ok((head, len))
}

/// Whether the build reads (and writes) MAT v7.3 files (the cargo feature `mat73`).
pub const V73_SUPPORTED: bool = cfg!(feature = "mat73");

/// What a build without the `mat73` feature says about a v7.3 file.
pub const V73_MISSING: &str = "a MAT v7.3 (HDF5) file, which this build of isar-clutter cannot \
    read: build it with `--features mat73` (as `make build` does; it needs Debian's \
    libhdf5-dev), or save the variable in MATLAB with `save(FILE, NAME, '-v7')`";

enum Inner {
    V5(v5::V5File),
    #[cfg(feature = "mat73")]
    V73(v73::V73File),
}

/// An open MAT file (v5, or v7.3 with the `mat73` feature) and the list of its top-level
/// variables.
pub struct MatFile {
    path: PathBuf,
    variables: Vec<Variable>,
    inner: Inner,
}

impl MatFile {
    /// Opens `path`, checks the header, and lists the variables (reading only their headers).
    ///
    /// # Errors
    /// [`MatError`] if the file cannot be read or is not a well-formed MAT file this build
    /// reads.
    pub fn open(path: &Path) -> Result<MatFile, MatError> {
        let fmt = |reason: String| MatError::Format {
            path: path.to_path_buf(),
            reason,
        };
        let (head, len) = head(path)?;
        let (variables, inner) = match sniff(&head, len).map_err(fmt)? {
            Kind::V5 { big } => {
                let (f, vars) = v5::V5File::open(path, big)?;
                (vars, Inner::V5(f))
            }
            #[cfg(feature = "mat73")]
            Kind::V73 => {
                let (f, vars) = v73::V73File::open(path).map_err(fmt)?;
                (vars, Inner::V73(f))
            }
            #[cfg(not(feature = "mat73"))]
            Kind::V73 => return Err(fmt(V73_MISSING.into())),
        };
        Ok(MatFile {
            path: path.to_path_buf(),
            variables,
            inner,
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file's format version.
    pub fn version(&self) -> MatVersion {
        match self.inner {
            Inner::V5(_) => MatVersion::V5,
            #[cfg(feature = "mat73")]
            Inner::V73(_) => MatVersion::V73,
        }
    }

    /// The file's top-level variables, in file order (v5) or name order (v7.3).
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// The variable a stack is read from: `name`, or, when `None`, the only numeric 3-D
    /// array of the file.
    ///
    /// # Errors
    /// [`MatError::Missing`] (listing the variables), [`MatError::Ambiguous`] or
    /// [`MatError::NotStack`].
    pub fn stack_variable(&self, name: Option<&str>) -> Result<&Variable, MatError> {
        self.choose(name).map(|i| &self.variables[i])
    }

    /// The index of the variable [`MatFile::stack_variable`] returns.
    fn choose(&self, name: Option<&str>) -> Result<usize, MatError> {
        let index = match name {
            Some(n) => self
                .variables
                .iter()
                .position(|v| v.name == n)
                .ok_or_else(|| MatError::Missing {
                    path: self.path.clone(),
                    name: n.to_string(),
                    variables: self.variables.clone(),
                })?,
            None => {
                let stacks: Vec<usize> = (0..self.variables.len())
                    .filter(|&i| self.variables[i].is_stack())
                    .collect();
                if stacks.len() != 1 {
                    return Err(MatError::Ambiguous {
                        path: self.path.clone(),
                        count: stacks.len(),
                        variables: self.variables.clone(),
                    });
                }
                stacks[0]
            }
        };
        let v = &self.variables[index];
        if let Some(what) = v.not_stack_reason() {
            return Err(MatError::NotStack {
                path: self.path.clone(),
                name: v.name.clone(),
                what,
            });
        }
        Ok(index)
    }

    /// Reads the variable `name` (or, when `None`, the only numeric 3-D array) as a complex
    /// stack in MATLAB's index order (`[H, W, N]` for MATLAB's usual layout).
    ///
    /// # Errors
    /// [`MatError`] if the variable is missing, ambiguous, not a numeric 3-D array, malformed,
    /// or does not fit in memory.
    pub fn read_stack(&self, name: Option<&str>) -> Result<Array3<Complex64>, MatError> {
        let index = self.choose(name)?;
        let v = &self.variables[index];
        let (d0, d1, d2) = (v.dims[0], v.dims[1], v.dims[2]);
        // Column-major (d0, d1, d2) is row-major (d2, d1, d0): fill linearly, then reverse.
        let mut out: Array3<Complex64> =
            crate::alloc::try_zeros((d2, d1, d0), "the MAT-file stack")?;
        let data = out.as_slice_mut().expect("standard layout");
        match &self.inner {
            Inner::V5(f) => f.read(index, v, data),
            #[cfg(feature = "mat73")]
            Inner::V73(f) => f.read(v, data),
        }
        .map_err(|reason| MatError::Format {
            path: self.path.clone(),
            reason: format!("variable {:?}: {reason}", v.name),
        })?;
        Ok(out.reversed_axes())
    }
}

/// Loads a stack from a MAT file (see [`MatFile::read_stack`]) as the dataset's
/// [`crate::io::npy::Stack`].
///
/// # Errors
/// As for [`MatFile::open`] and [`MatFile::read_stack`].
pub fn load_stack(path: &Path, variable: Option<&str>) -> Result<crate::io::npy::Stack, MatError> {
    Ok(crate::io::npy::Stack::Generated(
        MatFile::open(path)?.read_stack(variable)?,
    ))
}

/// Whether `path` names a MAT file by its extension (`.mat`, any case).
pub fn is_mat_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(version: u16, endian: &[u8; 2]) -> Vec<u8> {
        let mut h = b"MATLAB 5.0 MAT-file".to_vec();
        h.resize(124, b' ');
        h.extend(version.to_le_bytes());
        h.extend(endian);
        h
    }

    #[test]
    fn the_header_says_which_version() {
        assert_eq!(
            sniff(&header(0x0100, b"IM"), 128),
            Ok(Kind::V5 { big: false })
        );
        let mut be = header(0, b"MI");
        be[124..126].copy_from_slice(&0x0100u16.to_be_bytes());
        assert_eq!(sniff(&be, 128), Ok(Kind::V5 { big: true }));
        assert_eq!(sniff(&header(0x0200, b"IM"), 1024), Ok(Kind::V73));
        assert!(sniff(&header(0x0300, b"IM"), 128)
            .unwrap_err()
            .contains("unknown MAT version 0x0300"));
        assert!(sniff(b"\x89HDF\r\n\x1a\n\0\0", 10)
            .unwrap_err()
            .contains("HDF5 file without a MATLAB header"));
        assert!(sniff(b"MATLAB", 6).unwrap_err().contains("6 bytes"));
        assert!(sniff(&[0u8; 128], 128).unwrap_err().contains("MAT v4"));
        let mut ub = vec![0u8; 520];
        ub[512..].copy_from_slice(HDF5_MAGIC);
        assert!(sniff(&ub, 4096)
            .unwrap_err()
            .contains("HDF5 file without a MATLAB header"));
    }

    #[test]
    fn classes_are_named() {
        let v = Variable {
            name: "s".into(),
            class: "struct",
            dims: vec![],
            complex: false,
            logical: false,
            stored_as: None,
        };
        assert_eq!(v.describe(), "struct");
        assert_eq!(v.not_stack_reason().as_deref(), Some("a struct"));
        assert!(is_mat_path(Path::new("a/b.MAT")) && !is_mat_path(Path::new("b.npy")));
    }
}
