//! The CUDA route of training (`training: {device: cuda}`, burn's CUDA backend) in a build with
//! the `cuda` feature (`make test-cuda`), on a machine with an NVIDIA GPU: a toy set learnt on
//! the GPU, the network handed back to the CPU predicting what the GPU's validation measured,
//! and the GPU's first epoch beside the CPU's from the same seed (the same initial weights and
//! batches: their losses agree to rounding). Where no NVIDIA driver can be loaded the test says
//! that it skipped and passes (CI has no GPU); without the feature the file holds no test.

#![cfg(feature = "cuda")]

mod common;

use isar_clutter::apps::cnn::train::{train, train_on_device, Device, TrainingOptions};

/// Whether the NVIDIA driver's library loads (what the CUDA route checks first).
fn driver() -> bool {
    // SAFETY: dlopen with a valid C string; the handle is closed at once.
    let handle = unsafe { libc::dlopen(c"libcuda.so.1".as_ptr(), libc::RTLD_LAZY) };
    if handle.is_null() {
        return false;
    }
    // SAFETY: a handle dlopen returned.
    unsafe { libc::dlclose(handle) };
    true
}

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
