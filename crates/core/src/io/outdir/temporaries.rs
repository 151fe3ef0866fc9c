//! The temporaries of the tool's atomic writes: the name a temporary stands for and its
//! writer's pid, and their removal from a folder (those of dead writers, or of a run's folder
//! being taken over).

use anyhow::{Context, Result};
use std::fs;
use std::path::Path;

/// The name a temporary file of the tool's atomic writes stands for, and its writer's pid:
/// `.a.npy.tmp-12` -> (`a.npy`, 12); `.a.png.12-3.tmp` -> (`a.png`, 12).
pub fn temporary_of(name: &str) -> Option<(&str, u32)> {
    let rest = name.strip_prefix('.')?;
    if let Some((base, pid)) = rest.rsplit_once(".tmp-") {
        return Some((base, pid.parse().ok()?));
    }
    let rest = rest.strip_suffix(".tmp")?;
    let (base, pid_seq) = rest.rsplit_once('.')?;
    let (pid, seq) = pid_seq.split_once('-')?;
    seq.parse::<u64>().ok()?;
    Some((base, pid.parse().ok()?))
}

/// Removes the temporary files and folders of the tool's writes in `dir` (names that
/// [`temporary_of`] reads) that `select(base, pid, is_dir)` picks; returns their names, sorted.
/// Nothing when `dir` cannot be read.
///
/// # Errors
/// When a picked one cannot be removed (one already gone is not an error).
pub(super) fn remove_temporaries(
    dir: &Path,
    select: impl Fn(&str, u32, bool) -> bool,
) -> Result<Vec<String>> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Ok(Vec::new());
    };
    let mut removed = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some((base, pid)) = temporary_of(name) else {
            continue;
        };
        let path = e.path();
        let Ok(meta) = fs::symlink_metadata(&path) else {
            continue;
        };
        if !select(base, pid, meta.is_dir()) {
            continue;
        }
        let gone = if meta.is_dir() {
            fs::remove_dir_all(&path)
        } else {
            fs::remove_file(&path)
        };
        match gone {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(e).with_context(|| format!("removing temporary {}", path.display()))
            }
            _ => removed.push(name.to_string()),
        }
    }
    removed.sort();
    Ok(removed)
}
