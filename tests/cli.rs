//! End-to-end runs of the `isar-clutter` binary in temporary folders: the output layout and
//! columns (a public contract), readback of the Parquet tables, sweeps and job ids,
//! thread-count invariance, and a failing job that does not take the others down.

mod common;

use common::bin;
use common::read_table as read;
use ndarray::Array3;
use ndarray_npy::WriteNpyExt;
use num_complex::Complex;
use polars::prelude::*;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::Output;

const SPEC: &str = "name: e2e
seed: 42
datasets:
  - id: held
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: {pattern: left_right, left: 0.5, right: 2.0}
    size: [16, 24]
    samples: 50
    half_width: 4
  - id: measured
    kind: npy
    path: stack.npy
analysis:
  levels: 2
sweep:
  grid:
    datasets.held.alpha_h: [0.5, 2]
    analysis.levels: [1, 2]
";

fn setup(dir: &Path) -> PathBuf {
    let stack = Array3::from_shape_fn((6, 8, 8), |(n, r, c)| {
        Complex::new((n * r) as f32 + c as f32 * 0.5, (n + c) as f32 % 3.0)
    });
    stack
        .write_npy(File::create(dir.join("stack.npy")).unwrap())
        .unwrap();
    let spec = dir.join("spec.yaml");
    std::fs::write(&spec, SPEC).unwrap();
    spec
}

fn run(spec: &Path, out: &Path, jobs: &str) -> Output {
    bin(&[
        "run",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        jobs,
        "--quiet",
    ])
}

/// The values of a string column without nulls.
fn strings(df: &DataFrame, column: &str) -> Vec<String> {
    df.column(column)
        .unwrap()
        .str()
        .unwrap()
        .iter()
        .map(|s| s.unwrap().to_string())
        .collect()
}

fn names(df: &DataFrame) -> Vec<String> {
    df.get_column_names()
        .iter()
        .map(|s| s.to_string())
        .collect()
}

