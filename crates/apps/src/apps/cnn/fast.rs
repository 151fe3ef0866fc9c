//! Hand-written CPU kernels for the networks' convolution blocks (convolution with bias, batch
//! normalisation, ReLU and an optional 2x2 stride-2 max pooling), forward and backward, used by
//! [`super::net::Net`] when it runs on burn's `flex` backend (with or without autodiff); every
//! other backend runs the same block as a chain of burn operations.
//!
//! Why: on flex, a block is a dozen separate operations, each reading and writing the whole
//! activation (32 MiB for Table 23's first block at batch 128), the convolution's weight
//! gradient goes through a generic im2col, and the batch statistics broadcast through slow
//! paths. Here a convolution is an explicit im2col ([`super::im2col`], written in the tiles the
//! product reads) plus one matrix product per chunk of samples ([`super::sgemm`], on the
//! calling thread, AVX-512 where the processor has it), and normalisation, ReLU
//! and pooling are one pass forward and two passes backward. The block is one node of burn's
//! autodiff graph ([`Backward`]): burn still owns the graph, the other layers, the loss and the
//! optimiser.
//!
//! Determinism: work is split into chunks of samples whose size depends only on the shapes,
//! never on the number of threads; each chunk is computed by one thread in a fixed order, and
//! partial sums (batch statistics, weight and bias gradients) are added chunk after chunk in
//! order. Results are therefore bit-identical on a rayon pool of any size.
//!
//! `tests/cnn.rs` checks every kernel against plain loops in f64 (forward and all gradients).
//! Process-wide state: a pool of large buffers (`POOL`) and per-thread scratch (`SCRATCH`),
//! reused between training steps; neither carries values from one call to the next.

pub use super::geom::BlockGeom;
use super::im2col::{col2im, im2col, in_place, reads_in_place, tiled_len};
use super::parity::{parity_hw, parity_len, parity_planes, parity_view, reads_parity};
use super::sgemm::{gemm_nn, gemm_nt, Tiled};
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::flex::FlexTensor;
use burn::backend::{Autodiff, Flex};
use burn::tensor::{Tensor, TensorData, TensorPrimitive};
use rayon::prelude::*;
use std::cell::RefCell;
use std::sync::{Arc, Mutex};

/// Large buffers (convolution outputs, BN gradients) kept between training steps: a fresh
/// block of that size is mapped from the kernel and zeroed page by page on every step
/// otherwise (a sixth of the time in the profile).
static POOL: Mutex<Vec<Vec<f32>>> = Mutex::new(Vec::new());
/// Most buffers [`POOL`] keeps: two training steps' worth (burn frees a step's tapes after the
/// next step has begun: with 8, about one buffer a step was mapped and zeroed afresh).
const POOL_MAX: usize = 12;

thread_local! {
    /// Per-thread scratch (im2col matrices and their products), kept between calls.
    static SCRATCH: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

/// A buffer of `len` values from [`POOL`] (stale values: callers overwrite or fill it).
fn take(len: usize) -> Vec<f32> {
    let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
    let best = pool
        .iter()
        .enumerate()
        .filter(|(_, v)| v.capacity() >= len && v.capacity() <= 2 * len)
        .min_by_key(|(_, v)| v.capacity())
        .map(|(i, _)| i);
    match best {
        Some(i) => {
            let mut v = pool.remove(i);
            // Within the capacity: pages already touched, no allocation.
            v.resize(len, 0.0);
            v
        }
        None => vec![0.0; len],
    }
}

/// Gives a buffer back to [`POOL`]; when it is full, the buffer given back longest ago goes
/// (a full pool of buffers of another network's sizes would otherwise never take the ones in
/// use now, and every call would map and zero fresh pages).
fn give(v: Vec<f32>) {
    if v.len() < 1 << 16 {
        return;
    }
    let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
    if pool.len() >= POOL_MAX {
        pool.remove(0);
    }
    pool.push(v);
}

/// Runs `f` on this thread's scratch buffer resized to `len` values.
fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [f32]) -> R) -> R {
    SCRATCH.with_borrow_mut(|s| {
        if s.len() < len {
            s.resize(len, 0.0);
        }
        f(&mut s[..len])
    })
}

