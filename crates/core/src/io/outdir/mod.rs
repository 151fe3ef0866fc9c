//! Output folders the tool owns, and nothing else. A run (or a report) claims its folder
//! before it writes: the folder must be new, empty, or carry the tool's marker of the same
//! experiment (`.isar-clutter/owner.json`, or the `manifest.json` of an earlier version);
//! anything else is refused and left untouched. The claim takes a lock ([`take_lock`]: an `fcntl`
//! lock the kernel frees when its holder ends, whose file records the holder's pid, host and
//! start for messages), marks the folder in progress
//! until the run's manifest is written, and keeps a journal of every file the tool writes
//! there ([`note`], called by every atomic write before it creates its temporary file).
//! Cleaning removes only what that journal says the tool wrote; the temporary files of dead
//! writers go too. Readers ([`check_complete`]) refuse a folder that is in progress or whose
//! files differ from its manifest's list.
//!
//! State, all under `.isar-clutter/` in the output folder:
//! - `owner.json`: `{"tool": "isar-clutter", "name": <experiment>}`, the marker;
//! - `lock`: locked by the run writing now, recording its [`Holder`] (removed when it ends;
//!   `lock.shard-<i>` for shard `i`);
//! - `in-progress`: the [`Holder`] of a run that has not written its manifest yet;
//! - `owned`: the relative paths the tool wrote, one per line, as of the last finished claim;
//! - `journal`: paths noted since then (appended before each write, so a killed run's files
//!   are known too);
//! - `previous-manifest.json`: the manifest of the run before this one (moved aside when a
//!   run starts, so that a folder has a `manifest.json` only when its run completed);
//! - `figures.json`: the report's figure cache (the `isar-clutter` crate's `report::figures::cache`).

use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::collections::{BTreeSet, HashSet};
use std::fs::{self, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

mod check;
mod lock;
mod temporaries;

pub use check::{
    check_complete, check_file_output, file_record, file_record_hashed, remove_dead_temporaries_of,
};
pub use lock::{is_held, take_lock, HeldLock, Holder};
use temporaries::remove_temporaries;
pub use temporaries::temporary_of;

use crate::io::journal::{self, safe_relative};
pub use crate::io::journal::{note, STATE};

/// A claimed output folder: locked, journaled, and (for a run) marked in progress until
/// [`OutDir::complete`]. Dropping it releases the lock and stops the journal; a run that did
/// not complete stays marked in progress.
#[derive(Debug)]
pub struct OutDir {
    root: PathBuf,
    abs: PathBuf,
    /// The name of the lock under the state folder (`lock`, `lock.shard-<i>`).
    lock: String,
    /// The lock itself, released when the claim is dropped.
    _held: HeldLock,
    /// Notes for the caller: stale lock taken over, temporary files removed.
    pub notes: Vec<String>,
}

/// What a claim is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// A run: any folder the tool owns for this experiment (or a new or empty one); marked in
    /// progress until its manifest is written.
    Run,
    /// One shard of a run (`run --shards N --shard index`): several shards write into one
    /// folder at once, each under its own lock (`lock.shard-<index>`); the folder is marked in
    /// progress until `merge` writes the manifest. A shard removes nothing.
    Shard {
        /// The shard's index.
        index: usize,
    },
    /// Rebuilding the report of a finished run: the folder must be complete (or the caller
    /// allows an incomplete one).
    Report {
        /// Accept a folder that is in progress or whose files differ from its manifest.
        allow_incomplete: bool,
    },
}

