//! Training and prediction (docs/definitions.md §12): MATLAB's `trainingOptions('sgdm')`
//! defaults unless the spec says otherwise: SGD with momentum 0.9 (no dampening), learning rate
//! 0.01, L2 1e-4, mini-batch 128 (or the training-set size if smaller), 30 epochs, the data
//! shuffled once before training, the last partial mini-batch of an epoch left out (as MATLAB
//! does), validation accuracy every 50 iterations and after the last, and the last epoch's
//! network is the result. Prediction uses batch normalisation's running averages. The
//! equal-steps protocol ([`Protocol::EqualSteps`]) gives every training of a section the same
//! number of mini-batch steps instead of the same number of epochs.
//!
//! Everything random (initial weights, the shuffles) comes from ChaCha20 streams of the
//! training's seed, so a training is a function of its seed and data.

use super::net::{Net, NetConfig};
use burn::module::AutodiffModule;
use burn::optim::decay::WeightDecayConfig;
use burn::optim::momentum::MomentumConfig;
use burn::optim::{AdamConfig, GradientsParams, Optimizer, SgdConfig};
use burn::tensor::activation::log_softmax;
use burn::tensor::backend::{AutodiffBackend, Backend};
use burn::tensor::{Tensor, TensorData};
use num_complex::Complex32;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The pure-Rust CPU backend (burn's `flex`), the default.
pub type Cpu = burn::backend::Flex;
/// [`Cpu`] with automatic differentiation, for training.
pub type CpuTrain = burn::backend::Autodiff<Cpu>;

/// Optimisers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Optimiser {
    /// SGD with momentum (MATLAB's `sgdm`, the default).
    Sgdm,
    /// Adam (MATLAB's defaults: decay factors 0.9 and 0.999, epsilon 1e-8).
    Adam,
}

/// Where a training runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Device {
    /// burn's pure-Rust CPU backend `flex` (the default; bit-identical whatever the thread
    /// count).
    #[default]
    Cpu,
    /// An NVIDIA GPU (a binary built with the `cuda` feature; the cuDNN route for SGDM, burn's
    /// CUDA backend for Adam).
    Cuda,
    /// `cuda` where the binary has the feature and a GPU with its driver, NVRTC and cuDNN can
    /// be used, else `cpu` (the run says which, and why; `crate::apps::cnn::device::resolve`).
    Auto,
}

/// When the training set is shuffled (MATLAB's `Shuffle`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shuffle {
    /// Once, before the first epoch (MATLAB's default): every epoch sees the mini-batches in the
    /// same order.
    #[default]
    Once,
    /// Before every epoch, each epoch from its own random stream.
    EveryEpoch,
}

/// How many mini-batch steps a training takes (docs/definitions.md §12, protocols).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Protocol {
    /// MATLAB's (the default): `epochs` passes over the set, the last partial mini-batch of
    /// each left out, so `N` samples take `epochs * floor(N / batch)` steps and a small set
    /// takes few (100 and 250 samples both take 30 at the defaults).
    #[default]
    Matlab,
    /// Every training of a section the same number of steps (`steps`; by default what its
    /// largest training set takes in `epochs` epochs): the set reshuffled before every epoch,
    /// as many epochs as the steps need, the last one cut short.
    EqualSteps,
}

/// Training settings (a spec's `training:` block).
#[derive(Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingOptions {
    /// `sgdm` (default) or `adam`.
    #[serde(default = "sgdm")]
    pub optimizer: Optimiser,
    /// Learning rate (default 0.01).
    #[serde(default = "learning_rate")]
    pub learning_rate: f64,
    /// Momentum of `sgdm` (default 0.9).
    #[serde(default = "momentum")]
    pub momentum: f64,
    /// L2 regularisation (default 1e-4).
    #[serde(default = "l2")]
    pub l2: f64,
    /// Mini-batch size (default 128; the training-set size if that is smaller).
    #[serde(default = "batch_size")]
    pub batch_size: usize,
    /// Epochs (default 30).
    #[serde(default = "epochs")]
    pub epochs: usize,
    /// `once` (default, MATLAB's) or `every_epoch`.
    #[serde(default)]
    pub shuffle: Shuffle,
    /// Validation accuracy every this many iterations (mini-batches) and after the last one
    /// (MATLAB's `ValidationFrequency`, default 50). Validation does not change the network
    /// (the last epoch's is the result): it is a record, and costs a forward pass over the
    /// validation set each time.
    #[serde(default = "validation_frequency")]
    pub validation_frequency: usize,
    /// `cpu` (default), `cuda` or `auto`.
    #[serde(default)]
    pub device: Device,
    /// `matlab` (default) or `equal_steps`.
    #[serde(default)]
    pub protocol: Protocol,
    /// Mini-batch steps of every training under `equal_steps` (default: see
    /// [`TrainingOptions::for_largest`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps: Option<usize>,
}

