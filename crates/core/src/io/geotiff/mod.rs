//! Complex GeoTIFF scenes: Sentinel-1 SLC measurement files and Capella SLCs (complex int16,
//! GDAL's `CInt16`), complex float images (`CFloat32`, `CInt32`, `CFloat64`) and images of two
//! samples a pixel, real then imaginary (int16 or float32, interleaved or in two planes);
//! classic TIFF or BigTIFF in either byte order, in strips or tiles, uncompressed or deflated.
//! The first image of the file is read (overviews are not), a window at a time
//! ([`read::read_window`]): only the strips or tiles under the window are read, so a window of
//! a scene of any size needs the window's memory and a band of blocks. Its georeferencing
//! ([`georef::Georef`]) goes into a run's manifest. A Sentinel-1 measurement inside its SAFE
//! product is calibrated by the product's calibration annotation ([`s1cal`]).
//!
//! Why a reader of our own: the `tiff` crate (image-rs, 0.11) decodes no complex sample
//! format (TIFF's `SampleFormat` 5 and 6), and GDAL, which does, would add a C library with
//! ~100 shared dependencies to every build for the one format; what a SAR GeoTIFF uses is a
//! small, fixed part of TIFF 6 and BigTIFF, tested here against files GDAL wrote (rasterio).

pub mod georef;
pub mod ifd;
pub mod layout;
pub mod read;
pub mod s1cal;

pub use ifd::tag_name;
pub use layout::{Blocks, Compression, GeoTiff, Num, TiffError};

use super::cut::Window;
use super::mapping::{Gcp, Georeference};
use super::scenes::{OpenScene, Scene, Scenes};
use ifd::Ifd;
use num_complex::Complex32;
use std::path::Path;

