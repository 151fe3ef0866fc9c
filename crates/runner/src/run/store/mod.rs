//! The durable job store: every job, when it finishes, leaves its result under `OUT/jobs/`
//! (its key names it), so that a run killed at any moment resumes where it stopped, shards on
//! other machines add their jobs to the same folder, and `merge` assembles the tables from the
//! store alone.
//!
//! `key` is the first 20 hex digits of a SHA-256 over what determines the result: the store's
//! schema version, the sample format generation uses, the job's kind, identity and seed, its full validated parameters
//! ([`JobKind::key_material`]: for a dataset job its dataset, analysis and synthesis settings
//! and the plan-wide settings its rows depend on) and the content hash (XXH3-128) of its input files. A
//! changed spec or input file changes the keys of exactly the jobs it affects; a key of an
//! earlier spec is never read.
//!
//! A job's folder holds the files the job wrote (`maps/<id>/...`, `models/<id>/...`,
//! `samples/...`, `kspace/...`, the same relative paths as in the output folder) and, written
//! last, one pack `job.pack` ([`PACK`]); a job that wrote no files has no folder, its pack is
//! `OUT/jobs/<two digits>/<key>.pack` ([`flat_pack`]). The pack holds its record (id, kind,
//! key, schema, timings, every file with its size and content hash) and its table fragments
//! (Parquet), one file per job
//! however many tables it fills. A failed job leaves `failed.json` with its error instead, and
//! is run again by the next run. The pack is written through the atomic writer; packs are
//! committed to disk in groups ([`Commits`]: one `syncfs` per group, not two `fsync`s per
//! job), and every pack carries the content hash of its record and fragments, checked
//! whenever it is read, as are the hashes of the job's files when the entry is verified (to
//! resume, to merge, for `status`): a job whose pack or files did not reach the disk (a power
//! failure before its group was synced), or were changed or damaged since, is run again and
//! never merged.

use crate::run::jobs::{JobKind, Outcome, Rows};
use crate::run::plan::Plan;
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashSet};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

mod hash;
use hash::{content_hash, tree_hash};
pub use hash::{content_hash_of, load_hash_memo, save_hash_memo};

/// Version of what a job's record and fragments hold; part of every key, so results of another
/// schema are never merged.
pub const SCHEMA: u32 = 3;

/// The file of a finished job's record and table fragments in its folder.
pub const PACK: &str = "job.pack";

/// What a pack starts with: these 8 bytes, the record's length (`u64`, little endian) and the
/// XXH3-128 (`u128`, little endian) of everything after these 32 bytes (the record, then the
/// fragments).
const MAGIC: &[u8; 8] = b"ISARPAK3";

/// Bytes of a pack's header.
const HEADER: usize = 32;

/// A table fragment in a job's pack: a Parquet file at `offset` (from the end of the record)
/// of `bytes` bytes, with `columns` columns.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Fragment {
    /// The table it belongs to.
    pub table: String,
    /// Where its bytes start, after the record.
    pub offset: u64,
    /// How many bytes it has.
    pub bytes: u64,
    /// How many columns it has (the merge finds each table's widest fragment from the
    /// records alone).
    pub columns: usize,
    /// How many rows it has (the merge lays out each table's row groups from the records).
    pub rows: usize,
}

/// The record of a finished job (the start of its [`PACK`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Done {
    /// [`SCHEMA`] when written.
    pub schema: u32,
    /// The job's key.
    pub key: String,
    /// The job's id.
    pub id: String,
    /// The job's kind.
    pub kind: String,
    /// Wall time of the job in seconds.
    pub elapsed_s: f64,
    /// The job's timings for the manifest.
    pub timing: Option<serde_json::Value>,
    /// Table fragments in the job's order, in the pack after the record.
    pub fragments: Vec<Fragment>,
    /// Files the job wrote (relative to its folder, and to the output folder once merged),
    /// with their sizes.
    pub files: BTreeMap<String, u64>,
    /// The content hash ([`content_hash_of`]: `xxh3-128:` and 32 hex digits) of every file in
    /// `files`, checked whenever the entry is verified, so that a damaged file is never
    /// resumed or merged (the pack's own bytes are covered by the hash in its header).
    pub hashes: BTreeMap<String, String>,
    /// The build of the tool that computed the result ([`crate::run::manifest::build_commit`]);
    /// absent in records written before it was kept. The key does not hold the tool's
    /// version, so a result is reused by later builds: the merge says so when it does.
    #[serde(default)]
    pub built_by: Option<String>,
}

