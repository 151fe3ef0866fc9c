//! The im2col matrices of the convolution blocks ([`super::fast`]): [`im2col`] lays the input
//! patches of a chunk of samples out as the right-hand matrix of the convolution's product, in
//! tiles of [`TILE`] columns ([`super::sgemm::Tiled::packed`]) so that the product reads them
//! without packing, and [`col2im`] adds a row-major matrix of that shape back onto the images
//! (the input gradient).

use super::fast::BlockGeom;
use super::sgemm::TILE;

/// Values of the tiled im2col matrix of `s` samples: its rows times the columns rounded up to
/// whole tiles.
pub fn tiled_len(g: &BlockGeom, s: usize) -> usize {
    g.kk() * (s * g.p()).div_ceil(TILE) * TILE
}

/// The im2col matrix `[c k k, s p]` of samples `n0 .. n0 + s` of `x` in tiles
/// ([`super::sgemm::Tiled::packed`] of `c k k` rows; [`tiled_len`] values, the partial last
/// tile's missing columns zero): row `(ci, a, b)`, column `(sample, i, j)` holds
/// `x[n0 + sample, ci, i stride + a - top, j stride + b - left]` (zero outside the image).
/// `row` is scratch of at least `s p` values.
pub fn im2col(g: &BlockGeom, x: &[f32], n0: usize, s: usize, col: &mut [f32], row: &mut [f32]) {
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

/// Adds the row-major `col` (`[c k k, s p]`, the im2col matrix's shape) back onto the images `dx` of samples
/// `n0 .. n0 + s` (`dx` starts at sample `n0`): the adjoint of [`im2col`].
pub fn col2im(g: &BlockGeom, col: &[f32], s: usize, dx: &mut [f32]) {
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