/// The derived form, with `protocol` and `steps` shown only when they are not the defaults:
/// a job's store key is made from this text, so the results of specs written before the
/// protocols existed (what `matlab` computes) keep their keys.
impl std::fmt::Debug for TrainingOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("TrainingOptions");
        d.field("optimizer", &self.optimizer)
            .field("learning_rate", &self.learning_rate)
            .field("momentum", &self.momentum)
            .field("l2", &self.l2)
            .field("batch_size", &self.batch_size)
            .field("epochs", &self.epochs)
            .field("shuffle", &self.shuffle)
            .field("validation_frequency", &self.validation_frequency)
            .field("device", &self.device);
        if self.protocol != Protocol::Matlab || self.steps.is_some() {
            d.field("protocol", &self.protocol)
                .field("steps", &self.steps);
        }
        d.finish()
    }
}

fn validation_frequency() -> usize {
    50
}

fn sgdm() -> Optimiser {
    Optimiser::Sgdm
}
fn learning_rate() -> f64 {
    0.01
}
fn momentum() -> f64 {
    0.9
}
fn l2() -> f64 {
    1e-4
}
fn batch_size() -> usize {
    128
}
fn epochs() -> usize {
    30
}

impl Default for TrainingOptions {
    fn default() -> Self {
        TrainingOptions {
            optimizer: sgdm(),
            learning_rate: learning_rate(),
            momentum: momentum(),
            l2: l2(),
            batch_size: batch_size(),
            epochs: epochs(),
            shuffle: Shuffle::Once,
            validation_frequency: validation_frequency(),
            device: Device::Cpu,
            protocol: Protocol::Matlab,
            steps: None,
        }
    }
}

impl TrainingOptions {
    /// Checks the values, naming the offending key.
    ///
    /// # Errors
    /// `(key, message)` for a value out of range.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let positive = |k: &'static str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err((k, format!("must be positive, got {v}")))
            }
        };
        positive("learning_rate", self.learning_rate)?;
        if !(0.0..1.0).contains(&self.momentum) {
            return Err((
                "momentum",
                format!("must be in [0, 1), got {}", self.momentum),
            ));
        }
        if !(self.l2 >= 0.0 && self.l2.is_finite()) {
            return Err(("l2", format!("must be >= 0, got {}", self.l2)));
        }
        if self.batch_size == 0 {
            return Err(("batch_size", "must be at least 1".into()));
        }
        if self.epochs == 0 || self.epochs > 10_000 {
            return Err((
                "epochs",
                format!("must be in 1..=10000, got {}", self.epochs),
            ));
        }
        match (self.protocol, self.steps) {
            (Protocol::Matlab, Some(_)) => {
                return Err((
                    "steps",
                    "applies to `protocol: equal_steps` only (MATLAB's protocol counts epochs)"
                        .into(),
                ))
            }
            (Protocol::EqualSteps, Some(s)) if s == 0 || s > 10_000_000 => {
                return Err(("steps", format!("must be in 1..=10000000, got {s}")))
            }
            _ => {}
        }
        if self.validation_frequency == 0 {
            return Err(("validation_frequency", "must be at least 1".into()));
        }
        if self.device == Device::Cuda && !cfg!(feature = "cuda") {
            return Err((
                "device",
                "this binary was built without CUDA: rebuild with `make build FEATURES='mat73 cuda'` (or use `device: cpu`)".into(),
            ));
        }
        Ok(())
    }
}

impl TrainingOptions {
    /// The options of a section whose largest training set has `largest` samples: under
    /// `equal_steps` without `steps`, the steps that set takes in `epochs` epochs
    /// (`epochs * floor(largest / batch)`, at least 1); otherwise as written.
    pub fn for_largest(&self, largest: usize) -> TrainingOptions {
        let mut t = *self;
        if t.protocol == Protocol::EqualSteps && t.steps.is_none() {
            t.steps = Some((t.epochs * per_epoch(largest, t.batch_size)).max(1));
        }
        t
    }