/// The record of a failed job (`failed.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Failed {
    /// [`SCHEMA`] when written.
    pub schema: u32,
    /// The job's key.
    pub key: String,
    /// The job's id.
    pub id: String,
    /// The error with its cause chain.
    pub error: String,
    /// Wall time of the job in seconds.
    pub elapsed_s: f64,
}

/// What the store holds for one job.
#[derive(Debug, Clone)]
pub enum Entry {
    /// Finished and verified.
    Done(Done),
    /// Failed with this record.
    Failed(Failed),
    /// Nothing usable (never run, killed while running, or a record that does not verify:
    /// the reason).
    Missing(Option<String>),
}

/// The folder of the job with `key`.
pub fn job_dir(out: &Path, key: &str) -> PathBuf {
    out.join("jobs").join(key)
}

/// The pack of a finished job that wrote no files (`jobs/<the key's first two digits>/<key>.pack`):
/// not in a folder of its own. A folder costs the file system a directory inode (ext4 places
/// each with its Orlov search over the block groups), more than the pack itself: in a sweep of
/// tiny jobs the `mkdir` was 18 % of a shard's CPU (`perf`). The packs are spread over 256
/// folders by their keys' first two digits: no folder of 100,000 entries, and a file is created
/// and renamed under its folder's lock, for which the pool's threads spun when every pack was
/// in `jobs/` (18 % of a shard's CPU samples; the shards' wall time did not move measurably).
/// A job with files keeps them and its pack in `jobs/<key>/` ([`PACK`]).
pub fn flat_pack(out: &Path, key: &str) -> PathBuf {
    let fan = key.get(..2).unwrap_or("00");
    out.join("jobs").join(fan).join(format!("{key}.pack"))
}

/// Where the pack of the job with `key` may be, in the order it is looked for: without a folder
/// ([`flat_pack`]), then in the job's folder.
fn pack_places(out: &Path, key: &str) -> [PathBuf; 2] {
    [flat_pack(out, key), job_dir(out, key).join(PACK)]
}

/// The first place of [`pack_places`] where `read` finds something (`Ok(None)`: not there).
fn first_pack<T>(
    out: &Path,
    key: &str,
    read: impl Fn(&Path) -> std::result::Result<Option<T>, String>,
) -> std::result::Result<Option<T>, String> {
    for place in pack_places(out, key) {
        if let Some(found) = read(&place)? {
            return Ok(Some(found));
        }
    }
    Ok(None)
}

/// The key of `job` in `plan`.
///
/// # Errors
/// If an input file cannot be read for its hash.
pub fn key(job: &dyn JobKind, plan: &Plan) -> Result<String> {
    let mut text = format!(
        "isar-clutter/store/{SCHEMA}\nsample_format={}\nkind={}\nidentity={}\nseed={:?}\n{}\n",
        crate::synthesis::SAMPLE_FORMAT,
        job.kind(),
        job.identity(),
        job.seed(),
        job.key_material(plan)
    );
    for file in job.input_files() {
        text.push_str(&format!("file={}\n", content_hash(&file)?));
    }
    Ok(crate::seeds::sha256_hex(text.as_bytes())[..20].to_string())
}

