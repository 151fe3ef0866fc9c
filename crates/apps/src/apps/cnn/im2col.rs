//! The im2col matrices of the convolution blocks ([`super::fast`]): [`im2col`] lays the input
//! patches of a chunk of samples out as the right-hand matrix of the convolution's product, in
//! tiles of [`TILE`] columns ([`super::sgemm::Tiled::packed`]) so that the product reads them
//! without packing, and [`col2im`] adds a row-major matrix of that shape back onto the images
//! (the input gradient).

use super::geom::BlockGeom;
use super::sgemm::{Isa, TILE};

/// Values of the tiled im2col matrix of `s` samples: its rows times the columns rounded up to
/// whole tiles.
pub fn tiled_len(g: &BlockGeom, s: usize) -> usize {
    g.kk() * (s * g.p()).div_ceil(TILE) * TILE
}

/// The im2col matrix of samples `n0 .. n0 + s` of `x` read in place, where the convolution
/// reads no padding and each tile is a stretch of an output row (stride 1, `ow` a multiple of
/// [`TILE`], no padding above or on the left, every window inside the image): the tiles'
/// starts in `x` (sample, output row, stretch) and the rows' offsets `(ci, a, b)`, for
/// [`super::sgemm::Tiled::gather`]. `None` for other geometries (then [`im2col`] copies).
/// The network's first convolution, in its space-to-depth form, is such a geometry: its
/// im2col matrix would be 16 copies of the input.
pub fn in_place(g: &BlockGeom, n0: usize, s: usize) -> Option<(Vec<usize>, Vec<usize>)> {
    if !reads_in_place(g) {
        return None;
    }
    let hw = g.h * g.w;
    let tiles = (n0..n0 + s)
        .flat_map(|ni| {
            (0..g.oh).flat_map(move |i| {
                (0..g.ow / TILE).map(move |part| ni * g.c * hw + i * g.w + part * TILE)
            })
        })
        .collect();
    let rows = (0..g.c)
        .flat_map(|ci| (0..g.k).flat_map(move |a| (0..g.k).map(move |b| ci * hw + a * g.w + b)))
        .collect();
    Some((tiles, rows))
}

/// Whether the convolution of `g` reads its input in place ([`in_place`]): stride 1, `ow` a
/// multiple of [`TILE`], no padding above or on the left, every window inside the image.
pub fn reads_in_place(g: &BlockGeom) -> bool {
    g.stride == 1
        && g.ow.is_multiple_of(TILE)
        && g.top == 0
        && g.left == 0
        && g.oh + g.k - 1 <= g.h
        && g.ow + g.k - 1 <= g.w
}

/// The im2col matrix `[c k k, s p]` of samples `n0 .. n0 + s` of `x` in tiles
/// ([`super::sgemm::Tiled::packed`] of `c k k` rows; [`tiled_len`] values, the partial last
/// tile's missing columns zero): row `(ci, a, b)`, column `(sample, i, j)` holds
/// `x[n0 + sample, ci, i stride + a - top, j stride + b - left]` (zero outside the image).
/// `row` is scratch of at least `s p` values.
pub fn im2col(g: &BlockGeom, x: &[f32], n0: usize, s: usize, col: &mut [f32], row: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if Isa::best() == Isa::Avx512 {
        // SAFETY: the processor runs AVX-512 (checked above).
        unsafe { im2col_avx512(g, x, n0, s, col, row) };
        return;
    }
    im2col_body(g, x, n0, s, col, row);
}

/// [`im2col`] compiled for AVX-512 (wider copies and the stride-2 gathers as shuffles).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn im2col_avx512(
    g: &BlockGeom,
    x: &[f32],
    n0: usize,
    s: usize,
    col: &mut [f32],
    row: &mut [f32],
) {
    im2col_body(g, x, n0, s, col, row);
}

