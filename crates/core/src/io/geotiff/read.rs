//! A window of a [`GeoTiff`] into complex64 values: the rows of blocks under the window in
//! parallel (each band of output rows is one row of blocks), in each only the blocks the
//! window covers; an uncompressed block read a group of rows at a time (a scene stored as one
//! strip then needs a few MiB, not the strip), a deflated one decoded whole.

use super::ifd::Order;
use super::layout::{Compression, GeoTiff, Num, TiffError};
use crate::io::cut::Window;
use num_complex::Complex32;
use rayon::prelude::*;
use std::io::Read;

/// Bytes of one uncompressed read (rows of a block at a time up to this, at least one).
const READ_BYTES: usize = 4 << 20;

/// Reads `win` of `tiff` into `out` (`win.rows() x win.cols()` values, row after row).
///
/// # Errors
/// [`TiffError::Io`] if the file cannot be read, [`TiffError::Field`] naming the block whose
/// data do not decode or are short.
pub fn read_window(tiff: &GeoTiff, win: &Window, out: &mut [Complex32]) -> Result<(), TiffError> {
    assert_eq!(out.len(), win.rows() * win.cols(), "the window's values");
    assert!(
        win.inside(tiff.rows, tiff.cols),
        "the window inside the image"
    );
    let file = std::fs::File::open(&tiff.path).map_err(|cause| TiffError::Io {
        path: tiff.path.clone(),
        cause,
    })?;
    let bh = tiff.blocks.bh;
    // Split the output at the block rows' boundaries: each band is one row of blocks.
    let mut bands = vec![];
    let mut rest = out;
    let mut r = win.r0;
    while r < win.r1 {
        let end = ((r / bh + 1) * bh).min(win.r1);
        let (band, tail) = rest.split_at_mut((end - r) * win.cols());
        bands.push((r, end, band));
        rest = tail;
        r = end;
    }
    bands
        .into_par_iter()
        .try_for_each(|(r0, r1, band)| read_band(tiff, &file, win, r0..r1, band))
}

/// Rows `rows` (inside one row of blocks) of the window's columns into `band`.
fn read_band(
    tiff: &GeoTiff,
    file: &std::fs::File,
    win: &Window,
    rows: std::ops::Range<usize>,
    band: &mut [Complex32],
) -> Result<(), TiffError> {
    let b = &tiff.blocks;
    let by = rows.start / b.bh;
    let top = by * b.bh;
    let top_row = rows.start;
    for bx in win.c0 / b.bw..=(win.c1 - 1) / b.bw {
        let left = bx * b.bw;
        let (c0, c1) = (win.c0.max(left), win.c1.min(left + b.bw));
        let index = by * b.across + bx;
        match tiff.compression {
            Compression::None => {
                let per_read = (READ_BYTES / (b.bw * part_bytes(tiff))).max(1);
                let mut r = rows.start;
                while r < rows.end {
                    let end = (r + per_read).min(rows.end);
                    let planes = planes(tiff, index, |plane| {
                        uncompressed_rows(tiff, file, plane, r - top..end - top)
                    })?;
                    write_rows(
                        tiff,
                        &planes,
                        (r, end),
                        (r, c0, c1, left),
                        win,
                        (&mut *band, top_row),
                    );
                    r = end;
                }
            }
            Compression::Deflate => {
                let planes = planes(tiff, index, |plane| inflated(tiff, file, plane, by))?;
                let span = (rows.start, rows.end);
                write_rows(
                    tiff,
                    &planes,
                    span,
                    (top, c0, c1, left),
                    win,
                    (&mut *band, top_row),
                );
            }
        }
    }
    Ok(())
}

/// Bytes a pixel takes in one plane (both parts interleaved, or one part in a plane).
fn part_bytes(tiff: &GeoTiff) -> usize {
    tiff.num.size() * if tiff.planar { 1 } else { 2 }
}

/// Rows of a block the image holds (a strip at the bottom may be short; a tile is whole).
fn block_rows(tiff: &GeoTiff, by: usize) -> usize {
    let b = &tiff.blocks;
    if b.tiled {
        b.bh
    } else {
        b.bh.min(tiff.rows - by * b.bh)
    }
}

/// `read(block index)` for block `index` of each plane (one, or the real and imaginary).
fn planes(
    tiff: &GeoTiff,
    index: usize,
    read: impl Fn(usize) -> Result<Vec<u8>, TiffError>,
) -> Result<Vec<Vec<u8>>, TiffError> {
    let per_plane = tiff.blocks.across * tiff.blocks.down;
    let n = if tiff.planar { 2 } else { 1 };
    (0..n).map(|p| read(p * per_plane + index)).collect()
}

