//! `.npy` input: a header reader that validates files at spec-validation time without loading
//! them, and loaders for image stacks (complex64, complex128, float32, float64) and real
//! parameter maps. Stacks stay in their stored element type so that memory is the input's
//! size; the analysis converts to f64 on the fly. Process-wide state: the mappings that
//! `map_for_reading` offers (`OFFERED`, by file identity), held until the `Stack::load` of the
//! same unchanged file takes them, so that a file validated and then loaded is mapped once.

use super::FileId;
use crate::stats::analysis::{analyse, Analysis, AnalysisError, Sample};
use ndarray::{Array2, Array3, ArrayView3};
use num_complex::Complex;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Problems reading an `.npy` file; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum NpyError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (in the message, not a `source()`, so that a chain printed with `{:#}`
        /// says it once).
        cause: std::io::Error,
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

/// The header of an `.npy` file as written, before its element type is interpreted: what
/// [`read_header`] and readers of other element types (the model folder's `uint8` arrays)
/// share.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawHeader {
    /// Byte offset of the data.
    pub data_offset: usize,
    /// The numpy type descriptor (`<f8`, `|u1`, ...).
    pub descr: String,
    /// Whether the data is stored in column-major order.
    pub fortran_order: bool,
    /// Array shape.
    pub shape: Vec<usize>,
}

impl RawHeader {
    /// Bytes of data that elements of `size` bytes take (`None` if the count overflows).
    pub fn data_bytes(&self, size: usize) -> Option<usize> {
        element_count(&self.shape)?.checked_mul(size)
    }
}

/// The number of elements of `shape`, `None` where no array can have it: the product of the
/// non-zero axis lengths exceeds `isize::MAX` (ndarray's rule, which bounds the axes of an
/// empty array too).
pub fn element_count(shape: &[usize]) -> Option<usize> {
    let nonzero = shape
        .iter()
        .filter(|&&d| d != 0)
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .filter(|&n| n <= isize::MAX as usize)?;
    Some(if shape.contains(&0) { 0 } else { nonzero })
}

/// Reads the header of an `.npy` file (magic, version, dict) without interpreting its element
/// type. The header length is checked against the file before anything is allocated.
///
/// # Errors
/// [`NpyError`] if the file is missing or its header is not a valid `.npy` header.
pub fn read_raw_header(path: &Path) -> Result<RawHeader, NpyError> {
    let io = |cause| NpyError::Io {
        path: path.to_path_buf(),
        cause,
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
            (u64::from(u16::from_le_bytes(b)), 10)
        }
        2 | 3 => {
            let mut b = [0u8; 4];
            f.read_exact(&mut b).map_err(|_| bad("truncated header"))?;
            (u64::from(u32::from_le_bytes(b)), 12)
        }
        v => return Err(bad(&format!("unknown format version {v}"))),
    };
    // Read at most what the file holds: a forged length cannot allocate gigabytes.
    let mut text = Vec::new();
    f.take(len).read_to_end(&mut text).map_err(io)?;
    if text.len() as u64 != len {
        return Err(bad(&format!(
            "truncated header: {len} bytes announced, {} present",
            text.len()
        )));
    }
    let text = String::from_utf8_lossy(&text);
    let descr = dict_value(&text, "descr").ok_or_else(|| bad("no 'descr'"))?;
    let descr = descr.trim_matches(|c| c == '\'' || c == '"').to_string();
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
    Ok(RawHeader {
        data_offset: prefix + len as usize,
        descr,
        fortran_order,
        shape,
    })
}

