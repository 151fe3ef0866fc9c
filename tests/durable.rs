//! Durable runs (issue 15): every finished job is in the job store, so a run killed at any
//! moment resumes with the same tables; shards run subsets and `merge` assembles the same
//! tables as one local run; bad shard arguments and merges are refused clearly.

mod common;
use common::{bin, maps, run_output, same_tables, text, BIN};

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// 24 jobs: four datasets under a 6-value sweep, about 0.1-0.3 s each on one thread.
const SPEC: &str = "name: durable
seed: 5
datasets:
  - id: a
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 0.5
    size: [32, 32]
    samples: 400
    half_width: 4
  - id: b
    kind: filtered_noise
    family: exponential
    alpha_h: 2.0
    alpha_v: 1.0
    size: [32, 32]
    samples: 400
    half_width: 4
  - id: c
    kind: filtered_noise
    family: exponential
    alpha_h: 0.5
    alpha_v: 2.0
    size: [32, 32]
    samples: 400
    half_width: 4
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.5
    alpha_v: 1.5
    size: [32, 32]
    samples: 400
    half_width: 4
analysis:
  levels: 2
sweep:
  grid:
    datasets.*.mean: [0, 1, 2, 3, 4, 5]
";

fn spec(dir: &Path) -> PathBuf {
    let p = dir.join("spec.yaml");
    fs::write(&p, SPEC).unwrap();
    p
}

/// `run SPEC --out OUT --no-report --quiet` plus `extra`.
fn run(spec: &Path, out: &Path, extra: &[&str]) -> Output {
    run_output(spec, out, &[&["--no-report"], extra].concat())
}

fn done_records(out: &Path) -> usize {
    fs::read_dir(out.join("jobs"))
        .map(|r| {
            r.flatten()
                .map(|e| {
                    let p = e.path();
                    if p.join("job.pack").is_file() {
                        1
                    } else if p.is_dir() && e.file_name().len() == 2 {
                        // Packs of jobs without files, by their keys' first two digits.
                        fs::read_dir(&p).map_or(0, |r| r.flatten().count())
                    } else {
                        0
                    }
                })
                .sum()
        })
        .unwrap_or(0)
}