impl GeoTiff {
    /// Opens `path`: reads its first image's tags and checks that it holds complex pixels of a
    /// kind this reader takes and that every block lies inside the file.
    ///
    /// # Errors
    /// [`TiffError::Io`] if it cannot be read; [`TiffError::Field`] naming the tag at fault:
    /// not a TIFF, real or unsigned pixels, a compression or predictor it does not take, a
    /// block past the end of the file (truncated).
    pub fn open(path: &Path) -> Result<GeoTiff, TiffError> {
        let io = |cause| TiffError::Io {
            path: path.to_path_buf(),
            cause,
        };
        let bad = |field: &str, reason: String| TiffError::Field {
            path: path.to_path_buf(),
            field: field.to_string(),
            reason,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let ifd = Ifd::read(&file, len).map_err(|r| bad("header", r))?;
        let one = |tag: u16| -> Result<u64, TiffError> {
            match ifd.ints(tag) {
                Some([v, ..]) => Ok(*v),
                _ => Err(bad(tag_name(tag), "missing (or not an integer)".into())),
            }
        };
        let or = |tag: u16, default: u64| {
            ifd.ints(tag)
                .and_then(|v| v.first().copied())
                .unwrap_or(default)
        };
        let (cols, rows) = (one(256)? as usize, one(257)? as usize);
        if rows == 0 || cols == 0 {
            return Err(bad(
                "ImageWidth",
                format!("the image is {rows} x {cols} pixels"),
            ));
        }
        let (num, planar) = pixel_type(&ifd).map_err(|(tag, r)| bad(tag, r))?;
        let compression = match or(259, 1) {
            1 => Compression::None,
            8 | 32946 => Compression::Deflate,
            c => {
                return Err(bad(
                    "Compression",
                    format!(
                        "{c} ({}); this reader takes uncompressed (1) and deflate (8): \
                         gdal_translate -co COMPRESS=DEFLATE rewrites it",
                        match c {
                            5 => "LZW",
                            7 => "JPEG",
                            50000 => "zstd",
                            34887 => "LERC",
                            _ => "another scheme",
                        }
                    ),
                ))
            }
        };
        match or(317, 1) {
            1 => {}
            p => {
                return Err(bad(
                    "Predictor",
                    format!("{p}; this reader takes none (1): gdal_translate -co PREDICTOR=1"),
                ))
            }
        }
        let blocks = blocks(&ifd, rows, cols, planar).map_err(|(tag, r)| bad(tag, r))?;
        for (k, (&at, &n)) in blocks.offsets.iter().zip(&blocks.counts).enumerate() {
            if at.checked_add(n).is_none_or(|end| end > len) {
                let what = if blocks.tiled {
                    "TileByteCounts"
                } else {
                    "StripByteCounts"
                };
                return Err(bad(
                    what,
                    format!(
                        "block {k} holds {n} bytes at offset {at}, past the end of the file \
                         ({len} bytes): truncated"
                    ),
                ));
            }
        }
        Ok(GeoTiff {
            path: path.to_path_buf(),
            rows,
            cols,
            num,
            planar,
            order: ifd.order,
            big: ifd.big,
            compression,
            blocks,
            georef: georef::Georef::read(&ifd),
            calibration: None,
        })
    }

    /// What the manifest records of the file: its size, pixel type, layout and georeferencing.
    pub fn describe(&self) -> serde_json::Value {
        serde_json::json!({
            "path": self.path.display().to_string(),
            "format": if self.big { "BigTIFF" } else { "TIFF" },
            "rows": self.rows,
            "cols": self.cols,
            "pixel": self.num.gdal_complex(),
            "planes": if self.planar { 2 } else { 1 },
            "compression": match self.compression {
                Compression::None => "none",
                Compression::Deflate => "deflate",
            },
            "blocks": if self.blocks.tiled { "tiles" } else { "strips" },
            "georef": self.georef,
            "calibrated_to": self.calibration.as_ref().map(|c| c.quantity.clone()),
            "calibration_source": self.calibration.as_ref().map(|c| c.source.clone()),
        })
    }
}

/// The parts' type and whether they lie in two planes, from `SampleFormat`,
/// `BitsPerSample`, `SamplesPerPixel` and `PlanarConfiguration`.
fn pixel_type(ifd: &Ifd) -> Result<(Num, bool), (&'static str, String)> {
    let spp = ifd.ints(277).and_then(|v| v.first().copied()).unwrap_or(1);
    let format = ifd.ints(339).and_then(|v| v.first().copied()).unwrap_or(1);
    let bits = ifd.ints(258).and_then(|v| v.first().copied()).unwrap_or(1);
    let planar = ifd.ints(284).and_then(|v| v.first().copied()).unwrap_or(1) == 2;
    let num = |part_bits: u64, float: bool| match (part_bits, float) {
        (16, false) => Some(Num::I16),
        (32, false) => Some(Num::I32),
        (32, true) => Some(Num::F32),
        (64, true) => Some(Num::F64),
        _ => None,
    };
    let found = match (spp, format) {
        (1, 5) => num(bits / 2, false),
        (1, 6) => num(bits / 2, true),
        (2, 2) => num(bits, false),
        (2, 3) => num(bits, true),
        _ => None,
    };
    let formats = [
        "?",
        "unsigned integer",
        "signed integer",
        "float",
        "undefined",
        "complex integer",
        "complex float",
    ];
    found.map(|n| (n, planar && spp == 2)).ok_or_else(|| {
        (
            "SampleFormat",
            format!(
                "{spp} sample(s) a pixel of {bits}-bit {} (SampleFormat {format}); a complex \
                     image is one complex sample (CInt16, CInt32, CFloat32, CFloat64) or two \
                     signed int16 / float32 samples (real, imaginary)",
                formats.get(format as usize).unwrap_or(&"?")
            ),
        )
    })
}

/// The strips or tiles of `ifd`'s image of `rows x cols` (`planar`: two planes).
fn blocks(
    ifd: &Ifd,
    rows: usize,
    cols: usize,
    planar: bool,
) -> Result<Blocks, (&'static str, String)> {
    let tiled = ifd.ints(322).is_some();
    let (bw, bh, offsets, counts) = if tiled {
        let side = |tag| ifd.ints(tag).and_then(|v| v.first().copied()).unwrap_or(0) as usize;
        (side(322), side(323), 324, 325)
    } else {
        let rps = ifd
            .ints(278)
            .and_then(|v| v.first().copied())
            .unwrap_or(u64::from(u32::MAX));
        (cols, (rps as usize).clamp(1, rows), 273, 279)
    };
    if bw == 0 || bh == 0 {
        return Err(("TileWidth", format!("tiles of {bw} x {bh} pixels")));
    }
    let (across, down) = (cols.div_ceil(bw), rows.div_ceil(bh));
    let n = across * down * if planar { 2 } else { 1 };
    let list = |tag: u16| -> Result<Vec<u64>, (&'static str, String)> {
        let v = ifd
            .ints(tag)
            .ok_or((tag_name(tag), "missing".to_string()))?;
        if v.len() != n {
            return Err((
                tag_name(tag),
                format!("{} values for the image's {n} blocks", v.len()),
            ));
        }
        Ok(v.to_vec())
    };
    Ok(Blocks {
        tiled,
        bw,
        bh,
        across,
        down,
        offsets: list(offsets)?,
        counts: list(counts)?,
    })
}

/// A stack of coregistered complex GeoTIFF scenes: the same window of each is one sample.
pub type TiffStack = Scenes<GeoTiff>;

impl OpenScene for GeoTiff {
    fn open(path: &Path) -> Result<GeoTiff, TiffError> {
        GeoTiff::open(path)
    }
}

impl Scene for GeoTiff {
    type Error = TiffError;

