//! The durable job store: every job, when it finishes, leaves its result under
//! `OUT/jobs/<key>/`, so that a run killed at any moment resumes where it stopped, shards on
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
//! `samples/...`, `kspace/...`, the same relative paths as in the output folder), its table
//! fragments (`fragments/<n>-<table>.parquet`) and, written last, `done.json` (id, kind, key,
//! schema, timings, every file with its size). A failed job leaves `failed.json` with its error
//! instead, and is run again by the next run. Everything is written through the atomic writer;
//! the records are synced to disk before and after their rename. `done.json` lists the size
//! and the content hash (XXH3-128) of every file and fragment, checked whenever the entry is
//! read (to resume, to merge, for `status`), so a job whose files did not reach the disk, or
//! were changed or damaged since, is run again and never merged.

use crate::io::atomic::{read_parquet, write_parquet};
use crate::run::jobs::{JobKind, Outcome, Rows};
use crate::run::plan::Plan;
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Version of what a job's record and fragments hold; part of every key, so results of another
/// schema are never merged.
pub const SCHEMA: u32 = 2;

/// The record of a finished job (`done.json`).
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
    /// Table fragments in the job's order: `(table, file under fragments/)`.
    pub fragments: Vec<(String, String)>,
    /// Files the job wrote (relative to its folder, and to the output folder once merged),
    /// with their sizes.
    pub files: BTreeMap<String, u64>,
    /// The content hash ([`content_hash_of`]: `xxh3-128:` and 32 hex digits) of every file in
    /// `files` and of every fragment (`fragments/<file>`), checked whenever the entry is read,
    /// so that a damaged file is never resumed or merged.
    pub hashes: BTreeMap<String, String>,
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

/// What identifies a file's content without reading it: its path and its
/// [`crate::io::FileId`], flat (the memo's JSON rows).
type Seen = (PathBuf, u64, u64, u64, i128, i128);

/// The content hashes of this process, and those read from an output folder's memo.
static MEMO: Mutex<Option<HashMap<Seen, String>>> = Mutex::new(None);

/// What identifies `path`'s content now (its change time is the last field).
fn seen(path: &Path) -> Result<Seen> {
    let meta = fs::metadata(path).with_context(|| format!("reading {}", path.display()))?;
    let (dev, ino, len, mtime, ctime) = crate::io::file_id(&meta);
    Ok((path.to_path_buf(), dev, ino, len, mtime, ctime))
}

/// The rows of `out`'s memo file, if it holds any.
fn read_hash_memo(out: &Path) -> Option<Vec<(Seen, String)>> {
    serde_json::from_slice(&fs::read(memo_path(out)).ok()?).ok()
}

/// The memo of input hashes an output folder keeps: `jobs/input-hashes.json`.
fn memo_path(out: &Path) -> PathBuf {
    out.join("jobs").join("input-hashes.json")
}

/// Reads the input hashes recorded in `out` by an earlier run (a missing or unreadable memo
/// is no memo: every input is hashed again), so that a resumed run does not re-read its
/// inputs: hashing a 32 MB stack took 40 % of a resumed run.
pub fn load_hash_memo(out: &Path) {
    let Some(rows) = read_hash_memo(out) else {
        return;
    };
    if let Ok(mut m) = MEMO.lock() {
        m.get_or_insert_with(HashMap::new)
            .extend(rows.into_iter().filter(|(_, h)| h.starts_with(HASH_PREFIX)));
    }
}

/// Records the hashes of `files` in `out`'s memo; a file changed less than a second before
/// (whose timestamps a write in the same clock tick would not move) is left out, as git does
/// with "racily clean" files.
///
/// # Errors
/// If the memo cannot be written.
pub fn save_hash_memo(out: &Path, files: &[PathBuf]) -> Result<()> {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as i128);
    let memo = MEMO.lock().ok().and_then(|m| m.clone()).unwrap_or_default();
    let mut rows: Vec<(Seen, String)> = Vec::new();
    for f in files {
        let Ok(id) = seen(f) else { continue };
        if now - id.5 < 1_000_000_000 {
            continue;
        }
        if let Some(h) = memo.get(&id) {
            rows.push((id, h.clone()));
        }
    }
    rows.sort();
    rows.dedup();
    // A re-run over the same inputs finds its memo as it would write it: nothing to write.
    if read_hash_memo(out).as_ref() == Some(&rows) {
        return Ok(());
    }
    crate::io::atomic::atomic_write(&memo_path(out), |w| {
        serde_json::to_writer(&mut *w, &rows)?;
        Ok(())
    })
}