/// burn's CPU backend with autodiff, the type the fast training path runs on.
pub type FlexTrain = Autodiff<Flex>;

/// Sum of `v` in eight interleaved f32 lanes (vectorisable, a fixed order), then in f64.
fn lane_sum(v: &[f32], f: impl Fn(f32) -> f32) -> f64 {
    let mut lanes = [0.0f32; 8];
    let mut it = v.chunks_exact(8);
    for ch in &mut it {
        for (l, x) in lanes.iter_mut().zip(ch) {
            *l += f(*x);
        }
    }
    let mut s: f64 = lanes.iter().map(|&l| f64::from(l)).sum();
    for x in it.remainder() {
        s += f64::from(f(*x));
    }
    s
}

/// The convolution with bias: `[n, f, oh, ow]` from `x` `[n, c, h, w]`, `w` `[f, c, k, k]`,
/// and the chunks' im2col matrices one after the other ([`chunk_cols`]; empty where the
/// convolution reads its input in place), kept for the backward pass: reading them back costs
/// less than building them again.
pub fn conv_forward(g: &BlockGeom, x: &[f32], w: &[f32], bias: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let (p, s) = (g.p(), g.chunk());
    let mut z = take(g.n * g.f * p);
    let keep = !reads_in_place(g);
    let mut cols = if keep {
        take(chunk_cols(g, g.n))
    } else {
        Vec::new()
    };
    // Each chunk's part of `cols` (none where nothing is kept).
    let mut parts: Vec<Option<&mut [f32]>> = if keep {
        cols.chunks_mut(tiled_len(g, s)).map(Some).collect()
    } else {
        (0..g.n.div_ceil(s)).map(|_| None).collect()
    };
    z.par_chunks_mut(s * g.f * p)
        .zip(parts.par_iter_mut())
        .enumerate()
        .for_each(|(ci, (zc, cc))| {
            let sn = zc.len() / (g.f * p);
            conv_chunk(g, x, w, bias, ci * s, sn, cc.take(), |tmp, layout| {
                debug_assert_eq!(layout, (p, g.ow), "training reads no parity planes");
                for si in 0..sn {
                    for fi in 0..g.f {
                        zc[(si * g.f + fi) * p..][..p]
                            .copy_from_slice(&tmp[fi * sn * p + si * p..][..p]);
                    }
                }
            });
        });
    (z, cols)
}

/// Values of the im2col matrices of the chunks of `n` samples, one after the other (each
/// chunk's at `chunk index * tiled_len(g, g.chunk())`).
fn chunk_cols(g: &BlockGeom, n: usize) -> usize {
    let s = g.chunk();
    (n / s) * tiled_len(g, s) + tiled_len(g, n % s)
}

/// The convolution with bias of samples `n0 .. n0 + sn`, handed to `then` as `[f, sn q]`
/// (filter-major, in this thread's scratch) with `(q, row)`: each sample's `oh x ow` outputs
/// start every `q` values, their rows every `row` (`(p, ow)`, except in prediction's
/// stride-2 convolutions: [`super::parity`]); the im2col matrix (where one is needed) goes to
/// `keep` when given, else to scratch. Without `keep`, a stride-2 convolution reads parity
/// planes instead (the same sums).
#[allow(clippy::too_many_arguments)]
fn conv_chunk(
    g: &BlockGeom,
    x: &[f32],
    w: &[f32],
    bias: &[f32],
    n0: usize,
    sn: usize,
    keep: Option<&mut [f32]>,
    then: impl FnOnce(&[f32], (usize, usize)),
) {
    let kk = g.kk();
    let view = in_place(g, n0, sn);
    let parity = (view.is_none() && keep.is_none() && reads_parity(g)).then(|| parity_view(g, sn));
    let (q, row) = match parity {
        Some(_) => {
            let (ph, pw) = parity_hw(g);
            (ph * pw, pw)
        }
        None => (g.p(), g.ow),
    };
    let sp = sn * q;
    let cl = match (&parity, view.is_some() || keep.is_some()) {
        (Some(_), _) => parity_len(g, sn),
        (None, true) => 0,
        (None, false) => tiled_len(g, sn),
    };
    with_scratch(cl + g.f * sp, |scratch| {
        let (col, tmp) = scratch.split_at_mut(cl);
        let (b, bl) = match (&view, &parity, keep) {
            (Some((tiles, rows)), _, _) => (x, Tiled::gather(tiles, rows)),
            (None, Some((tiles, rows)), _) => {
                parity_planes(g, x, n0, sn, col);
                (&*col, Tiled::gather(tiles, rows))
            }
            (None, None, keep) => {
                let col = keep.unwrap_or(col);
                // The output rows serve as im2col's row scratch before the bias.
                im2col(g, x, n0, sn, col, tmp);
                (&*col, Tiled::packed(kk, sp))
            }
        };
        for (row, &b) in tmp.chunks_exact_mut(sp).zip(bias) {
            row.fill(b);
        }
        gemm_nn(g.f, sp, kk, w, (kk, 1), b, &bl, tmp, sp, true);
        then(tmp, (q, row));
    });
}

