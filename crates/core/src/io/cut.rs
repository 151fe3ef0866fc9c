//! Clutter stacks cut from scenes (`isar-clutter cut`): a scene `[H, W]`, or a time stack of
//! coregistered scenes `[T, H, W]`, in an `.npy` file, cut into square or rectangular patches
//! `[N, h, w]` that `fit` and `run` read as a stack of clutter samples. Patches are placed on a
//! grid of `stride` inside a window of the scene, and a patch that overlaps any box to avoid
//! (targets, buildings) is left out. With `T` scenes every place gives `T` samples, in the
//! order place by place, scene by scene within a place (sample `p T + t` is scene `t` at place
//! `p`). The input is mapped, not read into memory (the rows behind the patches being cut are
//! dropped from the mapping as it goes), and the patches are streamed into the output two
//! blocks at a time ([`crate::io::stream`]), so memory stays at a few blocks and a band of
//! rows whatever the scene's size; the places are written beside the stack
//! (`OUT.patches.json`).

use crate::io::npy::{read_header, Dtype};
use anyhow::{bail, Context, Result};
use num_complex::{Complex, Complex32};
use std::path::{Path, PathBuf};

/// A rectangle of pixels, rows `r0..r1` and columns `c0..c1` (half-open, from 0): a cut's
/// window and boxes to avoid, and the window of a UAVSAR stack ([`super::uavsar`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Window {
    /// First row.
    pub r0: usize,
    /// Row past the last.
    pub r1: usize,
    /// First column.
    pub c0: usize,
    /// Column past the last.
    pub c1: usize,
}

impl std::str::FromStr for Window {
    type Err = String;

    /// `r0:r1,c0:c1` (`100:600,0:512`).
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("{s:?} is not a window r0:r1,c0:c1 (pixels, from 0, end excluded)");
        let (rows, cols) = s.split_once(',').ok_or_else(bad)?;
        let range = |t: &str| -> Result<(usize, usize), String> {
            let (a, b) = t.split_once(':').ok_or_else(bad)?;
            let (a, b) = (
                a.trim().parse().map_err(|_| bad())?,
                b.trim().parse().map_err(|_| bad())?,
            );
            if a >= b {
                return Err(format!("{s:?}: a range's start must be below its end"));
            }
            Ok((a, b))
        };
        let ((r0, r1), (c0, c1)) = (range(rows)?, range(cols)?);
        Ok(Window { r0, r1, c0, c1 })
    }
}

impl Window {
    /// The whole of a scene of `h x w` pixels.
    pub fn whole(h: usize, w: usize) -> Window {
        Window {
            r0: 0,
            r1: h,
            c0: 0,
            c1: w,
        }
    }

    /// The `rows x cols` pixels from `(row, col)` (an end past `usize::MAX` saturates, so that
    /// [`Window::inside`] refuses it).
    pub fn at(row: usize, col: usize, rows: usize, cols: usize) -> Window {
        Window {
            r0: row,
            r1: row.saturating_add(rows),
            c0: col,
            c1: col.saturating_add(cols),
        }
    }

    /// Rows.
    pub fn rows(&self) -> usize {
        self.r1 - self.r0
    }

    /// Columns.
    pub fn cols(&self) -> usize {
        self.c1 - self.c0
    }

    /// Whether the window lies inside a scene of `h x w` pixels.
    pub fn inside(&self, h: usize, w: usize) -> bool {
        self.r1 <= h && self.c1 <= w
    }

    fn overlaps(&self, other: &Window) -> bool {
        self.r0 < other.r1 && other.r0 < self.r1 && self.c0 < other.c1 && other.c0 < self.c1
    }
}

/// A patch size or stride: `64` (square) or `64x32` (rows x columns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Size2 {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
}

impl std::str::FromStr for Size2 {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("{s:?} is not a size: N or ROWSxCOLS, at least 1 (e.g. 64, 64x32)");
        let (r, c) = s.split_once(['x', 'X']).unwrap_or((s, s));
        let (rows, cols): (usize, usize) = (
            r.trim().parse().map_err(|_| bad())?,
            c.trim().parse().map_err(|_| bad())?,
        );
        if rows == 0 || cols == 0 {
            return Err(bad());
        }
        Ok(Size2 { rows, cols })
    }
}