/// The body of [`im2col`].
#[inline(always)]
fn im2col_body(g: &BlockGeom, x: &[f32], n0: usize, s: usize, col: &mut [f32], row: &mut [f32]) {
    let (p, sp, hw, kk) = (g.p(), s * g.p(), g.h * g.w, g.kk());
    // A run of the `ow` columns of one output row starts at a multiple of `ow`; when `ow`
    // divides the tile, no run crosses a tile and each is written in place.
    let direct = TILE.is_multiple_of(g.ow);
    let tiles = sp.div_ceil(TILE);
    let row = &mut row[..sp];
    for ci in 0..g.c {
        for a in 0..g.k {
            for b in 0..g.k {
                let r = (ci * g.k + a) * g.k + b;
                let (j0, j1) = valid_range(g.ow, g.stride, b, g.left, g.w);
                for si in 0..s {
                    let img = &x[((n0 + si) * g.c + ci) * hw..][..hw];
                    for i in 0..g.oh {
                        let j = si * p + i * g.ow;
                        let out = if direct {
                            &mut col[((j / TILE) * kk + r) * TILE + j % TILE..][..g.ow]
                        } else {
                            &mut row[j..][..g.ow]
                        };
                        let ih = (i * g.stride + a) as isize - g.top as isize;
                        if ih < 0 || ih >= g.h as isize || j0 >= j1 {
                            out.fill(0.0);
                            continue;
                        }
                        let src = &img[ih as usize * g.w..][..g.w];
                        out[..j0].fill(0.0);
                        out[j1..].fill(0.0);
                        let first = j0 * g.stride + b - g.left;
                        if g.stride == 1 && j1 - j0 == TILE {
                            // A whole tile row: a fixed-size copy, not a call to memcpy.
                            let src: &[f32; TILE] =
                                src[first..][..TILE].try_into().expect("a tile");
                            let dst: &mut [f32; TILE] = out.try_into().expect("a tile");
                            *dst = *src;
                        } else if g.stride == 1 {
                            out[j0..j1].copy_from_slice(&src[first..first + (j1 - j0)]);
                        } else if g.stride == 2 {
                            gather2(&mut out[j0..j1], &src[first..]);
                        } else {
                            for (o, v) in out[j0..j1]
                                .iter_mut()
                                .zip(src[first..].iter().step_by(g.stride))
                            {
                                *o = *v;
                            }
                        }
                    }
                }
                if direct {
                    // The partial last tile's missing columns.
                    col[((tiles - 1) * kk + r) * TILE..][..TILE][sp - (tiles - 1) * TILE..]
                        .fill(0.0);
                    continue;
                }
                for (jt, vals) in row.chunks(TILE).enumerate() {
                    let dst = &mut col[(jt * kk + r) * TILE..][..TILE];
                    dst[..vals.len()].copy_from_slice(vals);
                    dst[vals.len()..].fill(0.0);
                }
            }
        }
    }
}

/// `out[t] = src[2 t]`: as pairs when `src` holds them all (a shape the compiler turns into
/// vector shuffles), one by one otherwise.
#[inline(always)]
fn gather2(out: &mut [f32], src: &[f32]) {
    let n = out.len();
    if src.len() >= 2 * n {
        // Eight at a time (a run is often just eight long, too short for the compiler's own
        // vector loop), then the rest.
        let mut o8 = out.chunks_exact_mut(8);
        let mut s16 = src[..2 * n].chunks_exact(16);
        for (o, s) in (&mut o8).zip(&mut s16) {
            for t in 0..8 {
                o[t] = s[2 * t];
            }
        }
        for (o, pair) in o8
            .into_remainder()
            .iter_mut()
            .zip(s16.remainder().chunks_exact(2))
        {
            *o = pair[0];
        }
    } else {
        for (t, o) in out.iter_mut().enumerate() {
            *o = src[2 * t];
        }
    }
}

/// Adds the row-major `col` (`[c k k, s p]`, the im2col matrix's shape) back onto the images `dx` of samples
/// `n0 .. n0 + s` (`dx` starts at sample `n0`): the adjoint of [`im2col`].
pub fn col2im(g: &BlockGeom, col: &[f32], s: usize, dx: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if Isa::best() == Isa::Avx512 {
        // SAFETY: the processor runs AVX-512 (checked above).
        unsafe { col2im_avx512(g, col, s, dx) };
        return;
    }
    col2im_body(g, col, s, dx);
}

/// [`col2im`] compiled for AVX-512 (the same additions in the same order).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn col2im_avx512(g: &BlockGeom, col: &[f32], s: usize, dx: &mut [f32]) {
    col2im_body(g, col, s, dx);
}

/// The body of [`col2im`].
#[inline(always)]
fn col2im_body(g: &BlockGeom, col: &[f32], s: usize, dx: &mut [f32]) {
    let (p, sp, hw) = (g.p(), s * g.p(), g.h * g.w);
    for ci in 0..g.c {
        for a in 0..g.k {
            for b in 0..g.k {
                let r = (ci * g.k + a) * g.k + b;
                let row = &col[r * sp..(r + 1) * sp];
                let (j0, j1) = valid_range(g.ow, g.stride, b, g.left, g.w);
                if j0 >= j1 {
                    continue;
                }
                for si in 0..s {
                    let img = &mut dx[(si * g.c + ci) * hw..][..hw];
                    for i in 0..g.oh {
                        let ih = (i * g.stride + a) as isize - g.top as isize;
                        if ih < 0 || ih >= g.h as isize {
                            continue;
                        }
                        let src = &row[si * p + i * g.ow..][..g.ow];
                        let dst = &mut img[ih as usize * g.w..][..g.w];
                        let first = j0 * g.stride + b - g.left;
                        for (o, v) in dst[first..].iter_mut().step_by(g.stride).zip(&src[j0..j1]) {
                            *o += *v;
                        }
                    }
                }
            }
        }
    }
}

/// The output columns `j0 .. j1` whose input column `j stride + b - left` lies in `0 .. w`.
fn valid_range(ow: usize, stride: usize, b: usize, left: usize, w: usize) -> (usize, usize) {
    let j0 = left.saturating_sub(b).div_ceil(stride).min(ow);
    // j stride + b - left <= w - 1  <=>  j <= (w - 1 + left - b) / stride
    let j1 = if w + left > b {
        ((w - 1 + left - b) / stride + 1).min(ow)
    } else {
        0
    };
    (j0, j1.max(j0))
}
