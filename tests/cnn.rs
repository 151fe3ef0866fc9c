//! The CNN building blocks against the dissertation and against obviously correct oracles:
//! the layer tables of Tables 18 and 23 (activations and learnables), MATLAB's 'same'
//! padding, the space-to-depth form of conv1 against a direct convolution, the batch norm
//! against its formula, a finite-difference gradient check on a tiny input, a trivially
//! separable toy set learnt to > 95 %, and the saved network predicting as before.

mod common;

use burn::module::{AutodiffModule, Param};
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
    let (c, tr, va, opts) = common::toy_case();
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
    let again = loaded.into_trained().predict(&va.images);
    assert_eq!(before, again);
    // The same seed trains the same network.
    let t2 = train(&c, &opts, &tr, &va, 7);
    assert_eq!(t2.epochs, t.epochs);
}

/// Seeded standard-normal values.
fn normals(n: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            z as f32
        })
        .collect()
}

/// The oracle of a block, in f64 with plain loops: direct convolution with bias, batch
/// normalisation with the batch's statistics, ReLU and (if asked) 2x2 max pooling; returns
/// `sum(output * r)` (a scalar whose gradient is the backward pass given `r`) and the output.
#[allow(clippy::too_many_arguments)]
fn block_oracle(
    g: &isar_clutter::apps::cnn::fast::BlockGeom,
    x: &[f64],
    w: &[f64],
    bias: &[f64],
    gamma: &[f64],
    beta: &[f64],
    r: &[f64],
) -> (f64, Vec<f64>) {
    let (n, c, h, wd, f, k) = (g.n, g.c, g.h, g.w, g.f, g.k);
    let (oh, ow) = (g.oh, g.ow);
    let mut z = vec![0.0f64; n * f * oh * ow];
    for s in 0..n {
        for o in 0..f {
            for i in 0..oh {
                for j in 0..ow {
                    let mut acc = bias[o];
                    for ci in 0..c {
                        for a in 0..k {
                            for b in 0..k {
                                let ih = (i * g.stride + a) as isize - g.top as isize;
                                let iw = (j * g.stride + b) as isize - g.left as isize;
                                if ih >= 0 && iw >= 0 && (ih as usize) < h && (iw as usize) < wd {
                                    acc += w[((o * c + ci) * k + a) * k + b]
                                        * x[((s * c + ci) * h + ih as usize) * wd + iw as usize];
                                }
                            }
                        }
                    }
                    z[((s * f + o) * oh + i) * ow + j] = acc;
                }
            }
        }
    }
    let m = (n * oh * ow) as f64;
    let mut y = z.clone();
    for o in 0..f {
        let vals = || (0..n).flat_map(|s| z[(s * f + o) * oh * ow..][..oh * ow].iter());
        let mean = vals().sum::<f64>() / m;
        let var = vals().map(|v| (v - mean) * (v - mean)).sum::<f64>() / m;
        for s in 0..n {
            for v in &mut y[(s * f + o) * oh * ow..][..oh * ow] {
                *v = ((*v - mean) / (var + 1e-5).sqrt() * gamma[o] + beta[o]).max(0.0);
            }
        }
    }
    let out = if g.pool {
        let (ph, pw) = (oh / 2, ow / 2);
        let mut p = vec![0.0f64; n * f * ph * pw];
        for sf in 0..n * f {
            for i in 0..ph {
                for j in 0..pw {
                    let at = |a: usize, b: usize| y[(sf * oh + 2 * i + a) * ow + 2 * j + b];
                    p[(sf * ph + i) * pw + j] = at(0, 0).max(at(0, 1)).max(at(1, 0)).max(at(1, 1));
                }
            }
        }
        p
    } else {
        y
    };
    (out.iter().zip(r).map(|(a, b)| a * b).sum(), out)
}

