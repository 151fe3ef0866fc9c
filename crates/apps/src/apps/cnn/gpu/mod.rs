//! The cuDNN route of `training: {device: cuda}` (feature `cuda`; docs/cnn.md, *On a GPU*):
//! the networks of Tables 18 and 23 trained with cuDNN's convolutions, batch normalisation,
//! ReLU and pooling and a few kernels of its own ([`kernels`]), through `cudarc`, which loads
//! the NVIDIA driver, NVRTC and cuDNN 9 at run time: the project builds and tests without CUDA.
//!
//! The training is the CPU's ([`super::train::train_on`]): the same initial weights (drawn on
//! the host from the seed), the same shuffles and mini-batches, MATLAB's SGDM with L2, the same
//! BN running-statistics schedule, the last partial mini-batch left out, validation every
//! `validation_frequency` steps; only the arithmetic's order differs, so results agree to
//! float rounding. The set is staged on the GPU once; each step gathers its mini-batch there
//! from the epoch's order, and the whole step (forward, loss, backward, SGDM, counters) is
//! captured once as a CUDA graph and replayed; the host waits for the GPU only at the end.

mod dnn;
mod kernels;
#[cfg_attr(not(test), allow(dead_code))]
pub(super) mod layout;
mod pass;

use super::net::{Net, NetConfig};
use super::train::{
    zerocenter_mean, Cpu, Epoch, Labelled, Optimiser, Protocol, Shuffle, Trained, TrainingOptions,
};
use anyhow::{bail, Context, Result};
use cudarc::driver::{sys, CudaContext, CudaStream, PushKernelArg};
use kernels::{blocks, launch, Kernels};
use layout::{flatten, unflatten, Geometry, Params};
use num_complex::Complex32;
use pass::{Buf, DeviceNet, Pass, Sgd, StepData};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use std::sync::Arc;
use std::time::Instant;

/// Samples of a prediction pass.
const PREDICT_BATCH: usize = 1024;

/// How the cuDNN route runs (for measurements; the defaults are what `run` uses).
#[derive(Debug, Clone, Copy)]
pub struct GpuOptions {
    /// Capture a training step as a CUDA graph and replay it (default); `false` issues every
    /// step's calls one by one.
    pub graph: bool,
    /// Let cuDNN use TF32 tensor cores for the convolutions (10 bits of mantissa in the
    /// products; default `false`: float arithmetic, as on the CPU).
    pub tf32: bool,
    /// Choose each convolution's algorithms by timing them (cuDNN's `Find`, deterministic ones
    /// only) instead of by cuDNN's heuristics (default `false`: the heuristics' choice depends
    /// only on the GPU and the library, a timing's may change from run to run).
    pub find: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            graph: true,
            tf32: false,
            find: false,
        }
    }
}

/// Whether a library loads (`dlopen`).
fn loads(names: &[&std::ffi::CStr]) -> bool {
    names.iter().any(|name| {
        // SAFETY: dlopen with a valid C string; the handle is closed at once.
        let handle = unsafe { libc::dlopen(name.as_ptr(), libc::RTLD_LAZY) };
        if handle.is_null() {
            return false;
        }
        // SAFETY: a handle dlopen returned.
        unsafe { libc::dlclose(handle) };
        true
    })
}

/// Checks that the NVIDIA driver's library (`libcuda.so.1`) can be loaded.
///
/// # Errors
/// Says that no driver could be loaded.
pub fn driver() -> Result<()> {
    if !loads(&[c"libcuda.so.1", c"libcuda.so"]) {
        bail!("no NVIDIA driver could be loaded (libcuda.so.1): run on a machine with a GPU and its driver, or use `device: cpu`");
    }
    Ok(())
}

/// Checks that the NVIDIA driver, NVRTC and cuDNN 9 can be loaded (cudarc panics at the first
/// call into a library it cannot load).
///
/// # Errors
/// Names the library that is missing.
pub fn available() -> Result<()> {
    driver()?;
    if !loads(&[c"libnvrtc.so", c"libnvrtc.so.13", c"libnvrtc.so.12"]) {
        bail!("NVRTC (libnvrtc.so.13 or .12, CUDA's run-time compiler) could not be loaded: put the CUDA toolkit's or the nvidia-cuda-nvrtc wheel's lib folder on LD_LIBRARY_PATH");
    }
    if !loads(&[c"libcudnn.so.9", c"libcudnn.so"]) {
        bail!("cuDNN 9 (libcudnn.so.9) could not be loaded: install it (e.g. the nvidia-cudnn-cu13 wheel) and put its lib folder on LD_LIBRARY_PATH");
    }
    Ok(())
}

