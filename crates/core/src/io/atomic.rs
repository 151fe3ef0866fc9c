//! Writing outputs so that a reader never sees half a file: every file is written to a
//! temporary name in its folder and renamed into place (swapped in with `RENAME_EXCHANGE` where
//! the kernel has it); `.npy` arrays (and the runner's Parquet tables) through the same path; a whole folder
//! (a model) swapped in the same way. Nothing is ever renamed over a folder or a link that is
//! not the caller's.

use anyhow::{Context, Result};
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `path` atomically: `write` fills a temporary file in the same folder, which is then
/// renamed over `path`. The path is noted in the journal of a claimed output folder that holds
/// it ([`crate::io::journal::note`]) before anything is written. An output of up to 1 MiB (a
/// map, a table, a record) is held in memory first, and where `path` already holds exactly
/// those bytes (a re-run that computed the same result) it is left as it is: replacing a file
/// made the file system free the old one's blocks, a tenth of a millisecond per file on the
/// development VM.
///
/// # Errors
/// If the temporary file cannot be written or renamed, or `path` exists and is not a regular
/// file (a folder is never renamed away); the temporary file is removed.
pub fn atomic_write(
    path: &Path,
    write: impl FnOnce(&mut AtomicWriter) -> Result<()>,
) -> Result<()> {
    write_via_temporary(path, false, write)
}

/// [`atomic_write`], and the file's data on disk (`fsync`) before the rename and the rename
/// itself after it (the folder synced): for records that must survive a power failure, such
/// as the job store's `done.json`.
///
/// # Errors
/// As [`atomic_write`], or if a sync fails.
pub fn atomic_write_durable(
    path: &Path,
    write: impl FnOnce(&mut AtomicWriter) -> Result<()>,
) -> Result<()> {
    write_via_temporary(path, true, write)
}

/// [`atomic_write`] for a library that writes files by name (libhdf5): `write` creates and
/// fills the temporary path it is given (in `path`'s folder, which exists), which is then
/// renamed over `path`.
///
/// # Errors
/// As [`atomic_write`]; the temporary file is removed.
pub fn atomic_write_path(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let (dir, tmp) = temporary(path);
    crate::io::journal::note(path);
    let result = (|| -> Result<()> {
        fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        write(&tmp)?;
        replace(&tmp, path)
            .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.with_context(|| format!("writing {}", path.display()))
}

/// The folder of `path` and the temporary name beside it that a write goes through.
fn temporary(path: &Path) -> (&Path, PathBuf) {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    (dir, dir.join(format!(".{name}.tmp-{}", std::process::id())))
}

/// What an atomic write fills: the bytes are held in memory up to [`HELD`] and go to the
/// temporary file beyond.
pub struct AtomicWriter {
    held: Vec<u8>,
    file: Option<BufWriter<File>>,
    dir: PathBuf,
    tmp: PathBuf,
}

/// Outputs up to this size are held in memory (and compared with the file they replace).
const HELD: usize = 1 << 20;

impl AtomicWriter {
    /// Creates the temporary file (and its folder when it is missing: one failed open, not a
    /// mkdir per file).
    fn create(&self) -> std::io::Result<File> {
        fn named(path: &Path) -> impl Fn(std::io::Error) -> std::io::Error + '_ {
            move |e| std::io::Error::new(e.kind(), format!("cannot create {}: {e}", path.display()))
        }
        // As File::create, but never through a symbolic link planted at the temporary's name.
        let open = |path: &Path| {
            use std::os::unix::fs::OpenOptionsExt;
            fs::OpenOptions::new()
                .write(true)
                .create(true)
                .truncate(true)
                .custom_flags(libc::O_NOFOLLOW)
                .open(path)
        };
        match open(&self.tmp) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                fs::create_dir_all(&self.dir).map_err(named(&self.dir))?;
                open(&self.tmp).map_err(named(&self.tmp))
            }
            other => other.map_err(named(&self.tmp)),
        }
    }

    /// Moves what is held to the temporary file, which takes every later write.
    fn spill(&mut self) -> std::io::Result<&mut BufWriter<File>> {
        if self.file.is_none() {
            // One write call for most outputs: each costs about 20 us on the development VM.
            let mut w = BufWriter::with_capacity(HELD, self.create()?);
            w.write_all(&std::mem::take(&mut self.held))?;
            self.file = Some(w);
        }
        Ok(self.file.as_mut().expect("just made"))
    }
}