/// Checks a finished job's files against its record: every file present with its size and
/// content hash. The reason when one is not.
fn verify(dir: &Path, done: &Done) -> std::result::Result<(), String> {
    // Hashed on the current pool: a job's maps are many small files.
    let files: Vec<(&String, &u64)> = done.files.iter().collect();
    files.par_iter().try_for_each(|(rel, bytes)| {
        let path = dir.join(rel);
        match fs::metadata(&path) {
            Err(_) => return Err(format!("{rel} is missing")),
            Ok(m) if m.len() != **bytes => {
                return Err(format!(
                    "{rel} has {} bytes, its record says {bytes}",
                    m.len()
                ))
            }
            _ => {}
        }
        let Some(want) = done.hashes.get(*rel) else {
            return Err(format!("{rel} has no content hash in its record"));
        };
        match content_hash_of(&path) {
            Ok(got) if &got == want => Ok(()),
            Ok(_) => Err(format!(
                "{rel} differs from what the job wrote (its content hash does not match)"
            )),
            Err(e) => Err(format!("{rel} cannot be read: {e:#}")),
        }
    })
}

/// Reads what the store holds for `key`, verifying a pack (its header, the hash of its record
/// and fragments, the schema and key, every file of the job present with its size and content
/// hash): a damaged entry is [`Entry::Missing`] with the reason, and the job is run again.
pub fn entry(out: &Path, key: &str) -> Entry {
    read_entry(out, key, true)
}

/// What the store holds for `key`, its record read but neither the pack's fragments nor the
/// job's files hashed: for a caller that verified the entry ([`entry`]) under the claim it
/// still holds, or that wrote it itself (the merge after a run or a merge has checked every
/// entry), or that asks only whether a record is there.
pub fn entry_verified_earlier(out: &Path, key: &str) -> Entry {
    read_entry(out, key, false)
}

/// [`entry`], with the pack's and the files' hashes checked when `verify`.
fn read_entry(out: &Path, key: &str, verify_files: bool) -> Entry {
    let dir = job_dir(out, key);
    let pack = if verify_files {
        read_pack(out, key).map(|p| p.map(|(done, _)| done))
    } else {
        first_pack(out, key, read_record)
    };
    match pack {
        Ok(Some(done)) => {
            if done.schema != SCHEMA || done.key != key {
                return Entry::Missing(Some(format!(
                    "{PACK} of schema {} (this tool writes {SCHEMA})",
                    done.schema
                )));
            }
            if verify_files {
                if let Err(why) = verify(&dir, &done) {
                    return Entry::Missing(Some(why));
                }
            }
            return Entry::Done(done);
        }
        Err(why) => return Entry::Missing(Some(why)),
        Ok(None) => {}
    }
    if let Ok(bytes) = fs::read(dir.join("failed.json")) {
        if let Ok(f) = serde_json::from_slice::<Failed>(&bytes) {
            if f.schema == SCHEMA && f.key == key {
                return Entry::Failed(f);
            }
        }
    }
    Entry::Missing(None)
}

/// The record at the start of the pack `path`, its hash not checked; `Ok(None)` where there is
/// no pack, `Err` with the reason where it cannot be read.
fn read_record(path: &Path) -> std::result::Result<Option<Done>, String> {
    use std::io::Read;
    let mut file = match fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{PACK} cannot be read: {e}")),
    };
    let mut header = [0u8; HEADER];
    file.read_exact(&mut header)
        .map_err(|_| format!("{PACK} is shorter than its header"))?;
    let len = record_len(&header)?;
    let mut record = vec![0u8; len];
    file.read_exact(&mut record)
        .map_err(|_| format!("{PACK} is shorter than its record"))?;
    serde_json::from_slice(&record)
        .map(Some)
        .map_err(|e| format!("{PACK}'s record unreadable: {e}"))
}

/// The record's length from a pack's header, which must start with [`MAGIC`].
fn record_len(header: &[u8]) -> std::result::Result<usize, String> {
    if header.len() < HEADER || &header[..8] != MAGIC {
        return Err(format!("{PACK} does not start as a pack of this tool"));
    }
    let len = u64::from_le_bytes(header[8..16].try_into().expect("8 bytes"));
    usize::try_from(len).map_err(|_| format!("{PACK} names a record of {len} bytes"))
}

