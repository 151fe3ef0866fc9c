//! The CNN building blocks against the dissertation and against obviously correct oracles:
//! the layer tables of Tables 18 and 23 (activations and learnables), MATLAB's 'same'
//! padding, the space-to-depth form of conv1 against a direct convolution, the batch norm
//! against its formula, a finite-difference gradient check on a tiny input, a trivially
//! separable toy set learnt to > 95 %, and the saved network predicting as before.

use burn::module::Param;
use burn::tensor::{Tensor, TensorData};
use isar_clutter::apps::cnn::net::{same_padding, Arch, NetConfig};
use isar_clutter::apps::cnn::train::{train, Cpu, CpuTrain, Labelled, TrainingOptions};
use num_complex::Complex32;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};

fn cfg(arch: Arch, classes: usize) -> NetConfig {
    NetConfig {
        arch,
        height: 64,
        width: 64,
        classes,
    }
}

/// Table 18 (with its printed 2 classes) and Table 23, row by row: activations `H x W x C`
/// and learnables (weights + biases, or offset + scale).
#[test]
fn layer_shapes_and_learnables_match_tables_18_and_23() {
    let t18 = cfg(Arch::Table18, 2).layers();
    let expect18: [(&str, [usize; 3], usize); 13] = [
        ("conv1", [32, 32, 16], 8 * 8 * 2 * 16 + 16),
        ("batchnorm_1", [32, 32, 16], 32),
        ("relu1", [32, 32, 16], 0),
        ("maxpool_1", [16, 16, 16], 0),
        ("conv2", [8, 8, 64], 4 * 4 * 16 * 64 + 64),
        ("batchnorm_2", [8, 8, 64], 128),
        ("relu2", [8, 8, 64], 0),
        ("maxpool_2", [4, 4, 64], 0),
        ("conv3", [2, 2, 128], 2 * 2 * 64 * 128 + 128),
        ("batchnorm_3", [2, 2, 128], 256),
        ("relu3", [2, 2, 128], 0),
        ("fc", [1, 1, 2], 2 * 512 + 2),
        ("", [0; 3], 0),
    ];
    assert_eq!(t18.len(), 12);
    for (row, (name, act, learn)) in t18.iter().zip(expect18) {
        assert_eq!(
            (row.name.as_str(), row.activations, row.learnables),
            (name, act, learn)
        );
    }
    let t23 = cfg(Arch::Table23, 25).layers();
    let expect23: [(&str, [usize; 3], usize); 12] = [
        ("conv1", [32, 32, 64], 8 * 8 * 2 * 64 + 64),
        ("batchnorm_1", [32, 32, 64], 128),
        ("relu1", [32, 32, 64], 0),
        ("maxpool_1", [16, 16, 64], 0),
        ("conv2", [8, 8, 16], 4 * 4 * 64 * 16 + 16),
        ("batchnorm_2", [8, 8, 16], 32),
        ("relu2", [8, 8, 16], 0),
        ("maxpool_2", [4, 4, 16], 0),
        ("conv3", [2, 2, 16], 2 * 2 * 16 * 16 + 16),
        ("batchnorm_3", [2, 2, 16], 32),
        ("relu3", [2, 2, 16], 0),
        ("fc", [1, 1, 25], 25 * 64 + 25),
    ];
    for (row, (name, act, learn)) in t23.iter().zip(expect23) {
        assert_eq!(
            (row.name.as_str(), row.activations, row.learnables),
            (name, act, learn)
        );
    }
    // The network built holds exactly the learnables the table counts.
    for c in [cfg(Arch::Table18, 4), cfg(Arch::Table23, 25)] {
        let net = c.init::<Cpu>(1, &Default::default());
        use burn::module::Module;
        // burn counts the BN running mean and variance too (not learnable: 2 per channel).
        let running: usize = 2 * c.arch.filters().iter().sum::<usize>();
        assert_eq!(net.num_params(), c.learnables() + running, "{c:?}");
    }
    // The logits have one column per class.
    let c = cfg(Arch::Table18, 4);
    let net = c.init::<Cpu>(1, &Default::default());
    let [ch, h, w] = c.prepared_shape();
    let x = Tensor::<Cpu, 4>::zeros([3, ch, h, w], &Default::default());
    assert_eq!(net.logits(x).dims(), [3, 4]);
}

#[test]
fn same_padding_follows_matlab() {
    // out = ceil(n / s); total = max((out - 1) s + k - n, 0), smaller half first.
    assert_eq!(same_padding(64, 8, 2), (32, 3, 3));
    assert_eq!(same_padding(16, 4, 2), (8, 1, 1));
    assert_eq!(same_padding(4, 2, 2), (2, 0, 0));
    assert_eq!(same_padding(63, 8, 2), (32, 3, 4));
    assert_eq!(same_padding(5, 4, 2), (3, 1, 2));
    assert_eq!(same_padding(7, 2, 2), (4, 0, 1));
}

