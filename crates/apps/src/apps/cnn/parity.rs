//! The stride-2 convolutions of prediction read without an im2col matrix ([`super::fast`]'s
//! inference blocks): the chunk's input is split once into its four parity planes (even and
//! odd rows times even and odd columns of the zero-padded image), after which every tap
//! `(a, b)` of a stride-2 kernel reads plane `(a % 2, b % 2)` shifted by `(a / 2, b / 2)`:
//! one contiguous stretch per input channel. The product then reads the planes in place
//! ([`super::sgemm::Tiled::gather`]) over a grid of `ph x pw` output positions a sample, of
//! which the first `oh x ow` are the convolution's (the others are computed and dropped).
//!
//! The im2col matrix writes each input value `k^2 / 4` times (four for the networks' 4x4
//! second convolutions); the planes write it once, plus the padding. The product sums the
//! same taps in the same order as with the im2col matrix, so the outputs are the same bits.

use super::geom::BlockGeom;
use super::im2col::reads_in_place;
use super::sgemm::TILE;

/// Whether the convolution of `g` reads parity planes in prediction: stride 2, and not read
/// from its input in place (the first convolution's space-to-depth form is).
pub fn reads_parity(g: &BlockGeom) -> bool {
    g.stride == 2 && !reads_in_place(g)
}

/// Rows and columns of each parity plane: the output's plus the reach of the kernel's taps in
/// the plane, `(k - 1) / 2`.
pub fn parity_hw(g: &BlockGeom) -> (usize, usize) {
    let reach = (g.k - 1) / 2;
    (g.oh + reach, g.ow + reach)
}

/// Values of the parity planes of `s` samples (`[4, c, s, ph, pw]`), with the slack the
/// shifted reads of the last plane's last output positions pass its end by.
pub fn parity_len(g: &BlockGeom, s: usize) -> usize {
    let (ph, pw) = parity_hw(g);
    let reach = (g.k - 1) / 2;
    4 * g.c * s * ph * pw + reach * (pw + 1)
}

/// Writes the parity planes of samples `n0 .. n0 + s` of `x` `[n, c, h, w]` into `planes`
/// ([`parity_len`] values): plane `(py, px)` of channel `ci` holds, at `(i, j)`, the padded
/// input at row `2 i + py`, column `2 j + px` (`x[.., ci, 2 i + py - top, 2 j + px - left]`,
/// zero outside the image).
pub fn parity_planes(g: &BlockGeom, x: &[f32], n0: usize, s: usize, planes: &mut [f32]) {
    let (ph, pw) = parity_hw(g);
    let (hw, plane) = (g.h * g.w, s * ph * pw);
    for si in 0..s {
        for ci in 0..g.c {
            let img = &x[((n0 + si) * g.c + ci) * hw..][..hw];
            for py in 0..2 {
                for px in 0..2 {
                    let base = ((py * 2 + px) * g.c + ci) * plane + si * ph * pw;
                    for i in 0..ph {
                        let out = &mut planes[base + i * pw..][..pw];
                        let y = (2 * i + py) as isize - g.top as isize;
                        if y < 0 || y >= g.h as isize {
                            out.fill(0.0);
                            continue;
                        }
                        let src = &img[y as usize * g.w..][..g.w];
                        for (j, o) in out.iter_mut().enumerate() {
                            let x = (2 * j + px) as isize - g.left as isize;
                            *o = if x >= 0 && x < g.w as isize {
                                src[x as usize]
                            } else {
                                0.0
                            };
                        }
                    }
                }
            }
        }
    }
    let end = 4 * g.c * plane;
    planes[end..].fill(0.0);
}

