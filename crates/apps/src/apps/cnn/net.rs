//! The two networks of the dissertation's chapter 5.3, exactly as Tables 18 (clutter
//! classification) and 23 (target location) list them (docs/definitions.md §12): three blocks of
//! convolution ('same' padding, MATLAB's split), batch normalisation and ReLU, max pooling
//! after the first two, a fully connected layer and softmax cross-entropy. Weights start from
//! MATLAB's defaults (Glorot-uniform weights, zero biases, BN scale 1 and offset 0), drawn from
//! a ChaCha stream so that a network is a function of its seed.
//!
//! Two forms that compute the same function faster on burn's CPU backend (`tests/cnn.rs`
//! checks them against the plain operations; throughput in BENCHMARKS.md, *CNN training*):
//! - the first convolution (2 channels, 8x8, stride 2) runs as a 4x4 stride-1 convolution on
//!   the space-to-depth input (the padded image cut into 2x2 blocks: 8 channels), with the
//!   8x8 weights rearranged to match; the input side of that rearrangement is done once per
//!   sample by [`NetConfig::prepare`], the weight side in every forward pass;
//! - batch normalisation reduces and scales on the `[N * C, H * W]` view instead of
//!   broadcasting `[1, C, 1, 1]`;
//! - on burn's `flex` backend (with or without autodiff), each convolution block (convolution,
//!   BN, ReLU, pooling) runs as one hand-written kernel with its own backward pass
//!   ([`super::fast`]); other backends run the chain of burn operations below.

use super::fast::{self, BlockGeom, FlexTrain};
use burn::backend::Flex;
use burn::module::{Module, Param, RunningState};
use burn::tensor::activation::relu;
use burn::tensor::backend::Backend;
use burn::tensor::module::{conv2d, max_pool2d};
use burn::tensor::ops::PaddedConvOptions;
use burn::tensor::{Tensor, TensorData};
use num_complex::Complex32;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha20Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::any::{Any, TypeId};

/// Batch normalisation's epsilon (MATLAB's default).
pub const BN_EPSILON: f64 = 1e-5;
/// Weight of the newest batch in the running mean and variance (MATLAB's `MeanDecay` and
/// `VarianceDecay` defaults).
pub const BN_DECAY: f64 = 0.1;

/// Which table's network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Arch {
    /// Table 18: 16, 64, 128 filters (clutter classification).
    Table18,
    /// Table 23: 64, 16, 16 filters (target location).
    Table23,
}

impl Arch {
    /// Filters of the three convolutions.
    pub fn filters(self) -> [usize; 3] {
        match self {
            Arch::Table18 => [16, 64, 128],
            Arch::Table23 => [64, 16, 16],
        }
    }
}

/// Kernel sizes of the three convolutions (both tables).
pub const KERNELS: [usize; 3] = [8, 4, 2];
/// Stride of every convolution and pooling (both tables).
pub const STRIDE: usize = 2;
/// Input channels: real and imaginary parts.
pub const CHANNELS: usize = 2;

/// MATLAB's 'same' padding for stride `s`: output `ceil(n / s)`, total padding
/// `max((out - 1) s + k - n, 0)` with the smaller half first. Returns `(out, before, after)`.
pub fn same_padding(n: usize, k: usize, s: usize) -> (usize, usize, usize) {
    let out = n.div_ceil(s);
    let total = ((out - 1) * s + k).saturating_sub(n);
    (out, total / 2, total - total / 2)
}

/// A network's geometry: architecture, image size and number of classes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetConfig {
    /// Table 18 or 23.
    pub arch: Arch,
    /// Image height.
    pub height: usize,
    /// Image width.
    pub width: usize,
    /// Number of classes (outputs of the fully connected layer).
    pub classes: usize,
}

