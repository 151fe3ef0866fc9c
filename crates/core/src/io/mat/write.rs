//! Writing a stack of samples as one MATLAB variable, `H x W x M` single or double complex,
//! streamed block by block in constant memory: MAT v7.3 (HDF5 behind MATLAB's 512-byte header,
//! complex as a compound of `real` and `imag`, a `MATLAB_class` attribute, the dimensions
//! reversed as MATLAB stores them; needs the `mat73` feature) or MAT v5 (uncompressed, at most
//! 2 GB per variable as MATLAB's `-v7` allows). The samples arrive as `[count, H, W]` blocks
//! and are written column-major (`x(h, w, m)`), so MATLAB's `load` gives `H x W x M`. Written
//! to a temporary name and renamed into place ([`crate::io::atomic`]).

use super::format::{header, Blocks, MatClass, MatVersion, Part, MARK};
use super::reader::{MatFile, V73_SUPPORTED};
use super::sniff::{head, sniff};
use super::v5::MI_MATRIX;
use super::variable::{MatError, Variable};
use anyhow::{bail, Context, Result};
use ndarray::Array3;
use num_complex::Complex;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

/// What and how to write.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MatOutput {
    /// The format.
    pub version: MatVersion,
    /// The class of the values.
    pub class: MatClass,
    /// The variable's name (a MATLAB identifier).
    pub variable: String,
}

/// The largest v5 variable (its `miMATRIX` element), as MATLAB's `-v7` allows: 2^31 - 1 bytes.
pub const V5_MAX_BYTES: u64 = (1 << 31) - 1;

/// Checks a MATLAB variable name: a letter, then letters, digits or `_`, at most 63 characters.
///
/// # Errors
/// Saying what is wrong with `name`.
pub fn check_variable_name(name: &str) -> Result<()> {
    let ok = name.len() <= 63
        && name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !ok {
        bail!(
            "{name:?} is not a MATLAB variable name (a letter, then letters, digits or `_`, at \
             most 63 characters)"
        );
    }
    Ok(())
}

/// The bytes of a v5 file of `count` values of `size` bytes each (real and imaginary parts) in
/// a variable called `name`: `(miMATRIX payload, offset of the real part's data)`.
fn v5_layout(name: &str, count: u64, size: u64) -> (u64, u64) {
    let pad = |b: u64| b.div_ceil(8) * 8;
    let part = count.saturating_mul(size);
    // Array flags (tag + 8), dimensions (tag + 3 x 4, padded), name (tag + padded bytes).
    let before = 16 + 24 + 8 + pad(name.len() as u64);
    let payload = before.saturating_add(2u64.saturating_mul(8u64.saturating_add(pad(part))));
    (payload, 128 + 8 + before + 8)
}

/// Refuses, before anything is written, what cannot be written: an invalid variable name, no
/// samples, a v5 variable over 2 GB, v7.3 in a build without the `mat73` feature.
///
/// # Errors
/// Saying what to change.
pub fn check_output(out: &MatOutput, (h, w, m): (usize, usize, usize)) -> Result<()> {
    check_variable_name(&out.variable)?;
    if m == 0 || h == 0 || w == 0 {
        bail!("a .mat output needs at least one sample of at least 1x1 pixels");
    }
    let size = match out.class {
        MatClass::Single => 4,
        MatClass::Double => 8,
    };
    match out.version {
        MatVersion::V5 => {
            let count = (h as u64).saturating_mul(w as u64).saturating_mul(m as u64);
            let (payload, _) = v5_layout(&out.variable, count, size);
            if payload > V5_MAX_BYTES {
                bail!(
                    "--mat-version 5 holds at most 2 GB per variable (MATLAB's -v7 limit); \
                     {h}x{w}x{m} {} complex takes {:.2} GB: leave out --mat-version (v7.3) or \
                     write fewer samples",
                    out.class.name(),
                    payload as f64 / 1e9
                );
            }
        }
        MatVersion::V73 if !V73_SUPPORTED => bail!(
            "writing MAT v7.3 needs a build with `--features mat73` (as `make build` does; it \
             needs Debian's libhdf5-dev); --mat-version 5 writes MAT v5 (at most 2 GB)"
        ),
        MatVersion::V73 => {}
    }
    Ok(())
}

