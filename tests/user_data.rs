//! What a user added or gave is never dropped or accepted only to fail later, and the messages
//! say what happened (issue 26, items 4 and 5). Each test is named after the defect it pins:
//!
//! - `generate --out X.mat` over the tool's own `.mat` to which a variable was appended (v5 by
//!   bytes, v7.3 with libhdf5) is refused naming the variable, and the file is kept byte for
//!   byte;
//! - a stack with a NaN or infinite pixel is refused by `fit` (every method) naming the pixels,
//!   and in a run only the synthesis jobs of that stack fail, with the same message, while the
//!   other dataset's models generate;
//! - duplicate `train_sizes` and `scr_db` of the CNN sections are refused by `validate` at
//!   their YAML path;
//! - a v7.3 variable whose `MATLAB_class` is numeric but whose data are strings or booleans is
//!   refused by `validate` at `datasets[i].variable`;
//! - under `--quiet`, jobs whose outcome cannot be stored (a full disk) are reported as failed
//!   with their cause, not as jobs of shards not yet run;
//! - an I/O error's cause is printed once, not twice.

mod common;
use common::{bin, BIN};

use isar_clutter::io::mat::MatFile;
use ndarray::Array3;
use ndarray_npy::WriteNpyExt;
use num_complex::Complex64;
use std::path::{Path, PathBuf};
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs the binary, asserting exit code 2 and no panic; its stderr.
fn refused(args: &[&str]) -> String {
    let o = bin(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?} should be refused: {e}");
    assert!(!e.contains("panicked"), "{e}");
    e
}

/// Runs the binary, asserting success; its stderr.
fn ok(args: &[&str]) -> String {
    let o = bin(args);
    let e = stderr(&o);
    assert!(o.status.success(), "{args:?}: {e}");
    e
}

/// A seeded 20 x 16 x 16 stack saved as complex128 `.npy` at `dir/name`, with `bad` values
/// put at `(sample, row, column)`.
fn stack_npy(dir: &Path, name: &str, bad: &[((usize, usize, usize), Complex64)]) -> PathBuf {
    let mut x: Array3<Complex64> = common::random_stack(7, 20, 16, 16);
    for &(at, v) in bad {
        x[at] = v;
    }
    let p = dir.join(name);
    x.write_npy(std::fs::File::create(&p).unwrap()).unwrap();
    p
}

/// A model folder fitted by the binary to a clean stack.
fn model(dir: &Path) -> PathBuf {
    let input = stack_npy(dir, "clean.npy", &[]);
    let m = dir.join("model");
    ok(&[
        "fit",
        "--input",
        s(&input),
        "--method",
        "method1",
        "--out",
        s(&m),
        "--jobs",
        "1",
    ]);
    m
}

/// `generate` 4 samples from `model` into `out` with the extra arguments.
fn generate(model: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "generate",
        "--model",
        s(model),
        "--samples",
        "4",
        "--seed",
        "3",
        "--out",
        s(out),
    ];
    args.extend(extra);
    bin(&args)
}

// ---- 4. Nothing a user added is dropped ----

/// A MAT v5 element of type `ty` with its payload, padded to 8 bytes.
fn v5_element(ty: u32, payload: &[u8]) -> Vec<u8> {
    let mut v = ty.to_le_bytes().to_vec();
    v.extend((payload.len() as u32).to_le_bytes());
    v.extend(payload);
    v.resize(v.len().div_ceil(8) * 8, 0);
    v
}

/// A 1x1 double variable as MATLAB's `save(..., '-append')` adds it to a v5 file.
fn v5_scalar(name: &str, value: f64) -> Vec<u8> {
    let flags: Vec<u8> = [6u32, 0].iter().flat_map(|x| x.to_le_bytes()).collect();
    let dims: Vec<u8> = [1i32, 1].iter().flat_map(|x| x.to_le_bytes()).collect();
    let mut body = v5_element(6, &flags);
    body.extend(v5_element(5, &dims));
    body.extend(v5_element(1, name.as_bytes()));
    body.extend(v5_element(9, &value.to_le_bytes()));
    v5_element(14, &body)
}

