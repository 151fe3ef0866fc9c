//! Sentinel-1 measurements calibrated by their SAFE product's calibration annotation, against
//! xarray-sentinel (B-Open's Sentinel-1 reader; `tests/geotiff/make_s1_calibration.py`, run at
//! test time in `.venv`): `cut --calibration sigma0` of a CInt16 measurement written by
//! rasterio gives the values xarray-sentinel's `calibrate_amplitude` gives (each divided by the
//! `sigmaNought` table interpolated at its line and pixel), value for value; the `geotiff`
//! kind's calibrated analysis is that of the same patches; vectors off a regular grid and a
//! quantity the annotation has no table of are refused, naming the annotation.

mod common;

use std::path::{Path, PathBuf};

/// The fixture folder in `dir`; `None` (skip) without rasterio and xarray-sentinel in `.venv`.
fn fixtures(dir: &Path) -> Option<PathBuf> {
    common::python_fixtures(
        "tests/geotiff/make_s1_calibration.py",
        &["numpy", "rasterio", "xarray_sentinel"],
        &dir.join("fixtures"),
    )
}

/// The measurement inside the SAFE folder `safe` of the fixtures, relative to them.
fn measurement(safe: &str) -> String {
    format!(
        "{safe}/measurement/s1a-iw1-slc-vv-20240501t140000-20240501t140027-053600-067f00-004.tiff"
    )
}

/// The SAFE product of the fixtures.
const SAFE: &str = "S1A_IW_SLC__1SDV_20240501T140000_20240501T140027_053600_067F00_ABCD.SAFE";

#[test]
fn a_sentinel1_measurement_is_calibrated_as_xarray_sentinel_calibrates_it() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let tiff = fx.join(measurement(SAFE));
    // The whole scene as one patch, then the usual cut: xarray-sentinel's values.
    let whole = d.join("whole.npy");
    let o = common::bin(&[
        "cut",
        "--input",
        tiff.to_str().unwrap(),
        "--patch",
        "40x30",
        "--calibration",
        "sigma0",
        "--out",
        whole.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::text(&o));
    let ours = std::fs::read(&whole).unwrap();
    let theirs = std::fs::read(fx.join("s1_sigma0.npy")).unwrap();
    // The same header length (both numpy's [1, 40, 30] / [40, 30] complex64 layouts differ in
    // shape only): compare the 1,200 values.
    let values = |b: &[u8]| b[b.len() - 40 * 30 * 8..].to_vec();
    assert_eq!(values(&ours), values(&theirs));
    let cut = d.join("cut.npy");
    common::scenes::cut_cli(
        std::slice::from_ref(&tiff),
        &cut,
        &["--calibration", "sigma0"],
    );
    common::scenes::cut_cli(&[fx.join("s1_sigma0.npy")], &d.join("theirs_cut.npy"), &[]);
    assert_eq!(
        std::fs::read(&cut).unwrap(),
        std::fs::read(d.join("theirs_cut.npy")).unwrap()
    );
    // The dataset kind: the analysis of those patches.
    let fields = format!(
        "kind: geotiff, path: [fixtures/{}], calibration: sigma0, {}",
        measurement(SAFE),
        common::scenes::CUT_FIELDS
    );
    std::fs::copy(d.join("theirs_cut.npy"), fx.join("theirs_cut.npy")).unwrap();
    let calibrated = common::scenes::run(d, "s1", &fields);
    common::scenes::assert_same_tables(
        &calibrated,
        &common::scenes::run(d, "npy", "kind: npy, path: fixtures/theirs_cut.npy"),
    );
    let files = common::scenes::dataset_files(&calibrated);
    assert_eq!(files["files"][0]["calibrated_to"], "sigma0", "{files}");
    let source = files["files"][0]["calibration_source"].as_str().unwrap();
    assert!(source.ends_with("annotation/calibration/calibration-s1a-iw1-slc-vv-20240501t140000-20240501t140027-053600-067f00-004.xml"), "{source}");
    // Refusals at `calibration`, naming the annotation.
    let bad = fields.replace(SAFE, "bad_pixels.SAFE");
    for (spec, words) in [
        (bad, "calibrationVector 2 gives other pixels than the first"),
        (
            fields.replace("sigma0", "rcs"),
            "gives sigma0, beta0 and gamma0 (asked for rcs)",
        ),
    ] {
        let e = common::scenes::refused(d, "bad", &spec);
        assert!(
            e.contains("datasets[0].calibration") && e.contains(words),
            "{e}"
        );
    }
}
