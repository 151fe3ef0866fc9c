//! The `hdf5` dataset kind against files it did not write (`tests/hdf5/make_fixtures.py`,
//! h5py in the project's virtualenv `.venv`, run at test time): one stack stored as h5py's
//! complex compound (chunked, gzip), as MATLAB's `{real, imag}` compound, as float pairs, as
//! real and imaginary datasets and with the samples last gives, in each form, the analysis the
//! same pixels give as `.npy` (read back by h5py), value for value (also chunked with the
//! samples last, big-endian, int16 and real-only data); which stacks are mapped rather than
//! read; a missing dataset,
//! strings, a single scene, an imaginary part of another shape and a truncated file are
//! refused at validation naming the file and the field.
#![cfg(feature = "mat73")]

mod common;
use common::{bin, text};

use std::path::{Path, PathBuf};

/// The fixture folder in `dir`; `None` (skip) without numpy, h5py in `.venv`.
fn fixtures(dir: &Path) -> Option<PathBuf> {
    common::python_fixtures(
        "tests/hdf5/make_fixtures.py",
        &["numpy", "h5py"],
        &dir.join("fixtures"),
    )
}

/// A spec analysing the dataset `fields` (a flow mapping's fields after `id`).
fn spec(dir: &Path, name: &str, fields: &str) -> PathBuf {
    let path = dir.join(format!("{name}.yaml"));
    std::fs::write(
        &path,
        format!(
            "name: {name}\nseed: 3\ndatasets:\n  - {{id: stack, {fields}}}\nanalysis:\n  levels: 2\n"
        ),
    )
    .unwrap();
    path
}

#[test]
fn every_form_of_an_hdf5_stack_is_analysed_as_its_pixels_are() {
    let dir = tempfile::tempdir().unwrap();
    let Some(_) = fixtures(dir.path()) else {
        return;
    };
    let h5 = "kind: hdf5, path: fixtures/stack.h5";
    let forms = [
        ("npy", "kind: npy, path: fixtures/stack.npy".to_string()),
        ("compound", format!("{h5}, dataset: /science/slc/HH")),
        ("pairs", format!("{h5}, dataset: pairs")),
        ("parts", format!("{h5}, dataset: /re, imag: /im")),
        ("hwn", format!("{h5}, dataset: hwn, layout: hwn")),
        ("matlab", format!("{h5}, dataset: matlab")),
        (
            "hwn_chunked",
            format!("{h5}, dataset: hwn_chunked, layout: hwn"),
        ),
        (
            "pairs_hwn",
            format!("{h5}, dataset: pairs_hwn, layout: hwn"),
        ),
        ("complex_be", format!("{h5}, dataset: complex_be")),
        ("shuffled", format!("{h5}, dataset: shuffled")),
        ("c128_chunked", format!("{h5}, dataset: c128_chunked")),
        ("pairs_chunked", format!("{h5}, dataset: pairs_chunked")),
        ("fletcher", format!("{h5}, dataset: fletcher")),
    ];
    analysed_alike(dir.path(), &forms);
    let ub = "kind: hdf5, path: fixtures/userblock.h5";
    analysed_alike(
        dir.path(),
        &[
            ("ub_npy", "kind: npy, path: fixtures/stack.npy".to_string()),
            ("ub_contig", format!("{ub}, dataset: contig")),
            ("ub_chunked", format!("{ub}, dataset: chunked")),
            ("ub_plain", format!("{ub}, dataset: plain_chunks")),
        ],
    );
    analysed_alike(
        dir.path(),
        &[
            ("ints_npy", "kind: npy, path: fixtures/ints.npy".to_string()),
            ("ints", format!("{h5}, dataset: ints")),
            ("ints_be", format!("{h5}, dataset: ints_be")),
        ],
    );
    analysed_alike(
        dir.path(),
        &[
            (
                "real_npy",
                "kind: npy, path: fixtures/real32.npy".to_string(),
            ),
            ("real32", format!("{h5}, dataset: real32")),
        ],
    );
}

/// Each of `forms` (a name and a dataset's fields) analysed gives the first's tables, value for
/// value.
fn analysed_alike(dir: &Path, forms: &[(&str, String)]) {
    let mut tables = vec![];
    for (name, fields) in forms {
        let s = spec(dir, name, fields);
        let out = dir.join(format!("out_{name}"));
        let o = bin(&[
            "run",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-report",
        ]);
        assert!(o.status.success(), "{name}: {}", text(&o));
        tables.push(common::tables(&out));
    }
    let names: Vec<&String> = tables[0]
        .keys()
        .filter(|n| !n.starts_with("jobs"))
        .collect();
    assert!(names.len() >= 3, "tables: {names:?}");
    for (k, (form, _)) in forms.iter().enumerate().skip(1) {
        for n in &names {
            assert!(
                tables[0][*n].equals_missing(&tables[k][*n]),
                "{form}: {n} differs:\n{}\n{}",
                tables[0][*n],
                tables[k][*n]
            );
        }
    }
}