/// A job's pack read whole and checked (header, the hash of everything after it, the record):
/// the record and the fragments' bytes (everything after the record). `Ok(None)` where there is
/// no pack; `Err` with the reason where it does not verify.
///
/// # Errors
/// The reason, as [`Entry::Missing`] gives it.
pub fn read_pack(out: &Path, key: &str) -> std::result::Result<Option<(Done, Vec<u8>)>, String> {
    let read = |path: &Path| match fs::read(path) {
        Ok(b) => Ok(Some(b)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{PACK} cannot be read: {e}")),
    };
    let Some(bytes) = first_pack(out, key, read)? else {
        return Ok(None);
    };
    let len = record_len(&bytes)?;
    let want = u128::from_le_bytes(bytes[16..32].try_into().expect("16 bytes"));
    if tree_hash(&bytes[HEADER..]) != want {
        return Err(format!(
            "{PACK} differs from what the job wrote (its content hash does not match)"
        ));
    }
    let end = HEADER
        .checked_add(len)
        .filter(|&e| e <= bytes.len())
        .ok_or_else(|| format!("{PACK} is shorter than its record"))?;
    let done: Done = serde_json::from_slice(&bytes[HEADER..end])
        .map_err(|e| format!("{PACK}'s record unreadable: {e}"))?;
    let body = bytes[end..].to_vec();
    if done
        .fragments
        .iter()
        .any(|f| f.offset.saturating_add(f.bytes) > body.len() as u64)
    {
        return Err(format!("{PACK} is shorter than its fragments"));
    }
    Ok(Some((done, body)))
}

/// Fragment `i` of a pack's record, read from the pack's fragment bytes.
///
/// # Errors
/// If the Parquet bytes cannot be read.
pub fn fragment(done: &Done, body: &[u8], i: usize) -> Result<polars::prelude::DataFrame> {
    use polars::prelude::{ParquetReader, SerReader};
    let f = &done.fragments[i];
    let bytes = &body[f.offset as usize..(f.offset + f.bytes) as usize];
    let df = if crate::io::frame::is_frame(bytes) {
        crate::io::frame::decode(bytes)
    } else {
        // Written by a build before the plain fragments, or of a type they do not take.
        ParquetReader::new(std::io::Cursor::new(bytes))
            .finish()
            .map_err(anyhow::Error::from)
    };
    df.with_context(|| format!("reading fragment {} ({}) of job {}", i, f.table, done.id))
}

/// The note of a run or merge that redoes jobs whose stored result did not verify.
pub fn damaged_note(damaged: &[String]) -> String {
    let shown: Vec<&str> = damaged.iter().take(5).map(String::as_str).collect();
    format!(
        "redone: the job store's result of {} job(s) did not verify and was not used: {}{}",
        damaged.len(),
        shown.join("; "),
        if damaged.len() > 5 { "; ..." } else { "" }
    )
}

/// Prepares the folder of a job about to run: whatever an earlier attempt left in it goes
/// first (its record, its files, a killed writer's temporary files), so that a pack exists
/// only for a run that finished and lists exactly the files that run wrote. The store's files
/// are not journaled ([`crate::io::journal::STORE`]): this is what keeps a job's folder clean.
/// No other process writes the folder meanwhile: the output folder's lock (or a shard's, for
/// the jobs only that shard runs) is held.
///
/// # Errors
/// If the folder cannot be emptied.
pub fn begin(out: &Path, key: &str) -> Result<PathBuf> {
    let gone = |removed: std::io::Result<()>, doing: &str, path: &Path| match removed {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(e).with_context(|| format!("{doing} {}", path.display()))
        }
        _ => Ok(()),
    };
    let dir = job_dir(out, key);
    gone(fs::remove_dir_all(&dir), "emptying", &dir)?;
    let flat = flat_pack(out, key);
    gone(fs::remove_file(&flat), "removing", &flat)?;
    Ok(dir)
}

