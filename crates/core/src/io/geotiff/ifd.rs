//! A TIFF file's header and first image file directory (IFD), classic TIFF and BigTIFF, in
//! either byte order: the tags as numbers (integer, rational and floating types widened to
//! `f64` and `u64`) or ASCII text, each read from where the entry says (inline or at its
//! offset), with a tag's type and count checked against the file's length.

use std::collections::BTreeMap;
use std::os::unix::fs::FileExt;

/// A file's byte order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// `II`: little-endian.
    Little,
    /// `MM`: big-endian.
    Big,
}

impl Order {
    /// `N` bytes as an unsigned integer in this order.
    pub fn uint(self, b: &[u8]) -> u64 {
        let fold = |acc: u64, &x: &u8| (acc << 8) | u64::from(x);
        match self {
            Order::Little => b.iter().rev().fold(0, fold),
            Order::Big => b.iter().fold(0, fold),
        }
    }

    /// Two bytes as `u16`.
    pub fn u16(self, b: &[u8]) -> u16 {
        self.uint(&b[..2]) as u16
    }
}

/// One tag's values.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// Integers (BYTE, SHORT, LONG, LONG8, IFD and their signed forms, as bits).
    Ints(Vec<u64>),
    /// Floating point values (FLOAT, DOUBLE, RATIONAL, SRATIONAL).
    Floats(Vec<f64>),
    /// ASCII text (its trailing NULs dropped).
    Text(String),
    /// UNDEFINED bytes, or a type this reader does not name.
    Bytes(Vec<u8>),
}

/// The first IFD of a TIFF file: its byte order, whether it is a BigTIFF, and its tags.
#[derive(Debug, Clone, PartialEq)]
pub struct Ifd {
    /// Byte order.
    pub order: Order,
    /// BigTIFF (version 43).
    pub big: bool,
    /// Tags by number.
    pub tags: BTreeMap<u16, Value>,
}

/// The size in bytes of one value of TIFF field type `t` (`None`: not a type of TIFF 6 or
/// BigTIFF).
fn type_size(t: u16) -> Option<usize> {
    Some(match t {
        1 | 2 | 6 | 7 => 1,
        3 | 8 => 2,
        4 | 9 | 11 | 13 => 4,
        5 | 10 | 12 | 16 | 17 | 18 => 8,
        _ => return None,
    })
}

/// Reads `len` bytes at `at`, or says why not (`what` names them).
pub fn read_at(file: &std::fs::File, at: u64, len: usize, what: &str) -> Result<Vec<u8>, String> {
    let mut buf = vec![0u8; len];
    file.read_exact_at(&mut buf, at)
        .map_err(|e| format!("{what}: {len} bytes at offset {at}: {e}"))?;
    Ok(buf)
}

impl Ifd {
    /// Reads the header and the first IFD of `file` (`len` bytes long).
    ///
    /// # Errors
    /// What is wrong: not a TIFF, an IFD or a value past the end of the file.
    pub fn read(file: &std::fs::File, len: u64) -> Result<Ifd, String> {
        let head = read_at(file, 0, 16.min(len as usize), "the header")?;
        let order = match head.get(..2) {
            Some(b"II") => Order::Little,
            Some(b"MM") => Order::Big,
            _ => return Err("not a TIFF file (it does not start with II or MM)".into()),
        };
        let (big, first) = match head.get(2..4).map(|b| order.u16(b)) {
            Some(42) if head.len() >= 8 => (false, order.uint(&head[4..8])),
            Some(43) if head.len() >= 16 => (true, order.uint(&head[8..16])),
            v => {
                return Err(format!(
                    "not a TIFF file (version {v:?}; 42 for TIFF, 43 for BigTIFF)"
                ))
            }
        };
        let (count_size, entry_size, inline) = if big { (8, 20, 8) } else { (2, 12, 4) };
        if first == 0 || first >= len {
            return Err(format!(
                "its first IFD is at offset {first}, past its {len} bytes (truncated?)"
            ));
        }
        let n = order.uint(&read_at(file, first, count_size, "the IFD's entry count")?);
        if n == 0 || n > 4096 {
            return Err(format!("its first IFD claims {n} entries"));
        }
        let entries = read_at(
            file,
            first + count_size as u64,
            n as usize * entry_size,
            "the first IFD (truncated?)",
        )?;
        let mut tags = BTreeMap::new();
        for e in entries.chunks_exact(entry_size) {
            let (tag, typ) = (order.u16(&e[0..2]), order.u16(&e[2..4]));
            let (count, field) = if big {
                (order.uint(&e[4..12]), &e[12..20])
            } else {
                (order.uint(&e[4..8]), &e[8..12])
            };
            let Some(size) = type_size(typ) else {
                tags.insert(tag, Value::Bytes(vec![]));
                continue;
            };
            let bytes = (count as u128) * size as u128;
            let data = if bytes <= inline as u128 {
                field[..bytes as usize].to_vec()
            } else {
                let at = order.uint(field);
                if bytes > (len as u128).saturating_sub(at as u128) {
                    return Err(format!(
                        "tag {tag} ({}) holds {count} values at offset {at}, past the end of \
                         the file ({len} bytes; truncated?)",
                        tag_name(tag)
                    ));
                }
                read_at(file, at, bytes as usize, tag_name(tag))?
            };
            tags.insert(tag, decode(order, typ, size, &data));
        }
        Ok(Ifd { order, big, tags })
    }

