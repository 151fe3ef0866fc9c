//! MAT v5 files (`save -v6`/`-v7`, SciPy's `savemat`): the reader of the file's top-level
//! variables and of one numeric array's data (single or double, any integer class, real or
//! complex; compressed (`miCOMPRESSED`) or not; little- or big-endian), and the tags the
//! writer ([`super::write`]) shares. The format is MathWorks' "MAT-File Format" (R2024a),
//! chapter 1; the file is mapped read-only and a compressed variable is inflated only when it
//! is the one being read (its header, to list it, is read from the first bytes of the
//! stream). Malformed bytes are errors, never panics.

use super::variable::{MatError, Variable, CLASSES};
use num_complex::Complex64;
use std::io::Read;
use std::path::Path;

/// `miMATRIX`: a top-level array element.
pub(crate) const MI_MATRIX: u32 = 14;
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
                stored_as: None,
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
            stored_as: None,
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
    start: usize,
    end: usize,
    compressed: bool,
}

/// A mapped MAT v5 file and where each top-level variable lies in it.
pub struct V5File {
    map: memmap2::Mmap,
    big: bool,
    entries: Vec<Entry>,
}

impl V5File {
    /// Maps `path` (whose 128-byte header said v5 of the byte order `big`) and lists its
    /// variables, reading only their headers.
    ///
    /// # Errors
    /// [`MatError`] if the file cannot be read or its elements are malformed.
    pub fn open(path: &Path, big: bool) -> Result<(V5File, Vec<Variable>), MatError> {
        let io = |cause| MatError::Io {
            path: path.to_path_buf(),
            cause,
        };
        let fmt = |reason: String| MatError::Format {
            path: path.to_path_buf(),
            reason,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        // SAFETY: read-only private map; undefined only if another process truncates the
        // file while it is read (as for `.npy` stacks).
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(io)?;
        if map.len() < 128 {
            return Err(fmt(format!(
                "not a MAT file: {} bytes, shorter than the 128-byte MAT header",
                map.len()
            )));
        }
        let mut entries = Vec::new();
        let mut variables = Vec::new();
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
            variables.push(var);
            entries.push(Entry {
                start,
                end,
                compressed,
            });
            at = if compressed { end } else { end.div_ceil(8) * 8 };
        }
        Ok((V5File { map, big, entries }, variables))
    }

    /// Reads the data of variable `index` (`v`, a numeric array) into `data`, column-major.
    ///
    /// # Errors
    /// What is malformed, in words.
    pub fn read(&self, index: usize, v: &Variable, data: &mut [Complex64]) -> Result<(), String> {
        let entry = &self.entries[index];
        let count = data.len();
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