/// A contiguous dataset of complex64, complex128 or real floats in the machine's byte order is
/// mapped as a `.npy` file is (no copy: the reason a 1 GB stack is analysed as fast as its
/// `.npy`, BENCHMARKS.md); big-endian, chunked or integer data are read, in single precision
/// where their numbers fit.
#[test]
fn contiguous_native_hdf5_stacks_are_mapped_and_others_read() {
    use isar_clutter::io::h5stack::{H5Stack, Storage};
    use isar_clutter::io::npy::Dtype;
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let file = fx.join("stack.h5");
    let storage = |name: &str, imag: Option<&str>| {
        H5Stack::open(&file, name, imag, false)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"))
            .storage
    };
    let mapped = |dtype| Storage::Mapped { offset: 0, dtype };
    let kind = |s: Storage| match s {
        Storage::Mapped { dtype, .. } => mapped(dtype),
        s => s,
    };
    for (name, imag, want) in [
        ("pairs", None, mapped(Dtype::Complex64)),
        ("hwn", None, mapped(Dtype::Complex128)),
        ("real32", None, mapped(Dtype::Float32)),
        ("matlab", None, mapped(Dtype::Complex64)),
        ("re", Some("im"), Storage::Double),
        ("science/slc/HH", None, Storage::Single),
        ("complex_be", None, Storage::Single),
        ("ints", None, Storage::Single),
        ("ints_be", None, Storage::Single),
    ] {
        assert_eq!(kind(storage(name, imag)), want, "{name}");
    }
}

#[test]
fn bad_hdf5_stacks_are_refused_naming_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let Some(_) = fixtures(dir.path()) else {
        return;
    };
    let refused = |name: &str, fields: &str| -> String {
        let s = spec(dir.path(), name, fields);
        let o = bin(&["validate", s.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o));
        text(&o)
    };
    let h5 = "kind: hdf5, path: fixtures/stack.h5";
    for (name, fields, want) in [
        (
            "missing",
            format!("{h5}, dataset: /science/slc/VV"),
            &[
                "datasets[0].dataset",
                "stack.h5",
                "no dataset \"/science/slc/VV\"",
                "science",
            ][..],
        ),
        (
            "text",
            format!("{h5}, dataset: text"),
            &["datasets[0].dataset", "\"text\" holds", "not numbers"][..],
        ),
        (
            "scene",
            format!("{h5}, dataset: scene"),
            &["datasets[0].dataset", "single scene [16, 12]", "give `cut`"][..],
        ),
        (
            "stack_cut",
            format!("{h5}, dataset: pairs, cut: {{patch: 4}}"),
            &["datasets[0].cut", "applies to a single scene [H, W]"][..],
        ),
        (
            "imag",
            format!("{h5}, dataset: re, imag: im_short"),
            &["datasets[0].imag", "[3, 16, 12]", "one shape"][..],
        ),
        (
            "truncated",
            "kind: hdf5, path: fixtures/truncated.h5, dataset: pairs".to_string(),
            &["datasets[0].path", "truncated.h5", "libhdf5 cannot open it"][..],
        ),
        (
            "no_dataset",
            h5.to_string(),
            &["datasets[0].dataset", "kind hdf5 needs `dataset`"][..],
        ),
    ] {
        let e = refused(name, &fields);
        for w in want {
            assert!(e.contains(w), "{name}: {w:?} not in {e}");
        }
    }
}