/// The variables of a MAT file, as the tool lists them. libhdf5 keeps its lock on a v7.3 file
/// a moment after the test's own writer closed it while other tests of this binary use the
/// library (`unable to lock file, errno = 11` once in a full `make test`): the open is retried
/// for up to a second on that error alone.
fn variables(p: &Path) -> Vec<String> {
    let mut tries = 0;
    let file = loop {
        match MatFile::open(p) {
            Err(e) if tries < 20 && format!("{e:?}").contains("unable to lock file") => {
                tries += 1;
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
            other => break other,
        }
    };
    file.unwrap()
        .variables()
        .iter()
        .map(|v| format!("{} {}", v.name, v.describe()))
        .collect()
}

#[test]
fn generate_refuses_its_own_v5_mat_once_a_variable_was_appended_and_keeps_it() {
    let dir = tempfile::tempdir().unwrap();
    let m = model(dir.path());
    let out = dir.path().join("app.mat");
    let o = generate(&m, &out, &["--mat-version", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The tool's own file, as it left it, is replaced.
    let o = generate(&m, &out, &["--mat-version", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut bytes = std::fs::read(&out).unwrap();
    bytes.extend(v5_scalar("note", 2.5));
    std::fs::write(&out, &bytes).unwrap();
    assert_eq!(
        variables(&out),
        ["samples 16x16x4 single complex", "note 1x1 double"]
    );
    for extra in [
        &["--mat-version", "5"][..],
        &["--mat-version", "5", "--var", "note"],
    ] {
        let o = generate(&m, &out, extra);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(
            e.contains(&format!(
                "{} was written by isar-clutter but now also holds 1 variable(s) it did not \
                 write: note (1x1 double)",
                out.display()
            )) && e.contains("nothing was changed"),
            "{e}"
        );
        assert_eq!(std::fs::read(&out).unwrap(), bytes, "the file is kept");
    }
    // Nothing was left beside it.
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["app.mat", "clean.npy", "model"]);
}

#[cfg(feature = "mat73")]
#[test]
fn generate_refuses_its_own_v73_mat_once_a_variable_was_appended_and_keeps_it() {
    use hdf5_metno::types::FixedAscii;
    let dir = tempfile::tempdir().unwrap();
    let m = model(dir.path());
    let out = dir.path().join("app.mat");
    let o = generate(&m, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    {
        // As h5py or MATLAB's save(..., '-append') add a variable: the user block stays.
        let f = hdf5_metno::File::open_rw(&out).unwrap();
        let ds = f
            .new_dataset_builder()
            .with_data(&ndarray::arr2(&[[1.0f64, 2.0, 3.0]]))
            .create("calib")
            .unwrap();
        let class = FixedAscii::<6>::from_ascii(b"double").unwrap();
        ds.new_attr::<FixedAscii<6>>()
            .create("MATLAB_class")
            .unwrap()
            .write_scalar(&class)
            .unwrap();
        drop(ds);
        f.close().unwrap();
    }
    assert_eq!(
        variables(&out),
        ["calib 3x1 double", "samples 16x16x4 single complex"]
    );
    let bytes = std::fs::read(&out).unwrap();
    let o = generate(&m, &out, &[]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("now also holds 1 variable(s) it did not write: calib (3x1 double)"),
        "{e}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), bytes, "the file is kept");
    // Written as v5 instead: refused all the same.
    let e = refused(&[
        "generate",
        "--model",
        s(&m),
        "--samples",
        "4",
        "--seed",
        "3",
        "--mat-version",
        "5",
        "--out",
        s(&out),
    ]);
    assert!(e.contains("calib (3x1 double)"), "{e}");
    assert_eq!(std::fs::read(&out).unwrap(), bytes, "the file is kept");
}

const NAN_PIXELS: &str = "the stack has NaN or infinite values at 2 of 256 pixel(s) \
                          ([row, column] from 0: [2, 5], [9, 1])";

/// A stack with a NaN at sample 3, pixel [2, 5] and an infinity at sample 7, pixel [9, 1].
fn nan_stack(dir: &Path) -> PathBuf {
    stack_npy(
        dir,
        "bad.npy",
        &[
            ((3, 2, 5), Complex64::new(f64::NAN, 0.0)),
            ((7, 9, 1), Complex64::new(1.0, f64::INFINITY)),
        ],
    )
}

#[test]
fn fit_refuses_a_stack_with_nan_or_inf_pixels_naming_them_so_generate_never_meets_its_model() {
    let dir = tempfile::tempdir().unwrap();
    let input = nan_stack(dir.path());
    for method in [
        "method1",
        "method2",
        "full_covariance",
        "uncorrelated",
        "fourth_order",
    ] {
        let out = dir.path().join(method);
        let e = refused(&[
            "fit",
            "--input",
            s(&input),
            "--method",
            method,
            "--out",
            s(&out),
            "--jobs",
            "1",
        ]);
        assert!(
            e.contains(&format!(
                "fitting {method} to {}: {NAN_PIXELS}",
                input.display()
            )),
            "{e}"
        );
        assert!(!out.exists(), "{method}: no model folder is written");
    }
    // The model a run or an earlier version could write (a NaN mean) is still refused by
    // `generate`: the two agree on what a valid model is.
    let m = model(dir.path());
    let mean = m.join("mean.npy");
    let mut mu: ndarray::Array2<Complex64> = ndarray_npy::read_npy(&mean).unwrap();
    mu[[2, 5]] = Complex64::new(f64::NAN, 0.0);
    mu.write_npy(std::fs::File::create(&mean).unwrap()).unwrap();
    let o = generate(&m, &dir.path().join("g.npy"), &[]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("mean.npy") && e.contains("finite"), "{e}");
}

#[test]
fn a_run_fails_only_the_synthesis_jobs_of_a_stack_with_nan_pixels() {
    let dir = tempfile::tempdir().unwrap();
    nan_stack(dir.path());
    stack_npy(dir.path(), "clean.npy", &[]);
    let spec = dir.path().join("nan.yaml");
    std::fs::write(
        &spec,
        "name: nan\nseed: 1\ndatasets:\n  - {id: bad, kind: npy, path: bad.npy}\n  - {id: \
         clean, kind: npy, path: clean.npy}\nanalysis:\n  levels: 1\nsynthesis:\n  methods: \
         [method1, uncorrelated]\n  samples: 8\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let o = bin(&[
        "run",
        s(&spec),
        "--quiet",
        "--no-report",
        "--jobs",
        "2",
        "--out",
        s(&out),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    let jobs = common::read_table(&out, "jobs.parquet");
    let ids = common::opt_strings(&jobs, "job");
    let errors = common::opt_strings(&jobs, "error");
    let error_of = |id: &str| {
        let i = ids.iter().position(|j| j.as_deref() == Some(id));
        errors[i.unwrap_or_else(|| panic!("no job {id} in {ids:?}"))].clone()
    };
    // The analysis of the stack with NaN pixels is NaN-aware; its fits fail, naming the pixels.
    assert_eq!(error_of("bad"), None);
    for method in ["method1", "uncorrelated"] {
        let e = error_of(&format!("bad.{method}")).expect("the fit fails");
        assert!(
            e.contains(&format!("fitting {method}: {NAN_PIXELS}")),
            "{e}"
        );
        assert!(!out.join("models").join(format!("bad.{method}")).exists());
        assert_eq!(error_of(&format!("clean.{method}")), None);
        let m = out.join("models").join(format!("clean.{method}"));
        let o = generate(&m, &dir.path().join(format!("{method}.npy")), &[]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(
        e.contains("failed: bad.method1") && e.contains("[2, 5], [9, 1]"),
        "{e}"
    );
}

// ---- 5. Clear messages ----

/// `validate` of a spec written to `dir`; its stderr (asserting exit code 2).
fn invalid(dir: &Path, text: &str) -> String {
    let spec = dir.join("spec.yaml");
    std::fs::write(&spec, text).unwrap();
    refused(&["validate", s(&spec)])
}

const CLASSES: &str = "name: dup\nseed: 1\ndatasets:
  - {id: a, kind: filtered_noise, family: exponential, alpha_h: 4.0, alpha_v: 0.2, size: [32, 32], samples: 60}
  - {id: b, kind: filtered_noise, family: exponential, alpha_h: 0.2, alpha_v: 4.0, size: [32, 32], samples: 60}
  - {id: c, kind: filtered_noise, family: exponential, alpha_h: 1.0, alpha_v: 1.0, size: [64, 64], samples: 60}
analysis:
  levels: 1
";

#[test]
fn duplicate_train_sizes_and_scr_db_are_refused_at_validate_with_the_yaml_path() {
    let dir = tempfile::tempdir().unwrap();
    let classification = |sizes: &str| {
        format!(
            "{CLASSES}classification:\n  classes: [a, b]\n  methods: [original, method1]\n  \
             train_sizes: {sizes}\n  repeats: 2\n"
        )
    };
    let spec = dir.path().join("ok.yaml");
    std::fs::write(&spec, classification("[20, 40]")).unwrap();
    ok(&["validate", s(&spec)]);
    let e = invalid(dir.path(), &classification("[20, 40, 20]"));
    assert!(
        e.contains("classification.train_sizes[2]") && e.contains("20 is listed twice"),
        "{e}"
    );
    let location = |scr: &str| {
        format!(
            "{CLASSES}location:\n  clutter: c\n  fit_samples: 40\n  methods: [method1]\n  \
             generated_samples: 20\n  targets: [constant]\n  scr_db: {scr}\n"
        )
    };
    std::fs::write(&spec, location("[-10, 0]")).unwrap();
    ok(&["validate", s(&spec)]);
    for (scr, at, what) in [
        (
            "[-10, 0, -10.0]",
            "location.scr_db[2]",
            "-10 dB is listed twice",
        ),
        ("[0, -0.0]", "location.scr_db[1]", "0 dB is listed twice"),
    ] {
        let e = invalid(dir.path(), &location(scr));
        assert!(e.contains(at) && e.contains(what), "{scr}: {e}");
    }
    for (sets, at, what) in [
        (
            "[all, held_out, all]",
            "location.test_sets[2]",
            "all is listed twice",
        ),
        (
            "[]",
            "location.test_sets",
            "name at least one of held_out, all",
        ),
    ] {
        let e = invalid(
            dir.path(),
            &format!("{}  test_sets: {sets}\n", location("[0]")),
        );
        assert!(e.contains(at) && e.contains(what), "{sets}: {e}");
    }
}

/// A MAT v7.3 file (not written by the tool) holding `x`, 4x5x3 strings, and `flags`, 4x5x3
/// booleans, both with `MATLAB_class` `double`, and `good`, a 4x5x3 double stack.
#[cfg(feature = "mat73")]
fn mislabelled_v73(path: &Path) {
    use hdf5_metno::types::FixedAscii;
    let f = hdf5_metno::File::with_options()
        .with_fcpl(|p| p.userblock(512))
        .create(path)
        .unwrap();
    let class = FixedAscii::<6>::from_ascii(b"double").unwrap();
    let label = |ds: &hdf5_metno::Dataset| {
        ds.new_attr::<FixedAscii<6>>()
            .create("MATLAB_class")
            .unwrap()
            .write_scalar(&class)
            .unwrap();
    };
    let text = FixedAscii::<4>::from_ascii(b"abcd").unwrap();
    let x = Array3::from_elem((3, 5, 4), text);
    label(&f.new_dataset_builder().with_data(&x).create("x").unwrap());
    let flags = Array3::from_elem((3, 5, 4), true);
    label(
        &f.new_dataset_builder()
            .with_data(&flags)
            .create("flags")
            .unwrap(),
    );
    let good = Array3::from_elem((3, 5, 4), 1.5f64);
    label(
        &f.new_dataset_builder()
            .with_data(&good)
            .create("good")
            .unwrap(),
    );
    f.close().unwrap();
    let text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 \
                 HDF5 schema 1.00 .";
    let mut header = text.to_vec();
    header.resize(116, b' ');
    header.extend([0u8; 8]);
    header.extend(0x0200u16.to_le_bytes());
    header.extend(b"IM");
    let mut bytes = std::fs::read(path).unwrap();
    bytes[..128].copy_from_slice(&header);
    std::fs::write(path, bytes).unwrap();
}

#[cfg(feature = "mat73")]
#[test]
fn validate_refuses_a_v73_variable_whose_data_are_not_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let mat = dir.path().join("labelled.mat");
    mislabelled_v73(&mat);
    assert_eq!(
        variables(&mat),
        [
            "flags 4x5x3 double stored as bool",
            "good 4x5x3 double",
            "x 4x5x3 double stored as string (len 4)"
        ]
    );
    let spec = |var: &str| {
        format!(
            "name: t\nseed: 1\ndatasets:\n  - {{id: d, kind: mat, path: labelled.mat{var}}}\n\
             analysis:\n  levels: 1\n"
        )
    };
    for (var, stored) in [("x", "string (len 4)"), ("flags", "bool")] {
        let e = invalid(dir.path(), &spec(&format!(", variable: {var}")));
        assert!(
            e.contains("datasets[0].variable")
                && e.contains(&format!(
                    "variable {var:?} is stored as {stored}, not as numbers (its MATLAB_class \
                     says double)"
                )),
            "{e}"
        );
    }
    // Unnamed, the only numeric 3-D array is the one read.
    let p = dir.path().join("spec.yaml");
    std::fs::write(&p, spec("")).unwrap();
    ok(&["validate", s(&p)]);
}

/// Replaces every job folder of `out`'s job store with a file, so that no job's outcome can
/// be saved there (as on a full disk); returns how many.
fn break_the_store(out: &Path) -> usize {
    let mut n = 0;
    for e in std::fs::read_dir(out.join("jobs")).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            std::fs::remove_dir_all(&p).unwrap();
            std::fs::write(&p, b"").unwrap();
            n += 1;
        }
    }
    n
}

#[test]
fn under_quiet_jobs_whose_outcome_cannot_be_stored_are_reported_failed_with_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("store.yaml");
    std::fs::write(
        &spec,
        "name: store\nseed: 1\ndatasets:\n  - {id: a, kind: filtered_noise, family: \
         exponential, alpha_h: 1, alpha_v: 1, size: [16, 16], samples: 10}\n  - {id: b, kind: \
         filtered_noise, family: exponential, alpha_h: 2, alpha_v: 2, size: [16, 16], samples: \
         10}\nanalysis:\n  levels: 1\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    common::run_spec(&spec, &out, &["--no-report"]);
    assert_eq!(break_the_store(&out), 2);
    let o = bin(&[
        "run",
        s(&spec),
        "--quiet",
        "--fresh",
        "--no-report",
        "--out",
        s(&out),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        !e.contains("run their shards") && !e.contains("lacks"),
        "{e}"
    );
    assert!(
        e.contains(&format!(
            "2 job(s) failed and their outcome could not be saved in the job store {}",
            out.join("jobs").display()
        )) && e.contains("a: ")
            && e.contains("b: ")
            && e.contains("Not a directory (os error 20)"),
        "{e}"
    );
}

/// A real full disk: an 8 MiB tmpfs (in a mount namespace of its own, where `unshare` may make
/// one; skipped otherwise) that the run fills with a saved sample stack (13 MB; the outputs'
/// estimate, 14 MB, is within the margin of the up-front disk check, which only warns:
/// tests/resources.rs has the refusal).
#[test]
fn under_quiet_a_full_disk_says_no_space_left() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("full.yaml");
    std::fs::write(
        &spec,
        "name: full\nseed: 1\ndatasets:\n  - {id: a, kind: filtered_noise, family: \
         exponential, alpha_h: 1, alpha_v: 1, size: [64, 64], samples: 10}\nanalysis:\n  \
         levels: 1\nsynthesis:\n  methods: [uncorrelated]\n  samples: 400\n  save_samples: \
         true\n",
    )
    .unwrap();
    let disk = dir.path().join("disk");
    std::fs::create_dir(&disk).unwrap();
    let script = format!(
        "mount -t tmpfs -o size=8m tmpfs '{d}' || exit 77; exec '{BIN}' run '{spec}' --quiet \
         --no-report --jobs 1 --out '{d}/out'",
        d = disk.display(),
        spec = spec.display()
    );
    let o = std::process::Command::new("unshare")
        .args(["-rm", "sh", "-c", &script])
        .output();
    let o = match o {
        Ok(o) if o.status.code() != Some(77) && !stderr(&o).contains("unshare:") => o,
        _ => {
            eprintln!("skipped: no mount namespace with a tmpfs here (unshare -rm)");
            return;
        }
    };
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        !e.contains("run their shards") && !e.contains("lacks"),
        "{e}"
    );
    assert!(e.contains("No space left on device (os error 28)"), "{e}");
    assert_eq!(e.matches("(os error 28)").count(), 1, "{e}");
}

#[test]
fn an_io_error_cause_is_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let absent = |name: &str| dir.path().join(name);
    let cases: Vec<Vec<String>> = vec![
        vec![
            "fit".into(),
            "--input".into(),
            s(&absent("absent.npy")).into(),
            "--method".into(),
            "uncorrelated".into(),
            "--out".into(),
            s(&absent("m")).into(),
        ],
        vec![
            "fit".into(),
            "--input".into(),
            s(&absent("absent.mat")).into(),
            "--method".into(),
            "uncorrelated".into(),
            "--out".into(),
            s(&absent("m")).into(),
        ],
        vec![
            "generate".into(),
            "--model".into(),
            s(&absent("model")).into(),
            "--samples".into(),
            "2".into(),
            "--seed".into(),
            "1".into(),
            "--out".into(),
            s(&absent("g.npy")).into(),
        ],
        vec!["validate".into(), s(&absent("absent.yaml")).into()],
        vec!["table".into(), s(&absent("results")).into()],
        vec!["status".into(), s(&absent("results")).into()],
        vec!["merge".into(), s(&absent("results")).into()],
    ];
    for args in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let e = refused(&args);
        assert!(e.contains(s(dir.path())), "{e}");
        if e.contains("(os error 2)") {
            assert_eq!(
                e.matches("(os error 2)").count(),
                1,
                "{args:?} repeats its cause: {e}"
            );
        }
    }
    // The one this issue quoted: `fit` over a missing `.npy`.
    let e = refused(&[
        "fit",
        "--input",
        s(&absent("absent.npy")),
        "--method",
        "uncorrelated",
        "--out",
        s(&absent("m")),
    ]);
    assert!(
        e.contains(&format!(
            "cannot read {}: No such file or directory (os error 2)",
            absent("absent.npy").display()
        )) && !e.contains("(os error 2): No such file"),
        "{e}"
    );
}