/// Per-channel mean and biased variance of `z` `[n, f, p]` (two passes, f64 between samples).
pub fn batch_stats(g: &BlockGeom, z: &[f32]) -> (Vec<f64>, Vec<f64>) {
    let (p, f) = (g.p(), g.f);
    let m = (g.n * p) as f64;
    let sums: Vec<Vec<f64>> = z
        .par_chunks(f * p)
        .map(|zs| zs.chunks_exact(p).map(|pl| lane_sum(pl, |v| v)).collect())
        .collect();
    let mean: Vec<f64> = (0..f)
        .map(|fi| sums.iter().map(|s| s[fi]).sum::<f64>() / m)
        .collect();
    let meanf: Vec<f32> = mean.iter().map(|&v| v as f32).collect();
    let sq: Vec<Vec<f64>> = z
        .par_chunks(f * p)
        .map(|zs| {
            zs.chunks_exact(p)
                .zip(&meanf)
                .map(|(pl, &mu)| lane_sum(pl, |v| (v - mu) * (v - mu)))
                .collect()
        })
        .collect();
    let var: Vec<f64> = (0..f)
        .map(|fi| sq.iter().map(|s| s[fi]).sum::<f64>() / m)
        .collect();
    (mean, var)
}

/// `relu(z scale + shift)` per channel, then the pooling: the output `[n, f, H, W]` and, when
/// pooling, the position (0..4, row-major in the 2x2 window) of each window's maximum (the
/// first on ties).
pub fn affine_relu_pool(
    g: &BlockGeom,
    z: &[f32],
    scale: &[f32],
    shift: &[f32],
    want_arg: bool,
) -> (Vec<f32>, Vec<u8>) {
    let (p, f) = (g.p(), g.f);
    let (ph, pw) = g.out_hw();
    let q = ph * pw;
    let mut out = vec![0.0f32; g.n * f * q];
    let mut arg = vec![0u8; if want_arg && g.pool { g.n * f * q } else { 0 }];
    let write_arg = !arg.is_empty();
    let arg_chunk = if write_arg { f * q } else { 1 };
    let mut dummy = vec![0u8; g.n];
    let args: &mut [u8] = if arg.is_empty() { &mut dummy } else { &mut arg };
    out.par_chunks_mut(f * q)
        .zip(args.par_chunks_mut(arg_chunk))
        .zip(z.par_chunks(f * p))
        .for_each_init(Vec::new, |row: &mut Vec<f32>, ((os, ars), zs)| {
            for fi in 0..f {
                let zp = &zs[fi * p..][..p];
                let op = &mut os[fi * q..][..q];
                let ap = write_arg.then(|| &mut ars[fi * q..][..q]);
                plane(g, zp, scale[fi], shift[fi], op, ap, row);
            }
        });
    (out, arg)
}