impl Write for AtomicWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.file.is_none() && self.held.len() + buf.len() <= HELD {
            self.held.extend_from_slice(buf);
            return Ok(buf.len());
        }
        self.spill()?.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.file {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

/// A writer that seeks (MAT v5's real and imaginary parts) writes to the temporary file.
impl std::io::Seek for AtomicWriter {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        self.spill()?.seek(pos)
    }
}

/// Whether `path` is a regular file holding exactly `bytes`.
fn holds(path: &Path, bytes: &[u8]) -> bool {
    fs::symlink_metadata(path).is_ok_and(|m| m.is_file() && m.len() == bytes.len() as u64)
        && fs::read(path).is_ok_and(|b| b == bytes)
}

fn write_via_temporary(
    path: &Path,
    durable: bool,
    write: impl FnOnce(&mut AtomicWriter) -> Result<()>,
) -> Result<()> {
    let mut w = AtomicWriter::new(path);
    let result = write(&mut w).and_then(|()| w.finish(path, durable));
    if result.is_err() {
        let _ = fs::remove_file(&w.tmp);
    }
    result.with_context(|| format!("writing {}", path.display()))
}

impl AtomicWriter {
    /// The writer of `path` (noted in the journal now, before its temporary file exists).
    fn new(path: &Path) -> Self {
        let (dir, tmp) = temporary(path);
        crate::io::journal::note(path);
        AtomicWriter {
            held: Vec::new(),
            file: None,
            dir: dir.to_path_buf(),
            tmp,
        }
    }

    /// Puts what was written at `path`: the temporary file renamed over it (synced before and
    /// after when `durable`), or nothing where `path` holds the same bytes already.
    fn finish(&mut self, path: &Path, durable: bool) -> Result<()> {
        let file = match self.file.take() {
            Some(f) => f
                .into_inner()
                .map_err(std::io::IntoInnerError::into_error)?,
            // The same bytes are there already (written, and synced if durable, by the run
            // that made them).
            None if holds(path, &self.held) => return Ok(()),
            None => {
                let mut f = self.create()?;
                f.write_all(&self.held)?;
                f
            }
        };
        if durable {
            file.sync_all()?;
        }
        drop(file);
        replace(&self.tmp, path).with_context(|| {
            format!("cannot rename {} to {}", self.tmp.display(), path.display())
        })?;
        if durable {
            File::open(&self.dir).and_then(|d| d.sync_all())?;
        }
        Ok(())
    }
}

/// A file written piece by piece over a long time (a table assembled job by job, the
/// manifest's list of jobs) that appears at its path, whole, only when [`Staged::commit`] is
/// called; dropped uncommitted, its temporary file goes and the path is left as it was.
pub struct Staged {
    path: PathBuf,
    writer: AtomicWriter,
    committed: bool,
    /// SHA-256 of the bytes written so far, where asked for ([`Staged::hashed`]).
    sha: Option<sha2::Sha256>,
}

impl Staged {
    /// Starts the file `path` (noted in the journal of a claimed folder that holds it).
    pub fn new(path: &Path) -> Self {
        Staged {
            path: path.to_path_buf(),
            writer: AtomicWriter::new(path),
            committed: false,
            sha: None,
        }
    }

    /// [`Staged::new`], with the SHA-256 of the bytes kept up to date as they are written, for
    /// [`Staged::commit_hashed`]: the manifest's hash of a table of gigabytes without reading
    /// the table again, computed on the thread that writes it.
    pub fn hashed(path: &Path) -> Self {
        use sha2::Digest;
        let mut staged = Staged::new(path);
        staged.sha = Some(sha2::Sha256::new());
        staged
    }