/// One row of the layer table (Tables 18 and 23): name, activations `H x W x C` and the
/// number of learnable values.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layer {
    /// MATLAB's layer name (`conv1`, `batchnorm_1`, `relu1`, ...).
    pub name: String,
    /// Activations after the layer, `[H, W, C]` (a fully connected layer: `[1, 1, classes]`).
    pub activations: [usize; 3],
    /// Learnable values (weights and biases, or BN offset and scale).
    pub learnables: usize,
}

/// Why a geometry cannot carry the network.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NetError {
    /// The image shrinks below one pixel before the fully connected layer.
    #[error(
        "images of {height}x{width} are too small for the network: its three stride-2 convolutions and two 2x2 poolings need at least 32x32 (the receptive field of one output)"
    )]
    TooSmall {
        /// Image height.
        height: usize,
        /// Image width.
        width: usize,
    },
    /// Fewer than two classes.
    #[error("a classifier needs at least 2 classes, got {0}")]
    Classes(usize),
}

/// Side lengths through the network for an input side `n`: after conv1, pool1, conv2, pool2,
/// conv3; `None` when a pooling would meet a side of 1 or less.
fn sides(n: usize) -> Option<[usize; 5]> {
    let c1 = same_padding(n, KERNELS[0], STRIDE).0;
    let p1 = c1 / 2;
    let c2 = same_padding(p1.max(1), KERNELS[1], STRIDE).0;
    let p2 = c2 / 2;
    let c3 = same_padding(p2.max(1), KERNELS[2], STRIDE).0;
    (c1 >= 2 && c2 >= 2 && p1 >= 1 && p2 >= 1).then_some([c1, p1, c2, p2, c3])
}

impl NetConfig {
    /// Checks that the images carry the network.
    ///
    /// # Errors
    /// [`NetError`] for images smaller than 32x32 or fewer than 2 classes.
    pub fn check(&self) -> Result<(), NetError> {
        if self.classes < 2 {
            return Err(NetError::Classes(self.classes));
        }
        if self.height < 32
            || self.width < 32
            || sides(self.height).is_none()
            || sides(self.width).is_none()
        {
            return Err(NetError::TooSmall {
                height: self.height,
                width: self.width,
            });
        }
        Ok(())
    }

    /// Inputs of the fully connected layer (`H3 * W3 * C3`).
    pub fn flat(&self) -> usize {
        let (h, w) = (self.side_h()[4], self.side_w()[4]);
        h * w * self.arch.filters()[2]
    }

    fn side_h(&self) -> [usize; 5] {
        sides(self.height).expect("checked geometry")
    }

    fn side_w(&self) -> [usize; 5] {
        sides(self.width).expect("checked geometry")
    }

    /// The layer table in MATLAB's order and naming (Tables 18 and 23, without the input and
    /// output layers' rows).
    pub fn layers(&self) -> Vec<Layer> {
        let (sh, sw, f) = (self.side_h(), self.side_w(), self.arch.filters());
        let mut rows = vec![];
        let mut c_in = CHANNELS;
        for b in 0..3 {
            let (h, w) = (sh[2 * b], sw[2 * b]);
            let k = KERNELS[b];
            rows.push(Layer {
                name: format!("conv{}", b + 1),
                activations: [h, w, f[b]],
                learnables: k * k * c_in * f[b] + f[b],
            });
            rows.push(Layer {
                name: format!("batchnorm_{}", b + 1),
                activations: [h, w, f[b]],
                learnables: 2 * f[b],
            });
            rows.push(Layer {
                name: format!("relu{}", b + 1),
                activations: [h, w, f[b]],
                learnables: 0,
            });
            if b < 2 {
                rows.push(Layer {
                    name: format!("maxpool_{}", b + 1),
                    activations: [sh[2 * b + 1], sw[2 * b + 1], f[b]],
                    learnables: 0,
                });
            }
            c_in = f[b];
        }
        rows.push(Layer {
            name: "fc".into(),
            activations: [1, 1, self.classes],
            learnables: self.flat() * self.classes + self.classes,
        });
        rows
    }

