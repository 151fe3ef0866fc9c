//! The small CUDA kernels of the cuDNN route, compiled at run time by NVRTC: the mini-batch
//! gather from the training set staged on the device, explicit zero padding (cuDNN pads only
//! symmetrically; MATLAB's 'same' split can be uneven), batch normalisation's running
//! statistics (MATLAB's decay schedule, biased variance, as [`crate::apps::cnn::net::Bn`]),
//! softmax cross-entropy with its gradient and the step's loss and hits, arg-max and hit counts
//! for prediction, the SGD-with-momentum update, and the step counters. Every kernel reads the
//! step from device memory, so a captured CUDA graph replays them unchanged step after step.
//! Reductions are in a fixed order (one block, a fixed tree), so a training is deterministic.

use anyhow::{Context, Result};
use cudarc::driver::{CudaContext, CudaFunction, LaunchConfig};
use std::sync::{Arc, OnceLock};

/// Threads of a block (a power of two: the tree reductions halve it).
pub(super) const THREADS: u32 = 256;

const SOURCE: &str = r#"
typedef unsigned long long u64;

// Mini-batch `ctr[1]` of the epoch's order: samples and labels.
extern "C" __global__ void gather(const float* set, const unsigned* labels, const unsigned* order,
                                  const unsigned* ctr, unsigned n, unsigned each, float* x,
                                  unsigned* y) {
  u64 base = (u64)ctr[1] * n;
  u64 total = (u64)n * each;
  for (u64 i = blockIdx.x * (u64)blockDim.x + threadIdx.x; i < total;
       i += (u64)gridDim.x * blockDim.x) {
    u64 s = i / each, e = i % each;
    unsigned src = order[base + s];
    x[i] = set[(u64)src * each + e];
    if (e == 0) y[s] = labels[src];
  }
}

// Zero padding: `planes` planes of h x w into hp x wp at (top, left).
extern "C" __global__ void pad(const float* src, float* dst, unsigned planes, unsigned h,
                               unsigned w, unsigned hp, unsigned wp, unsigned top,
                               unsigned left) {
  u64 total = (u64)planes * hp * wp;
  for (u64 i = blockIdx.x * (u64)blockDim.x + threadIdx.x; i < total;
       i += (u64)gridDim.x * blockDim.x) {
    u64 j = i % wp, r = i / wp, ii = r % hp, p = r / hp;
    long long si = (long long)ii - top, sj = (long long)j - left;
    dst[i] = (si >= 0 && si < h && sj >= 0 && sj < w) ? src[(p * h + si) * w + sj] : 0.0f;
  }
}

// The gradient of `pad`: the padded gradient's inner part.
extern "C" __global__ void crop(const float* dpadded, float* dsrc, unsigned planes, unsigned h,
                                unsigned w, unsigned hp, unsigned wp, unsigned top,
                                unsigned left) {
  u64 total = (u64)planes * h * w;
  for (u64 i = blockIdx.x * (u64)blockDim.x + threadIdx.x; i < total;
       i += (u64)gridDim.x * blockDim.x) {
    u64 j = i % w, r = i / w, ii = r % h, p = r / h;
    dsrc[i] = dpadded[(p * hp + ii + top) * wp + j + left];
  }
}

__device__ double block_sum(double v, double* buf) {
  buf[threadIdx.x] = v;
  __syncthreads();
  for (unsigned k = blockDim.x / 2; k > 0; k >>= 1) {
    if (threadIdx.x < k) buf[threadIdx.x] += buf[threadIdx.x + k];
    __syncthreads();
  }
  double s = buf[0];
  __syncthreads();
  return s;
}

// Per channel of x [n, c, hw] and chunk `blockIdx.y` of its n hw values (of `parts`): the sum
// and the sum of squares of x less the channel's first value, in double.
extern "C" __global__ void bn_partial(const float* x, unsigned n, unsigned c, unsigned hw,
                                      unsigned parts, double* partial) {
  __shared__ double buf[256];
  unsigned ch = blockIdx.x, part = blockIdx.y;
  u64 count = (u64)n * hw;
  u64 chunk = (count + parts - 1) / parts;
  u64 lo = part * chunk, hi = lo + chunk < count ? lo + chunk : count;
  double shift = x[(u64)ch * hw];
  double s = 0.0, q = 0.0;
  for (u64 i = lo + threadIdx.x; i < hi; i += blockDim.x) {
    u64 b = i / hw, p = i % hw;
    double d = (double)x[(b * c + ch) * hw + p] - shift;
    s += d;
    q += d * d;
  }
  double ts = block_sum(s, buf);
  double tq = block_sum(q, buf);
  if (threadIdx.x == 0) {
    partial[2 * ((u64)ch * parts + part)] = ts;
    partial[2 * ((u64)ch * parts + part) + 1] = tq;
  }
}

