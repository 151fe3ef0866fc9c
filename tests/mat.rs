//! MATLAB `.mat` input and output against files written by the tools MATLAB users meet
//! (`tests/mat/make_fixtures.py`, run at test time in the project's virtualenv `.venv`: SciPy
//! for MAT v5, h5py in MATLAB's v7.3 conventions):
//!
//! - every dtype, compressed or not, big-endian, and (with the `mat73` feature) v7.3 contiguous
//!   and chunked, read value for value equal to the same data saved as `.npy`;
//! - the variable chosen by name or as the only numeric 3-D array; missing variables (listing
//!   the file's), structs, cells, char, sparse, logical, empty and 2-D arrays, truncated and
//!   corrupted files, HDF5 files that are not MAT files: clear errors naming the file and the
//!   variable, never a panic; a build without `mat73` names the feature for a v7.3 file;
//! - a `mat` dataset in a spec analyses to the same tables as the `.npy` with `layout: hwn`,
//!   and its bad inputs are spec errors at the YAML path; `fit --input X.mat` gives the model
//!   `fit --input X.npy --layout hwn` gives;
//! - `generate --out X.mat` (v7.3, `--mat-version 5`, `--mat-class double`) read back by SciPy
//!   and h5py (`tests/mat/check_generated.py`) with the right shape, dtype and values, and by
//!   the tool itself; bad `.mat` outputs refused before anything is written.
//!
//! Without SciPy and h5py in the virtualenv the tests skip with a message, unless `CI=true`,
//! where they fail.

mod common;
use common::bin;

use isar_clutter::io::mat::{MatError, MatFile};
use isar_clutter::io::npy::Stack;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The fixture folder, generated once per test process; `None` (skip) without SciPy/h5py.
fn fixtures() -> Option<&'static Path> {
    static DIR: OnceLock<Option<tempfile::TempDir>> = OnceLock::new();
    DIR.get_or_init(|| {
        let python = common::venv_python(&["scipy", "h5py"])?;
        let dir = tempfile::tempdir().unwrap();
        let out = Command::new(&python)
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mat/make_fixtures.py"))
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "make_fixtures.py failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        Some(dir)
    })
    .as_ref()
    .map(|d| d.path())
}

macro_rules! fixtures {
    () => {
        match fixtures() {
            Some(d) => d,
            None => return,
        }
    };
}

/// The error reading `var` of `path`, as text (the test fails if it reads).
fn err(path: &Path, var: Option<&str>) -> String {
    match MatFile::open(path).and_then(|m| m.read_stack(var)) {
        Ok(_) => panic!("{} {var:?} was read", path.display()),
        Err(e) => e.to_string(),
    }
}

/// Runs the binary with `args`, asserting success; its stderr.
fn ok(args: &[&str]) -> String {
    let a: Vec<&std::ffi::OsStr> = args.iter().map(|s| s.as_ref()).collect();
    let o = bin(&a);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {stderr}");
    stderr
}

/// Runs the binary with `args`, asserting exit code 2; its stderr.
fn fails(args: &[&str]) -> String {
    let a: Vec<&std::ffi::OsStr> = args.iter().map(|s| s.as_ref()).collect();
    let o = bin(&a);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?} should fail: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The fixture stacks: (tag, suffixes of the `.mat` files holding it as `x`).
fn stacks() -> Vec<(&'static str, Vec<&'static str>)> {
    let mut v = vec![
        ("c64", vec!["", "_z", "_be"]),
        ("c128", vec!["", "_z"]),
        ("f32", vec!["", "_z"]),
        ("f64", vec!["", "_z", "_be"]),
        ("i16", vec!["", "_z"]),
    ];
    if cfg!(feature = "mat73") {
        for (tag, suffixes) in &mut v {
            if *tag != "f64" {
                suffixes.extend(["_v73", "_v73z"]);
            }
        }
    }
    v
}