/// One sample's channel of [`affine_relu_pool`]: `relu(z scale + shift)` of the `p` values
/// `zp`, pooled when the block pools, into the `q` values `op` (and the maxima's positions
/// into `arg`, when given); `row` is scratch.
#[inline(always)]
fn plane(
    g: &BlockGeom,
    zp: &[f32],
    sc: f32,
    sh: f32,
    op: &mut [f32],
    arg: Option<&mut [u8]>,
    row: &mut Vec<f32>,
) {
    if !g.pool {
        for (o, &v) in op.iter_mut().zip(zp) {
            *o = (v * sc + sh).max(0.0);
        }
        return;
    }
    let (ph, pw) = g.out_hw();
    if arg.is_none() {
        // Values only: each window's four values normalised and rectified on the way in, pairs
        // of columns as vector lanes (the same values as below).
        let f = |v: f32| (v * sc + sh).max(0.0);
        for i in 0..ph {
            let r0 = zp[2 * i * g.ow..][..2 * pw].chunks_exact(2);
            let r1 = zp[(2 * i + 1) * g.ow..][..2 * pw].chunks_exact(2);
            for (o, (a, b)) in op[i * pw..][..pw].iter_mut().zip(r0.zip(r1)) {
                *o = max4([f(a[0]), f(a[1]), f(b[0]), f(b[1])]).0;
            }
        }
        return;
    }
    row.resize(zp.len(), 0.0);
    for (r, &v) in row.iter_mut().zip(zp) {
        *r = (v * sc + sh).max(0.0);
    }
    let window = |i: usize, j: usize| {
        let (r0, r1) = (&row[2 * i * g.ow..], &row[(2 * i + 1) * g.ow..]);
        max4([r0[2 * j], r0[2 * j + 1], r1[2 * j], r1[2 * j + 1]])
    };
    match arg {
        Some(arg) => {
            for i in 0..ph {
                for j in 0..pw {
                    let (v, best) = window(i, j);
                    op[i * pw + j] = v;
                    arg[i * pw + j] = best;
                }
            }
        }
        None => {
            for i in 0..ph {
                for j in 0..pw {
                    op[i * pw + j] = window(i, j).0;
                }
            }
        }
    }
}

/// The largest of a 2x2 window's values (row-major) and its position, the first on ties:
/// a tournament of the two rows' pairs, without branches (the data decide each comparison at
/// random, which a branch predictor cannot follow).
#[inline(always)]
fn max4(c: [f32; 4]) -> (f32, u8) {
    let (m01, i01) = if c[1] > c[0] { (c[1], 1) } else { (c[0], 0) };
    let (m23, i23) = if c[3] > c[2] { (c[3], 3) } else { (c[2], 2) };
    if m23 > m01 {
        (m23, i23)
    } else {
        (m01, i01)
    }
}

/// What the backward pass of a training block needs from its forward pass.
#[derive(Debug)]
pub struct BlockTape {
    /// Geometry.
    pub g: BlockGeom,
    /// The block's input `[n, c, h, w]`.
    pub x: FlexTensor,
    /// The weights `[f, c, k, k]`.
    pub w: Vec<f32>,
    /// The convolution's output with bias `[n, f, oh, ow]`.
    pub z: Vec<f32>,
    /// The chunks' im2col matrices (empty where the convolution reads its input in place).
    pub cols: Vec<f32>,
    /// Pooling positions (empty without pooling).
    pub arg: Vec<u8>,
    /// Batch mean per channel.
    pub mean: Vec<f64>,
    /// Batch (biased) variance per channel.
    pub var: Vec<f64>,
    /// `1 / sqrt(var + eps)` per channel.
    pub inv_std: Vec<f64>,
    /// BN scale `gamma`.
    pub gamma: Vec<f32>,
    /// Per-channel `gamma / sqrt(var + eps)` (as used forward).
    pub scale: Vec<f32>,
    /// Per-channel `beta - mean scale` (as used forward).
    pub shift: Vec<f32>,
}

impl Drop for BlockTape {
    fn drop(&mut self) {
        give(std::mem::take(&mut self.z));
        give(std::mem::take(&mut self.cols));
    }
}