// Running mean and biased variance from `bn_partial`'s sums (one thread per channel, the chunks
// in order); the newest batch weighs max(0.1, 1 / (k + 1)) at step k = ctr[0].
extern "C" __global__ void bn_running(const double* partial, const float* x, unsigned n,
                                      unsigned c, unsigned hw, unsigned parts, float* rmean,
                                      float* rvar, const unsigned* ctr) {
  unsigned ch = blockIdx.x * blockDim.x + threadIdx.x;
  if (ch >= c) return;
  double ts = 0.0, tq = 0.0;
  for (unsigned p = 0; p < parts; p++) {
    ts += partial[2 * ((u64)ch * parts + p)];
    tq += partial[2 * ((u64)ch * parts + p) + 1];
  }
  double count = (double)n * hw;
  double m = ts / count;
  double var = fmax(tq / count - m * m, 0.0);
  double mean = m + (double)x[(u64)ch * hw];
  float d = (float)fmax(0.1, 1.0 / ((double)ctr[0] + 1.0));
  rmean[ch] = rmean[ch] * (1.0f - d) + (float)mean * d;
  rvar[ch] = rvar[ch] * (1.0f - d) + (float)var * d;
}

// Softmax cross-entropy of logits [n, classes]: the gradient of the mean loss, and the step's
// mean loss and hits in stats[2 k], stats[2 k + 1] (k = ctr[0]). One block.
extern "C" __global__ void softmax_ce(const float* logits, const unsigned* labels, unsigned n,
                                      unsigned classes, float* dlogits, float* stats,
                                      const unsigned* ctr) {
  __shared__ double buf[256];
  double loss = 0.0, hits = 0.0;
  for (unsigned s = threadIdx.x; s < n; s += blockDim.x) {
    const float* z = logits + (u64)s * classes;
    float m = z[0];
    unsigned am = 0;
    for (unsigned k = 1; k < classes; k++) {
      if (z[k] > m) { m = z[k]; am = k; }
    }
    float sum = 0.0f;
    for (unsigned k = 0; k < classes; k++) sum += expf(z[k] - m);
    unsigned l = labels[s];
    loss += (double)(m + logf(sum) - z[l]);
    hits += am == l ? 1.0 : 0.0;
    for (unsigned k = 0; k < classes; k++) {
      float p = expf(z[k] - m) / sum;
      dlogits[(u64)s * classes + k] = (p - (k == l ? 1.0f : 0.0f)) / (float)n;
    }
  }
  double tl = block_sum(loss, buf);
  double th = block_sum(hits, buf);
  if (threadIdx.x == 0) {
    stats[2 * (u64)ctr[0]] = (float)(tl / n);
    stats[2 * (u64)ctr[0] + 1] = (float)th;
  }
}

// The first largest score of every row of logits [n, classes] into pred[offset + row].
extern "C" __global__ void argmax(const float* logits, unsigned n, unsigned classes,
                                  unsigned* pred, unsigned offset) {
  for (unsigned s = blockIdx.x * blockDim.x + threadIdx.x; s < n; s += gridDim.x * blockDim.x) {
    const float* z = logits + (u64)s * classes;
    float m = z[0];
    unsigned am = 0;
    for (unsigned k = 1; k < classes; k++) {
      if (z[k] > m) { m = z[k]; am = k; }
    }
    pred[offset + s] = am;
  }
}

// hits[slot] = how many of pred[0..n] equal labels[0..n]. One block.
extern "C" __global__ void count_hits(const unsigned* pred, const unsigned* labels, unsigned n,
                                      unsigned* hits, unsigned slot) {
  __shared__ double buf[256];
  double h = 0.0;
  for (unsigned s = threadIdx.x; s < n; s += blockDim.x) h += pred[s] == labels[s] ? 1.0 : 0.0;
  double total = block_sum(h, buf);
  if (threadIdx.x == 0) hits[slot] = (unsigned)total;
}

// SGD with momentum and L2: g += l2 p; v = momentum v + g; p -= lr v.
extern "C" __global__ void sgdm(float* p, const float* g, float* v, unsigned n, float lr,
                                float momentum, float l2) {
  for (unsigned i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) {
    float gi = g[i] + l2 * p[i];
    float vi = momentum * v[i] + gi;
    v[i] = vi;
    p[i] = p[i] - lr * vi;
  }
}