    /// Learnable values in all.
    pub fn learnables(&self) -> usize {
        self.layers().iter().map(|l| l.learnables).sum()
    }

    /// Shape `[8, Hb, Wb]` of one prepared sample: the image padded for conv1 and cut into
    /// 2x2 blocks (channel `4 c + 2 p + q` holds component `c` at block offset `(p, q)`).
    pub fn prepared_shape(&self) -> [usize; 3] {
        let (_, th, bh) = same_padding(self.height, KERNELS[0], STRIDE);
        let (_, tw, bw) = same_padding(self.width, KERNELS[0], STRIDE);
        [
            4 * CHANNELS,
            (self.height + th + bh) / 2,
            (self.width + tw + bw) / 2,
        ]
    }

    /// Values of one prepared sample.
    pub fn prepared_len(&self) -> usize {
        self.prepared_shape().iter().product()
    }

    /// [`NetConfig::prepare`] of every image of `images` (`N * H * W`), one after the other
    /// (`N` times [`NetConfig::prepared_len`] values); each image on its own, on the pool's
    /// threads.
    pub fn prepare_all(&self, images: &[Complex32], mean: &[f32]) -> Vec<f32> {
        let (pixels, each) = (self.height * self.width, self.prepared_len());
        let mut values = vec![0.0f32; images.len() / pixels * each];
        values
            .par_chunks_exact_mut(each)
            .zip(images.par_chunks_exact(pixels))
            .for_each(|(out, img)| self.prepare(img, mean, out));
        values
    }

    /// Prepares one complex image (`H * W`, row-major) for the network: subtracts the
    /// 'zerocenter' mean (`2 * H * W`: real plane, then imaginary plane), pads for conv1 ('same')
    /// and rearranges into 2x2 blocks, writing [`NetConfig::prepared_len`] values into `out`.
    pub fn prepare(&self, image: &[Complex32], mean: &[f32], out: &mut [f32]) {
        let (h, w) = (self.height, self.width);
        let [_, hb, wb] = self.prepared_shape();
        let (_, top, _) = same_padding(h, KERNELS[0], STRIDE);
        let (_, left, _) = same_padding(w, KERNELS[0], STRIDE);
        out.fill(0.0);
        let mut planes = [vec![0.0f32; w], vec![0.0f32; w]];
        for i in 0..h {
            let (pi, p) = ((i + top) / 2, (i + top) % 2);
            // The row's real and imaginary planes less the mean, then every other column of
            // each into its channel: columns j with (j + left) % 2 == q go to channel
            // 4c + 2p + q at (j + left) / 2.
            let img = &image[i * w..][..w];
            let means = (&mean[i * w..][..w], &mean[h * w + i * w..][..w]);
            let [re, im] = &mut planes;
            for ((r, m), (z, (mr, mi))) in re
                .iter_mut()
                .zip(im.iter_mut())
                .zip(img.iter().zip(means.0.iter().zip(means.1)))
            {
                *r = z.re - mr;
                *m = z.im - mi;
            }
            for (c, plane) in planes.iter().enumerate() {
                for q in 0..2 {
                    let ch = 4 * c + 2 * p + q;
                    let j0 = (q + 2 - left % 2) % 2;
                    let len = (w - j0).div_ceil(2);
                    let dst = &mut out[(ch * hb + pi) * wb + (j0 + left) / 2..][..len];
                    for (o, pair) in dst.iter_mut().zip(plane[j0..].chunks(2)) {
                        *o = pair[0];
                    }
                }
            }
        }
    }

