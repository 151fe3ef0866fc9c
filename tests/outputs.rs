//! The output folders a user can trust (issue 13, items 1, 2 and 5): the binary never deletes,
//! hides or mixes a user's files. Each test is one defect found by an adversarial user, and
//! asserts the exit code, that the message names the path, and that nothing outside the
//! tool's own files changed.

mod common;
use common::{bin, text, BIN};

use ndarray::Array3;
use ndarray_npy::WriteNpyExt;
use num_complex::Complex;
use std::collections::BTreeMap;
use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Two small datasets, one read from `stack.npy`: a second run can make that one fail.
const SPEC: &str = "name: owned
seed: 7
datasets:
  - id: noise
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 0.5
    size: [8, 8]
    samples: 20
    half_width: 2
  - id: measured
    kind: npy
    path: stack.npy
analysis:
  levels: 1
";

/// Six jobs of about half a second each on one thread: long enough to act during the run.
const SLOW: &str = "name: slow
seed: 1
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [64, 64]
    samples: 1500
    half_width: 6
analysis:
  levels: 3
sweep:
  grid:
    datasets.d.alpha_h: [0.5, 1, 2, 3, 4, 5]
";

fn setup(dir: &Path) -> PathBuf {
    let stack = Array3::from_shape_fn((6, 8, 8), |(n, r, c)| {
        Complex::new((n * r) as f32 + c as f32 * 0.5, (n + c) as f32 % 3.0)
    });
    stack
        .write_npy(File::create(dir.join("stack.npy")).unwrap())
        .unwrap();
    let spec = dir.join("spec.yaml");
    fs::write(&spec, SPEC).unwrap();
    spec
}

fn run(spec: &Path, out: &Path) -> Output {
    run_with(spec, out, &["--quiet"])
}

/// `run SPEC --out OUT` with `extra` arguments.
fn run_with(spec: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    bin(&args)
}

/// Every file under `dir` with its bytes (the tool's state folder left out on request).
fn snapshot(dir: &Path, skip_state: bool) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if skip_state && e.file_name() == ".isar-clutter" {
                continue;
            }
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    fs::read(&p).unwrap(),
                );
            }
        }
    }
    out
}

/// A folder of a user's files: figures, maps and notes of their own.
fn users_folder(dir: &Path) -> PathBuf {
    let thesis = dir.join("thesis");
    fs::create_dir_all(thesis.join("figures")).unwrap();
    fs::create_dir_all(thesis.join("maps/europe")).unwrap();
    fs::write(thesis.join("figures/overview.png"), b"not ours").unwrap();
    fs::write(thesis.join("maps/europe/wind.npy"), b"not ours either").unwrap();
    fs::write(thesis.join("notes.txt"), b"chapter 5").unwrap();
    thesis
}

