//! SICD (Sensor Independent Complex Data, NGA.STND.0024): the single-look complex product
//! format of Umbra, Capella's SICD deliveries and most spotlight SAR, a NITF 2.1 file whose
//! image segments hold the pixels (big-endian `RE32F_IM32F`, `RE16I_IM16I` or
//! `AMP8I_PHS8I`, pixel-interleaved, unblocked and uncompressed as the standard requires)
//! and whose XML data extension segment holds the metadata. A scene is checked at opening
//! (the segments against the XML's `ImageData`), read a window at a time (a row of the window
//! per read, rows in parallel; a large image split over several segments read as one), and
//! described for the manifest: collector, collection time, polarisation, grid, scene centre
//! and radiometric scale factors ([`xml::Metadata`]).

pub mod nitf;
pub mod xml;

pub use xml::Pixel;

use super::cut::Window;
use super::geotiff::ifd::Order;
use super::geotiff::read::convert;
use super::geotiff::Num;
use super::mapping::Georeference;
use super::scenes::{OpenScene, Scene, Scenes};
use num_complex::Complex32;
use rayon::prelude::*;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

/// Why a SICD file cannot be read (the field: a NITF field such as `NROWS`, or a SICD XML
/// element such as `ImageData/PixelType`).
pub type SicdError = crate::io::scenes::SceneError;

/// One image segment's rows: the first image row it holds, how many, and where its pixels
/// start in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rows {
    /// First image row.
    pub first: usize,
    /// Rows held.
    pub rows: usize,
    /// Offset of its first pixel.
    pub at: u64,
}

/// A SICD image, its segments checked against its XML.
#[derive(Debug, Clone, PartialEq)]
pub struct Sicd {
    /// The file.
    pub path: PathBuf,
    /// Rows (`ImageData/NumRows`).
    pub rows: usize,
    /// Columns (`ImageData/NumCols`).
    pub cols: usize,
    /// Pixel type.
    pub pixel: Pixel,
    /// The image segments' rows, top to bottom.
    pub segments: Vec<Rows>,
    /// The metadata the manifest records.
    pub metadata: xml::Metadata,
    /// The quantity reads are calibrated to and its scale polynomial (`None`: as stored).
    pub calibration: Option<(String, xml::Poly2)>,
}

