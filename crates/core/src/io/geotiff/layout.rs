//! What a GeoTIFF is once its first directory is checked ([`GeoTiff`]: its size, the number
//! type of its pixels' parts, its byte order, compression and blocks, its georeferencing), and
//! the errors of reading one; shared by the checks of `mod.rs` and the reads of `read.rs`.

use super::georef::Georef;
use super::ifd::Order;
use std::path::PathBuf;

/// Why a GeoTIFF cannot be read (the field: a TIFF tag, `header`, or a block).
pub type TiffError = crate::io::scenes::SceneError;

/// The number type of a pixel's real and imaginary parts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Num {
    /// 16-bit signed integers.
    I16,
    /// 32-bit signed integers.
    I32,
    /// IEEE single precision.
    F32,
    /// IEEE double precision.
    F64,
}

impl Num {
    /// Bytes of one part.
    pub fn size(self) -> usize {
        match self {
            Num::I16 => 2,
            Num::I32 | Num::F32 => 4,
            Num::F64 => 8,
        }
    }

    /// GDAL's name of the complex type of two parts of this type.
    pub fn gdal_complex(self) -> &'static str {
        match self {
            Num::I16 => "CInt16",
            Num::I32 => "CInt32",
            Num::F32 => "CFloat32",
            Num::F64 => "CFloat64",
        }
    }

    /// The part stored in `b` (this type's bytes in `order`), as `f32`.
    #[inline]
    pub fn read(self, order: Order, b: &[u8]) -> f32 {
        let le = order == Order::Little;
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().expect("a part's bytes");
                if le {
                    <$t>::from_le_bytes(a)
                } else {
                    <$t>::from_be_bytes(a)
                }
            }};
        }
        match self {
            Num::I16 => f32::from(get!(i16, 2)),
            Num::I32 => get!(i32, 4) as f32,
            Num::F32 => get!(f32, 4),
            Num::F64 => get!(f64, 8) as f32,
        }
    }
}

/// How a file compresses its blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Stored as is (`Compression` 1).
    None,
    /// zlib (`Compression` 8, or the old 32946).
    Deflate,
}

/// The strips or tiles of an image: each block `bw x bh` pixels (a strip: the image's width,
/// `RowsPerStrip` rows, the last one possibly shorter; a tile: always whole, padded at the
/// right and bottom edges), `across x down` of them a plane, plane after plane.
#[derive(Debug, Clone, PartialEq)]
pub struct Blocks {
    /// Tiles (else strips).
    pub tiled: bool,
    /// Block width (pixels).
    pub bw: usize,
    /// Block height (rows).
    pub bh: usize,
    /// Blocks across a row of blocks.
    pub across: usize,
    /// Rows of blocks.
    pub down: usize,
    /// Each block's offset in the file.
    pub offsets: Vec<u64>,
    /// Each block's stored bytes.
    pub counts: Vec<u64>,
}

/// A complex GeoTIFF image, its layout checked against its file.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoTiff {
    /// The file.
    pub path: PathBuf,
    /// Rows (`ImageLength`).
    pub rows: usize,
    /// Columns (`ImageWidth`).
    pub cols: usize,
    /// The parts' number type.
    pub num: Num,
    /// Whether the real and imaginary parts lie in two planes (`PlanarConfiguration` 2).
    pub planar: bool,
    /// Byte order.
    pub order: Order,
    /// BigTIFF.
    pub big: bool,
    /// Compression.
    pub compression: Compression,
    /// Strips or tiles.
    pub blocks: Blocks,
    /// Georeferencing.
    pub georef: Georef,
    /// Sentinel-1's calibration of its reads, from its SAFE product (`None`: as stored).
    pub calibration: Option<crate::io::lut::Calibrated>,
}