#[test]
fn run_writes_the_documented_tables() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    let o = run(&spec, &out, "2");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let jobs = read(&out, "jobs.parquet");
    let ids = strings(&jobs, "job");
    // held: 2 alpha_h x 2 levels; measured: only the analysis axis applies -> 2 jobs. Grid
    // axes are ordered by key (`analysis.levels` before `datasets.held.alpha_h`), the last
    // varying fastest; ids list the swept values by key.
    assert_eq!(
        ids,
        [
            "held.alpha_h=0.5.levels=1",
            "held.alpha_h=2.levels=1",
            "held.alpha_h=0.5.levels=2",
            "held.alpha_h=2.levels=2",
            "measured.levels=1",
            "measured.levels=2"
        ]
    );
    for c in [
        "job",
        "status",
        "error",
        "seed",
        "data_seed",
        "elapsed_s",
        "alpha_h",
        "levels",
    ] {
        assert!(
            names(&jobs).contains(&c.to_string()),
            "jobs.parquet lacks {c}"
        );
    }
    // Jobs that differ only in analysis levels analyse the same data (same data seed).
    let ds = jobs.column("data_seed").unwrap().u64().unwrap();
    assert_eq!(ds.get(0), ds.get(2));
    assert_ne!(ds.get(0), ds.get(1));

    let maps = read(&out, "analysis_maps.parquet");
    for c in [
        "job",
        "dataset",
        "level",
        "direction",
        "row",
        "col",
        "correlation",
        "covariance",
        "expected_correlation",
        "alpha_h",
        "levels",
    ] {
        assert!(
            names(&maps).contains(&c.to_string()),
            "analysis_maps lacks {c}"
        );
    }
    // Rows: held 16x24 -> level 1: 8x12 = 96 cells, level 2: 4x6 = 24; measured 8x8 -> 16 + 4.
    let per_dir = 2 * 96 + 2 * (96 + 24) + 16 + (16 + 4);
    assert_eq!(maps.height(), 3 * per_dir);

    let summary = read(&out, "analysis_summary.parquet");
    for c in [
        "job",
        "dataset",
        "level",
        "direction",
        "mean_correlation",
        "mean_covariance",
        "nan_cells",
    ] {
        assert!(
            names(&summary).contains(&c.to_string()),
            "analysis_summary lacks {c}"
        );
    }
    assert_eq!(summary.height(), 3 * (2 + 2 * 2 + 1 + 2));
    let pixels = read(&out, "pixel_stats.parquet");
    for c in [
        "job", "dataset", "row", "col", "mean_re", "mean_im", "variance",
    ] {
        assert!(
            names(&pixels).contains(&c.to_string()),
            "pixel_stats lacks {c}"
        );
    }
    assert_eq!(pixels.height(), 4 * 16 * 24 + 2 * 64);

    // The npy stack's pixel (r=2, c=1) over n = 0..5: re = 2n + 0.5 (mean 5.5, variance
    // 4 * 35/12), im = (n + 1) % 3 = 1,2,0,1,2,0 (mean 1, variance 2/3).
    let (mre, mim, var) = pixels.pixel("measured.levels=1", 2, 1);
    assert!(
        (mre - 5.5).abs() < 1e-12 && (mim - 1.0).abs() < 1e-12,
        "mean {mre} {mim}"
    );
    assert!((var - 37.0 / 3.0).abs() < 1e-12, "variance {var}");

    let manifest: serde_json::Value =
        serde_json::from_reader(File::open(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["master_seed"], 42);
    assert_eq!(manifest["jobs"].as_array().unwrap().len(), 6);
    assert_eq!(manifest["spec_hash_sha256"].as_str().unwrap().len(), 64);
    // The plants' record compiled in, as `sha256sum` hashes the committed file.
    let sum = std::process::Command::new("sha256sum")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reproduction/plant_calibration.json"
        ))
        .output()
        .unwrap();
    let sum = String::from_utf8(sum.stdout).unwrap();
    assert_eq!(
        manifest["plant_calibration_sha256"],
        sum.split_whitespace().next().unwrap()
    );
    assert!(out
        .join("maps/held.alpha_h=2.levels=2/level2_correlation_H.npy")
        .exists());
    assert!(out.join("maps/measured.levels=1/mean.npy").exists());
    // No temporary files are left behind.
    assert!(std::fs::read_dir(&out).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .contains(".tmp")));
}

/// Pixel lookup helper for the readback check.
trait PixelLookup {
    fn pixel(&self, job: &str, row: i64, col: i64) -> (f64, f64, f64);
}

impl PixelLookup for DataFrame {
    fn pixel(&self, job: &str, row: i64, col: i64) -> (f64, f64, f64) {
        let jobs = self.column("job").unwrap().str().unwrap();
        let rows = self.column("row").unwrap().i64().unwrap();
        let cols = self.column("col").unwrap().i64().unwrap();
        let i = (0..self.height())
            .find(|&i| {
                jobs.get(i) == Some(job) && rows.get(i) == Some(row) && cols.get(i) == Some(col)
            })
            .expect("pixel row present");
        let f = |c: &str| self.column(c).unwrap().f64().unwrap().get(i).unwrap();
        (f("mean_re"), f("mean_im"), f("variance"))
    }
}

#[test]
fn tables_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    assert!(run(&spec, &a, "1").status.success());
    assert!(run(&spec, &b, "2").status.success());
    for t in [
        "analysis_maps.parquet",
        "analysis_summary.parquet",
        "pixel_stats.parquet",
        "filter_correlation.parquet",
        "jobs.parquet",
    ] {
        let (mut x, mut y) = (read(&a, t), read(&b, t));
        if t == "jobs.parquet" {
            x = x.drop("elapsed_s").unwrap();
            y = y.drop("elapsed_s").unwrap();
        }
        assert!(
            x.equals_missing(&y),
            "{t} differs between --jobs 1 and --jobs 2"
        );
    }
    let npy = "maps/held.alpha_h=0.5.levels=2/level2_covariance_D.npy";
    assert_eq!(
        std::fs::read(a.join(npy)).unwrap(),
        std::fs::read(b.join(npy)).unwrap()
    );
}

