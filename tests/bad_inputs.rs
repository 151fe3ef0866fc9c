//! Hostile inputs are refused with a message naming the file or YAML path, never a panic:
//! `.npy` headers whose size overflows, inconsistent model folders, non-finite spec numbers
//! and a spec or `model.json` that starts with a UTF-8 byte-order mark. Each test is named
//! after the defect it pins (issue 13, item 4).

mod common;
use common::bin;

use isar_clutter::io::model;
use isar_clutter::stats::analysis::analyse;
use isar_clutter::synthesis::{fit, FitOptions, Method};
use ndarray::{Array2, Array3};
use ndarray_npy::WriteNpyExt;
use std::path::{Path, PathBuf};
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// An `.npy` (version 1.0) with `dict` as its header and `data` after it.
fn raw_npy(path: &Path, dict: &str, data: &[u8]) {
    let unpadded = 10 + dict.len() + 1;
    let total = unpadded.div_ceil(64) * 64;
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend(((total - 10) as u16).to_le_bytes());
    out.extend(dict.as_bytes());
    out.extend(std::iter::repeat_n(b' ', total - unpadded));
    out.push(b'\n');
    out.extend(data);
    std::fs::write(path, out).unwrap();
}

fn write_npy<A: ndarray_npy::WritableElement, D: ndarray::Dimension>(
    path: &Path,
    a: &ndarray::Array<A, D>,
) {
    a.write_npy(std::fs::File::create(path).unwrap()).unwrap();
}

// ---- 1. `.npy` shapes whose size overflows ----

const OVERFLOW_DICT: &str =
    "{'descr': '<c8', 'fortran_order': False, 'shape': (4611686018427387904, 4, 2), }";