    /// Puts the file in place, as [`atomic_write`] does.
    ///
    /// # Errors
    /// If the temporary file cannot be written or renamed; it is removed then.
    pub fn commit(self) -> Result<()> {
        self.commit_hashed().map(|_| ())
    }

    /// [`Staged::commit`], and the lower-case hex SHA-256 of the file's bytes where the file
    /// was started [`Staged::hashed`] (`None` otherwise).
    ///
    /// # Errors
    /// As [`Staged::commit`].
    pub fn commit_hashed(mut self) -> Result<Option<String>> {
        use sha2::Digest;
        self.committed = true;
        let result = self.writer.finish(&self.path, false);
        if result.is_err() {
            let _ = fs::remove_file(&self.writer.tmp);
        }
        result.with_context(|| format!("writing {}", self.path.display()))?;
        Ok(self.sha.take().map(|h| crate::seeds::hex(&h.finalize())))
    }
}

impl Write for Staged {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.writer.write(buf)?;
        if let Some(h) = &mut self.sha {
            sha2::Digest::update(h, &buf[..n]);
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.committed {
            self.writer.file = None;
            let _ = fs::remove_file(&self.writer.tmp);
        }
    }
}

/// Moves the finished file `tmp` to `path`. Where `path` exists (a re-run into the same
/// folder), Linux (glibc) swaps the two names atomically (`renameat2` with
/// `RENAME_EXCHANGE`) and the old file is then removed: a plain rename over an existing file makes ext4 start writing the
/// new file's data back at once (its `auto_da_alloc` safeguard), about 0.2 ms per file on the
/// development VM, which was a fifth of a short run's time. Readers see the old or the new
/// file, never a partial one, either way.
pub fn replace(tmp: &Path, path: &Path) -> std::io::Result<()> {
    if fs::symlink_metadata(path).is_ok_and(|m| !m.is_file()) {
        return Err(std::io::Error::other(
            "it exists and is not a regular file (nothing is renamed over a folder or a link)",
        ));
    }
    if exchange(tmp, path)? {
        // `tmp` now names the old file; a failure to remove it loses no result.
        let _ = fs::remove_file(tmp);
        return Ok(());
    }
    // No file at `path` yet (or no RENAME_EXCHANGE): a plain rename.
    fs::rename(tmp, path)
}

/// Swaps the names `a` and `b` atomically (`renameat2` with `RENAME_EXCHANGE`, Linux with
/// glibc); `Ok(false)` where that is impossible (`b` missing, another system or file system).
///
/// # Errors
/// If a path holds a NUL byte.
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        use std::ffi::CString;
        use std::os::unix::ffi::OsStrExt;
        let (a, b) = (
            CString::new(a.as_os_str().as_bytes())?,
            CString::new(b.as_os_str().as_bytes())?,
        );
        // SAFETY: both are valid NUL-terminated paths, relative to the working directory.
        let swapped = unsafe {
            libc::renameat2(
                libc::AT_FDCWD,
                a.as_ptr(),
                libc::AT_FDCWD,
                b.as_ptr(),
                libc::RENAME_EXCHANGE,
            )
        } == 0;
        Ok(swapped)
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        let _ = (a, b);
        Ok(false)
    }
}

/// Moves the finished folder `tmp` to `path`: swapped with an existing `path` atomically
/// (`RENAME_EXCHANGE`) where the kernel has it, after which `tmp` names the old folder and the
/// caller removes it; renamed otherwise. The caller has checked that an existing `path` is its
/// own.
///
/// # Errors
/// If `path` exists and is not a folder, or the rename fails.
pub fn swap_in_dir(tmp: &Path, path: &Path) -> Result<bool> {
    let exists = match fs::symlink_metadata(path) {
        Ok(m) if !m.is_dir() => anyhow::bail!(
            "{} exists and is not a folder; nothing was changed",
            path.display()
        ),
        Ok(_) => true,
        Err(_) => false,
    };
    if !exists {
        fs::rename(tmp, path)
            .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))?;
        return Ok(false);
    }
    if exchange(tmp, path)? {
        return Ok(true);
    }
    // No exchange: move the old folder aside first, then the new one in.
    let aside = tmp.with_extension("old");
    fs::rename(path, &aside)
        .and_then(|()| fs::rename(tmp, path))
        .and_then(|()| fs::rename(&aside, tmp))
        .with_context(|| format!("cannot replace {}", path.display()))?;
    Ok(true)
}