/// A context and a stream of its own (CUDA graphs cannot capture the legacy default stream),
/// with cudarc's per-buffer event tracking off (one stream: the order is the stream's).
fn stream() -> Result<Arc<CudaStream>> {
    let ctx = CudaContext::new(0).context("opening the first CUDA device")?;
    // SAFETY: all of this route's work is on one stream, so no cross-stream events are needed.
    unsafe { ctx.disable_event_tracking() };
    ctx.new_stream().context("a CUDA stream")
}

/// The kernels, compiled once per process.
fn kernels(stream: &Arc<CudaStream>) -> Result<Kernels> {
    Kernels::new(stream.context())
}

/// `values` (prepared samples of `each` floats) and `labels` staged on the device, padded with
/// zero samples and the label `u32::MAX` (never a class) to a whole number of prediction passes.
struct Staged {
    x: Buf<f32>,
    labels: Buf<u32>,
    n: usize,
}

impl Staged {
    fn new(
        stream: &Arc<CudaStream>,
        mut values: Vec<f32>,
        labels: &[usize],
        each: usize,
    ) -> Result<Self> {
        let n = labels.len();
        let padded = n.div_ceil(PREDICT_BATCH) * PREDICT_BATCH;
        values.resize(padded * each, 0.0);
        let mut l: Vec<u32> = labels.iter().map(|&c| c as u32).collect();
        l.resize(padded, u32::MAX);
        Ok(Staged {
            x: Buf::from(stream, &values)?,
            labels: Buf::from(stream, &l)?,
            n,
        })
    }

    fn passes(&self) -> usize {
        self.n.div_ceil(PREDICT_BATCH)
    }
}

/// Predicts every staged sample into `pred` and counts the hits into `hits[slot]`.
fn predict_staged(
    dn: &DeviceNet,
    ip: &Pass,
    set: &Staged,
    pred: &Buf<u32>,
    hits: &Buf<u32>,
    slot: usize,
) -> Result<()> {
    for k in 0..set.passes() {
        let x = set.x.ptr + 4 * (k * PREDICT_BATCH * dn.g.each) as u64;
        dn.predict(ip, x, pred.ptr, k * PREDICT_BATCH)?;
    }
    launch!(
        &dn.stream,
        dn.k.count_hits,
        blocks(1),
        pred.ptr,
        set.labels.ptr,
        set.n as u32,
        hits.ptr,
        slot as u32
    )
}

/// Trains a new network on `train_set` from `seed` on the GPU, as
/// [`super::train::train`] does on the CPU (SGDM only).
///
/// # Errors
/// Adam (the route has SGDM only), a library that cannot be loaded, or a CUDA or cuDNN
/// failure.
pub fn train(
    cfg: &NetConfig,
    opts: &TrainingOptions,
    train_set: &Labelled,
    validation: &Labelled,
    seed: u64,
    gpu: GpuOptions,
) -> Result<Trained> {
    let t0 = Instant::now();
    if opts.optimizer != Optimiser::Sgdm {
        bail!("the cuDNN route trains with sgdm only");
    }
    available()?;
    cfg.check()?;
    anyhow::ensure!(!train_set.is_empty(), "an empty training set");
    let session = Session::new(cfg, opts, train_set, validation, seed, gpu)?;
    let record = session.epochs()?;
    session.finish(record, t0)
}

/// A training's state on the GPU: the network, its training and prediction passes and the
/// training and validation sets staged there.
struct Session<'a> {
    cfg: &'a NetConfig,
    opts: &'a TrainingOptions,
    seed: u64,
    gpu: GpuOptions,
    stream: Arc<CudaStream>,
    dn: DeviceNet,
    tp: Pass,
    ip: Pass,
    tr: Staged,
    va: Staged,
    mean: Vec<f32>,
    batch: usize,
}

/// What the epochs left: the steps of each epoch, the validations (epoch, slot), the steps in
/// all and their time, and the device buffers of the per-step record and the hits.
struct Record {
    steps_of: Vec<usize>,
    validated: Vec<(usize, usize)>,
    iteration: usize,
    step_seconds: f64,
    stats: Buf<f32>,
    hits: Buf<u32>,
    pred: Buf<u32>,
    validations: usize,
}

