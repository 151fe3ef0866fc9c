//! MATLAB MAT v5 input (`save -v6`/`-v7`, SciPy's `savemat`): a reader of the file's
//! top-level variables that loads one numeric 3-D array (single or double, any integer class,
//! real or complex; compressed (`miCOMPRESSED`) or not; little- or big-endian) as a complex
//! stack in MATLAB's index order, `a[[i, j, k]] = x(i+1, j+1, k+1)`. Everything else is named
//! in a clear error: a missing variable lists the file's variables, and structs, cells, char
//! arrays, sparse matrices, objects and arrays that are not 3-D are refused with the file and
//! the variable. Malformed input (truncated, corrupted, a v4 or v7.3 file) is an error, never
//! a panic. The format is MathWorks' "MAT-File Format" (R2024a), chapter 1; the file is mapped
//! read-only and a compressed variable is inflated only when it is the one being read (its
//! header, to list it, is read from the first bytes of the stream).

use crate::io::npy::Stack;
use ndarray::Array3;
use num_complex::Complex64;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Problems reading a `.mat` file; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MatError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not a MAT v5 file this reader handles, or its bytes are malformed.
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
    /// MATLAB's class name (`double`, `single`, `int16`, `struct`, `cell`, `char`, `sparse`, ...).
    pub class: &'static str,
    /// Its dimensions (MATLAB order).
    pub dims: Vec<usize>,
    /// Whether it is complex.
    pub complex: bool,
    /// Whether it is a logical array.
    pub logical: bool,
}

impl Variable {
    /// Whether it is a numeric (not logical) array.
    pub fn is_numeric(&self) -> bool {
        numeric_class(self.class) && !self.logical
    }

    /// Whether it can be read as a stack.
    pub fn is_stack(&self) -> bool {
        self.is_numeric() && self.dims.len() == 3
    }

    /// `4x5x3 single complex`.
    pub fn describe(&self) -> String {
        let dims: Vec<String> = self.dims.iter().map(usize::to_string).collect();
        let kind = if self.logical { "logical" } else { self.class };
        let cx = if self.complex { " complex" } else { "" };
        format!("{} {kind}{cx}", dims.join("x"))
    }
}

