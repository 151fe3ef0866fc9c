//! Training on a GPU (`training: {device: cuda}`: the cuDNN route for SGDM) in a build with
//! the `cuda` feature (`make test-cuda`), on a machine with an NVIDIA GPU: a toy set learnt on
//! the GPU, the network handed back to the CPU predicting what the GPU's validation measured,
//! and the GPU's first epoch beside the CPU's from the same seed (the same initial weights and
//! batches: their losses agree to rounding); in [`cudnn`], one step against the CPU value for
//! value, the captured CUDA graph against the uncaptured steps and prediction on the GPU. Where
//! no NVIDIA driver can be loaded the test says
//! that it skipped and passes (CI has no GPU); without the feature the file holds no test.

#![cfg(feature = "cuda")]

mod common;

use common::nvidia_driver as driver;

use isar_clutter::apps::cnn::device::train_on_device;
use isar_clutter::apps::cnn::train::{train, Device, TrainingOptions};

#[test]
fn a_toy_set_is_learnt_on_the_gpu_and_predicts_on_the_cpu() {
    if !driver() {
        eprintln!("skipped: no NVIDIA driver (libcuda.so.1) on this machine");
        return;
    }
    let (c, tr, va, cpu) = common::toy_case();
    let gpu = TrainingOptions {
        device: Device::Cuda,
        ..cpu
    };
    let t = train_on_device(&c, &gpu, &tr, &va, 7).expect("a CUDA training");
    eprintln!("cuda: {:?}", t.epochs);
    assert!(t.validation_accuracy > 0.95, "{}", t.validation_accuracy);
    assert!(t.train_accuracy > 0.95, "{}", t.train_accuracy);
    assert!(t.epochs[3].loss < t.epochs[0].loss, "{:?}", t.epochs);
    // The network came back to the CPU: its predictions give the accuracy the training
    // reported for the validation set.
    let predicted = t.predict(&va.images);
    let right = predicted
        .iter()
        .zip(&va.labels)
        .filter(|(p, l)| p == l)
        .count();
    let accuracy = right as f64 / va.len() as f64;
    assert!(
        (accuracy - t.validation_accuracy).abs() < 1e-12,
        "{accuracy} vs {}",
        t.validation_accuracy
    );
    // The first epoch from the same seed on the CPU: the same initial weights and batches, so
    // the mean loss differs only by f32 rounding of sums taken in another order, which four
    // updates cannot carry to 1e-3 of the loss.
    let on_cpu = train(&c, &cpu, &tr, &va, 7);
    let (g, k) = (t.epochs[0].loss, on_cpu.epochs[0].loss);
    assert!(
        (g - k).abs() <= 1e-3 * k.abs(),
        "first epoch loss: cuda {g}, cpu {k}"
    );
}

mod cudnn {
    //! The cuDNN route against the CPU on seeded input: one SGDM step (with learning rate 1,
    //! so that the change of every value is its gradient plus L2, and a wrong gradient shows at
    //! full size) for three geometries (even and uneven 'same' padding, 4 and 25 classes), the
    //! captured CUDA graph against the same steps issued one by one (bit for bit), and
    //! prediction on the GPU against the CPU's.

    use super::common::nvidia_driver as driver;
    use isar_clutter::apps::cnn::gpu::{self, GpuOptions, Predictor};
    use isar_clutter::apps::cnn::net::{Arch, Net, NetConfig};
    use isar_clutter::apps::cnn::train::{train, Cpu, Labelled, TrainingOptions};
    use num_complex::Complex32;
    use rand::SeedableRng;
    use rand_chacha::ChaCha20Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// `n` images of `cfg`'s size, standard normal, with a class-dependent bright row so that
    /// a network can learn them; labels cycle through the classes.
    fn set(cfg: &NetConfig, n: usize, seed: u64) -> Labelled {
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        let mut s = Labelled::default();
        for k in 0..n {
            let class = k % cfg.classes;
            let img: Vec<Complex32> = (0..cfg.height * cfg.width)
                .map(|p| {
                    let (a, b): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    let bright = if p / cfg.width == 3 * class % cfg.height {
                        3.0
                    } else {
                        0.0
                    };
                    Complex32::new((a + bright) as f32, b as f32)
                })
                .collect();
            s.push(&img, class);
        }
        s
    }

