//! MAT v5 input against files written by SciPy (`tests/mat/make_fixtures.py`, run at test time
//! in the project's virtualenv, `.venv`): every dtype, compressed or not, and big-endian, read
//! value for value equal to the same data saved as `.npy`; the variable is chosen by name or as
//! the only numeric 3-D array; missing variables, structs, cells, char arrays, sparse and 2-D
//! arrays, truncated files, v7.3 and plain HDF5 files are clear errors naming the file (and
//! the variable). Without SciPy in the virtualenv the tests skip with a message, unless
//! `CI=true`, where they fail.

use isar_clutter::io::mat::{MatError, MatFile};
use isar_clutter::io::npy::Stack;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The fixture folder, generated once per test process; `None` (skip) without SciPy.
fn fixtures() -> Option<&'static Path> {
    static DIR: OnceLock<Option<tempfile::TempDir>> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let python = root.join(".venv/bin/python");
        let ci = std::env::var("CI").is_ok_and(|v| v == "true");
        let has = python.exists()
            && std::process::Command::new(&python)
                .args(["-c", "import scipy, h5py"])
                .status()
                .is_ok_and(|s| s.success());
        if !has {
            assert!(
                !ci,
                "CI=true: the MAT tests need scipy and h5py in .venv (pip install scipy h5py)"
            );
            eprintln!("skipping the MAT tests: .venv lacks scipy or h5py");
            return None;
        }
        let dir = tempfile::tempdir().unwrap();
        let out = std::process::Command::new(&python)
            .arg(root.join("tests/mat/make_fixtures.py"))
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

fn err(path: &Path, var: Option<&str>) -> String {
    match MatFile::open(path).and_then(|m| m.read_stack(var)) {
        Ok(_) => panic!("{} {var:?} was read", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn every_dtype_compressed_or_not_and_big_endian_equals_the_npy() {
    let dir = fixtures!();
    let mut checked = 0;
    for tag in ["c64", "c128", "f32", "f64"] {
        let npy = Stack::load(&dir.join(format!("{tag}.npy")))
            .unwrap()
            .to_complex128(false);
        assert_eq!(npy.dim(), (4, 5, 3));
        for suffix in ["", "_z", "_be"] {
            let p: PathBuf = dir.join(format!("{tag}{suffix}.mat"));
            if !p.exists() {
                continue;
            }
            let named = MatFile::open(&p).unwrap().read_stack(Some("x")).unwrap();
            assert_eq!(named.dim(), (4, 5, 3), "{}", p.display());
            assert_eq!(named, npy, "{}", p.display());
            // The only 3-D array is found without a name, and as the dataset's Stack.
            let only = isar_clutter::io::mat::load_stack(&p, None).unwrap();
            assert_eq!(only.to_complex128(false), npy);
            // H x W x N read as [N, H, W] matches the .npy read the same way.
            assert_eq!(
                only.to_complex128(true),
                Stack::load(&dir.join(format!("{tag}.npy")))
                    .unwrap()
                    .to_complex128(true)
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 10);
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

#[test]
fn malformed_files_are_errors_not_panics() {
    let dir = fixtures!();
    let tmp = tempfile::tempdir().unwrap();
    for name in ["c128.mat", "c128_z.mat", "mixed.mat"] {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        for cut in [0, 10, 127, 128, 135, 200, bytes.len() - 9, bytes.len() - 1] {
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
        for at in (128..bytes.len()).step_by(7) {
            let mut b = bytes.clone();
            b[at] ^= 0x5a;
            let p = tmp.path().join(format!("flip_{name}"));
            std::fs::write(&p, &b).unwrap();
            let _ = MatFile::open(&p).and_then(|m| m.read_stack(None));
        }
    }
    let e = err(&dir.join("plain.h5"), None);
    assert!(e.contains("HDF5 file without a MATLAB header"), "{e}");
    let e = err(&dir.join("c64_v73.mat"), None);
    assert!(e.contains("v7.3"), "{e}");
}
