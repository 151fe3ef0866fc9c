//! Content hashes of the job store: of input files (memoised within the process and across
//! runs through the output folder's memo, `jobs/input-hashes.json`), which enter the job keys,
//! and of stored files, which a job's record keeps so that a damaged result is never used.
//! XXH3-128, as a tree over 8 MiB chunks hashed in parallel for large files.

use anyhow::{Context, Result};
use rayon::prelude::*;
use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

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
pub(super) fn content_hash(path: &Path) -> Result<String> {
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
pub(super) fn tree_hash(bytes: &[u8]) -> u128 {
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
