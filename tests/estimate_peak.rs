//! The memory estimate of a job against what the job really allocates: with the binary's
//! allocator, which counts the bytes of its mapped blocks (2 MiB and more, where every big array
//! lives), the peak of a job run alone must lie within a factor of two of its estimate.
//! One test function, so that no other test allocates in this process while it measures.

use isar_clutter::alloc::{mapped_bytes, reset_peak};
use isar_clutter::run::estimate::human_bytes;
use isar_clutter::run::jobs::{Context, JobKind};
use isar_clutter::run::plan;
use ndarray::Array3;
use ndarray_npy::WriteNpyExt;
use num_complex::Complex;

#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

/// Filtered noise of 200 samples of 64 x 64 (13 MB as complex128), an `.npy` stack of 300
/// samples of 48 x 40 in complex64, each analysed and synthesised with two methods, compared
/// under the CMD and the KL.
const SPEC: &str = "name: peak
seed: 5
datasets:
  - id: noise
    kind: filtered_noise
    family: exponential
    alpha_h: {pattern: left_right, left: 0.5, right: 2.0}
    alpha_v: 1.0
    size: [64, 64]
    samples: 200
    half_width: 4
  - id: file
    kind: npy
    path: stack.npy
analysis:
  levels: 2
synthesis:
  methods: [full_covariance, method1]
  samples: 300
  half_width: 4
metrics: [cmd, kl_pixel]
outputs:
  npy_maps: false
";

#[test]
fn estimates_bound_the_measured_peaks_within_a_factor_of_two() {
    let dir = tempfile::tempdir().unwrap();
    let stack = Array3::from_shape_fn((300, 48, 40), |(n, r, c)| {
        let x = ((n * 7919 + r * 104_729 + c * 1_299_709) % 1000) as f32 / 1000.0;
        Complex::new(x - 0.5, (x * 3.7).fract() - 0.5)
    });
    stack
        .write_npy(std::fs::File::create(dir.path().join("stack.npy")).unwrap())
        .unwrap();
    let spec = dir.path().join("spec.yaml");
    std::fs::write(&spec, SPEC).unwrap();
    let plan = plan::load(&spec).unwrap();
    let out = dir.path().join("out");
    assert_eq!(plan.jobs.len(), 6);
    let mut report = vec![];
    for job in &plan.jobs {
        let estimate = job.estimate(&plan);
        let cx = Context {
            plan: &plan,
            out: &out,
            shared: None,
            inputs: vec![],
        };
        let (before, _) = mapped_bytes();
        reset_peak();
        job.run(&cx).unwrap();
        let (_, peak) = mapped_bytes();
        let measured = (peak - before) as f64;
        let ratio = estimate.bytes as f64 / measured;
        report.push(format!(
            "{}: estimate {} measured {} (ratio {ratio:.2})",
            job.id,
            human_bytes(estimate.bytes),
            human_bytes(measured as u64)
        ));
        assert!((0.5..=2.0).contains(&ratio), "{}", report.join("\n"));
    }
    eprintln!("{}", report.join("\n"));
}