#[test]
fn every_dtype_compressed_or_not_big_endian_and_v73_equals_the_npy() {
    let dir = fixtures!();
    let mut checked = 0;
    for (tag, suffixes) in stacks() {
        let npy = Stack::load(&dir.join(format!("{tag}.npy"))).unwrap();
        let (plain, nhw) = (npy.to_complex128(false), npy.to_complex128(true));
        assert_eq!(plain.dim(), (4, 5, 3));
        for suffix in suffixes {
            let p: PathBuf = dir.join(format!("{tag}{suffix}.mat"));
            let named = MatFile::open(&p).unwrap().read_stack(Some("x")).unwrap();
            assert_eq!(named.dim(), (4, 5, 3), "{}", p.display());
            assert_eq!(named, plain, "{}", p.display());
            // The only 3-D array is found without a name, and as the dataset's Stack.
            let only = isar_clutter::io::mat::load_stack(&p, None).unwrap();
            assert_eq!(only.to_complex128(false), plain);
            // H x W x N read as [N, H, W] matches the .npy read the same way.
            assert_eq!(only.to_complex128(true), nhw);
            checked += 1;
        }
    }
    assert_eq!(checked, if cfg!(feature = "mat73") { 20 } else { 12 });
}

#[test]
fn variables_are_listed_with_class_and_size() {
    let dir = fixtures!();
    let m = MatFile::open(&dir.join("mixed.mat")).unwrap();
    let v: Vec<String> = m
        .variables()
        .iter()
        .map(|v| format!("{} {}", v.name, v.describe()))
        .collect();
    assert_eq!(
        v,
        [
            "stack 4x5x3 single complex",
            "st 1x1 struct",
            "ce 1x2 cell",
            "ch 1x12 char",
            "sp 4x4 sparse",
            "m2 4x5 double"
        ]
    );
    // The only 3-D stack in a file of other things is found without a name.
    assert_eq!(m.read_stack(None).unwrap().dim(), (4, 5, 3));
}

#[test]
fn the_variable_must_be_named_when_there_are_several() {
    let dir = fixtures!();
    let p = dir.join("two.mat");
    let e = err(&p, None);
    assert!(e.contains("2 numeric 3-D arrays") && e.contains("first (4x5x3 single complex)"));
    assert!(e.contains("scale (1x1 double)"), "{e}");
    let m = MatFile::open(&p).unwrap();
    assert_eq!(m.read_stack(Some("second")).unwrap()[[1, 2, 0]].re, 12.25);
    assert_eq!(m.read_stack(Some("first")).unwrap()[[1, 2, 2]].im, -2012.5);
}

#[test]
fn a_missing_variable_lists_the_file() {
    let dir = fixtures!();
    let p = dir.join("two.mat");
    let e = err(&p, Some("data"));
    assert!(e.contains(&p.display().to_string()), "{e}");
    assert!(
        e.contains("no variable \"data\"") && e.contains("first") && e.contains("second"),
        "{e}"
    );
    let e = err(&dir.join("flat.mat"), None);
    assert!(
        e.contains("0 numeric 3-D arrays") && e.contains("m2 (4x5 double)"),
        "{e}"
    );
}

#[test]
fn what_is_not_a_stack_is_refused_by_name() {
    let dir = fixtures!();
    let p = dir.join("mixed.mat");
    for (var, what) in [
        ("st", "a struct"),
        ("ce", "a cell array"),
        ("ch", "a char array"),
        ("sp", "a sparse matrix"),
        ("m2", "2-D (4x5 double)"),
    ] {
        let e = err(&p, Some(var));
        assert!(
            e.contains(&p.display().to_string())
                && e.contains(&format!("variable {var:?} is {what}")),
            "{e}"
        );
    }
}

/// Truncations at `cuts` and byte flips every `step` bytes from `from`: errors naming the file
/// (truncations), never panics.
fn malformed(bytes: &[u8], name: &str, cuts: &[usize], from: usize, step: usize) {
    let tmp = tempfile::tempdir().unwrap();
    for &cut in cuts {
        let p = tmp.path().join(format!("cut{cut}_{name}"));
        std::fs::write(&p, &bytes[..cut]).unwrap();
        let r = MatFile::open(&p).and_then(|m| m.read_stack(None));
        if cut < 128 {
            assert!(matches!(r, Err(MatError::Format { .. })), "{cut}: {r:?}");
        } else if cut > 128 {
            let e = r.expect_err("a truncated file is an error").to_string();
            assert!(e.contains(&p.display().to_string()), "{e}");
        }
    }
    // Flipped bytes anywhere: an error or a stack, never a panic.
    for at in (from..bytes.len()).step_by(step) {
        let mut b = bytes.to_vec();
        b[at] ^= 0x5a;
        let p = tmp.path().join(format!("flip_{name}"));
        std::fs::write(&p, &b).unwrap();
        let _ = MatFile::open(&p).and_then(|m| m.read_stack(None));
    }
}

