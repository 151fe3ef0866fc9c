//! The `geotiff` dataset kind: complex GeoTIFF scenes (Sentinel-1 SLC measurement files,
//! Capella SLCs, GDAL's `CInt16` / `CFloat32` images), read by the core's `io::geotiff`: a
//! real or unsigned pixel type, a compression it does not take or a block past the end of the
//! file is refused naming the file and the TIFF tag; only the strips or tiles under the
//! window are read, and each file's georeferencing goes into the manifest.

use super::scenes::{SceneDataset, SceneFormat};
use crate::io::geotiff::GeoTiff;

/// The `geotiff` format.
#[derive(Debug, Clone, PartialEq)]
pub struct Geotiff;

impl SceneFormat for Geotiff {
    const NAME: &'static str = "geotiff";
    type Scene = GeoTiff;
}

/// A validated `geotiff` dataset.
pub type GeotiffDataset = SceneDataset<Geotiff>;