/// How a scene is cut.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CutOptions {
    /// Patch size.
    pub patch: Size2,
    /// Step between patches (default: the patch size, patches that touch).
    pub stride: Size2,
    /// Where patches may lie (default: the whole scene).
    pub window: Option<Window>,
    /// Boxes no patch may overlap.
    pub avoid: Vec<Window>,
    /// A region patches must lie wholly inside (pixel coordinates), besides the window.
    pub polygon: Option<super::polygon::Polygon>,
    /// A mask of the scene (`.npy`, `[H, W]`, `bool` or `uint8`): no patch may cover a
    /// non-zero pixel.
    pub avoid_mask: Option<PathBuf>,
}

/// `places` less those whose `patch` covers a non-zero pixel of the mask file `path` (an
/// `[h, w]` `bool` or `uint8` `.npy`, mapped, not read).
///
/// # Errors
/// Naming the mask: unreadable, of another type, order or shape.
pub fn unmasked(
    places: Vec<(usize, usize)>,
    patch: Size2,
    (h, w): (usize, usize),
    path: &Path,
) -> Result<Vec<(usize, usize)>> {
    let header = crate::io::npy::read_raw_header(path)
        .with_context(|| format!("reading the mask {}", path.display()))?;
    if !matches!(header.descr.as_str(), "|b1" | "|u1") || header.fortran_order {
        bail!(
            "the mask {} holds {} ({} order); a mask is bool or uint8 in C order",
            path.display(),
            header.descr,
            if header.fortran_order { "Fortran" } else { "C" }
        );
    }
    if header.shape != [h, w] {
        bail!(
            "the mask {} has shape {:?}; the scene's is [{h}, {w}]",
            path.display(),
            header.shape
        );
    }
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    // SAFETY: read-only and private; the mask must not change while it is read.
    let map = unsafe { memmap2::Mmap::map(&file) }
        .with_context(|| format!("mapping {}", path.display()))?;
    let mask = map
        .get(header.data_offset..header.data_offset + h * w)
        .with_context(|| format!("the mask {} is truncated", path.display()))?;
    Ok(places
        .into_iter()
        .filter(|&(r, c)| {
            (r..r + patch.rows).all(|i| mask[i * w + c..][..patch.cols].iter().all(|&b| b == 0))
        })
        .collect())
}

/// The places (top-left row and column) of the patches of a scene of `h x w` pixels.
///
/// # Errors
/// When the window leaves the scene or holds no patch, naming the sizes.
pub fn places(h: usize, w: usize, o: &CutOptions) -> Result<Vec<(usize, usize)>> {
    let win = o.window.unwrap_or(Window::whole(h, w));
    if !win.inside(h, w) {
        bail!(
            "--window {}:{},{}:{} leaves the {h}x{w} scene",
            win.r0,
            win.r1,
            win.c0,
            win.c1
        );
    }
    let (p, s) = (o.patch, o.stride);
    let (p_rows, p_cols) = (p.rows as f64, p.cols as f64);
    let mut out = vec![];
    let mut r = win.r0;
    while r + p.rows <= win.r1 {
        let mut c = win.c0;
        while c + p.cols <= win.c1 {
            let patch = Window {
                r0: r,
                r1: r + p.rows,
                c0: c,
                c1: c + p.cols,
            };
            let held = o.polygon.as_ref().is_none_or(|poly| {
                let (r, c) = (r as f64, c as f64);
                poly.holds((r, r + p_rows), (c, c + p_cols))
            });
            if held && !o.avoid.iter().any(|a| a.overlaps(&patch)) {
                out.push((r, c));
            }
            c += s.cols;
        }
        r += s.rows;
    }
    if out.is_empty() {
        bail!(
            "no {}x{} patch fits in the window {}:{},{}:{} of the {h}x{w} scene outside the boxes \
             to avoid (and inside the polygon)",
            p.rows,
            p.cols,
            win.r0,
            win.r1,
            win.c0,
            win.c1
        );
    }
    Ok(out)
}