/// Gradients of a block's inputs.
#[derive(Debug, Clone)]
pub struct BlockGrads {
    /// Of the input `x` (when asked for).
    pub x: Option<Vec<f32>>,
    /// Of the weights.
    pub w: Vec<f32>,
    /// Of the convolution's bias.
    pub bias: Vec<f32>,
    /// Of the BN scale.
    pub gamma: Vec<f32>,
    /// Of the BN offset.
    pub beta: Vec<f32>,
}

/// The training forward pass (batch statistics): output, batch mean and biased variance, and
/// the tape for [`block_backward`].
#[allow(clippy::too_many_arguments)]
pub fn block_forward_train(
    g: &BlockGeom,
    x: FlexTensor,
    w: &[f32],
    bias: &[f32],
    gamma: &[f32],
    beta: &[f32],
    eps: f64,
) -> (Vec<f32>, BlockTape) {
    let (z, cols) = conv_forward(g, flex_slice(&x), w, bias);
    let (mean, var) = batch_stats(g, &z);
    let inv_std: Vec<f64> = var.iter().map(|&v| 1.0 / (v + eps).sqrt()).collect();
    let scale: Vec<f32> = gamma
        .iter()
        .zip(&inv_std)
        .map(|(&gm, &is)| (f64::from(gm) * is) as f32)
        .collect();
    let shift: Vec<f32> = beta
        .iter()
        .zip(&mean)
        .zip(&scale)
        .map(|((&b, &mu), &sc)| (f64::from(b) - mu * f64::from(sc)) as f32)
        .collect();
    let (out, arg) = affine_relu_pool(g, &z, &scale, &shift, true);
    let tape = BlockTape {
        g: *g,
        x,
        w: w.to_vec(),
        z,
        cols,
        arg,
        mean,
        var,
        inv_std,
        gamma: gamma.to_vec(),
        scale,
        shift,
    };
    (out, tape)
}

