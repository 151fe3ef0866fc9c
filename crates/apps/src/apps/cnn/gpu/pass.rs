//! The network on the GPU: its learnable values, gradients and momentum in three flat buffers
//! (one SGD kernel updates them all), and a [`Pass`] for a fixed number of samples holding the
//! cuDNN descriptors and every activation: a training step (gather, forward with the batch's
//! statistics, softmax cross-entropy, backward, SGDM, counters) issued on one stream without a
//! host synchronisation, so that it can be captured as a CUDA graph, and prediction (the
//! running statistics) writing the classes to device memory.

mod block;

use super::dnn::{Conv, ConvShape, Handle, Pool, Relu, Tensor};
use super::kernels::{blocks, grid, launch, Kernels, THREADS};
use super::layout::{Geometry, Params};
use crate::apps::cnn::geom::BlockGeom;
use anyhow::{Context, Result};
use cudarc::driver::{CudaSlice, CudaStream, DevicePtr, PushKernelArg};
use std::sync::Arc;

/// A device buffer and its address.
pub(super) struct Buf<T> {
    _slice: CudaSlice<T>,
    /// Device address.
    pub ptr: u64,
    /// Elements.
    pub len: usize,
}

impl<T: cudarc::driver::DeviceRepr + cudarc::driver::ValidAsZeroBits> Buf<T> {
    /// `len` zeros (at least one element, so that the address is valid).
    pub fn zeros(stream: &Arc<CudaStream>, len: usize) -> Result<Self> {
        let slice = stream
            .alloc_zeros::<T>(len.max(1))
            .with_context(|| format!("allocating {len} values on the GPU"))?;
        let ptr = slice.device_ptr(stream).0;
        Ok(Buf {
            _slice: slice,
            ptr,
            len,
        })
    }

    /// A copy of `v`.
    pub fn from(stream: &Arc<CudaStream>, v: &[T]) -> Result<Self> {
        if v.is_empty() {
            return Self::zeros(stream, 0);
        }
        let slice = stream
            .clone_htod(v)
            .with_context(|| format!("copying {} values to the GPU", v.len()))?;
        let ptr = slice.device_ptr(stream).0;
        Ok(Buf {
            _slice: slice,
            ptr,
            len: v.len(),
        })
    }

    /// The values back on the host (waits for the stream).
    pub fn read(&self, stream: &Arc<CudaStream>) -> Result<Vec<T>> {
        stream
            .clone_dtoh(&self._slice)
            .context("copying values from the GPU")
            .map(|mut v| {
                v.truncate(self.len);
                v
            })
    }

    /// Overwrites the first `v.len()` values.
    pub fn write(&mut self, stream: &Arc<CudaStream>, v: &[T]) -> Result<()> {
        let mut view = self._slice.slice_mut(0..v.len());
        stream
            .memcpy_htod(v, &mut view)
            .context("copying values to the GPU")
    }
}

/// The float offset `at` of `b` as an address.
fn at(b: &Buf<f32>, at: usize) -> u64 {
    b.ptr + 4 * at as u64
}

/// One block's descriptors and activations for `n` samples.
struct BlockPass {
    g: BlockGeom,
    conv: Conv,
    /// The pooled output `[n, F, oh/2, ow/2]`.
    pooled: Option<Tensor>,
    padded: Option<Buf<f32>>,
    conv_out: Buf<f32>,
    bn_out: Buf<f32>,
    relu_out: Buf<f32>,
    pool_out: Option<Buf<f32>>,
    saved_mean: Buf<f32>,
    saved_inv: Buf<f32>,
    /// Training only: chunks of the running statistics' sums and their partial sums.
    parts: usize,
    partial: Option<Buf<f64>>,
    /// Training only: gradients of the convolution's output size, of the block's output and of
    /// the padded input.
    d_a: Option<Buf<f32>>,
    d_b: Option<Buf<f32>>,
    d_out: Option<Buf<f32>>,
    d_padded: Option<Buf<f32>>,
}

