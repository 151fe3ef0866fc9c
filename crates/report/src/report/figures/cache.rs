//! Figures that need not be drawn again. A report opens a [`FigureCache`] on its results
//! folder; while it is open, every figure drawn into that folder is first keyed by a BLAKE3 hash of
//! everything it is drawn from (the values, titles, labels and layout the drawing code
//! receives, [`FORMAT`], the tool's version and a digest of the drawing code) and skipped when
//! the sidecar `.isar-clutter/figures.json` records the same key and both its files still hold
//! the bytes the tool wrote (their BLAKE3 hash). A figure whose key changed, whose file is missing,
//! or whose file a user edited is drawn again. The sidecar keeps only the figures of the last
//! report. The open caches are kept in a process-wide list by folder (as [`crate::io::outdir`]
//! keeps its journals), so that the drawing functions need no extra argument.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Version of the figures' format: bump it when the files drawn from the same inputs change
/// for a reason outside the drawing code (a dependency), so that every cached figure is drawn
/// again. A change of the drawing code itself does that alone: the key holds a digest of its
/// source ([`code_digest`]).
pub const FORMAT: u32 = 1;

/// BLAKE3 of the drawing code's source (this folder's modules that draw) and the embedded
/// font's length, computed once.
fn code_digest() -> &'static [u8] {
    static DIGEST: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    DIGEST.get_or_init(|| {
        let mut h = blake3::Hasher::new();
        for source in [
            include_str!("mod.rs"),
            include_str!("heatmap.rs"),
            include_str!("charts.rs"),
        ] {
            h.update(&(source.len() as u64).to_le_bytes());
            h.update(source.as_bytes());
        }
        h.update(&(super::FONT_BYTES.len() as u64).to_le_bytes());
        h.finalize().as_bytes().to_vec()
    })
}

/// The sidecar, relative to the results folder.
pub const SIDECAR: &str = ".isar-clutter/figures.json";

/// What the sidecar records of one figure.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
struct Entry {
    /// The key of the inputs the files were drawn from.
    key: String,
    /// The files (relative to the results folder) and the BLAKE3 hash of their bytes as written.
    files: BTreeMap<String, String>,
}

#[derive(Debug, Default, serde::Serialize, serde::Deserialize)]
struct Sidecar {
    format: u32,
    figures: BTreeMap<String, Entry>,
}

#[derive(Debug, Default)]
struct State {
    /// This report's figures.
    now: BTreeMap<String, Entry>,
    /// Figures drawn (ids, relative paths without extension).
    drawn: BTreeSet<String>,
    /// Files kept as they were (relative paths).
    kept: BTreeSet<PathBuf>,
}

#[derive(Debug)]
struct Active {
    root: PathBuf,
    abs: PathBuf,
    before: BTreeMap<String, Entry>,
    state: Mutex<State>,
}

/// Every open cache of this process.
static ACTIVE: Mutex<Vec<Arc<Active>>> = Mutex::new(Vec::new());

/// An open figure cache of a results folder; see the module documentation. Dropping it without
/// [`FigureCache::finish`] leaves the sidecar as it was.
#[derive(Debug)]
pub struct FigureCache {
    inner: Arc<Active>,
}

/// What a report drew and what it kept, as [`FigureCache::finish`] returns it.
#[derive(Debug, Clone, Default)]
pub struct CacheSummary {
    /// Figures drawn, as relative paths without extension (`figures/<job>/<stem>`).
    pub drawn: BTreeSet<String>,
    /// Files of figures kept as they were, relative to the results folder.
    pub kept: BTreeSet<PathBuf>,
}

impl FigureCache {
    /// Opens the cache of the results folder `root` (an unreadable or older sidecar counts as
    /// empty: every figure is drawn).
    ///
    /// # Errors
    /// If `root` cannot be resolved to an absolute path.
    pub fn open(root: &Path) -> anyhow::Result<FigureCache> {
        let abs = std::path::absolute(root)
            .map_err(|e| anyhow::anyhow!("cannot resolve {}: {e}", root.display()))?;
        let before = std::fs::read(root.join(SIDECAR))
            .ok()
            .and_then(|b| serde_json::from_slice::<Sidecar>(&b).ok())
            .filter(|s| s.format == FORMAT)
            .map(|s| s.figures)
            .unwrap_or_default();
        let inner = Arc::new(Active {
            root: root.to_path_buf(),
            abs,
            before,
            state: Mutex::new(State::default()),
        });
        if let Ok(mut active) = ACTIVE.lock() {
            active.push(inner.clone());
        }
        Ok(FigureCache { inner })
    }

    /// Closes the cache: writes the sidecar (this report's figures only) when it changed, and
    /// says what was drawn and kept.
    ///
    /// # Errors
    /// If the sidecar cannot be written; the message names it.
    pub fn finish(self) -> anyhow::Result<CacheSummary> {
        let state = std::mem::take(
            &mut *self
                .inner
                .state
                .lock()
                .map_err(|_| anyhow::anyhow!("figure cache lock poisoned"))?,
        );
        if state.now != self.inner.before || !self.inner.root.join(SIDECAR).is_file() {
            let sidecar = Sidecar {
                format: FORMAT,
                figures: state.now,
            };
            crate::io::atomic::atomic_write(&self.inner.root.join(SIDECAR), |w| {
                Ok(serde_json::to_writer_pretty(w, &sidecar)?)
            })?;
        }
        Ok(CacheSummary {
            drawn: state.drawn,
            kept: state.kept,
        })
    }
}