    /// A new network with MATLAB's initial values, drawn from ChaCha20 seeded with `seed`.
    pub fn init<B: Backend>(&self, seed: u64, device: &B::Device) -> Net<B> {
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        let f = self.arch.filters();
        let mut c_in = CHANNELS;
        let mut convs = vec![];
        for b in 0..3 {
            let k = KERNELS[b];
            let (fan_in, fan_out) = (k * k * c_in, k * k * f[b]);
            convs.push((
                glorot(&mut rng, [f[b], c_in, k, k], fan_in, fan_out, device),
                Param::from_tensor(Tensor::zeros([f[b]], device)),
            ));
            c_in = f[b];
        }
        let fc_w = glorot(
            &mut rng,
            [self.flat(), self.classes],
            self.flat(),
            self.classes,
            device,
        );
        let mut convs = convs.into_iter().zip(f);
        let mut next = || {
            let ((w, b), f) = convs.next().expect("three convolutions");
            (w, b, Bn::new(f, device))
        };
        let blocks = [next(), next(), next()];
        let fc_b = Param::from_tensor(Tensor::zeros([self.classes], device));
        Net::from_parts(blocks, (fc_w, fc_b), (self.height, self.width))
    }
}

/// Glorot-uniform values in `[-b, b]`, `b = sqrt(6 / (fan_in + fan_out))`, as a parameter.
fn glorot<B: Backend, const D: usize>(
    rng: &mut ChaCha20Rng,
    shape: [usize; D],
    fan_in: usize,
    fan_out: usize,
    device: &B::Device,
) -> Param<Tensor<B, D>> {
    let bound = (6.0 / (fan_in + fan_out) as f64).sqrt();
    let n: usize = shape.iter().product();
    let values: Vec<f32> = (0..n)
        .map(|_| ((rng.random::<f64>() * 2.0 - 1.0) * bound) as f32)
        .collect();
    Param::from_tensor(Tensor::from_data(TensorData::new(values, shape), device))
}

/// Batch normalisation with learnable scale and offset and running statistics (used by
/// inference), computed on the `[N * C, H * W]` view.
#[derive(Module, Debug)]
pub struct Bn<B: Backend> {
    /// Scale (MATLAB's `Scale`), initially 1.
    pub gamma: Param<Tensor<B, 1>>,
    /// Offset (MATLAB's `Offset`), initially 0.
    pub beta: Param<Tensor<B, 1>>,
    /// Running mean, for inference.
    pub running_mean: RunningState<Tensor<B, 1>>,
    /// Running (biased) variance, for inference.
    pub running_var: RunningState<Tensor<B, 1>>,
    /// Running-statistics updates so far: update `k` (from 0) gives the newest batch the
    /// weight `max(BN_DECAY, 1 / (k + 1))`, so the first updates average the batches seen
    /// instead of leaning on the initial 0 and 1 (with 30 updates, as a 100-sample training
    /// makes, 0.9^30 = 4 % of the initial variance of 1 would remain: wrong by orders of
    /// magnitude for clutter of small power).
    #[module(skip)]
    pub updates: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl<B: Backend> Bn<B> {
    /// The weight of the newest batch in the next running-statistics update (see
    /// [`Bn::updates`]), counting the update.
    pub fn next_decay(&self) -> f64 {
        let k = self
            .updates
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        BN_DECAY.max(1.0 / (k + 1) as f64)
    }

    /// A copy on another backend (values through host memory).
    pub fn to_backend<B2: Backend>(&self, device: &B2::Device) -> Bn<B2> {
        Bn {
            gamma: param(&self.gamma, device),
            beta: param(&self.beta, device),
            running_mean: RunningState::new(move_tensor(self.running_mean.value(), device)),
            running_var: RunningState::new(move_tensor(self.running_var.value(), device)),
            updates: std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(
                self.updates.load(std::sync::atomic::Ordering::Relaxed),
            )),
        }
    }

    fn new(c: usize, device: &B::Device) -> Self {
        Bn {
            gamma: Param::from_tensor(Tensor::ones([c], device)),
            beta: Param::from_tensor(Tensor::zeros([c], device)),
            running_mean: RunningState::new(Tensor::zeros([c], device)),
            running_var: RunningState::new(Tensor::ones([c], device)),
            updates: Default::default(),
        }
    }

