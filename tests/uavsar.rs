//! The `uavsar` dataset kind against files it did not write: UAVSAR scenes and annotations
//! written by numpy (`tests/uavsar/make_fixtures.py`, run at test time in the project's
//! virtualenv `.venv`) give, in a window, the analysis the same pixels give when numpy reads
//! them and saves them as `.npy`, value for value; a truncated scene, an annotation without a
//! size, a window outside a scene and a list of annotations of the wrong length are refused at
//! validation, naming the file and the field.

mod common;
use common::scenes::{self, assert_same_tables, run};

use std::path::{Path, PathBuf};

/// The fixture folder in `dir`; `None` (skip) without numpy in `.venv`.
fn fixtures(dir: &Path) -> Option<PathBuf> {
    common::python_fixtures(
        "tests/uavsar/make_fixtures.py",
        &["numpy"],
        &dir.join("fixtures"),
    )
}

/// The three scenes' file names.
fn scenes() -> Vec<String> {
    (0..3)
        .map(|k| format!("fixtures/testsite_0{k}_L090HH_01_BC_s1_1x1.slc"))
        .collect()
}

/// The stack of UAVSAR windows, as `kind: uavsar` fields.
fn uavsar_fields(extra: &str) -> String {
    format!(
        "kind: uavsar, slc: [{}], window: {{row: 5, col: 7, size: [16, 16]}}{extra}",
        scenes().join(", ")
    )
}

#[test]
fn a_uavsar_window_stack_is_analysed_as_numpy_reads_its_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(_) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let npy = run(d, "npy", "kind: npy, path: fixtures/window.npy");
    assert_same_tables(&run(d, "uavsar", &uavsar_fields("")), &npy);
}

#[test]
fn a_cut_uavsar_stack_is_the_stack_cut_cuts_from_numpys_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let fields = format!(
        "kind: uavsar, slc: [{}], {}",
        scenes().join(", "),
        scenes::CUT_FIELDS
    );
    let ours = run(d, "cut", &fields);
    scenes::cut_cli(&[fx.join("scenes.npy")], &fx.join("cut.npy"), &[]);
    assert_same_tables(&ours, &run(d, "npy", "kind: npy, path: fixtures/cut.npy"));
    // `isar-clutter cut` of the .slc files (each with its own annotation): the same stack.
    let inputs: Vec<std::path::PathBuf> = scenes().iter().map(|s| d.join(s)).collect();
    scenes::cut_cli(&inputs, &fx.join("slc_cut.npy"), &[]);
    assert_eq!(
        std::fs::read(fx.join("slc_cut.npy")).unwrap(),
        std::fs::read(fx.join("cut.npy")).unwrap()
    );
}

#[test]
fn bad_uavsar_files_are_refused_naming_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let refused = |name: &str, fields: &str| scenes::refused(dir.path(), name, fields);
    // The whole stack validates.
    scenes::assert_valid(dir.path(), "good", &uavsar_fields(""));
    // A truncated scene.
    let slc = fx.join("testsite_01_L090HH_01_BC_s1_1x1.slc");
    let bytes = std::fs::read(&slc).unwrap();
    std::fs::write(&slc, &bytes[..bytes.len() - 8]).unwrap();
    let e = refused("truncated", &uavsar_fields(""));
    assert!(
        e.contains("datasets[0].slc[1]")
            && e.contains("testsite_01_L090HH_01_BC_s1_1x1.slc")
            && e.contains("9592 bytes")
            && e.contains("40 rows x 30 columns"),
        "{e}"
    );
    std::fs::write(&slc, &bytes).unwrap();
    // An annotation without the scene's columns.
    let ann = fx.join("testsite_02_L090HH_01_BC.ann");
    let text_ann = std::fs::read_to_string(&ann).unwrap();
    let cut: String = text_ann
        .lines()
        .filter(|l| !l.starts_with("slc_1_1x1 Columns"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&ann, cut).unwrap();
    let e = refused("no_columns", &uavsar_fields(""));
    assert!(
        e.contains("datasets[0].slc[2]")
            && e.contains("testsite_02_L090HH_01_BC.ann")
            && e.contains("slc_1_1x1 Columns")
            && e.contains("missing"),
        "{e}"
    );
    std::fs::write(&ann, text_ann).unwrap();
    // A window outside the scenes.
    let e = refused(
        "outside",
        &format!(
            "kind: uavsar, slc: {}, window: {{row: 30, col: 0, size: [16, 16]}}",
            scenes()[0]
        ),
    );
    assert!(
        e.contains("datasets[0].window") && e.contains("rows 30..46") && e.contains("40 x 30"),
        "{e}"
    );
    // Two annotations for three scenes.
    let e = refused(
        "annotations",
        &uavsar_fields(", annotation: [fixtures/testsite_00_L090HH_01_BC.ann, fixtures/testsite_01_L090HH_01_BC.ann]"),
    );
    assert!(
        e.contains("datasets[0].annotation") && e.contains("2 annotation file(s) for 3 scene(s)"),
        "{e}"
    );
    // A scene without an annotation beside it.
    std::fs::rename(&ann, fx.join("elsewhere.ann")).unwrap();
    let e = refused("no_annotation", &uavsar_fields(""));
    assert!(
        e.contains("datasets[0].slc[2]")
            && e.contains("no annotation file found")
            && e.contains("testsite_02_L090HH_01_BC.ann"),
        "{e}"
    );
}
