//! An estimate for every size: every numeric key of the spec schema is listed in
//! [`cases::CASES`] (the schema is walked through the spec's own errors, [`schema`], so a key
//! added and forgotten fails here), and each is set, one at a time, to an absurd value in a
//! small valid spec (10^12, and `u64::MAX` for an integer): a key that scales memory or work
//! must be refused by `validate` with an error naming its YAML path (and `run` must not
//! succeed), and neither `validate` nor `run` may abort, panic or run on for a minute for any
//! key. The table of what each absurd value gives is printed (`--nocapture`). The shipped
//! experiments are checked to stay far below the ceiling of work.

mod cases;
mod schema;

use cases::{matches, Case, Expect, CASES};
use isar_clutter::run::plan;
use schema::{set, Base};
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Longest a `run` of a case may take (a few seconds at most when nothing absurd runs).
const RUN_TIMEOUT: Duration = Duration::from_secs(60);

fn valid_bases(root: &Path) -> Vec<Base> {
    let bases = cases::bases(root);
    for b in &bases {
        let file = b.write("base", &b.doc);
        if let Err(e) = plan::load(&file) {
            panic!("base {} must be valid: {e}", b.name);
        }
    }
    bases
}

#[test]
fn every_numeric_key_of_the_schema_is_listed() {
    let root = tempfile::tempdir().unwrap();
    let bases = valid_bases(root.path());
    let keys = schema::numeric_keys(&bases);
    eprintln!("{} numeric keys:\n  {}", keys.len(), {
        let k: Vec<&str> = keys.iter().map(String::as_str).collect();
        k.join("\n  ")
    });
    let missing: Vec<&String> = keys
        .iter()
        .filter(|k| !CASES.iter().any(|c| matches(c.key, k)))
        .collect();
    let stale: Vec<&str> = CASES
        .iter()
        .filter(|c| !keys.iter().any(|k| matches(c.key, k)))
        .map(|c| c.key)
        .collect();
    assert!(
        missing.is_empty(),
        "numeric keys without a case in tests/estimate_every_key/cases.rs (does each scale memory or work?): {missing:?}"
    );
    assert!(
        stale.is_empty(),
        "cases of keys the schema lacks: {stale:?}"
    );
    // Keys known to scale memory or work must be among those found (the walk itself works).
    for key in [
        "calibration.points",
        "hypotheses.max_offset",
        "datasets[].scene.plant.branches_per_stem",
        "classification.training.epochs",
        "datasets[].size[]",
        "classification.train_sizes[]",
    ] {
        assert!(keys.contains(key), "{key} not found by the walk");
    }
}

/// What one command gave.
struct Ran {
    status: ExitStatus,
    stderr: String,
    seconds: f64,
}

/// Runs `cmd` with its output in files under `dir`, killing it after `timeout`.
fn run_with_timeout(mut cmd: Command, dir: &Path, tag: &str, timeout: Duration) -> Ran {
    let err_path = dir.join(format!("{tag}.stderr"));
    let t = Instant::now();
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > timeout {
            child.kill().unwrap();
            let status = child.wait().unwrap();
            return Ran {
                status,
                stderr: format!("still running after {timeout:?}: killed by the test"),
                seconds: t.elapsed().as_secs_f64(),
            };
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Ran {
        status,
        stderr: std::fs::read_to_string(&err_path).unwrap_or_default(),
        seconds: t.elapsed().as_secs_f64(),
    }
}

/// How a command ended, for the table and the checks: its exit code, or why it crashed.
fn ending(r: &Ran) -> Result<i32, String> {
    if let Some(sig) = r.status.signal() {
        return Err(format!("killed by signal {sig}: {}", r.stderr.trim()));
    }
    if r.stderr.contains("panicked") || r.stderr.contains("panic") {
        return Err(format!("panicked: {}", r.stderr.trim()));
    }
    match r.status.code() {
        Some(c @ 0..=2) => Ok(c),
        other => Err(format!("exit {other:?}: {}", r.stderr.trim())),
    }
}

/// The first line of an error, shortened.
fn first_line(text: &str) -> String {
    let line = text
        .lines()
        .find(|l| l.starts_with("error:") || l.contains("failed:"))
        .unwrap_or("")
        .trim();
    let line = line.strip_prefix("error: ").unwrap_or(line);
    // The spec's folder is a temporary one: `case12.yaml: ...` is enough.
    let line = match (line.find('/'), line.find(".yaml: ")) {
        (Some(a), Some(b)) if a < b => {
            let name = line[..b].rsplit('/').next().unwrap_or("");
            format!("{}{name}{}", &line[..a], &line[b..])
        }
        _ => line.to_string(),
    };
    let line = line.as_str();
    let short: String = line.chars().take(230).collect();
    if short.len() < line.len() {
        format!("{short}...")
    } else {
        short
    }
}

/// Sets the case's value in its base, runs `validate` and `run`; the table's line, or the
/// reasons it fails.
fn check_case(i: usize, case: &Case, bases: &[Base], out: &Path) -> Result<String, String> {
    let base = bases.iter().find(|b| b.name == case.base).unwrap();
    let mut doc = base.doc.clone();
    set(
        &mut doc,
        case.set,
        serde_yaml_ng::from_str(case.value).unwrap(),
    );
    let name = format!("case{i}");
    let spec = base.write(&name, &doc);
    let bin = env!("CARGO_BIN_EXE_isar-clutter");
    let mut validate = Command::new(bin);
    validate.arg("validate").arg(&spec);
    let v = run_with_timeout(validate, out, &format!("{name}.validate"), RUN_TIMEOUT);
    let mut run = Command::new(bin);
    run.arg("run")
        .arg(&spec)
        .arg("--out")
        .arg(out.join(&name))
        .args(["--quiet", "--no-report", "--jobs", "1"]);
    let r = run_with_timeout(run, out, &format!("{name}.run"), RUN_TIMEOUT);
    let what = format!("{} = {} ({})", case.set, case.value, case.base);
    let (v_code, r_code) = match (ending(&v), ending(&r)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) => return Err(format!("{what}: validate {e}")),
        (_, Err(e)) => return Err(format!("{what}: run {e}")),
    };
    let validated = if v_code == 0 {
        "accepted".to_string()
    } else {
        format!("refused: {}", first_line(&v.stderr))
    };
    let ran = match r_code {
        0 => format!("run ok ({:.1} s)", r.seconds),
        c => format!("run exit {c}: {}", first_line(&r.stderr)),
    };
    if let Expect::Refused(at) = case.expect {
        let at = if at.is_empty() { case.set } else { at };
        let named = v.stderr.contains(&format!(".yaml: {at}:"))
            || v.stderr.contains(&format!(".yaml: {at} (line"));
        if v_code != 2 || !named {
            return Err(format!(
                "{what} scales memory or work: validate must refuse it at {at}; it gave exit {v_code}: {}",
                v.stderr.trim()
            ));
        }
        if r_code == 0 {
            return Err(format!("{what}: run must not succeed"));
        }
    }
    let kind = match case.expect {
        Expect::Refused(_) => "size".to_string(),
        Expect::Value(why) => format!("value: {why}"),
    };
    Ok(format!(
        "{} [{kind}]\n    {what}\n    validate {validated}\n    {ran}",
        case.key
    ))
}