/// Every hand-written block kernel ([`isar_clutter::apps::cnn::fast`]) against the f64 oracle
/// on seeded random input: the forward output, and the gradients of the input, weights, bias,
/// BN scale and offset against central differences of the oracle (stride 1 and 2, 'same'
/// padding split unevenly, with and without pooling, odd sides).
#[test]
fn fast_blocks_match_the_plain_loop_oracle_forward_and_gradients() {
    use isar_clutter::apps::cnn::fast::{block_train, BlockGeom, FlexTrain};
    let geoms = [
        // conv1 in space-to-depth form: stride 1, no padding, pooling.
        (3, 5, 7, 7, 4, 4, 1, 0, 0, 4, 4, true),
        // conv2: 4x4 stride 2 'same' on an odd side (padding 1 above, 2 below), pooling.
        (3, 3, 9, 9, 4, 4, 2, 1, 1, 5, 5, true),
        // conv3: 2x2 stride 2 'same', no pooling.
        (4, 3, 5, 4, 5, 2, 2, 0, 0, 3, 2, false),
        // Rows of a whole tile (32 columns, stride 1): the im2col's fixed-size copies, and
        // products over several tiles.
        (2, 2, 35, 35, 3, 4, 1, 0, 0, 32, 32, true),
        // The networks' second convolution: 4x4 stride 2 'same' (padding 1 and 2), rows of 8
        // columns (im2col through padded planes split by column parity).
        (3, 3, 15, 15, 4, 4, 2, 1, 1, 8, 8, true),
        // Rows of 12 columns, which do not divide a tile: im2col through its row buffer.
        (5, 2, 12, 12, 3, 3, 1, 1, 1, 12, 12, true),
    ];
    let dev = Default::default();
    for (case, &(n, c, h, w, f, k, stride, top, left, oh, ow, pool)) in geoms.iter().enumerate() {
        let g = BlockGeom {
            n,
            c,
            h,
            w,
            f,
            k,
            stride,
            top,
            left,
            oh,
            ow,
            pool,
        };
        let seed = 100 * case as u64;
        let x = normals(n * c * h * w, seed + 1);
        let wt = normals(f * c * k * k, seed + 2);
        let bias = normals(f, seed + 3);
        let gamma: Vec<f32> = normals(f, seed + 4).iter().map(|v| 1.0 + 0.3 * v).collect();
        let beta = normals(f, seed + 5);
        let [on, of, oh2, ow2] = g.out_shape();
        let r = normals(on * of * oh2 * ow2, seed + 6);
        let t4 = |v: &[f32], shape: [usize; 4]| {
            Tensor::<FlexTrain, 4>::from_data(TensorData::new(v.to_vec(), shape), &dev)
        };
        let t1 = |v: &[f32]| {
            Tensor::<FlexTrain, 1>::from_data(TensorData::new(v.to_vec(), [v.len()]), &dev)
                .require_grad()
        };
        let xt = t4(&x, [n, c, h, w]).require_grad();
        let wt_t = t4(&wt, [f, c, k, k]).require_grad();
        let (bt, gt, betat) = (t1(&bias), t1(&gamma), t1(&beta));
        let (out, _, _) = block_train(
            &g,
            xt.clone(),
            wt_t.clone(),
            bt.clone(),
            gt.clone(),
            betat.clone(),
            1e-5,
        );
        let rt = t4(&r, [on, of, oh2, ow2]);
        let grads = (out.clone() * rt).sum().backward();
        let got: Vec<f32> = out.inner().into_data().to_vec().unwrap();
        let f64s = |v: &[f32]| v.iter().map(|&a| f64::from(a)).collect::<Vec<f64>>();
        let mut params = [f64s(&x), f64s(&wt), f64s(&bias), f64s(&gamma), f64s(&beta)];
        let r64 = f64s(&r);
        let eval = |p: &[Vec<f64>; 5]| block_oracle(&g, &p[0], &p[1], &p[2], &p[3], &p[4], &r64);
        let (_, want) = eval(&params);
        let scale = want.iter().fold(1.0f64, |a, b| a.max(b.abs()));
        for (a, b) in got.iter().zip(&want) {
            assert!(
                (f64::from(*a) - b).abs() < 1e-4 * scale,
                "case {case}: forward {a} vs {b}"
            );
        }
        let fast_grads: [Vec<f32>; 5] = [
            xt.grad(&grads).unwrap().into_data().to_vec().unwrap(),
            wt_t.grad(&grads).unwrap().into_data().to_vec().unwrap(),
            bt.grad(&grads).unwrap().into_data().to_vec().unwrap(),
            gt.grad(&grads).unwrap().into_data().to_vec().unwrap(),
            betat.grad(&grads).unwrap().into_data().to_vec().unwrap(),
        ];
        let fds: Vec<Vec<f64>> = (0..5)
            .map(|pi| {
                let mut fd = vec![0.0f64; params[pi].len()];
                for i in 0..fd.len() {
                    let h = 1e-6;
                    let v0 = params[pi][i];
                    params[pi][i] = v0 + h;
                    let up = eval(&params).0;
                    params[pi][i] = v0 - h;
                    let down = eval(&params).0;
                    params[pi][i] = v0;
                    fd[i] = (up - down) / (2.0 * h);
                }
                fd
            })
            .collect();
        // The convolution's bias gradient is zero in exact arithmetic (batch normalisation
        // removes the bias); in f32 it is a sum of `n oh ow` terms of about the size of the
        // offset's gradient, each rounded: at most that many epsilons of that size.
        let beta_scale = fds[4].iter().fold(1e-3f64, |a, b| a.max(b.abs()));
        let rounding = (n * oh * ow) as f64 * f64::from(f32::EPSILON) * beta_scale;
        for (pi, name) in ["x", "w", "bias", "gamma", "beta"].iter().enumerate() {
            let fd = &fds[pi];
            let gscale = fd.iter().fold(1e-3f64, |a, b| a.max(b.abs()));
            let tol = 1e-3 * gscale + if pi == 2 { rounding } else { 0.0 };
            for (i, (a, b)) in fast_grads[pi].iter().zip(fd).enumerate() {
                assert!(
                    (f64::from(*a) - b).abs() < tol,
                    "case {case}: d{name}[{i}]: fast {a}, oracle {b} (scale {gscale})"
                );
            }
        }
    }
}

