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

/// Rewrites the annotation `path` without its lines that start with `prefix`; its text before.
fn drop_lines(path: &Path, prefix: &str) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let kept: String = text
        .lines()
        .filter(|l| !l.starts_with(prefix))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(path, kept).unwrap();
    text
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

/// A box of longitude and latitude through the flight line's `.llh` grid (numpy's rotated grid
/// of 2x8 looks): the stack of the blocks whose points numpy finds in the box, and the same
/// pixels cut by `isar-clutter cut --map-box`; an annotation without the `.llh` product, and a
/// `.llh` file of the wrong length, refused naming the file and the field.
#[test]
fn a_map_box_on_uavsar_scenes_reads_the_blocks_of_the_llh_points_in_it() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let b: serde_json::Value = common::read_json(&fx.join("map_box.json"));
    let (x, y) = (&b["box"][0], &b["box"][1]);
    let fields = format!(
        "kind: uavsar, slc: [{}], window: {{x: {x}, y: {y}}}",
        scenes().join(", ")
    );
    let map = run(d, "map", &fields);
    assert_same_tables(
        &map,
        &run(d, "map_npy", "kind: npy, path: fixtures/map_window.npy"),
    );
    // The `.llh` file decides the pixels: an input of the jobs (hashed into their store keys).
    let plan = isar_clutter::run::plan::load(&d.join("map.yaml")).unwrap();
    let inputs = plan.jobs[0].dataset.input_files();
    assert!(
        inputs
            .iter()
            .any(|p| p.ends_with("testsite_L090HH_01_BC_s1_2x8.llh")),
        "{inputs:?}"
    );
    // The command line: whole-window patches of the box, as numpy's window.
    let w: Vec<usize> = (0..4)
        .map(|k| b["window"][k].as_u64().unwrap() as usize)
        .collect();
    let (h, wd) = (w[1] - w[0], w[3] - w[2]);
    let inputs: Vec<std::path::PathBuf> = scenes().iter().map(|s| d.join(s)).collect();
    // `=`: the box starts with a minus sign.
    let boxed = format!(
        "--map-box={},{},{},{}",
        x[0].as_f64().unwrap(),
        x[1].as_f64().unwrap(),
        y[0].as_f64().unwrap(),
        y[1].as_f64().unwrap()
    );
    let patch = format!("{h}x{wd}");
    let mut args: Vec<String> = vec!["cut".into()];
    for i in &inputs {
        args.extend(["--input".into(), i.display().to_string()]);
    }
    args.extend(["--patch", &patch, "--stride", &patch, &boxed, "--out"].map(String::from));
    args.push(fx.join("map_cut.npy").display().to_string());
    let o = common::bin(&args);
    assert!(o.status.success(), "{}", common::text(&o));
    let npy = |f: &str| {
        ndarray_npy::read_npy::<_, ndarray::Array3<num_complex::Complex32>>(fx.join(f)).unwrap()
    };
    assert_eq!(npy("map_cut.npy"), npy("map_window.npy"));
    // Annotations that do not name the file: the one `..._s1_2x8.llh` beside the scenes.
    let anns: Vec<PathBuf> = (0..3)
        .map(|k| fx.join(format!("testsite_0{k}_L090HH_01_BC.ann")))
        .collect();
    let texts: Vec<String> = anns.iter().map(|a| drop_lines(a, "llh_1_2x8 ")).collect();
    assert_same_tables(&run(d, "map_unnamed", &fields), &map);
    for (a, t) in anns.iter().zip(&texts) {
        std::fs::write(a, t).unwrap();
    }
    // Without the `.llh` product in the annotation.
    let ann = fx.join("testsite_00_L090HH_01_BC.ann");
    let text = drop_lines(&ann, "llh_");
    let e = scenes::refused(d, "no_llh", &fields);
    assert!(
        e.contains("datasets[0].window")
            && e.contains("testsite_00_L090HH_01_BC.ann")
            && e.contains("no `llh_1_<R>x<A>` field"),
        "{e}"
    );
    // Asked for by the cut's map polygon alone: named there.
    let polygon = format!(
        "kind: uavsar, slc: [{}], cut: {{patch: 2, polygon_map: [[{x0}, {y0}], [{x1}, {y0}], \
         [{x0}, {y1}]]}}",
        scenes().join(", "),
        x0 = x[0],
        x1 = x[1],
        y0 = y[0],
        y1 = y[1]
    );
    let e = scenes::refused(d, "no_llh_polygon", &polygon);
    assert!(
        e.contains("datasets[0].cut.polygon_map") && e.contains("no `llh_1_<R>x<A>` field"),
        "{e}"
    );
    std::fs::write(&ann, text).unwrap();
    // A truncated `.llh` file.
    let llh = fx.join("testsite_L090HH_01_BC_s1_2x8.llh");
    let bytes = std::fs::read(&llh).unwrap();
    std::fs::write(&llh, &bytes[..bytes.len() - 12]).unwrap();
    let e = scenes::refused(d, "short_llh", &fields);
    assert!(
        e.contains("datasets[0].window")
            && e.contains("testsite_L090HH_01_BC_s1_2x8.llh holds 888 bytes")
            && e.contains("5 x 15 points"),
        "{e}"
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
    let text_ann = drop_lines(&ann, "slc_1_1x1 Columns");
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