#[test]
fn an_absurd_value_of_every_size_is_refused_and_nothing_crashes() {
    let root = tempfile::tempdir().unwrap();
    let bases = valid_bases(root.path());
    let out = root.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    // Every case, and an integer size once more at the largest integer a key takes (where an
    // unchecked `n + 1` or `a * b` would wrap around).
    let walk: Vec<Case> = CASES
        .iter()
        .flat_map(|c| {
            let max = (c.value == cases::BIG).then_some(Case {
                value: cases::MAX,
                ..*c
            });
            std::iter::once(*c).chain(max)
        })
        .collect();
    let next = AtomicUsize::new(0);
    let t = Instant::now();
    let mut results: Vec<(usize, Result<String, String>)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                s.spawn(|| {
                    let mut done = vec![];
                    loop {
                        let i = next.fetch_add(1, Ordering::SeqCst);
                        let Some(case) = walk.get(i) else {
                            return done;
                        };
                        done.push((i, check_case(i, case, &bases, &out)));
                    }
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().unwrap())
            .collect()
    });
    results.sort_by_key(|(i, _)| *i);
    let mut table = vec![];
    let mut failures = vec![];
    for (_, r) in results {
        match r {
            Ok(line) => table.push(line),
            Err(e) => failures.push(e),
        }
    }
    eprintln!(
        "{} keys, {} values in {:.1} s:\n{}",
        CASES.len(),
        walk.len(),
        t.elapsed().as_secs_f64(),
        table.join("\n")
    );
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn the_shipped_experiments_are_far_below_the_work_limit() {
    use isar_clutter::run::estimate::{human_bytes, MAX_FLOPS};
    use isar_clutter::run::jobs::all::AllJobs;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments");
    let mut specs: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    specs.sort();
    let mut lines = vec![];
    let mut largest = 0.0f64;
    for spec in &specs {
        let name = spec.file_name().unwrap().to_string_lossy().into_owned();
        let plan = match plan::load(spec) {
            Ok(p) => p,
            // A spec over downloaded data (`make data`) that is not there.
            Err(e) if e.path.ends_with(".path") => {
                lines.push(format!("{name}: skipped ({e})"));
                continue;
            }
            Err(e) => panic!("{e}"),
        };
        let all = AllJobs::new(&plan);
        let (mut flops, mut bytes) = (0.0f64, 0u64);
        for job in all.list() {
            let e = job.estimate(&plan);
            flops = flops.max(e.flops);
            bytes = bytes.max(e.bytes);
        }
        largest = largest.max(flops);
        lines.push(format!(
            "{name}: largest job {flops:.1e} flop, {}",
            human_bytes(bytes)
        ));
    }
    eprintln!("{}", lines.join("\n"));
    assert!(specs.len() >= 10, "{} specs", specs.len());
    assert!(
        largest < MAX_FLOPS / 1e4,
        "a shipped experiment's job is estimated at {largest:.1e} flop, too close to the limit {MAX_FLOPS:.0e}"
    );
}