/// The whole network with the fast kernels (`Autodiff<Flex>`) against the same network as a
/// chain of stock burn operations (`Autodiff<Flex, BalancedCheckpointing>`, a backend the fast
/// path does not take): logits, loss and every parameter's gradient, on both tables' nets.
#[test]
fn fast_network_matches_the_stock_burn_network() {
    use burn::backend::autodiff::checkpoint::strategy::BalancedCheckpointing;
    type Stock = burn::backend::Autodiff<Cpu, BalancedCheckpointing>;
    for (arch, classes) in [(Arch::Table18, 4), (Arch::Table23, 25)] {
        let c = NetConfig {
            arch,
            height: 32,
            width: 37,
            classes,
        };
        let n = 6;
        let x = normals(n * c.prepared_len(), 17);
        let labels: Vec<usize> = (0..n).map(|i| i % classes).collect();
        let [pc, ph, pw] = c.prepared_shape();
        let dev = Default::default();
        let fast = c.init::<CpuTrain>(21, &dev);
        let stock = c.init::<Stock>(21, &dev);
        let lf = isar_clutter::apps::cnn::train::loss(
            fast.logits(Tensor::from_data(
                TensorData::new(x.clone(), [n, pc, ph, pw]),
                &dev,
            )),
            &labels,
            classes,
            &dev,
        );
        let ls = isar_clutter::apps::cnn::train::loss(
            stock.logits(Tensor::from_data(
                TensorData::new(x.clone(), [n, pc, ph, pw]),
                &dev,
            )),
            &labels,
            classes,
            &dev,
        );
        let gf = lf.backward();
        let gs = ls.backward();
        let close = |name: &str, a: Vec<f32>, b: Vec<f32>| {
            assert_eq!(a.len(), b.len());
            // The conv biases' gradients are zero up to rounding (BN follows): an absolute floor.
            // Each is the f32 sum of n x oh x ow (about 10^3) cancelling terms, summed in another
            // order by each network; on a CPU without AVX-512 they differed by 2.2e-7 (the scale
            // 1e-4 gave a tolerance of 2e-7), so the floor is 1e-3 (a tolerance of 2e-6, still
            // far below the weights' gradients).
            let scale = b.iter().fold(1e-3f32, |m, v| m.max(v.abs()));
            for (i, (p, q)) in a.iter().zip(&b).enumerate() {
                assert!(
                    (p - q).abs() <= 2e-3 * scale,
                    "{arch:?} {name}[{i}]: fast {p}, stock {q} (scale {scale})"
                );
            }
        };
        macro_rules! grad {
            ($($f:ident).+) => {
                close(
                    stringify!($($f).+),
                    fast.$($f).+.val().grad(&gf).unwrap().into_data().to_vec().unwrap(),
                    stock.$($f).+.val().grad(&gs).unwrap().into_data().to_vec().unwrap(),
                )
            };
        }
        close(
            "loss",
            lf.into_data().to_vec().unwrap(),
            ls.into_data().to_vec().unwrap(),
        );
        grad!(w1);
        grad!(b1);
        grad!(bn1.gamma);
        grad!(bn1.beta);
        grad!(w2);
        grad!(b2);
        grad!(bn2.gamma);
        grad!(bn2.beta);
        grad!(w3);
        grad!(b3);
        grad!(bn3.gamma);
        grad!(bn3.beta);
        grad!(fc_w);
        grad!(fc_b);
        // The running statistics were updated alike.
        close(
            "bn1.running_var",
            fast.bn1
                .running_var
                .value()
                .inner()
                .into_data()
                .to_vec()
                .unwrap(),
            stock
                .bn1
                .running_var
                .value()
                .inner()
                .into_data()
                .to_vec()
                .unwrap(),
        );
        close(
            "bn3.running_mean",
            fast.bn3
                .running_mean
                .value()
                .inner()
                .into_data()
                .to_vec()
                .unwrap(),
            stock
                .bn3
                .running_mean
                .value()
                .inner()
                .into_data()
                .to_vec()
                .unwrap(),
        );
        // Inference (running statistics) agrees too.
        let fi = fast.valid();
        let si = stock.valid();
        let xi = || Tensor::<Cpu, 4>::from_data(TensorData::new(x.clone(), [n, pc, ph, pw]), &dev);
        close(
            "inference logits",
            fi.logits(xi()).into_data().to_vec().unwrap(),
            si.logits(xi()).into_data().to_vec().unwrap(),
        );
    }
}