/// The backward pass of a training block from the gradient `dout` of its output.
///
/// Long because the block's backward pass is one sequence of kernels over shared buffers; split,
/// the buffers would be threaded through every part.
pub fn block_backward(t: &BlockTape, dout: &[f32], want_dx: bool) -> BlockGrads {
    let g = &t.g;
    let (p, f, kk, s) = (g.p(), g.f, g.kk(), g.chunk());
    let (ph, pw) = g.out_hw();
    let q = ph * pw;
    let m = (g.n * p) as f64;
    let meanf: Vec<f32> = t.mean.iter().map(|&v| v as f32).collect();
    let inv_f: Vec<f32> = t.inv_std.iter().map(|&v| v as f32).collect();
    // Phase 1: the gradient `da` of the BN output (through pooling and ReLU) and its sums.
    let mut da = take(g.n * f * p);
    if g.pool {
        // Only each window's maximum gets a gradient.
        da.fill(0.0);
    }
    let sums: Vec<Vec<(f64, f64)>> = da
        .par_chunks_mut(f * p)
        .enumerate()
        .map(|(ni, das)| {
            let zs = &t.z[ni * f * p..][..f * p];
            let ds = &dout[ni * f * q..][..f * q];
            (0..f)
                .map(|fi| {
                    let (sc, sh) = (t.scale[fi], t.shift[fi]);
                    let zp = &zs[fi * p..][..p];
                    let dp = &mut das[fi * p..][..p];
                    let gp = &ds[fi * q..][..q];
                    if g.pool {
                        let ap = &t.arg[(ni * f + fi) * q..][..q];
                        for i in 0..ph {
                            for j in 0..pw {
                                let a = ap[i * pw + j] as usize;
                                let pos = (2 * i + a / 2) * g.ow + 2 * j + a % 2;
                                // Each position once (the windows do not overlap); a select,
                                // not a branch.
                                let live = zp[pos] * sc + sh > 0.0;
                                dp[pos] = if live { gp[i * pw + j] } else { 0.0 };
                            }
                        }
                    } else {
                        for ((d, &v), &gv) in dp.iter_mut().zip(zp).zip(gp) {
                            *d = if v * sc + sh > 0.0 { gv } else { 0.0 };
                        }
                    }
                    let (mu, is) = (meanf[fi], inv_f[fi]);
                    let dbeta = lane_sum(dp, |v| v);
                    let mut lanes = [0.0f32; 8];
                    let mut itd = dp.chunks_exact(8);
                    let mut itz = zp.chunks_exact(8);
                    for (cd, cz) in (&mut itd).zip(&mut itz) {
                        for l in 0..8 {
                            lanes[l] += cd[l] * ((cz[l] - mu) * is);
                        }
                    }
                    let mut dgamma: f64 = lanes.iter().map(|&l| f64::from(l)).sum();
                    for (d, v) in itd.remainder().iter().zip(itz.remainder()) {
                        dgamma += f64::from(d * ((v - mu) * is));
                    }
                    (dbeta, dgamma)
                })
                .collect()
        })
        .collect();
    let dbeta: Vec<f64> = (0..f)
        .map(|fi| sums.iter().map(|s| s[fi].0).sum())
        .collect();
    let dgamma: Vec<f64> = (0..f)
        .map(|fi| sums.iter().map(|s| s[fi].1).sum())
        .collect();
    // dz = scale (da - dbeta / m - xhat dgamma / m), xhat = (z - mean) inv_std.
    let c2: Vec<f32> = dbeta.iter().map(|&v| (v / m) as f32).collect();
    let c3: Vec<f32> = dgamma
        .iter()
        .zip(&t.inv_std)
        .map(|(&dg, &is)| (dg / m * is) as f32)
        .collect();
    // Phase 2, per chunk: dz, the bias and weight gradients' partial sums, and dx.
    let x = flex_slice(&t.x);
    let mut dx = if want_dx {
        vec![0.0f32; g.n * g.c * g.h * g.w]
    } else {
        vec![0.0f32; g.n]
    };
    let dx_chunk = if want_dx { s * g.c * g.h * g.w } else { s };
    let partials: Vec<(Vec<f32>, Vec<f64>)> = dx
        .par_chunks_mut(dx_chunk)
        .enumerate()
        .map(|(ci, dxc)| {
            let n0 = ci * s;
            let sn = (g.n - n0).min(s);
            let sp = sn * p;
            let view = in_place(g, n0, sn);
            with_scratch(kk * sp + f * sp, |scratch| {
                let (dz, dcol) = scratch.split_at_mut(f * sp);
                let mut db = vec![0.0f64; f];
                for si in 0..sn {
                    let ni = n0 + si;
                    for fi in 0..f {
                        let zp = &t.z[(ni * f + fi) * p..][..p];
                        let dp = &da[(ni * f + fi) * p..][..p];
                        let out = &mut dz[fi * sp + si * p..][..p];
                        let (sc, mu, a2, a3) = (t.scale[fi], meanf[fi], c2[fi], c3[fi]);
                        for ((o, &d), &v) in out.iter_mut().zip(dp).zip(zp) {
                            *o = sc * (d - a2 - (v - mu) * a3);
                        }
                        db[fi] += lane_sum(out, |v| v);
                    }
                }
                // The forward pass kept the im2col matrix wherever it needed one.
                let (b, bl) = match &view {
                    Some((tiles, rows)) => (x, Tiled::gather(tiles, rows)),
                    None => {
                        let cc = &t.cols[ci * tiled_len(g, s)..][..tiled_len(g, sn)];
                        (cc, Tiled::packed(kk, sp))
                    }
                };
                let mut dw = vec![0.0f32; f * kk];
                // dw[f, kk] = dz[f, sp] col[kk, sp]^T
                gemm_nt(f, kk, sp, dz, sp, b, &bl, &mut dw, kk, false);
                if want_dx {
                    // dcol[kk, sp] = w[f, kk]^T dz[f, sp]
                    let dcol = &mut dcol[..kk * sp];
                    let dzl = Tiled::row_major(sp, f, sp);
                    gemm_nn(kk, sp, f, &t.w, (1, kk), dz, &dzl, dcol, sp, false);
                    col2im(g, dcol, sn, dxc);
                }
                (dw, db)
            })
        })
        .collect();
    give(da);
    let mut dw = vec![0.0f32; f * kk];
    let mut db = vec![0.0f64; f];
    for (pw_, pb) in &partials {
        for (a, b) in dw.iter_mut().zip(pw_) {
            *a += *b;
        }
        for (a, b) in db.iter_mut().zip(pb) {
            *a += *b;
        }
    }
    BlockGrads {
        x: want_dx.then_some(dx),
        w: dw,
        bias: db.iter().map(|&v| v as f32).collect(),
        gamma: dgamma.iter().map(|&v| v as f32).collect(),
        beta: dbeta.iter().map(|&v| v as f32).collect(),
    }
}