    /// Mini-batch steps a training on `n` samples takes.
    pub fn steps_for(&self, n: usize) -> usize {
        let per_epoch = per_epoch(n, self.batch_size);
        match self.protocol {
            Protocol::Matlab => per_epoch * self.epochs,
            Protocol::EqualSteps => self.steps.unwrap_or(per_epoch * self.epochs),
        }
    }
}

/// Full mini-batches in one pass over `n` samples (the mini-batch is the set when it is
/// smaller): at least 1 for a set that is not empty.
fn per_epoch(n: usize, batch_size: usize) -> usize {
    n / batch_size.min(n).max(1)
}

/// Labelled complex images of one size.
#[derive(Debug, Clone, Default)]
pub struct Labelled {
    /// `N * H * W` values, image after image (row-major).
    pub images: Vec<Complex32>,
    /// `N` labels in `0..classes`.
    pub labels: Vec<usize>,
}

impl Labelled {
    /// Number of images.
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    /// Whether there are no images.
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    /// Appends one image.
    pub fn push(&mut self, image: &[Complex32], label: usize) {
        self.images.extend_from_slice(image);
        self.labels.push(label);
    }
}

/// The 'zerocenter' mean of a set: per channel (real, imaginary) and pixel, `2 * H * W`.
pub fn zerocenter_mean(set: &Labelled, pixels: usize) -> Vec<f32> {
    let mut acc = vec![0.0f64; 2 * pixels];
    for img in set.images.chunks_exact(pixels) {
        for (p, z) in img.iter().enumerate() {
            acc[p] += f64::from(z.re);
            acc[pixels + p] += f64::from(z.im);
        }
    }
    let n = set.len().max(1) as f64;
    acc.iter().map(|&s| (s / n) as f32).collect()
}

/// A set prepared for the network ([`NetConfig::prepare`]).
struct Prepared {
    values: Vec<f32>,
    labels: Vec<usize>,
    each: usize,
}

impl Prepared {
    fn new(cfg: &NetConfig, set: &Labelled, mean: &[f32]) -> Self {
        let each = cfg.prepared_len();
        Prepared {
            values: cfg.prepare_all(&set.images, mean),
            labels: set.labels.clone(),
            each,
        }
    }

    /// The samples `idx` as a `[n, 8, Hb, Wb]` tensor.
    fn batch<B: Backend>(
        &self,
        cfg: &NetConfig,
        idx: &[usize],
        device: &B::Device,
    ) -> Tensor<B, 4> {
        let mut v = Vec::with_capacity(idx.len() * self.each);
        for &i in idx {
            v.extend_from_slice(&self.values[i * self.each..(i + 1) * self.each]);
        }
        let [c, h, w] = cfg.prepared_shape();
        Tensor::from_data(TensorData::new(v, [idx.len(), c, h, w]), device)
    }
}

/// Per-epoch record of a training.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Epoch {
    /// Epoch number, from 1.
    pub epoch: usize,
    /// Mean cross-entropy over the epoch's mini-batches.
    pub loss: f64,
    /// Accuracy of the epoch's mini-batches (while training).
    pub batch_accuracy: f64,
    /// Validation accuracy of the last validation during the epoch (`None` where none fell in
    /// it; `NaN` without a validation set).
    pub validation_accuracy: Option<f64>,
}

/// A trained network with its 'zerocenter' mean and its record.
pub struct Trained {
    /// Geometry.
    pub cfg: NetConfig,
    /// The network for prediction (running BN statistics).
    pub net: Net<Cpu>,
    /// The 'zerocenter' mean (`2 * H * W`, real plane then imaginary plane).
    pub mean: Vec<f32>,
    /// Per-epoch record.
    pub epochs: Vec<Epoch>,
    /// Accuracy of the final network on the training set.
    pub train_accuracy: f64,
    /// Accuracy of the final network on the validation set (`NaN` without one).
    pub validation_accuracy: f64,
    /// Wall time of the whole training (steps and validation passes), seconds.
    pub seconds: f64,
    /// Samples through forward, backward and update per second of step time.
    pub samples_per_second: f64,
    /// Mini-batch size used.
    pub batch_size: usize,
}

/// Trains a new network on `train` (validating on `validation` after every epoch) from the
/// seed `seed` on the CPU backend.
pub fn train(
    cfg: &NetConfig,
    opts: &TrainingOptions,
    train: &Labelled,
    validation: &Labelled,
    seed: u64,
) -> Trained {
    train_on::<CpuTrain>(cfg, opts, train, validation, seed, &Default::default())
}

