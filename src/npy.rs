//! `.npy` input: a header reader that validates files at spec-validation time without loading
//! them, and loaders for image stacks (complex64, complex128, float32, float64) and real
//! parameter maps. Stacks stay in their stored element type so that memory is the input's
//! size; the analysis converts to f64 on the fly.

use crate::analysis::{analyse, Analysis, AnalysisError, Sample};
use ndarray::{Array2, Array3, ArrayView3};
use ndarray_npy::ReadNpyExt;
use num_complex::Complex;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// Problems reading an `.npy` file; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum NpyError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The header is not a valid `.npy` header.
    #[error("{path} is not a valid .npy file: {reason}")]
    Header {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The element type is not supported.
    #[error("{path} holds dtype {descr:?}; supported: complex64 (<c8), complex128 (<c16), float32 (<f4), float64 (<f8)")]
    Dtype {
        /// The file.
        path: PathBuf,
        /// The numpy type descriptor.
        descr: String,
    },
    /// The data could not be decoded.
    #[error("cannot load {path}: {reason}")]
    Data {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

/// Element types the tool reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    /// `<c8`.
    Complex64,
    /// `<c16`.
    Complex128,
    /// `<f4`.
    Float32,
    /// `<f8`.
    Float64,
}

impl Dtype {
    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            Dtype::Complex64 => 8,
            Dtype::Complex128 => 16,
            Dtype::Float32 => 4,
            Dtype::Float64 => 8,
        }
    }
}

/// The parsed header of an `.npy` file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NpyHeader {
    /// Element type.
    pub dtype: Dtype,
    /// Whether the data is stored in column-major order.
    pub fortran_order: bool,
    /// Array shape.
    pub shape: Vec<usize>,
}

/// Reads and validates the header of an `.npy` file without loading its data.
///
/// # Errors
/// [`NpyError`] if the file is missing, not `.npy`, or of an unsupported dtype.
pub fn read_header(path: &Path) -> Result<NpyHeader, NpyError> {
    let io = |source| NpyError::Io {
        path: path.to_path_buf(),
        source,
    };
    let bad = |reason: &str| NpyError::Header {
        path: path.to_path_buf(),
        reason: reason.to_string(),
    };
    let mut f = BufReader::new(File::open(path).map_err(io)?);
    let mut pre = [0u8; 8];
    f.read_exact(&mut pre).map_err(|_| bad("file too short"))?;
    if &pre[..6] != b"\x93NUMPY" {
        return Err(bad("missing the \\x93NUMPY magic string"));
    }
    let len = match pre[6] {
        1 => {
            let mut b = [0u8; 2];
            f.read_exact(&mut b).map_err(|_| bad("truncated header"))?;
            u16::from_le_bytes(b) as usize
        }
        2 | 3 => {
            let mut b = [0u8; 4];
            f.read_exact(&mut b).map_err(|_| bad("truncated header"))?;
            u32::from_le_bytes(b) as usize
        }
        v => return Err(bad(&format!("unknown format version {v}"))),
    };
    let mut text = vec![0u8; len];
    f.read_exact(&mut text)
        .map_err(|_| bad("truncated header"))?;
    let text = String::from_utf8_lossy(&text);
    let descr = dict_value(&text, "descr").ok_or_else(|| bad("no 'descr'"))?;
    let descr = descr.trim_matches(|c| c == '\'' || c == '"').to_string();
    let dtype = match descr.as_str() {
        "<c8" => Dtype::Complex64,
        "<c16" => Dtype::Complex128,
        "<f4" => Dtype::Float32,
        "<f8" => Dtype::Float64,
        _ => {
            return Err(NpyError::Dtype {
                path: path.to_path_buf(),
                descr,
            })
        }
    };
    let fortran_order = match dict_value(&text, "fortran_order").as_deref() {
        Some("True") => true,
        Some("False") => false,
        _ => return Err(bad("no 'fortran_order'")),
    };
    let shape = dict_value(&text, "shape").ok_or_else(|| bad("no 'shape'"))?;
    let shape = shape
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| bad("unreadable 'shape'"))?;
    Ok(NpyHeader {
        dtype,
        fortran_order,
        shape,
    })
}