/// Saves a finished job's outcome: one pack (its record, then its fragments), or
/// `failed.json`; the pack is made durable with its group ([`Commits`]).
///
/// # Errors
/// If a file cannot be written.
pub fn save(out: &Path, key: &str, job: &dyn JobKind, outcome: &Outcome) -> Result<()> {
    use polars::prelude::{ParquetCompression, ParquetWriter, StatisticsOptions};
    let dir = job_dir(out, key);
    let rows = match &outcome.rows {
        Err(error) => {
            let failed = Failed {
                schema: SCHEMA,
                key: key.into(),
                id: job.id().into(),
                error: error.clone(),
                elapsed_s: outcome.elapsed_s,
            };
            return write_json(&dir.join("failed.json"), &failed);
        }
        Ok(rows) => rows,
    };
    // Each fragment in the plain format of `io::frame` (the merge reads it once and the tables
    // it goes into are Parquet), or, for a column type it does not take, as a Parquet file in
    // memory without statistics or compression.
    let parts = rows
        .tables
        .iter()
        .map(|(table, df)| {
            if let Some(bytes) = crate::io::frame::encode(df) {
                return Ok((table.to_string(), (df.width(), df.height()), bytes));
            }
            let mut bytes = Vec::new();
            ParquetWriter::new(&mut bytes)
                .with_compression(ParquetCompression::Uncompressed)
                .with_statistics(StatisticsOptions {
                    min_value: false,
                    max_value: false,
                    distinct_count: false,
                    null_count: false,
                    binary_statistics_truncate_length: None,
                })
                .set_parallel(false)
                .finish(&mut df.clone())
                .with_context(|| format!("encoding the {table} fragment"))?;
            Ok((table.to_string(), (df.width(), df.height()), bytes))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut fragments = Vec::with_capacity(parts.len());
    let mut offset = 0u64;
    for (table, columns, bytes) in &parts {
        fragments.push(Fragment {
            table: table.clone(),
            offset,
            bytes: bytes.len() as u64,
            columns: columns.0,
            rows: columns.1,
        });
        offset += bytes.len() as u64;
    }
    let mut files = BTreeMap::new();
    list_files(&dir, &dir, &mut files)?;
    let hashes = files
        .keys()
        .cloned()
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|rel| {
            let h = content_hash_of(&dir.join(&rel))?;
            Ok((rel, h))
        })
        .collect::<Result<BTreeMap<_, _>>>()?;
    let done = Done {
        schema: SCHEMA,
        key: key.into(),
        id: job.id().into(),
        kind: job.kind().into(),
        elapsed_s: outcome.elapsed_s,
        timing: rows.timing.clone(),
        fragments,
        files,
        hashes,
        built_by: Some(crate::run::manifest::build_commit()),
    };
    let mut body = serde_json::to_vec(&done)?;
    let record = body.len() as u64;
    for (_, _, bytes) in &parts {
        body.extend_from_slice(bytes);
    }
    let mut header = Vec::with_capacity(HEADER);
    header.extend_from_slice(MAGIC);
    header.extend_from_slice(&record.to_le_bytes());
    header.extend_from_slice(&tree_hash(&body).to_le_bytes());
    let path = if done.files.is_empty() {
        flat_pack(out, key)
    } else {
        dir.join(PACK)
    };
    crate::io::atomic::atomic_write(&path, |w| {
        w.write_all(&header)?;
        w.write_all(&body)?;
        Ok(())
    })
}

/// Every regular file under `dir` but the records, relative to `root`.
fn list_files(root: &Path, dir: &Path, out: &mut BTreeMap<String, u64>) -> Result<()> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Ok(());
    };
    for e in entries.flatten() {
        let path = e.path();
        let rel = path.strip_prefix(root).unwrap_or(&path).to_path_buf();
        let name = e.file_name();
        let name = name.to_string_lossy();
        if dir == root && matches!(&*name, PACK | "failed.json") {
            continue;
        }
        if name.starts_with('.') {
            continue; // a temporary file of an atomic write
        }
        let meta = e
            .metadata()
            .with_context(|| format!("reading {}", path.display()))?;
        if meta.is_dir() {
            list_files(root, &path, out)?;
        } else if let Some(s) = rel.to_str() {
            out.insert(s.to_string(), meta.len());
        }
    }
    Ok(())
}

