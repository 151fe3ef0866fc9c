//! Reading an output folder safely: is it a complete run's (not in progress, every file its
//! manifest lists present and unchanged), the manifest's record of the files a run wrote, and
//! the check of a single output file's path.

use super::lock::Holder;
use super::temporaries::remove_temporaries;
use crate::io::journal::STATE;
use anyhow::{bail, Context, Result};
use std::fs;
use std::path::Path;

/// Checks that `root` is a complete run's folder: not in progress, a `manifest.json`, and
/// every file the manifest lists present with its recorded size (and hash for tables).
///
/// # Errors
/// Saying what is in progress, missing or changed, and how to read the folder anyway
/// (`--allow-incomplete`).
pub fn check_complete(root: &Path) -> Result<()> {
    if !root.is_dir() {
        bail!("{} is not a results folder", root.display());
    }
    let hint = "rerun the experiment into it, or pass --allow-incomplete to read what is there";
    let marker = root.join(STATE).join("in-progress");
    if let Ok(text) = fs::read_to_string(&marker) {
        // A merge that knew what was missing says so.
        let reason = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v["reason"].as_str().map(str::to_string));
        if let Some(reason) = reason {
            bail!("{} is incomplete: {reason}; {hint}", root.display());
        }
        if let Some(writer) = live_writer(root) {
            bail!(
                "{} is incomplete: {writer} is still writing into it; wait for it to finish, or \
                 pass --allow-incomplete to read what is there",
                root.display()
            );
        }
        match serde_json::from_str::<Holder>(&text) {
            Ok(h) if h.command == "shard" => bail!(
                "{} is incomplete: it is the folder of a sharded run whose shards have not all \
                 finished or have not been merged (the last shard to start was {}); `isar-clutter \
                 status {}` lists the jobs still missing; run their shards, then `isar-clutter \
                 merge {}`; or pass --allow-incomplete to read what is there",
                root.display(),
                h.describe(),
                root.display(),
                root.display()
            ),
            Ok(h) => bail!(
                "{} is incomplete: the {} was interrupted before writing its manifest, so its \
                 files may mix two runs; {hint}",
                root.display(),
                h.describe()
            ),
            Err(_) => bail!(
                "{} is incomplete: a run was interrupted before writing its manifest, so its \
                 files may mix two runs; {hint}",
                root.display()
            ),
        }
    }
    let path = root.join("manifest.json");
    let file = fs::File::open(&path).with_context(|| {
        format!(
            "{} has no manifest.json: not a finished run's folder; {hint}",
            root.display()
        )
    })?;
    // Read as a stream, each file checked as its record is read: a manifest of 100,000 jobs
    // is tens of MB of JSON, and as a `serde_json::Value` it took 370 MB.
    let mut problems = vec![];
    let mut de = serde_json::Deserializer::from_reader(std::io::BufReader::new(file));
    serde::de::DeserializeSeed::deserialize(
        ManifestFiles {
            root,
            problems: &mut problems,
        },
        &mut de,
    )
    .and_then(|()| de.end())
    .with_context(|| format!("reading {}", path.display()))?;
    if !problems.is_empty() {
        let n = problems.len();
        problems.truncate(8);
        bail!(
            "{} does not hold the files its manifest lists ({n} problem(s): {}{}): it was \
             changed after the run; {hint}",
            root.display(),
            problems.join("; "),
            if n > 8 { "; ..." } else { "" }
        );
    }
    Ok(())
}

/// A file's record in the manifest (`files`): its size and, for a table, its SHA-256.
#[derive(serde::Deserialize)]
struct FileRecord {
    bytes: Option<u64>,
    sha256: Option<String>,
}

/// Checks one listed file against its record; a problem found is pushed.
fn check_file(root: &Path, rel: &str, rec: &FileRecord, problems: &mut Vec<String>) {
    let file = root.join(rel);
    match fs::metadata(&file) {
        Err(_) => problems.push(format!("{rel} is missing")),
        Ok(m) if Some(m.len()) != rec.bytes => problems.push(format!(
            "{rel} has {} bytes, the manifest says {}",
            m.len(),
            rec.bytes.map_or("nothing".to_string(), |b| b.to_string())
        )),
        Ok(_) => {
            if let Some(want) = &rec.sha256 {
                let got = fs::File::open(&file)
                    .and_then(crate::seeds::sha256_hex_of)
                    .unwrap_or_default();
                if &got != want {
                    problems.push(format!("{rel} differs from the file the run wrote"));
                }
            }
        }
    }
}

/// The manifest read for its `files` alone, each record checked as it is read (every other
/// field skipped without being built); a manifest without `files` (of a version that did not
/// list them) passes.
struct ManifestFiles<'a> {
    root: &'a Path,
    problems: &'a mut Vec<String>,
}

