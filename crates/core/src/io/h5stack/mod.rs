//! Complex image stacks in HDF5 files (h5py's files, and the products of NISAR, ICEYE and OPERA
//! that store single-look complex data in HDF5). A stack is one dataset at a path in the file,
//! `[N, H, W]` (or `[H, W, N]`), whose elements are complex (a compound of two numbers named
//! `r`/`i`, as h5py and NISAR write them, `real`/`imag` or `re`/`im`), real (a second dataset
//! of the same shape may hold the imaginary parts), or float pairs (a last dimension of 2:
//! real, imaginary). Read with libhdf5 through `hdf5-metno` in a build with the cargo feature
//! `mat73` (`read.rs`): a contiguous dataset of complex64 or complex128 elements is mapped as
//! an `.npy` file is; any other is read in blocks of whole chunks (chunked and compressed
//! datasets included), so memory holds the stack and one block, never the file; a build
//! without it refuses such a stack, saying so. A single scene `[H, W]` ([`H5Scene`]) is read a
//! window at a time instead, to be cut into patches, and placed on the map by the coordinate
//! vectors beside it (`coords.rs`), and calibrated by the product's own scale factors
//! (`calibration.rs`: NISAR's tables, read by [`crate::io::lut`]; ICEYE's factor).

use crate::io::npy::Stack;
use std::path::Path;

#[cfg(feature = "mat73")]
mod calibration;
#[cfg(feature = "mat73")]
mod chunks;
pub mod coords;
#[cfg(feature = "mat73")]
mod geolocation;
#[cfg(feature = "mat73")]
mod product;
#[cfg(feature = "mat73")]
mod read;
mod types;

pub use types::{Form, H5Stack, OpenError, Storage};

impl H5Stack {
    /// Opens the stack `dataset` of `path` (with the imaginary parts in `imag`, for real
    /// data; samples last with `hwn`).
    ///
    /// # Errors
    /// The field and what is wrong, naming the file and the dataset: not HDF5 (or
    /// truncated), no such dataset (the file's top-level members listed), not numbers, not a
    /// stack's shape, `imag` of another shape or given for complex data; in a build without
    /// HDF5, that.
    pub fn open(
        path: &Path,
        dataset: &str,
        imag: Option<&str>,
        hwn: bool,
    ) -> Result<H5Stack, OpenError> {
        #[cfg(feature = "mat73")]
        {
            read::open(path, dataset, imag, hwn)
        }
        #[cfg(not(feature = "mat73"))]
        {
            let _ = (dataset, imag, hwn);
            Err((
                "path",
                format!(
                    "{}: this build reads no HDF5 (build with the `mat73` feature: make build)",
                    path.display()
                ),
            ))
        }
    }

    /// Reads the window `win` of a single scene ([`H5Stack::scene`]) into `out` (its values,
    /// row after row), one hyperslab, rounded to complex64.
    ///
    /// # Errors
    /// What libhdf5 says, naming the file and the dataset.
    pub fn read_window(
        &self,
        win: &crate::io::cut::Window,
        out: &mut [num_complex::Complex32],
    ) -> Result<(), String> {
        #[cfg(feature = "mat73")]
        {
            read::read_window(self, win, out)
        }
        #[cfg(not(feature = "mat73"))]
        {
            let _ = (win, out);
            Err(format!("{}: this build reads no HDF5", self.path.display()))
        }
    }

    /// The stack, `[N, H, W]` or, mapped, as stored (then `[H, W, N]` where [`H5Stack::hwn`]):
    /// a contiguous, unfiltered dataset whose elements are byte for byte complex64,
    /// complex128 or real floats is mapped as an `.npy` file's data is ([`Stack::Mapped`], no
    /// copy); any other is read in blocks of whole chunks of samples into complex64
    /// ([`Stack::Single`], where its numbers fit a `f32`: floats of 4 bytes, integers of 2) or
    /// complex128 (`[N, H, W]` whatever the stored order).
    ///
    /// # Errors
    /// What libhdf5 says, naming the dataset; a failed allocation.
    pub fn load(&self) -> Result<Stack, String> {
        #[cfg(feature = "mat73")]
        {
            read::load(self)
        }
        #[cfg(not(feature = "mat73"))]
        {
            Err(format!("{}: this build reads no HDF5", self.path.display()))
        }
    }

    /// Whether the stack [`H5Stack::load`] gives keeps the stored axis order (a mapped `[H,
    /// W, N]` dataset), which its analysis must then be told.
    pub fn loaded_hwn(&self) -> bool {
        self.hwn && matches!(self.storage, Storage::Mapped { .. })
    }