#[test]
fn npy_shape_overflow_is_refused_by_fit_naming_file_and_shape() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("huge.npy");
    raw_npy(&input, OVERFLOW_DICT, &[0u8; 64]);
    let out = dir.path().join("m");
    let o = bin(&[
        "fit",
        "--input",
        input.to_str().unwrap(),
        "--method",
        "uncorrelated",
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("huge.npy"), "{e}");
    assert!(e.contains("[4611686018427387904, 4, 2]"), "{e}");
    assert!(e.contains("overflows"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
}

#[test]
fn npy_shape_overflow_is_refused_by_validate_naming_the_yaml_path() {
    let dir = tempfile::tempdir().unwrap();
    raw_npy(&dir.path().join("huge.npy"), OVERFLOW_DICT, &[]);
    let spec = dir.path().join("spec.yaml");
    std::fs::write(
        &spec,
        "name: t\nseed: 1\ndatasets:\n  - id: d\n    kind: npy\n    path: huge.npy\nanalysis:\n  levels: 1\n",
    )
    .unwrap();
    let o = bin(&["validate", spec.to_str().unwrap()]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("datasets[0].path"), "{e}");
    assert!(e.contains("huge.npy"), "{e}");
    assert!(e.contains("overflows"), "{e}");
}

#[test]
fn npy_shape_larger_than_the_file_is_refused_as_truncated() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("short.npy");
    raw_npy(
        &input,
        "{'descr': '<f8', 'fortran_order': False, 'shape': (1099511627776, 4, 4), }",
        &[0u8; 128],
    );
    let o = bin(&[
        "fit",
        "--input",
        input.to_str().unwrap(),
        "--method",
        "uncorrelated",
        "--out",
        dir.path().join("m").to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("short.npy") && e.contains("truncated"), "{e}");
}

/// Found by `tests/fuzz.rs`: an empty stack whose other axis is huge passed the size check
/// (product 0) and then panicked in ndarray, which bounds the non-zero axes too.
#[test]
fn npy_empty_shape_with_a_huge_axis_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("empty.npy");
    raw_npy(
        &input,
        "{'descr': '<c8', 'fortran_order': False, 'shape': (0, 18446744073709551615, 0), }",
        &[],
    );
    let o = bin(&[
        "fit",
        "--input",
        input.to_str().unwrap(),
        "--method",
        "uncorrelated",
        "--out",
        dir.path().join("m").to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("empty.npy") && e.contains("overflows"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
}

#[test]
fn npy_header_length_beyond_the_file_is_refused_without_allocating_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("liar.npy");
    let mut bytes = b"\x93NUMPY\x02\x00".to_vec();
    bytes.extend(u32::MAX.to_le_bytes());
    bytes.extend(b"{'descr': '<f8'");
    std::fs::write(&p, bytes).unwrap();
    let e = isar_clutter::io::npy::read_header(&p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("liar.npy") && e.contains("truncated header"),
        "{e}"
    );
}

// ---- 2. model folders validated as a whole ----

/// A model of `method` fitted to a 16x16 stack and saved into `dir/name`.
fn saved_model(dir: &Path, name: &str, method: Method) -> PathBuf {
    let stack = common::random_stack(7, 12, 16, 16);
    let levels = if method == Method::Method2 { 2 } else { 1 };
    let analysis = analyse(stack.view(), levels).unwrap();
    let opts = FitOptions {
        half_width: 4,
        levels,
        ..FitOptions::default()
    };
    let m = fit(method, &analysis, Some(stack.view()), opts).unwrap();
    let info = model::ModelInfo::new(&m, &analysis, 4, levels, "test".into());
    let out = dir.join(name);
    model::save(&m, &info, &out).unwrap();
    out
}

fn load_error(dir: &Path) -> String {
    format!(
        "{:#}",
        model::load(dir).expect_err("the model must be refused")
    )
}

#[test]
fn every_saved_model_loads_back() {
    let dir = tempfile::tempdir().unwrap();
    for &method in Method::ALL {
        let m = saved_model(dir.path(), method.as_str(), method);
        let (loaded, info) = model::load(&m).unwrap();
        assert_eq!((loaded.method(), info.height, info.width), (method, 16, 16));
        // `fit --out` replaces a folder holding only these names: the lists know every file,
        // and the method's own list names exactly the files beside the shared ones.
        let mut own = vec![];
        for e in std::fs::read_dir(&m).unwrap().flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            assert!(model::is_model_file(&name), "{name} is not a model file");
            if !model::SHARED_FILES.contains(&name.as_str()) {
                own.push(name);
            }
        }
        own.sort();
        let mut listed: Vec<&str> = method.files().to_vec();
        listed.sort();
        assert_eq!(own, listed, "{method:?}");
    }
}

#[test]
fn model_alpha_map_of_the_wrong_cell_grid_is_refused_by_generate() {
    let dir = tempfile::tempdir().unwrap();
    let m = saved_model(dir.path(), "x", Method::Method1);
    write_npy(&m.join("alpha_h.npy"), &Array2::<f64>::ones((3, 4)));
    let out = dir.path().join("gen.npy");
    let o = bin(&[
        "generate",
        "--model",
        m.to_str().unwrap(),
        "--samples",
        "2",
        "--seed",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("alpha_h.npy: shape [3, 4], expected [8, 8] (cell grid of model.json"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
fn model_r_levels_that_disagree_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = saved_model(dir.path(), "x", Method::Method2);
    // One r level fewer than model.json's `levels: 2`.
    write_npy(&m.join("r_v.npy"), &Array3::<f64>::zeros((1, 8, 8)));
    let e = load_error(&m);
    assert!(
        e.contains("r_v.npy: shape [1, 8, 8], expected [2, 8, 8]"),
        "{e}"
    );
    // r_h and r_v agreeing with each other but not with `levels`.
    write_npy(&m.join("r_h.npy"), &Array3::<f64>::zeros((1, 8, 8)));
    let e = load_error(&m);
    assert!(
        e.contains("r_h.npy: shape [1, 8, 8], expected [2, 8, 8]"),
        "{e}"
    );
}

#[test]
fn model_levels_beyond_the_half_width_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = saved_model(dir.path(), "x", Method::Method2);
    let json = m.join("model.json");
    let text = std::fs::read_to_string(&json).unwrap();
    std::fs::write(&json, text.replace("\"levels\": 2", "\"levels\": 3")).unwrap();
    let e = load_error(&m);
    assert!(
        e.contains("model.json") && e.contains("half_width 4 truncates"),
        "{e}"
    );
}

#[test]
fn model_nan_and_inf_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = saved_model(dir.path(), "x", Method::Uncorrelated);
    let mut std = Array2::<f64>::ones((16, 16));
    std[[2, 3]] = f64::INFINITY;
    write_npy(&m.join("std.npy"), &std);
    let e = load_error(&m);
    assert!(e.contains("std.npy: value inf at [2, 3]"), "{e}");

    let m = saved_model(dir.path(), "y", Method::Method1);
    let mut alpha = Array2::<f64>::ones((8, 8));
    alpha[[0, 1]] = f64::NAN;
    write_npy(&m.join("alpha_v.npy"), &alpha);
    let e = load_error(&m);
    assert!(e.contains("alpha_v.npy: value NaN at [0, 1]"), "{e}");

    let m = saved_model(dir.path(), "z", Method::FourthOrder);
    let mut c = ndarray::Array4::<f64>::zeros((2, 4, 16, 16));
    c[[1, 2, 3, 4]] = f64::NAN;
    write_npy(&m.join("fleishman.npy"), &c);
    let e = load_error(&m);
    assert!(
        e.contains("fleishman.npy: value NaN at [1, 2, 3, 4]"),
        "{e}"
    );
}

#[test]
fn model_mis_shaped_arrays_are_refused_not_panicking() {
    let dir = tempfile::tempdir().unwrap();
    let m = saved_model(dir.path(), "x", Method::FullCovariance);
    write_npy(
        &m.join("deviations.npy"),
        &Array3::<f64>::zeros((12, 16, 16)),
    );
    let e = load_error(&m);
    // Right shape, wrong element type (float64 where complex128 belongs): too short a file.
    assert!(e.contains("deviations.npy"), "{e}");
    write_npy(
        &m.join("deviations.npy"),
        &Array3::<num_complex::Complex64>::zeros((11, 16, 16)),
    );
    let e = load_error(&m);
    assert!(
        e.contains("deviations.npy: shape [11, 16, 16], expected [12, 16, 16]"),
        "{e}"
    );
    let m = saved_model(dir.path(), "y", Method::Method1);
    write_npy(&m.join("clamped.npy"), &Array2::<u8>::from_elem((8, 8), 7));
    let e = load_error(&m);
    assert!(e.contains("clamped.npy: value 7 at [0, 0]"), "{e}");
}

#[test]
fn model_json_with_a_zero_sized_or_huge_image_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = saved_model(dir.path(), "x", Method::Method1);
    let json = m.join("model.json");
    let text = std::fs::read_to_string(&json).unwrap();
    std::fs::write(&json, text.replace("\"height\": 16", "\"height\": 0")).unwrap();
    let e = load_error(&m);
    assert!(e.contains("model.json") && e.contains("height 0"), "{e}");
    std::fs::write(
        &json,
        text.replace("\"half_width\": 4", "\"half_width\": 4611686018427387904"),
    )
    .unwrap();
    let e = load_error(&m);
    assert!(e.contains("model.json") && e.contains("filter bank"), "{e}");
    std::fs::write(
        &json,
        text.replace("\"height\": 16", "\"height\": 4611686018427387904"),
    )
    .unwrap();
    let e = load_error(&m);
    assert!(e.contains("model.json") || e.contains("mean.npy"), "{e}");
}

#[test]
fn model_json_with_a_byte_order_mark_loads() {
    let dir = tempfile::tempdir().unwrap();
    let m = saved_model(dir.path(), "x", Method::Uncorrelated);
    let json = m.join("model.json");
    let text = std::fs::read_to_string(&json).unwrap();
    std::fs::write(&json, format!("\u{feff}{text}")).unwrap();
    assert!(model::load(&m).is_ok());
}

// ---- 3. non-finite numbers in a spec ----

const SPEC: &str = "name: t
seed: 1
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 4
analysis:
  levels: 1
";

/// `validate` on `text`: exit code and stderr.
fn validate(text: &str) -> (Option<i32>, String) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("spec.yaml");
    std::fs::write(&p, text).unwrap();
    let o = bin(&["validate", p.to_str().unwrap()]);
    (o.status.code(), stderr(&o))
}

#[test]
fn spec_mean_nan_is_refused_naming_the_yaml_path() {
    for (field, value) in [
        ("mean", ".nan"),
        ("mean", ".inf"),
        ("mean_im", "-.inf"),
        ("mean_im", ".NaN"),
        ("std", ".nan"),
        ("texture_shape", ".inf"),
    ] {
        let text = SPEC.replace(
            "    samples: 4\n",
            &format!("    samples: 4\n    {field}: {value}\n"),
        );
        let (code, e) = validate(&text);
        assert_eq!(code, Some(2), "{field}: {value}: {e}");
        assert!(
            e.contains(&format!("spec.yaml: datasets[0].{field}")),
            "{e}"
        );
        assert!(e.contains("finite"), "{e}");
    }
}

#[test]
fn spec_non_finite_numbers_in_patterns_and_sweeps_are_refused() {
    let text = SPEC.replace(
        "    samples: 4\n",
        "    samples: 4\n    mean: {pattern: left_right, left: 0, right: .nan}\n",
    );
    let (code, e) = validate(&text);
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("datasets[0].mean.right"), "{e}");

    let text = format!("{SPEC}sweep:\n  grid:\n    datasets.d.mean: [0.0, .nan]\n");
    let (code, e) = validate(&text);
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("sweep.grid.datasets.d.mean[1]"), "{e}");
}