/// Writes an array as `.npy`, atomically.
///
/// # Errors
/// If writing fails.
pub fn write_npy<A: ndarray_npy::WritableElement, D: ndarray::Dimension>(
    path: &Path,
    a: &ndarray::Array<A, D>,
) -> Result<()> {
    use ndarray_npy::{WriteNpyError, WriteNpyExt};
    atomic_write(path, |w| match a.write_npy(w) {
        Ok(()) => Ok(()),
        // The I/O error itself (ndarray-npy's says `I/O error: {e}` and gives `e` as its
        // cause, which a printed chain repeated).
        Err(WriteNpyError::Io(e)) => Err(e.into()),
        Err(e) => Err(e.into()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_path_hands_a_temporary_name_and_cleans_up_after_a_failure() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("new/out.mat");
        atomic_write_path(&path, |tmp| {
            assert_eq!(tmp.parent(), path.parent());
            assert!(!tmp.exists());
            Ok(fs::write(tmp, b"first")?)
        })
        .unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"first");
        let err = atomic_write_path(&path, |tmp| {
            fs::write(tmp, b"partial")?;
            anyhow::bail!("libhdf5 failed")
        })
        .unwrap_err();
        assert!(format!("{err:#}").contains("out.mat"), "{err:#}");
        assert_eq!(fs::read(&path).unwrap(), b"first");
        let names: Vec<_> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["out.mat"]);
    }

    #[test]
    fn atomic_write_makes_its_folder_and_replaces_an_existing_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a/b/out.bin");
        atomic_write(&path, |w| Ok(w.write_all(b"first")?)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"first");
        // A re-run: the old file is swapped out and removed, the new one is in place whole.
        atomic_write(&path, |w| Ok(w.write_all(&[7u8; 3 << 20])?)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), vec![7u8; 3 << 20]);
        // A failing writer leaves the last good file and no temporary file.
        let err = atomic_write(&path, |w| {
            w.write_all(b"partial")?;
            anyhow::bail!("disk full")
        })
        .unwrap_err();
        assert!(format!("{err:#}").contains("out.bin"), "{err:#}");
        assert_eq!(fs::read(&path).unwrap().len(), 3 << 20);
        let names: Vec<_> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["out.bin"]);
    }

    /// A re-run that computes the same bytes leaves the file alone (same inode, so no block of
    /// it is freed and written again); other bytes, of the same size or not, replace it.
    #[test]
    fn the_same_bytes_leave_the_file_as_it_is() {
        use std::os::unix::fs::MetadataExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.npy");
        let ino = || fs::metadata(&path).unwrap().ino();
        atomic_write(&path, |w| Ok(w.write_all(&[1u8; 4096])?)).unwrap();
        let first = ino();
        atomic_write(&path, |w| Ok(w.write_all(&[1u8; 4096])?)).unwrap();
        assert_eq!(ino(), first, "rewritten although unchanged");
        atomic_write(&path, |w| Ok(w.write_all(&[2u8; 4096])?)).unwrap();
        assert_ne!(ino(), first);
        assert_eq!(fs::read(&path).unwrap(), vec![2u8; 4096]);
        // Written in pieces, and durably: compared as a whole.
        let second = ino();
        atomic_write_durable(&path, |w| {
            w.write_all(&[2u8; 4000])?;
            Ok(w.write_all(&[2u8; 96])?)
        })
        .unwrap();
        assert_eq!(ino(), second);
        // Past what is held in memory: written through the temporary file.
        atomic_write(&path, |w| Ok(w.write_all(&vec![3u8; HELD + 1])?)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), vec![3u8; HELD + 1]);
        let names: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["m.npy"]);
    }
}