/// Rows `rows` (from the block's top) of uncompressed block `k`.
fn uncompressed_rows(
    tiff: &GeoTiff,
    file: &std::fs::File,
    k: usize,
    rows: std::ops::Range<usize>,
) -> Result<Vec<u8>, TiffError> {
    let row_bytes = tiff.blocks.bw * part_bytes(tiff);
    let need = rows.end * row_bytes;
    if (tiff.blocks.counts[k] as usize) < need {
        return Err(short(tiff, k, tiff.blocks.counts[k] as usize, need));
    }
    let at = tiff.blocks.offsets[k] + (rows.start * row_bytes) as u64;
    let mut buf = vec![0u8; rows.len() * row_bytes];
    std::os::unix::fs::FileExt::read_exact_at(file, &mut buf, at).map_err(|cause| {
        TiffError::Io {
            path: tiff.path.clone(),
            cause,
        }
    })?;
    Ok(buf)
}

/// Deflated block `k` (of block row `by`), decoded whole.
fn inflated(
    tiff: &GeoTiff,
    file: &std::fs::File,
    k: usize,
    by: usize,
) -> Result<Vec<u8>, TiffError> {
    let b = &tiff.blocks;
    let need = block_rows(tiff, by) * b.bw * part_bytes(tiff);
    let mut raw = vec![0u8; b.counts[k] as usize];
    std::os::unix::fs::FileExt::read_exact_at(file, &mut raw, b.offsets[k]).map_err(|cause| {
        TiffError::Io {
            path: tiff.path.clone(),
            cause,
        }
    })?;
    let mut data = Vec::with_capacity(need);
    flate2::read::ZlibDecoder::new(&raw[..])
        .take(need as u64)
        .read_to_end(&mut data)
        .map_err(|e| TiffError::Field {
            path: tiff.path.clone(),
            field: format!("block {k}"),
            reason: format!("its deflate stream does not decode: {e}"),
        })?;
    if data.len() < need {
        return Err(short(tiff, k, data.len(), need));
    }
    Ok(data)
}

/// The error of block `k` holding `got` bytes of the `need` its rows take.
fn short(tiff: &GeoTiff, k: usize, got: usize, need: usize) -> TiffError {
    TiffError::Field {
        path: tiff.path.clone(),
        field: format!("block {k}"),
        reason: format!("holds {got} bytes of pixels, its rows need {need}"),
    }
}

/// Copies image rows `rows.0..rows.1` of columns `c0..c1` from `planes` (whose first row is
/// image row `first` and first column `left`) into `band`, whose first row is image row
/// `band_top` (its rows the window's columns).
fn write_rows(
    tiff: &GeoTiff,
    planes: &[Vec<u8>],
    rows: (usize, usize),
    (first, c0, c1, left): (usize, usize, usize, usize),
    win: &Window,
    (band, band_top): (&mut [Complex32], usize),
) {
    let (num, order) = (tiff.num, tiff.order);
    let (size, bw) = (num.size(), tiff.blocks.bw);
    for r in rows.0..rows.1 {
        let dst = &mut band[(r - band_top) * win.cols()..][c0 - win.c0..c1 - win.c0];
        let i = r - first;
        let (j0, j1) = (i * bw + c0 - left, i * bw + c1 - left);
        if tiff.planar {
            let (re, im) = (
                &planes[0][j0 * size..j1 * size],
                &planes[1][j0 * size..j1 * size],
            );
            for ((z, a), b) in dst
                .iter_mut()
                .zip(re.chunks_exact(size))
                .zip(im.chunks_exact(size))
            {
                *z = Complex32::new(num.read(order, a), num.read(order, b));
            }
        } else {
            convert(num, order, &planes[0][j0 * 2 * size..j1 * 2 * size], dst);
        }
    }
}

/// Interleaved parts `src` (real, imaginary, ... of type `num` in `order`) into `dst`: one
/// tight loop per type and order, the parts' sizes known to the compiler (SICD's pixels
/// too).
pub fn convert(num: Num, order: Order, src: &[u8], dst: &mut [Complex32]) {
    macro_rules! run {
        ($t:ty, $n:expr, $from:ident) => {
            for (z, b) in dst.iter_mut().zip(src.chunks_exact(2 * $n)) {
                let re = <$t>::$from(b[..$n].try_into().expect("a part"));
                let im = <$t>::$from(b[$n..].try_into().expect("a part"));
                *z = Complex32::new(re as f32, im as f32);
            }
        };
    }
    match (num, order) {
        (Num::I16, Order::Little) => run!(i16, 2, from_le_bytes),
        (Num::I16, Order::Big) => run!(i16, 2, from_be_bytes),
        (Num::I32, Order::Little) => run!(i32, 4, from_le_bytes),
        (Num::I32, Order::Big) => run!(i32, 4, from_be_bytes),
        (Num::F32, Order::Little) => run!(f32, 4, from_le_bytes),
        (Num::F32, Order::Big) => run!(f32, 4, from_be_bytes),
        (Num::F64, Order::Little) => run!(f64, 8, from_le_bytes),
        (Num::F64, Order::Big) => run!(f64, 8, from_be_bytes),
    }
}