impl<'a> Session<'a> {
    /// The network drawn from `seed` on the host and copied to the GPU, its passes, and the
    /// sets prepared ('zerocenter' mean of the training set, space-to-depth) and staged.
    fn new(
        cfg: &'a NetConfig,
        opts: &'a TrainingOptions,
        train_set: &Labelled,
        validation: &Labelled,
        seed: u64,
        gpu: GpuOptions,
    ) -> Result<Self> {
        let stream = stream()?;
        let g = Geometry::new(cfg);
        let p = Params::new(&g);
        let mean = zerocenter_mean(train_set, cfg.height * cfg.width);
        let net: Net<Cpu> = cfg.init(seed, &Default::default());
        let (flat, run) = flatten(&net, &g, &p);
        let mut dn = DeviceNet::new(stream.clone(), kernels(&stream)?, g, p, &flat, &run)?;
        let batch = opts.batch_size.min(train_set.len()).max(1);
        let tp = dn.pass(batch, true, (gpu.tf32, gpu.find))?;
        let ip = dn.pass(PREDICT_BATCH, false, (gpu.tf32, gpu.find))?;
        let stage = |set: &Labelled| {
            Staged::new(
                &stream,
                cfg.prepare_all(&set.images, &mean),
                &set.labels,
                g.each,
            )
        };
        let (tr, va) = (stage(train_set)?, stage(validation)?);
        Ok(Session {
            cfg,
            opts,
            seed,
            gpu,
            stream,
            dn,
            tp,
            ip,
            tr,
            va,
            mean,
            batch,
        })
    }

    /// Every epoch's steps (the first issued call by call, the rest replays of its captured
    /// graph) and validations, on the GPU; waits for them at the end.
    fn epochs(&self) -> Result<Record> {
        let (opts, batch, stream, dn) = (self.opts, self.batch, &self.stream, &self.dn);
        let n = self.tr.n;
        let per_epoch = n / batch;
        let last_iteration = opts.steps_for(n);
        let n_epochs = last_iteration.div_ceil(per_epoch.max(1));
        let reshuffle =
            opts.shuffle == Shuffle::EveryEpoch || opts.protocol == Protocol::EqualSteps;
        let validations = if self.va.n == 0 {
            0
        } else {
            last_iteration / opts.validation_frequency + 1
        };
        let mut order: Vec<usize> = (0..n).collect();
        let mut order_dev = Buf::<u32>::zeros(stream, per_epoch * batch)?;
        let mut rec = Record {
            steps_of: Vec::with_capacity(n_epochs),
            validated: vec![],
            iteration: 0,
            step_seconds: 0.0,
            stats: Buf::zeros(stream, 2 * last_iteration)?,
            hits: Buf::zeros(stream, validations + 1)?,
            pred: Buf::zeros(
                stream,
                self.tr.passes().max(self.va.passes()) * PREDICT_BATCH,
            )?,
            validations,
        };
        let data = StepData {
            set: self.tr.x.ptr,
            labels: self.tr.labels.ptr,
            order: order_dev.ptr,
            stats: rec.stats.ptr,
        };
        let sgd = Sgd {
            lr: opts.learning_rate as f32,
            momentum: opts.momentum as f32,
            l2: opts.l2 as f32,
        };
        let mut graph = None;
        let t = Instant::now();
        for epoch in 1..=n_epochs {
            if epoch == 1 || reshuffle {
                let mut rng = ChaCha20Rng::seed_from_u64(self.seed);
                rng.set_stream(epoch as u64);
                order.shuffle(&mut rng);
            }
            let steps = per_epoch.min(last_iteration - rec.iteration);
            let o: Vec<u32> = order[..steps * batch].iter().map(|&i| i as u32).collect();
            order_dev.write(stream, &o)?;
            launch!(stream, dn.k.new_epoch, blocks(1), dn.ctr.ptr)?;
            for _ in 0..steps {
                match &graph {
                    Some(gr) => launch_graph(gr)?,
                    None if self.gpu.graph && rec.iteration >= 1 => {
                        let gr = capture(dn, &self.tp, &data, sgd)?;
                        launch_graph(&gr)?;
                        graph = Some(gr);
                    }
                    None => dn.step(&self.tp, &data, sgd)?,
                }
                rec.iteration += 1;
                let i = rec.iteration;
                if validations > 0
                    && (i.is_multiple_of(opts.validation_frequency) || i == last_iteration)
                {
                    let slot = rec.validated.len();
                    predict_staged(dn, &self.ip, &self.va, &rec.pred, &rec.hits, slot)?;
                    rec.validated.push((epoch, slot));
                }
            }
            rec.steps_of.push(steps);
        }
        stream
            .synchronize()
            .context("the training's steps on the GPU")?;
        rec.step_seconds = t.elapsed().as_secs_f64();
        Ok(rec)
    }