    /// The integers of `tag` (`None`: absent or not integers).
    pub fn ints(&self, tag: u16) -> Option<&[u64]> {
        match self.tags.get(&tag) {
            Some(Value::Ints(v)) => Some(v),
            _ => None,
        }
    }

    /// The numbers of `tag` as `f64` (integers too; `None`: absent or text).
    pub fn floats(&self, tag: u16) -> Option<Vec<f64>> {
        match self.tags.get(&tag) {
            Some(Value::Floats(v)) => Some(v.clone()),
            Some(Value::Ints(v)) => Some(v.iter().map(|&x| x as f64).collect()),
            _ => None,
        }
    }

    /// The text of `tag`.
    pub fn text(&self, tag: u16) -> Option<&str> {
        match self.tags.get(&tag) {
            Some(Value::Text(s)) => Some(s),
            _ => None,
        }
    }
}

/// The values of one entry of type `typ` (values of `size` bytes) from its bytes.
fn decode(order: Order, typ: u16, size: usize, data: &[u8]) -> Value {
    let each = data.chunks_exact(size);
    match typ {
        2 => Value::Text(
            String::from_utf8_lossy(data)
                .trim_end_matches('\0')
                .to_string(),
        ),
        7 => Value::Bytes(data.to_vec()),
        11 => Value::Floats(
            each.map(|b| f64::from(f32::from_bits(order.uint(b) as u32)))
                .collect(),
        ),
        12 => Value::Floats(each.map(|b| f64::from_bits(order.uint(b))).collect()),
        5 => Value::Floats(
            each.map(|b| order.uint(&b[..4]) as f64 / order.uint(&b[4..]) as f64)
                .collect(),
        ),
        10 => Value::Floats(
            each.map(|b| {
                f64::from(order.uint(&b[..4]) as u32 as i32)
                    / f64::from(order.uint(&b[4..]) as u32 as i32)
            })
            .collect(),
        ),
        _ => Value::Ints(each.map(|b| order.uint(b)).collect()),
    }
}

/// A TIFF tag's name, for messages.
pub fn tag_name(tag: u16) -> &'static str {
    match tag {
        256 => "ImageWidth",
        257 => "ImageLength",
        258 => "BitsPerSample",
        259 => "Compression",
        273 => "StripOffsets",
        277 => "SamplesPerPixel",
        278 => "RowsPerStrip",
        279 => "StripByteCounts",
        284 => "PlanarConfiguration",
        317 => "Predictor",
        322 => "TileWidth",
        323 => "TileLength",
        324 => "TileOffsets",
        325 => "TileByteCounts",
        339 => "SampleFormat",
        33922 => "ModelTiepointTag",
        33550 => "ModelPixelScaleTag",
        34264 => "ModelTransformationTag",
        34735 => "GeoKeyDirectoryTag",
        _ => "a tag",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_orders_read_integers_as_written() {
        assert_eq!(Order::Little.uint(&[0x34, 0x12]), 0x1234);
        assert_eq!(Order::Big.uint(&[0x12, 0x34]), 0x1234);
        assert_eq!(
            Order::Little.uint(&1u64.to_le_bytes()),
            1,
            "an 8-byte BigTIFF offset"
        );
        let v = decode(Order::Big, 12, 8, &2.5f64.to_be_bytes());
        assert_eq!(v, Value::Floats(vec![2.5]));
        let v = decode(Order::Little, 5, 8, &[3, 0, 0, 0, 2, 0, 0, 0]);
        assert_eq!(v, Value::Floats(vec![1.5]));
        let v = decode(Order::Little, 2, 1, b"WGS 84|\0");
        assert_eq!(v, Value::Text("WGS 84|".into()));
    }
}
