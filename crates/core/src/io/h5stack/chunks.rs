//! Chunked, compressed HDF5 stacks read on every core: libhdf5 inflates a dataset's chunks one
//! after the other on one thread (a 1 GiB gzip'd stack took 5.4-5.9 s, as long as h5py), so
//! where a stack's chunks are plain enough, each chunk's place is found once through libhdf5
//! (`H5Dget_chunk_info_by_coord`), and the chunks read (`pread`), inflated and unshuffled by
//! rayon, each straight into its place in the stack (memory: the stack and two chunks a
//! thread; a mapping of the file would count its pages in the process as well).
//!
//! Plain enough: chunked, `[N, H, W]` (or float pairs `[N, H, W, 2]` with the pair in each
//! chunk), elements byte for byte complex64 or complex128 ([`super::read`]'s native types),
//! filters only deflate and shuffle, every chunk allocated. Any other stack is read by libhdf5
//! ([`super::read`]); so is any chunk whose bytes do not inflate to its size (an error naming
//! it).

use crate::io::npy::Dtype;
use hdf5_metno::filters::Filter;
use rayon::prelude::*;
use std::io::Read;
use std::os::unix::fs::FileExt;
use std::path::Path;

/// A filter of the pipeline, in the order the writer applied it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    /// zlib stream.
    Deflate,
    /// Byte shuffle of elements of this many bytes.
    Shuffle(usize),
}

/// Where a stack's chunks are and how to undo their filters.
pub(super) struct ChunkPlan {
    /// The stored dimensions `[N, H, W]` (without a pairs' 2).
    dims: [usize; 3],
    /// The chunk's extent in those dimensions.
    chunk: [usize; 3],
    /// Bytes of one element (a complex value).
    elem: usize,
    /// The filters, in the writer's order.
    steps: Vec<Step>,
    /// Per chunk (in row-major order of chunk coordinates): file offset, stored bytes and the
    /// filter mask (a bit set: that filter skipped).
    places: Vec<(u64, u64, u32)>,
}

/// The plan for `ds` if it is plain enough (see the module), else `None`.
pub(super) fn plan(ds: &hdf5_metno::Dataset, dtype: Dtype, pairs: bool) -> Option<ChunkPlan> {
    let elem = match dtype {
        Dtype::Complex64 => 8,
        Dtype::Complex128 => 16,
        _ => return None,
    };
    let chunk = ds.chunk()?;
    let shape = ds.shape();
    if pairs && (chunk.len() != 4 || chunk[3] != 2) || !pairs && chunk.len() != 3 {
        return None;
    }
    let dims = [shape[0], shape[1], shape[2]];
    let chunk = [chunk[0], chunk[1], chunk[2]];
    let steps = steps_of(ds, if pairs { elem / 2 } else { elem })?;
    let grid: Vec<usize> = (0..3).map(|d| dims[d].div_ceil(chunk[d].max(1))).collect();
    let count = grid.iter().product::<usize>();
    let base = user_block(ds)?;
    let places = hdf5_metno::sync::sync(|| {
        let mut places = Vec::with_capacity(count);
        for a in 0..grid[0] {
            for b in 0..grid[1] {
                for c in 0..grid[2] {
                    let mut at = vec![(a * chunk[0]) as u64, (b * chunk[1]) as u64];
                    at.push((c * chunk[2]) as u64);
                    if pairs {
                        at.push(0);
                    }
                    places.push(chunk_place(ds, &at, base)?);
                }
            }
        }
        Some(places)
    })?;
    Some(ChunkPlan {
        dims,
        chunk,
        elem,
        steps,
        places,
    })
}

/// The filters of `ds` (elements of `type_size` bytes) if they are only deflate and shuffle.
fn steps_of(ds: &hdf5_metno::Dataset, type_size: usize) -> Option<Vec<Step>> {
    ds.filters()
        .into_iter()
        .map(|f| match f {
            Filter::Deflate(_) => Some(Step::Deflate),
            Filter::Shuffle => Some(Step::Shuffle(type_size)),
            _ => None,
        })
        .collect()
}

/// Where the chunk at `at` (its first element's coordinates) of `ds` lies in the file: its
/// offset from the file's start (libhdf5's address, which counts from the end of a user
/// block, plus `base`, the user block's size), stored bytes and filter mask; `None` if
/// libhdf5 says none (not allocated).
fn chunk_place(ds: &hdf5_metno::Dataset, at: &[u64], base: u64) -> Option<(u64, u64, u32)> {
    let (mut mask, mut addr, mut size) = (0u32, 0u64, 0u64);
    // SAFETY: `ds` is an open dataset of `at.len()` dimensions (the callers pass its rank);
    // the outputs are valid for writes; the callers hold hdf5-metno's lock.
    let status = unsafe {
        hdf5_metno_sys::h5d::H5Dget_chunk_info_by_coord(
            ds.id(),
            at.as_ptr(),
            &mut mask,
            &mut addr,
            &mut size,
        )
    };
    if status < 0 || addr == hdf5_metno_sys::h5::HADDR_UNDEF || size == 0 {
        return None;
    }
    Some((addr.checked_add(base)?, size, mask))
}