    fn path(&self) -> &Path {
        &self.path
    }

    fn dims(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    fn read_window(&self, window: &Window, out: &mut [Complex32]) -> Result<(), TiffError> {
        read::read_window(self, window, out)?;
        if let Some(c) = &self.calibration {
            c.apply(window, out);
        }
        Ok(())
    }

    /// `sigma0`, `beta0` or `gamma0` by the Sentinel-1 calibration annotation of its SAFE
    /// product (each value divided by the table at its pixel, [`s1cal`]).
    fn calibrate(&mut self, quantity: &str) -> Result<(), String> {
        let c = s1cal::sentinel1(&self.path, quantity, (self.rows, self.cols))?;
        self.calibration = Some(c);
        Ok(())
    }

    fn describe(&self) -> serde_json::Value {
        GeoTiff::describe(self)
    }

    /// Rows of a tile, or of a strip.
    fn block_rows(&self) -> usize {
        self.blocks.bh.max(1)
    }

    /// The affine transform of the tags, or else their ground control points (two tie points
    /// or more), moved by half a pixel where the raster's points are pixel centres (GeoKey
    /// 1025, `RasterPixelIsPoint`), as GDAL reads them.
    fn georeference(&self) -> Result<Georeference, String> {
        let point = self.georef.geokeys.get(&1025) == Some(&georef::KeyValue::Ints(vec![2]));
        let half = if point { 0.5 } else { 0.0 };
        if let Some([x0, a, b, y0, d, e]) = self.georef.affine {
            return Ok(Georeference::Affine([
                x0 - half * (a + b),
                a,
                b,
                y0 - half * (d + e),
                d,
                e,
            ]));
        }
        if self.georef.tiepoints.len() < 2 {
            return Err(crate::io::scenes::no_georeference(&self.path));
        }
        Ok(Georeference::Gcps(
            self.georef
                .tiepoints
                .iter()
                .map(|t| Gcp {
                    col: t[0] + half,
                    row: t[1] + half,
                    x: t[3],
                    y: t[4],
                })
                .collect(),
        ))
    }
}