#[test]
fn malformed_files_are_errors_not_panics() {
    let dir = fixtures!();
    for name in ["c128.mat", "c128_z.mat", "mixed.mat"] {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        let n = bytes.len();
        malformed(
            &bytes,
            name,
            &[0, 10, 127, 128, 135, 200, n - 9, n - 1],
            128,
            7,
        );
    }
    for name in ["plain.h5", "plain_ub.mat"] {
        let e = err(&dir.join(name), None);
        assert!(e.contains("HDF5 file without a MATLAB header"), "{e}");
    }
}

#[cfg(not(feature = "mat73"))]
#[test]
fn without_the_feature_a_v73_file_names_it() {
    let dir = fixtures!();
    let p = dir.join("c64_v73.mat");
    let e = err(&p, None);
    assert!(
        e.contains(&p.display().to_string()) && e.contains("v7.3") && e.contains("mat73"),
        "{e}"
    );
}

#[cfg(feature = "mat73")]
#[test]
fn v73_variables_are_listed_and_refused_by_what_they_are() {
    let dir = fixtures!();
    let p = dir.join("mixed_v73.mat");
    let m = MatFile::open(&p).unwrap();
    assert_eq!(m.version(), isar_clutter::io::mat::MatVersion::V73);
    let v: Vec<String> = m
        .variables()
        .iter()
        .map(|v| format!("{} {}", v.name, v.describe()))
        .collect();
    assert_eq!(
        v,
        [
            "ce 1x2 cell",
            "ch 1x12 char",
            "em 0x3 double",
            "lg 2x3x4 logical",
            "m2 4x5 double",
            "sp 4x4 sparse",
            "st struct",
            "stack 4x5x3 single complex"
        ]
    );
    let stack = m.read_stack(None).unwrap();
    let npy = Stack::load(&dir.join("c64.npy"))
        .unwrap()
        .to_complex128(false);
    assert_eq!(stack, npy);
    for (var, what) in [
        ("st", "a struct"),
        ("ce", "a cell array"),
        ("ch", "a char array"),
        ("sp", "a sparse matrix"),
        ("m2", "2-D (4x5 double)"),
        ("lg", "a logical array"),
        ("em", "2-D (0x3 double)"),
    ] {
        let e = err(&p, Some(var));
        assert!(
            e.contains(&p.display().to_string())
                && e.contains(&format!("variable {var:?} is {what}")),
            "{e}"
        );
    }
    let e = err(&p, Some("data"));
    assert!(
        e.contains("no variable \"data\"") && e.contains("stack (4x5x3 single complex)"),
        "{e}"
    );
    let e = err(&dir.join("two_v73.mat"), None);
    assert!(
        e.contains("2 numeric 3-D arrays") && e.contains("second (4x5x3 double)"),
        "{e}"
    );
}

#[cfg(feature = "mat73")]
#[test]
fn malformed_v73_files_are_errors_not_panics() {
    let dir = fixtures!();
    for name in ["c64_v73.mat", "c64_v73z.mat"] {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        let n = bytes.len();
        let cuts = [0, 127, 200, 511, 512, 600, 1500, n / 2, n - 100, n - 1];
        malformed(&bytes, name, &cuts, 512, 13);
    }
}

/// A spec analysing `datasets` (YAML list items) at one level.
fn spec(dir: &Path, name: &str, datasets: &str) -> PathBuf {
    let p = dir.join(format!("{name}.yaml"));
    std::fs::write(
        &p,
        format!("name: {name}\nseed: 1\ndatasets:\n{datasets}analysis:\n  levels: 2\n"),
    )
    .unwrap();
    p
}