    /// Every value of a network, tensor by tensor (name, values).
    fn values(net: &Net<Cpu>) -> Vec<(&'static str, Vec<f32>)> {
        fn v<const D: usize>(t: burn::tensor::Tensor<Cpu, D>) -> Vec<f32> {
            t.into_data().to_vec().unwrap()
        }
        vec![
            ("w1", v(net.w1.val())),
            ("b1", v(net.b1.val())),
            ("gamma1", v(net.bn1.gamma.val())),
            ("beta1", v(net.bn1.beta.val())),
            ("mean1", v(net.bn1.running_mean.value())),
            ("var1", v(net.bn1.running_var.value())),
            ("w2", v(net.w2.val())),
            ("b2", v(net.b2.val())),
            ("gamma2", v(net.bn2.gamma.val())),
            ("beta2", v(net.bn2.beta.val())),
            ("mean2", v(net.bn2.running_mean.value())),
            ("var2", v(net.bn2.running_var.value())),
            ("w3", v(net.w3.val())),
            ("b3", v(net.b3.val())),
            ("gamma3", v(net.bn3.gamma.val())),
            ("beta3", v(net.bn3.beta.val())),
            ("mean3", v(net.bn3.running_mean.value())),
            ("var3", v(net.bn3.running_var.value())),
            ("fc_w", v(net.fc_w.val())),
            ("fc_b", v(net.fc_b.val())),
        ]
    }

