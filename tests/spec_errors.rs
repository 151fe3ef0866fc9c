//! Bad input is refused before anything runs: every error names the spec file and the YAML
//! path (and the line where the parser knows it), the binary exits non-zero and writes
//! nothing.

use isar_clutter::run::plan;
use ndarray::Array3;
use ndarray_npy::WriteNpyExt;
use num_complex::Complex;
use std::path::Path;
use std::process::Command;

const GOOD: &str = "name: t
seed: 1
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 10
analysis:
  levels: 2
";

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Loads `text` as a spec and returns the error message.
fn error_of(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "spec.yaml", text);
    let e = plan::load(&p).expect_err("the spec must be refused");
    e.to_string()
}

fn npy_stack(dir: &Path, name: &str, shape: (usize, usize, usize)) {
    let a = Array3::<Complex<f32>>::from_elem(shape, Complex::new(1.0, 0.0));
    a.write_npy(std::fs::File::create(dir.join(name)).unwrap())
        .unwrap();
}

#[test]
fn the_good_spec_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "spec.yaml", GOOD);
    assert_eq!(plan::load(&p).unwrap().jobs.len(), 1);
}

#[test]
fn unknown_key_names_path_and_line() {
    let e = error_of(&GOOD.replace("    samples: 10\n", "    samples: 10\n    smaples: 3\n"));
    assert!(e.contains("spec.yaml: datasets[0]"), "{e}");
    assert!(e.contains("unknown field `smaples`"), "{e}");
    assert!(e.contains("line 11"), "{e}");
}

#[test]
fn unknown_top_level_key() {
    let e = error_of(&format!("{GOOD}analysys:\n  levels: 2\n"));
    assert!(e.contains("unknown field `analysys`"), "{e}");
}

#[test]
fn wrong_type_names_the_field() {
    let e = error_of(&GOOD.replace("alpha_h: 1.0", "alpha_h: fast"));
    assert!(e.contains("datasets[0].alpha_h"), "{e}");
    assert!(e.contains("line 7"), "{e}");
    let e = error_of(&GOOD.replace("samples: 10", "samples: -3"));
    assert!(e.contains("datasets[0].samples"), "{e}");
    let e = error_of(&GOOD.replace(
        "alpha_h: 1.0",
        "alpha_h: {pattern: ramp, axis: diagonal, from: 1, to: 2}",
    ));
    assert!(e.contains("datasets[0].alpha_h.axis"), "{e}");
}

#[test]
fn field_of_another_kind_is_refused() {
    let e = error_of(&GOOD.replace("alpha_h: 1.0", "alpha_h: 1.0\n    layout: hwn"));
    assert!(
        e.contains("datasets[0].layout") && e.contains("does not apply"),
        "{e}"
    );
    let e = error_of(&GOOD.replace(
        "alpha_h: 1.0",
        "alpha_h: {pattern: left_right, left: 1, top: 2}",
    ));
    assert!(e.contains("datasets[0].alpha_h.top"), "{e}");
}