/// The raw text of `key`'s value in a numpy header dict literal.
fn dict_value(text: &str, key: &str) -> Option<String> {
    let start = text.find(&format!("'{key}'"))? + key.len() + 2;
    let rest = text[start..].trim_start().strip_prefix(':')?.trim_start();
    let end = if rest.starts_with('(') {
        rest.find(')')? + 1
    } else {
        rest.find([',', '}'])?
    };
    Some(rest[..end].trim().to_string())
}

/// A stack in its stored element type, `[N, H, W]`.
#[derive(Debug, Clone, PartialEq)]
pub enum Stack {
    /// complex64.
    C64(Array3<Complex<f32>>),
    /// complex128.
    C128(Array3<Complex<f64>>),
    /// float32 (imaginary part 0).
    F32(Array3<f32>),
    /// float64 (imaginary part 0).
    F64(Array3<f64>),
}

/// Whether axes are `[N, H, W]` or `[H, W, N]`.
fn view<T>(a: &Array3<T>, hwn: bool) -> ArrayView3<'_, T> {
    if hwn {
        a.view().permuted_axes([2, 0, 1])
    } else {
        a.view()
    }
}

impl Stack {
    /// Loads a stack from `path` in its stored axis order.
    ///
    /// # Errors
    /// [`NpyError`] if the file cannot be read or decoded.
    pub fn load(path: &Path) -> Result<Stack, NpyError> {
        let header = read_header(path)?;
        let f = || {
            File::open(path)
                .map(BufReader::new)
                .map_err(|source| NpyError::Io {
                    path: path.to_path_buf(),
                    source,
                })
        };
        let data = |e: ndarray_npy::ReadNpyError| NpyError::Data {
            path: path.to_path_buf(),
            reason: e.to_string(),
        };
        let stack = match header.dtype {
            Dtype::Complex64 => Stack::C64(Array3::read_npy(f()?).map_err(data)?),
            Dtype::Complex128 => Stack::C128(Array3::read_npy(f()?).map_err(data)?),
            Dtype::Float32 => Stack::F32(Array3::read_npy(f()?).map_err(data)?),
            Dtype::Float64 => Stack::F64(Array3::read_npy(f()?).map_err(data)?),
        };
        Ok(stack)
    }

    /// Runs the multiscale analysis on the stack (`hwn`: axes stored as `[H, W, N]`).
    ///
    /// # Errors
    /// [`AnalysisError`] as for [`analyse`].
    pub fn analyse(&self, hwn: bool, levels: usize) -> Result<Analysis, AnalysisError> {
        fn go<T: Sample>(
            a: &Array3<T>,
            hwn: bool,
            levels: usize,
        ) -> Result<Analysis, AnalysisError> {
            analyse(view(a, hwn), levels)
        }
        match self {
            Stack::C64(a) => go(a, hwn, levels),
            Stack::C128(a) => go(a, hwn, levels),
            Stack::F32(a) => go(a, hwn, levels),
            Stack::F64(a) => go(a, hwn, levels),
        }
    }

    /// Bytes of element data held.
    pub fn bytes(&self) -> usize {
        match self {
            Stack::C64(a) => a.len() * 8,
            Stack::C128(a) => a.len() * 16,
            Stack::F32(a) => a.len() * 4,
            Stack::F64(a) => a.len() * 8,
        }
    }
}

/// Loads a real `[H, W]` map (float32 or float64).
///
/// # Errors
/// [`NpyError`] if the file is missing, complex, or not 2-D.
pub fn read_real_map(path: &Path) -> Result<Array2<f64>, NpyError> {
    let header = read_header(path)?;
    let data = |reason: String| NpyError::Data {
        path: path.to_path_buf(),
        reason,
    };
    if header.shape.len() != 2 {
        return Err(data(format!(
            "a map must be 2-D [H, W], this one has shape {:?}",
            header.shape
        )));
    }
    let f = File::open(path)
        .map(BufReader::new)
        .map_err(|source| NpyError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    match header.dtype {
        Dtype::Float64 => Array2::<f64>::read_npy(f).map_err(|e| data(e.to_string())),
        Dtype::Float32 => Array2::<f32>::read_npy(f)
            .map(|a| a.mapv(f64::from))
            .map_err(|e| data(e.to_string())),
        _ => Err(data(
            "a parameter map must be real (float32 or float64)".into(),
        )),
    }
}