impl BlockPass {
    fn new(
        stream: &Arc<CudaStream>,
        h: &Handle,
        g: BlockGeom,
        n: usize,
        train: bool,
        (tf32, find): (bool, bool),
    ) -> Result<Self> {
        let pad = g.uneven();
        let (ih, iw) = if pad { g.padded_hw() } else { (g.h, g.w) };
        let shape = ConvShape {
            n,
            c: g.c,
            h: ih,
            w: iw,
            k: g.f,
            r: g.k,
            s: g.k,
            stride: g.stride,
            pad_h: if pad { 0 } else { g.top },
            pad_w: if pad { 0 } else { g.left },
        };
        anyhow::ensure!(
            shape.out() == (g.oh, g.ow),
            "cuDNN's convolution gives {:?}, the network {:?}",
            shape.out(),
            (g.oh, g.ow)
        );
        let conv = Conv::new(h, shape, tf32, train, find)?;
        let out = n * g.f * g.oh * g.ow;
        // Chunks of about 4096 values for the running statistics' sums.
        let parts = (n * g.oh * g.ow).div_ceil(4096).clamp(1, 256);
        let (ph, pw) = g.out_hw();
        let pooled_len = n * g.f * ph * pw;
        let z = |len: usize| Buf::<f32>::zeros(stream, len);
        let opt = |on: bool, len: usize| on.then(|| z(len)).transpose();
        Ok(BlockPass {
            g,
            pooled: g.pool.then(|| Tensor::new(n, g.f, ph, pw)).transpose()?,
            padded: opt(pad, n * g.c * ih * iw)?,
            conv_out: z(out)?,
            bn_out: z(out)?,
            relu_out: z(out)?,
            pool_out: opt(g.pool, pooled_len)?,
            saved_mean: z(g.f)?,
            saved_inv: z(g.f)?,
            parts,
            partial: train
                .then(|| Buf::<f64>::zeros(stream, 2 * g.f * parts))
                .transpose()?,
            d_a: opt(train, out)?,
            d_b: opt(train, out)?,
            d_out: opt(train, pooled_len)?,
            d_padded: opt(train && pad, n * g.c * ih * iw)?,
            conv,
        })
    }

    /// The block's output (pooled, or the ReLU's).
    fn output(&self) -> u64 {
        self.pool_out.as_ref().unwrap_or(&self.relu_out).ptr
    }
}

/// Descriptors and activations for `n` samples through the network.
pub(super) struct Pass {
    /// Samples.
    pub n: usize,
    blocks: Vec<BlockPass>,
    fc: Conv,
    logits: Buf<f32>,
    /// Training only: the gathered mini-batch, its labels and the loss's gradient.
    x: Option<Buf<f32>>,
    labels: Option<Buf<u32>>,
    dlogits: Option<Buf<f32>>,
}

impl Pass {
    /// A pass of `n` samples (`train`: with the buffers of the backward pass; `tf32`, `find`:
    /// see [`Conv::new`]).
    pub fn new(
        stream: &Arc<CudaStream>,
        h: &Handle,
        g: &Geometry,
        n: usize,
        train: bool,
        (tf32, find): (bool, bool),
    ) -> Result<Self> {
        let blocks = g
            .blocks
            .iter()
            .map(|&b| BlockPass::new(stream, h, b, n, train, (tf32, find)))
            .collect::<Result<Vec<_>>>()?;
        let b3 = g.blocks[2];
        let fc = Conv::new(
            h,
            ConvShape {
                n,
                c: b3.f,
                h: b3.oh,
                w: b3.ow,
                k: g.classes,
                r: b3.oh,
                s: b3.ow,
                stride: 1,
                pad_h: 0,
                pad_w: 0,
            },
            tf32,
            train,
            find,
        )?;
        let z = |len: usize| Buf::<f32>::zeros(stream, len);
        let opt = |len: usize| train.then(|| z(len)).transpose();
        Ok(Pass {
            n,
            blocks,
            fc,
            logits: z(n * g.classes)?,
            x: opt(n * g.each)?,
            labels: train.then(|| Buf::<u32>::zeros(stream, n)).transpose()?,
            dlogits: opt(n * g.classes)?,
        })
    }

    /// Workspace bytes its convolutions need.
    pub fn workspace(&self) -> usize {
        self.blocks
            .iter()
            .map(|b| b.conv.workspace)
            .chain([self.fc.workspace])
            .max()
            .unwrap_or(0)
    }
}

/// The network on the device and what its passes share.
pub(super) struct DeviceNet {
    pub stream: Arc<CudaStream>,
    pub handle: Handle,
    pub k: Kernels,
    relu: Relu,
    pool: Pool,
    pub g: Geometry,
    pub p: Params,
    pub params: Buf<f32>,
    pub grads: Buf<f32>,
    pub velocity: Buf<f32>,
    pub running: Buf<f32>,
    /// `[step, step of the epoch]`.
    pub ctr: Buf<u32>,
    workspace: Buf<u8>,
}

/// SGD's settings.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sgd {
    pub lr: f32,
    pub momentum: f32,
    pub l2: f32,
}

/// Where a training step finds its data: the set staged on the device, the epoch's order and
/// the per-step record.
pub(super) struct StepData {
    pub set: u64,
    pub labels: u64,
    pub order: u64,
    pub stats: u64,
}

impl DeviceNet {
    /// The network with values `flat` and running statistics `running` (the layout of `p`).
    pub fn new(
        stream: Arc<CudaStream>,
        k: Kernels,
        g: Geometry,
        p: Params,
        flat: &[f32],
        running: &[f32],
    ) -> Result<Self> {
        let handle = Handle::new(stream.cu_stream() as _)?;
        Ok(DeviceNet {
            params: Buf::from(&stream, flat)?,
            grads: Buf::zeros(&stream, p.len)?,
            velocity: Buf::zeros(&stream, p.len)?,
            running: Buf::from(&stream, running)?,
            ctr: Buf::zeros(&stream, 2)?,
            workspace: Buf::zeros(&stream, 0)?,
            relu: Relu::new()?,
            pool: Pool::new()?,
            handle,
            k,
            g,
            p,
            stream,
        })
    }