#[test]
fn missing_files_are_named() {
    let e = error_of("name: t\nseed: 1\ndatasets:\n  - id: m\n    kind: npy\n    path: nowhere.npy\nanalysis:\n  levels: 1\n");
    assert!(
        e.contains("datasets[0].path") && e.contains("nowhere.npy"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("alpha_h: 1.0", "alpha_h: {pattern: npy, path: alpha.npy}"));
    assert!(
        e.contains("datasets[0].alpha_h.path") && e.contains("alpha.npy"),
        "{e}"
    );
}

#[test]
fn levels_too_deep_for_the_image() {
    let e = error_of(&GOOD.replace("levels: 2", "levels: 5"));
    assert!(
        e.contains("analysis.levels") && e.contains("32x32") && e.contains("16x16"),
        "{e}"
    );
}

#[test]
fn fewer_than_two_samples() {
    let e = error_of(&GOOD.replace("samples: 10", "samples: 1"));
    assert!(
        e.contains("datasets[0].samples") && e.contains("at least 2"),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    npy_stack(dir.path(), "one.npy", (1, 8, 8));
    let p = write(dir.path(), "s.yaml", "name: t\nseed: 1\ndatasets:\n  - id: m\n    kind: npy\n    path: one.npy\nanalysis:\n  levels: 1\n");
    let e = plan::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("datasets[0].path") && e.contains("1 sample"),
        "{e}"
    );
    // [H, W, N] layout: the last axis is the sample axis.
    npy_stack(dir.path(), "hwn.npy", (8, 8, 1));
    let p = write(dir.path(), "s.yaml", "name: t\nseed: 1\ndatasets:\n  - id: m\n    kind: npy\n    path: hwn.npy\n    layout: hwn\nanalysis:\n  levels: 1\n");
    assert!(plan::load(&p).unwrap_err().to_string().contains("1 sample"));
}

#[test]
fn not_a_stack() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("junk.npy"), b"not numpy").unwrap();
    let p = write(dir.path(), "s.yaml", "name: t\nseed: 1\ndatasets:\n  - id: m\n    kind: npy\n    path: junk.npy\nanalysis:\n  levels: 1\n");
    let e = plan::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("junk.npy") && e.contains("not a valid .npy"),
        "{e}"
    );
}

#[test]
fn sweep_errors_name_the_axis() {
    let e = error_of(&format!(
        "{GOOD}sweep:\n  grid:\n    datasets.nope.alpha_h: [1, 2]\n"
    ));
    assert!(
        e.contains("sweep.grid.datasets.nope.alpha_h") && e.contains("no dataset"),
        "{e}"
    );
    let e = error_of(&format!(
        "{GOOD}sweep:\n  grid:\n    datasets.d.alpha_h: [1, 0]\n"
    ));
    assert!(
        e.contains("datasets[0].alpha_h") && e.contains("non-zero"),
        "{e}"
    );
    let e = error_of(&format!(
        "{GOOD}sweep:\n  zip:\n    datasets.d.alpha_h: [1, 2]\n    datasets.d.alpha_v: [1]\n"
    ));
    assert!(e.contains("equal lengths"), "{e}");
    let e = error_of(&format!(
        "{GOOD}sweep:\n  grid:\n    datasets.d.colour: [red]\n"
    ));
    assert!(e.contains("unknown field `colour`"), "{e}");
    let e = error_of(&format!(
        "{GOOD}sweep:\n  grid:\n    analysis.levels: [2, 9]\n"
    ));
    assert!(
        e.contains("analysis.levels") && e.contains("levels = 9"),
        "{e}"
    );
}

#[test]
fn duplicate_dataset_ids() {
    let dup = GOOD.replace(
        "analysis:",
        "  - id: d\n    kind: npy\n    path: x.npy\nanalysis:",
    );
    let e = error_of(&dup);
    assert!(
        e.contains("datasets[1].id") && e.contains("already used"),
        "{e}"
    );
}