impl OutDir {
    /// Claims `root` for the experiment `name`.
    ///
    /// Refused (nothing changed) when `root` is not a folder, holds files and no marker of the
    /// tool, belongs to another experiment, or is locked by a live holder; for
    /// [`Purpose::Report`] also when it is not a complete run's folder. A lock of a dead holder
    /// is taken over (said in [`OutDir::notes`]), and the temporary files of dead writers are
    /// removed. For [`Purpose::Run`] the folder is marked in progress and its manifest moved
    /// aside.
    ///
    /// # Errors
    /// As above; every message names the folder and says why.
    pub fn claim(root: &Path, name: Option<&str>, purpose: Purpose) -> Result<OutDir> {
        match fs::symlink_metadata(root) {
            Ok(m) if !m.is_dir() => bail!(
                "{} exists and is not a folder: choose another --out (nothing was changed)",
                root.display()
            ),
            Ok(_) => check_owner(root, name, purpose)?,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                fs::create_dir_all(root)
                    .with_context(|| format!("cannot create {}", root.display()))?;
            }
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", root.display())),
        }
        if let Purpose::Report { allow_incomplete } = purpose {
            if !allow_incomplete {
                check_complete(root)?;
            }
        }
        let state = root.join(STATE);
        fs::create_dir_all(&state).with_context(|| format!("cannot create {}", state.display()))?;
        let mut notes = vec![];
        let me = Holder::me(match purpose {
            Purpose::Run => "run",
            Purpose::Shard { .. } => "shard",
            Purpose::Report { .. } => "report",
        });
        let lock = match purpose {
            Purpose::Shard { index } => format!("lock.shard-{index}"),
            _ => "lock".to_string(),
        };
        let held = take_lock(
            &state.join(&lock),
            &root.display().to_string(),
            &me,
            &mut notes,
        )?;
        let abs = std::path::absolute(root)
            .with_context(|| format!("cannot resolve {}", root.display()))?;
        // From here on the lock is ours; dropping `dir` releases it on any error.
        let mut dir = OutDir {
            root: root.to_path_buf(),
            abs,
            lock,
            _held: held,
            notes,
        };
        // What the folder held may have changed while the lock was not ours (a run of another
        // experiment that finished a moment ago).
        check_owner(root, name, purpose)?;
        dir.check_no_other_writer(purpose)?;
        dir.prepare(&state, name, purpose, &me)?;
        Ok(dir)
    }

    /// Refuses when another writer holds the folder: a shard runs beside other shards, never
    /// beside a whole run or a merge; those run beside nothing. Each writer takes its own lock
    /// before it looks at the others', so of two started at once at least one sees the other.
    fn check_no_other_writer(&self, purpose: Purpose) -> Result<()> {
        let root = &self.root;
        let conflicts = lock::other_locks(root, &self.lock)?;
        let blocking: Vec<String> = conflicts
            .into_iter()
            .filter(|(name, _)| !matches!(purpose, Purpose::Shard { .. }) || name == "lock")
            .map(|(_, h)| h)
            .collect();
        if let Some(h) = blocking.first() {
            bail!(
                "{} is being written by {h} that is still running: wait for it to finish (nothing \
                 was changed)",
                root.display(),
            );
        }
        Ok(())
    }

    /// Readies a claimed folder: its owner marker written (for a named experiment), the
    /// temporary files of dead writers removed (not by a shard: other shards' are alive), and
    /// for a run or a shard the folder marked in progress and its manifest moved aside; then
    /// the journal opened.
    fn prepare(
        &mut self,
        state: &Path,
        name: Option<&str>,
        purpose: Purpose,
        me: &Holder,
    ) -> Result<()> {
        let root = self.root.clone();
        if let Some(name) = name {
            let owner = serde_json::json!({"tool": crate::TOOL, "name": name});
            let marker = state.join("owner.json");
            // A re-run finds its marker as it would write it.
            let same = fs::read(&marker)
                .ok()
                .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
                .is_some_and(|v| v == owner);
            if !same {
                write_json(&marker, &owner)?;
            }
        }
        let removed = if matches!(purpose, Purpose::Shard { .. }) {
            0 // other shards may be writing: their temporary files are alive
        } else {
            self.remove_dead_temporaries()?
        };
        if removed > 0 {
            self.notes.push(format!(
                "removed {removed} temporary file(s) left by an interrupted writer in {}",
                root.display()
            ));
        }
        if matches!(purpose, Purpose::Run | Purpose::Shard { .. }) {
            write_json(&state.join("in-progress"), me)?;
            let manifest = root.join("manifest.json");
            match fs::rename(&manifest, state.join("previous-manifest.json")) {
                // Another shard moved it first, or there was none.
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(e)
                        .with_context(|| format!("cannot move {} aside", manifest.display()))
                }
                _ => {}
            }
        }
        let file = lock::open_no_follow(
            OpenOptions::new().create(true).append(true),
            &state.join("journal"),
            "journal",
        )?;
        journal::open(&self.abs, file)?;
        Ok(())
    }

    /// The folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Calls `f` with every file noted under this claim (relative paths, each once), read
    /// from the records on disk: nothing but a 64-bit hash per path is held in memory.
    ///
    /// # Errors
    /// If a record cannot be read, or as `f`.
    pub fn each_written(&self, mut f: impl FnMut(&Path) -> Result<()>) -> Result<()> {
        let mut seen = HashSet::new();
        each_owned(&self.root, |rel| {
            if journal::is_written(&self.abs, rel) && seen.insert(journal::path_hash(rel)) {
                f(rel)?;
            }
            Ok(())
        })
    }

    /// The relative paths the tool's records say it wrote here (the `owned` list and the
    /// journal), including this claim's.
    pub fn owned(&self) -> Result<BTreeSet<PathBuf>> {
        owned(&self.root)
    }

    /// Removes the files the tool wrote here earlier that `stale` selects and this claim has not
    /// written (an earlier run's job that is gone, a failed job's old maps, an old figure), and
    /// then the folders that removal left empty. Returns how many files went. Files the tool's
    /// records do not list are never touched. The records are read and rewritten as a stream
    /// (`owned` becomes what is left of them and this claim's files), so that memory holds a
    /// 64-bit hash per path, not the paths.
    ///
    /// # Errors
    /// If a file cannot be removed; the message names it.
    pub fn remove_stale(&self, stale: impl Fn(&Path) -> bool) -> Result<usize> {
        let state = self.root.join(STATE);
        let mut keep = crate::io::atomic::Staged::new(&state.join("owned"));
        let mut removed = 0;
        let mut parents = BTreeSet::new();
        let mut seen = HashSet::new();
        each_owned(&self.root, |rel| {
            if !seen.insert(journal::path_hash(rel)) {
                return Ok(());
            }
            let path = self.root.join(rel);
            let kept = if journal::is_written(&self.abs, rel) {
                true
            } else if stale(rel) {
                match fs::symlink_metadata(&path) {
                    Ok(m) if m.is_file() => {
                        fs::remove_file(&path)
                            .with_context(|| format!("removing stale {}", path.display()))?;
                        removed += 1;
                    }
                    _ => {}
                }
                parents.extend(rel.ancestors().skip(1).map(Path::to_path_buf));
                false
            } else {
                path.is_file()
            };
            if let (true, Some(s)) = (kept, rel.to_str()) {
                keep.write_all(s.as_bytes())?;
                keep.write_all(b"\n")?;
            }
            Ok(())
        })?;
        // Deepest first; only folders the removal emptied (remove_dir fails on any other).
        let mut parents: Vec<PathBuf> = parents
            .into_iter()
            .filter(|p| !p.as_os_str().is_empty())
            .collect();
        parents.sort_by_key(|p| std::cmp::Reverse(p.components().count()));
        for p in parents {
            let _ = fs::remove_dir(self.root.join(p));
        }
        // The records now: what is left of the old list, and this claim's files; the journal
        // of earlier claims is emptied (this claim's paths stay noted in memory).
        keep.commit()?;
        lock::open_no_follow(
            OpenOptions::new().write(true).create(true).truncate(true),
            &state.join("journal"),
            "journal",
        )
        .with_context(|| format!("cannot reset {}/{STATE}/journal", self.root.display()))?;
        Ok(removed)
    }

    /// Keeps the folder marked incomplete and says why (a merge with jobs missing): readers
    /// refuse it with this reason.
    ///
    /// # Errors
    /// If the marker cannot be written.
    pub fn mark_incomplete(&self, reason: &str) -> Result<()> {
        let mut v = serde_json::to_value(Holder::me("merge"))?;
        v["reason"] = serde_json::Value::String(reason.into());
        write_json(&self.root.join(STATE).join("in-progress"), &v)
    }

    /// Marks the run complete: called right after its manifest is written.
    ///
    /// # Errors
    /// If the marker cannot be removed.
    pub fn complete(&self) -> Result<()> {
        let marker = self.root.join(STATE).join("in-progress");
        match fs::remove_file(&marker) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(e).with_context(|| format!("cannot remove {}", marker.display()))
            }
            _ => Ok(()),
        }
    }

    /// Removes the temporary files (`.NAME.tmp-PID`, `.NAME.PID-SEQ.tmp`) of owned paths
    /// whose writer is not this process. The lock is ours, so no other writer is alive here.
    fn remove_dead_temporaries(&self) -> Result<usize> {
        let me = std::process::id();
        let mut removed = 0;
        let mut owned = HashSet::new();
        let mut folders = BTreeSet::new();
        each_owned(&self.root, |rel| {
            owned.insert(journal::path_hash(rel));
            folders.insert(rel.parent().map(Path::to_path_buf).unwrap_or_default());
            Ok(())
        })?;
        for folder in folders {
            removed += remove_temporaries(&self.root.join(&folder), |base, pid, is_dir| {
                pid != me && !is_dir && owned.contains(&journal::path_hash(&folder.join(base)))
            })?
            .len();
        }
        Ok(removed)
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        journal::close(&self.abs);
        // The lock goes with `_held`, after this.
    }
}