#[test]
fn a_run_killed_half_way_resumes_to_the_same_tables() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let whole = dir.path().join("whole");
    let o = run(&spec, &whole, &["--jobs", "1"]);
    assert!(o.status.success(), "{}", text(&o));
    // The same run, killed (SIGKILL) once about half of its jobs are in the store.
    let out = dir.path().join("killed");
    let mut child = Command::new(BIN)
        .args([
            "run",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--no-report", "--quiet", "--jobs", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while done_records(&out) < 12 {
        assert!(
            t.elapsed() < Duration::from_secs(120),
            "the run never got half-way"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = done_records(&out);
    assert!((12..24).contains(&before), "{before} jobs done at the kill");
    assert!(!out.join("manifest.json").exists());
    // The rerun skips what the store holds and ends with the same tables and maps.
    let o = run(&spec, &out, &["--jobs", "1"]);
    assert!(o.status.success(), "{}", text(&o));
    let msg = text(&o);
    assert!(
        msg.contains(&format!("{before} job(s) already done")),
        "{msg}"
    );
    same_tables(&out, &whole);
    assert_eq!(maps(&out), maps(&whole));
    // A third run has nothing to do; --fresh redoes everything, with the same tables.
    let o = run(&spec, &out, &[]);
    assert!(text(&o).contains("24 job(s) already done"), "{}", text(&o));
    let o = run(&spec, &out, &["--fresh"]);
    assert!(
        o.status.success() && !text(&o).contains("already done"),
        "{}",
        text(&o)
    );
    same_tables(&out, &whole);
}

#[test]
fn three_shards_and_a_merge_equal_one_local_run() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let local = dir.path().join("local");
    assert!(run(&spec, &local, &[]).status.success());
    let out = dir.path().join("sharded");
    // Shards 0 and 2 (the second from the environment, as a Slurm array task would).
    let o = run(&spec, &out, &["--shards", "3", "--shard", "0"]);
    assert!(o.status.success(), "{}", text(&o));
    let o = Command::new(BIN)
        .args([
            "run",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--no-report", "--quiet", "--shards", "3"])
        .env("SLURM_ARRAY_TASK_ID", "2")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        !out.join("manifest.json").exists(),
        "a shard writes no tables"
    );
    // Shard 1 is missing: merge refuses and names its jobs; status shows them.
    let o = bin(&["merge", out.to_str().unwrap(), "--no-report"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let msg = text(&o);
    assert!(msg.contains("lacks") && msg.contains("job(s): "), "{msg}");
    let status = text(&bin(&["status", out.to_str().unwrap()]));
    let missing: Vec<&str> = status
        .lines()
        .filter(|l| l.contains(" missing"))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|id| *id != "shard")
        .collect();
    assert!(!missing.is_empty(), "{status}");
    for id in &missing {
        assert!(msg.contains(id), "merge did not name {id}: {msg}");
    }
    assert!(status.contains("shard 1/3: 0 done"), "{status}");
    // The shards are balanced: each has some jobs.
    for s in 0..3 {
        assert!(
            !status.contains(&format!("shard {s}/3: 0 done, 0 failed, 0 missing")),
            "{status}"
        );
    }
    let o = run(&spec, &out, &["--shards", "3", "--shard", "1"]);
    assert!(o.status.success(), "{}", text(&o));
    let o = bin(&["merge", out.to_str().unwrap(), "--no-report"]);
    assert!(o.status.success(), "{}", text(&o));
    same_tables(&out, &local);
    assert_eq!(maps(&out), maps(&local));
    assert!(bin(&["table", out.to_str().unwrap()]).status.success());
}

#[test]
fn bad_shards_and_merges_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let out = dir.path().join("out");
    for (args, needle) in [
        (
            vec!["--shards", "3", "--shard", "3"],
            "not below --shards 3",
        ),
        (vec!["--shards", "0", "--shard", "0"], "at least 1"),
        (vec!["--shards", "2"], "--shards without --shard"),
    ] {
        let o = Command::new(BIN)
            .args([
                "run",
                spec.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .args(&args)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        assert!(text(&o).contains(needle), "{args:?}: {}", text(&o));
    }
    assert!(!out.exists(), "a refused shard wrote something");
    // merge on a folder that holds no run, and on one whose spec changed since.
    let o = bin(&["merge", dir.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("plan.json"), "{}", text(&o));
    assert!(run(&spec, &out, &["--shards", "2", "--shard", "0"])
        .status
        .success());
    fs::write(&spec, SPEC.replace("seed: 5", "seed: 6")).unwrap();
    let o = bin(&["merge", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("changed since the jobs"), "{}", text(&o));
    // A record of another schema version is not merged: the job counts as missing.
    fs::write(&spec, SPEC).unwrap();
    let record = out.join(".isar-clutter/plan.json");
    let text_record = fs::read_to_string(&record).unwrap();
    fs::write(
        &record,
        text_record.replace(
            &format!("\"schema\": {}", isar_clutter::run::store::SCHEMA),
            "\"schema\": 99",
        ),
    )
    .unwrap();
    let o = bin(&["merge", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("schema 99"), "{}", text(&o));
}

#[test]
fn a_live_shard_blocks_a_merge_and_a_partial_merge_stays_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("spec.yaml");
    // Heavier jobs (about half a second each on one thread): the shard is still running when
    // the merge and the whole run try the folder.
    fs::write(&spec, SPEC.replace("samples: 400", "samples: 3000")).unwrap();
    let out = dir.path().join("out");
    let mut shard = Command::new(BIN)
        .args([
            "run",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args([
            "--no-report",
            "--quiet",
            "--jobs",
            "1",
            "--shards",
            "2",
            "--shard",
            "0",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t = Instant::now();
    // The shard holds its lock and has recorded its spec: it is running jobs.
    while !(out.join(".isar-clutter/lock.shard-0").exists()
        && out.join(".isar-clutter/plan.json").exists())
    {
        assert!(t.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(2));
    }
    let o = bin(&["merge", out.to_str().unwrap(), "--partial", "--no-report"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("shard") && text(&o).contains("still running"),
        "{}",
        text(&o)
    );
    let o = run(&spec, &out, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("still running"), "{}", text(&o));
    assert!(shard.wait().unwrap().success());
    // Shard 1 never ran: a partial merge writes the tables, lists its jobs as failed and
    // leaves the folder marked incomplete.
    let o = bin(&["merge", out.to_str().unwrap(), "--partial", "--no-report"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("missing from the job store"),
        "{}",
        text(&o)
    );
    let o = bin(&["table", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("incomplete: merged with --partial while"),
        "{}",
        text(&o)
    );
    assert!(bin(&["table", out.to_str().unwrap(), "--allow-incomplete"])
        .status
        .success());
    // Once shard 1 ran, a merge completes the folder.
    assert!(run(&spec, &out, &["--shards", "2", "--shard", "1"])
        .status
        .success());
    assert!(bin(&["merge", out.to_str().unwrap(), "--no-report"])
        .status
        .success());
    assert!(bin(&["table", out.to_str().unwrap()]).status.success());
}

/// The output folder remembers its inputs' hashes (`jobs/input-hashes.json`) so that a resumed
/// run does not re-read them, and the memo never hides a change: an input rewritten in place
/// with the same size (and, on a coarse clock, the same modification time) runs its job again.
#[test]
fn the_input_hash_memo_never_hides_a_changed_input() {
    use ndarray_npy::WriteNpyExt;
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("s.npy");
    let stack = ndarray::Array3::from_shape_fn((20, 8, 8), |(n, r, c)| {
        num_complex::Complex::new((n * 7 + r * 3 + c) as f32, r as f32)
    });
    stack.write_npy(fs::File::create(&data).unwrap()).unwrap();
    let spec = dir.path().join("spec.yaml");
    fs::write(
        &spec,
        format!("name: memo\nseed: 1\ndatasets:\n  - id: d\n    kind: npy\n    path: {}\nanalysis:\n  levels: 2\n", data.display()),
    )
    .unwrap();
    let out = dir.path().join("out");
    let run = || {
        bin(&[
            "run",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-report",
        ])
    };
    // Older than a second: its hash may be remembered.
    std::thread::sleep(Duration::from_millis(1100));
    let o = run();
    assert!(o.status.success(), "{}", text(&o));
    let memo = fs::read_to_string(out.join("jobs/input-hashes.json")).unwrap();
    assert!(memo.contains("s.npy"), "{memo}");
    let o = run();
    assert!(text(&o).contains("1 job(s) already done"), "{}", text(&o));
    // The same size, other values.
    let mut changed = stack.clone();
    changed[[3, 2, 1]] = num_complex::Complex::new(-1.0, 5.0);
    changed.write_npy(fs::File::create(&data).unwrap()).unwrap();
    let o = run();
    assert!(
        o.status.success() && !text(&o).contains("already done"),
        "{}",
        text(&o)
    );
}

/// A stored result that another build of the tool computed is merged as it is (the store's keys
/// do not hold the tool's version), and the merge says so, naming that build; the manifest
/// records the build that computed each job (`computed_by`). The other build is made by
/// rewriting one job's pack record (and its hash) as an older build would have written it.
#[test]
fn results_of_another_build_are_merged_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path());
    let out = dir.path().join("out");
    let o = run(&spec, &out, &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains("different build"), "{}", text(&o));
    let jobs = |out: &Path| -> Vec<serde_json::Value> {
        let m: serde_json::Value =
            serde_json::from_slice(&fs::read(out.join("manifest.json")).unwrap()).unwrap();
        m["jobs"].as_array().unwrap().clone()
    };
    let this = jobs(&out)[0]["computed_by"].as_str().unwrap().to_string();
    assert!(jobs(&out).iter().all(|j| j["computed_by"] == this.as_str()));
    // One pack as an older build wrote it: header (magic, record length, XXH3-128 of the
    // body), then the record (JSON) and the fragments.
    // A job's folder holds `job.pack`; a job without files has its pack in a folder named
    // by its key's first two digits.
    let pack = fs::read_dir(out.join("jobs"))
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_dir())
        .flat_map(|e| fs::read_dir(e.path()).unwrap().flatten())
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "pack"))
        .unwrap();
    let bytes = fs::read(&pack).unwrap();
    let len = u64::from_le_bytes(bytes[8..16].try_into().unwrap()) as usize;
    let body = &bytes[32..];
    let mut record: serde_json::Value = serde_json::from_slice(&body[..len]).unwrap();
    let id = record["id"].as_str().unwrap().to_string();
    record["built_by"] = "0123abc (an older build)".into();
    let mut new_body = serde_json::to_vec(&record).unwrap();
    new_body.extend_from_slice(&body[len..]);
    let mut new = bytes[..8].to_vec();
    new.extend_from_slice(&(new_body.len() - (body.len() - len)).to_le_bytes()[..8]);
    new.extend_from_slice(&xxhash_rust::xxh3::xxh3_128(&new_body).to_le_bytes());
    new.extend_from_slice(&new_body);
    fs::write(&pack, new).unwrap();
    let o = bin(&["merge", out.to_str().unwrap(), "--no-report"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains(
            "1 job(s) were merged from results a different build of the tool computed \
             (first: 0123abc (an older build)"
        ),
        "{}",
        text(&o)
    );
    let entry = jobs(&out)
        .into_iter()
        .find(|j| j["job"] == id.as_str())
        .unwrap();
    assert_eq!(entry["computed_by"], "0123abc (an older build)");
}