    /// The per-epoch record, the training set's accuracy (predicted on the GPU) and the
    /// network copied back to the CPU.
    fn finish(self, rec: Record, t0: Instant) -> Result<Trained> {
        let (stream, batch) = (&self.stream, self.batch);
        let stats = rec.stats.read(stream)?;
        let hits = rec.hits.read(stream)?;
        let mut epochs = Vec::with_capacity(rec.steps_of.len());
        let mut k = 0;
        for (e, &steps) in rec.steps_of.iter().enumerate() {
            let s = &stats[2 * k..2 * (k + steps)];
            k += steps;
            let loss = s.chunks(2).map(|c| f64::from(c[0])).sum::<f64>() / steps.max(1) as f64;
            let right: f64 = s.chunks(2).map(|c| f64::from(c[1])).sum();
            let validation_accuracy = rec
                .validated
                .iter()
                .rev()
                .find(|(ep, _)| *ep == e + 1)
                .map(|&(_, slot)| f64::from(hits[slot]) / self.va.n as f64);
            epochs.push(Epoch {
                epoch: e + 1,
                loss,
                batch_accuracy: right / (steps * batch).max(1) as f64,
                validation_accuracy,
            });
        }
        let slot = rec.validations;
        predict_staged(&self.dn, &self.ip, &self.tr, &rec.pred, &rec.hits, slot)?;
        let train_hits = rec.hits.read(stream)?[slot];
        let flat = self.dn.params.read(stream)?;
        let run = self.dn.running.read(stream)?;
        let (g, p) = (&self.dn.g, &self.dn.p);
        let net: Net<Cpu> = unflatten(
            self.cfg,
            g,
            p,
            &flat,
            &run,
            rec.iteration,
            &Default::default(),
        );
        let validation_accuracy = epochs
            .last()
            .and_then(|e| e.validation_accuracy)
            .unwrap_or(f64::NAN);
        Ok(Trained {
            cfg: *self.cfg,
            net,
            mean: self.mean,
            epochs,
            train_accuracy: f64::from(train_hits) / self.tr.n as f64,
            validation_accuracy,
            seconds: t0.elapsed().as_secs_f64(),
            samples_per_second: (rec.iteration * batch) as f64 / rec.step_seconds.max(1e-12),
            batch_size: batch,
        })
    }
}

/// One training step captured as a CUDA graph (nothing runs until it is launched).
fn capture(
    dn: &DeviceNet,
    tp: &Pass,
    data: &StepData,
    sgd: Sgd,
) -> Result<cudarc::driver::CudaGraph> {
    dn.stream
        .begin_capture(sys::CUstreamCaptureMode::CU_STREAM_CAPTURE_MODE_THREAD_LOCAL)
        .context("starting a CUDA graph capture")?;
    let issued = dn.step(tp, data, sgd);
    let graph = dn
        .stream
        .end_capture(sys::CUgraphInstantiate_flags(0))
        .context("ending the CUDA graph capture");
    issued?;
    graph?.context("the captured CUDA graph is empty")
}

fn launch_graph(g: &cudarc::driver::CudaGraph) -> Result<()> {
    g.launch()
        .context("launching the training step's CUDA graph")
}

/// A trained network on the GPU for prediction.
pub struct Predictor {
    dn: DeviceNet,
    ip: Pass,
    cfg: NetConfig,
    mean: Vec<f32>,
}

/// Samples staged on the GPU for [`Predictor::classes`].
pub struct StagedSet(Staged);

impl Predictor {
    /// `trained`'s network on the GPU.
    ///
    /// # Errors
    /// A library that cannot be loaded, or a CUDA or cuDNN failure.
    pub fn new(trained: &Trained, gpu: GpuOptions) -> Result<Self> {
        available()?;
        let stream = stream()?;
        let g = Geometry::new(&trained.cfg);
        let p = Params::new(&g);
        let (flat, run) = flatten(&trained.net, &g, &p);
        let mut dn = DeviceNet::new(stream.clone(), kernels(&stream)?, g, p, &flat, &run)?;
        let ip = dn.pass(PREDICT_BATCH, false, (gpu.tf32, gpu.find))?;
        Ok(Predictor {
            dn,
            ip,
            cfg: trained.cfg,
            mean: trained.mean.clone(),
        })
    }

    /// `images` (`N * H * W`) prepared and copied to the GPU.
    ///
    /// # Errors
    /// A CUDA failure.
    pub fn stage(&self, images: &[Complex32]) -> Result<StagedSet> {
        let n = images.len() / (self.cfg.height * self.cfg.width);
        let labels = vec![0usize; n];
        Staged::new(
            &self.dn.stream,
            self.cfg.prepare_all(images, &self.mean),
            &labels,
            self.dn.g.each,
        )
        .map(StagedSet)
    }

    /// The predicted class of every staged sample.
    ///
    /// # Errors
    /// A CUDA or cuDNN failure.
    pub fn classes(&self, set: &StagedSet) -> Result<Vec<usize>> {
        let set = &set.0;
        let pred = Buf::<u32>::zeros(&self.dn.stream, set.passes() * PREDICT_BATCH)?;
        let hits = Buf::<u32>::zeros(&self.dn.stream, 1)?;
        predict_staged(&self.dn, &self.ip, set, &pred, &hits, 0)?;
        let mut p = pred.read(&self.dn.stream)?;
        p.truncate(set.n);
        Ok(p.into_iter().map(|c| c as usize).collect())
    }
}