#[test]
fn a_failing_job_is_recorded_and_the_others_finish() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    // A valid header with too little data: validation passes, loading fails.
    let bytes = std::fs::read(dir.path().join("stack.npy")).unwrap();
    std::fs::write(dir.path().join("stack.npy"), &bytes[..bytes.len() - 40]).unwrap();
    let out = dir.path().join("out");
    let o = run(&spec, &out, "2");
    assert_eq!(
        o.status.code(),
        Some(1),
        "failed jobs make the exit code non-zero"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("failed: measured.levels=1") && stderr.contains("stack.npy"),
        "{stderr}"
    );
    let jobs = read(&out, "jobs.parquet");
    let status = strings(&jobs, "status");
    assert_eq!(status, ["ok", "ok", "ok", "ok", "failed", "failed"]);
    let err = jobs
        .column("error")
        .unwrap()
        .str()
        .unwrap()
        .get(4)
        .unwrap()
        .to_string();
    assert!(err.contains("stack.npy"), "{err}");
    assert_eq!(read(&out, "analysis_summary.parquet").height(), 3 * 6);
}

#[test]
fn dry_run_prints_the_job_table_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    let o = bin(&[
        "run",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--dry-run",
    ]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("held.alpha_h=0.5.levels=1") && text.contains("6 job(s)"),
        "{text}"
    );
    assert!(!out.exists());
}

#[test]
fn table3_spec_writes_the_filter_table() {
    let dir = tempfile::tempdir().unwrap();
    let spec =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/table3_filter_correlation.yaml");
    let out = dir.path().join("t3");
    assert!(run(&spec, &out, "2").status.success());
    let t = read(&out, "filter_correlation.parquet");
    let lag = t.column("lag").unwrap().i64().unwrap();
    let corr = t.column("correlation").unwrap().f64().unwrap();
    let dir_col = t.column("direction").unwrap().str().unwrap();
    let want = [
        1.0, 0.6481, 0.3415, 0.1635, 0.0741, 0.0324, 0.0138, 0.0057, 0.0023,
    ];
    let mut seen = 0;
    for i in 0..t.height() {
        if dir_col.get(i) == Some("H") {
            let l = lag.get(i).unwrap() as usize;
            assert!(
                (corr.get(i).unwrap() - want[l]).abs() < 5e-5,
                "Table 3 lag {l}"
            );
            seen += 1;
        }
    }
    assert_eq!(seen, 9);
}

#[test]
fn swept_columns_never_shadow_table_columns_and_stale_maps_go() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("s.yaml");
    let text = "name: s\nseed: 3\ndatasets:\n  - id: d\n    kind: filtered_noise\n    family: exponential\n    alpha_h: 1\n    alpha_v: 1\n    size: [8, 8]\n    samples: 20\n    half_width: 3\nanalysis:\n  levels: 1\nsweep:\n  grid:\n    datasets.d.mean_im: [0.5, 2]\n";
    let out = dir.path().join("out");
    // An earlier run of the spec with one more sweep value: that job's maps are stale now.
    std::fs::write(&spec, text.replace("[0.5, 2]", "[0.5, 2, 3]")).unwrap();
    assert!(run(&spec, &out, "2").status.success());
    assert!(out.join("maps/d.mean_im=3/mean.npy").exists());
    std::fs::write(&spec, text).unwrap();
    assert!(run(&spec, &out, "2").status.success());
    let px = read(&out, "pixel_stats.parquet");
    assert!(names(&px).contains(&"swept_mean_im".to_string()));
    let swept = px.column("swept_mean_im").unwrap().f64().unwrap();
    let est = px.column("mean_im").unwrap().f64().unwrap();
    // The estimated mean (20 samples of unit variance) sits near the swept true mean.
    for i in 0..px.height() {
        assert!((est.get(i).unwrap() - swept.get(i).unwrap()).abs() < 1.0);
    }
    // filter_correlation has the same swept column type as the other tables.
    let fc = read(&out, "filter_correlation.parquet");
    assert_eq!(fc.column("mean_im").unwrap().dtype(), &DataType::Float64);
    assert!(
        !out.join("maps/d.mean_im=3").exists(),
        "maps of jobs no longer in the plan are removed"
    );
    assert!(out.join("maps/d.mean_im=0.5").exists());
}