/// The values of a flex tensor in row-major order (it must be contiguous f32, see
/// [`contiguous`]).
fn flex_slice(t: &FlexTensor) -> &[f32] {
    let n = t.layout().num_elements();
    &t.storage::<f32>()[..n]
}

/// A contiguous copy of a flex tensor (the same buffer when it already is).
fn contiguous(t: FlexTensor) -> FlexTensor {
    t.to_contiguous()
}

/// A flex tensor of `shape` holding `v`.
fn flex_tensor(v: Vec<f32>, shape: &[usize]) -> FlexTensor {
    FlexTensor::from_data(TensorData::new(v, shape.to_vec()))
}

/// The values of a flex tensor (autodiff or not) as a `Vec`.
fn values<B: burn::tensor::backend::Backend, const D: usize>(t: Tensor<B, D>) -> Vec<f32> {
    t.into_data().convert::<f32>().to_vec().expect("f32 tensor")
}

/// The block as one autodiff operation (parents: `x`, `w`, `bias`, `gamma`, `beta`).
#[derive(Debug)]
struct BlockOp;

impl Backward<Flex, 5> for BlockOp {
    type State = Arc<BlockTape>;

    fn backward(
        self,
        ops: Ops<Self::State, 5>,
        grads: &mut Gradients,
        _checkpointer: &mut Checkpointer,
    ) {
        let [nx, nw, nb, ng, nbeta] = ops.parents;
        let dout = contiguous(grads.consume::<Flex>(&ops.node));
        let t = ops.state;
        let gr = block_backward(&t, flex_slice(&dout), nx.is_some());
        let g = t.g;
        if let (Some(node), Some(dx)) = (nx, gr.x) {
            grads.register::<Flex>(node.id, flex_tensor(dx, &[g.n, g.c, g.h, g.w]));
        }
        if let Some(node) = nw {
            grads.register::<Flex>(node.id, flex_tensor(gr.w, &[g.f, g.c, g.k, g.k]));
        }
        for (node, v) in [(nb, gr.bias), (ng, gr.gamma), (nbeta, gr.beta)] {
            if let Some(node) = node {
                grads.register::<Flex>(node.id, flex_tensor(v, &[g.f]));
            }
        }
    }
}

/// A training block on `Autodiff<Flex>`: the output (a node of the autodiff graph) and the
/// batch's per-channel mean and biased variance (for the running statistics).
#[allow(clippy::too_many_arguments)]
pub fn block_train(
    g: &BlockGeom,
    x: Tensor<FlexTrain, 4>,
    w: Tensor<FlexTrain, 4>,
    bias: Tensor<FlexTrain, 1>,
    gamma: Tensor<FlexTrain, 1>,
    beta: Tensor<FlexTrain, 1>,
    eps: f64,
) -> (Tensor<FlexTrain, 4>, Vec<f32>, Vec<f32>) {
    let wv = values(w.clone().inner());
    let bv = values(bias.clone().inner());
    let gv = values(gamma.clone().inner());
    let betav = values(beta.clone().inner());
    let x = x.into_primitive().tensor();
    let (w, bias, gamma, beta) = (
        w.into_primitive().tensor(),
        bias.into_primitive().tensor(),
        gamma.into_primitive().tensor(),
        beta.into_primitive().tensor(),
    );
    let xin = contiguous(x.primitive.clone());
    let (out, tape) = block_forward_train(g, xin, &wv, &bv, &gv, &betav, eps);
    let mean: Vec<f32> = tape.mean.iter().map(|&v| v as f32).collect();
    let var: Vec<f32> = tape.var.iter().map(|&v| v as f32).collect();
    let out = flex_tensor(out, &g.out_shape());
    let nodes = [
        x.node.clone(),
        w.node.clone(),
        bias.node.clone(),
        gamma.node.clone(),
        beta.node.clone(),
    ];
    let result = match BlockOp
        .prepare::<NoCheckpointing>(nodes)
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => prep.finish(Arc::new(tape), out),
        OpsKind::UnTracked(prep) => prep.finish(out),
    };
    (
        Tensor::from_primitive(TensorPrimitive::Float(result)),
        mean,
        var,
    )
}