/// The relative paths the tool's records say it wrote in `root`.
///
/// # Errors
/// If a record exists but cannot be read.
pub fn owned(root: &Path) -> Result<BTreeSet<PathBuf>> {
    let mut set = BTreeSet::new();
    each_owned(root, |rel| {
        set.insert(rel.to_path_buf());
        Ok(())
    })?;
    Ok(set)
}

/// Calls `f` with every path of `root`'s records (`owned`, then `journal`), line by line,
/// without holding them (a path may come twice: once from each record).
///
/// # Errors
/// If a record exists but cannot be read, or as `f`.
fn each_owned(root: &Path, mut f: impl FnMut(&Path) -> Result<()>) -> Result<()> {
    use std::io::BufRead;
    for name in ["owned", "journal"] {
        let path = root.join(STATE).join(name);
        let file = match fs::File::open(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
        };
        for line in std::io::BufReader::new(file).lines() {
            let line = line.with_context(|| format!("reading {}", path.display()))?;
            let rel = Path::new(&line);
            if safe_relative(rel) && !rel.starts_with(STATE) {
                f(rel)?;
            }
        }
    }
    Ok(())
}

/// Takes the lock of a single output of `command` (a `generate`'s samples file, a `fit`'s
/// model folder): `.NAME.lock` beside it (its folder made if missing, and removed with the
/// lock if it is still empty then), held until the returned lock is dropped and removed then. Two writers of one output started at once: one is
/// refused, naming the other.
///
/// # Errors
/// When another live writer holds it, or the lock cannot be taken.
pub fn lock_output(path: &Path, command: &str) -> Result<HeldLock> {
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .with_context(|| format!("{} does not name a file", path.display()))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    // The folders missing now, deepest first: the lock removes them again if they stay empty.
    let made: Vec<PathBuf> = dir
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
        .map(Path::to_path_buf)
        .collect();
    fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut notes = vec![];
    let held = take_lock(
        &dir.join(format!(".{name}.lock")),
        &path.display().to_string(),
        &Holder::me(command),
        &mut notes,
    );
    Ok(held?.made_folders(made))
}