#[cfg(test)]
mod tests {
    use super::super::ifd::Order;
    use super::super::layout::{GeoTiff, Num};
    use super::*;
    use rand::{RngExt, SeedableRng};
    use std::io::Write;

    /// How a test file lays its image out.
    struct Layout {
        num: Num,
        /// `(bw, bh)` tiles, else strips of `bh` rows.
        tiles: Option<(usize, usize)>,
        rows_per_strip: usize,
        deflate: bool,
        planar: bool,
        order: Order,
        big: bool,
        /// One complex sample a pixel (SampleFormat 5/6), else two real samples.
        complex_sample: bool,
    }

    /// The bytes of `x` as part type `num` in `order`.
    fn part(num: Num, order: Order, x: f32) -> Vec<u8> {
        let mut b = match num {
            Num::I16 => (x as i16).to_le_bytes().to_vec(),
            Num::I32 => (x as i32).to_le_bytes().to_vec(),
            Num::F32 => x.to_le_bytes().to_vec(),
            Num::F64 => f64::from(x).to_le_bytes().to_vec(),
        };
        if order == Order::Big {
            b.reverse();
        }
        b
    }

    /// Writes `img` (`rows x cols`, row-major) as a TIFF laid out by `l`: the slow and plain
    /// writer the reader is checked against.
    fn write(path: &std::path::Path, img: &[Complex32], rows: usize, cols: usize, l: &Layout) {
        let (bw, bh) = l.tiles.unwrap_or((cols, l.rows_per_strip));
        let (across, down) = (cols.div_ceil(bw), rows.div_ceil(bh));
        let planes = if l.planar { 2 } else { 1 };
        let mut data = vec![0u8; if l.big { 16 } else { 8 }];
        let (mut offsets, mut counts) = (vec![], vec![]);
        for plane in 0..planes {
            for by in 0..down {
                for bx in 0..across {
                    let held = if l.tiles.is_some() {
                        bh
                    } else {
                        bh.min(rows - by * bh)
                    };
                    let mut block = vec![];
                    for i in 0..held {
                        for j in 0..bw {
                            let (r, c) = (by * bh + i, bx * bw + j);
                            let z = if r < rows && c < cols {
                                img[r * cols + c]
                            } else {
                                Complex32::new(0.0, 0.0)
                            };
                            let parts = if l.planar {
                                vec![[z.re, z.im][plane]]
                            } else {
                                vec![z.re, z.im]
                            };
                            for x in parts {
                                block.extend(part(l.num, l.order, x));
                            }
                        }
                    }
                    if l.deflate {
                        let mut e =
                            flate2::write::ZlibEncoder::new(vec![], flate2::Compression::fast());
                        e.write_all(&block).unwrap();
                        block = e.finish().unwrap();
                    }
                    offsets.push(data.len() as u64);
                    counts.push(block.len() as u64);
                    data.extend(block);
                }
            }
        }
        let spp = if l.complex_sample { 1 } else { 2 };
        let bits = (l.num.size() * 8 * if l.complex_sample { 2 } else { 1 }) as u64;
        let format = match (l.num, l.complex_sample) {
            (Num::I16 | Num::I32, true) => 5,
            (_, true) => 6,
            (Num::I16 | Num::I32, false) => 2,
            (_, false) => 3,
        };
        let long = if l.big { 16 } else { 4 };
        let mut tags: Vec<(u16, u16, Vec<u64>)> = vec![
            (256, 4, vec![cols as u64]),
            (257, 4, vec![rows as u64]),
            (258, 3, vec![bits; spp]),
            (259, 3, vec![if l.deflate { 8 } else { 1 }]),
            (277, 3, vec![spp as u64]),
            (284, 3, vec![if l.planar { 2 } else { 1 }]),
            (339, 3, vec![format; spp]),
        ];
        match l.tiles {
            Some((w, h)) => tags.extend([
                (322, 4, vec![w as u64]),
                (323, 4, vec![h as u64]),
                (324, long, offsets),
                (325, long, counts),
            ]),
            None => tags.extend([
                (273, long, offsets),
                (278, 4, vec![bh as u64]),
                (279, long, counts),
            ]),
        }
        tags.sort_by_key(|t| t.0);
        let uint = |v: u64, n: usize| -> Vec<u8> {
            let le = v.to_le_bytes()[..n].to_vec();
            if l.order == Order::Big {
                le.into_iter().rev().collect()
            } else {
                le
            }
        };
        let size = |t: u16| match t {
            3 => 2,
            4 => 4,
            _ => 8,
        };
        let inline = if l.big { 8 } else { 4 };
        // Values that do not fit an entry go before the IFD.
        let mut fields = vec![];
        for (tag, t, v) in &tags {
            let bytes: Vec<u8> = v.iter().flat_map(|&x| uint(x, size(*t))).collect();
            let field = if bytes.len() <= inline {
                let mut f = bytes.clone();
                f.resize(inline, 0);
                f
            } else {
                let at = data.len() as u64;
                data.extend(&bytes);
                uint(at, inline)
            };
            fields.push((*tag, *t, v.len() as u64, field));
        }
        let ifd = data.len() as u64;
        let (cn, en) = if l.big { (8, 8) } else { (2, 4) };
        data.extend(uint(fields.len() as u64, cn));
        for (tag, t, n, field) in fields {
            data.extend(uint(u64::from(tag), 2));
            data.extend(uint(u64::from(t), 2));
            data.extend(uint(n, en));
            data.extend(field);
        }
        data.extend(uint(0, inline));
        let mut head = match l.order {
            Order::Little => b"II".to_vec(),
            Order::Big => b"MM".to_vec(),
        };
        if l.big {
            head.extend(uint(43, 2));
            head.extend(uint(8, 2));
            head.extend(uint(0, 2));
            head.extend(uint(ifd, 8));
        } else {
            head.extend(uint(42, 2));
            head.extend(uint(ifd, 4));
        }
        data[..head.len()].copy_from_slice(&head);
        std::fs::write(path, data).unwrap();
    }

