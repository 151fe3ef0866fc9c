//! MATLAB `.mat` files in and out. Reading: the file's top-level variables are listed without
//! reading their data, and one numeric 3-D array (single or double, any integer class, real or
//! complex) is loaded as a complex stack in MATLAB's index order, `a[[i, j, k]] = x(i+1, j+1,
//! k+1)`, from a MAT v5 file (`save -v6`/`-v7`, SciPy's `savemat`; [`v5`]) or, with the cargo
//! feature `mat73`, a MAT v7.3 file (HDF5 behind a 512-byte MATLAB header; `v73`). Everything
//! else is a clear error naming the file and the variable: a missing variable lists the file's
//! variables, and structs, cells, char arrays, sparse matrices, logical arrays, objects and
//! arrays that are not 3-D are refused by what they are, as are v7.3 datasets whose
//! `MATLAB_class` is numeric but whose data are stored as strings, booleans or another
//! compound (when the file is listed, so at `validate`, not when the data are read); malformed
//! input (truncated, corrupted, a MAT v4 file, an HDF5 file without the MATLAB header) is an
//! error, never a panic. Writing ([`write`]): streamed stacks of generated samples as MATLAB
//! `H x W x M` arrays, v7.3 (with the feature) or v5; a `.mat` that holds anything besides the
//! one variable the tool wrote is never replaced ([`write::is_ours`]). The reader that picks the
//! format is [`MatFile`].

pub mod format;
mod reader;
mod sniff;
pub mod v5;
#[cfg(feature = "mat73")]
pub mod v73;
mod variable;
pub mod write;

pub use format::{MatClass, MatVersion};
pub use write::MatOutput;

pub use reader::{is_mat_path, load_stack, MatFile, V73_MISSING, V73_SUPPORTED};
pub use variable::{MatError, Variable};
