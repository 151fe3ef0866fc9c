//! The dissertation's qualitative similarity findings (4.4.1, Tables 6, 7, 25-28) as
//! assertions on one seeded run of the binary: Method 2 is closer than Method 1 at levels 2-3
//! on non-exponential data; the full-covariance baseline has the smallest correlation matrix
//! distance; the level-1 RMSE of Methods 1 and 2 and of the baseline is within 2x of the noise
//! floor. Also: the model-order table and the `table` command read back from that run, and the
//! held-out comparisons (`synthesis.held_out`) that show the baseline's in-sample advantage.

mod common;

use common::{opt_strings, read_table, run_spec};
use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

const SPEC: &str = "name: findings
seed: 2020
datasets:
  - id: nonexp
    kind: filtered_noise
    family: dyadic
    r_h: [0.6, 0.5, 0.1]
    r_v: [0.4, -0.1, 0.25]
    size: [32, 32]
    samples: 200
    half_width: 8
  - id: exp
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [32, 32]
    samples: 200
    half_width: 8
analysis:
  levels: 3
synthesis:
  methods: [method1, method2, full_covariance, uncorrelated, fourth_order]
  samples: 1000
metrics: [multiscale_rmse, cmd, kl_pixel, {kl_area: {block: 8, bins: 16}}]
";

/// `(dataset, method, statistic, level, direction) -> value` for one metric.
type Values = HashMap<(String, String, String, Option<i64>, Option<String>), f64>;

fn values(dir: &Path, metric: &str) -> Values {
    let df = read_table(dir, "similarity.parquet");
    let s = |c: &str| opt_strings(&df, c);
    let (ds, method, m, stat, dir_) = (
        s("dataset"),
        s("method"),
        s("metric"),
        s("statistic"),
        s("direction"),
    );
    let level: Vec<Option<i64>> = df.column("level").unwrap().i64().unwrap().iter().collect();
    let value: Vec<Option<f64>> = df.column("value").unwrap().f64().unwrap().iter().collect();
    let mut out = HashMap::new();
    for i in 0..df.height() {
        if m[i].as_deref() == Some(metric) {
            out.insert(
                (
                    ds[i].clone().unwrap(),
                    method[i].clone().unwrap(),
                    stat[i].clone().unwrap(),
                    level[i],
                    dir_[i].clone(),
                ),
                value[i].unwrap(),
            );
        }
    }
    out
}

fn rmse(v: &Values, ds: &str, method: &str, level: i64, dir: &str) -> f64 {
    v[&(
        ds.into(),
        method.into(),
        "rmse".into(),
        Some(level),
        Some(dir.into()),
    )]
}

fn summary(v: &Values, ds: &str, method: &str, stat: &str) -> f64 {
    v[&(ds.into(), method.into(), stat.into(), None, None)]
}