/// [`places`] in a scene of `(h, w)` pixels, less those whose patch covers a pixel of the
/// options' mask ([`unmasked`]); `input` names the scene in messages.
///
/// # Errors
/// When the window leaves the scene, no patch fits, or the mask is unreadable, of another
/// shape, or covers every place.
pub fn masked_places(
    (h, w): (usize, usize),
    o: &CutOptions,
    input: &Path,
) -> Result<Vec<(usize, usize)>> {
    let mut places = places(h, w, o).with_context(|| format!("cutting {}", input.display()))?;
    if let Some(mask) = &o.avoid_mask {
        places = unmasked(places, o.patch, (h, w), mask)?;
        if places.is_empty() {
            bail!(
                "cutting {}: every patch covers a pixel of the mask {}",
                input.display(),
                mask.display()
            );
        }
    }
    Ok(places)
}

/// Refuses a stack of `samples` complex64 patches of `patch` that would not fit on the disk
/// of `out`.
///
/// # Errors
/// Saying how much is needed and what to do.
pub fn check_room(out: &Path, samples: usize, patch: Size2) -> Result<()> {
    let bytes = crate::resources::saturating_bytes(&[samples, patch.rows, patch.cols, 8]);
    if let Some(why) =
        crate::resources::disk_shortfall(out, bytes, &format!("the {samples} patches"))
    {
        bail!("{why}: cut fewer patches (--stride, --window) or choose another --out");
    }
    Ok(())
}

/// What [`cut_npy`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Cut {
    /// Scenes in the input (`T`; 1 for a 2-D scene).
    pub scenes: usize,
    /// Places of the patches.
    pub places: usize,
    /// The record of the places written beside the stack ([`record_path`]).
    pub record: PathBuf,
}

impl Cut {
    /// Samples written, `places x scenes`.
    pub fn samples(&self) -> usize {
        self.places * self.scenes
    }
}

/// The record of the places of the stack `out` (`OUT.patches.json`): written by [`cut_npy`],
/// and what tells an earlier stack of `cut`'s from a file it must not replace.
pub fn record_path(out: &Path) -> PathBuf {
    PathBuf::from(format!("{}.patches.json", out.display()))
}

/// The record of a cut (`OUT.patches.json`).
#[derive(serde::Serialize)]
struct Record<'a> {
    input: String,
    /// The quantity the values were calibrated to (absent: as stored).
    #[serde(skip_serializing_if = "Option::is_none")]
    calibrated_to: Option<&'a str>,
    scene_shape: &'a [usize],
    options: &'a CutOptions,
    order: &'static str,
    places: &'a [(usize, usize)],
}

/// Cuts the `.npy` scene (or time stack) `input` into the complex64 stack `out`, `chunk`
/// samples a block, with `progress` hearing the samples written so far. Real scenes become
/// complex with a zero imaginary part; complex128 is rounded to complex64, the element type of
/// the tool's stacks.
///
/// # Errors
/// Naming the input: not an `.npy` of 2 or 3 dimensions, stored in column-major order, or
/// truncated; no patch fits; the output does not fit on its disk or cannot be written.
pub fn cut_npy(
    input: &Path,
    out: &Path,
    o: &CutOptions,
    chunk: usize,
    progress: impl Fn(usize),
) -> Result<Cut> {
    let header = read_header(input).with_context(|| format!("reading {}", input.display()))?;
    let (scenes, h, w) = match header.shape[..] {
        [h, w] => (1, h, w),
        [t, h, w] => (t, h, w),
        _ => bail!(
            "{}: a scene is [H, W] or a time stack [T, H, W], this array has shape {:?}",
            input.display(),
            header.shape
        ),
    };
    if header.fortran_order && h * w > 1 {
        bail!(
            "{}: stored in column-major (Fortran) order; save it in C order (numpy's default)",
            input.display()
        );
    }
    let places = masked_places((h, w), o, input)?;
    let samples = places.len() * scenes;
    let (ph, pw) = (o.patch.rows, o.patch.cols);
    check_room(out, samples, o.patch)?;
    let file =
        std::fs::File::open(input).with_context(|| format!("opening {}", input.display()))?;
    // SAFETY: read-only and private; undefined only if another process truncates the input
    // while it is cut (inputs must not change meanwhile).
    let map = unsafe { memmap2::Mmap::map(&file) }
        .with_context(|| format!("mapping {}", input.display()))?;
    let size = header.dtype.size();
    let need = [scenes, h, w, size]
        .iter()
        .try_fold(1usize, |a, &b| a.checked_mul(b));
    let data = need
        .and_then(|n| map.get(header.data_offset..header.data_offset.checked_add(n)?))
        .with_context(|| {
            format!(
                "{}: truncated: the header promises {} bytes of data, the file holds {}",
                input.display(),
                need.map_or("more than 2^64".into(), |n| n.to_string()),
                map.len().saturating_sub(header.data_offset)
            )
        })?;
    let cutter = Cutter {
        map: &map,
        data,
        header: &header,
        shape: (scenes, h, w),
        patch: (ph, pw),
        places: &places,
        released: std::sync::Mutex::new(0),
    };
    let fill = |first: usize, dst: &mut [Complex32]| cutter.fill(first, dst);
    write_patches(
        out,
        (samples, Size2 { rows: ph, cols: pw }, chunk),
        fill,
        progress,
        || Ok(()),
    )?;
    let input = (input.display().to_string(), None);
    let record = write_record(out, input, &header.shape, o, &places)?;
    Ok(Cut {
        scenes,
        places: places.len(),
        record,
    })
}