#[test]
fn a_single_hdf5_scene_is_cut_as_isar_clutter_cut_cuts_h5pys_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    // /frame/VV: a [40, 30] complex scene chunked 8 x 8 and compressed (an OPERA CSLC's form).
    let fields = "kind: hdf5, path: fixtures/stack.h5, dataset: /frame/VV";
    let ours = common::scenes::run(
        d,
        "scene_cut",
        &format!("{fields}, {}", common::scenes::CUT_FIELDS),
    );
    common::scenes::cut_cli(&[fx.join("frame.npy")], &fx.join("frame_cut.npy"), &[]);
    let npy = common::scenes::run(d, "frame_npy", "kind: npy, path: fixtures/frame_cut.npy");
    common::scenes::assert_same_tables(&ours, &npy);
    let files = common::scenes::dataset_files(&ours);
    assert_eq!(files["cut"]["places"], serde_json::json!(14), "{files}");
    assert_eq!(
        files["files"][0]["dataset"],
        serde_json::json!("/frame/VV"),
        "{files}"
    );
    // `isar-clutter cut` of the HDF5 scene itself: the same stack, byte for byte; a stack
    // or no --dataset refused.
    let h5_cut = fx.join("h5_cut.npy");
    let said =
        common::scenes::cut_cli(&[fx.join("stack.h5")], &h5_cut, &["--dataset", "/frame/VV"]);
    assert!(said.contains("(14 place(s) x 1 scene(s))"), "{said}");
    assert_eq!(
        std::fs::read(&h5_cut).unwrap(),
        std::fs::read(fx.join("frame_cut.npy")).unwrap()
    );
    // The same frame behind a user block (chunk addresses counted from its end).
    let ub_cut = fx.join("ub_cut.npy");
    common::scenes::cut_cli(&[fx.join("userblock.h5")], &ub_cut, &["--dataset", "frame"]);
    assert_eq!(
        std::fs::read(&ub_cut).unwrap(),
        std::fs::read(fx.join("frame_cut.npy")).unwrap()
    );
    // The window and the avoided box as map boxes in the frame's UTM metres (its coordinate
    // vectors: columns 5 m apart from x = 500000, rows 10 m apart down from y = 4200000), each
    // box's edges inside the pixels `CUT_FIELDS` names, give the same cut.
    let map_fields = format!(
        "{fields}, window: {{x: [500006, 500144], y: [4199621, 4199979]}}, cut: {{patch: 8, \
         stride: [8, 6], avoid: [{{row: 10, col: 10, size: [4, 4]}}]}}"
    );
    common::scenes::assert_same_tables(&common::scenes::run(d, "scene_map", &map_fields), &npy);
    let map_cut = fx.join("map_cut.npy");
    common::scenes::cut_cli_in(
        &[fx.join("stack.h5")],
        &map_cut,
        &["--map-box", "500006,500144,4199621,4199979"],
        &["--dataset", "/frame/VV"],
    );
    assert_eq!(
        std::fs::read(&map_cut).unwrap(),
        std::fs::read(fx.join("frame_cut.npy")).unwrap()
    );
    // An ICEYE SLC (int16 `s_i`, `s_q`) calibrated to beta0 by its `calibration_factor`: the
    // cut of numpy's calibrated scene, value for value; sigma0 and a file without the factor
    // refused at `calibration`.
    let iceye = format!(
        "kind: hdf5, path: fixtures/iceye.h5, dataset: s_i, imag: s_q, calibration: beta0, {}",
        common::scenes::CUT_FIELDS
    );
    common::scenes::cut_cli(
        &[fx.join("iceye_beta0.npy")],
        &fx.join("iceye_cut.npy"),
        &[],
    );
    let calibrated = common::scenes::run(d, "iceye", &iceye);
    common::scenes::assert_same_tables(
        &calibrated,
        &common::scenes::run(d, "iceye_npy", "kind: npy, path: fixtures/iceye_cut.npy"),
    );
    let iceye_files = common::scenes::dataset_files(&calibrated);
    assert_eq!(
        iceye_files["files"][0]["calibrated_to"], "beta0",
        "{iceye_files}"
    );
    for (fields, words) in [
        (
            iceye.replace("beta0", "sigma0"),
            "gives beta0 only (asked for sigma0)",
        ),
        (
            format!(
                "{fields}, calibration: beta0, {}",
                common::scenes::CUT_FIELDS
            ),
            "stack.h5: its HDF5 holds no /calibration_factor",
        ),
    ] {
        let e = common::scenes::refused(d, "bad_cal", &fields);
        assert!(
            e.contains("datasets[0].calibration") && e.contains(words),
            "{e}"
        );
    }
    // A scene with no coordinate vectors beside it has no map: refused, saying what is looked for.
    let o = bin(&[
        "cut",
        "--input",
        fx.join("userblock.h5").to_str().unwrap(),
        "--dataset",
        "frame",
        "--patch",
        "8",
        "--map-box",
        "0,1,0,1",
        "--out",
        fx.join("no_map.npy").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("userblock.h5: frame has no coordinate vectors beside it in /"),
        "{}",
        text(&o)
    );
    for (extra, words) in [
        (vec!["--dataset", "pairs"], "is a stack"),
        (vec![], "--dataset: give the scene's dataset"),
    ] {
        let mut args = vec!["cut", "--input"];
        let input = fx.join("stack.h5");
        let out = fx.join("refused.npy");
        args.push(input.to_str().unwrap());
        args.extend(["--patch", "8", "--out", out.to_str().unwrap()]);
        args.extend(extra.iter().copied());
        let o = bin(&args);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(words), "{}", text(&o));
        assert!(!out.exists());
    }
}