#[test]
fn the_dissertations_similarity_findings_hold_on_a_seeded_run() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("findings.yaml");
    std::fs::write(&spec, SPEC).unwrap();
    let out = tmp.path().join("out");
    run_spec(&spec, &out, &[]);
    let r = values(&out, "multiscale_rmse");
    // Method 2 closer than Method 1 at levels 2 and 3 on non-exponential data (Tables 6, 28),
    // direction by direction.
    for level in [2, 3] {
        for d in ["H", "V", "D"] {
            let (m1, m2) = (
                rmse(&r, "nonexp", "method1", level, d),
                rmse(&r, "nonexp", "method2", level, d),
            );
            assert!(m2 < m1, "level {level} {d}: method2 {m2} vs method1 {m1}");
        }
    }
    // Level-1 RMSE within 2x of the noise floor (Table 6's level-1 column is the same order
    // for every method).
    for ds in ["nonexp", "exp"] {
        let floor = summary(&r, ds, "noise_floor", "average_level_1");
        for m in ["method1", "method2", "full_covariance"] {
            let v = summary(&r, ds, m, "average_level_1");
            assert!(v <= 2.0 * floor, "{ds} {m}: {v} vs noise floor {floor}");
        }
        // The uncorrelated control is far off: the metric separates.
        assert!(summary(&r, ds, "uncorrelated", "average_level_1") > 10.0 * floor);
    }
    // The full-covariance baseline has the smallest CMD (Tables 7, 25, 27).
    let c = values(&out, "cmd");
    for ds in ["nonexp", "exp"] {
        let cmd = |m: &str| c[&(ds.into(), m.into(), "distance".into(), None, None)];
        let base = cmd("full_covariance");
        for m in ["method1", "method2", "uncorrelated", "fourth_order"] {
            assert!(
                base < cmd(m),
                "{ds}: full_covariance {base} vs {m} {}",
                cmd(m)
            );
        }
        // Method 2 beats Method 1 on non-exponential data (Table 7: .3747 vs .5058).
        if ds == "nonexp" {
            assert!(cmd("method2") < cmd("method1"));
        }
    }
    // KL maps and model-order rows exist for the fourth-order comparison.
    assert!(out
        .join("maps/nonexp.fourth_order/kl_pixel_re.npy")
        .exists());
    assert!(out.join("maps/nonexp/noise_floor_kl_area_im.npy").exists());
    let mo = read_table(&out, "model_order.parquet");
    assert_eq!(
        mo.height(),
        2 * 2 * 3,
        "2 datasets x 2 components x (2, 4, noise floor)"
    );
    // The table command reads it back, Markdown included.
    let table = Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
        .args([
            "table",
            out.to_str().unwrap(),
            "--table",
            "cmd",
            "--format",
            "md",
        ])
        .output()
        .unwrap();
    assert!(table.status.success());
    let text = String::from_utf8(table.stdout).unwrap();
    assert!(text.contains("| dataset | noise_floor | method1 | method2 | full_covariance | uncorrelated | fourth_order |"), "{text}");
    assert_eq!(
        text.lines()
            .filter(|l| l.starts_with("| nonexp") || l.starts_with("| exp"))
            .count(),
        2
    );
}

const MODEL_ORDER: &str = "name: mo
seed: 3
datasets:
  - id: gaussian
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 1000
  - id: k_nu1
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 1000
    texture_shape: 1.0
analysis:
  levels: 1
synthesis:
  methods: [uncorrelated, fourth_order]
  samples: 3000
  analyse_generated: false
metrics: [kl_pixel]
";