/// The content hash of a file: `xxh3-128:` and [`tree_hash`] of its bytes in 32 hex digits.
/// The hash only tells the job keys whether an input changed (the key itself keeps 80 bits),
/// so a fast non-cryptographic 128-bit hash serves: on the development VM a mapped 32 MB stack
/// took about 2 ms, against 4 ms for BLAKE3 on two threads and 20 ms for SHA-256 (the largest
/// cost of a first run after the analysis). Memoised per path, device, inode, size and
/// modification and change times: within the process (a large stack read by many jobs is
/// hashed once) and across runs through the output folder's memo ([`load_hash_memo`]).
fn content_hash(path: &Path) -> Result<String> {
    let id = seen(path)?;
    if let Some(h) = MEMO
        .lock()
        .ok()
        .and_then(|m| m.as_ref().and_then(|m| m.get(&id).cloned()))
    {
        return Ok(h);
    }
    let hex = format!("{HASH_PREFIX}{:032x}", hash_file(path)?);
    if let Ok(mut m) = MEMO.lock() {
        m.get_or_insert_with(HashMap::new).insert(id, hex.clone());
    }
    Ok(hex)
}

/// What a content hash of this version starts with; memo entries without it (SHA-256 or BLAKE3
/// of earlier versions) are not read.
const HASH_PREFIX: &str = "xxh3-128:";

/// [`tree_hash`] of a file's bytes: mapped and hashed on the current rayon pool, or read in
/// blocks where the file cannot be mapped.
fn hash_file(path: &Path) -> Result<u128> {
    let file = fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
    // An `.npy` stack keeps its mapping for the analysis that loads it next.
    // SAFETY (both): read-only and private; an input rewritten during the run is undefined
    // here as for the analysis (documented in `io::npy::Stack`).
    let map = if path.extension().is_some_and(|e| e == "npy") {
        unsafe { crate::io::npy::map_for_reading(&file) }
    } else {
        unsafe { memmap2::Mmap::map(&file) }.map(std::sync::Arc::new)
    };
    match map {
        Ok(map) => Ok(tree_hash(&map)),
        Err(_) => hash_reader(file).with_context(|| format!("reading {}", path.display())),
    }
}

/// Bytes per leaf of [`tree_hash`].
const HASH_CHUNK: usize = 8 << 20;

/// XXH3-128 (seed 0, as `xxhsum -H2` prints it) of `bytes` up to [`HASH_CHUNK`] bytes; beyond,
/// XXH3-128 of the XXH3-128 digests (16 bytes each, little endian) of its consecutive
/// `HASH_CHUNK`-byte chunks, the last one shorter, hashed in parallel on the current rayon
/// pool (a single XXH3 stream runs on one thread, and the page faults of a fresh mapping with
/// it).
fn tree_hash(bytes: &[u8]) -> u128 {
    if bytes.len() <= HASH_CHUNK {
        return xxhash_rust::xxh3::xxh3_128(bytes);
    }
    let leaves: Vec<u128> = bytes
        .par_chunks(HASH_CHUNK)
        .map(xxhash_rust::xxh3::xxh3_128)
        .collect();
    root(&leaves)
}

/// The tree hash from its leaves (the XXH3-128 of each chunk, in order): a lone leaf is the
/// hash; several are hashed together, 16 bytes each, little endian.
fn root(leaves: &[u128]) -> u128 {
    match leaves {
        [one] => *one,
        _ => {
            let digests: Vec<u8> = leaves.iter().flat_map(|d| d.to_le_bytes()).collect();
            xxhash_rust::xxh3::xxh3_128(&digests)
        }
    }
}

/// [`tree_hash`] of everything `r` yields, read one chunk at a time.
fn hash_reader(mut r: impl std::io::Read) -> std::io::Result<u128> {
    let mut leaves = Vec::new();
    let mut buf = vec![0u8; HASH_CHUNK];
    loop {
        let mut n = 0;
        while n < HASH_CHUNK {
            match r.read(&mut buf[n..])? {
                0 => break,
                m => n += m,
            }
        }
        if n == 0 && !leaves.is_empty() {
            break;
        }
        leaves.push(xxhash_rust::xxh3::xxh3_128(&buf[..n]));
        if n < HASH_CHUNK {
            break;
        }
    }
    Ok(root(&leaves))
}