// The end of a step: the step and the epoch's step counters advance.
extern "C" __global__ void tick(unsigned* ctr) { ctr[0] += 1; ctr[1] += 1; }

// The start of an epoch: its step counter back to 0.
extern "C" __global__ void new_epoch(unsigned* ctr) { ctr[1] = 0; }
"#;

/// The compiled kernels.
pub(super) struct Kernels {
    pub gather: CudaFunction,
    pub pad: CudaFunction,
    pub crop: CudaFunction,
    pub bn_partial: CudaFunction,
    pub bn_running: CudaFunction,
    pub softmax_ce: CudaFunction,
    pub argmax: CudaFunction,
    pub count_hits: CudaFunction,
    pub sgdm: CudaFunction,
    pub tick: CudaFunction,
    pub new_epoch: CudaFunction,
}

impl Kernels {
    /// Compiles the kernels (NVRTC, once per process) and loads them into `ctx`.
    pub fn new(ctx: &Arc<CudaContext>) -> Result<Self> {
        static PTX: OnceLock<String> = OnceLock::new();
        let ptx = match PTX.get() {
            Some(p) => p.clone(),
            None => {
                let p = cudarc::nvrtc::compile_ptx(SOURCE)
                    .map_err(|e| {
                        anyhow::anyhow!("NVRTC could not compile the route's kernels: {e:?}")
                    })?
                    .to_src();
                PTX.get_or_init(|| p).clone()
            }
        };
        let module = ctx
            .load_module(cudarc::nvrtc::Ptx::from_src(ptx))
            .context("loading the route's kernels")?;
        let f = |name: &str| {
            module
                .load_function(name)
                .with_context(|| format!("kernel {name}"))
        };
        Ok(Kernels {
            gather: f("gather")?,
            pad: f("pad")?,
            crop: f("crop")?,
            bn_partial: f("bn_partial")?,
            bn_running: f("bn_running")?,
            softmax_ce: f("softmax_ce")?,
            argmax: f("argmax")?,
            count_hits: f("count_hits")?,
            sgdm: f("sgdm")?,
            tick: f("tick")?,
            new_epoch: f("new_epoch")?,
        })
    }
}

/// A grid of [`THREADS`]-thread blocks covering `n` elements (at most 4096 blocks: the
/// kernels loop).
pub(super) fn grid(n: usize) -> LaunchConfig {
    let blocks = n.div_ceil(THREADS as usize).clamp(1, 4096) as u32;
    LaunchConfig {
        grid_dim: (blocks, 1, 1),
        block_dim: (THREADS, 1, 1),
        shared_mem_bytes: 0,
    }
}

/// `blocks` blocks of [`THREADS`] threads.
pub(super) fn blocks(blocks: usize) -> LaunchConfig {
    LaunchConfig {
        grid_dim: (blocks.max(1) as u32, 1, 1),
        block_dim: (THREADS, 1, 1),
        shared_mem_bytes: 0,
    }
}

/// A kernel argument as the 8 bytes it is passed in: CUDA copies a parameter's own size from
/// the start of its slot, which on a little-endian machine holds a `u32`'s or an `f32`'s bits.
pub(super) trait KArg {
    fn bits(self) -> u64;
}

impl KArg for u64 {
    fn bits(self) -> u64 {
        self
    }
}

impl KArg for u32 {
    fn bits(self) -> u64 {
        u64::from(self)
    }
}

impl KArg for f32 {
    fn bits(self) -> u64 {
        u64::from(self.to_bits())
    }
}

/// Launches `f` on `stream` with `cfg` and the arguments (device addresses as `u64`, counts as
/// `u32`, scalars as `f32`); the caller has `cudarc::driver::PushKernelArg` and
/// `anyhow::Context` in scope.
macro_rules! launch {
    ($stream:expr, $f:expr, $cfg:expr, $($arg:expr),+ $(,)?) => {{
        let vals = [$($crate::apps::cnn::gpu::kernels::KArg::bits($arg)),+];
        let mut b = $stream.launch_builder(&$f);
        for v in vals.iter() {
            b.arg(v);
        }
        // SAFETY: the arguments match the kernel's signature in `SOURCE` (addresses of buffers
        // of the sizes the kernel reads, which the caller allocated).
        unsafe { b.launch($cfg) }.map(|_| ()).context(stringify!($f))
    }};
}
pub(super) use launch;