/// Tables 1-2's test, with a known answer: on Gaussian clutter the second- and fourth-order
/// models tie (the dissertation saw a few tenths of a dB between them on its plants); on
/// K-distributed clutter (excess kurtosis 3) the fourth-order model is clearly closer.
#[test]
fn the_model_order_test_separates_gaussian_from_k_distributed_clutter() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("mo.yaml");
    std::fs::write(&spec, MODEL_ORDER).unwrap();
    let out = tmp.path().join("out");
    run_spec(&spec, &out, &[]);
    let df = read_table(&out, "model_order.parquet");
    let ds: Vec<String> = df
        .column("dataset")
        .unwrap()
        .str()
        .unwrap()
        .iter()
        .map(|v| v.unwrap().to_string())
        .collect();
    let order: Vec<Option<i64>> = df
        .column("model_order")
        .unwrap()
        .i64()
        .unwrap()
        .iter()
        .collect();
    let mean: Vec<f64> = df
        .column("kl_mean_db")
        .unwrap()
        .f64()
        .unwrap()
        .iter()
        .map(Option::unwrap)
        .collect();
    // Mean over the two components of the mean-pixel KL in dB.
    let db = |d: &str, o: Option<i64>| {
        let v: Vec<f64> = (0..df.height())
            .filter(|&i| ds[i] == d && order[i] == o)
            .map(|i| mean[i])
            .collect();
        assert_eq!(v.len(), 2);
        (v[0] + v[1]) / 2.0
    };
    let (g2, g4) = (db("gaussian", Some(2)), db("gaussian", Some(4)));
    assert!(
        (g2 - g4).abs() < 0.5,
        "Gaussian: order 2 {g2} dB, order 4 {g4} dB"
    );
    let (k2, k4) = (db("k_nu1", Some(2)), db("k_nu1", Some(4)));
    assert!(
        k4 < k2 - 2.0,
        "K-distributed: order 2 {k2} dB, order 4 {k4} dB"
    );
    // The fourth-order model is not far above the noise floor.
    let floor = db("k_nu1", None);
    assert!(k4 < floor + 3.0, "order 4 {k4} dB, noise floor {floor} dB");

    // `table` with a filter and a pivot: one dataset, components across the page.
    let table = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
            .arg("table")
            .arg(&out)
            .args(args)
            .output()
            .unwrap()
    };
    let o = table(&[
        "--table",
        "kl",
        "--filter",
        "dataset=k_nu1",
        "--pivot",
        "component",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let header = text.lines().nth(2).unwrap();
    let cols: Vec<&str> = header.split_whitespace().collect();
    assert_eq!(cols, ["dataset", "metric", "method", "re", "im"], "{text}");
    assert!(!text.contains("gaussian"), "{text}");
    assert_eq!(
        text.lines().skip(4).count(),
        3,
        "noise floor and two models: {text}"
    );
    let o = table(&["--filter", "plant=A"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no table of"));
    let o = table(&["--table", "kl", "--filter", "plant=A"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("no column \"plant\" to filter on"));
    let o = table(&["--table", "nope"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("no table \"nope\""));
}

const HELD_OUT: &str = "name: held
seed: 11
datasets:
  - id: exp
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 100
analysis:
  levels: 2
synthesis:
  methods: [full_covariance, method1]
  samples: 100
  held_out: true
metrics: [cmd]
";

/// `synthesis.held_out` (docs/definitions.md section 6): every method and the floor also
/// compared on the half of the originals no fit saw (`reference = held_out`, 50 originals of
/// 100); the full covariance baseline, which draws from the sample covariance of the originals
/// it is compared with, is far closer in sample than held out, while Method 1 (a few
/// correlations per cell) moves much less; held out, the baseline is not below the floor of
/// the two halves.
#[test]
fn held_out_similarity_shows_the_baselines_in_sample_advantage() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("held.yaml");
    std::fs::write(&spec, HELD_OUT).unwrap();
    let out = tmp.path().join("out");
    run_spec(&spec, &out, &[]);
    let df = read_table(&out, "similarity.parquet");
    let s = |c: &str| opt_strings(&df, c);
    let (method, reference) = (s("method"), s("reference"));
    let value: Vec<Option<f64>> = df.column("value").unwrap().f64().unwrap().iter().collect();
    let n_orig: Vec<Option<i64>> = df
        .column("samples_original")
        .unwrap()
        .i64()
        .unwrap()
        .iter()
        .collect();
    let pick = |m: &str, r: &str| -> (f64, i64) {
        let rows: Vec<usize> = (0..df.height())
            .filter(|&i| method[i].as_deref() == Some(m) && reference[i].as_deref() == Some(r))
            .collect();
        assert_eq!(rows.len(), 1, "{m} {r}: {rows:?}");
        (value[rows[0]].unwrap(), n_orig[rows[0]].unwrap())
    };
    let (fc_in, n_in) = pick("full_covariance", "in_sample");
    let (fc_held, n_held) = pick("full_covariance", "held_out");
    let (m1_in, _) = pick("method1", "in_sample");
    let (m1_held, _) = pick("method1", "held_out");
    let (floor_held, n_floor) = pick("noise_floor", "held_out");
    assert_eq!((n_in, n_held, n_floor), (100, 50, 50));
    eprintln!(
        "cmd: full covariance {fc_in:.4} in sample, {fc_held:.4} held out; method 1 {m1_in:.4}, \
         {m1_held:.4}; floor of the halves {floor_held:.4}"
    );
    assert!(fc_held > 3.0 * fc_in, "{fc_held} vs {fc_in}");
    assert!(m1_held < 3.0 * m1_in, "{m1_held} vs {m1_in}");
    // Fitted on 50 samples, the baseline carries their sampling noise besides the held-out
    // half's: it does not get below the floor of the two halves (here 0.61 against 0.56).
    assert!(
        fc_held > 0.8 * floor_held,
        "{fc_held} vs floor {floor_held}"
    );
}