/// Whether the header of `path` names the platform `isar-clutter` (the tool wrote the file,
/// whatever was added to it since).
fn has_mark(path: &Path) -> bool {
    let Ok((head, len)) = head(path) else {
        return false;
    };
    sniff(&head, len).is_ok()
        && head[..116]
            .windows(MARK.len())
            .any(|w| w == MARK.as_bytes())
}

/// The variables of a MAT file besides the one the tool writes (the first complex `single` or
/// `double` 3-D array; every variable when there is none).
fn added_variables(path: &Path) -> Result<Vec<Variable>, MatError> {
    let file = MatFile::open(path)?;
    let ours = file
        .variables()
        .iter()
        .position(|v| v.is_stack() && v.complex && matches!(v.class, "single" | "double"));
    Ok(file
        .variables()
        .iter()
        .enumerate()
        .filter(|&(i, _)| Some(i) != ours)
        .map(|(_, v)| v.clone())
        .collect())
}

/// Whether `path` is a MAT file as `generate` left it, so that `generate` may replace it: its
/// header names the platform `isar-clutter` and it holds one variable, a complex `single` or
/// `double` 3-D array. A file of the tool's to which a variable was added since (MATLAB's
/// `save(..., '-append')`, h5py) is not: replacing it would drop what the user added.
pub fn is_ours(path: &Path) -> bool {
    has_mark(path) && added_variables(path).is_ok_and(|added| added.is_empty())
}

/// Checks that `generate` may write its `.mat` at `path`: nothing there, or a file
/// [`is_ours`]. A file the tool wrote that now holds variables it did not write is refused
/// naming them (anything else that is not ours by [`crate::io::outdir::check_file_output`]),
/// and is kept untouched.
///
/// # Errors
/// Naming the path, and the added variables where the tool wrote the file.
pub fn check_replaceable(path: &Path) -> Result<()> {
    let regular = std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file());
    if regular && has_mark(path) {
        let added = added_variables(path).with_context(|| {
            format!(
                "{} was written by isar-clutter but cannot be listed now, so it is not \
                 replaced (nothing was changed)",
                path.display()
            )
        })?;
        if !added.is_empty() {
            let names: Vec<String> = added
                .iter()
                .map(|v| format!("{} ({})", v.name, v.describe()))
                .collect();
            bail!(
                "{} was written by isar-clutter but now also holds {} variable(s) it did not \
                 write: {}; writing over it would drop them, so remove them or choose another \
                 --out (nothing was changed)",
                path.display(),
                added.len(),
                names.join(", ")
            );
        }
    }
    crate::io::outdir::check_file_output(path, "samples .mat", is_ours)
}

/// Streams `m` samples of `h x w` into `path` as the variable `out.variable`, `H x W x M`:
/// `block(first, count)` gives samples `first .. first + count` as `[count, H, W]` (at most
/// `chunk` at a time, so memory is one block and its column-major copy); `progress` hears how
/// many are written. `T`'s class must be `out.class`.
///
/// # Errors
/// As [`check_output`], or if a block fails or the file cannot be written (nothing is left at
/// `path` then, and an earlier file there is kept).
pub fn write_stack<T: Part>(
    path: &Path,
    out: &MatOutput,
    (h, w, m): (usize, usize, usize),
    chunk: usize,
    block: impl FnMut(usize, usize) -> Result<Array3<Complex<T>>>,
    progress: impl FnMut(usize),
) -> Result<()> {
    assert_eq!(
        T::CLASS,
        out.class,
        "the values' type is the output's class"
    );
    check_output(out, (h, w, m))?;
    let blocks = Blocks {
        dims: (h, w, m),
        chunk: chunk.max(1),
        block,
        progress,
    };
    match out.version {
        MatVersion::V5 => write_v5(path, &out.variable, blocks),
        #[cfg(feature = "mat73")]
        MatVersion::V73 => super::v73::write(path, &out.variable, blocks),
        #[cfg(not(feature = "mat73"))]
        MatVersion::V73 => unreachable!("refused by check_output"),
    }
}