#[test]
fn the_binary_exits_non_zero_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad.yaml",
        &GOOD.replace("levels: 2", "levels: 7"),
    );
    let out = dir.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
        .args(["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("bad.yaml: analysis.levels"), "{stderr}");
    assert!(!out.exists(), "nothing may be written for an invalid spec");
    let o = Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
        .args(["validate", p.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!o.status.success());
}

#[test]
fn star_axes_reach_only_datasets_that_take_the_field() {
    let dir = tempfile::tempdir().unwrap();
    npy_stack(dir.path(), "s.npy", (4, 8, 8));
    let text = GOOD.replace(
        "analysis:",
        "  - id: m\n    kind: npy\n    path: s.npy\nanalysis:",
    ) + "sweep:\n  grid:\n    datasets.*.samples: [4, 6]\n";
    let p = write(dir.path(), "spec.yaml", &text);
    let plan = plan::load(&p).unwrap();
    let ids: Vec<&str> = plan.jobs.iter().map(|j| j.id.as_str()).collect();
    assert_eq!(ids, ["d.samples=4", "d.samples=6", "m"]);
    let e = error_of(&format!(
        "{GOOD}sweep:\n  grid:\n    datasets.*.layout: [hwn]\n"
    ));
    assert!(e.contains("no dataset takes the field `layout`"), "{e}");
}

#[test]
fn messages_use_yaml_spellings() {
    let e = error_of(&GOOD.replace("alpha_h: 1.0", "alpha_h: 1.0\n    r_h: [0.1]"));
    assert!(e.contains("kind filtered_noise, family exponential"), "{e}");
    let e = error_of(&GOOD.replace("alpha_h: 1.0", "alpha_h: {pattern: left_right, left: 1}"));
    assert!(e.contains("pattern left_right needs `right`"), "{e}");
}

#[test]
fn synthesis_section_errors() {
    let e = error_of(&format!(
        "{GOOD}synthesis:\n  methods: [method3]\n  samples: 10\n"
    ));
    assert!(
        e.contains("synthesis.methods[0]") && e.contains("method3"),
        "{e}"
    );
    let e = error_of(&format!(
        "{GOOD}synthesis:\n  methods: [method1]\n  samples: 1\n"
    ));
    assert!(
        e.contains("synthesis.samples") && e.contains("at least 2"),
        "{e}"
    );
    let e = error_of(&format!(
        "{GOOD}synthesis:\n  methods: [method2]\n  samples: 10\n  half_width: 2\n"
    ));
    assert!(
        e.contains("synthesis.half_width") && e.contains("truncate"),
        "{e}"
    );
    let e = error_of(&format!(
        "{GOOD}synthesis:\n  methods: [method1, method1]\n  samples: 10\n"
    ));
    assert!(
        e.contains("synthesis.methods[1]") && e.contains("twice"),
        "{e}"
    );
    let e = error_of(&format!(
        "{GOOD}sweep:\n  grid:\n    synthesis.samples: [5]\n"
    ));
    assert!(e.contains("with a synthesis section"), "{e}");
}

#[test]
fn metrics_errors_name_the_entry() {
    let syn = format!("{GOOD}synthesis:\n  methods: [method1]\n  samples: 20\n");
    let e = error_of(&format!("{GOOD}metrics: [cmd]\n"));
    assert!(
        e.contains("spec.yaml: metrics") && e.contains("add a `synthesis` section"),
        "{e}"
    );
    let e = error_of(&format!("{syn}metrics: [cmd, kl_pixle]\n"));
    assert!(
        e.contains("metrics[1].kl_pixle") && e.contains("unknown metric \"kl_pixle\""),
        "{e}"
    );
    let e = error_of(&format!("{syn}metrics: [{{kl_pixel: {{bins: 0}}}}]\n"));
    assert!(
        e.contains("metrics[0].kl_pixel.bins") && e.contains("at least 1"),
        "{e}"
    );
    let e = error_of(&format!("{syn}metrics: [{{kl_pixel: {{block: 4}}}}]\n"));
    assert!(
        e.contains("metrics[0].kl_pixel.block") && e.contains("only kl_area"),
        "{e}"
    );
    let e = error_of(&format!("{syn}metrics: [{{kl_area: {{bnis: 4}}}}]\n"));
    assert!(
        e.contains("metrics[0].kl_area") && e.contains("unknown field `bnis`"),
        "{e}"
    );
    let e = error_of(&format!("{syn}metrics: [{{cmd: {{bins: 4}}}}]\n"));
    assert!(
        e.contains("metrics[0].cmd") && e.contains("takes no parameters"),
        "{e}"
    );
    let e = error_of(&format!("{syn}metrics: [{{kl_area: {{block: 32}}}}]\n"));
    assert!(
        e.contains("metrics[0].kl_area.block") && e.contains("16x16"),
        "{e}"
    );
    let e = error_of(&format!("{syn}metrics: [cmd, cmd]\n"));
    assert!(
        e.contains("metrics[1].cmd") && e.contains("listed twice"),
        "{e}"
    );
    let e = error_of(&format!(
        "{syn}metrics: [{{kl_pixel: {{smoothing: -1}}}}]\n"
    ));
    assert!(e.contains("metrics[0].kl_pixel.smoothing"), "{e}");
    let e = error_of(&format!(
        "{syn}metrics: [{{kl_area: {{bias_correction: jackknife}}}}]\n"
    ));
    assert!(
        e.contains("metrics[0].kl_area") && e.contains("resplit"),
        "{e}"
    );
}

#[test]
fn noise_floor_errors() {
    let dir = tempfile::tempdir().unwrap();
    npy_stack(dir.path(), "s.npy", (3, 8, 8));
    let text = "name: t\nseed: 1\ndatasets:\n  - id: m\n    kind: npy\n    path: s.npy\nanalysis:\n  levels: 1\nsynthesis:\n  methods: [uncorrelated]\n  samples: 4\nmetrics: [cmd]\n";
    let load = |t: &str| {
        plan::load(&write(dir.path(), "spec.yaml", t))
            .unwrap_err()
            .to_string()
    };
    let e = load(text);
    assert!(
        e.contains("spec.yaml: noise_floor") && e.contains("at least 4 samples"),
        "{e}"
    );
    let e = load(&format!("{text}noise_floor: draws\n"));
    assert!(
        e.contains("`draws` needs a synthetic or simulated dataset"),
        "{e}"
    );
    let e = load(&format!("{text}noise_floor: twice\n"));
    assert!(
        e.contains("noise_floor") && e.contains("unknown variant `twice`"),
        "{e}"
    );
    // `none` switches it off, so 3 samples are enough.
    let ok = plan::load(&write(
        dir.path(),
        "spec.yaml",
        &format!("{text}noise_floor: none\n"),
    ))
    .unwrap();
    assert!(ok.jobs.iter().all(|j| j.noise_floor.is_none()));
}

#[test]
fn texture_shape_must_be_positive() {
    let e = error_of(&GOOD.replace(
        "    samples: 10\n",
        "    samples: 10\n    texture_shape: 0\n",
    ));
    assert!(
        e.contains("datasets[0].texture_shape") && e.contains("> 0"),
        "{e}"
    );
}

#[test]
fn vegetation_errors_name_the_field() {
    let veg = |extra: &str| {
        format!("name: t\nseed: 1\ndatasets:\n  - id: p\n    kind: vegetation_isar\n    samples: 4\n{extra}analysis:\n  levels: 1\n")
    };
    let e = error_of(&veg(""));
    assert!(
        e.contains("datasets[0].plant") && e.contains("needs `plant`"),
        "{e}"
    );
    let e = error_of(&veg("    plant: F\n"));
    assert!(
        e.contains("datasets[0].plant") && e.contains("unknown plant \"F\""),
        "{e}"
    );
    let e = error_of(&veg("    plant: A\n    wind: gale\n"));
    assert!(
        e.contains("datasets[0].wind") && e.contains("unknown wind \"gale\""),
        "{e}"
    );
    let e = error_of(&veg("    plant: A\n    scene: {plant: {leaf_sise: 1}}\n"));
    assert!(
        e.contains("datasets[0].scene.plant") && e.contains("unknown field `leaf_sise`"),
        "{e}"
    );
    let e = error_of(&veg("    plant: A\n    scene: {noise_db: x}\n"));
    assert!(e.contains("datasets[0].scene.noise_db"), "{e}");
    let e = error_of(&veg("    plant: A\n    measurement: {frequencies: 2}\n"));
    assert!(
        e.contains("datasets[0].measurement") && e.contains("n_f"),
        "{e}"
    );
    let e = error_of(&veg("    plant: A\n    path: x.npy\n"));
    assert!(
        e.contains("datasets[0].path") && e.contains("does not apply"),
        "{e}"
    );
}
