//! The CNN applications end to end through `isar-clutter run` (docs/definitions.md §12), small
//! enough for `make test`: two classes that differ only in correlation direction are told
//! apart by a network trained on Method 1 samples and not by one trained on uncorrelated
//! samples; target location is near chance at a very low signal-to-clutter ratio and near
//! 100 % at a high one; the tables do not depend on the thread count; bad sections are
//! refused with their YAML path.

mod common;
use common::{bin, run_output, text};

use common::read_table;
use polars::prelude::*;
use std::path::Path;

fn run(spec: &Path, out: &Path, extra: &[&str]) {
    let o = run_output(spec, out, &[&["--no-report"], extra].concat());
    assert!(o.status.success(), "{}", text(&o));
}

fn f64s(df: &DataFrame, c: &str) -> Vec<f64> {
    df.column(c)
        .unwrap()
        .f64()
        .unwrap()
        .into_no_null_iter()
        .collect()
}

fn strs(df: &DataFrame, c: &str) -> Vec<String> {
    df.column(c)
        .unwrap()
        .str()
        .unwrap()
        .iter()
        .map(|v| v.unwrap_or_default().to_string())
        .collect()
}

/// Two exponential-filter classes, horizontal versus vertical correlation, zero mean and unit
/// variance (32 x 32, 60 samples each).
const DIRECTIONS: &str = "
datasets:
  - {id: horizontal, kind: filtered_noise, family: exponential, alpha_h: 4.0, alpha_v: 0.2, size: [32, 32], samples: 60}
  - {id: vertical, kind: filtered_noise, family: exponential, alpha_h: 0.2, alpha_v: 4.0, size: [32, 32], samples: 60}
analysis:
  levels: 1
";