/// Makes the packs of finished jobs durable in groups: after [`Commits::GROUP`] jobs or
/// [`Commits::EVERY`], whichever comes first, one `syncfs` of the store's file system (Linux;
/// `sync` elsewhere) commits every pack and file written since, instead of two `fsync`s per
/// job. A power failure loses at most the last group's jobs, which the next run redoes: their
/// packs or files, unsynced, fail their content hashes or are missing.
#[derive(Debug)]
pub struct Commits {
    store: PathBuf,
    state: Mutex<(usize, std::time::Instant)>,
}

impl Commits {
    /// Jobs per group.
    pub const GROUP: usize = 256;
    /// The longest a finished job waits for its group's sync.
    pub const EVERY: std::time::Duration = std::time::Duration::from_secs(2);

    /// The groups of the store of `out`.
    pub fn new(out: &Path) -> Self {
        Commits {
            store: out.join(crate::io::journal::STORE),
            state: Mutex::new((0, std::time::Instant::now())),
        }
    }

    /// Counts one saved job; syncs when its group is full or old enough.
    pub fn saved(&self) {
        let due = {
            let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
            s.0 += 1;
            let due = s.0 >= Self::GROUP || s.1.elapsed() >= Self::EVERY;
            if due {
                *s = (0, std::time::Instant::now());
            }
            due
        };
        if due {
            self.sync();
        }
    }

    /// Syncs what is pending (the end of a run or merge).
    pub fn flush(&self) {
        let pending = {
            let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
            std::mem::replace(&mut *s, (0, std::time::Instant::now())).0
        };
        if pending > 0 {
            self.sync();
        }
    }

    /// One `syncfs` of the store's file system; a failure loses no result (the jobs are
    /// verified whenever they are read) and is ignored.
    fn sync(&self) {
        #[cfg(target_os = "linux")]
        if let Ok(dir) = fs::File::open(&self.store) {
            use std::os::fd::AsRawFd;
            // SAFETY: a valid open descriptor, borrowed for the call.
            unsafe { libc::syncfs(dir.as_raw_fd()) };
        }
        #[cfg(not(target_os = "linux"))]
        // SAFETY: no arguments.
        unsafe {
            libc::sync()
        };
    }
}

/// The rows of a finished job, read back from its pack.
///
/// # Errors
/// If the pack does not verify or a fragment cannot be read.
pub fn load_rows(out: &Path, done: &Done) -> Result<Rows> {
    let (done, body) = match read_pack(out, &done.key) {
        Ok(Some(p)) => p,
        Ok(None) => bail!(
            "the pack of job {} is missing from {}",
            done.id,
            out.join("jobs").display()
        ),
        Err(why) => bail!("{}: {why}", job_dir(out, &done.key).display()),
    };
    let tables = (0..done.fragments.len())
        .map(|i| {
            Ok((
                static_name(&done.fragments[i].table),
                fragment(&done, &body, i)?,
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Rows {
        tables,
        files: done.files.keys().map(PathBuf::from).collect(),
        timing: done.timing.clone(),
    })
}

/// A table name as `&'static str` (the fragments' type): each distinct name is leaked once.
fn static_name(name: &str) -> &'static str {
    static NAMES: Mutex<Option<HashSet<&'static str>>> = Mutex::new(None);
    let mut guard = NAMES.lock().unwrap_or_else(|e| e.into_inner());
    let set = guard.get_or_insert_with(HashSet::new);
    if let Some(n) = set.get(name) {
        return n;
    }
    let leaked: &'static str = Box::leak(name.to_string().into_boxed_str());
    set.insert(leaked);
    leaked
}

/// Puts a finished job's files in place in the output folder: each is hard-linked (copied
/// where links are impossible) from the job's folder to the same relative path, atomically.
///
/// # Errors
/// If a file cannot be linked or copied.
pub fn publish(out: &Path, done: &Done) -> Result<()> {
    let dir = job_dir(out, &done.key);
    for rel in done.files.keys() {
        let from = dir.join(rel);
        let to = out.join(rel);
        crate::io::outdir::note(&to);
        if let Some(parent) = to.parent() {
            fs::create_dir_all(parent)
                .with_context(|| format!("cannot create {}", parent.display()))?;
        }
        if fs::symlink_metadata(&to).is_ok_and(|m| !m.is_file()) {
            bail!(
                "{} exists and is not a regular file; nothing is renamed over it",
                to.display()
            );
        }
        if same_file(&from, &to) {
            continue;
        }
        link_over(&from, &to).with_context(|| format!("publishing {}", to.display()))?;
    }
    Ok(())
}

/// Whether two paths name the same file (a link made by an earlier merge).
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => false,
    }
}