    /// Bytes of memory [`H5Stack::load`] allocates (none where it maps the file).
    pub fn loaded_bytes(&self) -> f64 {
        let (n, h, w) = self.shape();
        let values = n as f64 * h as f64 * w as f64;
        match self.storage {
            Storage::Mapped { .. } => 0.0,
            Storage::Single => 8.0 * values,
            Storage::Double => 16.0 * values,
        }
    }
}

/// A single scene `[H, W]` in an HDF5 file (a NISAR RSLC or OPERA CSLC frame) as a
/// [`crate::io::scenes::Scene`]: read a window (one hyperslab) at a time, so that a scene of
/// any size is cut into patches in bands.
#[derive(Debug, Clone, PartialEq)]
pub struct H5Scene {
    /// The scene's dataset, checked.
    pub stack: H5Stack,
    /// How its reads are calibrated (`None`: as stored).
    pub calibration: Option<crate::io::lut::Calibrated>,
    /// What placed a map window on it, once [`crate::io::scenes::Scene::georeference`] has
    /// (for the manifest): the coordinate vectors, or the geolocation grid and its height.
    placed_by: std::sync::OnceLock<String>,
}

impl H5Scene {
    /// The scene `stack`, as stored.
    pub fn new(stack: H5Stack) -> H5Scene {
        H5Scene {
            stack,
            calibration: None,
            placed_by: std::sync::OnceLock::new(),
        }
    }
}

impl crate::io::scenes::Scene for H5Scene {
    type Error = String;

    fn path(&self) -> &Path {
        &self.stack.path
    }

    fn dims(&self) -> (usize, usize) {
        (self.stack.dims[1], self.stack.dims[2])
    }

    fn read_window(
        &self,
        window: &crate::io::cut::Window,
        out: &mut [num_complex::Complex32],
    ) -> Result<(), String> {
        self.stack.read_window(window, out)?;
        if let Some(c) = &self.calibration {
            c.apply(window, out);
        }
        Ok(())
    }

    /// `beta0`, `sigma0` or `gamma0` from the product's table of it where a group above the
    /// scene holds NISAR's `metadata/calibrationInformation/geometry` (each value divided by
    /// the table, read bilinearly at its pixel: [`crate::io::lut`]), else `beta0` from the file's
    /// `calibration_factor` (ICEYE's SLC products: `beta0 = calibration_factor |value|^2`, as
    /// sarpy's ICEYE reader reads it: every value times the factor's square root).
    fn calibrate(&mut self, quantity: &str) -> Result<(), String> {
        #[cfg(feature = "mat73")]
        {
            use crate::io::lut::{Calibrated, Scale};
            let st = &self.stack;
            let calibrated = |source: String, scale| Calibrated {
                quantity: quantity.to_string(),
                source,
                scale,
            };
            if let Some((source, table)) = calibration::nisar_table(st, quantity)? {
                self.calibration = Some(calibrated(source, Scale::Table(Box::new(table))));
                return Ok(());
            }
            if quantity != "beta0" {
                return Err(format!(
                    "{}: no group above {} holds NISAR's calibration tables \
                     (metadata/calibrationInformation/geometry), and ICEYE's calibration_factor \
                     gives beta0 only (asked for {quantity})",
                    st.path.display(),
                    st.dataset
                ));
            }
            let factor = calibration::iceye_factor(st)?;
            let scale = Scale::Factor(factor.sqrt() as f32);
            self.calibration = Some(calibrated("/calibration_factor".into(), scale));
            Ok(())
        }
        #[cfg(not(feature = "mat73"))]
        {
            Err(format!(
                "{}: this build reads no HDF5 (asked for {quantity})",
                self.stack.path.display()
            ))
        }
    }

    fn block_rows(&self) -> usize {
        self.stack.chunk_rows
    }

    /// The affine transform of the coordinate vectors beside the scene in its group
    /// ([`coords`]), else its NISAR product's geolocation grid (`geolocation.rs`).
    fn georeference(&self) -> Result<crate::io::mapping::Georeference, String> {
        #[cfg(feature = "mat73")]
        {
            let (georef, by) = read::scene_georeference(&self.stack)?;
            let _ = self.placed_by.set(by);
            Ok(georef)
        }
        #[cfg(not(feature = "mat73"))]
        {
            Err(format!(
                "{}: this build reads no HDF5",
                self.stack.path.display()
            ))
        }
    }

    fn describe(&self) -> serde_json::Value {
        serde_json::json!({
            "path": self.stack.path.display().to_string(),
            "format": "HDF5",
            "dataset": self.stack.dataset,
            "imag": self.stack.imag,
            "rows": self.stack.dims[1],
            "cols": self.stack.dims[2],
            "calibrated_to": self.calibration.as_ref().map(|c| c.quantity.clone()),
            "calibration_source": self.calibration.as_ref().map(|c| c.source.clone()),
            "map_placed_by": self.placed_by.get(),
        })
    }
}
