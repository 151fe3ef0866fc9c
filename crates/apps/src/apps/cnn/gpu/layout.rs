//! Where things lie in the cuDNN route: each block's geometry ([`BlockGeom`]: the prepared space-to-depth
//! input of [`NetConfig::prepare`], conv1 as a 4x4 stride-1 convolution over its 8 channels as
//! on the CPU, MATLAB's 'same' padding of conv2 and conv3, done by cuDNN when it is even and by
//! an explicit pad otherwise), the one flat buffer that holds every learnable value (so that
//! one SGD kernel updates them all), and the moves of a [`Net`] into that buffer and back.

use crate::apps::cnn::geom::BlockGeom;
use crate::apps::cnn::net::{same_padding, Bn, Net, NetConfig, KERNELS, STRIDE};
use burn::module::{Param, RunningState};
use burn::tensor::backend::Backend;
use burn::tensor::{Tensor, TensorData};
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;

/// The network's geometry on the device.
#[derive(Debug, Clone, Copy)]
pub(super) struct Geometry {
    /// Per block (`n` unused: each pass has its own).
    pub blocks: [BlockGeom; 3],
    pub classes: usize,
    /// Values of one prepared input sample.
    pub each: usize,
}

impl Geometry {
    /// The geometry of `cfg`'s network (a checked configuration).
    pub fn new(cfg: &NetConfig) -> Self {
        let [c0, hb, wb] = cfg.prepared_shape();
        let f = cfg.arch.filters();
        let b1 = BlockGeom {
            n: 0,
            c: c0,
            h: hb,
            w: wb,
            f: f[0],
            k: KERNELS[0] / 2,
            stride: 1,
            top: 0,
            left: 0,
            oh: hb + 1 - KERNELS[0] / 2,
            ow: wb + 1 - KERNELS[0] / 2,
            pool: true,
        };
        let next = |prev: &BlockGeom, b: usize| {
            let (h, w) = prev.out_hw();
            let (oh, top, _) = same_padding(h, KERNELS[b], STRIDE);
            let (ow, left, _) = same_padding(w, KERNELS[b], STRIDE);
            BlockGeom {
                n: 0,
                c: prev.f,
                h,
                w,
                f: f[b],
                k: KERNELS[b],
                stride: STRIDE,
                top,
                left,
                oh,
                ow,
                pool: b < 2,
            }
        };
        let b2 = next(&b1, 1);
        let b3 = next(&b2, 2);
        Geometry {
            blocks: [b1, b2, b3],
            classes: cfg.classes,
            each: cfg.prepared_len(),
        }
    }
}

/// Offsets (in floats) of the learnable values in the flat buffer, each aligned to 64 floats
/// (256 bytes, as cuDNN's fastest paths want).
#[derive(Debug, Clone, Copy)]
pub(super) struct Params {
    /// Per block: weights, bias, BN scale, BN offset.
    pub block: [[usize; 4]; 3],
    /// Fully connected weights (as a filter `[classes, F3, H3, W3]`) and biases.
    pub fc: [usize; 2],
    /// Floats in all.
    pub len: usize,
    /// Per block: running mean and running variance (in the separate running buffer).
    pub running: [[usize; 2]; 3],
    /// Floats of the running buffer.
    pub running_len: usize,
}

fn align(n: usize) -> usize {
    n.div_ceil(64) * 64
}

impl Params {
    /// The layout for `g`.
    pub fn new(g: &Geometry) -> Self {
        let mut at = 0;
        let mut take = |n: usize| {
            let o = at;
            at += align(n);
            o
        };
        let mut block = [[0; 4]; 3];
        for (b, o) in g.blocks.iter().zip(block.iter_mut()) {
            *o = [take(b.f * b.c * b.k * b.k), take(b.f), take(b.f), take(b.f)];
        }
        let b3 = g.blocks[2];
        let fc = [take(g.classes * b3.f * b3.oh * b3.ow), take(g.classes)];
        let len = at;
        let mut at = 0;
        let mut running = [[0; 2]; 3];
        for (b, o) in g.blocks.iter().zip(running.iter_mut()) {
            *o = [at, at + align(b.f)];
            at += 2 * align(b.f);
        }
        Params {
            block,
            fc,
            len,
            running,
            running_len: at,
        }
    }
}

fn values<B: Backend, const D: usize>(p: &Param<Tensor<B, D>>) -> Vec<f32> {
    p.val()
        .into_data()
        .convert::<f32>()
        .to_vec()
        .expect("f32 values")
}

