//! Every resource estimated before it is spent, and state files that cannot be turned against
//! the user (issue 48), replayed through the binary: an absurd `fit` refused before it
//! allocates (no abort, no stale lock), `generate` of more samples than the disk holds refused
//! before it writes, `--jobs 100000` capped with a note, planted symbolic links in place of
//! lock files refused with their targets untouched, Slurm's `--time` and `--mem` checked when
//! the command line is read, and two jobs that do not fit together under `--max-memory` run
//! one after the other with the tables of `--jobs 1`.

mod common;
use common::{bin, same_tables, text};

use std::fs;
use std::path::Path;

const SPEC: &str = "name: resources
seed: 3
datasets:
  - id: a
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 0.5
    size: [32, 32]
    samples: 200
    half_width: 4
analysis:
  levels: 2
sweep:
  grid:
    datasets.*.mean: [0, 1]
";

fn spec(dir: &Path) -> String {
    let p = dir.join("spec.yaml");
    fs::write(&p, SPEC).unwrap();
    p.to_str().unwrap().to_string()
}

fn stack(dir: &Path) -> String {
    let p = dir.join("stack.npy");
    let x = common::random_stack(1, 20, 8, 8);
    ndarray_npy::write_npy(&p, &x).unwrap();
    p.to_str().unwrap().to_string()
}

/// `isar-clutter fit --input INPUT --method METHOD --out OUT` plus `extra`.
fn fit(input: &str, method: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "fit",
        "--input",
        input,
        "--method",
        method,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    bin(&args)
}

/// Names in `dir` other than `keep`.
fn left(dir: &Path, keep: &[&str]) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !keep.contains(&n.as_str()))
        .collect();
    names.sort();
    names
}

#[test]
fn an_absurd_fit_is_refused_before_it_allocates_and_leaves_no_lock() {
    let dir = tempfile::tempdir().unwrap();
    let input = stack(dir.path());
    for method in ["method1", "method2"] {
        let out = dir.path().join("m");
        let o = fit(&input, method, &out, &["--half-width", "1000000000"]);
        let msg = text(&o);
        assert_eq!(o.status.code(), Some(2), "{method}: {msg}");
        assert!(
            msg.contains(&format!(
                "{method} with half_width 1000000000 on a 8x8 image needs a model of about"
            )) && msg.contains("lower half_width"),
            "{msg}"
        );
        assert_eq!(
            left(dir.path(), &["stack.npy"]),
            Vec::<String>::new(),
            "{method}"
        );
    }
}

