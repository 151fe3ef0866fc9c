//! The journal of the files the tool writes into the output folders this process has
//! claimed: every atomic write calls [`note`] before its temporary file exists, and the path is
//! appended to the claimed folder's `.isar-clutter/journal`, so that even a killed run's files
//! are known to be the tool's. The claim itself ([`crate::io::outdir`]) opens and closes a
//! folder's journal here.

use anyhow::Result;
use std::collections::HashSet;
use std::fs::File;
use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

/// The folder of the tool's own state inside an output folder.
pub const STATE: &str = ".isar-clutter";

/// The folder of the job store inside an output folder (`jobs/`): its files are not journaled.
/// The store keeps its own order: a job's folder is emptied before the job runs, its result
/// verified by content hashes whenever it is read, and the whole store is a cache that stale
/// removal never touches; journaling it cost a line per file on disk and an entry per file in
/// memory (41 per tiny job), which grew a 100,000-job run by gigabytes.
pub const STORE: &str = "jobs";

/// Every active journal of this process: the absolute root and its state.
static ACTIVE: Mutex<Vec<Journal>> = Mutex::new(Vec::new());

#[derive(Debug)]
struct Journal {
    abs: PathBuf,
    file: File,
    /// [`path_hash`] of every path noted under this claim: 8 bytes a path, so that a sweep of
    /// 100,000 jobs with 20 maps each holds 2 million in about 40 MB (the paths themselves
    /// are on disk, in the journal file). Two paths with the same hash (odds about 1 in 10^7
    /// for 2 million paths) cost no result: the second is not appended to the journal file,
    /// which the next `owned` rewrite ([`crate::io::outdir::OutDir::remove_stale`]) completes.
    written: HashSet<u64>,
}

/// The 64-bit hash of a relative path that the journal keeps in memory (XXH3 of its bytes).
pub fn path_hash(rel: &Path) -> u64 {
    use std::os::unix::ffi::OsStrExt;
    xxhash_rust::xxh3::xxh3_64(rel.as_os_str().as_bytes())
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
            if rel.starts_with(STATE) || rel.starts_with(STORE) || !safe_relative(rel) {
                return;
            }
            if j.written.insert(path_hash(rel)) {
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
            written: HashSet::new(),
        });
    Ok(())
}

/// Stops the journal of `abs`.
pub(crate) fn close(abs: &Path) {
    if let Ok(mut active) = ACTIVE.lock() {
        active.retain(|j| j.abs != abs);
    }
}

/// Whether `rel` was noted under the claim of `abs` (by its [`path_hash`]).
pub(crate) fn is_written(abs: &Path, rel: &Path) -> bool {
    let Ok(active) = ACTIVE.lock() else {
        return false;
    };
    let h = path_hash(rel);
    active
        .iter()
        .find(|j| j.abs == abs)
        .is_some_and(|j| j.written.contains(&h))
}