/// The size of the user block before the HDF5 data of `ds`'s file (h5py's `userblock_size`),
/// which libhdf5's chunk addresses do not count.
fn user_block(ds: &hdf5_metno::Dataset) -> Option<u64> {
    ds.file().ok().map(|f| f.userblock())
}

/// Reads the window `win` of the single scene `ds` (`[H, W]`, chunked, elements byte for byte
/// complex64) of the file `path` into `out` (row after row): the chunks under the window read
/// and inflated on every core, a band of chunk rows per task; `None` where the scene is not
/// plain enough (other filters, a chunk not allocated), for libhdf5 to read instead.
pub(super) fn read_scene_window(
    ds: &hdf5_metno::Dataset,
    path: &Path,
    win: &crate::io::cut::Window,
    out: &mut [num_complex::Complex32],
) -> Option<Result<(), String>> {
    let chunk = ds.chunk()?;
    let [ch, cw] = chunk[..] else { return None };
    let steps = steps_of(ds, 8)?;
    let (ch, cw) = (ch.max(1), cw.max(1));
    let bands: Vec<usize> = (win.r0 / ch..win.r1.div_ceil(ch)).collect();
    let cols: Vec<usize> = (win.c0 / cw..win.c1.div_ceil(cw)).collect();
    let base = user_block(ds)?;
    let places: Vec<Vec<(u64, u64, u32)>> = hdf5_metno::sync::sync(|| {
        bands
            .iter()
            .map(|&b| {
                cols.iter()
                    .map(|&c| chunk_place(ds, &[(b * ch) as u64, (c * cw) as u64], base))
                    .collect::<Option<Vec<_>>>()
            })
            .collect::<Option<Vec<_>>>()
    })?;
    let file = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) => return Some(Err(format!("{}: {e}", path.display()))),
    };
    let width = win.cols();
    // The window's rows cut at the chunk rows' edges: one slab of `out` a band.
    let mut slabs = Vec::with_capacity(bands.len());
    let mut rest: &mut [u8] = bytemuck::cast_slice_mut(out);
    for &b in &bands {
        let rows = ((b + 1) * ch).min(win.r1) - (b * ch).max(win.r0);
        let (slab, tail) = rest.split_at_mut(rows * width * 8);
        slabs.push(slab);
        rest = tail;
    }
    let chunk_bytes = ch * cw * 8;
    let result = slabs
        .into_par_iter()
        .zip(&bands)
        .zip(&places)
        .try_for_each_init(
            || (vec![0u8; chunk_bytes], vec![0u8; chunk_bytes], Vec::new()),
            |(raw, tmp, stored), ((slab, &b), band)| {
                let r_first = (b * ch).max(win.r0);
                let rows = slab.len() / (width * 8);
                for (&c, &(addr, size, mask)) in cols.iter().zip(band) {
                    let at = [b * ch, c * cw];
                    stored.resize(usize::try_from(size).map_err(|e| e.to_string())?, 0);
                    file.read_exact_at(stored, addr).map_err(|e| {
                        format!(
                            "{}: chunk {at:?} ({size} bytes at {addr}): {e} (truncated?)",
                            path.display()
                        )
                    })?;
                    unfilter(&steps, stored, mask, raw, tmp)
                        .map_err(|e| format!("{}: chunk {at:?}: {e}", path.display()))?;
                    let (c_first, c_end) = ((c * cw).max(win.c0), ((c + 1) * cw).min(win.c1));
                    let n = (c_end - c_first) * 8;
                    for i in 0..rows {
                        let from = ((r_first + i - b * ch) * cw + (c_first - c * cw)) * 8;
                        let to = (i * width + (c_first - win.c0)) * 8;
                        slab[to..to + n].copy_from_slice(&raw[from..from + n]);
                    }
                }
                Ok(())
            },
        );
    Some(result)
}