#[test]
fn a_mat_dataset_analyses_like_its_npy() {
    let dir = fixtures!();
    let tmp = tempfile::tempdir().unwrap();
    let mut datasets = format!(
        "  - {{id: npy, kind: npy, path: {}, layout: hwn}}\n  - {{id: v5, kind: mat, path: {}, variable: clutter}}\n",
        s(&dir.join("measured_hwn.npy")),
        s(&dir.join("measured.mat")),
    );
    if cfg!(feature = "mat73") {
        datasets += &format!(
            "  - {{id: v73, kind: mat, path: {}}}\n",
            s(&dir.join("measured_v73.mat"))
        );
    }
    let spec = spec(tmp.path(), "mat_vs_npy", &datasets);
    ok(&["validate", s(&spec)]);
    let o = Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
        .args(["run", s(&spec), "--dry-run"])
        .output()
        .unwrap();
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(
        table.contains(" mat ") && table.contains("40x16x16"),
        "{table}"
    );
    let results = tmp.path().join("out");
    common::run_spec(&spec, &results, &["--no-report"]);
    let summary = common::read_table(&results, "analysis_summary.parquet");
    let ids = common::opt_strings(&summary, "dataset");
    let corr: Vec<f64> = summary
        .column("mean_correlation")
        .unwrap()
        .f64()
        .unwrap()
        .into_no_null_iter()
        .collect();
    let of = |id: &str| -> Vec<f64> {
        ids.iter()
            .zip(&corr)
            .filter(|(d, _)| d.as_deref() == Some(id))
            .map(|(_, c)| *c)
            .collect()
    };
    let npy = of("npy");
    assert_eq!(npy.len(), 6, "{summary}");
    let mut ids = vec!["v5"];
    if cfg!(feature = "mat73") {
        ids.push("v73");
    }
    for id in ids {
        assert_eq!(of(id), npy, "{id}");
        // The same maps, byte for byte.
        let maps = results.join("maps");
        let mut names: Vec<_> = std::fs::read_dir(maps.join("npy"))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        assert!(names.len() >= 8, "{names:?}");
        for n in &names {
            let read = |job: &str| std::fs::read(maps.join(job).join(n)).unwrap();
            assert!(read("npy") == read(id), "{id}: {n:?}");
        }
    }
}

#[test]
fn mat_dataset_errors_name_the_yaml_path_the_file_and_the_variables() {
    let dir = fixtures!();
    let tmp = tempfile::tempdir().unwrap();
    let cases: Vec<(String, &str, Vec<String>)> = vec![
        (
            format!(
                "{{id: a, kind: mat, path: {}, variable: data}}",
                s(&dir.join("two.mat"))
            ),
            "datasets[0].variable",
            vec![
                s(&dir.join("two.mat")).to_string(),
                "no variable \"data\"".into(),
                "first (4x5x3 single complex), second (4x5x3 double), scale (1x1 double)".into(),
            ],
        ),
        (
            format!("{{id: a, kind: mat, path: {}}}", s(&dir.join("two.mat"))),
            "datasets[0].variable",
            vec!["2 numeric 3-D arrays, so name the variable".into()],
        ),
        (
            format!(
                "{{id: a, kind: mat, path: {}, variable: st}}",
                s(&dir.join("mixed.mat"))
            ),
            "datasets[0].variable",
            vec!["variable \"st\" is a struct".into()],
        ),
        (
            format!(
                "{{id: a, kind: mat, path: {}, variable: x}}",
                s(&dir.join("plain.h5"))
            ),
            "datasets[0].path",
            vec!["HDF5 file without a MATLAB header".into()],
        ),
        (
            format!(
                "{{id: a, kind: mat, path: {}}}",
                s(&dir.join("missing.mat"))
            ),
            "datasets[0].path",
            vec!["cannot read".into(), "missing.mat".into()],
        ),
        (
            format!(
                "{{id: a, kind: npy, path: {}, variable: x}}",
                s(&dir.join("c64.npy"))
            ),
            "datasets[0].variable",
            vec!["`variable` does not apply".into()],
        ),
        (
            format!(
                "{{id: a, kind: mat, path: {}, layout: nhw}}",
                s(&dir.join("c64.mat"))
            ),
            "analysis.levels",
            vec!["dataset a".into()],
        ),
    ];
    for (i, (dataset, at, needles)) in cases.iter().enumerate() {
        let spec = spec(tmp.path(), &format!("bad{i}"), &format!("  - {dataset}\n"));
        let e = fails(&["validate", s(&spec)]);
        assert!(e.contains(s(&spec)) && e.contains(at), "{at}: {e}");
        for n in needles {
            assert!(e.contains(n.as_str()), "{n}: {e}");
        }
    }
}

