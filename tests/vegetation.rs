//! The `vegetation_isar` dataset kind through the runner: presets with spec overrides become
//! image stacks of the requested size, the same seed gives the same tables whatever the thread
//! count, and light wind moves plant A more than plant C (the dissertation's Table 16 ordering).

mod common;

use common::{opt_strings, read_table as read, run_spec};
use std::path::Path;

const SPEC: &str = "name: veg
seed: 9
datasets:
  - {id: plant_A_light, kind: vegetation_isar, plant: A, wind: light, samples: 16, image_size: 32,
     measurement: {frequencies: 64, azimuths: 48}, save_kspace: true}
  - {id: plant_C_light, kind: vegetation_isar, plant: C, wind: light, samples: 16, image_size: 32,
     measurement: {frequencies: 64, azimuths: 64}, scene: {noise_db: -40}}
analysis:
  levels: 2
";

fn run(spec: &Path, out: &Path, jobs: &str) {
    run_spec(spec, out, &["--no-report", "--jobs", jobs]);
}

#[test]
fn simulated_plants_run_reproducibly_and_order_by_motion() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("veg.yaml");
    std::fs::write(&spec, SPEC).unwrap();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    run(&spec, &a, "1");
    run(&spec, &b, "2");
    for t in ["pixel_stats.parquet", "analysis_summary.parquet"] {
        assert!(
            read(&a, t).equals_missing(&read(&b, t)),
            "{t} depends on threads"
        );
    }
    // The k-space samples behind the images, with their axes.
    let k = isar_clutter::io::npy::read_header(&a.join("kspace/plant_A_light.npy")).unwrap();
    assert_eq!(k.shape, [16, 64, 48]);
    assert_eq!(k.dtype, isar_clutter::io::npy::Dtype::Complex64);
    let f =
        isar_clutter::io::npy::read_real_vector(&a.join("kspace/plant_A_light.freqs.npy")).unwrap();
    assert_eq!((f.len(), f[0], f[63]), (64, 2e9, 18e9));
    let az =
        isar_clutter::io::npy::read_real_vector(&a.join("kspace/plant_A_light.azimuths_deg.npy"))
            .unwrap();
    assert!((az[0] + 25.5).abs() < 1e-9 && (az[47] - 25.5).abs() < 1e-9);
    assert!(!a.join("kspace/plant_C_light.npy").exists());
    let px = read(&a, "pixel_stats.parquet");
    assert_eq!(px.height(), 2 * 32 * 32);
    let ds = px.column("dataset").unwrap().str().unwrap();
    let var = px.column("variance").unwrap().f64().unwrap();
    let mean = |d: &str| {
        let v: Vec<f64> = (0..px.height())
            .filter(|&i| ds.get(i) == Some(d))
            .map(|i| var.get(i).unwrap())
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (va, vc) = (mean("plant_A_light"), mean("plant_C_light"));
    assert!(va > 2.0 * vc, "plant A {va} vs plant C {vc}");
}

