//! `.npy` input: a header reader that validates files at spec-validation time without loading
//! them, and loaders for image stacks (complex64, complex128, float32, float64) and real
//! parameter maps. Stacks stay in their stored element type so that memory is the input's
//! size; the analysis converts to f64 on the fly.

use crate::analysis::{analyse, Analysis, AnalysisError, Sample};
use ndarray::{Array2, Array3, ArrayView3};
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
    /// Byte offset of the data.
    pub data_offset: usize,
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
    let (len, prefix) = match pre[6] {
        1 => {
            let mut b = [0u8; 2];
            f.read_exact(&mut b).map_err(|_| bad("truncated header"))?;
            (u16::from_le_bytes(b) as usize, 10)
        }
        2 | 3 => {
            let mut b = [0u8; 4];
            f.read_exact(&mut b).map_err(|_| bad("truncated header"))?;
            (u32::from_le_bytes(b) as usize, 12)
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
        data_offset: prefix + len,
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
    /// Loads a stack from `path` in its stored axis order, reading the data in place (memory is
    /// the data's size).
    ///
    /// # Errors
    /// [`NpyError`] if the file cannot be read, is truncated, or is not 3-D.
    pub fn load(path: &Path) -> Result<Stack, NpyError> {
        let header = read_header(path)?;
        if header.shape.len() != 3 {
            return Err(NpyError::Data {
                path: path.to_path_buf(),
                reason: format!("a stack is 3-D, this array has shape {:?}", header.shape),
            });
        }
        Ok(match header.dtype {
            Dtype::Complex64 => Stack::C64(read_array(path, &header)?),
            Dtype::Complex128 => Stack::C128(read_array(path, &header)?),
            Dtype::Float32 => Stack::F32(read_array(path, &header)?),
            Dtype::Float64 => Stack::F64(read_array(path, &header)?),
        })
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

#[cfg(target_endian = "big")]
compile_error!(
    "isar-clutter reads little-endian .npy data in place; big-endian hosts are not supported"
);

/// An element of an `.npy` file that can be read in place (plain little-endian data).
pub trait Element: bytemuck::Pod {}
impl Element for f32 {}
impl Element for f64 {}
impl Element for Complex<f32> {}
impl Element for Complex<f64> {}

/// Asks the kernel to back a large allocation with transparent huge pages before it is first
/// touched: on virtual machines a 4 KiB page fault costs microseconds, so filling a 32 MB
/// stack page by page costs more than reading it. Advisory; errors are ignored.
fn advise_huge_pages<T>(v: &Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let start = v.as_ptr() as usize;
        let end = start + v.capacity() * std::mem::size_of::<T>();
        let aligned = start.next_multiple_of(HUGE);
        if end > aligned + HUGE {
            // SAFETY: madvise on a range inside our own allocation only changes how the kernel
            // backs those pages; MADV_HUGEPAGE does not alter their contents or validity.
            unsafe {
                libc::madvise(
                    aligned as *mut libc::c_void,
                    (end - aligned) / HUGE * HUGE,
                    libc::MADV_HUGEPAGE,
                );
            }
        }
    }
}

/// Reads the data of an `.npy` file into an array of its header's shape and memory order.
fn read_array<T: Element, D: ndarray::Dimension>(
    path: &Path,
    header: &NpyHeader,
) -> Result<ndarray::Array<T, D>, NpyError> {
    use ndarray::ShapeBuilder;
    use std::io::{Seek, SeekFrom};
    let data_err = |reason: String| NpyError::Data {
        path: path.to_path_buf(),
        reason,
    };
    let io = |source| NpyError::Io {
        path: path.to_path_buf(),
        source,
    };
    let count: usize = header.shape.iter().product();
    let mut f = File::open(path).map_err(io)?;
    let size = f.metadata().map_err(io)?.len() as usize;
    if size < header.data_offset + count * std::mem::size_of::<T>() {
        return Err(data_err(format!(
            "truncated: the header promises {} bytes of data, the file holds {}",
            count * std::mem::size_of::<T>(),
            size.saturating_sub(header.data_offset)
        )));
    }
    f.seek(SeekFrom::Start(header.data_offset as u64))
        .map_err(io)?;
    let mut out: Vec<T> = Vec::with_capacity(count);
    advise_huge_pages(&out);
    out.resize(count, T::zeroed());
    f.read_exact(bytemuck::cast_slice_mut(&mut out))
        .map_err(io)?;
    let dim = D::from_dimension(&ndarray::IxDyn(&header.shape)).ok_or_else(|| {
        data_err(format!(
            "expected {} axes, found shape {:?}",
            D::NDIM.unwrap_or(0),
            header.shape
        ))
    })?;
    ndarray::Array::from_shape_vec(dim.set_f(header.fortran_order), out)
        .map_err(|e| data_err(e.to_string()))
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
    match header.dtype {
        Dtype::Float64 => read_array::<f64, ndarray::Ix2>(path, &header),
        Dtype::Float32 => read_array::<f32, ndarray::Ix2>(path, &header).map(|a| a.mapv(f64::from)),
        _ => Err(data(
            "a parameter map must be real (float32 or float64)".into(),
        )),
    }
}
