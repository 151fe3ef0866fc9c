//! Shared helpers for the integration tests: seeded random stacks, tolerances and readers of a
//! results folder's Parquet tables (a module, not a test target).
#![allow(dead_code)]

pub mod paths;
pub mod scenes;

use ndarray::Array3;
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};

/// The JSON file at `path` (a fixture's or an output's), parsed.
pub fn read_json(path: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Agreement expected between two f64 evaluations of the same estimator by different
/// summation orders on stacks of at most a few hundred samples.
pub const REORDER_TOL: f64 = 1e-9;

/// A seeded random stack with spatially varying mean, variance and neighbour correlation:
/// `x = mu + s * (z + 0.6 * shift(z))` with complex Gaussian `z`.
pub fn random_stack(seed: u64, n: usize, h: usize, w: usize) -> Array3<Complex64> {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
    let z = Array3::from_shape_simple_fn((n, h + 1, w + 1), || Complex64::new(g(), g()));
    let scale = Array3::from_shape_simple_fn((1, h, w), || 0.5 + g().abs());
    let mean = Array3::from_shape_simple_fn((1, h, w), || Complex64::new(3.0 * g(), g()));
    Array3::from_shape_fn((n, h, w), |(s, r, c)| {
        let v = z[[s, r, c]]
            + z[[s, r, c + 1]] * 0.6
            + z[[s, r + 1, c]] * 0.3
            + z[[s, r + 1, c + 1]] * 0.2;
        mean[[0, r, c]] + v * scale[[0, r, c]]
    })
}

/// Largest absolute difference of two equally shaped maps, NaN equal to NaN.
pub fn max_diff(a: &ndarray::Array2<f64>, b: &ndarray::Array2<f64>) -> f64 {
    assert_eq!(a.dim(), b.dim(), "shapes differ");
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| {
            if x.is_nan() && y.is_nan() {
                0.0
            } else if x.is_nan() || y.is_nan() {
                f64::INFINITY
            } else {
                (x - y).abs()
            }
        })
        .fold(0.0, f64::max)
}

/// Reads the Parquet table `name` of a results folder.
pub fn read_table(dir: &std::path::Path, name: &str) -> polars::prelude::DataFrame {
    use polars::prelude::{ParquetReader, SerReader};
    ParquetReader::new(std::fs::File::open(dir.join(name)).unwrap())
        .finish()
        .unwrap()
}

/// A string column with its nulls.
pub fn opt_strings(df: &polars::prelude::DataFrame, column: &str) -> Vec<Option<String>> {
    df.column(column)
        .unwrap()
        .str()
        .unwrap()
        .iter()
        .map(|v| v.map(str::to_string))
        .collect()
}

/// Runs `isar-clutter run SPEC --quiet --out OUT` plus `extra` arguments and asserts that it
/// succeeded (its stderr in the message if not).
pub fn run_spec(spec: &std::path::Path, out: &std::path::Path, extra: &[&str]) {
    let o = run_output(spec, out, extra);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// What `isar-clutter run SPEC --quiet --out OUT` plus `extra` arguments did.
pub fn run_output(
    spec: &std::path::Path,
    out: &std::path::Path,
    extra: &[&str],
) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
        .arg("run")
        .arg(spec)
        .arg("--quiet")
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// The project's virtualenv Python (`.venv/bin/python`, what `make test-deps` fills) if it
/// imports every module of `modules`; `None` (the caller skips, saying why) otherwise, except
/// under `CI=true`, where a missing module fails the test.
pub fn venv_python(modules: &[&str]) -> Option<std::path::PathBuf> {
    let python = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
    let import = format!("import {}", modules.join(", "));
    let has = python.exists()
        && std::process::Command::new(&python)
            .args(["-c", &import])
            .status()
            .is_ok_and(|s| s.success());
    if has {
        return Some(python);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI=true: this test needs {} in .venv (`make test-deps` installs them)",
        modules.join(", ")
    );
    eprintln!(
        "skipping: .venv lacks one of {} (`make test-deps` installs them)",
        modules.join(", ")
    );
    None
}

/// Runs the fixture script `script` (relative to the project) with the virtualenv's Python
/// (which must import `modules`) to fill `out`; `None` (skip) where [`venv_python`] says so.
pub fn python_fixtures(
    script: &str,
    modules: &[&str],
    out: &std::path::Path,
) -> Option<std::path::PathBuf> {
    let python = venv_python(modules)?;
    let o = std::process::Command::new(&python)
        .arg(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(script))
        .arg(out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{script} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    Some(out.to_path_buf())
}

/// The tool's binary, as cargo built it for the integration tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_isar-clutter");

/// Runs the tool with `args` and waits for it.
pub fn bin<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> std::process::Output {
    std::process::Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Whether the NVIDIA driver's library (`libcuda.so.1`) loads: the GPU tests run, and `auto`
/// may pick the GPU.
pub fn nvidia_driver() -> bool {
    // SAFETY: dlopen with a valid C string; the handle is closed at once.
    let handle = unsafe { libc::dlopen(c"libcuda.so.1".as_ptr(), libc::RTLD_LAZY) };
    if handle.is_null() {
        return false;
    }
    // SAFETY: a handle dlopen returned.
    unsafe { libc::dlclose(handle) };
    true
}

/// What a run of the tool printed: its standard error, then its standard output.
pub fn text(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout)
}

/// Every Parquet table of a results folder, value by value, without the timing columns
/// (`*_s`, which differ between any two runs).
pub fn tables(
    dir: &std::path::Path,
) -> std::collections::BTreeMap<String, polars::prelude::DataFrame> {
    use polars::prelude::*;
    let mut out = std::collections::BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !name.ends_with(".parquet") {
            continue;
        }
        let df = ParquetReader::new(std::fs::File::open(e.path()).unwrap())
            .finish()
            .unwrap();
        let keep: Vec<String> = df
            .get_column_names()
            .iter()
            .map(|c| c.to_string())
            .filter(|c| !c.ends_with("_s"))
            .collect();
        out.insert(name, df.select(keep).unwrap());
    }
    assert!(!out.is_empty(), "no tables in {}", dir.display());
    out
}

/// Asserts two folders' tables are equal value by value (NaN equal to NaN).
pub fn same_tables(a: &std::path::Path, b: &std::path::Path) {
    let (x, y) = (tables(a), tables(b));
    assert_eq!(x.keys().collect::<Vec<_>>(), y.keys().collect::<Vec<_>>());
    for (name, df) in &x {
        assert!(
            df.equals_missing(&y[name]),
            "{name} differs:\n{df}\n{}",
            y[name]
        );
    }
}

/// Every `.npy` under `maps/`, by relative path.
pub fn maps(dir: &std::path::Path) -> std::collections::BTreeMap<std::path::PathBuf, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    let mut stack = vec![dir.join("maps")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            if e.path().is_dir() {
                stack.push(e.path());
            } else {
                out.insert(
                    e.path().strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(e.path()).unwrap(),
                );
            }
        }
    }
    out
}