/// Marks `root` (created if missing) as an output folder of the experiment `name` without
/// claiming it, for files written before any run (the Slurm scripts of `isar-clutter slurm`).
/// Refused, with nothing changed, where a run's claim would be: `root` is not a folder, holds
/// entries without the tool's marker, or belongs to another experiment.
///
/// # Errors
/// As above, or when the marker cannot be written.
pub fn mark(root: &Path, name: &str) -> Result<()> {
    match fs::symlink_metadata(root) {
        Ok(m) if !m.is_dir() => bail!(
            "{} exists and is not a folder: choose another --out (nothing was changed)",
            root.display()
        ),
        Ok(_) => check_owner(root, Some(name), Purpose::Run)?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", root.display())),
    }
    let state = root.join(STATE);
    fs::create_dir_all(&state).with_context(|| format!("cannot create {}", state.display()))?;
    let owner = serde_json::json!({"tool": crate::TOOL, "name": name});
    write_json(&state.join("owner.json"), &owner)
}

/// Refuses a folder the tool may not write into for the experiment `name` (any experiment
/// when `None`): one with entries and no marker of the tool, or one that belongs to another
/// experiment. A report needs the marker (or a manifest) even in an empty folder.
fn check_owner(root: &Path, name: Option<&str>, purpose: Purpose) -> Result<()> {
    let marker = root.join(STATE).join("owner.json");
    let owner = |path: &Path, pointer: &str| -> Result<Option<String>> {
        let Ok(text) = fs::read_to_string(path) else {
            return Ok(None);
        };
        let v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{} is not the tool's marker (not JSON)", path.display()))?;
        if v["tool"].as_str() != Some(crate::TOOL)
            && v.pointer("/tool/name").and_then(|t| t.as_str()) != Some(crate::TOOL)
        {
            return Ok(None);
        }
        Ok(v.pointer(pointer)
            .and_then(|n| n.as_str())
            .map(str::to_string))
    };
    let found = match owner(&marker, "/name")? {
        Some(n) => Some(n),
        // An output folder of a version without the marker: its manifest names the experiment.
        None => owner(&root.join("manifest.json"), "/spec/name")?,
    };
    match found {
        Some(n) if name.is_none_or(|name| n == name) => Ok(()),
        Some(other) => bail!(
            "{} holds the outputs of experiment {other:?}, not {:?}: choose another --out \
             (nothing was changed)",
            root.display(),
            name.unwrap_or_default()
        ),
        None if matches!(purpose, Purpose::Report { .. }) => bail!(
            "{} is not a results folder of isar-clutter (no {STATE}/owner.json and no \
             manifest.json of the tool)",
            root.display()
        ),
        None => {
            let mut entries: Vec<String> = fs::read_dir(root)
                .with_context(|| format!("cannot read {}", root.display()))?
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                // The tool's state alone (a claim that has not written its marker yet).
                .filter(|n| n != STATE)
                .collect();
            if entries.is_empty() {
                return Ok(());
            }
            // Another run of the tool may have claimed the folder between the marker's read
            // and the listing (its marker first, then its files): judged again by its marker.
            if owner(&marker, "/name")?.is_some() {
                return check_owner(root, name, purpose);
            }
            entries.sort();
            let shown: Vec<&str> = entries.iter().take(3).map(String::as_str).collect();
            bail!(
                "{} is not empty and was not written by isar-clutter (it holds {} entr{}: {}{}; \
                 no {STATE}/owner.json): the tool writes only into a new or empty folder or \
                 its own; choose another --out (nothing was changed)",
                root.display(),
                entries.len(),
                if entries.len() == 1 { "y" } else { "ies" },
                shown.join(", "),
                if entries.len() > 3 { ", ..." } else { "" }
            )
        }
    }
}

fn write_json(path: &Path, v: &impl Serialize) -> Result<()> {
    crate::io::atomic::atomic_write(path, |w| Ok(serde_json::to_writer_pretty(w, v)?))
}

#[cfg(test)]
mod tests;