/// Writes a MAT v5 file: the header, one `miMATRIX` (flags, dimensions, name, the real parts,
/// the imaginary parts), each block's real and imaginary parts written at their offsets.
fn write_v5<T: Part, B, P>(path: &Path, name: &str, mut blocks: Blocks<B, P>) -> Result<()>
where
    B: FnMut(usize, usize) -> Result<Array3<Complex<T>>>,
    P: FnMut(usize),
{
    let (h, w, m) = blocks.dims;
    let size = std::mem::size_of::<T>() as u64;
    let count = (h * w * m) as u64;
    let part = count * size;
    let (payload, re_at) = v5_layout(name, count, size);
    let im_at = re_at + part.div_ceil(8) * 8 + 8;
    let tag = |f: &mut dyn Write, ty: u32, bytes: u64| -> std::io::Result<()> {
        f.write_all(&ty.to_le_bytes())?;
        f.write_all(&(bytes as u32).to_le_bytes())
    };
    crate::io::atomic::atomic_write(path, |f| {
        f.write_all(&header(MatVersion::V5))?;
        tag(f, MI_MATRIX, payload)?;
        tag(f, 6, 8)?; // miUINT32 array flags: class, complex
        let class: u32 = match T::CLASS {
            MatClass::Single => 7,
            MatClass::Double => 6,
        };
        f.write_all(&(class | 0x0800).to_le_bytes())?;
        f.write_all(&0u32.to_le_bytes())?;
        tag(f, 5, 12)?; // miINT32 dimensions
        for d in [h, w, m] {
            f.write_all(&(d as i32).to_le_bytes())?;
        }
        f.write_all(&[0; 4])?;
        tag(f, 1, name.len() as u64)?; // miINT8 name
        f.write_all(name.as_bytes())?;
        f.write_all(&vec![0; name.len().div_ceil(8) * 8 - name.len()])?;
        tag(f, T::MI, part)?;
        let pad = vec![0u8; (part.div_ceil(8) * 8 - part) as usize];
        f.seek(SeekFrom::Start(re_at + part))?;
        f.write_all(&pad)?;
        tag(f, T::MI, part)?;
        f.seek(SeekFrom::Start(im_at + part))?;
        f.write_all(&pad)?;
        let mut values: Vec<T> = Vec::new();
        blocks.each(|first, _, x| {
            let at = first as u64 * (h * w) as u64 * size;
            for (offset, get) in [(re_at, 0), (im_at, 1)] {
                values.clear();
                values.extend(x.iter().map(|z| if get == 0 { z.re } else { z.im }));
                f.seek(SeekFrom::Start(offset + at))?;
                f.write_all(bytemuck::cast_slice(&values))?;
            }
            Ok(())
        })
    })
    .with_context(|| format!("writing the MAT v5 file {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_sizes_are_checked_before_writing() {
        let out = |version, variable: &str| MatOutput {
            version,
            class: MatClass::Single,
            variable: variable.into(),
        };
        for bad in ["", "1x", "a-b", "é", &"a".repeat(64)] {
            assert!(
                check_output(&out(MatVersion::V5, bad), (2, 2, 2)).is_err(),
                "{bad:?}"
            );
        }
        assert!(check_output(&out(MatVersion::V5, "samples"), (64, 64, 0)).is_err());
        // 64 x 64 x 65535 single complex is 2^31 - 131072 bytes (and a header); x 65536 is
        // 2^31 bytes of values, over the limit.
        assert!(check_output(&out(MatVersion::V5, "x"), (64, 64, 65535)).is_ok());
        let e = check_output(&out(MatVersion::V5, "x"), (64, 64, 65536)).unwrap_err();
        assert!(e.to_string().contains("at most 2 GB"), "{e}");
        assert_eq!(
            check_output(&out(MatVersion::V73, "x"), (64, 64, 65536)).is_ok(),
            crate::io::mat::V73_SUPPORTED
        );
    }
}