/// A training on a rayon pool of 1 thread and one on a pool of 2 threads give bit-identical
/// epochs, accuracies and weights.
#[test]
fn training_is_bit_identical_on_1_and_2_threads() {
    let c = NetConfig {
        arch: Arch::Table23,
        height: 32,
        width: 32,
        classes: 3,
    };
    let mut set = Labelled::default();
    let mut val = Labelled::default();
    let v = normals(2 * 30 * 32 * 32, 5);
    for (k, img) in v.chunks_exact(2 * 32 * 32).enumerate() {
        let img: Vec<Complex32> = img
            .chunks_exact(2)
            .map(|p| Complex32::new(p[0], p[1]))
            .collect();
        if k < 24 {
            set.push(&img, k % 3);
        } else {
            val.push(&img, k % 3);
        }
    }
    let opts = TrainingOptions {
        batch_size: 8,
        epochs: 2,
        ..TrainingOptions::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| train(&c, &opts, &set, &val, 3))
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.epochs, b.epochs);
    assert_eq!(a.train_accuracy.to_bits(), b.train_accuracy.to_bits());
    let wa: Vec<f32> = a.net.w1.val().into_data().to_vec().unwrap();
    let wb: Vec<f32> = b.net.w1.val().into_data().to_vec().unwrap();
    assert_eq!(wa, wb);
    let fa: Vec<f32> = a.net.fc_w.val().into_data().to_vec().unwrap();
    let fb: Vec<f32> = b.net.fc_w.val().into_data().to_vec().unwrap();
    assert_eq!(fa, fb);
}

/// Clutter of small power trained with few mini-batches (one per epoch, as a 100-sample
/// training does) still predicts in inference mode: the running BN statistics average the
/// batches seen instead of keeping most of their initial variance of 1 (which made every
/// prediction one class when the data's variance is 1e-6).
#[test]
fn few_updates_on_small_power_data_still_predict() {
    let c = common::toy_net();
    let (tr, va) = common::toy_sets(4, 32, 32, 1e-3);
    let opts = TrainingOptions {
        batch_size: 32,
        epochs: 6,
        ..TrainingOptions::default()
    };
    let t = train(&c, &opts, &tr, &va, 9);
    assert!(
        t.validation_accuracy > 0.9,
        "validation accuracy {}",
        t.validation_accuracy
    );
}