/// `n` 32 x 32 images of two alternating classes: complex white noise (parts `N(0, 1)`) with
/// 3 added to the real part of the top half (class 0) or the bottom half (class 1), all times
/// `scale`.
pub fn half_bright_set(
    rng: &mut ChaCha20Rng,
    n: usize,
    scale: f64,
) -> isar_clutter::apps::cnn::train::Labelled {
    let mut set = isar_clutter::apps::cnn::train::Labelled::default();
    for k in 0..n {
        let label = k % 2;
        let img: Vec<num_complex::Complex32> = (0..32 * 32)
            .map(|p| {
                let (a, b): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
                let bright = if (p / 32 < 16) == (label == 0) {
                    3.0
                } else {
                    0.0
                };
                num_complex::Complex32::new(((a + bright) * scale) as f32, (b * scale) as f32)
            })
            .collect();
        set.push(&img, label);
    }
    set
}

/// The toy network of the CNN tests: Table 18's layers on 32 x 32 images, two classes.
pub fn toy_net() -> isar_clutter::apps::cnn::net::NetConfig {
    use isar_clutter::apps::cnn::net::{Arch, NetConfig};
    NetConfig {
        arch: Arch::Table18,
        height: 32,
        width: 32,
        classes: 2,
    }
}

/// A training and a validation set of [`half_bright_set`] (`n_train` then `n_val` images from
/// one generator seeded with `seed`, all times `scale`).
pub fn toy_sets(
    seed: u64,
    n_train: usize,
    n_val: usize,
    scale: f64,
) -> (
    isar_clutter::apps::cnn::train::Labelled,
    isar_clutter::apps::cnn::train::Labelled,
) {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    let train = half_bright_set(&mut rng, n_train, scale);
    (train, half_bright_set(&mut rng, n_val, scale))
}

/// The toy classification of the CNN tests: [`toy_net`] on [`toy_sets`] of 64 and 64 images
/// (seed 1), batches of 16, 4 epochs; learnt to > 95 % in those epochs.
pub fn toy_case() -> (
    isar_clutter::apps::cnn::net::NetConfig,
    isar_clutter::apps::cnn::train::Labelled,
    isar_clutter::apps::cnn::train::Labelled,
    isar_clutter::apps::cnn::train::TrainingOptions,
) {
    let (tr, va) = toy_sets(1, 64, 64, 1.0);
    let opts = isar_clutter::apps::cnn::train::TrainingOptions {
        batch_size: 16,
        epochs: 4,
        ..Default::default()
    };
    (toy_net(), tr, va, opts)
}

/// Every `.rs` file under `dir`, sorted (the architecture tests read the tree with it).
pub fn rust_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                todo.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}
