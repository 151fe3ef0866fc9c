//! The `sicd` dataset kind: SICD files (NITF 2.1 with SICD XML; Umbra's and Capella's
//! single-look complex deliveries, spotlight SAR), read by the core's `io::sicd`: compressed
//! or blocked pixels, a pixel type or size where the NITF segments and the XML differ, or a
//! segment past the end of the file is refused naming the file and the NITF field or XML
//! element; the window is read a row at a time, and each file's collection metadata
//! (collector, time, polarisation, grid, scene centre, radiometric scale factors) goes into
//! the manifest.

use super::scenes::{SceneDataset, SceneFormat};
use crate::io::sicd::Sicd as SicdScene;

/// The `sicd` format.
#[derive(Debug, Clone, PartialEq)]
pub struct Sicd;

impl SceneFormat for Sicd {
    const NAME: &'static str = "sicd";
    type Scene = SicdScene;
}

/// A validated `sicd` dataset.
pub type SicdDataset = SceneDataset<Sicd>;