#[test]
fn fortran_order_and_hwn_stacks_read_like_c_order() {
    use ndarray::ShapeBuilder;
    let dir = tempfile::tempdir().unwrap();
    let c = Array3::from_shape_fn((5, 8, 6), |(n, r, col)| {
        Complex::new(((n * 7 + r * 3 + col) % 11) as f64, (n * r) as f64 * 0.25)
    });
    let mut f = Array3::zeros((5, 8, 6).f());
    f.assign(&c);
    let hwn = c
        .view()
        .permuted_axes([1, 2, 0])
        .as_standard_layout()
        .into_owned();
    c.write_npy(File::create(dir.path().join("c.npy")).unwrap())
        .unwrap();
    f.write_npy(File::create(dir.path().join("f.npy")).unwrap())
        .unwrap();
    hwn.write_npy(File::create(dir.path().join("hwn.npy")).unwrap())
        .unwrap();
    let spec = dir.path().join("s.yaml");
    let ds =
        |id: &str, extra: &str| format!("  - id: {id}\n    kind: npy\n    path: {id}.npy\n{extra}");
    let text = format!(
        "name: s\nseed: 1\ndatasets:\n{}{}{}analysis:\n  levels: 2\n",
        ds("c", ""),
        ds("f", ""),
        ds("hwn", "    layout: hwn\n")
    );
    std::fs::write(&spec, text).unwrap();
    let out = dir.path().join("out");
    let o = run(&spec, &out, "2");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = read(&out, "analysis_summary.parquet");
    let job = s.column("job").unwrap().str().unwrap();
    let corr = s.column("mean_correlation").unwrap().f64().unwrap();
    let of = |id: &str| {
        (0..s.height())
            .filter(|&i| job.get(i) == Some(id))
            .map(|i| corr.get(i).unwrap())
            .collect::<Vec<_>>()
    };
    assert_eq!(of("c"), of("f"));
    assert_eq!(of("c"), of("hwn"));
    assert_eq!(of("c").len(), 6);
}

