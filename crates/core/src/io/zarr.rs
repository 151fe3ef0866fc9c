//! A sweep's maps as one Zarr v3 store (`maps.zarr`, `outputs: {zarr_maps: true}`): one array
//! per map name, `[jobs, rows, cols]`, its chunks `[1, rows, cols]` gzip-compressed and
//! gathered in one shard file (`sharding_indexed`, the index at the end), so that a sweep of
//! any number of jobs writes a file per map name rather than a file per map and job; opened
//! lazily by zarr-python and xarray (`dimension_names` `job`, `row_<rows>`, `col_<cols>`, one
//! name per size since the levels' maps differ in size; `row`, `col` where every array has one
//! size; the job ids in the root group's attributes). Each job stages its maps' compressed chunks in one file
//! ([`write_staged`]); the merge packs the staged chunks of every job into the store
//! ([`pack`]), copying the compressed bytes.

use anyhow::{bail, Context, Result};
use num_complex::Complex64;
use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// A map's values.
pub enum Values<'a> {
    /// Real values.
    F64(&'a [f64]),
    /// Complex values.
    C128(&'a [Complex64]),
}

/// One map of one job, compressed as a chunk of its array.
#[derive(Debug, Clone, PartialEq)]
pub struct Chunk {
    /// The map's name (`variance`, `level1_correlation_H`, ...).
    pub name: String,
    /// Zarr's data type: `float64` or `complex128`.
    pub dtype: String,
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// The values, little-endian, gzip-compressed (the codecs `bytes`, `gzip`).
    pub data: Vec<u8>,
}

/// The chunk of map `name` (`rows x cols` values).
pub fn chunk(name: &str, rows: usize, cols: usize, values: Values) -> Chunk {
    let mut gz = flate2::write::GzEncoder::new(vec![], flate2::Compression::fast());
    let dtype = match values {
        Values::F64(v) => {
            for x in v {
                gz.write_all(&x.to_le_bytes()).expect("in memory");
            }
            "float64"
        }
        Values::C128(v) => {
            for z in v {
                gz.write_all(&z.re.to_le_bytes()).expect("in memory");
                gz.write_all(&z.im.to_le_bytes()).expect("in memory");
            }
            "complex128"
        }
    };
    Chunk {
        name: name.to_string(),
        dtype: dtype.into(),
        rows,
        cols,
        data: gz.finish().expect("in memory"),
    }
}

/// The head of a staged file: its format, and each chunk's fields and length.
#[derive(serde::Serialize, serde::Deserialize)]
struct StagedHead {
    format: String,
    chunks: Vec<(String, String, usize, usize, usize)>,
}

/// The format name of a staged file.
const STAGED: &str = "isar-clutter staged zarr chunks 1";

/// Writes one job's `chunks` to `path` (atomically): a JSON head line, then the chunks' bytes.
///
/// # Errors
/// If it cannot be written.
pub fn write_staged(path: &Path, chunks: &[Chunk]) -> Result<()> {
    let head = StagedHead {
        format: STAGED.into(),
        chunks: chunks
            .iter()
            .map(|c| {
                (
                    c.name.clone(),
                    c.dtype.clone(),
                    c.rows,
                    c.cols,
                    c.data.len(),
                )
            })
            .collect(),
    };
    let mut text = serde_json::to_vec(&head)?;
    text.push(b'\n');
    crate::io::atomic::atomic_write(path, |w| {
        w.write_all(&text)?;
        for c in chunks {
            w.write_all(&c.data)?;
        }
        Ok(())
    })
}

/// Reads the chunks [`write_staged`] wrote to `path`.
///
/// # Errors
/// Naming the file: unreadable, not a staged file, or cut short.
pub fn read_staged(path: &Path) -> Result<Vec<Chunk>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let end = bytes
        .iter()
        .position(|&b| b == b'\n')
        .unwrap_or(bytes.len());
    let head: StagedHead = serde_json::from_slice(&bytes[..end])
        .ok()
        .filter(|h: &StagedHead| h.format == STAGED)
        .with_context(|| format!("{} is not a staged chunk file", path.display()))?;
    let mut at = end + 1;
    let mut out = vec![];
    for (name, dtype, rows, cols, len) in head.chunks {
        let data = bytes
            .get(at..at + len)
            .with_context(|| format!("{} is cut short", path.display()))?;
        at += len;
        out.push(Chunk {
            name,
            dtype,
            rows,
            cols,
            data: data.to_vec(),
        });
    }
    Ok(out)
}

/// An array of the store being written: its shard file, each job's chunk in it, and where.
struct Shard {
    /// Its path in the store.
    path: String,
    file: crate::io::atomic::Staged,
    written: u64,
    /// `(offset, bytes)` per job; `u64::MAX` twice for a job without this map.
    index: Vec<(u64, u64)>,
}