/// Checks a finished job's files against its record: every file present with its size and
/// content hash, every fragment present with its content hash. The reason when one is not.
fn verify(dir: &Path, done: &Done) -> std::result::Result<(), String> {
    let fragments = done
        .fragments
        .iter()
        .map(|(_, f)| (format!("fragments/{f}"), None));
    let files = done.files.iter().map(|(rel, b)| (rel.clone(), Some(*b)));
    let all: Vec<(String, Option<u64>)> = files.chain(fragments).collect();
    // Hashed on the current pool: a job's maps are many small files.
    all.par_iter().try_for_each(|(rel, bytes)| {
        let path = dir.join(rel);
        match (fs::metadata(&path), bytes) {
            (Err(_), _) => return Err(format!("{rel} is missing")),
            (Ok(m), Some(b)) if m.len() != *b => {
                return Err(format!("{rel} has {} bytes, its record says {b}", m.len()))
            }
            _ => {}
        }
        let Some(want) = done.hashes.get(rel) else {
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

/// The content hash of a stored file as a job's record keeps it: `xxh3-128:` and the
/// [`tree_hash`] of its bytes in 32 hex digits (not memoised: a file of the store is read
/// every time).
///
/// # Errors
/// If the file cannot be read.
pub fn content_hash_of(path: &Path) -> Result<String> {
    let hash = || -> std::io::Result<u128> {
        let mut file = fs::File::open(path)?;
        let len = file.metadata()?.len();
        if len <= HASH_CHUNK as u64 {
            // Most stored files are small maps and fragments: one read costs less than a
            // mapping's set-up and page faults.
            let mut bytes = Vec::with_capacity(len as usize);
            std::io::Read::read_to_end(&mut file, &mut bytes)?;
            return Ok(tree_hash(&bytes));
        }
        // SAFETY: read-only and private; a stored file rewritten while it is hashed gives a
        // hash that does not match, and the job is redone.
        match unsafe { memmap2::Mmap::map(&file) } {
            Ok(map) => Ok(tree_hash(&map)),
            Err(_) => hash_reader(file),
        }
    };
    let h = hash().with_context(|| format!("reading {}", path.display()))?;
    Ok(format!("{HASH_PREFIX}{h:032x}"))
}

/// Reads what the store holds for `key`, verifying a `done.json` (schema, key, every file
/// and fragment present with its size and content hash): a damaged entry is
/// [`Entry::Missing`] with the reason, and the job is run again.
pub fn entry(out: &Path, key: &str) -> Entry {
    read_entry(out, key, true)
}

/// What the store holds for `key`, its record read but its files not hashed: for a caller that
/// verified the entry ([`entry`]) under the claim it still holds, or that wrote it itself (the
/// merge after a run or a merge has checked every entry), or that asks only whether a record
/// is there.
pub fn entry_verified_earlier(out: &Path, key: &str) -> Entry {
    read_entry(out, key, false)
}

/// [`entry`], with the files' hashes checked when `verify`.
fn read_entry(out: &Path, key: &str, verify_files: bool) -> Entry {
    let dir = job_dir(out, key);
    let read = |name: &str| fs::read(dir.join(name)).ok();
    if let Some(bytes) = read("done.json") {
        let done: Done = match serde_json::from_slice(&bytes) {
            Ok(d) => d,
            Err(e) => return Entry::Missing(Some(format!("done.json unreadable: {e}"))),
        };
        if done.schema != SCHEMA || done.key != key {
            return Entry::Missing(Some(format!(
                "done.json of schema {} (this tool writes {SCHEMA})",
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
    if let Some(bytes) = read("failed.json") {
        if let Ok(f) = serde_json::from_slice::<Failed>(&bytes) {
            if f.schema == SCHEMA && f.key == key {
                return Entry::Failed(f);
            }
        }
    }
    Entry::Missing(None)
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

/// Prepares the folder of a job about to run: its old records go first (a rerun of a failed or
/// interrupted job), so that `done.json` exists only for a run that finished.
///
/// # Errors
/// If a record cannot be removed.
pub fn begin(out: &Path, key: &str) -> Result<PathBuf> {
    let dir = job_dir(out, key);
    for name in ["done.json", "failed.json"] {
        match fs::remove_file(dir.join(name)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(e).with_context(|| format!("removing {}", dir.join(name).display()))
            }
            _ => {}
        }
    }
    Ok(dir)
}

/// Saves a finished job's outcome: its fragments and then `done.json` (or `failed.json`).
///
/// # Errors
/// If a file cannot be written.
pub fn save(out: &Path, key: &str, job: &dyn JobKind, outcome: &Outcome) -> Result<()> {
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
    let fragments: Vec<(String, String)> = rows
        .tables
        .iter()
        .enumerate()
        .map(|(i, (table, _))| (table.to_string(), format!("{i}-{table}.parquet")))
        .collect();
    // On the pool: each fragment is its own file.
    rows.tables
        .par_iter()
        .zip(&fragments)
        .try_for_each(|((_, df), (_, file))| {
            write_parquet(&dir.join("fragments").join(file), &mut df.clone())
        })?;
    let mut files = BTreeMap::new();
    list_files(&dir, &dir, &mut files)?;
    let hashed: Vec<String> = files
        .keys()
        .cloned()
        .chain(fragments.iter().map(|(_, f)| format!("fragments/{f}")))
        .collect();
    let hashes = hashed
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
    };
    write_json(&dir.join("done.json"), &done)
}

/// Every regular file under `dir` but the records and fragments, relative to `root`.
fn list_files(root: &Path, dir: &Path, out: &mut BTreeMap<String, u64>) -> Result<()> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Ok(());
    };
    for e in entries.flatten() {
        let path = e.path();
        let rel = path.strip_prefix(root).unwrap_or(&path).to_path_buf();
        let name = e.file_name();
        let name = name.to_string_lossy();
        if dir == root && matches!(&*name, "done.json" | "failed.json" | "fragments") {
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

/// The rows of a finished job, read back from its fragments.
///
/// # Errors
/// If a fragment cannot be read.
pub fn load_rows(out: &Path, done: &Done) -> Result<Rows> {
    let dir = job_dir(out, &done.key).join("fragments");
    let tables = done
        .fragments
        .par_iter()
        .map(|(table, file)| {
            let path = dir.join(file);
            let df =
                read_parquet(&path)?.with_context(|| format!("{} is missing", path.display()))?;
            Ok((static_name(table), df))
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
    for (i, job) in jobs.iter().enumerate() {
        let key = match job.inputs() {
            Inputs::Rows(_) => continue,
            Inputs::Dataset { data_seed, .. } => Some(data_seed),
            Inputs::Nothing => None,
        };
        let cost = job.estimate(plan).flops.max(1.0);
        match groups
            .iter_mut()
            .find(|(k, _, _)| key.is_some() && *k == key)
        {
            Some((_, g, c)) => {
                g.push(i);
                *c += cost;
            }
            None => groups.push((key, vec![i], cost)),
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The tree hash written out serially: the oracle of the parallel and the streaming forms.
    fn tree_hash_serial(bytes: &[u8]) -> u128 {
        use xxhash_rust::xxh3::xxh3_128;
        if bytes.len() <= HASH_CHUNK {
            return xxh3_128(bytes);
        }
        let mut digests = Vec::new();
        for chunk in bytes.chunks(HASH_CHUNK) {
            digests.extend_from_slice(&xxh3_128(chunk).to_le_bytes());
        }
        xxh3_128(&digests)
    }

    /// The hash of a file, mapped and hashed on two threads (an empty file cannot be mapped:
    /// read) or read in chunks, is the tree hash of its bytes, for sizes around XXH3's
    /// short-input and block sizes and around one, two and three chunks; its text is the prefix
    /// and 32 hex digits.
    #[test]
    fn file_hash_is_the_tree_hash_of_the_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(16);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let c = HASH_CHUNK;
        for size in [
            0usize,
            1,
            16,
            17,
            240,
            241,
            1025,
            1_000_003,
            c - 1,
            c,
            c + 1,
            2 * c,
            2 * c + 7,
        ] {
            let mut bytes = vec![0u8; size];
            rng.fill_bytes(&mut bytes);
            let path = dir.path().join(format!("f{size}.bin"));
            fs::write(&path, &bytes).unwrap();
            let want = tree_hash_serial(&bytes);
            assert_eq!(
                pool.install(|| hash_file(&path)).unwrap(),
                want,
                "mapped, size {size}"
            );
            assert_eq!(hash_reader(&bytes[..]).unwrap(), want, "read, size {size}");
            let text = pool.install(|| content_hash(&path)).unwrap();
            assert_eq!(text, format!("xxh3-128:{want:032x}"), "size {size}");
            // A stored file's hash (read whole up to a chunk, mapped beyond) is the same.
            let stored = pool.install(|| content_hash_of(&path)).unwrap();
            assert_eq!(stored, text, "stored, size {size}");
        }
    }

    /// Known answers, so that the digest is the published XXH3-128 (seed 0) and not only the
    /// crate's agreement with itself: `xxhsum -H2` of an empty file and of "abc".
    #[test]
    fn small_files_hash_to_the_published_xxh3_128() {
        assert_eq!(
            format!("{:032x}", hash_reader(&[][..]).unwrap()),
            "99aa06d3014798d86001c324468d497f"
        );
        assert_eq!(
            format!("{:032x}", hash_reader(&b"abc"[..]).unwrap()),
            "06b05ab6733a618578af5f94892f3950"
        );
    }
}