fn state<B: Backend>(s: &RunningState<Tensor<B, 1>>) -> Vec<f32> {
    s.value()
        .into_data()
        .convert::<f32>()
        .to_vec()
        .expect("f32 values")
}

/// Where each of conv1's `[F, 2, 8, 8]` weights goes among the 4x4 kernels over the 8 block
/// channels (`[F, 8, 4, 4]`, channel `4 c + 2 p + q`, position `(i, j)` = row `2 i + p`,
/// column `2 j + q`), as the CPU's space-to-depth form rearranges them: pairs of (index in
/// the `[F, 2, 8, 8]` array, index in the `[F, 8, 4, 4]` one).
fn w1_blocks(f: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..f * 2 * 64).map(|plain| {
        let (o, c, r, col) = (plain / 128, plain / 64 % 2, plain / 8 % 8, plain % 8);
        let (i, p, j, q) = (r / 2, r % 2, col / 2, col % 2);
        (plain, ((o * 8 + 4 * c + 2 * p + q) * 4 + i) * 4 + j)
    })
}

/// conv1's `[F, 2, 8, 8]` weights in the `[F, 8, 4, 4]` layout ([`w1_blocks`]).
fn w1_to_blocks(w: &[f32], f: usize) -> Vec<f32> {
    let mut out = vec![0.0; w.len()];
    for (plain, blocked) in w1_blocks(f) {
        out[blocked] = w[plain];
    }
    out
}

/// The inverse of [`w1_to_blocks`].
fn w1_from_blocks(b: &[f32], f: usize) -> Vec<f32> {
    let mut out = vec![0.0; b.len()];
    for (plain, blocked) in w1_blocks(f) {
        out[plain] = b[blocked];
    }
    out
}

/// The fully connected `[flat, classes]` weights as the filter `[classes, flat]` and back
/// (a transpose; `flat` in `C, H, W` order on both sides).
fn transpose(v: &[f32], rows: usize, cols: usize) -> Vec<f32> {
    let mut out = vec![0.0; v.len()];
    for r in 0..rows {
        for c in 0..cols {
            out[c * rows + r] = v[r * cols + c];
        }
    }
    out
}

/// A convolution block's weights, biases and batch normalisation.
type ConvParts<'a, B> = (&'a Param<Tensor<B, 4>>, &'a Param<Tensor<B, 1>>, &'a Bn<B>);

/// The learnable values and running statistics of `net` in the device layout.
pub(super) fn flatten<B: Backend>(net: &Net<B>, g: &Geometry, p: &Params) -> (Vec<f32>, Vec<f32>) {
    let mut flat = vec![0.0f32; p.len];
    let mut run = vec![0.0f32; p.running_len];
    let put = |dst: &mut [f32], at: usize, v: &[f32]| dst[at..at + v.len()].copy_from_slice(v);
    let parts: [ConvParts<'_, B>; 3] = [
        (&net.w1, &net.b1, &net.bn1),
        (&net.w2, &net.b2, &net.bn2),
        (&net.w3, &net.b3, &net.bn3),
    ];
    for (b, (w, bias, bn)) in parts.iter().enumerate() {
        let mut wv = values(w);
        if b == 0 {
            wv = w1_to_blocks(&wv, g.blocks[0].f);
        }
        let o = p.block[b];
        put(&mut flat, o[0], &wv);
        put(&mut flat, o[1], &values(bias));
        put(&mut flat, o[2], &values(&bn.gamma));
        put(&mut flat, o[3], &values(&bn.beta));
        put(&mut run, p.running[b][0], &state(&bn.running_mean));
        put(&mut run, p.running[b][1], &state(&bn.running_var));
    }
    let fc = values(&net.fc_w);
    let rows = fc.len() / g.classes;
    put(&mut flat, p.fc[0], &transpose(&fc, rows, g.classes));
    put(&mut flat, p.fc[1], &values(&net.fc_b));
    (flat, run)
}