#[test]
fn spec_mean_map_file_with_nan_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = Array2::<f64>::zeros((16, 16));
    m[[4, 4]] = f64::NAN;
    write_npy(&dir.path().join("mean.npy"), &m);
    let p = dir.path().join("spec.yaml");
    let text = SPEC.replace(
        "    samples: 4\n",
        "    samples: 4\n    mean: {pattern: npy, path: mean.npy}\n",
    );
    std::fs::write(&p, text).unwrap();
    let e = isar_clutter::run::plan::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("datasets[0].mean") && e.contains("finite"),
        "{e}"
    );
}

#[test]
fn spec_alpha_inf_stays_allowed_and_alpha_nan_refused() {
    let (code, e) = validate(&SPEC.replace("alpha_h: 1.0", "alpha_h: .inf"));
    assert_eq!(code, Some(0), "{e}");
    let (code, e) = validate(&format!(
        "{SPEC}sweep:\n  grid:\n    datasets.d.alpha_v: [1.0, -.inf]\n"
    ));
    assert_eq!(code, Some(0), "{e}");
    let (code, e) = validate(&SPEC.replace("alpha_h: 1.0", "alpha_h: .nan"));
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("datasets[0].alpha_h"), "{e}");
}

// ---- 4. a byte-order mark before the spec ----

#[test]
fn spec_with_a_utf8_byte_order_mark_is_accepted() {
    let (code, e) = validate(&format!("\u{feff}{SPEC}"));
    assert_eq!(code, Some(0), "{e}");
    // The document's first key is read as itself, not as "\u{feff}name".
    let (code, e) = validate(&format!(
        "\u{feff}{}",
        SPEC.replace("seed: 1\n", "seed: x\n")
    ));
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("spec.yaml: seed"), "{e}");
}
