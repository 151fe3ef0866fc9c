//! Opening a `.mat` file whichever its version: the header says v5 or v7.3 ([`super::sniff`]),
//! the variables are listed without their data, and one is loaded as a stack.

use super::format::MatVersion;
use super::sniff::{head, sniff, Kind};
use super::v5;
#[cfg(feature = "mat73")]
use super::v73;
use super::variable::{MatError, Variable};
use ndarray::Array3;
use num_complex::Complex64;
use std::path::{Path, PathBuf};

/// Whether the build reads (and writes) MAT v7.3 files (the cargo feature `mat73`).
pub const V73_SUPPORTED: bool = cfg!(feature = "mat73");

/// What a build without the `mat73` feature says about a v7.3 file.
pub const V73_MISSING: &str = "a MAT v7.3 (HDF5) file, which this build of isar-clutter cannot \
    read: build it with `--features mat73` (as `make build` does; it needs Debian's \
    libhdf5-dev), or save the variable in MATLAB with `save(FILE, NAME, '-v7')`";

enum Inner {
    V5(v5::V5File),
    #[cfg(feature = "mat73")]
    V73(v73::V73File),
}

/// An open MAT file (v5, or v7.3 with the `mat73` feature) and the list of its top-level
/// variables.
pub struct MatFile {
    path: PathBuf,
    variables: Vec<Variable>,
    inner: Inner,
}

impl MatFile {
    /// Opens `path`, checks the header, and lists the variables (reading only their headers).
    ///
    /// # Errors
    /// [`MatError`] if the file cannot be read or is not a well-formed MAT file this build
    /// reads.
    pub fn open(path: &Path) -> Result<MatFile, MatError> {
        let fmt = |reason: String| MatError::Format {
            path: path.to_path_buf(),
            reason,
        };
        let (head, len) = head(path)?;
        let (variables, inner) = match sniff(&head, len).map_err(fmt)? {
            Kind::V5 { big } => {
                let (f, vars) = v5::V5File::open(path, big)?;
                (vars, Inner::V5(f))
            }
            #[cfg(feature = "mat73")]
            Kind::V73 => {
                let (f, vars) = v73::V73File::open(path).map_err(fmt)?;
                (vars, Inner::V73(f))
            }
            #[cfg(not(feature = "mat73"))]
            Kind::V73 => return Err(fmt(V73_MISSING.into())),
        };
        Ok(MatFile {
            path: path.to_path_buf(),
            variables,
            inner,
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file's format version.
    pub fn version(&self) -> MatVersion {
        match self.inner {
            Inner::V5(_) => MatVersion::V5,
            #[cfg(feature = "mat73")]
            Inner::V73(_) => MatVersion::V73,
        }
    }

    /// The file's top-level variables, in file order (v5) or name order (v7.3).
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// The variable a stack is read from: `name`, or, when `None`, the only numeric 3-D
    /// array of the file.
    ///
    /// # Errors
    /// [`MatError::Missing`] (listing the variables), [`MatError::Ambiguous`] or
    /// [`MatError::NotStack`].
    pub fn stack_variable(&self, name: Option<&str>) -> Result<&Variable, MatError> {
        self.choose(name).map(|i| &self.variables[i])
    }

    /// The index of the variable [`MatFile::stack_variable`] returns.
    fn choose(&self, name: Option<&str>) -> Result<usize, MatError> {
        let index = match name {
            Some(n) => self
                .variables
                .iter()
                .position(|v| v.name == n)
                .ok_or_else(|| MatError::Missing {
                    path: self.path.clone(),
                    name: n.to_string(),
                    variables: self.variables.clone(),
                })?,
            None => {
                let stacks: Vec<usize> = (0..self.variables.len())
                    .filter(|&i| self.variables[i].is_stack())
                    .collect();
                if stacks.len() != 1 {
                    return Err(MatError::Ambiguous {
                        path: self.path.clone(),
                        count: stacks.len(),
                        variables: self.variables.clone(),
                    });
                }
                stacks[0]
            }
        };
        let v = &self.variables[index];
        if let Some(what) = v.not_stack_reason() {
            return Err(MatError::NotStack {
                path: self.path.clone(),
                name: v.name.clone(),
                what,
            });
        }
        Ok(index)
    }

    /// Reads the variable `name` (or, when `None`, the only numeric 3-D array) as a complex
    /// stack in MATLAB's index order (`[H, W, N]` for MATLAB's usual layout).
    ///
    /// # Errors
    /// [`MatError`] if the variable is missing, ambiguous, not a numeric 3-D array, malformed,
    /// or does not fit in memory.
    pub fn read_stack(&self, name: Option<&str>) -> Result<Array3<Complex64>, MatError> {
        let index = self.choose(name)?;
        let v = &self.variables[index];
        let (d0, d1, d2) = (v.dims[0], v.dims[1], v.dims[2]);
        // Column-major (d0, d1, d2) is row-major (d2, d1, d0): fill linearly, then reverse.
        let mut out: Array3<Complex64> =
            crate::alloc::try_zeros((d2, d1, d0), "the MAT-file stack")?;
        let data = out.as_slice_mut().expect("standard layout");
        match &self.inner {
            Inner::V5(f) => f.read(index, v, data),
            #[cfg(feature = "mat73")]
            Inner::V73(f) => f.read(v, data),
        }
        .map_err(|reason| MatError::Format {
            path: self.path.clone(),
            reason: format!("variable {:?}: {reason}", v.name),
        })?;
        Ok(out.reversed_axes())
    }
}

/// Loads a stack from a MAT file (see [`MatFile::read_stack`]) as the dataset's
/// [`crate::io::npy::Stack`].
///
/// # Errors
/// As for [`MatFile::open`] and [`MatFile::read_stack`].
pub fn load_stack(path: &Path, variable: Option<&str>) -> Result<crate::io::npy::Stack, MatError> {
    Ok(crate::io::npy::Stack::Generated(
        MatFile::open(path)?.read_stack(variable)?,
    ))
}

/// Whether `path` names a MAT file by its extension (`.mat`, any case).
pub fn is_mat_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_are_named() {
        let v = Variable {
            name: "s".into(),
            class: "struct",
            dims: vec![],
            complex: false,
            logical: false,
            stored_as: None,
        };
        assert_eq!(v.describe(), "struct");
        assert_eq!(v.not_stack_reason().as_deref(), Some("a struct"));
        assert!(is_mat_path(Path::new("a/b.MAT")) && !is_mat_path(Path::new("b.npy")));
    }
}
