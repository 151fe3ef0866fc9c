//! `run --device cpu|cuda|auto` (and `training.device: auto`): on a machine without a usable
//! GPU (CI), `auto` trains on the CPU, says so even under `--quiet`, records why in the
//! manifest and gives the CPU run's tables; `cuda` is an error (exit 2) that says what is
//! missing; a device that is none of the three is refused by the command line. On a machine
//! whose NVIDIA driver loads the fallback tests say that they skipped.

mod common;

use common::{bin, nvidia_driver as driver, read_json, run_output, tables, text};
use std::path::Path;
use std::process::Output;

/// `run SPEC --out OUT --no-report --quiet` plus `extra`.
fn run(spec: &Path, out: &Path, extra: &[&str]) -> Output {
    run_output(spec, out, &[&["--no-report"], extra].concat())
}

/// A small classification spec (two filtered-noise classes, 32 x 32, two epochs) in `dir`.
fn spec(dir: &Path, device: &str) -> std::path::PathBuf {
    let path = dir.join(format!("small_{device}.yaml"));
    std::fs::write(
        &path,
        format!(
            "name: small
seed: 5
datasets:
  - {{id: horizontal, kind: filtered_noise, family: exponential, alpha_h: 4.0, alpha_v: 0.2, size: [32, 32], samples: 40}}
  - {{id: vertical, kind: filtered_noise, family: exponential, alpha_h: 0.2, alpha_v: 4.0, size: [32, 32], samples: 40}}
analysis:
  levels: 1
classification:
  classes: [horizontal, vertical]
  methods: [original]
  train_sizes: [20]
  repeats: 1
  training: {{epochs: 2, batch_size: 8, device: {device}}}
"
        ),
    )
    .unwrap();
    path
}

#[test]
fn auto_trains_on_the_cpu_without_a_gpu_says_why_and_gives_the_cpu_tables() {
    if driver() {
        eprintln!("skipped: an NVIDIA driver loads here, so `auto` may pick the GPU");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cpu = spec(dir.path(), "cpu");
    let (a, b, c) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("c"),
    );
    let o = run(&cpu, &a, &[]);
    assert!(o.status.success(), "{}", text(&o));
    // `--device auto` over the spec's `cpu`, and the spec's own `auto`.
    for (spec, out) in [(cpu.clone(), &b), (spec(dir.path(), "auto"), &c)] {
        let extra: &[&str] = if out == &b {
            &["--device", "auto"]
        } else {
            &[]
        };
        let o = run(&spec, out, extra);
        assert!(o.status.success(), "{}", text(&o));
        assert!(
            text(&o).contains("CNN trainings on: cpu (auto: "),
            "{}",
            text(&o)
        );
        let m = read_json(&out.join("manifest.json"));
        let line = m["training_device"].as_str().unwrap();
        assert!(line.starts_with("cpu (auto: "), "{line}");
        let (x, y) = (tables(&a), tables(out));
        assert_eq!(x.keys().collect::<Vec<_>>(), y.keys().collect::<Vec<_>>());
        for (name, t) in &x {
            let (t, u) = if name == "classification.parquet" {
                let drop = |d: &polars::prelude::DataFrame| {
                    d.drop_many(["train_seconds", "train_samples_per_second"])
                };
                (drop(t), drop(&y[name]))
            } else {
                (t.clone(), y[name].clone())
            };
            assert!(t.equals_missing(&u), "{name} differs:\n{t}\n{u}");
        }
    }
    // The CPU run records its device too.
    let m = read_json(&a.join("manifest.json"));
    assert_eq!(m["training_device"], "cpu");
}

#[test]
fn cuda_without_a_usable_gpu_is_an_error_saying_what_is_missing() {
    if driver() {
        eprintln!("skipped: an NVIDIA driver loads here");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &spec(dir.path(), "cpu"),
        &dir.path().join("o"),
        &["--device", "cuda"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("built without CUDA") || t.contains("no NVIDIA driver"),
        "{t}"
    );
    assert!(t.contains("--device"), "{t}");
    assert!(!dir.path().join("o").join("manifest.json").exists());
}

#[test]
fn a_device_that_is_none_of_the_three_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(
        &spec(dir.path(), "cpu"),
        &dir.path().join("o"),
        &["--device", "tpu"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("expected cpu, cuda or auto"),
        "{}",
        text(&o)
    );
}

#[test]
fn reproduce_with_cuda_and_no_usable_gpu_stops_before_any_run() {
    if driver() {
        eprintln!("skipped: an NVIDIA driver loads here");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("reproduction");
    let doc = dir.path().join("doc.md");
    let o = bin(&[
        "reproduce",
        "--only",
        "cnn_location_gain",
        "--device",
        "cuda",
        "--out",
        out.to_str().unwrap(),
        "--doc",
        doc.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--device"), "{}", text(&o));
    assert!(!out.join("cnn_location_gain").exists(), "{}", text(&o));
}