/// Where the product reads the planes of `s` samples: the tiles of the `s ph pw` output
/// positions, one after the other, and the rows' offsets `(ci, a, b)` (plane `(a % 2, b % 2)`
/// of channel `ci`, shifted by `(a / 2, b / 2)`), for [`super::sgemm::Tiled::gather`]; the
/// product has `s ph pw` columns.
pub fn parity_view(g: &BlockGeom, s: usize) -> (Vec<usize>, Vec<usize>) {
    let (ph, pw) = parity_hw(g);
    let plane = s * ph * pw;
    let tiles = (0..plane.div_ceil(TILE)).map(|t| t * TILE).collect();
    let rows = (0..g.c)
        .flat_map(|ci| {
            (0..g.k).flat_map(move |a| {
                (0..g.k)
                    .map(move |b| (((a % 2) * 2 + b % 2) * g.c + ci) * plane + (a / 2) * pw + b / 2)
            })
        })
        .collect();
    (tiles, rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::apps::cnn::im2col::{im2col, tiled_len};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Every valid output position's column of the planes' view holds the im2col matrix's
    /// column, value for value, on the networks' stride-2 geometries and odd ones (padding
    /// on one side only, kernels of 2, 3, 4 and 5, odd image sides).
    #[test]
    fn the_planes_view_is_the_im2col_matrix() {
        let mut rng = ChaCha8Rng::seed_from_u64(30);
        // (c, h, w, k, top, left, oh, ow)
        let cases = [
            (64, 16, 16, 4, 1, 1, 8, 8),
            (16, 4, 4, 2, 0, 0, 2, 2),
            (3, 9, 7, 3, 1, 0, 5, 4),
            (2, 10, 11, 5, 2, 2, 5, 6),
            (5, 8, 8, 4, 1, 1, 4, 4),
        ];
        for (case, &(c, h, w, k, top, left, oh, ow)) in cases.iter().enumerate() {
            let (n, n0, s) = (5, 1, 3);
            let g = BlockGeom {
                n,
                c,
                h,
                w,
                f: 1,
                k,
                stride: 2,
                top,
                left,
                oh,
                ow,
                pool: false,
            };
            assert!(reads_parity(&g), "case {case}");
            let x: Vec<f32> = (0..n * c * h * w)
                .map(|_| rng.random_range(-1.0f32..1.0))
                .collect();
            let mut col = vec![f32::NAN; tiled_len(&g, s)];
            let mut row = vec![0.0; s * g.p()];
            im2col(&g, &x, n0, s, &mut col, &mut row);
            let mut planes = vec![f32::NAN; parity_len(&g, s)];
            parity_planes(&g, &x, n0, s, &mut planes);
            let (tiles, rows) = parity_view(&g, s);
            let (ph, pw) = parity_hw(&g);
            for r in 0..g.kk() {
                for si in 0..s {
                    for i in 0..oh {
                        for j in 0..ow {
                            let want = packed_at(&col, g.kk(), r, si * g.p() + i * ow + j);
                            let jj = si * ph * pw + i * pw + j;
                            let got = planes[tiles[jj / TILE] + rows[r] + jj % TILE];
                            assert_eq!(got.to_bits(), want.to_bits(), "case {case} r {r}");
                        }
                    }
                }
            }
            // Every position the product reads lies inside and is a number.
            let last = tiles.last().unwrap() + rows.iter().max().unwrap();
            let cols = s * ph * pw;
            assert!(last + (cols - 1) % TILE < planes.len(), "case {case}");
            assert!(planes.iter().all(|v| v.is_finite()), "case {case}");
        }
    }

    /// Prediction's blocks (parity planes for the stride-2 convolutions) give the same bits as
    /// the training path's convolution (im2col) followed by the same normalisation, ReLU and
    /// pooling, on the networks' second and third convolutions at a batch of several chunks.
    #[test]
    fn inference_blocks_give_the_im2col_paths_bits() {
        use crate::apps::cnn::fast::{affine_relu_pool, block_infer, bn_affine, conv_forward};
        use burn::backend::Flex;
        use burn::tensor::{Tensor, TensorData};
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        // (n, c, h, w, f, k, top, left, oh, ow, pool)
        let cases = [
            (21, 64, 16, 16, 16, 4, 1, 1, 8, 8, true),
            (21, 16, 4, 4, 16, 2, 0, 0, 2, 2, false),
            (9, 3, 9, 9, 5, 4, 1, 1, 5, 5, true),
        ];
        for (case, &(n, c, h, w, f, k, top, left, oh, ow, pool)) in cases.iter().enumerate() {
            let g = BlockGeom {
                n,
                c,
                h,
                w,
                f,
                k,
                stride: 2,
                top,
                left,
                oh,
                ow,
                pool,
            };
            let mut r = |len: usize| -> Vec<f32> {
                (0..len).map(|_| rng.random_range(-1.0f32..1.0)).collect()
            };
            let (x, wt, bias, gamma, beta, mean) =
                (r(n * c * h * w), r(f * c * k * k), r(f), r(f), r(f), r(f));
            let var: Vec<f32> = r(f).iter().map(|v| 1.0 + v.abs()).collect();
            let eps = 1e-5;
            let dev = Default::default();
            let t = |v: &[f32], shape: Vec<usize>| {
                Tensor::<Flex, 1>::from_data(TensorData::new(v.to_vec(), [v.len()]), &dev)
                    .reshape::<4, _>([shape[0], shape[1], shape[2], shape[3]])
            };
            let t1 = |v: &[f32]| {
                Tensor::<Flex, 1>::from_data(TensorData::new(v.to_vec(), [v.len()]), &dev)
            };
            let got: Vec<f32> = block_infer(
                &g,
                t(&x, vec![n, c, h, w]),
                t(&wt, vec![f, c, k, k]),
                t1(&bias),
                t1(&gamma),
                t1(&beta),
                t1(&mean),
                t1(&var),
                eps,
            )
            .into_data()
            .to_vec()
            .unwrap();
            let (scale, shift) = bn_affine(&gamma, &beta, &mean, &var, eps);
            let (z, _) = conv_forward(&g, &x, &wt, &bias);
            let (want, _) = affine_relu_pool(&g, &z, &scale, &shift, false);
            assert_eq!(got.len(), want.len(), "case {case}");
            for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    a.to_bits(),
                    b.to_bits(),
                    "case {case}, value {i}: {a} vs {b}"
                );
            }
        }
    }

    /// The value of row `r`, column `j` of a matrix of `rows` rows in whole tiles (what
    /// [`im2col`] writes, [`crate::apps::cnn::sgemm::Tiled::packed`]).
    fn packed_at(b: &[f32], rows: usize, r: usize, j: usize) -> f32 {
        b[((j / TILE) * rows + r) * TILE + j % TILE]
    }
}