/// Writes `samples` patches of `patch` to the complex64 stack `out` atomically, streamed with
/// direct I/O in blocks of `chunk` samples that `fill` makes (`fill(first, block)`), saying how
/// many are written to `progress`; `after` (run before the file is committed) may still refuse
/// it, as a reader that failed inside `fill` does.
///
/// # Errors
/// If the file cannot be written, or `after` says so.
pub fn write_patches(
    out: &Path,
    (samples, patch, chunk): (usize, Size2, usize),
    fill: impl Fn(usize, &mut [Complex32]) + Sync,
    progress: impl Fn(usize),
    after: impl FnOnce() -> Result<()>,
) -> Result<()> {
    crate::io::atomic::atomic_write_path(out, |tmp| {
        crate::io::stream::write_samples(
            tmp,
            &crate::io::model::npy_header_c64(samples, patch.rows, patch.cols),
            (samples, patch.rows * patch.cols, chunk),
            crate::io::stream::WriteMode::Direct,
            fill,
            progress,
        )?;
        after()
    })
}

/// Writes the record of the cut of `input` (its files, and the quantity their values were
/// calibrated to, if any; of `scene_shape`) into `out` at `places` ([`record_path`]); its
/// path.
///
/// # Errors
/// If it cannot be written.
pub fn write_record(
    out: &Path,
    (input, calibrated_to): (String, Option<&str>),
    scene_shape: &[usize],
    o: &CutOptions,
    places: &[(usize, usize)],
) -> Result<PathBuf> {
    let record = record_path(out);
    let text = serde_json::to_vec_pretty(&Record {
        input,
        calibrated_to,
        scene_shape,
        options: o,
        order: "sample p * scenes + t is scene t at place p (top-left row, column)",
        places,
    })?;
    crate::io::atomic::atomic_write(&record, |w| Ok(std::io::Write::write_all(w, &text)?))?;
    Ok(record)
}

/// The patches of one mapped scene (or time stack), filled in order.
struct Cutter<'a> {
    map: &'a memmap2::Mmap,
    data: &'a [u8],
    header: &'a crate::io::npy::NpyHeader,
    /// `(T, H, W)`.
    shape: (usize, usize, usize),
    /// `(h, w)`.
    patch: (usize, usize),
    places: &'a [(usize, usize)],
    /// Rows of every scene already dropped from the mapping.
    released: std::sync::Mutex<usize>,
}