#[test]
fn a_folder_of_user_files_passed_as_out_is_refused_and_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let thesis = users_folder(dir.path());
    let before = snapshot(&thesis, false);
    let o = run(&spec, &thesis);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let msg = text(&o);
    assert!(
        msg.contains("thesis") && msg.contains("not written by isar-clutter"),
        "{msg}"
    );
    assert_eq!(
        snapshot(&thesis, false),
        before,
        "the user's folder changed"
    );
    // `report` into it is refused too, and changes nothing.
    let o = bin(&["report", thesis.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert_eq!(snapshot(&thesis, false), before);
}

#[test]
fn reruns_remove_only_what_the_tool_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    let o = run(&spec, &out);
    assert!(o.status.success(), "{}", text(&o));
    assert!(out.join("maps/measured/mean.npy").is_file());
    assert!(out.join("figures/measured").is_dir());
    // The user adds files of their own inside the tool's folders.
    fs::write(out.join("maps/measured/my_notes.txt"), b"keep").unwrap();
    fs::write(out.join("figures/measured/annotated.png"), b"keep").unwrap();
    fs::write(out.join("figures/poster.svg"), b"keep").unwrap();
    // A second run where `measured` fails (its file truncated): the job's maps of the first
    // run must not stay behind as if they were this run's, and the user's files stay.
    let bytes = fs::read(dir.path().join("stack.npy")).unwrap();
    fs::write(dir.path().join("stack.npy"), &bytes[..bytes.len() - 40]).unwrap();
    let o = run(&spec, &out);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        !out.join("maps/measured/mean.npy").exists(),
        "old maps of a failed job kept"
    );
    assert!(
        !out.join("figures/measured/mean.png").exists(),
        "old figures of a failed job kept"
    );
    assert!(out.join("maps/noise/mean.npy").is_file());
    assert_eq!(
        fs::read(out.join("maps/measured/my_notes.txt")).unwrap(),
        b"keep"
    );
    assert_eq!(
        fs::read(out.join("figures/measured/annotated.png")).unwrap(),
        b"keep"
    );
    assert_eq!(fs::read(out.join("figures/poster.svg")).unwrap(), b"keep");
    // A spec without that dataset: its folders go (but not the user's files in them).
    fs::write(
        &spec,
        SPEC.split("  - id: measured").next().unwrap().to_string() + "analysis:\n  levels: 1\n",
    )
    .unwrap();
    let o = run(&spec, &out);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        fs::read(out.join("maps/measured/my_notes.txt")).unwrap(),
        b"keep"
    );
    let listed: Vec<_> = fs::read_dir(out.join("maps/measured"))
        .unwrap()
        .flatten()
        .collect();
    assert_eq!(listed.len(), 1, "only the user's file is left");
}

#[test]
fn another_experiment_cannot_write_into_a_runs_folder() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    assert!(run(&spec, &out).status.success());
    let before = snapshot(&out, false);
    let other = dir.path().join("other.yaml");
    fs::write(&other, SPEC.replace("name: owned", "name: other")).unwrap();
    let o = run(&other, &out);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("experiment \"owned\""), "{}", text(&o));
    assert_eq!(snapshot(&out, false), before);
}

#[test]
fn generate_never_renames_over_a_folder_or_a_foreign_file() {
    let dir = tempfile::tempdir().unwrap();
    let stack = dir.path().join("s.npy");
    Array3::from_shape_fn((30, 8, 8), |(n, r, c)| {
        Complex::new(((n * 7 + r * 3 + c) % 11) as f32, (n % 3) as f32)
    })
    .write_npy(File::create(&stack).unwrap())
    .unwrap();
    let model = dir.path().join("model");
    let fit = |method: &str, out: &Path| {
        bin(&[
            "fit",
            "--input",
            stack.to_str().unwrap(),
            "--method",
            method,
            "--out",
            out.to_str().unwrap(),
            "--levels",
            "2",
            "--half-width",
            "3",
        ])
    };
    assert!(fit("method2", &model).status.success());
    assert!(model.join("r_h.npy").is_file());
    let gen = |out: &Path| {
        bin(&[
            "generate",
            "--model",
            model.to_str().unwrap(),
            "--samples",
            "5",
            "--seed",
            "1",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    // An existing folder: refused, the folder and its files stay, no hidden copy appears.
    let folder = dir.path().join("data");
    fs::create_dir_all(&folder).unwrap();
    fs::write(folder.join("keep.txt"), b"x").unwrap();
    let before = snapshot(dir.path(), false);
    let o = gen(&folder);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("is a folder"), "{}", text(&o));
    assert_eq!(snapshot(dir.path(), false), before);
    // A file that is not a samples .npy the tool wrote: refused and kept.
    let paper = dir.path().join("paper.tex");
    fs::write(&paper, b"\\documentclass").unwrap();
    let o = gen(&paper);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("paper.tex"), "{}", text(&o));
    assert_eq!(fs::read(&paper).unwrap(), b"\\documentclass");
    // The user's measured complex64 stack (the fit's input) looks like generated samples
    // inside, but no generation record names it: refused and kept.
    let measured = fs::read(&stack).unwrap();
    let o = gen(&stack);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("s.npy exists"), "{}", text(&o));
    assert_eq!(fs::read(&stack).unwrap(), measured);
    // Its own earlier output is replaced; the record beside it says how to write it again.
    let samples = dir.path().join("samples.npy");
    assert!(gen(&samples).status.success());
    let record: serde_json::Value =
        serde_json::from_slice(&fs::read(dir.path().join("samples.npy.json")).unwrap()).unwrap();
    assert_eq!(record["file"], "samples.npy");
    assert_eq!(record["shape"], serde_json::json!([5, 8, 8]));
    assert_eq!(record["seed"], 1);
    assert_eq!(record["method"], "method2");
    let model_json = fs::read(model.join("model.json")).unwrap();
    assert_eq!(
        record["model_json_sha256"],
        isar_clutter::seeds::sha256_hex(&model_json)
    );
    // A temporary file that a killed generate left (its pid is no live process) goes.
    let left = dir.path().join(".samples.npy.tmp-999999999");
    fs::write(&left, b"half").unwrap();
    let o = gen(&samples);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!left.exists());
    assert!(
        text(&o).contains(".samples.npy.tmp-999999999"),
        "{}",
        text(&o)
    );
    // A file of another shape saved over the samples since is not the tool's any more.
    Array3::from_shape_fn((4, 8, 8), |_| Complex::new(1f32, 0.0))
        .write_npy(File::create(&samples).unwrap())
        .unwrap();
    let o = gen(&samples);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // A user's file where the record goes is refused too.
    fs::write(dir.path().join("other.npy.json"), b"{}").unwrap();
    let o = gen(&dir.path().join("other.npy"));
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("other.npy.json"), "{}", text(&o));
    assert!(!dir.path().join("other.npy").exists());
    // fit: a file, or a folder that is not a model folder, is refused; a refit with another
    // method replaces the model whole (no file of the earlier method stays).
    let o = fit("method1", &paper);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let o = fit("method1", &folder);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("keep.txt") || text(&o).contains("no model.json"),
        "{}",
        text(&o)
    );
    assert_eq!(fs::read(folder.join("keep.txt")).unwrap(), b"x");
    assert!(fit("method1", &model).status.success());
    assert!(model.join("alpha_h.npy").is_file());
    assert!(
        !model.join("r_h.npy").exists(),
        "a file of the earlier model stayed"
    );
    let hidden: Vec<_> = fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");
}