/// Reads and validates the header of an `.npy` file without loading its data: the element
/// type is one the tool reads, and the data size the shape implies fits in memory
/// arithmetic (a forged shape whose size overflows is refused, naming the shape).
///
/// # Errors
/// [`NpyError`] if the file is missing, not `.npy`, of an unsupported dtype, or of a shape
/// whose size overflows.
pub fn read_header(path: &Path) -> Result<NpyHeader, NpyError> {
    let raw = read_raw_header(path)?;
    let dtype = match raw.descr.as_str() {
        "<c8" => Dtype::Complex64,
        "<c16" => Dtype::Complex128,
        "<f4" => Dtype::Float32,
        "<f8" => Dtype::Float64,
        _ => {
            return Err(NpyError::Dtype {
                path: path.to_path_buf(),
                descr: raw.descr,
            })
        }
    };
    check_size(path, &raw.shape, raw.data_offset, dtype.size())?;
    Ok(NpyHeader {
        data_offset: raw.data_offset,
        dtype,
        fortran_order: raw.fortran_order,
        shape: raw.shape,
    })
}

/// Refuses a shape whose data, of `size`-byte elements after `offset` header bytes, has a
/// byte count beyond `isize::MAX` (counting the non-zero axes, as ndarray does).
///
/// # Errors
/// [`NpyError::Header`] naming the file and the shape.
pub fn check_size(
    path: &Path,
    shape: &[usize],
    offset: usize,
    size: usize,
) -> Result<(), NpyError> {
    let nonzero: Vec<usize> = shape.iter().copied().filter(|&d| d != 0).collect();
    element_count(&nonzero)
        .and_then(|n| n.checked_mul(size))
        .and_then(|b| b.checked_add(offset))
        .filter(|&b| b <= isize::MAX as usize)
        .map(|_| ())
        .ok_or_else(|| NpyError::Header {
            path: path.to_path_buf(),
            reason: format!(
                "shape {shape:?} of {size}-byte elements overflows the addressable size"
            ),
        })
}

impl NpyHeader {
    /// Number of elements (the product of the shape; [`read_header`] refused overflow).
    pub fn count(&self) -> usize {
        element_count(&self.shape).unwrap_or(usize::MAX)
    }