#[test]
fn method1_samples_teach_correlation_direction_and_uncorrelated_samples_do_not() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("directions.yaml");
    std::fs::write(
        &spec,
        format!(
            "name: directions\nseed: 11\n{DIRECTIONS}classification:
  classes: [horizontal, vertical]
  normalise: zero_mean_unit_variance
  holdout: 0.25
  methods: [method1, uncorrelated]
  train_sizes: [200]
  original_fraction: 0
  repeats: 1
  training: {{epochs: 8, batch_size: 32}}
"
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    run(&spec, &out, &[]);
    let t = read_table(&out, "classification.parquet");
    let (methods, test) = (strs(&t, "method"), f64s(&t, "test_accuracy"));
    let acc = |m: &str| test[methods.iter().position(|x| x == m).unwrap()];
    // 15 held-out originals per class: chance is 0.5 with a standard deviation of 0.09.
    assert_eq!(
        t.column("test_samples").unwrap().i64().unwrap().get(0),
        Some(30)
    );
    eprintln!(
        "method1 {}, uncorrelated {}",
        acc("method1"),
        acc("uncorrelated")
    );
    assert!(acc("method1") >= 0.85, "method1: {}", acc("method1"));
    assert!(
        acc("uncorrelated") <= 0.75,
        "uncorrelated: {}",
        acc("uncorrelated")
    );
    // Only generated samples were trained on.
    let originals: Vec<i64> = t
        .column("train_originals")
        .unwrap()
        .i64()
        .unwrap()
        .into_no_null_iter()
        .collect();
    assert_eq!(originals, [0, 0]);
}

/// Runs a spec of 150 samples of dyadic clutter (64 x 64) with the `location:` section whose
/// fields are `section`: the temporary folder and the output folder in it.
fn location_run(section: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("location.yaml");
    std::fs::write(
        &spec,
        format!(
            "name: location
seed: 12
datasets:
  - {{id: clutter, kind: filtered_noise, family: dyadic, r_h: [0.5, 0.3, 0.1], r_v: [0.4, 0.2, 0.1], size: [64, 64], samples: 150}}
analysis:
  levels: 3
location:
{section}"
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    run(&spec, &out, &[]);
    (dir, out)
}

#[test]
fn target_location_goes_from_chance_to_certain_with_the_signal_to_clutter_ratio() {
    let (_dir, out) = location_run(
        "  clutter: clutter
  fit_samples: 100
  methods: [method2]
  generated_samples: 1000
  targets: [constant]
  scr_db: [-30, 20]
  repeats: 1
  training: {epochs: 4, batch_size: 64}
",
    );
    let t = read_table(&out, "location.parquet");
    let (scr, test) = (f64s(&t, "scr_db"), f64s(&t, "test_accuracy"));
    let low = test[scr.iter().position(|&s| s == -30.0).unwrap()];
    let high = test[scr.iter().position(|&s| s == 20.0).unwrap()];
    // 50 test samples over 25 locations: chance is 0.04 (standard deviation 0.03).
    eprintln!("location accuracy: {low} at -30 dB, {high} at +20 dB");
    assert!(low <= 0.16, "accuracy {low} at -30 dB");
    assert!(high >= 0.9, "accuracy {high} at +20 dB");
    let s = read_table(&out, "location_summary.parquet");
    let s50 = s
        .column("scr_50_db")
        .unwrap()
        .f64()
        .unwrap()
        .get(0)
        .unwrap();
    assert!((-30.0..=20.0).contains(&s50), "{s50}");
    assert!(out
        .join("examples/location.constant.method2.scr20.r0.npy")
        .is_file());
}

/// A location run of 150 clutter samples: methods fitted on 100, `original` on 120, one
/// training each of `original` and Method 2; `extra` adds keys to the section.
fn originals_pool_run(extra: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    location_run(&format!(
        "  clutter: clutter
  fit_samples: 100
  original_samples: 120
{extra}  methods: [original, method2]
  generated_samples: 100
  targets: [constant]
  scr_db: [0]
  repeats: 1
  training: {{epochs: 1, batch_size: 64}}
"
    ))
}

/// The integer column `c` of `t`.
fn ints(t: &DataFrame, c: &str) -> Vec<i64> {
    t.column(c)
        .unwrap()
        .i64()
        .unwrap()
        .into_no_null_iter()
        .collect()
}

/// `location.original_samples`: `original` trains and validates on that many originals (the
/// fit part first), and every method is tested on the samples after them.
#[test]
fn original_samples_sets_the_originals_pool_and_the_test_set() {
    let (_dir, out) = originals_pool_run("");
    let t = read_table(&out, "location.parquet");
    assert_eq!(strings(&t, "method"), ["original", "method2"]);
    assert_eq!(ints(&t, "test_samples"), [30, 30]);
    assert_eq!(ints(&t, "train_samples"), [60, 50]);
}

/// `location.test_sets`: `all` (the dissertation's protocol) tests every network on all the
/// clutter samples (150 here), those it was fitted or trained on included; both test sets
/// listed give, from one training each, a row per test set equal to what a run with that test
/// set alone gives, and a summary row per target, test set and method.
#[test]
fn test_sets_read_one_training_on_each_set() {
    let (_a, alone_all) = originals_pool_run("  test_sets: [all]\n");
    let t = read_table(&alone_all, "location.parquet");
    assert_eq!(ints(&t, "test_samples"), [150, 150]);
    let (_h, alone_held) = originals_pool_run("");
    let (_b, both) = originals_pool_run("  test_sets: [held_out, all]\n");
    let t = read_table(&both, "location.parquet");
    assert_eq!(ints(&t, "test_samples"), [30, 150, 30, 150]);
    assert_eq!(
        strings(&t, "test_set"),
        ["held_out", "all", "held_out", "all"]
    );
    let accuracy = |t: &DataFrame| f64s(t, "test_accuracy");
    let (held, all) = (
        accuracy(&read_table(&alone_held, "location.parquet")),
        accuracy(&read_table(&alone_all, "location.parquet")),
    );
    assert_eq!(accuracy(&t), [held[0], all[0], held[1], all[1]]);
    let s = read_table(&both, "location_summary.parquet");
    assert_eq!(
        strings(&s, "test_set"),
        ["held_out", "held_out", "all", "all"]
    );
    assert_eq!(
        strings(&s, "method"),
        ["original", "method2", "original", "method2"]
    );
}

/// The string column `c` of `t`.
fn strings(t: &DataFrame, c: &str) -> Vec<String> {
    t.column(c)
        .unwrap()
        .str()
        .unwrap()
        .iter()
        .map(|m| m.unwrap_or_default().to_string())
        .collect()
}

/// The columns of a training table that do not measure time.
fn without_timings(df: &DataFrame) -> DataFrame {
    df.drop_many(["train_seconds", "train_samples_per_second"])
}

#[test]
fn training_tables_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("small.yaml");
    std::fs::write(
        &spec,
        format!(
            "name: small\nseed: 13\n{DIRECTIONS}classification:
  classes: [horizontal, vertical]
  normalise: [zero_mean, zero_mean_unit_variance]
  methods: [original, method1, method2, full_covariance, uncorrelated]
  train_sizes: [40]
  repeats: 1
  levels: 2
  half_width: 4
  training: {{epochs: 2, batch_size: 16}}
"
        ),
    )
    .unwrap();
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    run(&spec, &one, &["--jobs", "1"]);
    run(&spec, &two, &["--jobs", "2"]);
    for table in [
        "classification.parquet",
        "training_history.parquet",
        "confusion.parquet",
    ] {
        let (a, b) = (read_table(&one, table), read_table(&two, table));
        let (a, b) = if table == "classification.parquet" {
            (without_timings(&a), without_timings(&b))
        } else {
            (a, b)
        };
        assert_eq!(a.height(), b.height(), "{table}");
        assert!(a.equals_missing(&b), "{table} differs:\n{a}\n{b}");
    }
    assert_eq!(read_table(&one, "classification.parquet").height(), 10);
}

/// `validate` refuses `section` with a message naming `path` and containing `needle`.
fn refused(section: &str, datasets: &str, path: &str, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("bad.yaml");
    std::fs::write(&spec, format!("name: bad\nseed: 1\n{datasets}{section}")).unwrap();
    let o = bin(&["validate", spec.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("bad.yaml") && t.contains(path) && t.contains(needle),
        "{path}: {t}"
    );
}

#[test]
fn bad_sections_are_refused_with_their_yaml_path() {
    let cls = |extra: &str| {
        format!(
            "classification:\n  classes: [horizontal, vertical]\n  methods: [method1, original]\n  train_sizes: [100]\n{extra}"
        )
    };
    refused(
        "classification:\n  classes: [horizontal, nothing]\n  methods: [method1]\n  train_sizes: [100]\n",
        DIRECTIONS,
        "classification.classes[1]",
        "not the id of a dataset",
    );
    let mixed = "datasets:
  - {id: horizontal, kind: filtered_noise, family: exponential, alpha_h: 4.0, alpha_v: 0.2, size: [32, 32], samples: 60}
  - {id: vertical, kind: filtered_noise, family: exponential, alpha_h: 0.2, alpha_v: 4.0, size: [48, 48], samples: 60}
analysis:
  levels: 1
";
    refused(
        &cls(""),
        mixed,
        "classification.classes[1]",
        "one image size",
    );
    refused(
        &cls("  holdout: 1.0\n"),
        DIRECTIONS,
        "classification.holdout",
        "[0, 1)",
    );
    refused(
        &cls("  holdout: -0.1\n"),
        DIRECTIONS,
        "classification.holdout",
        "[0, 1)",
    );
    refused(
        "classification:\n  classes: [horizontal, vertical]\n  methods: [method1]\n  train_sizes: [2000]\n  original_fraction: 0.5\n",
        DIRECTIONS,
        "classification.train_sizes[0]",
        "fit part holds 48",
    );
    refused(
        &cls("  training: {momentum: 1.5}\n"),
        DIRECTIONS,
        "classification.training.momentum",
        "[0, 1)",
    );
    refused(
        &cls("  training: {epochs: 0}\n"),
        DIRECTIONS,
        "classification.training.epochs",
        "1..=10000",
    );
    refused(
        &cls("  speed: fast\n"),
        DIRECTIONS,
        "classification",
        "unknown field `speed`",
    );
    refused(
        "classification:\n  classes: [horizontal, vertical]\n  methods: [method3]\n  train_sizes: [100]\n",
        DIRECTIONS,
        "classification.methods[0]",
        "unknown method",
    );
    let small = "datasets:
  - {id: a, kind: filtered_noise, family: exponential, alpha_h: 4.0, alpha_v: 0.2, size: [16, 16], samples: 60}
  - {id: b, kind: filtered_noise, family: exponential, alpha_h: 0.2, alpha_v: 4.0, size: [16, 16], samples: 60}
analysis:
  levels: 1
";
    refused(
        "classification:\n  classes: [a, b]\n  methods: [method1]\n  train_sizes: [100]\n",
        small,
        "classification.classes",
        "too small for the network",
    );
    let clutter = "datasets:
  - {id: clutter, kind: filtered_noise, family: exponential, alpha_h: 2.0, alpha_v: 2.0, size: [64, 64], samples: 100}
analysis:
  levels: 1
";
    let loc = |extra: &str| {
        format!(
            "location:\n  clutter: clutter\n  methods: [method1]\n  targets: [constant]\n{extra}"
        )
    };
    refused(
        &loc("  scr_db: []\n  fit_samples: 50\n"),
        clutter,
        "location.scr_db",
        "at least one",
    );
    refused(
        &loc("  scr_db: [0]\n"),
        clutter,
        "location.fit_samples",
        "at least 101",
    );
    refused(
        &loc("  scr_db: [0]\n  fit_samples: 50\n  original_samples: 30\n"),
        clutter,
        "location.original_samples",
        "at least fit_samples (50)",
    );
    refused(
        &loc("  scr_db: [0]\n  fit_samples: 50\n  original_samples: 100\n"),
        clutter,
        "location.original_samples",
        "leaves none to test on",
    );
    refused(
        "location:\n  clutter: clutter\n  methods: [method1]\n  targets: [moving]\n  scr_db: [0]\n  fit_samples: 50\n",
        clutter,
        "location.targets",
        "unknown variant",
    );
    refused(
        "location:\n  clutter: clutter\n  methods: [method1]\n  targets: [constant]\n  scr_db: [0]\n  fit_samples: 40\n",
        small.replace("a, kind", "clutter, kind").as_str(),
        "location.clutter",
        "needs at least 60x60",
    );
}

/// A location training's key names what it reads, not the section's lists of the other
/// trainings: a spec grown by an SCR point and a target resumes the trainings it had and runs
/// only the new ones (and the summary over them all).
#[test]
fn a_location_spec_grown_by_an_scr_point_reruns_only_the_new_trainings() {
    let section = |targets: &str, scr: &str| {
        format!(
            "  clutter: clutter
  fit_samples: 100
  methods: [original, method2]
  generated_samples: 100
  targets: {targets}
  scr_db: {scr}
  repeats: 1
  training: {{epochs: 1, batch_size: 64}}
"
        )
    };
    let (dir, out) = location_run(&section("[constant]", "[0]"));
    let spec = dir.path().join("location.yaml");
    let grown = std::fs::read_to_string(&spec).unwrap().replace(
        &section("[constant]", "[0]"),
        &section("[constant, stochastic]", "[0, 10]"),
    );
    std::fs::write(&spec, grown).unwrap();
    let o = bin(&[
        "run",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-report",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // The clutter and the two trainings at 0 dB of the constant target.
    assert!(
        text(&o).contains("resumed: 3 job(s) already done"),
        "{}",
        text(&o)
    );
    let t = read_table(&out, "location.parquet");
    assert_eq!(t.height(), 8, "2 targets x 2 methods x 2 SCRs");
}
