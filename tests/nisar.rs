//! NISAR products' calibration tables against files the tool did not write
//! (`tests/hdf5/make_nisar_fixtures.py`: h5py in isce3's RSLC and GSLC layouts, and the scenes
//! calibrated by numpy and scipy's bilinear interpolator by ASF's stated convention, `sigma0 =
//! |DN|^2 / table^2`): an RSLC frame calibrated to sigma0 by the `hdf5` kind is analysed value
//! for value as numpy's calibrated scene is; `cut --calibration gamma0` of a GSLC frame (its
//! y axes falling) writes numpy's patches byte for byte; tables that cannot be placed on the
//! scene (another epoch, no times beside it, a zero, too few ranges) and a quantity the
//! product has no table of are refused naming the file and the dataset.
#![cfg(feature = "mat73")]

mod common;

use std::path::{Path, PathBuf};

/// The fixture folder in `dir`; `None` (skip) without numpy, h5py and scipy in `.venv`.
fn fixtures(dir: &Path) -> Option<PathBuf> {
    common::python_fixtures(
        "tests/hdf5/make_nisar_fixtures.py",
        &["numpy", "h5py", "scipy"],
        &dir.join("fixtures"),
    )
}

/// The RSLC scene's dataset.
const RSLC: &str = "/science/LSAR/RSLC/swaths/frequencyA/HH";

#[test]
fn nisar_tables_calibrate_as_numpy_does_by_asfs_convention() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let cut = common::scenes::CUT_FIELDS;
    // The RSLC frame calibrated to sigma0, against the cut of numpy's calibrated scene.
    let rslc = format!("kind: hdf5, path: fixtures/rslc.h5, dataset: {RSLC}, {cut}");
    common::scenes::cut_cli(
        &[fx.join("rslc_sigma0.npy")],
        &fx.join("rslc_sigma0_cut.npy"),
        &[],
    );
    let npy = common::scenes::run(d, "npy", "kind: npy, path: fixtures/rslc_sigma0_cut.npy");
    let calibrated = common::scenes::run(d, "rslc", &format!("{rslc}, calibration: sigma0"));
    common::scenes::assert_same_tables(&calibrated, &npy);
    let files = common::scenes::dataset_files(&calibrated);
    assert_eq!(files["files"][0]["calibrated_to"], "sigma0", "{files}");
    assert_eq!(
        files["files"][0]["calibration_source"],
        "/science/LSAR/RSLC/metadata/calibrationInformation/geometry/sigma0",
        "{files}"
    );
    // The GSLC frame by `cut --calibration gamma0`: numpy's patches, byte for byte.
    let gslc = ["--dataset", "/science/LSAR/GSLC/grids/frequencyA/HH"];
    let ours = d.join("gslc_cut.npy");
    let theirs = d.join("gslc_numpy_cut.npy");
    let extra = [&gslc[..], &["--calibration", "gamma0"]].concat();
    common::scenes::cut_cli(&[fx.join("gslc.h5")], &ours, &extra);
    common::scenes::cut_cli(&[fx.join("gslc_gamma0.npy")], &theirs, &[]);
    assert_eq!(
        std::fs::read(&ours).unwrap(),
        std::fs::read(&theirs).unwrap()
    );
    let record = std::fs::read_to_string(d.join("gslc_cut.npy.patches.json")).unwrap();
    assert!(record.contains("\"calibrated_to\": \"gamma0\""), "{record}");
    // Uncalibrated, the same cut differs (the check above is not vacuous).
    let plain = d.join("gslc_plain.npy");
    common::scenes::cut_cli(&[fx.join("gslc.h5")], &plain, &gslc);
    assert_ne!(
        std::fs::read(&plain).unwrap(),
        std::fs::read(&theirs).unwrap()
    );

    // Refusals, at `datasets[0].calibration`, naming the file and what is wrong.
    let bad = |group: &str| {
        format!(
            "kind: hdf5, path: fixtures/bad.h5, dataset: /{group}/swaths/frequencyA/HH, \
             calibration: sigma0, {cut}"
        )
    };
    for (fields, words) in [
        (
            format!("{rslc}, calibration: rcs"),
            "geometry holds no rcs table (it holds [\"beta0\", \"gamma0\", \"sigma0\"])",
        ),
        (
            bad("epoch"),
            "/epoch/metadata/calibrationInformation/geometry/zeroDopplerTime is in \
             \"seconds since 2025-11-01T00:00:00.000000000\" but /epoch/swaths/zeroDopplerTime \
             in \"seconds since 2025-11-02",
        ),
        (
            bad("no_time"),
            "no zeroDopplerTime beside /no_time/swaths/frequencyA/HH",
        ),
        (
            bad("zero"),
            "geometry/sigma0: the table's value at [2, 1] is 0, not a positive number",
        ),
        (
            bad("short"),
            "/short/swaths/frequencyA/slantRange holds 29 values for the scene's 30 columns",
        ),
    ] {
        let e = common::scenes::refused(d, "bad", &fields);
        assert!(
            e.contains("datasets[0].calibration") && e.contains("h5: ") && e.contains(words),
            "{fields}: {e}"
        );
    }
    // From `cut`: named at --calibration; an .npy input has no scale factors.
    let o = common::bin(&[
        "cut",
        "--input",
        fx.join("rslc_sigma0.npy").to_str().unwrap(),
        "--patch",
        "8",
        "--calibration",
        "sigma0",
        "--out",
        d.join("never.npy").to_str().unwrap(),
    ]);
    let said = common::text(&o);
    assert_eq!(o.status.code(), Some(2), "{said}");
    assert!(said.contains("--calibration: ") && said.contains("holds no scale factors"));
    assert!(!d.join("never.npy").exists());
}