impl Sicd {
    /// Opens `path`: reads the NITF segments and the SICD XML, and checks the image segments
    /// against the XML's size and pixel type.
    ///
    /// # Errors
    /// [`SicdError::Io`] if it cannot be read; [`SicdError::Field`] naming the NITF field or
    /// XML element at fault: not NITF, no SICD XML, compressed or blocked pixels, a pixel type
    /// or size that differs between the two, a segment past the end of the file.
    pub fn open(path: &Path) -> Result<Sicd, SicdError> {
        let bad = |field: &str, reason: String| SicdError::Field {
            path: path.to_path_buf(),
            field: field.to_string(),
            reason,
        };
        let file = std::fs::File::open(path).map_err(|cause| SicdError::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        let len = file
            .metadata()
            .map_err(|cause| SicdError::Io {
                path: path.to_path_buf(),
                cause,
            })?
            .len();
        let nitf = nitf::Nitf::read(&file, len).map_err(|r| bad("NITF header", r))?;
        let des = nitf
            .des
            .iter()
            .find(|d| d.id == "XML_DATA_CONTENT" || d.id == "SICD_XML")
            .ok_or_else(|| {
                bad(
                    "DESID",
                    format!(
                        "no XML_DATA_CONTENT data extension segment (the file has {:?}): not a \
                         SICD",
                        nitf.des.iter().map(|d| d.id.as_str()).collect::<Vec<_>>()
                    ),
                )
            })?;
        let text = nitf::bytes_at(&file, des.segment.data_at, des.segment.data_len as usize)
            .map_err(|r| bad("DES", r))?;
        let text = String::from_utf8_lossy(&text);
        let (rows, cols, pixel, metadata) =
            xml::read(&text).map_err(|(element, r)| bad(element, r))?;
        let segments = segments(&nitf, (rows, cols), &pixel).map_err(|(f, r)| bad(f, r))?;
        Ok(Sicd {
            path: path.to_path_buf(),
            rows,
            cols,
            pixel,
            segments,
            metadata,
            calibration: None,
        })
    }

    /// Reads `win` into `out` (its values, row after row), rows in parallel.
    ///
    /// # Errors
    /// [`SicdError::Io`] if the file cannot be read.
    pub fn read_window(&self, win: &Window, out: &mut [Complex32]) -> Result<(), SicdError> {
        assert_eq!(out.len(), win.rows() * win.cols(), "the window's values");
        assert!(
            win.inside(self.rows, self.cols),
            "the window inside the image"
        );
        let io = |cause| SicdError::Io {
            path: self.path.clone(),
            cause,
        };
        let file = std::fs::File::open(&self.path).map_err(io)?;
        let size = self.pixel.size();
        out.par_chunks_mut(win.cols())
            .enumerate()
            .try_for_each_init(
                || vec![0u8; win.cols() * size],
                |buf, (i, row)| {
                    let r = win.r0 + i;
                    let s = self
                        .segments
                        .iter()
                        .find(|s| r < s.first + s.rows)
                        .expect("the segments cover the image");
                    let at = s.at + (((r - s.first) * self.cols + win.c0) * size) as u64;
                    file.read_exact_at(buf, at).map_err(io)?;
                    match self.pixel {
                        Pixel::Re32fIm32f => convert(Num::F32, Order::Big, buf, row),
                        Pixel::Re16iIm16i => convert(Num::I16, Order::Big, buf, row),
                        Pixel::Amp8iPhs8i(_) => {
                            for (z, b) in row.iter_mut().zip(buf.chunks_exact(size)) {
                                *z = self.pixel.value(b);
                            }
                        }
                    }
                    if let Some((_, poly)) = &self.calibration {
                        let g = &self.metadata.calibration;
                        for (j, z) in row.iter_mut().enumerate() {
                            *z *= g.factor(poly, r, win.c0 + j);
                        }
                    }
                    Ok(())
                },
            )
    }
}

/// The rows of each image segment of `nitf`, checked: uncompressed, unblocked,
/// pixel-interleaved, of the XML's pixel type and width, together the XML's rows, each within
/// the file.
fn segments(
    nitf: &nitf::Nitf,
    (rows, cols): (usize, usize),
    pixel: &Pixel,
) -> Result<Vec<Rows>, (&'static str, String)> {
    if nitf.images.is_empty() {
        return Err(("NUMI", "the file has no image segment".into()));
    }
    let (pvtype, nbpp) = pixel.nitf();
    let mut out = vec![];
    let mut first = 0;
    for (k, im) in nitf.images.iter().enumerate() {
        let seg = format!("image segment {k} ({})", im.iid1);
        if im.ic != "NC" && im.ic != "NM" {
            return Err((
                "IC",
                format!("{seg} is compressed ({}); SICD pixels are not", im.ic),
            ));
        }
        if im.blocks != (1, 1) {
            return Err((
                "NBPR",
                format!(
                    "{seg} is in {} x {} blocks; SICD images are one block",
                    im.blocks.0, im.blocks.1
                ),
            ));
        }
        if im.pvtype != pvtype || im.nbpp != nbpp || im.subcats.len() != 2 || im.imode != "P" {
            return Err((
                "PVTYPE",
                format!(
                    "{seg} holds {} band(s) of {}-bit {} (IMODE {}); the XML's {} is 2 \
                     pixel-interleaved bands of {nbpp}-bit {pvtype}",
                    im.subcats.len(),
                    im.nbpp,
                    im.pvtype,
                    im.imode,
                    pixel.name()
                ),
            ));
        }
        if im.cols != cols {
            return Err((
                "NCOLS",
                format!("{seg} has {} columns; the XML's NumCols is {cols}", im.cols),
            ));
        }
        let need = (im.rows * im.cols * pixel.size()) as u64;
        if im.segment.data_len < need {
            return Err((
                "LI",
                format!(
                    "{seg} holds {} bytes; its {} x {} pixels need {need}",
                    im.segment.data_len, im.rows, im.cols
                ),
            ));
        }
        out.push(Rows {
            first,
            rows: im.rows,
            at: im.segment.data_at,
        });
        first += im.rows;
    }
    if first != rows {
        return Err((
            "NROWS",
            format!("the image segments hold {first} rows; the XML's NumRows is {rows}"),
        ));
    }
    Ok(out)
}

/// A stack of coregistered SICD images (over time or aspect): the same window of each is one
/// sample.
pub type SicdStack = Scenes<Sicd>;

impl OpenScene for Sicd {
    fn open(path: &Path) -> Result<Sicd, SicdError> {
        Sicd::open(path)
    }
}

impl Scene for Sicd {
    type Error = SicdError;