#[test]
fn fig19_spec_recovers_the_spatially_varying_correlation() {
    // Figs. 19-21: the estimate of every cell against the exact expected map. Per-cell sd of a
    // correlation estimate from N = 1000 complex samples is about (1 - rho^2) / sqrt(2N) <= 0.022,
    // so an RMSE bound of 0.03 fails on a biased estimator but not on sampling noise.
    let dir = tempfile::tempdir().unwrap();
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/fig19_spatial.yaml");
    let out = dir.path().join("fig19");
    assert!(run(&spec, &out, "2").status.success());
    let m = read(&out, "analysis_maps.parquet");
    let level = m.column("level").unwrap().i64().unwrap();
    let dirn = m.column("direction").unwrap().str().unwrap();
    let col = m.column("col").unwrap().i64().unwrap();
    let corr = m.column("correlation").unwrap().f64().unwrap();
    let exp = m.column("expected_correlation").unwrap().f64().unwrap();
    for l in 1..=3 {
        for d in ["H", "V", "D"] {
            let rows: Vec<usize> = (0..m.height())
                .filter(|&i| level.get(i) == Some(l) && dirn.get(i) == Some(d))
                .collect();
            let mse = rows
                .iter()
                .map(|&i| (corr.get(i).unwrap() - exp.get(i).unwrap()).powi(2))
                .sum::<f64>()
                / rows.len() as f64;
            assert!(mse.sqrt() < 0.03, "level {l} {d}: RMSE {}", mse.sqrt());
        }
    }
    // The horizontal alpha ramps from 0.3 to 3: level-1 H correlation rises across the image.
    let mean_h = |c: i64| {
        let v: Vec<f64> = (0..m.height())
            .filter(|&i| {
                level.get(i) == Some(1) && dirn.get(i) == Some("H") && col.get(i) == Some(c)
            })
            .map(|i| exp.get(i).unwrap())
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    assert!(
        mean_h(31) - mean_h(0) > 0.5,
        "{} -> {}",
        mean_h(0),
        mean_h(31)
    );
}

const SYNTH: &str = "name: syn
seed: 5
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: {pattern: left_right, left: 0.5, right: 2}
    alpha_v: 1
    size: [16, 16]
    samples: 200
    half_width: 8
analysis:
  levels: 2
synthesis:
  methods: [method1, method2, full_covariance, uncorrelated]
  samples: 300
  save_samples: true
metrics: [multiscale_rmse, cmd, kl_pixel, {kl_area: {block: 4}}]
sweep:
  grid:
    synthesis.samples: [300]
";

#[test]
fn synthesis_jobs_write_params_samples_and_generated_analyses() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("syn.yaml");
    std::fs::write(&spec, SYNTH).unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let o = run(&spec, &a, "2");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(run(&spec, &b, "1").status.success());
    let jobs = read(&a, "jobs.parquet");
    let ids = strings(&jobs, "job");
    // The synthesis axis applies to the synthesis jobs only: the analysis job has no params.
    assert_eq!(
        ids,
        [
            "d",
            "d.method1.synthesis.samples=300",
            "d.method2.synthesis.samples=300",
            "d.full_covariance.synthesis.samples=300",
            "d.uncorrelated.synthesis.samples=300"
        ]
    );
    // Common random numbers: one generation seed for every method of the dataset.
    let gen = jobs.column("generation_seed").unwrap().u64().unwrap();
    assert!((1..5).all(|i| gen.get(i) == gen.get(0)));
    let summary = read(&a, "analysis_summary.parquet");
    let sources: std::collections::BTreeSet<String> =
        strings(&summary, "source").into_iter().collect();
    assert_eq!(
        sources.into_iter().collect::<Vec<_>>(),
        [
            "full_covariance",
            "method1",
            "method2",
            "original",
            "uncorrelated"
        ]
    );
    let params = read(&a, "synthesis_params.parquet");
    for c in [
        "job",
        "dataset",
        "method",
        "row",
        "col",
        "alpha_h",
        "alpha_v",
        "r_h1",
        "r_h2",
        "r_v1",
        "r_v2",
        "residual_h",
        "residual_v",
        "clamped",
    ] {
        assert!(
            names(&params).contains(&c.to_string()),
            "synthesis_params lacks {c}"
        );
    }
    assert_eq!(
        params.height(),
        2 * 8 * 8,
        "methods 1 and 2, one row per level-1 cell"
    );
    // Saved samples: [M, H, W] complex64.
    let npy = a.join("samples/d.method1.synthesis.samples=300.npy");
    let header = isar_clutter::io::npy::read_header(&npy).unwrap();
    assert_eq!(header.shape, [300, 16, 16]);
    assert_eq!(header.dtype, isar_clutter::io::npy::Dtype::Complex64);
    // Same tables and samples whatever the thread count.
    for t in [
        "analysis_summary.parquet",
        "synthesis_params.parquet",
        "pixel_stats.parquet",
        "similarity.parquet",
        "model_order.parquet",
    ] {
        assert!(
            read(&a, t).equals_missing(&read(&b, t)),
            "{t} differs between --jobs 2 and 1"
        );
    }
    // Metrics: every method and the noise floor, identical KL maps.
    let sim = read(&a, "similarity.parquet");
    let methods: std::collections::BTreeSet<String> = strings(&sim, "method").into_iter().collect();
    assert_eq!(methods.len(), 5, "{methods:?}");
    for m in [
        "d/noise_floor_kl_area_re.npy",
        "d.method2.synthesis.samples=300/kl_pixel_im.npy",
    ] {
        assert_eq!(
            std::fs::read(a.join("maps").join(m)).unwrap(),
            std::fs::read(b.join("maps").join(m)).unwrap(),
            "{m}"
        );
    }
    assert_eq!(
        std::fs::read(&npy).unwrap(),
        std::fs::read(b.join("samples/d.method1.synthesis.samples=300.npy")).unwrap()
    );
}

