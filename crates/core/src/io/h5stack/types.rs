//! What an HDF5 stack is once checked ([`H5Stack`]: its file, dataset, element form and
//! dimensions), shared by the checks and reads of `read.rs` and the dispatch of `mod.rs`.

use std::path::PathBuf;

/// How a dataset's elements hold complex values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// A compound of two numbers (index into the names read: `r`/`i`, `real`/`imag`,
    /// `re`/`im`).
    Compound(usize),
    /// Real numbers (the imaginary parts from a second dataset, or 0).
    Real,
    /// Float pairs: a last dimension of 2.
    Pairs,
}

/// How a stack's values are brought into memory ([`H5Stack::load`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// Mapped from the file: contiguous, unfiltered elements that are byte for byte those of
    /// an `.npy` file of this type, from this byte of the file on.
    Mapped {
        /// Where the elements start.
        offset: u64,
        /// Their type.
        dtype: crate::io::npy::Dtype,
    },
    /// Read into complex64 (every stored number fits a `f32`).
    Single,
    /// Read into complex128.
    Double,
}

/// A stack in an HDF5 file, checked: its dataset exists, holds numbers, and has a stack's
/// shape.
#[derive(Debug, Clone, PartialEq)]
pub struct H5Stack {
    /// The file.
    pub path: PathBuf,
    /// The dataset's path in the file.
    pub dataset: String,
    /// The dataset of the imaginary parts, for a real `dataset`.
    pub imag: Option<String>,
    /// How the elements hold complex values.
    pub form: Form,
    /// The stored dimensions of the stack (without a pairs' last 2).
    pub dims: [usize; 3],
    /// Whether the samples are the last dimension (`[H, W, N]`).
    pub hwn: bool,
    /// How [`H5Stack::load`] brings it into memory.
    pub storage: Storage,
    /// Rows of its chunks along the image rows (1 where not chunked).
    pub chunk_rows: usize,
    /// A single scene `[H, W]` (`dims` `[1, H, W]`), read a window at a time
    /// ([`H5Stack::read_window`]) and cut into patches rather than read whole.
    pub scene: bool,
}

/// Why a stack cannot be opened: the field it concerns (`path`, `dataset` or `imag`) and what
/// is wrong, naming the file.
pub type OpenError = (&'static str, String);

impl H5Stack {
    /// `(N, H, W)`.
    pub fn shape(&self) -> (usize, usize, usize) {
        let [a, b, c] = self.dims;
        if self.hwn && !self.scene {
            (c, a, b)
        } else {
            (a, b, c)
        }
    }
}