    /// The changes of one step (`after - before`) of the GPU and the CPU agree: to 2e-4 of the
    /// tensor's largest change (f32 sums of thousands of products in another order), and the
    /// running statistics to 1e-4 relative. The convolutions' biases, whose gradient is zero
    /// in exact arithmetic (batch normalisation removes them), only have to stay below 1e-5.
    fn compare(
        before: &Net<Cpu>,
        cpu: &Net<Cpu>,
        gpu: &[(&'static str, Vec<f32>)],
    ) -> Result<(), String> {
        for (((name, b), (_, c)), (_, g)) in values(before).iter().zip(values(cpu)).zip(gpu) {
            if name.starts_with("mean") || name.starts_with("var") {
                for (x, y) in c.iter().zip(g) {
                    if (x - y).abs() > 1e-4 * x.abs().max(1e-3) {
                        return Err(format!("{name}: cpu {x}, gpu {y}"));
                    }
                }
                continue;
            }
            let dc: Vec<f32> = c.iter().zip(b).map(|(x, y)| x - y).collect();
            let dg: Vec<f32> = g.iter().zip(b).map(|(x, y)| x - y).collect();
            if name.starts_with('b') && name.len() == 2 {
                if let Some(x) = dc.iter().chain(&dg).find(|x| x.abs() > 1e-5) {
                    return Err(format!("{name}: a change of {x}"));
                }
                continue;
            }
            let scale = dc.iter().fold(0.0f32, |m, x| m.max(x.abs()));
            for (i, (x, y)) in dc.iter().zip(&dg).enumerate() {
                if (x - y).abs() > 2e-4 * scale {
                    return Err(format!(
                        "{name}[{i}]: change cpu {x}, gpu {y} (largest {scale})"
                    ));
                }
            }
        }
        Ok(())
    }

    #[test]
    fn one_sgdm_step_changes_every_value_as_on_the_cpu() {
        if !driver() {
            eprintln!("skipped: no NVIDIA driver (libcuda.so.1) on this machine");
            return;
        }
        for (arch, height, width, classes) in [
            (Arch::Table18, 64, 64, 4),
            (Arch::Table23, 64, 64, 25),
            (Arch::Table18, 48, 40, 3),
        ] {
            let cfg = NetConfig {
                arch,
                height,
                width,
                classes,
            };
            let data = set(&cfg, 32, 11);
            let opts = TrainingOptions {
                batch_size: 32,
                epochs: 1,
                learning_rate: 1.0,
                ..Default::default()
            };
            let empty = Labelled::default();
            let before: Net<Cpu> = cfg.init(5, &Default::default());
            let cpu = train(&cfg, &opts, &data, &empty, 5);
            let eager = GpuOptions {
                graph: false,
                ..GpuOptions::default()
            };
            let gpu = gpu::train(&cfg, &opts, &data, &empty, 5, eager).expect("the cuDNN route");
            let (lc, lg) = (cpu.epochs[0].loss, gpu.epochs[0].loss);
            assert!(
                (lc - lg).abs() <= 1e-5 * lc,
                "{cfg:?}: loss cpu {lc}, gpu {lg}"
            );
            let got = values(&gpu.net);
            compare(&before, &cpu.net, &got).unwrap_or_else(|e| panic!("{cfg:?}: {e}"));
            // The tolerance sees one value off: the largest change of w2 moved by 1 %.
            let mut off = got.clone();
            let w2 = &mut off.iter_mut().find(|(n, _)| *n == "w2").unwrap().1;
            let b2 = values(&before)
                .into_iter()
                .find(|(n, _)| *n == "w2")
                .unwrap()
                .1;
            let i = (0..w2.len())
                .max_by(|&a, &b| (w2[a] - b2[a]).abs().total_cmp(&(w2[b] - b2[b]).abs()))
                .unwrap();
            w2[i] += 0.01 * (w2[i] - b2[i]);
            assert!(
                compare(&before, &cpu.net, &off).is_err(),
                "{cfg:?}: a perturbed value passed"
            );
            eprintln!("{cfg:?}: one step as on the CPU (loss {lg})");
        }
    }

    #[test]
    fn the_captured_graph_replays_the_steps_bit_for_bit_and_predicts_as_the_cpu() {
        if !driver() {
            eprintln!("skipped: no NVIDIA driver (libcuda.so.1) on this machine");
            return;
        }
        let cfg = NetConfig {
            arch: Arch::Table23,
            height: 64,
            width: 64,
            classes: 5,
        };
        let (tr, va) = (set(&cfg, 96, 1), set(&cfg, 40, 2));
        let opts = TrainingOptions {
            batch_size: 16,
            epochs: 3,
            validation_frequency: 7,
            ..Default::default()
        };
        let graph = gpu::train(&cfg, &opts, &tr, &va, 9, GpuOptions::default()).unwrap();
        let eager = GpuOptions {
            graph: false,
            ..GpuOptions::default()
        };
        let plain = gpu::train(&cfg, &opts, &tr, &va, 9, eager).unwrap();
        assert_eq!(values(&graph.net), values(&plain.net));
        assert_eq!(graph.epochs, plain.epochs);
        // The CPU's training from the same seed: the same losses to rounding over 18 steps.
        let cpu = train(&cfg, &opts, &tr, &va, 9);
        for (g, c) in graph.epochs.iter().zip(&cpu.epochs) {
            assert!((g.loss - c.loss).abs() <= 1e-3 * c.loss, "{g:?} vs {c:?}");
        }
        // Prediction on the GPU gives the CPU's classes for the returned network.
        let p = Predictor::new(&graph, GpuOptions::default()).unwrap();
        let on_gpu = p.classes(&p.stage(&va.images).unwrap()).unwrap();
        assert_eq!(on_gpu, graph.predict(&va.images));
        let right = on_gpu
            .iter()
            .zip(&va.labels)
            .filter(|(a, b)| a == b)
            .count();
        assert_eq!(right as f64 / va.len() as f64, graph.validation_accuracy);
        eprintln!("graph: {:?}", graph.epochs);
    }

    /// Trainings of a sweep run at once on one GPU (threads, a stream each) give what each
    /// gives alone, bit for bit.
    #[test]
    fn trainings_at_once_give_what_each_gives_alone() {
        if !driver() {
            eprintln!("skipped: no NVIDIA driver (libcuda.so.1) on this machine");
            return;
        }
        let cfg = NetConfig {
            arch: Arch::Table18,
            height: 64,
            width: 64,
            classes: 4,
        };
        let tr = set(&cfg, 64, 3);
        let opts = TrainingOptions {
            batch_size: 16,
            epochs: 2,
            ..Default::default()
        };
        let empty = Labelled::default();
        let one = |seed| gpu::train(&cfg, &opts, &tr, &empty, seed, GpuOptions::default()).unwrap();
        let alone: Vec<_> = (0..4).map(|k| values(&one(20 + k).net)).collect();
        let together: Vec<_> = std::thread::scope(|s| {
            let hs: Vec<_> = (0..4)
                .map(|k| s.spawn(move || values(&one(20 + k).net)))
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(alone, together);
    }
}