    fn path(&self) -> &Path {
        &self.path
    }

    fn dims(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    fn read_window(&self, window: &Window, out: &mut [Complex32]) -> Result<(), SicdError> {
        Sicd::read_window(self, window, out)
    }

    /// From `Radiometric`'s `SigmaZeroSFPoly` (`sigma0`), `BetaZeroSFPoly` (`beta0`),
    /// `GammaZeroSFPoly` (`gamma0`) or `RCSSFPoly` (`rcs`).
    fn calibrate(&mut self, quantity: &str) -> Result<(), String> {
        let name = match quantity {
            "sigma0" => "SigmaZeroSFPoly",
            "beta0" => "BetaZeroSFPoly",
            "gamma0" => "GammaZeroSFPoly",
            "rcs" => "RCSSFPoly",
            q => return Err(format!("{q} is not sigma0, beta0, gamma0 or rcs")),
        };
        let g = &self.metadata.calibration;
        let poly = g.polys.get(name).ok_or_else(|| {
            format!(
                "{}: its SICD XML has no Radiometric/{name}",
                self.path.display()
            )
        })?;
        if g.scp_pixel.is_none() || g.ss.is_none() {
            return Err(format!(
                "{}: its SICD XML lacks ImageData/SCPPixel or Grid/Row/SS, Grid/Col/SS, which \
                 place Radiometric/{name}",
                self.path.display()
            ));
        }
        self.calibration = Some((quantity.to_string(), poly.clone()));
        Ok(())
    }

    /// SICD's image projection (longitude, latitude at the scene centre's height), where
    /// the XML holds what it needs.
    fn georeference(&self) -> Result<Georeference, String> {
        let p = self.metadata.projection.as_ref();
        let projection = Box::new(
            p.map_err(|m| format!("{}: {m}", self.path.display()))?
                .clone(),
        );
        let height = self.metadata.scp_llh.map(|l| l[2]).ok_or_else(|| {
            format!(
                "{}: its SICD XML lacks GeoData/SCP/LLH/HAE, the height a map box is placed at",
                self.path.display()
            )
        })?;
        Ok(Georeference::Sicd { projection, height })
    }

    fn describe(&self) -> serde_json::Value {
        serde_json::json!({
            "calibrated_to": self.calibration.as_ref().map(|c| c.0.clone()),
            "path": self.path.display().to_string(),
            "format": "SICD",
            "rows": self.rows,
            "cols": self.cols,
            "pixel": self.pixel.name(),
            "segments": self.segments.len(),
            "sicd": self.metadata,
            "projection": match &self.metadata.projection {
                Ok(p) => serde_json::json!(p.formation.name()),
                Err(why) => serde_json::json!({ "none": why }),
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn rows_converted_at_once_equal_the_pixel_by_pixel_definition() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for (pixel, num) in [(Pixel::Re32fIm32f, Num::F32), (Pixel::Re16iIm16i, Num::I16)] {
            // Random parts, as finite values of the type (float bits that are not NaN).
            let bytes: Vec<u8> = (0..64)
                .flat_map(|_| match num {
                    Num::F32 => rng.random_range(-1e6f32..1e6).to_be_bytes().to_vec(),
                    _ => rng.random::<i16>().to_be_bytes().to_vec(),
                })
                .collect();
            let mut fast = vec![Complex32::default(); 32];
            convert(num, Order::Big, &bytes, &mut fast);
            let slow: Vec<Complex32> = bytes
                .chunks_exact(pixel.size())
                .map(|b| pixel.value(b))
                .collect();
            assert_eq!(fast, slow, "{}", pixel.name());
        }
        // Amplitude through the table, phase a quarter turn.
        let table: Vec<f32> = (0..256).map(|i| i as f32 * 0.5).collect();
        let z = Pixel::Amp8iPhs8i(Some(table)).value(&[10, 64]);
        assert!((z - Complex32::new(0.0, 5.0)).norm() < 1e-6, "{z}");
    }
}