/// What [`pack`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Packed {
    /// Arrays written.
    pub arrays: usize,
    /// Jobs whose chunks were packed.
    pub jobs: usize,
    /// Jobs without a staged file (their maps are empty chunks: the fill value).
    pub missing: Vec<String>,
}

/// Packs the staged chunks of `jobs` (id and staged file, in the job dimension's order) into
/// the Zarr v3 store `root`, with `attributes` (and the job ids, `jobs`) on its root group. A
/// map name seen with a second size becomes a second array, `<name>@<rows>x<cols>`.
///
/// # Errors
/// If a staged file cannot be read or the store written.
pub fn pack(
    root: &Path,
    jobs: &[(String, PathBuf)],
    attributes: serde_json::Value,
) -> Result<Packed> {
    let n = jobs.len();
    let mut shards: BTreeMap<(String, String, usize, usize), Shard> = BTreeMap::new();
    let mut taken: BTreeMap<String, usize> = BTreeMap::new();
    let (mut packed, mut missing) = (0, vec![]);
    for (j, (id, staged)) in jobs.iter().enumerate() {
        if !staged.is_file() {
            missing.push(id.clone());
            continue;
        }
        packed += 1;
        for c in read_staged(staged)? {
            let key = (c.name.clone(), c.dtype.clone(), c.rows, c.cols);
            let shard = shards.entry(key).or_insert_with(|| {
                let seen = taken.entry(c.name.clone()).or_insert(0);
                let path = match *seen {
                    0 => c.name.clone(),
                    _ => format!("{}@{}x{}", c.name, c.rows, c.cols),
                };
                *seen += 1;
                Shard {
                    file: crate::io::atomic::Staged::new(&root.join(&path).join("c/0/0/0")),
                    path,
                    written: 0,
                    index: vec![(u64::MAX, u64::MAX); n],
                }
            });
            shard.file.write_all(&c.data)?;
            shard.index[j] = (shard.written, c.data.len() as u64);
            shard.written += c.data.len() as u64;
        }
    }
    let shapes: std::collections::BTreeSet<(usize, usize)> =
        shards.keys().map(|k| (k.2, k.3)).collect();
    let arrays = shards.len();
    for ((_, dtype, rows, cols), mut shard) in shards {
        for (offset, bytes) in &shard.index {
            shard.file.write_all(&offset.to_le_bytes())?;
            shard.file.write_all(&bytes.to_le_bytes())?;
        }
        shard.file.commit()?;
        let dims = if shapes.len() == 1 {
            ["job".to_string(), "row".into(), "col".into()]
        } else {
            [
                "job".to_string(),
                format!("row_{rows}"),
                format!("col_{cols}"),
            ]
        };
        let meta = array_meta([n, rows, cols], &dtype, &dims);
        write_json(&root.join(&shard.path).join("zarr.json"), &meta)?;
    }
    let mut attrs = attributes;
    let ids: Vec<&str> = jobs.iter().map(|(id, _)| id.as_str()).collect();
    attrs["jobs"] = serde_json::json!(ids);
    let group = serde_json::json!({"zarr_format": 3, "node_type": "group", "attributes": attrs});
    write_json(&root.join("zarr.json"), &group)?;
    Ok(Packed {
        arrays,
        jobs: packed,
        missing,
    })
}

/// The `zarr.json` of an array of `shape` and `dtype`: one shard of chunks `[1, rows, cols]`.
fn array_meta(shape: [usize; 3], dtype: &str, dims: &[String; 3]) -> serde_json::Value {
    let fill = if dtype == "complex128" {
        serde_json::json!(["NaN", "NaN"])
    } else {
        serde_json::json!("NaN")
    };
    let little = serde_json::json!({"name": "bytes", "configuration": {"endian": "little"}});
    serde_json::json!({
        "zarr_format": 3,
        "node_type": "array",
        "shape": shape,
        "data_type": dtype,
        "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": shape}},
        "chunk_key_encoding": {"name": "default", "configuration": {"separator": "/"}},
        "fill_value": fill,
        "codecs": [{
            "name": "sharding_indexed",
            "configuration": {
                "chunk_shape": [1, shape[1], shape[2]],
                "codecs": [little, {"name": "gzip", "configuration": {"level": 1}}],
                "index_codecs": [little],
                "index_location": "end"
            }
        }],
        "dimension_names": dims,
        "attributes": {}
    })
}

/// Writes `value` as JSON to `path`, atomically.
fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_vec_pretty(value)?;
    crate::io::atomic::atomic_write(path, |w| Ok(w.write_all(&text)?))
}

