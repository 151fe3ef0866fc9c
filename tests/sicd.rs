//! The `sicd` dataset kind against files it did not write: SICD images written by sarpy
//! (NGA's reader and writer; `tests/sicd/make_fixtures.py`, run at test time in the project's
//! virtualenv `.venv`) of `RE16I_IM16I` and `RE32F_IM32F` pixels give, in a window, the
//! analysis the same pixels give when sarpy reads them and saves them as `.npy`, value for
//! value, and their collection metadata reaches the manifest (and the calibration to sigma-0
//! with their own scale polynomial, where asked); a truncated file, a pixel type
//! where the XML and the NITF image segment differ, a file that is not NITF and a window
//! outside the images are refused at validation, naming the file and the field. Ground points
//! project to the pixels sarpy's projection gives, and a window given in longitude and
//! latitude reads the pixels sarpy puts it on (`tests/sicd/make_projection_fixtures.py`).

mod common;
use common::scenes::{assert_same_tables, assert_valid, dataset_files, refused, run};

use isar_clutter::io::sicd::Sicd;
use serde_json::json;
use std::path::{Path, PathBuf};

/// The fixture folder in `dir`; `None` (skip) without sarpy in `.venv`.
fn fixtures(dir: &Path) -> Option<PathBuf> {
    common::python_fixtures(
        "tests/sicd/make_fixtures.py",
        &["numpy", "sarpy"],
        &dir.join("fixtures"),
    )
}

/// The stack of windows of the images `prefix_0{k}.nitf`, as `kind: sicd` fields.
fn sicd_fields(prefix: &str) -> String {
    let files: Vec<String> = (0..3)
        .map(|k| format!("fixtures/{prefix}_0{k}.nitf"))
        .collect();
    format!(
        "kind: sicd, path: [{}], window: {{row: 5, col: 7, size: [16, 16]}}",
        files.join(", ")
    )
}

#[test]
fn sicd_window_stacks_are_analysed_as_sarpy_reads_their_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(_) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let ints = run(d, "ints", &sicd_fields("scene"));
    assert_same_tables(
        &ints,
        &run(d, "ints_npy", "kind: npy, path: fixtures/window.npy"),
    );
    let floats = run(d, "floats", &sicd_fields("float"));
    let npy = run(
        d,
        "floats_npy",
        "kind: npy, path: fixtures/float_window.npy",
    );
    assert_same_tables(&floats, &npy);
    let files = dataset_files(&ints);
    let f = &files["files"][1];
    assert_eq!(
        (&f["format"], &f["pixel"]),
        (&json!("SICD"), &json!("RE16I_IM16I")),
        "{f}"
    );
    let m = &f["sicd"];
    assert_eq!(
        (
            &m["collector"],
            &m["core_name"],
            &m["polarization"],
            &m["mode"]
        ),
        (
            &json!("TESTSAT"),
            &json!("CORE13"),
            &json!("V:V"),
            &json!("SPOTLIGHT")
        ),
        "{m}"
    );
    assert!(
        m["collect_start"]
            .as_str()
            .unwrap()
            .starts_with("2024-05-13T10:00:00"),
        "{m}"
    );
    assert_eq!(
        (&m["row"]["ss"], &m["col"]["imp_resp_wid"]),
        (&json!(0.5), &json!(0.38)),
        "{m}"
    );
    assert_eq!(m["scp_llh"][0], json!(48.0), "{m}");
    assert_eq!(
        dataset_files(&floats)["files"][0]["pixel"],
        json!("RE32F_IM32F")
    );
}

#[test]
fn bad_sicd_files_are_refused_naming_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    assert_valid(d, "good", &sicd_fields("scene"));
    let nitf = fx.join("scene_02.nitf");
    let bytes = std::fs::read(&nitf).unwrap();
    // Cut short.
    std::fs::write(&nitf, &bytes[..bytes.len() - 100]).unwrap();
    let e = refused(d, "truncated", &sicd_fields("scene"));
    assert!(
        e.contains("datasets[0].path[2]")
            && e.contains("scene_02.nitf: NITF header:")
            && e.contains("truncated"),
        "{e}"
    );
    // The XML says float32 where the image segment holds int16.
    let tag = b"<PixelType>RE16I_IM16I";
    let at = bytes.windows(tag.len()).position(|w| w == tag).unwrap();
    let mut changed = bytes.clone();
    changed[at..at + tag.len()].copy_from_slice(b"<PixelType>RE32F_IM32F");
    std::fs::write(&nitf, &changed).unwrap();
    let e = refused(d, "pixel", &sicd_fields("scene"));
    assert!(
        e.contains("datasets[0].path[2]")
            && e.contains("scene_02.nitf: PVTYPE:")
            && e.contains("16-bit SI")
            && e.contains("RE32F_IM32F"),
        "{e}"
    );
    std::fs::write(&nitf, &bytes).unwrap();
    // Not NITF.
    std::fs::write(fx.join("x.nitf"), b"II*\0not a nitf").unwrap();
    let e = refused(d, "not_nitf", "kind: sicd, path: fixtures/x.nitf");
    assert!(
        e.contains("datasets[0].path") && e.contains("x.nitf: NITF header: not a NITF 2.1 file"),
        "{e}"
    );
    let e = refused(
        d,
        "no_poly",
        "kind: sicd, path: [fixtures/scene_00.nitf, fixtures/scene_01.nitf], calibration: sigma0",
    );
    assert!(
        e.contains("datasets[0].calibration")
            && e.contains("scene_00.nitf: its SICD XML has no Radiometric/SigmaZeroSFPoly"),
        "{e}"
    );
    let e = refused(
        d,
        "outside",
        "kind: sicd, path: [fixtures/scene_00.nitf, fixtures/scene_01.nitf], window: {row: 0, col: 20, size: [16, 16]}",
    );
    assert!(
        e.contains("datasets[0].window") && e.contains("columns 20..36") && e.contains("40 x 30"),
        "{e}"
    );
}

