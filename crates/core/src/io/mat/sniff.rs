//! What a file's first bytes say it is: MAT v5 (either byte order), MAT v7.3 (HDF5 behind the
//! MATLAB header), or neither, and why.

use super::variable::MatError;
use std::io::Read;
use std::path::Path;

/// The `HDF5` signature that starts an HDF5 superblock.
const HDF5_MAGIC: &[u8; 8] = b"\x89HDF\r\n\x1a\n";

/// What a file's first 128 bytes say it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// MAT v5 (`-v6`/`-v7`), big- or little-endian.
    V5 { big: bool },
    /// MAT v7.3: HDF5 behind a 512-byte user block holding the MATLAB header.
    V73,
}

/// Reads the 128-byte header (`head`: the file's first bytes, up to 520 so that an HDF5
/// signature after a 512-byte user block shows; `len`: the file's length).
pub(super) fn sniff(head: &[u8], len: u64) -> Result<Kind, String> {
    let hdf5 = head.starts_with(HDF5_MAGIC) || head.get(512..520) == Some(&HDF5_MAGIC[..]);
    let not_mat = "an HDF5 file without a MATLAB header: not a MAT file";
    if head.starts_with(HDF5_MAGIC) {
        return Err(not_mat.into());
    }
    if head.len() < 128 {
        return Err(format!(
            "not a MAT file: {len} bytes, shorter than the 128-byte MAT header"
        ));
    }
    let big = match &head[126..128] {
        b"IM" => false,
        b"MI" => true,
        _ if hdf5 => return Err(not_mat.into()),
        _ if head[..4].contains(&0) => {
            return Err("not a MAT v5 file (a MAT v4 file? save it with -v7 or -v7.3)".into())
        }
        _ => return Err("not a MAT file: no endian indicator at byte 126".into()),
    };
    let version = if big {
        u16::from_be_bytes([head[124], head[125]])
    } else {
        u16::from_le_bytes([head[124], head[125]])
    };
    match version {
        0x0100 => Ok(Kind::V5 { big }),
        0x0200 if !big => Ok(Kind::V73),
        v => Err(format!("unknown MAT version {v:#06x}")),
    }
}

/// The file's first 520 bytes (fewer if it is shorter) and its length.
pub(super) fn head(path: &Path) -> Result<(Vec<u8>, u64), MatError> {
    let io = |cause| MatError::Io {
        path: path.to_path_buf(),
        cause,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let len = f.metadata().map_err(io)?.len();
    let mut head = Vec::with_capacity(520);
    f.take(520).read_to_end(&mut head).map_err(io)?;
    Ok((head, len))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(version: u16, endian: &[u8; 2]) -> Vec<u8> {
        let mut h = b"MATLAB 5.0 MAT-file".to_vec();
        h.resize(124, b' ');
        h.extend(version.to_le_bytes());
        h.extend(endian);
        h
    }

    #[test]
    fn the_header_says_which_version() {
        assert_eq!(
            sniff(&header(0x0100, b"IM"), 128),
            Ok(Kind::V5 { big: false })
        );
        let mut be = header(0, b"MI");
        be[124..126].copy_from_slice(&0x0100u16.to_be_bytes());
        assert_eq!(sniff(&be, 128), Ok(Kind::V5 { big: true }));
        assert_eq!(sniff(&header(0x0200, b"IM"), 1024), Ok(Kind::V73));
        assert!(sniff(&header(0x0300, b"IM"), 128)
            .unwrap_err()
            .contains("unknown MAT version 0x0300"));
        assert!(sniff(b"\x89HDF\r\n\x1a\n\0\0", 10)
            .unwrap_err()
            .contains("HDF5 file without a MATLAB header"));
        assert!(sniff(b"MATLAB", 6).unwrap_err().contains("6 bytes"));
        assert!(sniff(&[0u8; 128], 128).unwrap_err().contains("MAT v4"));
        let mut ub = vec![0u8; 520];
        ub[512..].copy_from_slice(HDF5_MAGIC);
        assert!(sniff(&ub, 4096)
            .unwrap_err()
            .contains("HDF5 file without a MATLAB header"));
    }
}
