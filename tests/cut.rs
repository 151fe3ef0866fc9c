//! `isar-clutter cut` (issue 49 item 2): a time stack of scenes cut into patches, every
//! patch the scene's pixels at its place (the oracle: numpy-style slicing of the same array),
//! boxes avoided, the places recorded, the stack fit for `fit`; bad input refused naming it.

mod common;
use common::{bin, text};

use ndarray::{Array2, Array3};
use num_complex::Complex32;
use std::fs;

/// A pixel's value: its scene, row and column readable from it.
fn pixel(t: usize, r: usize, c: usize) -> Complex32 {
    Complex32::new((t * 1000 + r * 30 + c) as f32, r as f32 - c as f32)
}

/// The places (top-left row, column) a cut recorded in its `OUT.patches.json`.
fn recorded_places(record: &std::path::Path) -> Vec<(usize, usize)> {
    let record: serde_json::Value = serde_json::from_slice(&fs::read(record).unwrap()).unwrap();
    serde_json::from_value(record["places"].clone()).unwrap()
}

#[test]
fn a_time_stack_is_cut_place_by_place_around_the_boxes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Array3::from_shape_fn((2, 20, 24), |(t, r, c)| pixel(t, r, c));
    let input = dir.path().join("scene.npy");
    ndarray_npy::write_npy(&input, &scene).unwrap();
    let out = dir.path().join("stack.npy");
    let args = [
        "cut",
        "--input",
        input.to_str().unwrap(),
        "--patch",
        "4x6",
        "--stride",
        "4x6",
        "--window",
        "0:20,0:24",
        "--avoid",
        "8:12,6:12",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = bin(&args);
    assert!(o.status.success(), "{}", text(&o));
    // 5 x 4 places, less the one the box covers: 19 places x 2 scenes.
    assert!(
        text(&o).contains("38 patch(es) of 4x6 (19 place(s) x 2 scene(s))"),
        "{}",
        text(&o)
    );
    let got: Array3<Complex32> = ndarray_npy::read_npy(&out).unwrap();
    assert_eq!(got.dim(), (38, 4, 6));
    let places = recorded_places(&dir.path().join("stack.npy.patches.json"));
    assert_eq!(places.len(), 19);
    assert!(!places.contains(&(8, 6)), "the box's place is left out");
    for (p, &(r, c)) in places.iter().enumerate() {
        for t in 0..2 {
            let want = scene.slice(ndarray::s![t, r..r + 4, c..c + 6]);
            assert_eq!(
                got.index_axis(ndarray::Axis(0), p * 2 + t),
                want,
                "place {p} scene {t}"
            );
        }
    }
    // The stack is a clutter stack: `fit` reads it.
    let model = dir.path().join("m");
    let o = bin(&[
        "fit",
        "--input",
        out.to_str().unwrap(),
        "--method",
        "method1",
        "--out",
        model.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // Cutting again into the same file replaces it (the tool wrote it), and the temporary a
    // killed cut left (its pid gone) is removed; a foreign file is kept.
    let dead = dir.path().join(".stack.npy.tmp-4194303");
    fs::write(&dead, b"half").unwrap();
    let o = bin(&args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("removed .stack.npy.tmp-4194303: a killed writer"),
        "{}",
        text(&o)
    );
    assert!(!dead.exists());
    let foreign = dir.path().join("mine.npy");
    fs::write(&foreign, b"mine").unwrap();
    let mut again = args.to_vec();
    let last = again.len() - 1;
    again[last] = foreign.to_str().unwrap();
    let o = bin(&again);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert_eq!(fs::read(&foreign).unwrap(), b"mine");
}

#[test]
fn a_real_scene_becomes_complex_and_bad_input_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Array2::from_shape_fn((9, 9), |(r, c)| (r * 9 + c) as f64);
    let input = dir.path().join("real.npy");
    ndarray_npy::write_npy(&input, &scene).unwrap();
    let out = dir.path().join("s.npy");
    let o = bin(&[
        "cut",
        "--input",
        input.to_str().unwrap(),
        "--patch",
        "3",
        "--stride",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let got: Array3<Complex32> = ndarray_npy::read_npy(&out).unwrap();
    assert_eq!(got.dim(), (16, 3, 3));
    assert_eq!(
        got[[5, 1, 2]],
        Complex32::new((3 * 9 + 4) as f32, 0.0),
        "place (2, 2)"
    );
    for (args, says) in [
        (
            vec!["--patch", "10"],
            "no 10x10 patch fits in the window 0:9,0:9 of the 9x9 scene",
        ),
        (
            vec!["--patch", "3", "--window", "0:10,0:9"],
            "--window 0:10,0:9 leaves the 9x9 scene",
        ),
        (vec!["--patch", "0"], "is not a size"),
        (
            vec!["--patch", "3", "--avoid", "4:2,0:1"],
            "a range's start must be below its end",
        ),
    ] {
        let mut all = vec![
            "cut",
            "--input",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        all.extend(args);
        let o = bin(&all);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(says), "{says}: {}", text(&o));
    }
    let flat = dir.path().join("flat.npy");
    ndarray_npy::write_npy(&flat, &ndarray::Array1::<f64>::zeros(5)).unwrap();
    let o = bin(&[
        "cut",
        "--input",
        flat.to_str().unwrap(),
        "--patch",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o).contains(
            "flat.npy: a scene is [H, W] or a time stack [T, H, W], this array has shape [5]"
        ),
        "{}",
        text(&o)
    );
}

#[test]
fn a_mask_of_targets_keeps_patches_off_them() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Array3::from_shape_fn((1, 8, 8), |(t, r, c)| pixel(t, r, c));
    let input = dir.path().join("scene.npy");
    ndarray_npy::write_npy(&input, &scene).unwrap();
    let out = dir.path().join("s.npy");
    let cut = |mask: &std::path::Path| {
        bin(&[
            "cut",
            "--input",
            input.to_str().unwrap(),
            "--patch",
            "4",
            "--avoid-mask",
            mask.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    // A target at (5, 2): the patch at (4, 0) covers it.
    let mut bools = Array2::from_elem((8, 8), false);
    bools[[5, 2]] = true;
    let mask = dir.path().join("mask.npy");
    ndarray_npy::write_npy(&mask, &bools).unwrap();
    let o = cut(&mask);
    assert!(o.status.success(), "{}", text(&o));
    let places = recorded_places(&dir.path().join("s.npy.patches.json"));
    assert_eq!(places, vec![(0, 0), (0, 4), (4, 4)]);
    // uint8 works the same; a mask of another shape or type is refused naming it.
    let bytes = bools.mapv(u8::from);
    ndarray_npy::write_npy(&mask, &bytes).unwrap();
    assert!(cut(&mask).status.success());
    ndarray_npy::write_npy(&mask, &Array2::<u8>::zeros((8, 9))).unwrap();
    let o = cut(&mask);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o).contains("mask.npy has shape [8, 9]; the scene's is [8, 8]"),
        "{}",
        text(&o)
    );
    ndarray_npy::write_npy(&mask, &Array2::<f64>::zeros((8, 8))).unwrap();
    let o = cut(&mask);
    assert!(
        text(&o).contains("holds <f8 (C order); a mask is bool or uint8"),
        "{}",
        text(&o)
    );
    ndarray_npy::write_npy(&mask, &Array2::<u8>::ones((8, 8))).unwrap();
    let o = cut(&mask);
    assert!(
        text(&o).contains("every patch covers a pixel of the mask"),
        "{}",
        text(&o)
    );
}

#[test]
fn a_polygon_keeps_exactly_the_patches_wholly_inside_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Array2::from_shape_fn((40, 40), |(r, c)| pixel(0, r, c));
    let input = dir.path().join("scene.npy");
    ndarray_npy::write_npy(&input, &scene).unwrap();
    let out = dir.path().join("stack.npy");
    // A diamond round (20, 20): |r - 20| + |c - 20| <= 18. Convex, so a patch lies inside
    // exactly when its four corners do.
    let diamond = "2,20;20,38;38,20;20,2";
    let o = bin(&[
        "cut",
        "--input",
        input.to_str().unwrap(),
        "--patch",
        "6",
        "--stride",
        "2",
        "--polygon",
        diamond,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let inside = |r: f64, c: f64| (r - 20.0).abs() + (c - 20.0).abs() <= 18.0;
    let want: Vec<(usize, usize)> = (0..=34)
        .step_by(2)
        .flat_map(|r| (0..=34).step_by(2).map(move |c| (r, c)))
        .filter(|&(r, c)| {
            let (r, c) = (r as f64, c as f64);
            inside(r, c) && inside(r + 6.0, c) && inside(r, c + 6.0) && inside(r + 6.0, c + 6.0)
        })
        .collect();
    let record = dir.path().join("stack.npy.patches.json");
    assert_eq!(recorded_places(&record), want);
    assert!(want.len() > 20, "{}", want.len());
    let o = bin(&[
        "cut",
        "--input",
        input.to_str().unwrap(),
        "--patch",
        "6",
        "--polygon",
        "1,1;2,2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("is not a polygon"), "{}", text(&o));
}

/// `cut`'s map options: a box that is not four finite numbers, and a box beside `--window`,
/// are refused by the argument parser (exit 2), naming the option.
#[test]
fn cut_map_options_are_checked_when_parsed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.npy");
    let out = out.to_str().unwrap();
    for (extra, words) in [
        (vec!["--map-box", "1,2,3"], "X0,X1,Y0,Y1"),
        (vec!["--map-box", "1,1,3,4"], "a box"),
        (vec!["--map-box", "1,nan,3,4"], "X0,X1,Y0,Y1"),
        (
            vec!["--map-box", "1,2,3,4", "--window", "0:8,0:8"],
            "cannot be used with",
        ),
    ] {
        let mut args = vec!["cut", "--input", "x.tif", "--patch", "8", "--out", out];
        args.extend(extra.iter().copied());
        let o = bin(&args);
        let said = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {said}");
        assert!(
            said.contains(words) && said.contains("--map-box"),
            "{extra:?}: {said}"
        );
    }
}

/// `--dataset` belongs to HDF5 inputs: given with an `.npy` it is refused, nothing written.
#[test]
fn cut_refuses_a_dataset_for_inputs_that_have_none() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("scene.npy");
    ndarray_npy::write_npy(&input, &Array2::<Complex32>::zeros((16, 16))).unwrap();
    let out = dir.path().join("o.npy");
    let o = bin(&[
        "cut",
        "--input",
        input.to_str().unwrap(),
        "--patch",
        "8",
        "--dataset",
        "/data/VV",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("--dataset names the scene's dataset in HDF5 inputs"),
        "{}",
        text(&o)
    );
    assert!(!out.exists());
}