/// Replaces the file `to` with a hard link to `from` (a copy if linking fails), through a
/// temporary name.
fn link_over(from: &Path, to: &Path) -> Result<()> {
    let name = to.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    let tmp = to.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let _ = fs::remove_file(&tmp);
    if fs::hard_link(from, &tmp).is_err() {
        fs::copy(from, &tmp).with_context(|| format!("copying {}", from.display()))?;
    }
    // Swapped in rather than renamed over (see `replace`: no forced write-back of the new file).
    crate::io::atomic::replace(&tmp, to)
        .with_context(|| format!("renaming to {}", to.display()))?;
    Ok(())
}

/// Writes a record durably (synced before and after its rename).
fn write_json(path: &Path, v: &impl Serialize) -> Result<()> {
    crate::io::atomic::atomic_write_durable(path, |w| {
        serde_json::to_writer_pretty(&mut *w, v)?;
        Ok(())
    })
}

/// Which shard runs each job: jobs that read the same dataset stay together; groups are
/// handed out largest estimated work first, each to the shard with the least work so far
/// (ties: the lower shard). Deterministic for a plan and `shards`. `None` for jobs that read
/// other jobs' rows: `merge` runs them.
///
/// # Errors
/// If `shards` is zero.
pub fn assign(plan: &Plan, jobs: &[&dyn JobKind], shards: usize) -> Result<Vec<Option<usize>>> {
    use crate::run::jobs::Inputs;
    if shards == 0 {
        bail!("--shards must be at least 1");
    }
    let mut groups: Vec<(Option<u64>, Vec<usize>, f64)> = vec![];
    // The group of each data seed (a lookup, not a scan: a sweep of 100,000 jobs with as many
    // datasets made this quadratic).
    let mut of_seed: std::collections::HashMap<u64, usize> = Default::default();
    for (i, job) in jobs.iter().enumerate() {
        let key = match job.inputs() {
            Inputs::Rows(_) => continue,
            Inputs::Dataset { data_seed, .. } => Some(data_seed),
            Inputs::Nothing => None,
        };
        let cost = job.estimate(plan).flops.max(1.0);
        match key.and_then(|k| of_seed.get(&k).copied()) {
            Some(g) => {
                groups[g].1.push(i);
                groups[g].2 += cost;
            }
            None => {
                if let Some(k) = key {
                    of_seed.insert(k, groups.len());
                }
                groups.push((key, vec![i], cost));
            }
        }
    }
    let mut order: Vec<usize> = (0..groups.len()).collect();
    order.sort_by(|&a, &b| groups[b].2.total_cmp(&groups[a].2).then(a.cmp(&b)));
    let mut load = vec![0.0f64; shards];
    let mut out = vec![None; jobs.len()];
    for g in order {
        let s = (0..shards)
            .min_by(|&a, &b| load[a].total_cmp(&load[b]).then(a.cmp(&b)))
            .unwrap_or(0);
        load[s] += groups[g].2;
        for &i in &groups[g].1 {
            out[i] = Some(s);
        }
    }
    Ok(out)
}
