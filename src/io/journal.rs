//! The journal of the files the tool writes into the output folders this process has
//! claimed: every atomic write calls [`note`] before its temporary file exists, and the path is
//! appended to the claimed folder's `.isar-clutter/journal`, so that even a killed run's files
//! are known to be the tool's. The claim itself ([`crate::io::outdir`]) opens and closes a
//! folder's journal here.

use anyhow::Result;
use std::collections::BTreeSet;
use std::fs::File;
use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

/// The folder of the tool's own state inside an output folder.
pub const STATE: &str = ".isar-clutter";

/// Every active journal of this process: the absolute root and its state.
static ACTIVE: Mutex<Vec<Journal>> = Mutex::new(Vec::new());

#[derive(Debug)]
struct Journal {
    abs: PathBuf,
    file: File,
    written: BTreeSet<PathBuf>,
}

/// Records that the tool is about to write `path` if it lies in a claimed folder of this
/// process (appends it to the folder's journal before the temporary file exists); nothing
/// otherwise. Called by every atomic write.
pub fn note(path: &Path) {
    let Ok(mut active) = ACTIVE.lock() else {
        return;
    };
    if active.is_empty() {
        return;
    }
    let Ok(abs) = std::path::absolute(path) else {
        return;
    };
    for j in active.iter_mut() {
        if let Ok(rel) = abs.strip_prefix(&j.abs) {
            if rel.starts_with(STATE) || !safe_relative(rel) {
                return;
            }
            if j.written.insert(rel.to_path_buf()) {
                if let Some(s) = rel.to_str() {
                    // One write call per line (O_APPEND): lines of threads never interleave.
                    let _ = j.file.write_all(format!("{s}\n").as_bytes());
                }
            }
            return;
        }
    }
}

/// A relative path made of plain names only (no `..`, no root): safe to join to the root
/// and remove.
pub(crate) fn safe_relative(rel: &Path) -> bool {
    rel.components().next().is_some() && rel.components().all(|c| matches!(c, Component::Normal(_)))
}

/// Starts the journal of the claimed folder `abs` (absolute), appending to `file`.
///
/// # Errors
/// If the process's table of journals is poisoned.
pub(crate) fn open(abs: &Path, file: File) -> Result<()> {
    ACTIVE
        .lock()
        .map_err(|_| anyhow::anyhow!("journal lock poisoned"))?
        .push(Journal {
            abs: abs.to_path_buf(),
            file,
            written: BTreeSet::new(),
        });
    Ok(())
}

/// Stops the journal of `abs`.
pub(crate) fn close(abs: &Path) {
    if let Ok(mut active) = ACTIVE.lock() {
        active.retain(|j| j.abs != abs);
    }
}

/// The paths noted under the claim of `abs` so far (relative, sorted).
pub(crate) fn written(abs: &Path) -> Vec<PathBuf> {
    let Ok(active) = ACTIVE.lock() else {
        return Vec::new();
    };
    active
        .iter()
        .find(|j| j.abs == abs)
        .map(|j| j.written.iter().cloned().collect())
        .unwrap_or_default()
}