#[test]
fn an_rslc_map_box_lands_where_its_geolocation_grid_puts_it() {
    // `map_box.json`: a longitude/latitude box and the pixels scipy places it on through the
    // frame's geolocation grid at its reference terrain height (200 m; on the ellipsoid it
    // would land a column to the right).
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let b = common::read_json(&fx.join("map_box.json"));
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let (x, y) = (
        [f(&b["x"][0]), f(&b["x"][1])],
        [f(&b["y"][0]), f(&b["y"][1])],
    );
    let w: Vec<u64> = (0..4).map(|k| b["window"][k].as_u64().unwrap()).collect();
    let input = [fx.join("rslc.h5")];
    let cut = |name: &str, place: &[&str]| {
        let out = d.join(name);
        let extra = ["--dataset", RSLC, "--patch", "4", "--stride", "3"];
        let mut args: Vec<String> = vec!["cut".into(), "--input".into()];
        args.push(input[0].display().to_string());
        args.extend(extra.iter().chain(place).map(|a| a.to_string()));
        args.extend(["--out".into(), out.display().to_string()]);
        let o = common::bin(&args);
        assert!(o.status.success(), "{}", common::text(&o));
        std::fs::read(out).unwrap()
    };
    let map_box = format!("--map-box={},{},{},{}", x[0], x[1], y[0], y[1]);
    let pixels = format!("{}:{},{}:{}", w[0], w[1], w[2], w[3]);
    let by_map = cut("map.npy", &[&map_box]);
    assert_eq!(by_map, cut("pixels.npy", &["--window", &pixels]));
    let e = &b["ellipsoid_window"];
    let ellipsoid = format!("{}:{},{}:{}", e[0], e[1], e[2], e[3]);
    assert_ne!(by_map, cut("ellipsoid.npy", &["--window", &ellipsoid]));
    // The `hdf5` kind's map window: the same tables as its pixel window.
    let kind = format!("kind: hdf5, path: fixtures/rslc.h5, dataset: {RSLC}, cut: {{patch: 4}}");
    let map = format!(
        "{kind}, window: {{x: [{}, {}], y: [{}, {}]}}",
        x[0], x[1], y[0], y[1]
    );
    let px = format!(
        "{kind}, window: {{row: {}, col: {}, size: [{}, {}]}}",
        w[0],
        w[2],
        w[1] - w[0],
        w[3] - w[2]
    );
    let by_map = common::scenes::run(d, "map", &map);
    common::scenes::assert_same_tables(&by_map, &common::scenes::run(d, "px", &px));
    let files = common::scenes::dataset_files(&by_map);
    assert_eq!(
        files["files"][0]["map_placed_by"],
        "geolocation grid /science/LSAR/RSLC/metadata/geolocationGrid at 200 m above the \
         ellipsoid (the mean of /science/LSAR/RSLC/metadata/processingInformation/parameters/\
         referenceTerrainHeight)",
        "{files}"
    );
    // A box off the grid: refused, saying so.
    let o = common::bin(&[
        "cut",
        "--input",
        input[0].to_str().unwrap(),
        "--dataset",
        RSLC,
        "--patch",
        "4",
        "--map-box=-100,-99.9,10,10.1",
        "--out",
        d.join("never.npy").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", common::text(&o));
    assert!(
        common::text(&o).contains("maps to no finite pixels"),
        "{}",
        common::text(&o)
    );
}