impl<'de> serde::de::DeserializeSeed<'de> for ManifestFiles<'_> {
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> serde::de::Visitor<'de> for ManifestFiles<'_> {
    type Value = ();

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("the tool's manifest (a JSON object)")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        while let Some(key) = map.next_key::<std::borrow::Cow<'de, str>>()? {
            if key == "files" {
                map.next_value_seed(FileList {
                    root: self.root,
                    problems: &mut *self.problems,
                })?;
            } else {
                map.next_value::<serde::de::IgnoredAny>()?;
            }
        }
        Ok(())
    }
}

/// The manifest's `files` object, checked entry by entry ([`check_file`]).
struct FileList<'a> {
    root: &'a Path,
    problems: &'a mut Vec<String>,
}

impl<'de> serde::de::DeserializeSeed<'de> for FileList<'_> {
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> serde::de::Visitor<'de> for FileList<'_> {
    type Value = ();

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an object of file records")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        while let Some((rel, rec)) = map.next_entry::<String, FileRecord>()? {
            check_file(self.root, &rel, &rec, self.problems);
        }
        Ok(())
    }
}

/// The writer holding one of `root`'s locks now (`lock`, `lock.shard-<i>`), described; `None`
/// when none is held.
fn live_writer(root: &Path) -> Option<String> {
    // No lock is this reader's: every held one counts.
    let live = super::lock::other_locks(root, "").ok()?;
    live.into_iter().next().map(|(_, holder)| holder)
}

/// The record of one file the run wrote (`rel`, relative to `root`) for the manifest: its size,
/// and for a table at the top level its SHA-256, so that a reader can tell a folder changed
/// afterwards. `None` for a file that is not there (or whose name is not UTF-8).
///
/// # Errors
/// If a table cannot be read for its hash.
pub fn file_record(root: &Path, rel: &Path) -> Result<Option<(String, serde_json::Value)>> {
    file_record_hashed(root, rel, None)
}

/// [`file_record`], with the SHA-256 of a table given where it is known (computed as the table
/// was written): the file is not read again then.
///
/// # Errors
/// If a table that needs hashing cannot be read.
pub fn file_record_hashed(
    root: &Path,
    rel: &Path,
    sha256: Option<&str>,
) -> Result<Option<(String, serde_json::Value)>> {
    let path = root.join(rel);
    let Ok(m) = fs::metadata(&path) else {
        return Ok(None);
    };
    let Some(key) = rel.to_str() else {
        return Ok(None);
    };
    let mut rec = serde_json::json!({ "bytes": m.len() });
    if rel.extension().is_some_and(|e| e == "parquet") && rel.components().count() == 1 {
        let hash = match sha256 {
            Some(h) => h.to_string(),
            None => fs::File::open(&path)
                .and_then(crate::seeds::sha256_hex_of)
                .with_context(|| format!("reading {}", path.display()))?,
        };
        rec["sha256"] = serde_json::Value::String(hash);
    }
    Ok(Some((key.to_string(), rec)))
}

/// Refuses an output file path that is a folder (or anything but a regular file), and an
/// existing file that `ours` does not recognise as a file of the kind the tool writes there.
///
/// # Errors
/// Naming the path and what is there.
pub fn check_file_output(path: &Path, what: &str, ours: impl Fn(&Path) -> bool) -> Result<()> {
    match fs::symlink_metadata(path) {
        Err(_) => Ok(()),
        Ok(m) if m.is_dir() => bail!(
            "{} is a folder; --out names the {what} file to write (e.g. {}/samples.{}); \
             nothing was changed",
            path.display(),
            path.display(),
            what.rsplit('.').next().unwrap_or("npy")
        ),
        Ok(m) if !m.is_file() => bail!(
            "{} exists and is not a regular file; nothing was changed",
            path.display()
        ),
        Ok(_) if !ours(path) => bail!(
            "{} exists and is not a {what} file the tool wrote; remove it or choose another \
             --out (nothing was changed)",
            path.display()
        ),
        Ok(_) => Ok(()),
    }
}

/// Removes what killed writers of `path` left beside it: the temporary files or folders of the
/// tool's atomic writes (`.NAME.tmp-PID`, `.NAME.PID-SEQ.tmp`, NAME being `path`'s file name)
/// whose writer is not a live process of this machine (no such process, or a zombie). A pid
/// now reused by another process counts as alive and its file stays. Writers on other machines
/// sharing the folder cannot be told apart, so two machines must not write one path at once
/// (their renames would race anyway). Returns the names removed.
///
/// # Errors
/// When a temporary of a dead writer cannot be removed.
pub fn remove_dead_temporaries_of(path: &Path) -> Result<Vec<String>> {
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        return Ok(Vec::new());
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let me = std::process::id();
    remove_temporaries(dir, |base, pid, _| {
        base == name && pid != me && super::lock::is_gone(pid)
    })
}
