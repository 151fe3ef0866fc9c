//! The NetCDF-3 header: the big-endian cursor over the file's bytes, the parse of numrecs,
//! dimensions, global attributes and variables with every offset and size checked against the
//! file, and the decoder of stored values into their numeric type.

use super::types::{AttrValue, Dimension, NcError, NcType, Variable};
use std::path::Path;

pub(super) const NC_DIMENSION: u32 = 0x0A;
pub(super) const NC_VARIABLE: u32 = 0x0B;
pub(super) const NC_ATTRIBUTE: u32 = 0x0C;
pub(super) const STREAMING: u32 = 0xFFFF_FFFF;

pub(super) fn pad4(n: u64) -> u64 {
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
pub(super) enum Raw {
    Bytes(Vec<i8>),
    Shorts(Vec<i16>),
    Ints(Vec<i32>),
    Floats(Vec<f32>),
    Doubles(Vec<f64>),
}

impl Raw {
    /// Decodes big-endian values of a numeric type (`None` for NC_CHAR).
    pub(super) fn decode(ty: NcType, b: &[u8]) -> Option<Raw> {
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

type ParsedHeader = (
    u8,
    usize,
    Vec<Dimension>,
    Vec<(String, AttrValue)>,
    Vec<Variable>,
    u64,
);

/// Parses a NetCDF-3 header: dimensions, global attributes and variables, in file order.
///
/// Long because the header's parts are read in file order from one cursor, each checked with its
/// own error.
pub(super) fn parse_header(path: &Path, bytes: &[u8]) -> Result<ParsedHeader, NcError> {
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