    /// Normalises `x` (`[N, C, H, W]`): with the batch's statistics while training (and updates
    /// the running ones), with the running ones otherwise.
    pub fn forward(&self, x: Tensor<B, 4>) -> Tensor<B, 4> {
        let [n, c, h, w] = x.dims();
        let rows = x.reshape([n * c, h * w]);
        let (mean, var) = if B::ad_enabled(&rows.device()) {
            let mean = rows.clone().mean_dim(1).reshape([n, c]).mean_dim(0); // [1, C]
            let centred = rows.clone() - per_row(mean.clone(), n, c);
            let var = centred.square().mean_dim(1).reshape([n, c]).mean_dim(0); // [1, C]
            let decay = self.next_decay();
            let update = |state: &RunningState<Tensor<B, 1>>, batch: &Tensor<B, 2>| {
                let old = state.value_sync();
                let new = old.mul_scalar(1.0 - decay)
                    + batch.clone().detach().reshape([c]).mul_scalar(decay);
                state.update(new.detach());
            };
            update(&self.running_mean, &mean);
            update(&self.running_var, &var);
            (mean, var)
        } else {
            (
                self.running_mean.value().reshape([1, c]),
                self.running_var.value().reshape([1, c]),
            )
        };
        // y = x * scale + shift, scale = gamma / sqrt(var + eps), shift = beta - mean * scale.
        let scale = self.gamma.val().reshape([1, c]) / (var + BN_EPSILON).sqrt();
        let shift = self.beta.val().reshape([1, c]) - mean * scale.clone();
        (rows * per_row(scale, n, c) + per_row(shift, n, c)).reshape([n, c, h, w])
    }
}

/// A tensor's values on another backend.
fn move_tensor<B: Backend, B2: Backend, const D: usize>(
    t: Tensor<B, D>,
    device: &B2::Device,
) -> Tensor<B2, D> {
    Tensor::from_data(t.into_data(), device)
}

/// A parameter's values as a new parameter on another backend.
fn param<B: Backend, B2: Backend, const D: usize>(
    p: &Param<Tensor<B, D>>,
    device: &B2::Device,
) -> Param<Tensor<B2, D>> {
    Param::from_tensor(move_tensor(p.val(), device))
}

/// A per-channel `[1, C]` tensor as a `[N * C, 1]` column of the `[N * C, H * W]` view.
fn per_row<B: Backend>(v: Tensor<B, 2>, n: usize, c: usize) -> Tensor<B, 2> {
    v.expand([n, c]).reshape([n * c, 1])
}

/// The network of Table 18 or 23 (see [`NetConfig`]).
#[derive(Module, Debug)]
pub struct Net<B: Backend> {
    /// conv1 weights `[F1, 2, 8, 8]`.
    pub w1: Param<Tensor<B, 4>>,
    /// conv1 biases.
    pub b1: Param<Tensor<B, 1>>,
    /// batchnorm_1.
    pub bn1: Bn<B>,
    /// conv2 weights `[F2, F1, 4, 4]`.
    pub w2: Param<Tensor<B, 4>>,
    /// conv2 biases.
    pub b2: Param<Tensor<B, 1>>,
    /// batchnorm_2.
    pub bn2: Bn<B>,
    /// conv3 weights `[F3, F2, 2, 2]`.
    pub w3: Param<Tensor<B, 4>>,
    /// conv3 biases.
    pub b3: Param<Tensor<B, 1>>,
    /// batchnorm_3.
    pub bn3: Bn<B>,
    /// Fully connected weights `[H3 * W3 * F3, classes]` (input index in `C, H, W` order).
    pub fc_w: Param<Tensor<B, 2>>,
    /// Fully connected biases.
    pub fc_b: Param<Tensor<B, 1>>,
    /// Image height the network was built for.
    pub height: usize,
    /// Image width the network was built for.
    pub width: usize,
}

/// One convolution block's parameters: weights, biases and its batch normalisation.
pub type BlockParams<B> = (Param<Tensor<B, 4>>, Param<Tensor<B, 1>>, Bn<B>);