/// The model files of two model folders are equal, byte for byte (`model.json` aside: its
/// `source` names the input).
fn same_models(a: &Path, b: &Path) {
    let mut names: Vec<_> = std::fs::read_dir(a)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() > 2, "{names:?}");
    for n in names.iter().filter(|n| *n != "model.json") {
        assert_eq!(
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
            "{n:?}"
        );
    }
}

#[test]
fn fit_reads_a_mat_like_the_npy_in_hwn() {
    let dir = fixtures!();
    let tmp = tempfile::tempdir().unwrap();
    let npy_model = tmp.path().join("from_npy");
    ok(&[
        "fit",
        "--input",
        s(&dir.join("measured_hwn.npy")),
        "--layout",
        "hwn",
        "--method",
        "method1",
        "--out",
        s(&npy_model),
        "--jobs",
        "1",
    ]);
    let mut inputs = vec![("measured.mat", Some("clutter"))];
    if cfg!(feature = "mat73") {
        inputs.push(("measured_v73.mat", None));
    }
    for (file, var) in inputs {
        let (input, model) = (dir.join(file), tmp.path().join(file));
        let mut args = vec![
            "fit",
            "--input",
            s(&input),
            "--method",
            "method1",
            "--out",
            s(&model),
            "--jobs",
            "1",
        ];
        if let Some(v) = var {
            args.extend(["--var", v]);
        }
        let said = ok(&args);
        assert!(
            said.contains("(variable clutter)") && said.contains("40 samples of 16x16"),
            "{said}"
        );
        same_models(&npy_model, &model);
        let json = std::fs::read_to_string(model.join("model.json")).unwrap();
        assert!(json.contains("(variable clutter)"), "{json}");
    }
    // Errors: a missing variable lists the file's, --var on a .npy, a bad layout.
    let e = fails(&[
        "fit",
        "--input",
        s(&dir.join("measured.mat")),
        "--var",
        "x",
        "--method",
        "method1",
        "--out",
        s(&tmp.path().join("m")),
    ]);
    assert!(
        e.contains("no variable \"x\"") && e.contains("clutter (16x16x40 single complex)"),
        "{e}"
    );
    let e = fails(&[
        "fit",
        "--input",
        s(&dir.join("c64.npy")),
        "--var",
        "x",
        "--method",
        "method1",
        "--out",
        s(&tmp.path().join("m")),
    ]);
    assert!(e.contains("--var names a variable of a .mat input"), "{e}");
    let e = fails(&[
        "fit",
        "--input",
        s(&dir.join("mixed.mat")),
        "--var",
        "ce",
        "--method",
        "method1",
        "--out",
        s(&tmp.path().join("m")),
    ]);
    assert!(e.contains("variable \"ce\" is a cell array"), "{e}");
    assert!(!tmp.path().join("m").exists());
}

/// Fits `method1` to the measured stack into `tmp/model`.
fn model(dir: &Path, tmp: &Path) -> PathBuf {
    let model = tmp.join("model");
    ok(&[
        "fit",
        "--input",
        s(&dir.join("measured_hwn.npy")),
        "--layout",
        "hwn",
        "--method",
        "method1",
        "--out",
        s(&model),
        "--jobs",
        "1",
    ]);
    model
}