    #[test]
    fn windows_of_every_layout_are_read_as_the_slow_writer_laid_them_out() {
        let (rows, cols) = (23, 29);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let img: Vec<Complex32> = (0..rows * cols)
            .map(|_| {
                Complex32::new(
                    rng.random_range(-3000..3000) as f32,
                    rng.random_range(-3000..3000) as f32,
                )
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let mut n = 0;
        for num in [Num::I16, Num::I32, Num::F32, Num::F64] {
            for (tiles, rps) in [(None, 1), (None, 5), (None, 23), (Some((16, 8)), 0)] {
                for deflate in [false, true] {
                    for (planar, complex_sample) in [(false, true), (false, false), (true, false)] {
                        for (order, big) in [(Order::Little, false), (Order::Big, true)] {
                            let l = Layout {
                                num,
                                tiles,
                                rows_per_strip: rps,
                                deflate,
                                planar,
                                order,
                                big,
                                complex_sample,
                            };
                            let path = dir.path().join(format!("{n}.tif"));
                            n += 1;
                            write(&path, &img, rows, cols, &l);
                            let tiff = GeoTiff::open(&path).unwrap();
                            assert_eq!(
                                (tiff.rows, tiff.cols, tiff.num, tiff.planar),
                                (rows, cols, num, planar)
                            );
                            for win in [
                                Window::whole(rows, cols),
                                Window::at(3, 5, 17, 20),
                                Window::at(22, 28, 1, 1),
                                Window::at(7, 0, 9, 29),
                            ] {
                                let mut out =
                                    vec![Complex32::new(f32::NAN, 0.0); win.rows() * win.cols()];
                                read_window(&tiff, &win, &mut out).unwrap();
                                for i in 0..win.rows() {
                                    for j in 0..win.cols() {
                                        assert_eq!(
                                            out[i * win.cols() + j],
                                            img[(win.r0 + i) * cols + win.c0 + j],
                                            "file {n}, window {win:?}, ({i}, {j})"
                                        );
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn a_file_cut_short_or_not_a_tiff_is_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let img = vec![Complex32::new(1.0, 2.0); 6 * 4];
        let l = Layout {
            num: Num::I16,
            tiles: None,
            rows_per_strip: 2,
            deflate: false,
            planar: false,
            order: Order::Little,
            big: false,
            complex_sample: true,
        };
        let path = dir.path().join("a.tif");
        write(&path, &img, 6, 4, &l);
        let bytes = std::fs::read(&path).unwrap();
        // This writer puts the directory last: cut short, the file loses it.
        std::fs::write(&path, &bytes[..bytes.len() - 20]).unwrap();
        let e = GeoTiff::open(&path).unwrap_err().to_string();
        assert!(e.contains("a.tif: header:"), "{e}");
        std::fs::write(&path, b"GIF89a").unwrap();
        let e = GeoTiff::open(&path).unwrap_err().to_string();
        assert!(e.contains("not a TIFF"), "{e}");
    }
}