/// The chunk of job `j` of the array at `dir` of the store (`rows x cols` values, `float64`),
/// read back through its shard's index: the slow, plain reader the tests check [`pack`] with.
///
/// # Errors
/// If the shard cannot be read or is not what the metadata says.
pub fn read_f64(dir: &Path, j: usize) -> Result<Option<Vec<f64>>> {
    let meta: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("zarr.json"))?)?;
    let n = meta["shape"][0].as_u64().context("shape")? as usize;
    let shard = std::fs::read(dir.join("c/0/0/0"))?;
    let index = shard
        .len()
        .checked_sub(16 * n)
        .context("shard shorter than its index")?;
    let entry = |k: usize| {
        let at = index + 16 * j + 8 * k;
        u64::from_le_bytes(shard[at..at + 8].try_into().expect("8 bytes"))
    };
    let (offset, bytes) = (entry(0), entry(1));
    if offset == u64::MAX {
        return Ok(None);
    }
    let mut raw = vec![];
    flate2::read::GzDecoder::new(&shard[offset as usize..(offset + bytes) as usize])
        .read_to_end(&mut raw)?;
    if raw.len() % 8 != 0 {
        bail!("a chunk of {} bytes", raw.len());
    }
    Ok(Some(
        raw.chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
            .collect(),
    ))
}

/// The job ids of the store at `root` (its root group's `jobs`, in the job dimension's
/// order); empty where there is no store.
///
/// # Errors
/// If the root's `zarr.json` exists but cannot be read as the store's.
pub fn jobs(root: &Path) -> Result<Vec<String>> {
    let meta = root.join("zarr.json");
    if !meta.is_file() {
        return Ok(vec![]);
    }
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&meta)?)
        .with_context(|| format!("{}", meta.display()))?;
    let ids = v["attributes"]["jobs"]
        .as_array()
        .with_context(|| format!("{}: no attributes.jobs", meta.display()))?;
    ids.iter()
        .map(|i| {
            i.as_str()
                .map(str::to_string)
                .with_context(|| format!("{}: a job id that is not text", meta.display()))
        })
        .collect()
}

/// One job's map read back from the store.
#[derive(Debug, Clone, PartialEq)]
pub struct JobMap {
    /// The map's name (an array's name without a second size's `@RxC`).
    pub name: String,
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Its values: real (`float64`) ...
    pub real: Option<Vec<f64>>,
    /// ... or complex (`complex128`).
    pub complex: Option<Vec<Complex64>>,
}