/// [`train`] on any autodiff backend `B` whose inner backend is [`Cpu`]-compatible for the
/// returned network (the weights are moved to the CPU at the end).
///
/// Long because the training loop's state (the optimisers, the order, the iteration count and
/// the record) lives across its epochs and mini-batches.
pub fn train_on<B: AutodiffBackend>(
    cfg: &NetConfig,
    opts: &TrainingOptions,
    train: &Labelled,
    validation: &Labelled,
    seed: u64,
    device: &B::Device,
) -> Trained {
    let t0 = Instant::now();
    let pixels = cfg.height * cfg.width;
    let mean = zerocenter_mean(train, pixels);
    let prepared = Prepared::new(cfg, train, &mean);
    let prepared_val = Prepared::new(cfg, validation, &mean);
    let mut net: Net<B> = cfg.init(seed, device);
    let batch = opts.batch_size.min(train.len()).max(1);
    let lr = opts.learning_rate;
    let mut sgd = SgdConfig::new()
        .with_momentum(Some(MomentumConfig {
            momentum: opts.momentum,
            dampening: 0.0,
            nesterov: false,
        }))
        .with_weight_decay((opts.l2 > 0.0).then_some(WeightDecayConfig {
            penalty: opts.l2 as f32,
        }))
        .init::<B, Net<B>>();
    let mut adam = AdamConfig::new()
        .with_beta_1(0.9)
        .with_beta_2(0.999)
        .with_epsilon(1e-8)
        .with_weight_decay((opts.l2 > 0.0).then_some(WeightDecayConfig {
            penalty: opts.l2 as f32,
        }))
        .init::<B, Net<B>>();
    let mut order: Vec<usize> = (0..train.len()).collect();
    let per_epoch = per_epoch(train.len(), opts.batch_size);
    let last_iteration = opts.steps_for(train.len());
    let n_epochs = last_iteration.div_ceil(per_epoch.max(1));
    let reshuffle = opts.shuffle == Shuffle::EveryEpoch || opts.protocol == Protocol::EqualSteps;
    let mut epochs = Vec::with_capacity(n_epochs);
    let mut step_seconds = 0.0;
    let mut stepped = 0usize;
    let mut iteration = 0usize;
    for epoch in 1..=n_epochs {
        if epoch == 1 || reshuffle {
            let mut rng = ChaCha20Rng::seed_from_u64(seed);
            rng.set_stream(epoch as u64);
            order.shuffle(&mut rng);
        }
        let (mut loss_sum, mut right, mut seen, mut batches) = (0.0, 0usize, 0usize, 0usize);
        let mut validation_accuracy = None;
        let left = last_iteration - iteration;
        for idx in order.chunks_exact(batch).take(left) {
            let t = Instant::now();
            let x = prepared.batch::<B>(cfg, idx, device);
            let labels: Vec<usize> = idx.iter().map(|&i| prepared.labels[i]).collect();
            let logits = net.logits(x);
            let batch_loss = loss(logits.clone(), &labels, cfg.classes, device);
            let grads = GradientsParams::from_grads(batch_loss.backward(), &net);
            net = match opts.optimizer {
                Optimiser::Sgdm => sgd.step(lr, net, grads),
                Optimiser::Adam => adam.step(lr, net, grads),
            };
            let batch_loss: f64 = batch_loss
                .into_scalar()
                .to_string()
                .parse()
                .unwrap_or(f64::NAN);
            let predicted = argmax_rows(logits.inner());
            step_seconds += t.elapsed().as_secs_f64();
            stepped += idx.len();
            right += predicted
                .iter()
                .zip(&labels)
                .filter(|(p, l)| p == l)
                .count();
            seen += idx.len();
            loss_sum += batch_loss;
            batches += 1;
            iteration += 1;
            if iteration.is_multiple_of(opts.validation_frequency) || iteration == last_iteration {
                validation_accuracy = Some(accuracy(&net.valid(), cfg, &prepared_val));
            }
        }
        epochs.push(Epoch {
            epoch,
            loss: loss_sum / batches.max(1) as f64,
            batch_accuracy: right as f64 / seen.max(1) as f64,
            validation_accuracy,
        });
    }
    let inference = net.valid();
    let train_accuracy = accuracy(&inference, cfg, &prepared);
    let validation_accuracy = epochs
        .last()
        .and_then(|e| e.validation_accuracy)
        .unwrap_or(f64::NAN);
    let cpu: Net<Cpu> = inference.to_backend(&Default::default());
    Trained {
        cfg: *cfg,
        net: cpu,
        mean,
        epochs,
        train_accuracy,
        validation_accuracy,
        seconds: t0.elapsed().as_secs_f64(),
        samples_per_second: stepped as f64 / step_seconds.max(1e-12),
        batch_size: batch,
    }
}