/// Batch normalisation with fixed statistics as one affine map per channel: `scale = gamma /
/// sqrt(var + eps)`, `shift = beta - mean scale` (in f64, rounded once to f32).
pub fn bn_affine(
    gamma: &[f32],
    beta: &[f32],
    mean: &[f32],
    var: &[f32],
    eps: f64,
) -> (Vec<f32>, Vec<f32>) {
    let scale: Vec<f32> = gamma
        .iter()
        .zip(var)
        .map(|(&gm, &v)| (f64::from(gm) / (f64::from(v) + eps).sqrt()) as f32)
        .collect();
    let shift = beta
        .iter()
        .zip(mean)
        .zip(&scale)
        .map(|((&b, &mu), &sc)| (f64::from(b) - f64::from(mu) * f64::from(sc)) as f32)
        .collect();
    (scale, shift)
}

/// An inference block on `Flex` with BN's running statistics.
#[allow(clippy::too_many_arguments)]
pub fn block_infer(
    g: &BlockGeom,
    x: Tensor<Flex, 4>,
    w: Tensor<Flex, 4>,
    bias: Tensor<Flex, 1>,
    gamma: Tensor<Flex, 1>,
    beta: Tensor<Flex, 1>,
    mean: Tensor<Flex, 1>,
    var: Tensor<Flex, 1>,
    eps: f64,
) -> Tensor<Flex, 4> {
    let (wv, bv, gv, betav, mv, vv) = (
        values(w),
        values(bias),
        values(gamma),
        values(beta),
        values(mean),
        values(var),
    );
    let x = contiguous(x.into_primitive().tensor());
    let (scale, shift) = bn_affine(&gv, &betav, &mv, &vv, eps);
    // The convolution of each chunk goes straight into normalisation, ReLU and pooling (the
    // same operations as `conv_forward` then `affine_relu_pool`, without the full-size
    // convolution output in between).
    let (p, s, f) = (g.p(), g.chunk(), g.f);
    let (ph, pw) = g.out_hw();
    let q = ph * pw;
    let xs = flex_slice(&x);
    let mut out = vec![0.0f32; g.n * f * q];
    out.par_chunks_mut(s * f * q).enumerate().for_each_init(
        || (Vec::new(), vec![0.0f32; p]),
        |(row, packed): &mut (Vec<f32>, Vec<f32>), (ci, oc)| {
            let sn = oc.len() / (f * q);
            conv_chunk(g, xs, &wv, &bv, ci * s, sn, None, |tmp, (zq, zrow)| {
                for si in 0..sn {
                    for fi in 0..f {
                        let mut zp = &tmp[(fi * sn + si) * zq..][..zq];
                        if zrow != g.ow {
                            // The convolution's rows out of the wider grid it was computed on.
                            for (dst, src) in packed.chunks_exact_mut(g.ow).zip(zp.chunks(zrow)) {
                                dst.copy_from_slice(&src[..g.ow]);
                            }
                            zp = packed;
                        }
                        let op = &mut oc[(si * f + fi) * q..][..q];
                        plane(g, &zp[..p], scale[fi], shift[fi], op, None, row);
                    }
                }
            });
        },
    );
    Tensor::from_primitive(TensorPrimitive::Float(flex_tensor(out, &g.out_shape())))
}