impl Cutter<'_> {
    /// Element `index` of the data as complex64.
    fn value(&self, index: usize) -> Complex32 {
        let size = self.header.dtype.size();
        let at = &self.data[index * size..][..size];
        match self.header.dtype {
            Dtype::Complex64 => bytemuck::pod_read_unaligned::<Complex32>(at),
            Dtype::Complex128 => {
                let z = bytemuck::pod_read_unaligned::<Complex<f64>>(at);
                Complex32::new(z.re as f32, z.im as f32)
            }
            Dtype::Float32 => Complex32::new(bytemuck::pod_read_unaligned::<f32>(at), 0.0),
            Dtype::Float64 => Complex32::new(bytemuck::pod_read_unaligned::<f64>(at) as f32, 0.0),
        }
    }

    /// Drops the rows above `row` of every scene from the mapping: they are read for the last
    /// time (places are in row-major order), so memory stays at a band of rows, not the whole
    /// scene (a 20,000 x 20,000 scene: 3 GiB).
    fn release_above(&self, row: usize) {
        let (scenes, h, w) = self.shape;
        let row_bytes = w * self.header.dtype.size();
        let Ok(mut done) = self.released.lock() else {
            return;
        };
        if row <= *done {
            return;
        }
        for t in 0..scenes {
            let offset = self.header.data_offset + (t * h + *done) * row_bytes;
            // SAFETY: the map is read-only, so dropping its pages loses nothing: a later read
            // faults them in again from the unchanged file.
            let _ = unsafe {
                self.map.unchecked_advise_range(
                    memmap2::UncheckedAdvice::DontNeed,
                    offset,
                    (row - *done) * row_bytes,
                )
            };
        }
        *done = row;
    }

    /// Fills samples `first ..` (whole patches) into `dst`.
    fn fill(&self, first: usize, dst: &mut [Complex32]) {
        let (scenes, h, w) = self.shape;
        let (ph, pw) = self.patch;
        if let Some(&(row, _)) = self.places.get(first / scenes) {
            self.release_above(row);
        }
        for (k, sample) in dst.chunks_exact_mut(ph * pw).enumerate() {
            let s = first + k;
            let ((r, c), t) = (self.places[s / scenes], s % scenes);
            for (i, out_row) in sample.chunks_exact_mut(pw).enumerate() {
                let start = (t * h + r + i) * w + c;
                for (j, x) in out_row.iter_mut().enumerate() {
                    *x = self.value(start + j);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts(patch: &str, stride: &str, window: Option<&str>, avoid: &[&str]) -> CutOptions {
        CutOptions {
            patch: patch.parse().unwrap(),
            stride: stride.parse().unwrap(),
            window: window.map(|w| w.parse().unwrap()),
            avoid: avoid.iter().map(|a| a.parse().unwrap()).collect(),
            polygon: None,
            avoid_mask: None,
        }
    }

    #[test]
    fn places_step_by_the_stride_inside_the_window_and_around_the_boxes() {
        let p = places(10, 12, &opts("4", "4", None, &[])).unwrap();
        assert_eq!(p, vec![(0, 0), (0, 4), (0, 8), (4, 0), (4, 4), (4, 8)]);
        let p = places(10, 12, &opts("4x6", "2x3", Some("2:10,0:12"), &["4:5,7:8"])).unwrap();
        // Rows 2, 4, 6 (6 + 4 = 10); columns 0, 3, 6; the box (row 4, column 7) removes the
        // patches covering it: (2, 3), (2, 6), (4, 3), (4, 6).
        assert_eq!(p, vec![(2, 0), (4, 0), (6, 0), (6, 3), (6, 6)]);
        assert!(places(10, 12, &opts("11", "1", None, &[]))
            .unwrap_err()
            .to_string()
            .contains("no 11x11 patch fits"));
        assert!(places(10, 12, &opts("2", "1", Some("0:11,0:2"), &[]))
            .unwrap_err()
            .to_string()
            .contains("leaves the 10x12 scene"));
    }

    #[test]
    fn sizes_and_windows_parse_or_are_refused() {
        assert_eq!("64".parse::<Size2>(), Ok(Size2 { rows: 64, cols: 64 }));
        assert_eq!("64x32".parse::<Size2>(), Ok(Size2 { rows: 64, cols: 32 }));
        for bad in ["0", "x", "4x0", "-1", "a"] {
            assert!(bad.parse::<Size2>().is_err(), "{bad}");
        }
        assert_eq!(
            "1:5,2:9".parse::<Window>(),
            Ok(Window {
                r0: 1,
                r1: 5,
                c0: 2,
                c1: 9
            })
        );
        for bad in ["1:5", "5:1,0:2", "a:b,c:d", "1:5;2:9"] {
            assert!(bad.parse::<Window>().is_err(), "{bad}");
        }
    }
}