#[test]
fn generating_more_than_the_disk_holds_is_refused_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let input = stack(dir.path());
    let model = dir.path().join("m");
    let o = fit(&input, "method1", &model, &["--half-width", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = dir.path().join("x.npy");
    let o = bin(&[
        "generate",
        "--model",
        model.to_str().unwrap(),
        "--samples",
        "18446744073709551615",
        "--seed",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(
        msg.contains("the 18446744073709551615 samples (--samples) need about 16.0 EiB on disk")
            && msg.contains("nothing was written"),
        "{msg}"
    );
    assert_eq!(left(dir.path(), &["stack.npy", "m"]), Vec::<String>::new());
}

#[test]
fn a_thread_count_past_the_machine_is_capped_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let out = dir.path().join("out");
    let o = bin(&[
        "run",
        &spec,
        "--out",
        out.to_str().unwrap(),
        "--no-report",
        "--jobs",
        "100000",
    ]);
    let msg = text(&o);
    assert!(o.status.success(), "{msg}");
    let most = isar_clutter::resources::max_threads();
    assert!(
        msg.contains("note: --jobs 100000 is more than this machine can use")
            && msg.contains(&format!("running {most} threads")),
        "{msg}"
    );
    let o = bin(&["run", &spec, "--out", out.to_str().unwrap(), "--jobs", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

#[test]
fn planted_symlinks_in_place_of_lock_files_are_refused_and_their_targets_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let victim = dir.path().join("victim.txt");
    fs::write(&victim, "precious").unwrap();
    // The run's lock.
    let out = dir.path().join("out");
    fs::create_dir_all(out.join(".isar-clutter")).unwrap();
    fs::write(
        out.join(".isar-clutter/owner.json"),
        r#"{"tool": "isar-clutter", "name": "resources"}"#,
    )
    .unwrap();
    std::os::unix::fs::symlink(&victim, out.join(".isar-clutter/lock")).unwrap();
    let o = bin(&["run", &spec, "--out", out.to_str().unwrap(), "--no-report"]);
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(msg.contains("is a symbolic link"), "{msg}");
    assert_eq!(fs::read_to_string(&victim).unwrap(), "precious");
    // A single output's lock (`generate`, `fit`).
    let input = stack(dir.path());
    let model = dir.path().join("m");
    std::os::unix::fs::symlink(&victim, dir.path().join(".m.lock")).unwrap();
    let o = fit(&input, "method1", &model, &[]);
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(msg.contains(".m.lock is a symbolic link"), "{msg}");
    assert_eq!(fs::read_to_string(&victim).unwrap(), "precious");
    assert!(!model.exists());
}

#[test]
fn slurm_time_and_memory_are_checked_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let out = dir.path().join("out");
    for (flag, value, says) in [
        ("--time", "soon", "is not a Slurm time limit"),
        ("--mem", "lots", "is not a Slurm memory size"),
    ] {
        let o = bin(&[
            "slurm",
            &spec,
            "--shards",
            "2",
            "--out",
            out.to_str().unwrap(),
            flag,
            value,
        ]);
        let msg = text(&o);
        assert_eq!(o.status.code(), Some(2), "{msg}");
        assert!(msg.contains(says), "{msg}");
        assert!(!out.exists());
    }
}

#[test]
fn jobs_that_do_not_fit_together_run_one_after_the_other_with_the_same_tables() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let o = bin(&["run", &spec, "--dry-run"]);
    // `largest job ...: 1.23 MiB peak memory`: the limit is set between one job and two.
    let line = text(&o);
    let peak = line
        .split("largest job ")
        .nth(1)
        .and_then(|l| l.split(": ").nth(1))
        .and_then(|l| l.split(" peak memory").next())
        .unwrap_or_else(|| panic!("{line}"))
        .to_string();
    let bytes = isar_clutter::run::estimate::parse_size(&peak.replace(' ', "")).unwrap();
    let limit = (bytes * 3 / 2).to_string();
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    common::run_spec(Path::new(&spec), &one, &["--no-report", "--jobs", "1"]);
    let tight = ["--no-report", "--jobs", "2", "--max-memory", &limit];
    common::run_spec(Path::new(&spec), &two, &tight);
    same_tables(&one, &two);
}

#[test]
fn a_report_of_a_damaged_manifest_is_drawn_with_allow_incomplete_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let out = dir.path().join("out");
    common::run_spec(Path::new(&spec), &out, &["--no-report"]);
    fs::write(out.join("manifest.json"), "{ damaged").unwrap();
    let o = bin(&["report", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let o = bin(&["report", out.to_str().unwrap(), "--allow-incomplete"]);
    assert!(o.status.success(), "{}", text(&o));
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("manifest.json could not be read"), "{html}");
    assert!(html.contains("summary"), "the tables are still shown");
}

/// Runs `command` (a shell line, `{d}` the mount point) with a 1 MiB tmpfs mounted at `{d}` in
/// a mount namespace of its own; `None` where `unshare` cannot make one (skipped).
fn on_a_small_disk(dir: &Path, command: &str) -> Option<std::process::Output> {
    let disk = dir.join("disk");
    fs::create_dir(&disk).unwrap();
    let script = format!(
        "mount -t tmpfs -o size=1m tmpfs '{d}' || exit 77; {}; s=$?; ls -A '{d}'; exit $s",
        command.replace("{d}", &disk.display().to_string()),
        d = disk.display()
    );
    let o = std::process::Command::new("unshare")
        .args(["-rm", "sh", "-c", &script])
        .output()
        .ok()?;
    if o.status.code() == Some(77) || text(&o).contains("unshare:") {
        eprintln!("skipped: no mount namespace with a tmpfs here (unshare -rm)");
        return None;
    }
    Some(o)
}

#[test]
fn outputs_larger_than_the_free_disk_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    // 400 saved samples of 64 x 64: a 13 MB stack on a 1 MiB file system.
    let spec = dir.path().join("full.yaml");
    fs::write(
        &spec,
        "name: full\nseed: 1\ndatasets:\n  - {id: a, kind: filtered_noise, family: \
         exponential, alpha_h: 1, alpha_v: 1, size: [64, 64], samples: 10}\nanalysis:\n  \
         levels: 1\nsynthesis:\n  methods: [uncorrelated]\n  samples: 400\n  save_samples: \
         true\n",
    )
    .unwrap();
    let bin = common::BIN;
    let run = format!(
        "'{bin}' run '{}' --no-report --out '{{d}}/out'",
        spec.display()
    );
    let Some(o) = on_a_small_disk(dir.path(), &run) else {
        return;
    };
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(
        msg.contains("the outputs need about 14 MB on disk, more than the 1 MB free")
            && msg.contains("nothing was written"),
        "{msg}"
    );
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        "",
        "the disk stays empty"
    );
    // `validate` checks the default folder, `outputs/full` under the working directory.
    fs::remove_dir(dir.path().join("disk")).unwrap();
    let validate = format!("cd '{{d}}' && '{bin}' validate '{}' >&2", spec.display());
    let o = on_a_small_disk(dir.path(), &validate).unwrap();
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(
        msg.contains("full.yaml: `run` would refuse it: the outputs need about 14 MB on disk"),
        "{msg}"
    );
    // `generate` of 20000 samples of 8 x 8 (10 MB) into the same kind of disk.
    let input = stack(dir.path());
    let model = dir.path().join("m");
    let o = fit(&input, "uncorrelated", &model, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let generate = format!(
        "'{bin}' generate --model '{}' --samples 20000 --seed 1 --out '{{d}}/x.npy'",
        model.display()
    );
    fs::remove_dir(dir.path().join("disk")).unwrap();
    let o = on_a_small_disk(dir.path(), &generate).unwrap();
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(
        msg.contains("the 20000 samples (--samples) need about 9.77 MiB on disk, more than the")
            && msg.contains("nothing was written"),
        "{msg}"
    );
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        "",
        "the disk stays empty"
    );
}