/// Every map of job `job` in the store at `root` (reading each array's shard index and the
/// job's chunk only), in the order of the arrays' names; `None` if the store does not list the
/// job.
///
/// # Errors
/// If the store cannot be read or a chunk is not what its array's metadata says.
pub fn read_job(root: &Path, job: &str) -> Result<Option<Vec<JobMap>>> {
    use std::io::{Seek, SeekFrom};
    let ids = jobs(root)?;
    let Some(j) = ids.iter().position(|i| i == job) else {
        return Ok(None);
    };
    let n = ids.len() as u64;
    let mut names: Vec<String> = std::fs::read_dir(root)?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("zarr.json").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut out = vec![];
    for name in names {
        let dir = root.join(&name);
        let meta: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("zarr.json"))?)?;
        let (rows, cols) = (
            meta["shape"][1].as_u64().context("shape")? as usize,
            meta["shape"][2].as_u64().context("shape")? as usize,
        );
        let dtype = meta["data_type"].as_str().context("data_type")?.to_string();
        let shard_path = dir.join("c/0/0/0");
        let mut shard = std::fs::File::open(&shard_path)
            .with_context(|| format!("{}", shard_path.display()))?;
        let len = shard.metadata()?.len();
        let at = len
            .checked_sub(16 * (n - j as u64))
            .with_context(|| format!("{}: shorter than its index", shard_path.display()))?;
        let mut entry = [0u8; 16];
        shard.seek(SeekFrom::Start(at))?;
        shard.read_exact(&mut entry)?;
        let offset = u64::from_le_bytes(entry[..8].try_into().expect("8 bytes"));
        let bytes = u64::from_le_bytes(entry[8..].try_into().expect("8 bytes"));
        if offset == u64::MAX {
            continue;
        }
        let mut packed = vec![0u8; usize::try_from(bytes)?];
        shard.seek(SeekFrom::Start(offset))?;
        shard.read_exact(&mut packed)?;
        let mut raw = vec![];
        flate2::read::GzDecoder::new(&packed[..]).read_to_end(&mut raw)?;
        let width = if dtype == "complex128" { 16 } else { 8 };
        if raw.len() != rows * cols * width {
            bail!(
                "{}: job {job}'s chunk holds {} bytes, not {rows} x {cols} {dtype}",
                shard_path.display(),
                raw.len()
            );
        }
        let f = |b: &[u8]| f64::from_le_bytes(b.try_into().expect("8 bytes"));
        let values: Vec<f64> = raw.chunks_exact(8).map(f).collect();
        let base = name.split('@').next().unwrap_or(&name).to_string();
        out.push(JobMap {
            name: base,
            rows,
            cols,
            complex: (width == 16).then(|| {
                values
                    .chunks_exact(2)
                    .map(|p| Complex64::new(p[0], p[1]))
                    .collect()
            }),
            real: (width == 8).then_some(values),
        });
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staged_chunks_pack_into_shards_each_job_at_its_index() {
        let dir = tempfile::tempdir().unwrap();
        let a: Vec<f64> = (0..6).map(|i| i as f64 * 0.5).collect();
        let b: Vec<f64> = (0..6).map(|i| -(i as f64)).collect();
        let wide: Vec<f64> = (0..8).map(f64::from).collect();
        let jobs: Vec<(String, PathBuf)> = ["a", "gone", "b"]
            .iter()
            .map(|id| (id.to_string(), dir.path().join(format!("{id}.chunks"))))
            .collect();
        write_staged(&jobs[0].1, &[chunk("variance", 2, 3, Values::F64(&a))]).unwrap();
        let both = [
            chunk("variance", 2, 3, Values::F64(&b)),
            chunk("variance", 2, 4, Values::F64(&wide)),
        ];
        write_staged(&jobs[2].1, &both).unwrap();
        assert_eq!(read_staged(&jobs[2].1).unwrap(), both);
        let root = dir.path().join("maps.zarr");
        let p = pack(&root, &jobs, serde_json::json!({"tool": "test"})).unwrap();
        assert_eq!(
            (p.arrays, p.jobs, p.missing),
            (2, 2, vec!["gone".to_string()])
        );
        let v = root.join("variance");
        assert_eq!(read_f64(&v, 0).unwrap(), Some(a));
        assert_eq!(read_f64(&v, 1).unwrap(), None);
        assert_eq!(read_f64(&v, 2).unwrap(), Some(b));
        assert_eq!(read_f64(&root.join("variance@2x4"), 2).unwrap(), Some(wide));
        let group: serde_json::Value =
            serde_json::from_slice(&std::fs::read(root.join("zarr.json")).unwrap()).unwrap();
        assert_eq!(
            group["attributes"]["jobs"],
            serde_json::json!(["a", "gone", "b"])
        );
    }

    /// One job's maps read back through the shards' indexes are the staged values: real and
    /// complex, both sizes of a name (the second's `@RxC` dropped); a job with no chunks has
    /// none, a job the store does not list is `None`, and no store lists no jobs.
    #[test]
    fn a_jobs_maps_are_read_back_by_its_id() {
        let dir = tempfile::tempdir().unwrap();
        let a: Vec<f64> = (0..6).map(|i| i as f64 * 0.25).collect();
        let wide: Vec<f64> = (0..8).map(|i| -f64::from(i)).collect();
        let mean: Vec<Complex64> = (0..6).map(|i| Complex64::new(i as f64, -1.5)).collect();
        let jobs: Vec<(String, PathBuf)> = ["x", "y"]
            .iter()
            .map(|id| (id.to_string(), dir.path().join(format!("{id}.chunks"))))
            .collect();
        write_staged(&jobs[0].1, &[chunk("variance", 2, 3, Values::F64(&a))]).unwrap();
        let y = [
            chunk("mean", 2, 3, Values::C128(&mean)),
            chunk("variance", 2, 3, Values::F64(&a)),
            chunk("variance", 2, 4, Values::F64(&wide)),
        ];
        write_staged(&jobs[1].1, &y).unwrap();
        let root = dir.path().join("maps.zarr");
        pack(&root, &jobs, serde_json::json!({})).unwrap();
        assert_eq!(super::jobs(&root).unwrap(), ["x", "y"]);
        let got = read_job(&root, "y").unwrap().unwrap();
        let names: Vec<(&str, usize, usize)> = got
            .iter()
            .map(|m| (m.name.as_str(), m.rows, m.cols))
            .collect();
        assert_eq!(
            names,
            [("mean", 2, 3), ("variance", 2, 3), ("variance", 2, 4)]
        );
        assert_eq!(got[0].complex.as_deref(), Some(&mean[..]));
        assert_eq!(got[1].real.as_deref(), Some(&a[..]));
        assert_eq!(got[2].real.as_deref(), Some(&wide[..]));
        let x = read_job(&root, "x").unwrap().unwrap();
        assert_eq!(x.len(), 1);
        assert_eq!(x[0].real, read_f64(&root.join("variance"), 0).unwrap());
        assert_eq!(read_job(&root, "z").unwrap(), None);
        assert!(super::jobs(&dir.path().join("none")).unwrap().is_empty());
    }
}
