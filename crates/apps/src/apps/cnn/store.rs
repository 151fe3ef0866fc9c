//! Trained networks on disk (`networks/<job>/`): `network.json` (geometry, class names, format
//! version) and one float32 `.npy` per tensor in MATLAB's terms (`conv1_weights.npy` as
//! `[F, C, k, k]`, `batchnorm_1_scale.npy`, `..._offset.npy`, `..._mean.npy`,
//! `..._variance.npy`, `fc_weights.npy` as `[inputs, classes]`, `fc_bias.npy`) plus the
//! 'zerocenter' mean `zerocenter_mean.npy` (`[2, H, W]`: real plane, imaginary plane). numpy
//! reads every file; [`load`] checks every shape against the geometry before building the
//! network again.

use super::net::{Bn, Net, NetConfig};
use super::train::{Cpu, Trained};
use crate::io::atomic::{atomic_write, write_npy};
use anyhow::{bail, Context, Result};
use burn::module::{Param, RunningState};
use burn::tensor::backend::Backend;
use burn::tensor::{Tensor, TensorData};
use ndarray::{ArrayD, IxDyn};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Version of the folder's layout.
pub const FORMAT: u32 = 1;

/// `network.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NetworkInfo {
    /// [`FORMAT`].
    pub format: u32,
    /// Geometry.
    pub config: NetConfig,
    /// Class names in label order.
    pub classes: Vec<String>,
    /// The job that trained it.
    pub job: String,
    /// The training's seed.
    pub seed: u64,
}

/// Tensor files with their shapes for a geometry, in writing order.
fn files(cfg: &NetConfig) -> Vec<(String, Vec<usize>)> {
    let f = cfg.arch.filters();
    let k = super::net::KERNELS;
    let mut c_in = super::net::CHANNELS;
    let mut out = vec![];
    for b in 0..3 {
        out.push((
            format!("conv{}_weights", b + 1),
            vec![f[b], c_in, k[b], k[b]],
        ));
        out.push((format!("conv{}_bias", b + 1), vec![f[b]]));
        for part in ["scale", "offset", "mean", "variance"] {
            out.push((format!("batchnorm_{}_{part}", b + 1), vec![f[b]]));
        }
        c_in = f[b];
    }
    out.push(("fc_weights".into(), vec![cfg.flat(), cfg.classes]));
    out.push(("fc_bias".into(), vec![cfg.classes]));
    out.push((
        "zerocenter_mean".into(),
        vec![super::net::CHANNELS, cfg.height, cfg.width],
    ));
    out
}

fn values<B: Backend, const D: usize>(t: Tensor<B, D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .to_vec()
        .expect("f32 tensor data")
}

/// The tensors of a trained network in [`files`] order.
fn tensors(t: &Trained) -> Vec<Vec<f32>> {
    let n = &t.net;
    let mut out = vec![];
    for (w, b, bn) in [
        (&n.w1, &n.b1, &n.bn1),
        (&n.w2, &n.b2, &n.bn2),
        (&n.w3, &n.b3, &n.bn3),
    ] {
        out.push(values(w.val()));
        out.push(values(b.val()));
        out.push(values(bn.gamma.val()));
        out.push(values(bn.beta.val()));
        out.push(values(bn.running_mean.value()));
        out.push(values(bn.running_var.value()));
    }
    out.push(values(n.fc_w.val()));
    out.push(values(n.fc_b.val()));
    out.push(t.mean.clone());
    out
}

/// Saves a trained network into `dir` (created if needed), every file atomically.
///
/// # Errors
/// If a file cannot be written.
pub fn save(t: &Trained, classes: &[String], job: &str, seed: u64, dir: &Path) -> Result<()> {
    for ((name, shape), v) in files(&t.cfg).into_iter().zip(tensors(t)) {
        let a = ArrayD::from_shape_vec(IxDyn(&shape), v).expect("tensor shape");
        write_npy(&dir.join(format!("{name}.npy")), &a)?;
    }
    let info = NetworkInfo {
        format: FORMAT,
        config: t.cfg,
        classes: classes.to_vec(),
        job: job.to_string(),
        seed,
    };
    atomic_write(&dir.join("network.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &info)?;
        Ok(())
    })
}

/// A network loaded for prediction: the network, its 'zerocenter' mean and `network.json`.
pub struct Loaded {
    /// The network with its running BN statistics.
    pub net: Net<Cpu>,
    /// The 'zerocenter' mean.
    pub mean: Vec<f32>,
    /// `network.json`.
    pub info: NetworkInfo,
}

