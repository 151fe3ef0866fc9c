//! What a MAT file the tool writes is made of, shared by the v5 writer ([`super::write`]) and
//! the v7.3 writer ([`super::v73`]): the format and class, the part types of a complex value,
//! the 128-byte header that marks the file as the tool's, and the samples as column-major
//! blocks.

use anyhow::Result;
use ndarray::Array3;
use num_complex::Complex;

/// The MAT format written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatVersion {
    /// MAT v5 (MATLAB's `-v6`/`-v7`): at most 2 GB per variable.
    V5,
    /// MAT v7.3 (HDF5): any size.
    V73,
}

/// The MATLAB class of the written values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatClass {
    /// `single` complex: 8 bytes per value (what `.npy` samples hold).
    Single,
    /// `double` complex: 16 bytes per value.
    Double,
}

impl std::str::FromStr for MatClass {
    type Err = String;

    /// The class of MATLAB's name (`single`, `double`).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "single" => Ok(MatClass::Single),
            "double" => Ok(MatClass::Double),
            other => Err(format!("unknown MAT class {other:?} (single or double)")),
        }
    }
}

impl MatClass {
    /// MATLAB's names of the classes, as a command line offers them.
    pub const NAMES: [&'static str; 2] = ["single", "double"];

    /// MATLAB's name of the class.
    pub fn name(self) -> &'static str {
        match self {
            MatClass::Single => "single",
            MatClass::Double => "double",
        }
    }
}

/// A real or imaginary part of a written value: `f32` (`single`) or `f64` (`double`).
pub trait Part: bytemuck::Pod + Send + Sync + private::H5 {
    /// The class it is written as.
    const CLASS: MatClass;
    /// Its MAT v5 data type (`miSINGLE` = 7, `miDOUBLE` = 9).
    const MI: u32;
}

impl Part for f32 {
    const CLASS: MatClass = MatClass::Single;
    const MI: u32 = 7;
}

impl Part for f64 {
    const CLASS: MatClass = MatClass::Double;
    const MI: u32 = 9;
}

mod private {
    /// What the v7.3 writer needs of a part type (nothing without the feature).
    #[cfg(feature = "mat73")]
    pub trait H5: hdf5_metno::H5Type {}
    /// What the v7.3 writer needs of a part type (nothing without the feature).
    #[cfg(not(feature = "mat73"))]
    pub trait H5 {}
    impl H5 for f32 {}
    impl H5 for f64 {}
}

/// The 128-byte MAT header: the text (with the platform `isar-clutter`, which marks the files
/// the tool wrote, and the UTC time), the subsystem offset (none), the version and `IM`.
pub fn header(version: MatVersion) -> [u8; 128] {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let text = match version {
        MatVersion::V5 => format!("MATLAB 5.0 MAT-file, {MARK} Created on: {}", ctime(secs)),
        MatVersion::V73 => format!(
            "MATLAB 7.3 MAT-file, {MARK} Created on: {} HDF5 schema 1.00 .",
            ctime(secs)
        ),
    };
    let mut h = [b' '; 128];
    h[..text.len()].copy_from_slice(text.as_bytes());
    h[116..124].fill(0);
    let v: u16 = match version {
        MatVersion::V5 => 0x0100,
        MatVersion::V73 => 0x0200,
    };
    h[124..126].copy_from_slice(&v.to_le_bytes());
    h[126..128].copy_from_slice(b"IM");
    h
}

/// The platform field of the headers the tool writes.
pub(super) const MARK: &str = "Platform: isar-clutter,";

/// `Mon Nov 24 02:22:00 2025` (UTC) for `secs` since 1970, as MATLAB dates its headers.
fn ctime(secs: u64) -> String {
    const DAYS: [&str; 7] = ["Thu", "Fri", "Sat", "Sun", "Mon", "Tue", "Wed"];
    const MONTHS: [&str; 12] = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ];
    let (days, rest) = (secs / 86400, secs % 86400);
    let (year, month, day) = crate::io::netcdf::time::civil_from_days(days as i64);
    format!(
        "{} {} {day:2} {:02}:{:02}:{:02} {year}",
        DAYS[(days % 7) as usize],
        MONTHS[month as usize - 1],
        rest / 3600,
        rest / 60 % 60,
        rest % 60
    )
}

/// The samples to write, `dims = (H, W, M)`, in blocks of at most `chunk`.
pub(crate) struct Blocks<B, P> {
    /// `(H, W, M)`.
    pub(crate) dims: (usize, usize, usize),
    /// Samples per block (at least 1).
    pub(crate) chunk: usize,
    /// `block(first, count)`: samples `first .. first + count` as `[count, H, W]`.
    pub(crate) block: B,
    /// Hears the number of samples written so far.
    pub(crate) progress: P,
}

impl<T: Part, B, P> Blocks<B, P>
where
    B: FnMut(usize, usize) -> Result<Array3<Complex<T>>>,
    P: FnMut(usize),
{
    /// Calls `put(first, count, x)` for every block, `x` the block's values column-major
    /// within each sample (`x[s * H * W + c * H + r]` = sample `s`, row `r`, column `c`).
    pub(crate) fn each(
        &mut self,
        mut put: impl FnMut(usize, usize, &[Complex<T>]) -> Result<()>,
    ) -> Result<()> {
        let (h, w, m) = self.dims;
        let mut done = 0;
        let mut cols: Vec<Complex<T>> = Vec::new();
        while done < m {
            let count = self.chunk.min(m - done);
            let b = (self.block)(done, count)?;
            anyhow::ensure!(b.dim() == (count, h, w), "a block of shape {:?}", b.dim());
            cols.clear();
            cols.reserve(count * h * w);
            for plane in b.outer_iter() {
                cols.extend(plane.t().iter().copied());
            }
            put(done, count, &cols)?;
            done += count;
            (self.progress)(done);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_are_matlab_s() {
        assert_eq!(ctime(0), "Thu Jan  1 00:00:00 1970");
        // 2024-02-29 13:05:09 UTC, a leap day.
        assert_eq!(ctime(1_709_211_909), "Thu Feb 29 13:05:09 2024");
        assert_eq!(ctime(1_763_950_920), "Mon Nov 24 02:22:00 2025");
    }

    #[test]
    fn headers_are_marked_and_versioned() {
        for (v, code) in [(MatVersion::V5, 0x0100u16), (MatVersion::V73, 0x0200)] {
            let h = header(v);
            assert!(h.starts_with(if v == MatVersion::V5 {
                b"MATLAB 5.0 MAT-file, Platform: isar-clutter, Created on: "
            } else {
                b"MATLAB 7.3 MAT-file, Platform: isar-clutter, Created on: "
            }));
            assert_eq!(
                &h[124..],
                &[code.to_le_bytes()[0], code.to_le_bytes()[1], b'I', b'M']
            );
            assert!(super::super::sniff::sniff(&h, 128).is_ok());
        }
    }
}
