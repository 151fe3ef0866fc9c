//! The calibration experiment (2.3, Figs. 11-14) end to end: `experiments/calibration.yaml`
//! runs without datasets and writes the spectra and the error summary; the calibrated sphere
//! matches its Mie series inside the band while the raw data do not; bad parameters are refused
//! with their YAML path.

mod common;

use common::{read_table, run_spec};
use std::path::Path;

#[test]
fn the_calibration_experiment_recovers_the_mie_series() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/calibration.yaml");
    run_spec(&spec, tmp.path(), &[]);
    let spectra = read_table(tmp.path(), "calibration.parquet");
    assert_eq!(spectra.height(), 801);
    let s = read_table(tmp.path(), "calibration_summary.parquet");
    let get = |band: &str, stat: &str| -> f64 {
        let b = s.column("band").unwrap().str().unwrap();
        let st = s.column("statistic").unwrap().str().unwrap();
        let v = s.column("value").unwrap().f64().unwrap();
        (0..s.height())
            .find(|&i| b.get(i) == Some(band) && st.get(i) == Some(stat))
            .and_then(|i| v.get(i))
            .unwrap()
    };
    // Inside the band (away from the gate's edge transients) the calibrated sphere is within
    // 0.1 dB and 1 degree of Mie; the raw data are tens of dB off (gain, ripple, clutter).
    assert!(
        get("inner", "max_abs_error_db") < 0.1,
        "{}",
        get("inner", "max_abs_error_db")
    );
    assert!(get("inner", "max_abs_phase_error_deg") < 1.0);
    assert!(get("inner", "max_abs_raw_error_db") > 10.0);
    // The report has the spectra figure.
    assert!(tmp.path().join("figures/calibration_spectra.png").is_file());
}

#[test]
fn bad_calibration_parameters_name_their_path() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("c.yaml");
    std::fs::write(&p, "name: c\nseed: 1\ncalibration:\n  points: 4\n").unwrap();
    let e = isar_clutter::run::plan::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("calibration.points") && e.contains("at least 16"),
        "{e}"
    );
    std::fs::write(&p, "name: c\nseed: 1\ncalibration:\n  f_stop: 1.0e9\n").unwrap();
    let e = isar_clutter::run::plan::load(&p).unwrap_err().to_string();
    assert!(e.contains("calibration.f_stop"), "{e}");
    std::fs::write(&p, "name: c\nseed: 1\ncalibration:\n  radius: 1\n").unwrap();
    let e = isar_clutter::run::plan::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("calibration") && e.contains("unknown field `radius`"),
        "{e}"
    );
    // Datasets still need an analysis section.
    std::fs::write(&p, "name: c\nseed: 1\ndatasets:\n  - id: d\n    kind: filtered_noise\n    family: exponential\n    alpha_h: 1\n    alpha_v: 1\n    size: [8, 8]\n    samples: 4\n").unwrap();
    let e = isar_clutter::run::plan::load(&p).unwrap_err().to_string();
    assert!(e.contains("analysis") && e.contains("missing field"), "{e}");
}