#[test]
fn fit_then_generate_streams_the_same_samples_as_the_library() {
    use isar_clutter::synthesis::{fit, FitOptions, Method};
    let dir = tempfile::tempdir().unwrap();
    let stack = Array3::from_shape_fn((40, 8, 10), |(n, r, c)| {
        let x = ((n * 31 + r * 7 + c * 3) % 17) as f32 - 8.0;
        Complex::new(x + (c as f32) * 0.1, ((n + 2 * r) % 5) as f32)
    });
    stack
        .write_npy(File::create(dir.path().join("s.npy")).unwrap())
        .unwrap();
    for method in [
        "method1",
        "method2",
        "full_covariance",
        "uncorrelated",
        "fourth_order",
    ] {
        let model_dir = dir.path().join(method);
        let o = bin(&[
            "fit",
            "--input",
            dir.path().join("s.npy").to_str().unwrap(),
            "--method",
            method,
            "--out",
            model_dir.to_str().unwrap(),
            "--levels",
            "2",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = dir.path().join(format!("{method}.npy"));
        let gen = |jobs: &str, chunk: &str, path: &Path| {
            let o = bin(&[
                "generate",
                "--model",
                model_dir.to_str().unwrap(),
                "--samples",
                "37",
                "--seed",
                "9",
                "--out",
                path.to_str().unwrap(),
                "--chunk",
                chunk,
                "--jobs",
                jobs,
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        };
        gen("2", "5", &out);
        let other = dir.path().join("other.npy");
        gen("1", "100", &other);
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&other).unwrap(),
            "{method}: chunking and threads do not change the file"
        );
        // The loaded model generates what the freshly fitted one does.
        let (loaded, info) = isar_clutter::io::model::load(&model_dir).unwrap();
        assert_eq!(info.samples_fitted, 40);
        let m: Method = serde_json::from_value(serde_json::Value::String(method.into())).unwrap();
        let c128 = stack.mapv(|z| num_complex::Complex64::new(z.re as f64, z.im as f64));
        let levels = if m == Method::Method2 { 2 } else { 1 };
        let a = isar_clutter::stats::analysis::analyse(c128.view(), levels).unwrap();
        let fresh = fit(
            m,
            &a,
            Some(c128.view()),
            FitOptions {
                half_width: 8,
                levels,
                ..FitOptions::default()
            },
        )
        .unwrap();
        let want = fresh.generate_c64(9, 0, 37);
        assert_eq!(loaded.generate_c64(9, 0, 37), want, "{method}");
        let read_back: Array3<Complex<f32>> = ndarray_npy::read_npy(&out).unwrap();
        assert_eq!(
            read_back, want,
            "{method}: the streamed file holds the samples"
        );
    }
}

/// `model.json` records the sample format; a model without it (written before the format was
/// recorded) is format 1 and generates exactly what it did, `--sample-format` chooses the
/// other, `--buffered` writes the same bytes as direct I/O, and a format this version does not
/// know is refused with the file named.
#[test]
fn model_folders_carry_their_sample_format() {
    let dir = tempfile::tempdir().unwrap();
    let stack = Array3::from_shape_fn((40, 8, 10), |(n, r, c)| {
        Complex::new(
            ((n * 31 + r * 7 + c * 3) % 17) as f32 - 8.0,
            ((n + 2 * r) % 5) as f32,
        )
    });
    let input = dir.path().join("s.npy");
    stack.write_npy(File::create(&input).unwrap()).unwrap();
    let model = dir.path().join("m");
    let o = bin(&[
        "fit",
        "--input",
        input.to_str().unwrap(),
        "--method",
        "method1",
        "--out",
        model.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = model.join("model.json");
    let info: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(info["sample_format"], 2);
    let gen = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "generate",
            "--model",
            model.to_str().unwrap(),
            "--samples",
            "21",
            "--seed",
            "4",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = bin(&args);
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).to_string(),
            std::fs::read(&out).ok(),
        )
    };
    let (ok, _, two) = gen("two.npy", &[]);
    assert!(ok);
    let (ok, _, buffered) = gen("buffered.npy", &["--buffered"]);
    assert!(ok);
    assert_eq!(
        two, buffered,
        "direct and buffered writes hold the same bytes"
    );
    let (ok, _, forced_one) = gen("forced1.npy", &["--sample-format", "1"]);
    assert!(ok);
    assert_ne!(two, forced_one);
    // The same folder as an earlier version wrote it: no sample_format.
    let mut old = info.clone();
    old.as_object_mut().unwrap().remove("sample_format");
    std::fs::write(&json, serde_json::to_vec_pretty(&old).unwrap()).unwrap();
    let (ok, err, one) = gen("one.npy", &[]);
    assert!(ok, "{err}");
    assert!(err.contains("format 1"), "{err}");
    assert_eq!(one, forced_one, "an old model generates format 1");
    let (loaded, _) = isar_clutter::io::model::load(&model).unwrap();
    assert_eq!(loaded.moments().sample_format, 1);
    let (ok, _, forced_two) = gen("forced2.npy", &["--sample-format", "2"]);
    assert!(ok);
    assert_eq!(forced_two, two);
    // A format from the future.
    let mut future = info.clone();
    future["sample_format"] = serde_json::json!(3);
    std::fs::write(&json, serde_json::to_vec_pretty(&future).unwrap()).unwrap();
    let (ok, err, _) = gen("three.npy", &[]);
    assert!(!ok);
    assert!(
        err.contains("model.json") && err.contains("sample_format 3"),
        "{err}"
    );
}

/// With `mat73` built through the Makefile (Debian's static libhdf5.a, `make hdf5`), the binary
/// needs no libhdf5 (nor libcurl and the 31 libraries that the shared one brings) at start; a
/// dynamic build is refused under `CI=true`, which builds through the Makefile.
#[cfg(feature = "mat73")]
#[test]
fn the_binary_does_not_load_libhdf5_at_start() {
    let link = env!("ISAR_CLUTTER_HDF5_LINK");
    if link != "static" {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI builds with `make`, which links libhdf5 statically (HDF5_DIR from `make hdf5`)"
        );
        eprintln!("skipped: libhdf5 is linked dynamically (build with `make` for a static one)");
        return;
    }
    let out = std::process::Command::new("readelf")
        .args(["-d", env!("CARGO_BIN_EXE_isar-clutter")])
        .output()
        .expect("readelf (binutils) runs");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let needed: Vec<&str> = text.lines().filter(|l| l.contains("(NEEDED)")).collect();
    assert!(!needed.is_empty(), "no NEEDED entries read:\n{text}");
    for lib in ["libhdf5", "libcurl", "libssl", "libcrypto"] {
        assert!(
            needed.iter().all(|l| !l.contains(lib)),
            "the binary needs {lib}:\n{}",
            needed.join("\n")
        );
    }
}