/// H1-H4 through the runner: the table has every hypothesis with a verdict, Table 16 has one
/// variance per dataset, and H1 (light wind moves plant A more than no wind) is verified.
#[test]
fn hypotheses_table_from_a_small_plant_run() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("h.yaml");
    let small = "samples: 12, image_size: 32, measurement: {frequencies: 64, azimuths: 64}";
    std::fs::write(
        &spec,
        format!(
            "name: h\nseed: 4\ndatasets:\n  - {{id: plant_A_none, kind: vegetation_isar, plant: A, wind: none, {small}}}\n  - {{id: plant_A_light, kind: vegetation_isar, plant: A, wind: light, {small}}}\nanalysis:\n  levels: 2\nhypotheses: {{max_offset: 2}}\n"
        ),
    )
    .unwrap();
    let out = tmp.path().join("out");
    run(&spec, &out, "2");
    let h = read(&out, "hypotheses.parquet");
    let s = |c: &str| opt_strings(&h, c);
    let (hyp, ds, stat, verdict) = (s("hypothesis"), s("dataset"), s("statistic"), s("verdict"));
    for name in ["table16", "H1", "H2", "H3", "H4"] {
        assert!(hyp.iter().any(|x| x.as_deref() == Some(name)), "no {name}");
    }
    assert_eq!(
        hyp.iter()
            .filter(|x| x.as_deref() == Some("table16"))
            .count(),
        2
    );
    let i = (0..h.height())
        .find(|&i| {
            hyp[i].as_deref() == Some("H1")
                && ds[i].as_deref() == Some("plant_A")
                && stat[i].as_deref() == Some("variance_ratio_light_over_none")
        })
        .expect("H1 row for plant A");
    assert_eq!(verdict[i].as_deref(), Some("verified"));
    let cf = read(&out, "correlating_function.parquet");
    assert_eq!(cf.height(), 2 * 25, "5 x 5 offsets per dataset");
    // The report draws Figs. 50-56 from these tables: the correlating function's map and cuts,
    // the correlation by level for each wind, and against the wind for each level.
    let report = isar_clutter::report::build(&out, false).unwrap();
    let stems: Vec<String> = report
        .figures
        .iter()
        .map(|f| {
            f.files[0]
                .file_stem()
                .unwrap()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    for stem in [
        "plants_correlating_function",
        "plants_correlating_horizontal",
        "plants_correlating_vertical",
        "plants_correlation_by_level_none",
        "plants_correlation_by_level_light",
        "plants_correlation_by_wind_level_1",
        "plants_correlation_by_wind_level_2",
        "plants_mean_kspace",
    ] {
        assert!(stems.iter().any(|s| s == stem), "no {stem} in {stems:?}");
        assert!(out.join("figures").join(format!("{stem}.png")).is_file());
    }
}

/// The mean k-space image (Fig. 48) an analysis job writes is the mean over the samples of the
/// k-space data it simulated (checked against the saved samples, complex64: to their rounding).
#[test]
fn the_mean_kspace_image_is_the_mean_of_the_kspace_samples() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("k.yaml");
    std::fs::write(
        &spec,
        "name: k\nseed: 3\ndatasets:\n  - {id: plant_B_light, kind: vegetation_isar, plant: B, wind: light, samples: 5, image_size: 32, save_kspace: true, measurement: {frequencies: 40, azimuths: 24}}\nanalysis:\n  levels: 1\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    run(&spec, &out, "2");
    let k: ndarray::Array3<num_complex::Complex<f32>> =
        ndarray_npy::read_npy(out.join("kspace/plant_B_light.npy")).unwrap();
    let mean: ndarray::Array2<num_complex::Complex64> =
        ndarray_npy::read_npy(out.join("kspace/plant_B_light.mean.npy")).unwrap();
    assert_eq!(mean.dim(), (40, 24));
    let scale = mean.iter().map(|z| z.norm()).fold(0.0, f64::max);
    for ((f, a), m) in mean.indexed_iter() {
        let want: num_complex::Complex64 = (0..5)
            .map(|s| {
                let z = k[[s, f, a]];
                num_complex::Complex64::new(z.re as f64, z.im as f64)
            })
            .sum::<num_complex::Complex64>()
            / 5.0;
        assert!(
            (m - want).norm() <= 1e-6 * scale,
            "[{f}, {a}]: {m} vs {want}"
        );
    }
}

/// Plant k-space data measured through the simulated chain (system response, chamber clutter,
/// background subtraction, noise) and calibrated with the sphere give nearly the images of the
/// ideal simulation, while the raw measurement does not.
#[test]
fn calibrated_plant_measurements_match_the_ideal_simulation() {
    use isar_clutter::experiment::Dataset;
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("c.yaml");
    std::fs::write(
        &spec,
        "name: c\nseed: 2\ndatasets:\n  - {id: plant_B_light, kind: vegetation_isar, plant: B, wind: light, samples: 6, image_size: 32, measurement: {azimuths: 48}, calibration: {}}\nanalysis:\n  levels: 1\n",
    )
    .unwrap();
    let p = isar_clutter::run::plan::load(&spec).unwrap();
    let job = &p.jobs[0];
    let Dataset::Vegetation(v) = &job.dataset else {
        panic!("vegetation")
    };
    assert_eq!(v.measurement.frequencies, 801, "the chain's frequencies");
    let calibrated = job
        .dataset
        .materialise(job.data_seed)
        .unwrap()
        .stack
        .to_complex128(false);
    let mut ideal = v.clone();
    ideal.calibration = None;
    let ideal = Dataset::Vegetation(ideal)
        .materialise(job.data_seed)
        .unwrap()
        .stack
        .to_complex128(false);
    let rel = |x: &ndarray::Array3<num_complex::Complex64>| {
        let d: f64 = x
            .iter()
            .zip(ideal.iter())
            .map(|(a, b)| (a - b).norm_sqr())
            .sum();
        (d / ideal.iter().map(|z| z.norm_sqr()).sum::<f64>()).sqrt()
    };
    // With the default chain (1 % of the chamber clutter left after background subtraction,
    // plus noise) the images stay within 20 % (RMS, relative); with neither, only the error of
    // a(f) (the sphere's time gating) remains, and it is smaller.
    let err = rel(&calibrated);
    assert!(
        err > 0.0 && err < 0.2,
        "calibrated images differ from the ideal by {err}"
    );
    let mut clean = v.clone();
    clean.calibration = Some(isar_clutter::physics::calibration::ChainParams {
        background_residual: 0.0,
        noise: 0.0,
        ..Default::default()
    });
    let clean = Dataset::Vegetation(clean)
        .materialise(job.data_seed)
        .unwrap()
        .stack
        .to_complex128(false);
    let err_clean = rel(&clean);
    assert!(err_clean < err / 2.0, "clean chain {err_clean} vs {err}");
}

/// `noise_floor: draws` on simulated plants compares the original with an independent
/// simulation of the same scene (`synthesis.samples` samples, its own seed); `auto` keeps the
/// cheap `halves`.
#[test]
fn plant_noise_floor_draws_an_independent_simulation() {
    let tmp = tempfile::tempdir().unwrap();
    let base = "name: nf\nseed: 5\ndatasets:\n  - {id: plant_B_light, kind: vegetation_isar, plant: B, wind: light, samples: 8, image_size: 32, measurement: {frequencies: 64, azimuths: 48}}\nanalysis:\n  levels: 1\nsynthesis:\n  methods: [uncorrelated]\n  samples: 6\nmetrics: [multiscale_rmse]\n";
    for (mode, want, compared) in [("draws", "draws", 6), ("auto", "halves", 4)] {
        let spec = tmp.path().join(format!("{mode}.yaml"));
        std::fs::write(&spec, format!("{base}noise_floor: {mode}\n")).unwrap();
        let out = tmp.path().join(mode);
        run(&spec, &out, "2");
        let t = read(&out, "similarity.parquet");
        let (method, floor) = (opt_strings(&t, "method"), opt_strings(&t, "noise_floor"));
        let compared_col = t.column("samples_compared").unwrap().i64().unwrap();
        let value = t.column("value").unwrap().f64().unwrap();
        let rows: Vec<usize> = (0..t.height())
            .filter(|&i| method[i].as_deref() == Some("noise_floor"))
            .collect();
        assert!(!rows.is_empty(), "{mode}: no noise-floor rows");
        for &i in &rows {
            assert_eq!(floor[i].as_deref(), Some(want), "{mode}");
            assert_eq!(compared_col.get(i), Some(compared), "{mode}");
            let v = value.get(i).unwrap();
            assert!(v.is_finite() && v > 0.0, "{mode}: {v}");
        }
    }
}