/// The projection fixtures' folder in `dir` (`tests/sicd/make_projection_fixtures.py`);
/// `None` (skip) without sarpy in `.venv`.
fn projection_fixtures(dir: &Path) -> Option<PathBuf> {
    common::python_fixtures(
        "tests/sicd/make_projection_fixtures.py",
        &["numpy", "sarpy"],
        &dir.join("fixtures"),
    )
}

/// SICD's ground-to-image projection (`io::projection`) against sarpy's `ground_to_image_geo`
/// on images of the four projection models (INCA, PFA, RGAZCOMP, a ground plane) that sarpy
/// wrote: 60 points on and around each image at two heights land on the pixel places sarpy
/// gives within 1e-6 pixel (both iterate to a millionth of a metre on the ground; a pixel is
/// 0.4-0.5 m).
#[test]
fn sicd_ground_points_project_to_sarpys_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = projection_fixtures(dir.path()) else {
        return;
    };
    let points: serde_json::Value = common::read_json(&fx.join("proj_points.json"));
    for kind in ["inca", "pfa", "rgazcomp", "plane"] {
        let sicd = Sicd::open(&fx.join(format!("proj_{kind}.nitf"))).unwrap();
        let projection = sicd.metadata.projection.as_ref().unwrap();
        let p = &points[kind];
        let (llh, pixel) = (p["llh"].as_array().unwrap(), p["pixel"].as_array().unwrap());
        assert_eq!(llh.len(), 60, "{kind}");
        for (l, want) in llh.iter().zip(pixel) {
            let f = |v: &serde_json::Value, i: usize| v[i].as_f64().unwrap();
            let ([r, c], left) = projection.geodetic_to_image(f(l, 0), f(l, 1), f(l, 2));
            assert!(
                (r - f(want, 0)).abs() < 1e-6 && (c - f(want, 1)).abs() < 1e-6 && left < 1e-6,
                "{kind} {l}: ({r}, {c}) where sarpy has {want} (left {left} m)"
            );
        }
    }
}

/// A window given as a box of longitude and latitude over a stack of two coregistered SICD
/// images is the pixels sarpy's projection puts the box on (its edges mapped at 17 points,
/// rounded outwards, in the fixture script), analysed value for value as sarpy reads them.
/// An image whose XML lacks what the projection needs is refused naming the element.
#[test]
fn a_map_box_on_sicd_images_reads_the_pixels_sarpy_projects_it_to() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = projection_fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let b: serde_json::Value = common::read_json(&fx.join("map_box.json"));
    let (x, y) = (&b["box"][0], &b["box"][1]);
    let fields = format!(
        "kind: sicd, path: [fixtures/proj_inca.nitf, fixtures/proj_inca_b.nitf], window: {{x: {x}, y: {y}}}"
    );
    let map = run(d, "map", &fields);
    assert_same_tables(
        &map,
        &run(d, "map_npy", "kind: npy, path: fixtures/map_window.npy"),
    );
    assert_eq!(dataset_files(&map)["files"][0]["projection"], json!("INCA"));
    // The first fixtures' images have no aperture track.
    let _ = fixtures(&d.join("plain")).unwrap();
    let e = refused(
        d,
        "no_track",
        "kind: sicd, path: plain/fixtures/scene_00.nitf, window: {x: [10.9, 11.1], y: [47.9, 48.1]}",
    );
    assert!(
        e.contains("datasets[0].window")
            && e.contains("scene_00.nitf: its SICD XML lacks ImageFormation/ImageFormAlgo"),
        "{e}"
    );
}