    /// Bytes of element data (saturating; [`read_header`] refused overflow).
    pub fn data_bytes(&self) -> usize {
        self.count().saturating_mul(self.dtype.size())
    }
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

/// A stack, `[N, H, W]` (or `[H, W, N]`), in its stored element type.
#[derive(Debug)]
pub enum Stack {
    /// A generated stack (complex128).
    Generated(Array3<Complex<f64>>),
    /// A stack read from a file of complex64 values (a UAVSAR stack), kept in single
    /// precision: half the memory of a complex128 copy, analysed as a mapped complex64 `.npy`.
    Single(Array3<Complex<f32>>),
    /// An `.npy` file mapped read-only into memory: no copy and no page-by-page allocation of
    /// the input (the file must not be modified while a run reads it).
    Mapped(MappedNpy),
}

/// A memory-mapped `.npy` file and its header.
#[derive(Debug)]
pub struct MappedNpy {
    /// The file.
    pub path: PathBuf,
    /// Its header.
    pub header: NpyHeader,
    map: Arc<memmap2::Mmap>,
}

fn file_id(file: &File) -> Option<FileId> {
    file.metadata().ok().map(|m| super::file_id(&m))
}

/// Mappings made by [`map_for_reading`], kept for the [`Stack::load`] of the same file.
static OFFERED: Mutex<Vec<(FileId, Arc<memmap2::Mmap>)>> = Mutex::new(Vec::new());

/// Maps `file` read-only and keeps the mapping for the next [`Stack::load`] of the same,
/// unchanged file, which then reads it without mapping (and faulting in) its pages again: a
/// run that hashes an input for its job key and then analyses it maps it once (a second
/// mapping of a 32 MB stack cost about 2 ms on the development VM).
///
/// # Safety
/// As for any map of a file: undefined if another process truncates or rewrites the file
/// while the mapping is alive (inputs must not change during a run).
///
/// # Errors
/// If the file cannot be mapped.
pub unsafe fn map_for_reading(file: &File) -> std::io::Result<Arc<memmap2::Mmap>> {
    // SAFETY: the caller's contract.
    let map = Arc::new(unsafe { memmap2::Mmap::map(file) }?);
    if let (Some(id), Ok(mut offered)) = (file_id(file), OFFERED.lock()) {
        offered.retain(|(i, _)| *i != id);
        offered.push((id, Arc::clone(&map)));
    }
    Ok(map)
}

/// Drops the mappings [`map_for_reading`] kept that no load took (the inputs of jobs resumed
/// from the store, or read some other way): called when a run's jobs are done.
pub fn release_offered() {
    if let Ok(mut offered) = OFFERED.lock() {
        offered.clear();
    }
}

/// The mapping [`map_for_reading`] kept for `file`, if its content is unchanged since.
fn take_map(file: &File) -> Option<Arc<memmap2::Mmap>> {
    let id = file_id(file)?;
    let mut offered = OFFERED.lock().ok()?;
    let at = offered.iter().position(|(i, _)| *i == id)?;
    Some(offered.swap_remove(at).1)
}

/// The stack in `[N, H, W]` order, from its stored axes (`hwn`: `[H, W, N]`), without a copy.
pub fn nhw_view<T>(a: ArrayView3<'_, T>, hwn: bool) -> ArrayView3<'_, T> {
    if hwn {
        a.permuted_axes([2, 0, 1])
    } else {
        a
    }
}

/// A stack of any element type the analysis reads as complex128 (a copy, allocated fallibly;
/// the imaginary part of real values is 0).
///
/// # Errors
/// [`crate::alloc::AllocError`] if the copy does not fit in memory.
pub fn widen<T: Sample>(
    a: ArrayView3<'_, T>,
) -> Result<Array3<Complex<f64>>, crate::alloc::AllocError> {
    let mut out = crate::alloc::try_zeros(a.raw_dim(), "the stack as complex128")?;
    ndarray::Zip::from(&mut out).and(a).for_each(|o, &v| {
        let [re, im] = T::components(v);
        *o = Complex::new(re, im);
    });
    Ok(out)
}

impl Stack {
    /// Maps a stack from `path`, checking its header and size.
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
        Stack::map_at(path, header)
    }

    /// Maps the stack `header` describes in `path`: its elements, stored as an `.npy` file's
    /// would be (little-endian, packed), from byte `header.data_offset` on; another format's
    /// contiguous data (an HDF5 dataset's) is mapped so, without a copy.
    ///
    /// # Errors
    /// [`NpyError`] if the file cannot be opened or mapped, or holds fewer bytes than the
    /// header promises.
    ///
    /// # Panics
    /// If `header.shape` is not 3-D.
    pub fn map_at(path: &Path, header: NpyHeader) -> Result<Stack, NpyError> {
        assert_eq!(header.shape.len(), 3, "a stack's header");
        let data_err = |reason: String| NpyError::Data {
            path: path.to_path_buf(),
            reason,
        };
        let file = File::open(path).map_err(|cause| NpyError::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        let map =
            match take_map(&file) {
                Some(map) => map,
                // SAFETY: the map is read-only and private to this process; it is undefined only
                // if another process truncates or rewrites the file during the run (documented
                // above).
                None => Arc::new(unsafe { memmap2::Mmap::map(&file) }.map_err(|cause| {
                    NpyError::Io {
                        path: path.to_path_buf(),
                        cause,
                    }
                })?),
            };
        let need = header.data_bytes();
        if map.len().saturating_sub(header.data_offset) < need {
            return Err(data_err(format!(
                "truncated: the header promises {need} bytes of data, the file holds {}",
                map.len().saturating_sub(header.data_offset)
            )));
        }
        Ok(Stack::Mapped(MappedNpy {
            path: path.to_path_buf(),
            header,
            map,
        }))
    }

    /// Runs the multiscale analysis on the stack (`hwn`: axes stored as `[H, W, N]`).
    ///
    /// # Errors
    /// [`AnalysisError`] as for [`analyse`].
    pub fn analyse(&self, hwn: bool, levels: usize) -> Result<Analysis, AnalysisError> {
        match self {
            Stack::Generated(a) => analyse(nhw_view(a.view(), hwn), levels),
            Stack::Single(a) => analyse(nhw_view(a.view(), hwn), levels),
            Stack::Mapped(m) => match m.header.dtype {
                Dtype::Complex64 => m.analyse::<Complex<f32>>(hwn, levels),
                Dtype::Complex128 => m.analyse::<Complex<f64>>(hwn, levels),
                Dtype::Float32 => m.analyse::<f32>(hwn, levels),
                Dtype::Float64 => m.analyse::<f64>(hwn, levels),
            },
        }
    }

    /// The stack as complex128 `[N, H, W]` (a copy; `hwn`: axes stored as `[H, W, N]`).
    ///
    /// # Panics
    /// If the copy does not fit in memory (see [`Stack::try_to_complex128`]).
    pub fn to_complex128(&self, hwn: bool) -> Array3<Complex<f64>> {
        self.try_to_complex128(hwn)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// The stack as complex128 `[N, H, W]`, allocated fallibly.
    ///
    /// # Errors
    /// [`crate::alloc::AllocError`] if the copy (or, for a mapped stack, its aligned read)
    /// does not fit in memory.
    pub fn try_to_complex128(
        &self,
        hwn: bool,
    ) -> Result<Array3<Complex<f64>>, crate::alloc::AllocError> {
        fn widen_mapped<T: Element + Sample>(
            m: &MappedNpy,
            hwn: bool,
        ) -> Result<Array3<Complex<f64>>, crate::alloc::AllocError> {
            use ndarray::ShapeBuilder;
            let bytes = &m.map[m.header.data_offset..][..m.header.data_bytes()];
            let count = bytes.len() / std::mem::size_of::<T>();
            let mut data: ndarray::Array1<T> = crate::alloc::try_zeros(count, "the stack read")?;
            for (d, b) in data
                .iter_mut()
                .zip(bytes.chunks_exact(std::mem::size_of::<T>()))
            {
                *d = bytemuck::pod_read_unaligned(b);
            }
            let s = &m.header.shape;
            let a = ArrayView3::from_shape(
                (s[0], s[1], s[2]).set_f(m.header.fortran_order),
                data.as_slice().expect("standard layout"),
            )
            .expect("size checked at load");
            widen(nhw_view(a, hwn))
        }
        match self {
            Stack::Generated(a) => {
                let a = nhw_view(a.view(), hwn);
                let mut out = crate::alloc::try_zeros(a.raw_dim(), "the stack as complex128")?;
                out.assign(&a);
                Ok(out)
            }
            Stack::Single(a) => widen(nhw_view(a.view(), hwn)),
            Stack::Mapped(m) => match m.header.dtype {
                Dtype::Complex64 => widen_mapped::<Complex<f32>>(m, hwn),
                Dtype::Complex128 => widen_mapped::<Complex<f64>>(m, hwn),
                Dtype::Float32 => widen_mapped::<f32>(m, hwn),
                Dtype::Float64 => widen_mapped::<f64>(m, hwn),
            },
        }
    }

    /// Bytes of element data.
    pub fn bytes(&self) -> usize {
        match self {
            Stack::Generated(a) => a.len() * 16,
            Stack::Single(a) => a.len() * 8,
            Stack::Mapped(m) => m.header.data_bytes(),
        }
    }
}

impl MappedNpy {
    /// Analyses the mapped data in place; data that is not aligned for `T` (a header whose
    /// length is not a multiple of the element size) is copied first.
    fn analyse<T: Element + Sample>(
        &self,
        hwn: bool,
        levels: usize,
    ) -> Result<Analysis, AnalysisError> {
        use ndarray::ShapeBuilder;
        let bytes = &self.map[self.header.data_offset..][..self.header.data_bytes()];
        let s = &self.header.shape;
        let shape = (s[0], s[1], s[2]).set_f(self.header.fortran_order);
        match bytemuck::try_cast_slice::<u8, T>(bytes) {
            Ok(data) => analyse(
                nhw_view(
                    ArrayView3::from_shape(shape, data).expect("size checked at load"),
                    hwn,
                ),
                levels,
            ),
            Err(_) => {
                let data: Vec<T> = bytes
                    .chunks_exact(std::mem::size_of::<T>())
                    .map(bytemuck::pod_read_unaligned)
                    .collect();
                analyse(
                    nhw_view(
                        ArrayView3::from_shape(shape, &data).expect("size checked at load"),
                        hwn,
                    ),
                    levels,
                )
            }
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
    let io = |cause| NpyError::Io {
        path: path.to_path_buf(),
        cause,
    };
    let count = header.count();
    let need = count.saturating_mul(std::mem::size_of::<T>());
    let mut f = File::open(path).map_err(io)?;
    let size = f.metadata().map_err(io)?.len();
    let held = size.saturating_sub(header.data_offset as u64);
    if held < need as u64 {
        return Err(data_err(format!(
            "truncated: the header promises {need} bytes of data, the file holds {held}"
        )));
    }
    f.seek(SeekFrom::Start(header.data_offset as u64))
        .map_err(io)?;
    let mut out: Vec<T> = vec![T::zeroed(); count];
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
    read_real(
        path,
        "a map must be 2-D [H, W]",
        "a parameter map must be real (float32 or float64)",
    )
}

/// Reads a real 1-D vector (`float32` or `float64`) as f64.
///
/// # Errors
/// [`NpyError`] if the file is not a readable 1-D real array.
pub fn read_real_vector(path: &Path) -> Result<ndarray::Array1<f64>, NpyError> {
    read_real(
        path,
        "a vector must be 1-D",
        "a vector must be real (float32 or float64)",
    )
}

/// A real array of `D`'s dimensionality as f64; `shape_rule` and `type_rule` say what a wrong
/// shape or element type breaks.
fn read_real<D: ndarray::Dimension>(
    path: &Path,
    shape_rule: &str,
    type_rule: &str,
) -> Result<ndarray::Array<f64, D>, NpyError> {
    let header = read_header(path)?;
    let data = |reason: String| NpyError::Data {
        path: path.to_path_buf(),
        reason,
    };
    if Some(header.shape.len()) != D::NDIM {
        return Err(data(format!(
            "{shape_rule}, this one has shape {:?}",
            header.shape
        )));
    }
    match header.dtype {
        Dtype::Float64 => read_array::<f64, D>(path, &header),
        Dtype::Float32 => read_array::<f32, D>(path, &header).map(|a| a.mapv(f64::from)),
        _ => Err(data(type_rule.into())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_stack(path: &Path, scale: f32) {
        use ndarray_npy::WriteNpyExt;
        let a = Array3::from_shape_fn((3, 4, 4), |(n, r, c)| {
            Complex::new(scale * (n * 16 + r * 4 + c) as f32, 1.0)
        });
        a.write_npy(File::create(path).unwrap()).unwrap();
    }

    fn mapped(stack: &Stack) -> &MappedNpy {
        match stack {
            Stack::Mapped(m) => m,
            _ => panic!("not mapped"),
        }
    }

    /// A stack mapped for its hash is loaded from that mapping, once; a file changed since is
    /// mapped again and read as it is now.
    #[test]
    fn a_mapping_made_for_hashing_serves_the_next_load_of_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.npy");
        write_stack(&path, 1.0);
        let offered = unsafe { map_for_reading(&File::open(&path).unwrap()) }.unwrap();
        let first = Stack::load(&path).unwrap();
        assert!(Arc::ptr_eq(&mapped(&first).map, &offered));
        let second = Stack::load(&path).unwrap();
        assert!(!Arc::ptr_eq(&mapped(&second).map, &offered));
        assert_eq!(first.to_complex128(false), second.to_complex128(false));
        // Offered, then rewritten (other values, same size): not used.
        let stale = unsafe { map_for_reading(&File::open(&path).unwrap()) }.unwrap();
        std::thread::sleep(std::time::Duration::from_millis(10));
        drop(first);
        drop(second);
        write_stack(&path, 2.0);
        let now = Stack::load(&path).unwrap();
        assert!(!Arc::ptr_eq(&mapped(&now).map, &stale));
        assert_eq!(now.to_complex128(false)[[2, 3, 3]].re, 2.0 * 47.0);
    }
}