impl ChunkPlan {
    /// Reads every chunk of the file `path` into `out` (`N x H x W` elements of `elem` bytes),
    /// a slab of chunks along `N` per rayon task.
    pub(super) fn read(&self, path: &Path, out: &mut [u8]) -> Result<(), String> {
        let [n, h, w] = self.dims;
        let [cn, ch, cw] = self.chunk;
        assert_eq!(out.len(), n * h * w * self.elem, "the stack's bytes");
        let file = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let per_slab = h.div_ceil(ch) * w.div_ceil(cw);
        let chunk_bytes = cn * ch * cw * self.elem;
        out.par_chunks_mut(cn * h * w * self.elem)
            .enumerate()
            .try_for_each_init(
                || (vec![0u8; chunk_bytes], vec![0u8; chunk_bytes], Vec::new()),
                |(raw, tmp, stored), (a, slab)| {
                    let rows = slab.len() / (h * w * self.elem);
                    for (k, &(addr, size, mask)) in self.places[a * per_slab..(a + 1) * per_slab]
                        .iter()
                        .enumerate()
                    {
                        let (b, c) = (k / w.div_ceil(cw), k % w.div_ceil(cw));
                        let size = usize::try_from(size).map_err(|e| e.to_string())?;
                        stored.resize(size, 0);
                        file.read_exact_at(stored, addr).map_err(|e| {
                            format!(
                                "{}: chunk {:?} ({size} bytes at {addr}): {e} (truncated?)",
                                path.display(),
                                [a * cn, b * ch, c * cw]
                            )
                        })?;
                        unfilter(&self.steps, stored, mask, raw, tmp).map_err(|e| {
                            format!(
                                "{}: chunk {:?}: {e}",
                                path.display(),
                                [a * cn, b * ch, c * cw]
                            )
                        })?;
                        // Copy the chunk's part inside the stack, row by row.
                        let (r0, c0) = (b * ch, c * cw);
                        let (nr, nc) = (ch.min(h - r0), cw.min(w - c0));
                        for i in 0..rows {
                            for r in 0..nr {
                                let from = ((i * ch + r) * cw) * self.elem;
                                let to = ((i * h + r0 + r) * w + c0) * self.elem;
                                slab[to..to + nc * self.elem]
                                    .copy_from_slice(&raw[from..from + nc * self.elem]);
                            }
                        }
                    }
                    Ok(())
                },
            )
    }
}

/// Undoes the filters `steps` of one chunk's `stored` bytes into `raw` (its full size; `tmp`
/// of the same size for the steps between).
fn unfilter(
    steps: &[Step],
    stored: &[u8],
    mask: u32,
    raw: &mut Vec<u8>,
    tmp: &mut Vec<u8>,
) -> Result<(), String> {
    let want = raw.len();
    let mut bufs = [std::mem::take(raw), std::mem::take(tmp)];
    // Where the chunk's bytes are now: `None` the file, else `bufs[i]`.
    let mut cur: Option<usize> = None;
    let mut result = Ok(());
    for (i, step) in steps.iter().enumerate().rev() {
        if mask & (1 << i) != 0 {
            continue;
        }
        let (a, b) = bufs.split_at_mut(1);
        let (src, dst, to): (&[u8], &mut Vec<u8>, usize) = match cur {
            None => (stored, &mut a[0], 0),
            Some(0) => (&a[0][..], &mut b[0], 1),
            Some(_) => (&b[0][..], &mut a[0], 0),
        };
        result = apply(*step, src, &mut dst[..want]);
        if result.is_err() {
            break;
        }
        cur = Some(to);
    }
    match cur {
        None if result.is_ok() => {
            if stored.len() == want {
                bufs[0].copy_from_slice(stored);
            } else {
                result = Err(format!("{} bytes stored, {want} expected", stored.len()));
            }
        }
        Some(1) => bufs.swap(0, 1),
        _ => {}
    }
    let [r, t] = bufs;
    *raw = r;
    *tmp = t;
    result
}

/// Undoes one filter step: `src` into `dst` (the unfiltered size).
fn apply(step: Step, src: &[u8], dst: &mut [u8]) -> Result<(), String> {
    let want = dst.len();
    match step {
        Step::Deflate => {
            let mut z = flate2::read::ZlibDecoder::new(src);
            z.read_exact(dst)
                .map_err(|e| format!("does not inflate to {want} bytes: {e}"))?;
        }
        Step::Shuffle(size) => {
            if src.len() != want {
                return Err(format!("{} bytes to unshuffle, not {want}", src.len()));
            }
            // HDF5's shuffle: byte `j` of every element, element after element, for each `j`
            // in turn; the bytes after the last whole element as they are.
            let count = want / size.max(1);
            for (byte, plane) in src[..count * size].chunks_exact(count).enumerate() {
                for (e, &v) in plane.iter().enumerate() {
                    dst[e * size + byte] = v;
                }
            }
            dst[count * size..].copy_from_slice(&src[count * size..]);
        }
    }
    Ok(())
}