impl Drop for FigureCache {
    fn drop(&mut self) {
        if let Ok(mut active) = ACTIVE.lock() {
            active.retain(|a| !Arc::ptr_eq(a, &self.inner));
        }
    }
}

/// A figure being drawn under an open cache: its id and its files' relative paths.
pub(super) struct Slot {
    active: Arc<Active>,
    id: String,
    files: [String; 2],
}

/// The slot of the figure whose files are `files` (PNG, SVG), if a cache is open on a folder
/// that holds them.
pub(super) fn slot(files: &[PathBuf; 2]) -> Option<Slot> {
    let active = ACTIVE.lock().ok()?;
    if active.is_empty() {
        return None;
    }
    let abs = files.clone().map(|f| std::path::absolute(f).ok());
    let [Some(png), Some(svg)] = abs else {
        return None;
    };
    let a = active.iter().find(|a| png.starts_with(&a.abs))?;
    let rel = |p: &Path| Some(p.strip_prefix(&a.abs).ok()?.to_str()?.to_string());
    let files = [rel(&png)?, rel(&svg)?];
    let id = files[0].strip_suffix(".png")?.to_string();
    Some(Slot {
        active: a.clone(),
        id,
        files,
    })
}

impl Slot {
    /// True when the sidecar has this key for the figure and its files hold the recorded
    /// bytes; the figure is then recorded as kept.
    pub(super) fn fresh(&self, key: &str) -> bool {
        let Some(entry) = self.active.before.get(&self.id) else {
            return false;
        };
        let same_files = entry.files.len() == self.files.len()
            && self.files.iter().all(|f| {
                entry.files.get(f).is_some_and(|want| {
                    std::fs::read(self.active.root.join(f)).is_ok_and(|b| file_digest(&b) == *want)
                })
            });
        if entry.key != key || !same_files {
            return false;
        }
        if let Ok(mut s) = self.active.state.lock() {
            s.now.insert(self.id.clone(), entry.clone());
            s.kept.extend(self.files.iter().map(PathBuf::from));
        }
        true
    }

    /// Records the files just written (`bytes` in the order PNG, SVG) under `key`.
    pub(super) fn drawn(&self, key: &str, bytes: [&[u8]; 2]) {
        let files = self
            .files
            .iter()
            .zip(bytes)
            .map(|(f, b)| (f.clone(), file_digest(b)))
            .collect();
        if let Ok(mut s) = self.active.state.lock() {
            s.now.insert(
                self.id.clone(),
                Entry {
                    key: key.to_string(),
                    files,
                },
            );
            s.drawn.insert(self.id.clone());
        }
    }
}

/// The hash of a figure file's bytes as the sidecar records it (BLAKE3, hex).
fn file_digest(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

/// Builds the key of a figure: BLAKE3 over length-prefixed strings and numbers as written by
/// the figure, after [`FORMAT`], the tool's version and the drawing code's digest.
pub(super) struct Key {
    hash: blake3::Hasher,
    buf: Vec<u8>,
}

impl Key {
    /// A key of a figure of `size` pixels.
    pub(super) fn new(size: (u32, u32)) -> Self {
        let mut k = Key {
            hash: blake3::Hasher::new(),
            buf: Vec::with_capacity(1 << 16),
        };
        k.u64(u64::from(FORMAT));
        k.str(env!("CARGO_PKG_VERSION"));
        k.buf.extend_from_slice(code_digest());
        k.u64(u64::from(size.0));
        k.u64(u64::from(size.1));
        k
    }

    fn flush_if_full(&mut self) {
        if self.buf.len() >= 1 << 16 {
            self.hash.update(&self.buf);
            self.buf.clear();
        }
    }

    /// Adds a number.
    pub(super) fn u64(&mut self, v: u64) -> &mut Self {
        self.buf.extend_from_slice(&v.to_le_bytes());
        self.flush_if_full();
        self
    }

    /// Adds a float, bit for bit.
    pub(super) fn f64(&mut self, v: f64) -> &mut Self {
        self.u64(v.to_bits())
    }

    /// Adds a string (its length first).
    pub(super) fn str(&mut self, s: &str) -> &mut Self {
        self.u64(s.len() as u64);
        self.buf.extend_from_slice(s.as_bytes());
        self.flush_if_full();
        self
    }

    /// Adds floats (their number first).
    pub(super) fn f64s(&mut self, values: impl ExactSizeIterator<Item = f64>) -> &mut Self {
        self.u64(values.len() as u64);
        for v in values {
            self.f64(v);
        }
        self
    }

    /// The key as hex.
    pub(super) fn finish(mut self) -> String {
        self.hash.update(&self.buf);
        self.hash.finalize().to_hex().to_string()
    }
}