impl<B: Backend> Net<B> {
    /// The network of the three blocks' parameters (conv1 to conv3), the fully connected
    /// layer's weights and biases, for images of `height` x `width`.
    pub fn from_parts(
        [(w1, b1, bn1), (w2, b2, bn2), (w3, b3, bn3)]: [BlockParams<B>; 3],
        (fc_w, fc_b): (Param<Tensor<B, 2>>, Param<Tensor<B, 1>>),
        (height, width): (usize, usize),
    ) -> Net<B> {
        Net {
            w1,
            b1,
            bn1,
            w2,
            b2,
            bn2,
            w3,
            b3,
            bn3,
            fc_w,
            fc_b,
            height,
            width,
        }
    }

    /// A copy on another backend (values through host memory), e.g. a network trained on a
    /// GPU for prediction on the CPU.
    pub fn to_backend<B2: Backend>(&self, device: &B2::Device) -> Net<B2> {
        Net {
            w1: param(&self.w1, device),
            b1: param(&self.b1, device),
            bn1: self.bn1.to_backend(device),
            w2: param(&self.w2, device),
            b2: param(&self.b2, device),
            bn2: self.bn2.to_backend(device),
            w3: param(&self.w3, device),
            b3: param(&self.b3, device),
            bn3: self.bn3.to_backend(device),
            fc_w: param(&self.fc_w, device),
            fc_b: param(&self.fc_b, device),
            height: self.height,
            width: self.width,
        }
    }

    /// Class scores (before softmax), `[N, classes]`, of prepared inputs `[N, 8, Hb, Wb]`
    /// ([`NetConfig::prepare`]).
    pub fn forward(&self, x: Tensor<B, 4>) -> Tensor<B, 4> {
        let x = self.block1(x);
        let x = self.block(x, &self.w2, &self.b2, &self.bn2, KERNELS[1], true);
        self.block(x, &self.w3, &self.b3, &self.bn3, KERNELS[2], false)
    }

    /// Class scores `[N, classes]` of prepared inputs.
    pub fn logits(&self, x: Tensor<B, 4>) -> Tensor<B, 2> {
        let features = self.forward(x);
        let [n, c, h, w] = features.dims();
        features.reshape([n, c * h * w]).matmul(self.fc_w.val()) + self.fc_b.val().unsqueeze_dim(0)
    }

    /// conv1's output (with bias, before BN) for prepared inputs, computed in its
    /// space-to-depth form: the 8x8 stride-2 kernels `[F, 2, 8, 8]` rearranged into 4x4
    /// stride-1 kernels over the 8 block channels.
    pub fn conv1_output(&self, x: Tensor<B, 4>) -> Tensor<B, 4> {
        let opts = PaddedConvOptions::asymmetric([1, 1], [0, 0], [0, 0], [1, 1], 1);
        conv2d(x, self.w1_blocks(), Some(self.b1.val()), opts)
    }

    /// conv1's weights `[F, 2, 8, 8]` as 4x4 kernels over the 8 block channels.
    fn w1_blocks(&self) -> Tensor<B, 4> {
        let w = self.w1.val();
        let [f, c, k, _] = w.dims();
        let w: Tensor<B, 6> = w.reshape([f, c, k / 2, 2, k / 2, 2]);
        w.permute([0, 1, 3, 5, 2, 4])
            .reshape([f, 4 * c, k / 2, k / 2])
    }

    /// conv1, BN, ReLU and pooling.
    fn block1(&self, x: Tensor<B, 4>) -> Tensor<B, 4> {
        let [n, c, h, w] = x.dims();
        let w1 = self.w1_blocks();
        let k = w1.dims()[2];
        let g = BlockGeom {
            n,
            c,
            h,
            w,
            f: w1.dims()[0],
            k,
            stride: 1,
            top: 0,
            left: 0,
            oh: h + 1 - k,
            ow: w + 1 - k,
            pool: true,
        };
        match self.fast_block(&g, x, w1, &self.b1, &self.bn1) {
            Ok(y) => y,
            Err((x, _)) => {
                let y = self.conv1_output(x);
                let y = relu(self.bn1.forward(y));
                max_pool2d(y, [2, 2], [2, 2], [0, 0], [1, 1], false)
            }
        }
    }