/// Mean softmax cross-entropy of `logits` `[N, classes]` against `labels`.
pub fn loss<B: Backend>(
    logits: Tensor<B, 2>,
    labels: &[usize],
    classes: usize,
    device: &B::Device,
) -> Tensor<B, 1> {
    let n = labels.len();
    let mut onehot = vec![0.0f32; n * classes];
    for (i, &l) in labels.iter().enumerate() {
        onehot[i * classes + l] = 1.0;
    }
    let onehot = Tensor::<B, 2>::from_data(TensorData::new(onehot, [n, classes]), device);
    (log_softmax(logits, 1) * onehot).sum().neg() / n as f64
}

/// The index of the largest score of every row (the first on ties).
fn argmax_rows<B: Backend>(scores: Tensor<B, 2>) -> Vec<usize> {
    let [_, c] = scores.dims();
    let v: Vec<f32> = scores
        .into_data()
        .convert::<f32>()
        .to_vec()
        .expect("f32 scores");
    v.chunks_exact(c)
        .map(|row| {
            row.iter()
                .enumerate()
                .fold((0, f32::NEG_INFINITY), |(bi, bv), (i, &x)| {
                    if x > bv {
                        (i, x)
                    } else {
                        (bi, bv)
                    }
                })
                .0
        })
        .collect()
}

/// Rows of prediction per pass: 32 keeps a pass's buffers (1.3 MB of prepared 64 x 64 images,
/// the blocks' outputs) below the size the allocator maps afresh, so that they are reused
/// instead of faulted in and zeroed for every pass (20 % faster than 256 on Table 18's
/// network; BENCHMARKS.md).
const PREDICT_BATCH: usize = 32;

/// Predicted classes of a prepared set.
fn predict_prepared<B: Backend>(net: &Net<B>, cfg: &NetConfig, set: &Prepared) -> Vec<usize> {
    let device = Default::default();
    let idx: Vec<usize> = (0..set.labels.len()).collect();
    idx.chunks(PREDICT_BATCH)
        .flat_map(|chunk| argmax_rows(net.logits(set.batch::<B>(cfg, chunk, &device))))
        .collect()
}

/// Accuracy on a prepared set (`NaN` when it is empty).
fn accuracy<B: Backend>(net: &Net<B>, cfg: &NetConfig, set: &Prepared) -> f64 {
    if set.labels.is_empty() {
        return f64::NAN;
    }
    let p = predict_prepared(net, cfg, set);
    p.iter().zip(&set.labels).filter(|(a, b)| a == b).count() as f64 / p.len() as f64
}

impl Trained {
    /// Predicted classes of `images` (`N * H * W`).
    ///
    /// Batch by batch (as [`predict_prepared`]), each prepared as it is needed: no copy of the
    /// whole set.
    pub fn predict(&self, images: &[Complex32]) -> Vec<usize> {
        let cfg = &self.cfg;
        let pixels = cfg.height * cfg.width;
        let [c, h, w] = cfg.prepared_shape();
        let device = Default::default();
        images
            .chunks(PREDICT_BATCH * pixels)
            .flat_map(|chunk| {
                let n = chunk.len() / pixels;
                let v = cfg.prepare_all(chunk, &self.mean);
                let x = Tensor::from_data(TensorData::new(v, [n, c, h, w]), &device);
                argmax_rows(self.net.logits(x))
            })
            .collect()
    }

    /// Accuracy on a labelled set and its confusion matrix (`[true][predicted]` counts).
    pub fn evaluate(&self, set: &Labelled) -> (f64, Vec<Vec<usize>>) {
        let p = self.predict(&set.images);
        let mut confusion = vec![vec![0usize; self.cfg.classes]; self.cfg.classes];
        for (&t, &q) in set.labels.iter().zip(&p) {
            confusion[t][q] += 1;
        }
        let right = (0..self.cfg.classes)
            .map(|c| confusion[c][c])
            .sum::<usize>();
        (right as f64 / set.len().max(1) as f64, confusion)
    }
}