#[test]
fn generated_mat_files_read_back_in_scipy_h5py_and_the_tool() {
    let dir = fixtures!();
    let python = common::venv_python(&["scipy", "h5py"]).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let model = model(dir, tmp.path());
    let npy = tmp.path().join("samples.npy");
    let gen = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "generate",
            "--model",
            s(&model),
            "--samples",
            "37",
            "--seed",
            "5",
            "--chunk",
            "8",
            "--out",
            s(out),
        ];
        args.extend(extra);
        ok(&args)
    };
    gen(&npy, &[]);
    let expected = Stack::load(&npy).unwrap().to_complex128(false);
    let mut cases = vec![
        (
            "v5.mat",
            vec!["--mat-version", "5"],
            "5",
            "single",
            "samples",
        ),
        (
            "v5d.mat",
            vec![
                "--mat-version",
                "5",
                "--mat-class",
                "double",
                "--var",
                "gen",
            ],
            "5",
            "double",
            "gen",
        ),
    ];
    if cfg!(feature = "mat73") {
        cases.push(("v73.mat", vec![], "7.3", "single", "samples"));
        cases.push((
            "v73d.mat",
            vec!["--mat-class", "double", "--var", "X_1"],
            "7.3",
            "double",
            "X_1",
        ));
    }
    for (file, extra, version, class, var) in cases {
        let out = tmp.path().join(file);
        gen(&out, &extra);
        let check = Command::new(&python)
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mat/check_generated.py"))
            .args([s(&npy), s(&out), version, class, var])
            .output()
            .unwrap();
        assert!(
            check.status.success(),
            "{file}: {}{}",
            String::from_utf8_lossy(&check.stdout),
            String::from_utf8_lossy(&check.stderr)
        );
        assert_eq!(String::from_utf8_lossy(&check.stdout).trim(), "ok 16 16 37");
        // The tool reads its own file back: H x W x M, equal to the .npy (single, and double:
        // sample format 2 computes in f32, so double holds the same values widened).
        let back = MatFile::open(&out).unwrap().read_stack(None).unwrap();
        let back = Stack::Generated(back).to_complex128(true);
        assert_eq!(back.dim(), (37, 16, 16));
        assert_eq!(back, expected, "{file}");
        // A second run replaces the tool's own file.
        gen(&out, &extra);
    }
}

#[test]
fn bad_mat_outputs_are_refused_before_anything_is_written() {
    let dir = fixtures!();
    let tmp = tempfile::tempdir().unwrap();
    let model = model(dir, tmp.path());
    let gen = |out: &Path, samples: &str, extra: &[&str]| {
        let mut args = vec![
            "generate",
            "--model",
            s(&model),
            "--samples",
            samples,
            "--seed",
            "5",
            "--out",
            s(out),
        ];
        args.extend(extra);
        fails(&args)
    };
    // Over 2 GB in v5: 16 x 16 x 1.1M single complex.
    let big = tmp.path().join("big.mat");
    let e = gen(&big, "1100000", &["--mat-version", "5"]);
    assert!(
        e.contains("at most 2 GB") && e.contains("16x16x1100000 single"),
        "{e}"
    );
    assert!(!big.exists());
    // Someone else's .mat, a folder, a bad variable name, .mat options on a .npy.
    let theirs = tmp.path().join("theirs.mat");
    std::fs::copy(dir.join("c64.mat"), &theirs).unwrap();
    let e = gen(&theirs, "4", &["--mat-version", "5"]);
    assert!(
        e.contains("is not a samples .mat file the tool wrote"),
        "{e}"
    );
    assert_eq!(
        std::fs::read(&theirs).unwrap(),
        std::fs::read(dir.join("c64.mat")).unwrap()
    );
    let folder = tmp.path().join("folder.mat");
    std::fs::create_dir(&folder).unwrap();
    let e = gen(&folder, "4", &["--mat-version", "5"]);
    assert!(
        e.contains("is a folder") && e.contains("samples.mat"),
        "{e}"
    );
    let e = gen(
        &tmp.path().join("x.mat"),
        "4",
        &["--mat-version", "5", "--var", "2x"],
    );
    assert!(e.contains("not a MATLAB variable name"), "{e}");
    let e = gen(&tmp.path().join("x.npy"), "4", &["--mat-version", "5"]);
    assert!(e.contains("apply to a .mat output"), "{e}");
    let e = gen(&tmp.path().join("x.mat"), "0", &["--mat-version", "5"]);
    assert!(e.contains("at least one sample"), "{e}");
    if !cfg!(feature = "mat73") {
        let e = gen(&tmp.path().join("x.mat"), "4", &[]);
        assert!(
            e.contains("--features mat73") && e.contains("--mat-version 5"),
            "{e}"
        );
    }
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".mat") || n.contains("tmp"))
        .collect();
    let mut left = left;
    left.sort();
    assert_eq!(left, ["folder.mat", "theirs.mat"]);
}