impl Loaded {
    /// The loaded network as a predictor (no training record: no epochs, accuracies `NaN`).
    pub fn into_trained(self) -> Trained {
        Trained {
            cfg: self.info.config,
            net: self.net,
            mean: self.mean,
            epochs: vec![],
            train_accuracy: f64::NAN,
            validation_accuracy: f64::NAN,
            seconds: 0.0,
            samples_per_second: f64::NAN,
            batch_size: 0,
        }
    }
}

/// The network's description, `network.json`, checked: its format, geometry and class names.
fn read_info(dir: &Path) -> Result<NetworkInfo> {
    let json = dir.join("network.json");
    let text = std::fs::read_to_string(&json)
        .with_context(|| format!("{}: cannot read", json.display()))?;
    let info: NetworkInfo = serde_json::from_str(crate::io::strip_bom(&text))
        .with_context(|| format!("{}: not a network description", json.display()))?;
    if info.format != FORMAT {
        bail!(
            "{}: format {} (this version reads {FORMAT})",
            json.display(),
            info.format
        );
    }
    info.config
        .check()
        .with_context(|| format!("{}: geometry", json.display()))?;
    if info.classes.len() != info.config.classes {
        bail!(
            "{}: {} class names for {} classes",
            json.display(),
            info.classes.len(),
            info.config.classes
        );
    }
    Ok(info)
}

/// The network's arrays in the order of [`files`], each checked for its shape and finite
/// values.
fn read_arrays(dir: &Path, config: &NetConfig) -> Result<Vec<Vec<f32>>> {
    let mut arrays = vec![];
    for (name, shape) in files(config) {
        let path = dir.join(format!("{name}.npy"));
        let header = crate::io::npy::read_raw_header(&path)?;
        if header.shape != shape {
            bail!(
                "{}: shape {:?}, expected {:?}",
                path.display(),
                header.shape,
                shape
            );
        }
        let a: ArrayD<f32> = ndarray_npy::read_npy(&path)
            .with_context(|| format!("{}: not a float32 array", path.display()))?;
        if a.iter().any(|x| !x.is_finite()) {
            bail!("{}: holds values that are not finite", path.display());
        }
        arrays.push(a.into_raw_vec_and_offset().0);
    }
    Ok(arrays)
}

/// Loads a network saved by [`save`], checking every file's shape and finiteness.
///
/// # Errors
/// A message naming the folder and the file for a missing, misshapen or non-finite file.
pub fn load(dir: &Path) -> Result<Loaded> {
    let info = read_info(dir)?;
    let arrays = read_arrays(dir, &info.config)?;
    let device: burn::tensor::Device<Cpu> = Default::default();
    let cfg = info.config;
    let mut rest: Vec<(Vec<usize>, Vec<f32>)> = files(&cfg)
        .into_iter()
        .map(|(_, s)| s)
        .zip(arrays)
        .collect();
    rest.reverse();
    let mut take = || rest.pop().expect("one array per file");
    let vec1 = |take: &mut dyn FnMut() -> (Vec<usize>, Vec<f32>)| -> Tensor<Cpu, 1> {
        let (s, v) = take();
        Tensor::from_data(TensorData::new(v, [s[0]]), &device)
    };
    let block = |take: &mut dyn FnMut() -> (Vec<usize>, Vec<f32>)| {
        let (s, v) = take();
        let w = Param::from_tensor(Tensor::<Cpu, 4>::from_data(
            TensorData::new(v, [s[0], s[1], s[2], s[3]]),
            &device,
        ));
        let b = Param::from_tensor(vec1(take));
        let bn = Bn {
            gamma: Param::from_tensor(vec1(take)),
            beta: Param::from_tensor(vec1(take)),
            running_mean: RunningState::new(vec1(take)),
            running_var: RunningState::new(vec1(take)),
            updates: Default::default(),
        };
        (w, b, bn)
    };
    let blocks = [block(&mut take), block(&mut take), block(&mut take)];
    let (s, v) = take();
    let fc_w = Param::from_tensor(Tensor::<Cpu, 2>::from_data(
        TensorData::new(v, [s[0], s[1]]),
        &device,
    ));
    let (s, v) = take();
    let fc_b = Param::from_tensor(Tensor::<Cpu, 1>::from_data(
        TensorData::new(v, [s[0]]),
        &device,
    ));
    let (_, mean) = take();
    Ok(Loaded {
        net: Net::from_parts(blocks, (fc_w, fc_b), (cfg.height, cfg.width)),
        mean,
        info,
    })
}