/// A network on backend `B` from the device layout's values, its BN layers having made
/// `updates` running-statistics updates.
pub(super) fn unflatten<B: Backend>(
    cfg: &NetConfig,
    g: &Geometry,
    p: &Params,
    flat: &[f32],
    run: &[f32],
    updates: usize,
    device: &B::Device,
) -> Net<B> {
    let t1 = |v: &[f32]| Tensor::<B, 1>::from_data(TensorData::new(v.to_vec(), [v.len()]), device);
    let conv = |b: usize| {
        let blk = g.blocks[b];
        let o = p.block[b];
        let n = blk.f * blk.c * blk.k * blk.k;
        let mut w = flat[o[0]..o[0] + n].to_vec();
        let shape = if b == 0 {
            w = w1_from_blocks(&w, blk.f);
            [blk.f, 2, KERNELS[0], KERNELS[0]]
        } else {
            [blk.f, blk.c, blk.k, blk.k]
        };
        let w = Param::from_tensor(Tensor::<B, 4>::from_data(TensorData::new(w, shape), device));
        let bias = Param::from_tensor(t1(&flat[o[1]..o[1] + blk.f]));
        let bn = Bn {
            gamma: Param::from_tensor(t1(&flat[o[2]..o[2] + blk.f])),
            beta: Param::from_tensor(t1(&flat[o[3]..o[3] + blk.f])),
            running_mean: RunningState::new(t1(&run[p.running[b][0]..][..blk.f])),
            running_var: RunningState::new(t1(&run[p.running[b][1]..][..blk.f])),
            updates: Arc::new(AtomicUsize::new(updates)),
        };
        (w, bias, bn)
    };
    let blocks = [conv(0), conv(1), conv(2)];
    let b3g = g.blocks[2];
    let rows = b3g.f * b3g.oh * b3g.ow;
    let fc = transpose(&flat[p.fc[0]..p.fc[0] + rows * g.classes], g.classes, rows);
    let fc_w = Param::from_tensor(Tensor::<B, 2>::from_data(
        TensorData::new(fc, [rows, g.classes]),
        device,
    ));
    let fc_b = Param::from_tensor(t1(&flat[p.fc[1]..p.fc[1] + g.classes]));
    Net::from_parts(blocks, (fc_w, fc_b), (cfg.height, cfg.width))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::apps::cnn::net::Arch;
    use crate::apps::cnn::train::Cpu;

    /// The device layout holds every value of a network once: there and back gives the same
    /// network, and the rearranged conv1 computes what the CPU's does (its channels and
    /// positions are those of [`Net::conv1_output`]'s rearrangement).
    #[test]
    fn a_network_goes_into_the_device_layout_and_back_unchanged() {
        for (arch, h, w) in [(Arch::Table18, 64, 64), (Arch::Table23, 48, 64)] {
            let cfg = NetConfig {
                arch,
                height: h,
                width: w,
                classes: 5,
            };
            let net: Net<Cpu> = cfg.init(3, &Default::default());
            let g = Geometry::new(&cfg);
            let p = Params::new(&g);
            let (flat, run) = flatten(&net, &g, &p);
            let back: Net<Cpu> = unflatten(&cfg, &g, &p, &flat, &run, 0, &Default::default());
            for (a, b) in [
                (values(&net.w1), values(&back.w1)),
                (values(&net.w3), values(&back.w3)),
                (values(&net.fc_w), values(&back.fc_w)),
                (values(&net.bn2.gamma), values(&back.bn2.gamma)),
            ] {
                assert_eq!(a, b);
            }
            // The rearrangement is burn's reshape/permute of `Net::w1_blocks`.
            let w = net.w1.val();
            let [f, c, k, _] = w.dims();
            let blocks: Tensor<Cpu, 6> = w.reshape([f, c, k / 2, 2, k / 2, 2]);
            let blocks: Vec<f32> = blocks
                .permute([0, 1, 3, 5, 2, 4])
                .reshape([f, 4 * c, k / 2, k / 2])
                .into_data()
                .to_vec()
                .unwrap();
            assert_eq!(blocks, flat[p.block[0][0]..][..blocks.len()]);
            // The fully connected layer's filter input sizes add up.
            let b3 = g.blocks[2];
            assert_eq!(b3.f * b3.oh * b3.ow, cfg.flat());
        }
    }

    /// Uneven 'same' padding is where it falls: a 48-wide image's conv3 pads one column after.
    #[test]
    fn uneven_padding_is_found() {
        let cfg = NetConfig {
            arch: Arch::Table18,
            height: 64,
            width: 48,
            classes: 4,
        };
        let g = Geometry::new(&cfg);
        assert!(!g.blocks[1].uneven());
        assert!(g.blocks[2].uneven());
        let b3 = g.blocks[2];
        assert_eq!((b3.left, b3.padded_hw().1 - b3.w), (0, 1));
        assert_eq!(b3.padded_hw().0 - b3.h, 2 * b3.top);
        assert_eq!(g.blocks[0].oh, 32);
    }
}