    /// A pass of `n` samples (`math`: TF32 allowed, algorithms by measurement), the shared
    /// workspace grown to what it needs.
    pub fn pass(&mut self, n: usize, train: bool, math: (bool, bool)) -> Result<Pass> {
        let pass = Pass::new(&self.stream, &self.handle, &self.g, n, train, math)?;
        if pass.workspace() > self.workspace.len {
            self.workspace = Buf::zeros(&self.stream, pass.workspace())?;
        }
        Ok(pass)
    }

    /// The forward pass of `x` (`[n, 8, Hb, Wb]` at that address) to the logits: with the
    /// batch's statistics (and the running ones updated) when `train`, else the running ones.
    fn forward(&self, pass: &Pass, x: u64, train: bool) -> Result<()> {
        let h = &self.handle;
        let (ws, ws_len) = (self.workspace.ptr, self.workspace.len);
        let mut input = x;
        for b in 0..pass.blocks.len() {
            input = self.forward_block(pass, b, input, train)?;
        }
        let [fw, fb] = self.p.fc.map(|o| at(&self.params, o));
        // SAFETY: as above; the logits are `[n, classes, 1, 1]`.
        unsafe {
            pass.fc
                .forward(h, input, fw, fb, pass.logits.ptr, ws, ws_len)
        }
    }

    /// One training step on `pass`: the epoch's mini-batch `ctr[1]` gathered from `data`,
    /// forward, loss, backward, the SGDM update and the counters; nothing waits for the host.
    pub fn step(&self, pass: &Pass, data: &StepData, sgd: Sgd) -> Result<()> {
        let st = &self.stream;
        let (x, y) = (
            pass.x.as_ref().context("a training pass")?,
            pass.labels.as_ref().context("a training pass")?,
        );
        let (n, each, classes) = (pass.n as u32, self.g.each as u32, self.g.classes as u32);
        launch!(
            st,
            self.k.gather,
            grid(x.len),
            data.set,
            data.labels,
            data.order,
            self.ctr.ptr,
            n,
            each,
            x.ptr,
            y.ptr
        )?;
        self.forward(pass, x.ptr, true)?;
        let dl = pass.dlogits.as_ref().context("training")?;
        launch!(
            st,
            self.k.softmax_ce,
            blocks(1),
            pass.logits.ptr,
            y.ptr,
            n,
            classes,
            dl.ptr,
            data.stats,
            self.ctr.ptr
        )?;
        self.backward(pass, dl.ptr)?;
        let len = self.p.len as u32;
        launch!(
            st,
            self.k.sgdm,
            grid(self.p.len),
            self.params.ptr,
            self.grads.ptr,
            self.velocity.ptr,
            len,
            sgd.lr,
            sgd.momentum,
            sgd.l2
        )?;
        launch!(st, self.k.tick, blocks(1).with_threads(1), self.ctr.ptr)
    }

    /// The gradients of every learnable value from the loss's gradient `dlogits`.
    fn backward(&self, pass: &Pass, dlogits: u64) -> Result<()> {
        let h = &self.handle;
        let (ws, ws_len) = (self.workspace.ptr, self.workspace.len);
        let fw = at(&self.params, self.p.fc[0]);
        let [dfw, dfb] = self.p.fc.map(|o| at(&self.grads, o));
        let last = pass.blocks.last().context("three blocks")?;
        let d_last = last.d_out.as_ref().context("training")?.ptr;
        // SAFETY: buffers of the descriptors' shapes, as in `forward`.
        unsafe {
            pass.fc
                .backward_weights(h, last.output(), dlogits, dfw, dfb, ws, ws_len)?;
            pass.fc.backward_data(h, fw, dlogits, d_last, ws, ws_len)?;
        }
        for b in (0..pass.blocks.len()).rev() {
            self.backward_block(pass, b)?;
        }
        Ok(())
    }

    /// Predicted classes of `pass.n` prepared samples at `x` into `pred[offset..]`.
    pub fn predict(&self, pass: &Pass, x: u64, pred: u64, offset: usize) -> Result<()> {
        self.forward(pass, x, false)?;
        let (n, classes) = (pass.n as u32, self.g.classes as u32);
        launch!(
            &self.stream,
            self.k.argmax,
            grid(pass.n),
            pass.logits.ptr,
            n,
            classes,
            pred,
            offset as u32
        )
    }
}

/// A launch configuration with `threads` threads in its one block.
trait WithThreads {
    fn with_threads(self, threads: u32) -> Self;
}

impl WithThreads for cudarc::driver::LaunchConfig {
    fn with_threads(mut self, threads: u32) -> Self {
        self.block_dim = (threads.min(THREADS), 1, 1);
        self
    }
}