    /// The block `g` through [`fast`] when `B` is flex (with or without autodiff); gives `x`
    /// and `w` back otherwise.
    #[allow(clippy::type_complexity)]
    fn fast_block(
        &self,
        g: &BlockGeom,
        x: Tensor<B, 4>,
        w: Tensor<B, 4>,
        b: &Param<Tensor<B, 1>>,
        bn: &Bn<B>,
    ) -> Result<Tensor<B, 4>, (Tensor<B, 4>, Tensor<B, 4>)> {
        if TypeId::of::<B>() == TypeId::of::<FlexTrain>() {
            let device = x.device();
            let (y, mean, var) = fast::block_train(
                g,
                cast(x),
                cast(w),
                cast(b.val()),
                cast(bn.gamma.val()),
                cast(bn.beta.val()),
                BN_EPSILON,
            );
            let c = g.f;
            let decay = bn.next_decay();
            let update = |state: &RunningState<Tensor<B, 1>>, batch: Vec<f32>| {
                let old = state.value_sync();
                let batch = Tensor::<B, 1>::from_data(TensorData::new(batch, [c]), &device);
                let new = old.mul_scalar(1.0 - decay) + batch.mul_scalar(decay);
                state.update(new.detach());
            };
            update(&bn.running_mean, mean);
            update(&bn.running_var, var);
            Ok(cast(y))
        } else if TypeId::of::<B>() == TypeId::of::<Flex>() {
            let y = fast::block_infer(
                g,
                cast(x),
                cast(w),
                cast(b.val()),
                cast(bn.gamma.val()),
                cast(bn.beta.val()),
                cast(bn.running_mean.value()),
                cast(bn.running_var.value()),
                BN_EPSILON,
            );
            Ok(cast(y))
        } else {
            Err((x, w))
        }
    }

    /// A convolution block: 'same' stride-2 convolution, BN, ReLU and (if `pool`) 2x2 max
    /// pooling.
    fn block(
        &self,
        x: Tensor<B, 4>,
        w: &Param<Tensor<B, 4>>,
        b: &Param<Tensor<B, 1>>,
        bn: &Bn<B>,
        k: usize,
        pool: bool,
    ) -> Tensor<B, 4> {
        let [n, c, h, wd] = x.dims();
        let (oh, top, bottom) = same_padding(h, k, STRIDE);
        let (ow, left, right) = same_padding(wd, k, STRIDE);
        let g = BlockGeom {
            n,
            c,
            h,
            w: wd,
            f: w.dims()[0],
            k,
            stride: STRIDE,
            top,
            left,
            oh,
            ow,
            pool,
        };
        let x = match self.fast_block(&g, x, w.val(), b, bn) {
            Ok(y) => return y,
            Err((x, _)) => x,
        };
        let opts = PaddedConvOptions::asymmetric(
            [STRIDE, STRIDE],
            [top, left],
            [bottom, right],
            [1, 1],
            1,
        );
        let y = relu(bn.forward(conv2d(x, w.val(), Some(b.val()), opts)));
        if pool {
            max_pool2d(y, [2, 2], [2, 2], [0, 0], [1, 1], false)
        } else {
            y
        }
    }
}

/// `t` as the type `U`, which it is (checked by the caller through `TypeId`).
fn cast<T: 'static, U: 'static>(t: T) -> U {
    let mut slot = Some(t);
    (&mut slot as &mut dyn Any)
        .downcast_mut::<Option<U>>()
        .and_then(Option::take)
        .expect("the same type")
}