const CLASSES: [&str; 18] = [
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

const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;

/// Bytes of one element of a MAT data type (`miINT8` .. `miDOUBLE`), `None` for others.
fn mi_size(t: u32) -> Option<usize> {
    match t {
        1 | 2 => Some(1),
        3 | 4 => Some(2),
        5..=7 => Some(4),
        9 | 12 | 13 => Some(8),
        _ => None,
    }
}

/// A byte stream with the file's byte order and a count of what was consumed.
struct Elements<R> {
    r: R,
    big: bool,
}

/// A data element's tag: type and byte count, and whether it was the 4-byte "small" form.
struct Tag {
    ty: u32,
    bytes: usize,
    small: bool,
}

impl<R: Read> Elements<R> {
    fn u32(&self, b: [u8; 4]) -> u32 {
        if self.big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    }

    fn read4(&mut self) -> Result<[u8; 4], String> {
        let mut b = [0u8; 4];
        self.r
            .read_exact(&mut b)
            .map_err(|e| format!("truncated or corrupted data ({e})"))?;
        Ok(b)
    }

    fn tag(&mut self) -> Result<Tag, String> {
        let first = self.read4()?;
        let word = self.u32(first);
        if word >> 16 != 0 {
            return Ok(Tag {
                ty: word & 0xffff,
                bytes: (word >> 16) as usize,
                small: true,
            });
        }
        let b = self.read4()?;
        let bytes = self.u32(b) as usize;
        Ok(Tag {
            ty: word,
            bytes,
            small: false,
        })
    }

    /// The payload of an element (after its tag) with its padding skipped.
    fn payload(&mut self, tag: &Tag) -> Result<Vec<u8>, String> {
        if tag.small {
            if tag.bytes > 4 {
                return Err(format!("a small data element claims {} bytes", tag.bytes));
            }
            let b = self.read4()?;
            return Ok(b[..tag.bytes].to_vec());
        }
        let mut v = Vec::new();
        let padded = tag.bytes.div_ceil(8) * 8;
        (&mut self.r)
            .take(padded as u64)
            .read_to_end(&mut v)
            .map_err(|e| format!("corrupted data ({e})"))?;
        if v.len() < tag.bytes {
            return Err(format!(
                "truncated: an element of {} bytes ends after {}",
                tag.bytes,
                v.len()
            ));
        }
        v.truncate(tag.bytes);
        Ok(v)
    }

    /// The `miMATRIX` header: flags, dimensions and name.
    fn matrix_header(&mut self) -> Result<Variable, String> {
        let t = self.tag()?;
        if t.ty != 6 || t.bytes != 8 {
            return Err("a matrix without its array-flags sub-element".into());
        }
        let f = self.payload(&t)?;
        let flags = self.u32(f[0..4].try_into().expect("8 bytes"));
        let class = CLASSES
            .get((flags & 0xff) as usize)
            .copied()
            .unwrap_or("unknown");
        if class == "opaque" {
            // An opaque object (`string`, `table`, ...) has no dimensions sub-element.
            let t = self.tag()?;
            let name = String::from_utf8_lossy(&self.payload(&t)?).into_owned();
            return Ok(Variable {
                name,
                class,
                dims: Vec::new(),
                complex: false,
                logical: false,
            });
        }
        let t = self.tag()?;
        if t.ty != 5 || t.bytes % 4 != 0 {
            return Err("a matrix without its dimensions sub-element".into());
        }
        let d = self.payload(&t)?;
        let dims = d
            .chunks_exact(4)
            .map(|c| usize::try_from(self.u32(c.try_into().expect("4 bytes")) as i32))
            .collect::<Result<Vec<usize>, _>>()
            .map_err(|_| "a negative dimension".to_string())?;
        let t = self.tag()?;
        if t.ty != 1 && t.ty != 2 {
            return Err("a matrix without its name sub-element".into());
        }
        let name = String::from_utf8_lossy(&self.payload(&t)?).into_owned();
        Ok(Variable {
            name,
            class,
            dims,
            complex: flags & 0x0800 != 0,
            logical: flags & 0x0200 != 0,
        })
    }

    /// Reads a numeric sub-element of `count` values into `out` (real or imaginary parts).
    fn numeric(&mut self, count: usize, mut put: impl FnMut(usize, f64)) -> Result<(), String> {
        let t = self.tag()?;
        let size = mi_size(t.ty).ok_or(format!("data of unknown type {}", t.ty))?;
        if Some(t.bytes) != count.checked_mul(size) {
            return Err(format!(
                "{} bytes of data for {count} values of {size} bytes",
                t.bytes
            ));
        }
        let big = self.big;
        let mut decode = |i: usize, b: &[u8]| {
            macro_rules! num {
                ($t:ty) => {{
                    let a = b.try_into().expect("element size");
                    (if big {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    }) as f64
                }};
            }
            let v = match t.ty {
                1 => num!(i8),
                2 => num!(u8),
                3 => num!(i16),
                4 => num!(u16),
                5 => num!(i32),
                6 => num!(u32),
                7 => num!(f32),
                9 => num!(f64),
                12 => num!(i64),
                _ => num!(u64),
            };
            put(i, v);
        };
        if t.small {
            let b = self.read4()?;
            for (i, c) in b[..t.bytes].chunks_exact(size).enumerate() {
                decode(i, c);
            }
            return Ok(());
        }
        // Stream in blocks: no second copy of the data in its stored type.
        let mut buf = vec![0u8; size * 8192];
        let mut done = 0;
        while done < count {
            let n = (count - done).min(8192);
            self.r
                .read_exact(&mut buf[..n * size])
                .map_err(|e| format!("truncated or corrupted data ({e})"))?;
            for (k, c) in buf[..n * size].chunks_exact(size).enumerate() {
                decode(done + k, c);
            }
            done += n;
        }
        let pad = t.bytes.div_ceil(8) * 8 - t.bytes;
        let mut skip = [0u8; 8];
        // Padding may be absent at the very end of a compressed stream.
        let _ = self.r.read(&mut skip[..pad]);
        Ok(())
    }
}

/// One top-level element: where its payload lies and whether it is compressed.
struct Entry {
    var: Variable,
    start: usize,
    end: usize,
    compressed: bool,
}

/// A mapped MAT v5 file and the list of its top-level variables.
pub struct MatFile {
    path: PathBuf,
    map: memmap2::Mmap,
    big: bool,
    entries: Vec<Entry>,
}

impl MatFile {
    /// Opens `path`, checks the header, and lists the variables (reading only their headers).
    ///
    /// # Errors
    /// [`MatError`] if the file cannot be read or is not a well-formed MAT v5 file.
    pub fn open(path: &Path) -> Result<MatFile, MatError> {
        let io = |source| MatError::Io {
            path: path.to_path_buf(),
            source,
        };
        let fmt = |reason: String| MatError::Format {
            path: path.to_path_buf(),
            reason,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        // SAFETY: read-only private map; undefined only if another process truncates the
        // file while it is read (as for `.npy` stacks).
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(io)?;
        let big = header(&map).map_err(fmt)?;
        let mut entries = Vec::new();
        let mut at = 128;
        while at < map.len() {
            if map.len() - at < 8 {
                return Err(fmt(format!(
                    "truncated: {} stray bytes at the end",
                    map.len() - at
                )));
            }
            let mut e = Elements { r: &map[at..], big };
            let tag = e.tag().map_err(fmt)?;
            let start = at + 8;
            let end = start
                .checked_add(tag.bytes)
                .filter(|&end| end <= map.len())
                .ok_or_else(|| {
                    fmt(format!(
                        "truncated: the variable at byte {at} claims {} bytes, the file has {} left",
                        tag.bytes,
                        map.len() - start
                    ))
                })?;
            let compressed = match tag.ty {
                MI_MATRIX => false,
                MI_COMPRESSED => true,
                t => {
                    return Err(fmt(format!(
                        "unexpected data element of type {t} at byte {at}"
                    )))
                }
            };
            let var = entry_header(&map[start..end], compressed, big)
                .map_err(|r| fmt(format!("variable at byte {at}: {r}")))?;
            entries.push(Entry {
                var,
                start,
                end,
                compressed,
            });
            at = if compressed { end } else { end.div_ceil(8) * 8 };
        }
        Ok(MatFile {
            path: path.to_path_buf(),
            map,
            big,
            entries,
        })
    }

    /// The file's top-level variables, in file order.
    pub fn variables(&self) -> Vec<Variable> {
        self.entries.iter().map(|e| e.var.clone()).collect()
    }

    /// Reads the variable `name` (or, when `None`, the only numeric 3-D array) as a complex
    /// stack in MATLAB's index order (`[H, W, N]` for MATLAB's usual layout).
    ///
    /// # Errors
    /// [`MatError`] if the variable is missing, ambiguous, not a numeric 3-D array, malformed,
    /// or does not fit in memory.
    pub fn read_stack(&self, name: Option<&str>) -> Result<Array3<Complex64>, MatError> {
        let entry = match name {
            Some(n) => self
                .entries
                .iter()
                .find(|e| e.var.name == n)
                .ok_or_else(|| MatError::Missing {
                    path: self.path.clone(),
                    name: n.to_string(),
                    variables: self.variables(),
                })?,
            None => {
                let stacks: Vec<&Entry> =
                    self.entries.iter().filter(|e| e.var.is_stack()).collect();
                if stacks.len() != 1 {
                    return Err(MatError::Ambiguous {
                        path: self.path.clone(),
                        count: stacks.len(),
                        variables: self.variables(),
                    });
                }
                stacks[0]
            }
        };
        let v = &entry.var;
        if !v.is_stack() {
            let what = match v.class {
                "struct" => "a struct".to_string(),
                "cell" => "a cell array".to_string(),
                "char" => "a char array".to_string(),
                "sparse" => "a sparse matrix".to_string(),
                "object" | "opaque" | "function_handle" => format!("a MATLAB {} object", v.class),
                _ if v.logical => "a logical array".to_string(),
                _ if v.is_numeric() => format!("{}-D ({})", v.dims.len(), v.describe()),
                _ => format!("of class {}", v.class),
            };
            return Err(MatError::NotStack {
                path: self.path.clone(),
                name: v.name.clone(),
                what,
            });
        }
        let fmt = |reason: String| MatError::Format {
            path: self.path.clone(),
            reason: format!("variable {:?}: {reason}", v.name),
        };
        let (d0, d1, d2) = (v.dims[0], v.dims[1], v.dims[2]);
        let count = d0
            .checked_mul(d1)
            .and_then(|c| c.checked_mul(d2))
            .ok_or_else(|| fmt("its size overflows".into()))?;
        // Column-major (d0, d1, d2) is row-major (d2, d1, d0): fill linearly, then reverse.
        let mut out: Array3<Complex64> =
            crate::alloc::try_zeros((d2, d1, d0), "the MAT-file stack")?;
        let data = out.as_slice_mut().expect("standard layout");
        let bytes = &self.map[entry.start..entry.end];
        let mut read = |r: &mut dyn Read| -> Result<(), String> {
            let mut e = Elements { r, big: self.big };
            if entry.compressed {
                let t = e.tag()?;
                if t.ty != MI_MATRIX {
                    return Err("the compressed element is not a matrix".into());
                }
            }
            e.matrix_header()?;
            e.numeric(count, |i, x| data[i].re = x)?;
            if v.complex {
                e.numeric(count, |i, x| data[i].im = x)?;
            }
            Ok(())
        };
        if entry.compressed {
            read(&mut flate2::read::ZlibDecoder::new(bytes))
        } else {
            read(&mut &bytes[..])
        }
        .map_err(fmt)?;
        Ok(out.reversed_axes())
    }
}

/// Checks the 128-byte header; returns whether the file is big-endian.
fn header(map: &[u8]) -> Result<bool, String> {
    if map.starts_with(b"\x89HDF\r\n\x1a\n") {
        return Err("an HDF5 file without a MATLAB header: not a MAT file".into());
    }
    if map.len() < 128 {
        return Err(format!(
            "not a MAT file: {} bytes, shorter than the 128-byte MAT v5 header",
            map.len()
        ));
    }
    let big = match &map[126..128] {
        b"IM" => false,
        b"MI" => true,
        _ if map[..4].contains(&0) => {
            return Err("not a MAT v5 file (a MAT v4 file? save it with -v7 or -v7.3)".into())
        }
        _ => return Err("not a MAT file: no endian indicator at byte 126".into()),
    };
    let version = if big {
        u16::from_be_bytes([map[124], map[125]])
    } else {
        u16::from_le_bytes([map[124], map[125]])
    };
    match version {
        0x0100 => Ok(big),
        0x0200 => Err("a MAT v7.3 (HDF5) file: not read yet".into()),
        v => Err(format!("unknown MAT version {v:#06x}")),
    }
}

/// The header of a top-level element's matrix, inflating only its first bytes if compressed.
fn entry_header(bytes: &[u8], compressed: bool, big: bool) -> Result<Variable, String> {
    if compressed {
        let mut e = Elements {
            r: flate2::read::ZlibDecoder::new(bytes),
            big,
        };
        let t = e.tag()?;
        if t.ty != MI_MATRIX {
            return Err(format!(
                "compressed element of type {} (not a matrix)",
                t.ty
            ));
        }
        e.matrix_header()
    } else {
        Elements { r: bytes, big }.matrix_header()
    }
}

/// Loads a stack from a MAT v5 file (see [`MatFile::read_stack`]).
///
/// # Errors
/// As for [`MatFile::open`] and [`MatFile::read_stack`].
pub fn load_stack(path: &Path, variable: Option<&str>) -> Result<Stack, MatError> {
    Ok(Stack::Generated(MatFile::open(path)?.read_stack(variable)?))
}