/// Starts a run of the slow spec in the background.
fn start_slow(dir: &Path, out: &Path) -> std::process::Child {
    let spec = dir.join("slow.yaml");
    fs::write(&spec, SLOW).unwrap();
    Command::new(BIN)
        .args([
            "run",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--jobs", "1", "--quiet", "--no-report"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// Waits until `path` exists (at most 60 s).
fn wait_for(path: &Path) {
    let t = Instant::now();
    while !path.exists() {
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "{} never appeared",
            path.display()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_run_killed_while_writing_is_refused_by_table_and_report_until_rerun() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut child = start_slow(dir.path(), &out);
    // The first job's maps are written: the run is in its write phase, the manifest is not.
    wait_for(&out.join("maps/d.alpha_h=0.5/mean.npy"));
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert!(!out.join("manifest.json").exists());
    let before = snapshot(&out, false);
    for args in [
        vec!["table", out.to_str().unwrap()],
        vec!["report", out.to_str().unwrap()],
    ] {
        let o = bin(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        let msg = text(&o);
        assert!(
            msg.contains("incomplete") && msg.contains("interrupted") && msg.contains("out"),
            "{msg}"
        );
        assert!(msg.contains("--allow-incomplete"), "{msg}");
    }
    assert_eq!(
        snapshot(&out, false),
        before,
        "a refused reader changed the folder"
    );
    // A temporary file of the dead writer, as a kill in the middle of a write leaves it.
    let tmp = out.join("maps/d.alpha_h=0.5/.mean.npy.tmp-4194000");
    fs::write(&tmp, b"half").unwrap();
    // The rerun takes over the dead run's lock, removes its temporary file and completes.
    let spec = dir.path().join("slow.yaml");
    let o = run_with(&spec, &out, &["--no-report"]);
    assert!(o.status.success(), "{}", text(&o));
    let msg = text(&o);
    assert!(msg.contains("took over the lock of a run"), "{msg}");
    assert!(!tmp.exists());
    assert!(bin(&["table", out.to_str().unwrap()]).status.success());
}

#[test]
fn two_runs_into_one_folder_the_second_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut first = start_slow(dir.path(), &out);
    wait_for(&out.join(".isar-clutter/lock"));
    let spec = dir.path().join("slow.yaml");
    let o = run(&spec, &out);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let msg = text(&o);
    assert!(
        msg.contains("locked by a run") && msg.contains("pid"),
        "{msg}"
    );
    assert!(first.wait().unwrap().success());
    // The first run's outputs are whole: the reader accepts them.
    assert!(bin(&["table", out.to_str().unwrap()]).status.success());
}

#[test]
fn a_folder_changed_after_its_run_is_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    assert!(run(&spec, &out).status.success());
    // Another run's table copied in, or a table lost.
    fs::write(out.join("similarity.parquet"), b"PAR1 from elsewhere").unwrap();
    let o = bin(&["table", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("similarity.parquet"), "{}", text(&o));
    fs::remove_file(out.join("similarity.parquet")).unwrap();
    let o = bin(&["table", out.to_str().unwrap()]);
    assert!(
        text(&o).contains("similarity.parquet is missing"),
        "{}",
        text(&o)
    );
    let o = bin(&["table", out.to_str().unwrap(), "--allow-incomplete"]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn rayon_num_threads_is_honoured_and_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    let o = Command::new(BIN)
        .args([
            "run",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ])
        .arg("--no-report")
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let manifest: serde_json::Value =
        serde_json::from_slice(&fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["threads"], 1);
    // The manifest lists the files the run wrote, and the state keeps the tool's records.
    assert!(manifest["files"]["jobs.parquet"]["sha256"].is_string());
    assert!(manifest["files"]["maps/noise/mean.npy"]["bytes"].is_u64());
    let owned = fs::read_to_string(out.join(".isar-clutter/owned")).unwrap();
    assert!(owned.lines().any(|l| l == "maps/noise/mean.npy"), "{owned}");
    // One thread: the tables are written inline, each hashed as it is written.
    assert_tables_hashed(&out, &manifest);
}

/// Every table in the manifest carries the SHA-256 of the file's bytes (the merge computes it
/// while writing the table, not by reading it back).
fn assert_tables_hashed(out: &Path, manifest: &serde_json::Value) {
    let mut tables = 0;
    for e in fs::read_dir(out).unwrap().flatten() {
        let name = e.file_name().into_string().unwrap();
        if !name.ends_with(".parquet") {
            continue;
        }
        let want = isar_clutter::seeds::sha256_hex(&fs::read(e.path()).unwrap());
        assert_eq!(manifest["files"][&name]["sha256"], want.as_str(), "{name}");
        tables += 1;
    }
    assert!(tables >= 5, "{tables} tables");
}

#[test]
fn tables_written_on_threads_of_their_own_carry_their_sha256() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    let o = run_with(&spec, &out, &["--quiet", "--no-report", "--jobs", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let manifest: serde_json::Value =
        serde_json::from_slice(&fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["threads"], 2);
    assert_tables_hashed(&out, &manifest);
}

#[test]
fn a_write_phase_that_fails_leaves_the_folder_marked_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let spec = setup(dir.path());
    let out = dir.path().join("out");
    assert!(run(&spec, &out).status.success());
    // Where the jobs table goes there is now a folder of the user's: the table cannot be
    // written (as with a full disk), and the folder is not renamed away.
    fs::remove_file(out.join("jobs.parquet")).unwrap();
    fs::create_dir(out.join("jobs.parquet")).unwrap();
    fs::write(out.join("jobs.parquet/keep.txt"), b"x").unwrap();
    let o = run(&spec, &out);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("jobs.parquet"), "{}", text(&o));
    assert_eq!(fs::read(out.join("jobs.parquet/keep.txt")).unwrap(), b"x");
    assert!(!out.join("manifest.json").exists());
    let o = bin(&["table", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("incomplete"), "{}", text(&o));
}