/// Direct 'same' stride-2 convolution of one `[C, H, W]` image (the oracle).
fn conv_direct(
    x: &[f32],
    c: usize,
    h: usize,
    w: usize,
    wt: &[f32],
    f: usize,
    k: usize,
) -> Vec<f32> {
    let (oh, top, _) = same_padding(h, k, 2);
    let (ow, left, _) = same_padding(w, k, 2);
    let mut out = vec![0.0f32; f * oh * ow];
    for o in 0..f {
        for i in 0..oh {
            for j in 0..ow {
                let mut acc = 0.0f64;
                for ci in 0..c {
                    for a in 0..k {
                        for b in 0..k {
                            let (r, q) = (
                                (2 * i + a) as isize - top as isize,
                                (2 * j + b) as isize - left as isize,
                            );
                            if r >= 0 && q >= 0 && (r as usize) < h && (q as usize) < w {
                                acc += f64::from(wt[((o * c + ci) * k + a) * k + b])
                                    * f64::from(x[(ci * h + r as usize) * w + q as usize]);
                            }
                        }
                    }
                }
                out[(o * oh + i) * ow + j] = acc as f32;
            }
        }
    }
    out
}

/// conv1 as the network computes it (space-to-depth input, rearranged 4x4 kernels) equals the
/// direct 8x8 stride-2 'same' convolution, including an odd image size (asymmetric padding),
/// checked through the first block's pre-activation: BN in inference mode with running mean 0,
/// variance 1, scale 1 and offset 0 is the identity up to `1/sqrt(1 + eps)`.
#[test]
fn space_to_depth_conv1_equals_the_direct_convolution() {
    for (h, w) in [(64, 64), (37, 45)] {
        let c = NetConfig {
            arch: Arch::Table18,
            height: h,
            width: w,
            classes: 2,
        };
        let net = c.init::<Cpu>(5, &Default::default());
        let mut rng = ChaCha20Rng::seed_from_u64(9);
        let img: Vec<Complex32> = (0..h * w)
            .map(|_| {
                let (a, b): (f64, f64) = (
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                Complex32::new(a as f32, b as f32)
            })
            .collect();
        let mut prepared = vec![0.0; c.prepared_len()];
        c.prepare(&img, &vec![0.0; 2 * h * w], &mut prepared);
        let [pc, ph, pw] = c.prepared_shape();
        let x = Tensor::<Cpu, 4>::from_data(
            TensorData::new(prepared, [1, pc, ph, pw]),
            &Default::default(),
        );
        let got: Vec<f32> = net.conv1_output(x).into_data().to_vec().unwrap();
        let planes: Vec<f32> = img
            .iter()
            .map(|z| z.re)
            .chain(img.iter().map(|z| z.im))
            .collect();
        let wt: Vec<f32> = net.w1.val().into_data().to_vec().unwrap();
        let want = conv_direct(&planes, 2, h, w, &wt, 16, 8);
        assert_eq!(got.len(), want.len());
        let max = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(max < 1e-4, "{h}x{w}: max difference {max}");
    }
}

/// A finite-difference check of the gradient of the loss with respect to a few weights of
/// every layer, on a tiny input in f32: central differences with step 2e-3 agree with the
/// autodiff gradient to 5 % relative (f32 rounding of a loss near 1, about 1e-7, bounds the
/// difference quotient's error near 1e-4; the rest is curvature and ReLU/pooling kinks).
#[test]
fn gradients_agree_with_finite_differences() {
    let c = NetConfig {
        arch: Arch::Table18,
        height: 32,
        width: 32,
        classes: 3,
    };
    let dev = Default::default();
    let mut rng = ChaCha20Rng::seed_from_u64(3);
    let n = 4;
    let mut x = vec![0.0f32; n * c.prepared_len()];
    for v in x.iter_mut() {
        let z: f64 = StandardNormal.sample(&mut rng);
        *v = z as f32;
    }
    let labels = [0usize, 1, 2, 1];
    let [pc, ph, pw] = c.prepared_shape();
    let loss_of = |net: &isar_clutter::apps::cnn::net::Net<CpuTrain>| {
        let xt =
            Tensor::<CpuTrain, 4>::from_data(TensorData::new(x.clone(), [n, pc, ph, pw]), &dev);
        isar_clutter::apps::cnn::train::loss(net.logits(xt), &labels, c.classes, &dev)
    };
    let net = c.init::<CpuTrain>(11, &dev);
    let loss = loss_of(&net);
    let grads = loss.backward();
    let checks: Vec<(&str, Vec<f32>, Vec<f32>)> = vec![
        (
            "w1",
            net.w1
                .val()
                .grad(&grads)
                .unwrap()
                .into_data()
                .to_vec()
                .unwrap(),
            net.w1.val().inner().into_data().to_vec().unwrap(),
        ),
        (
            "w2",
            net.w2
                .val()
                .grad(&grads)
                .unwrap()
                .into_data()
                .to_vec()
                .unwrap(),
            net.w2.val().inner().into_data().to_vec().unwrap(),
        ),
        (
            "w3",
            net.w3
                .val()
                .grad(&grads)
                .unwrap()
                .into_data()
                .to_vec()
                .unwrap(),
            net.w3.val().inner().into_data().to_vec().unwrap(),
        ),
        (
            "fc_w",
            net.fc_w
                .val()
                .grad(&grads)
                .unwrap()
                .into_data()
                .to_vec()
                .unwrap(),
            net.fc_w.val().inner().into_data().to_vec().unwrap(),
        ),
    ];
    let mut compared = 0;
    for (name, g, _) in &checks {
        // The largest few gradient entries (small ones drown in f32 noise).
        let mut idx: Vec<usize> = (0..g.len()).collect();
        idx.sort_by(|&a, &b| g[b].abs().total_cmp(&g[a].abs()));
        for &i in idx.iter().take(3) {
            let h = 2e-3f32;
            let at = |delta: f32| -> f64 {
                let mut net = c.init::<CpuTrain>(11, &dev);
                match *name {
                    "w1" => net.w1 = nudged(&net.w1, i, delta),
                    "w2" => net.w2 = nudged(&net.w2, i, delta),
                    "w3" => net.w3 = nudged(&net.w3, i, delta),
                    _ => net.fc_w = nudged(&net.fc_w, i, delta),
                }
                let l: f32 = loss_of(&net).into_scalar();
                f64::from(l)
            };
            let fd = (at(h) - at(-h)) / (2.0 * f64::from(h));
            let ad = f64::from(g[i]);
            let rel = (fd - ad).abs() / ad.abs().max(1e-3);
            assert!(
                rel < 0.05,
                "{name}[{i}]: autodiff {ad}, finite difference {fd}"
            );
            compared += 1;
        }
    }
    assert_eq!(compared, 12);
}

/// `p` with `delta` added to element `i`.
fn nudged<const D: usize>(
    p: &Param<Tensor<CpuTrain, D>>,
    i: usize,
    delta: f32,
) -> Param<Tensor<CpuTrain, D>> {
    let t = p.val().inner();
    let dims = t.dims();
    let mut v: Vec<f32> = t.into_data().to_vec().unwrap();
    v[i] += delta;
    Param::from_tensor(Tensor::from_data(
        TensorData::new(v, dims),
        &Default::default(),
    ))
}

/// Two classes that differ in a large mean at different places are learnt to > 95 % in a few
/// epochs on a few samples.
#[test]
fn a_trivially_separable_toy_set_is_learnt() {
    let c = NetConfig {
        arch: Arch::Table18,
        height: 32,
        width: 32,
        classes: 2,
    };
    let mut rng = ChaCha20Rng::seed_from_u64(1);
    let mut make = |n: usize| {
        let mut set = Labelled::default();
        for k in 0..n {
            let label = k % 2;
            let img: Vec<Complex32> = (0..32 * 32)
                .map(|p| {
                    let (a, b): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    let bright = if (p / 32 < 16) == (label == 0) {
                        3.0
                    } else {
                        0.0
                    };
                    Complex32::new((a + bright) as f32, b as f32)
                })
                .collect();
            set.push(&img, label);
        }
        set
    };
    let (tr, va) = (make(64), make(64));
    let opts = TrainingOptions {
        batch_size: 16,
        epochs: 4,
        ..TrainingOptions::default()
    };
    let t = train(&c, &opts, &tr, &va, 7);
    assert!(
        t.validation_accuracy > 0.95,
        "validation accuracy {}",
        t.validation_accuracy
    );
    assert!(
        t.train_accuracy > 0.95,
        "train accuracy {}",
        t.train_accuracy
    );
    assert_eq!(t.epochs.len(), 4);
    // The loss goes down.
    assert!(t.epochs[3].loss < t.epochs[0].loss, "{:?}", t.epochs);
    // Saved and loaded again, the network predicts the same classes.
    let dir = tempfile::tempdir().unwrap();
    isar_clutter::apps::cnn::store::save(
        &t,
        &["top".into(), "bottom".into()],
        "toy",
        7,
        dir.path(),
    )
    .unwrap();
    let loaded = isar_clutter::apps::cnn::store::load(dir.path()).unwrap();
    let before = t.predict(&va.images);
    let again = isar_clutter::apps::cnn::train::Trained::from_loaded(loaded).predict(&va.images);
    assert_eq!(before, again);
    // The same seed trains the same network.
    let t2 = train(&c, &opts, &tr, &va, 7);
    assert_eq!(t2.epochs, t.epochs);
}
