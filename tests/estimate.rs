//! Sizes are estimated before anything is allocated: `validate` and `run --dry-run` refuse a
//! sweep of too many points at once (counted, not expanded) and a job whose estimated peak
//! memory exceeds the machine's or `--max-memory`, naming the YAML path of the size furthest
//! above its usual value (or the dataset's); they print the largest job's estimate otherwise.
//! Every size key's absurd value: `tests/estimate_every_key`.

mod common;
use common::bin;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const GOOD: &str = "name: est
seed: 1
datasets:
  - id: small
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 20
analysis:
  levels: 2
";

/// A dataset of 10^6 samples of 4096 x 4096 pixels: 2.7e14 bytes as complex128.
const BIG: &str = "  - id: big
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [4096, 4096]
    samples: 1000000
";

fn write(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("spec.yaml");
    std::fs::write(&p, text).unwrap();
    p
}

fn text_of(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `GOOD` with the big dataset after the small one.
fn with_big() -> String {
    GOOD.replace("analysis:", &format!("{BIG}analysis:"))
}

#[test]
fn a_sweep_of_12_to_the_8_points_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    // Eight grid axes of twelve values: 12^8 = 429981696 points.
    let values: Vec<String> = (1..=12).map(|v| v.to_string()).collect();
    let axes: String = [
        "alpha_h",
        "alpha_v",
        "mean",
        "mean_im",
        "std",
        "texture_shape",
        "half_width",
        "samples",
    ]
    .iter()
    .map(|k| format!("    datasets.small.{k}: [{}]\n", values.join(", ")))
    .collect();
    let spec = write(dir.path(), &format!("{GOOD}sweep:\n  grid:\n{axes}"));
    let t = Instant::now();
    let o = bin(&["validate", spec.to_str().unwrap()]);
    let elapsed = t.elapsed();
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("spec.yaml: sweep: sweep gives 429981696 points"),
        "{err}"
    );
    assert!(err.contains("at most 1000000 (split the spec)"), "{err}");
    assert!(elapsed < Duration::from_secs(1), "took {elapsed:?}");
}

#[test]
fn a_sweep_whose_count_overflows_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // 2^16 values on each of four axes: 2^64 points, past usize.
    let values: Vec<String> = (0..65536).map(|v| v.to_string()).collect();
    let list = format!("[{}]", values.join(","));
    let axes: String = ["mean", "std", "mean_im", "alpha_h"]
        .iter()
        .map(|k| format!("    datasets.small.{k}: {list}\n"))
        .collect();
    let spec = write(dir.path(), &format!("{GOOD}sweep:\n  grid:\n{axes}"));
    let o = bin(&["validate", spec.to_str().unwrap()]);
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("sweep gives more than"), "{err}");
}

#[test]
fn validate_prints_the_largest_job() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write(dir.path(), GOOD);
    let o = bin(&["validate", spec.to_str().unwrap()]);
    let (out, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(out.contains("valid, 1 job(s)"), "{out}");
    assert!(out.contains("largest job small:"), "{out}");
    assert!(out.contains("peak memory") && out.contains("flop"), "{out}");
}

#[test]
fn validate_refuses_a_dataset_no_machine_holds() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write(dir.path(), &with_big());
    let t = Instant::now();
    let o = bin(&["validate", spec.to_str().unwrap()]);
    let (out, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{out}{err}");
    // At the size furthest above its usual value: 4096 x 4096 pixels are 4096 times 64 x 64,
    // 10^6 samples 1000 times 1000.
    assert!(
        err.contains("spec.yaml: datasets[1].size: job big needs about"),
        "{err}"
    );
    assert!(err.contains("TiB"), "{err}");
    assert!(
        err.contains("datasets[1].size = [4096, 4096] is 4096 times its usual value"),
        "{err}"
    );
    assert!(t.elapsed() < Duration::from_secs(5));
}

#[test]
fn max_memory_refuses_and_admits() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write(dir.path(), GOOD);
    let s = spec.to_str().unwrap();
    let o = bin(&["validate", s, "--max-memory", "1K"]);
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    // No size is above its usual value: the dataset is named.
    assert!(err.contains("datasets[0]: job small needs about"), "{err}");
    assert!(err.ends_with("make the dataset smaller\n"), "{err}");
    assert!(err.contains("--max-memory 1.00 KiB"), "{err}");
    let o = bin(&["validate", s, "--max-memory", "512M"]);
    assert_eq!(o.status.code(), Some(0), "{}", text_of(&o).1);
    let o = bin(&["validate", s, "--max-memory", "lots"]);
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("\"lots\" is not a size"), "{err}");
}

#[test]
fn dry_run_prints_the_largest_job_and_refuses_the_big_one() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write(dir.path(), GOOD);
    let o = bin(&["run", spec.to_str().unwrap(), "--dry-run"]);
    let (out, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(out.contains("largest job small:"), "{out}");
    let spec = write(dir.path(), &with_big());
    let o = bin(&["run", spec.to_str().unwrap(), "--dry-run"]);
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("datasets[1].size: job big needs about"),
        "{err}"
    );
    assert!(!dir.path().join("outputs").exists());
}

#[test]
fn a_plan_of_more_than_a_million_jobs_is_refused() {
    // 500001 sweep points (under the point limit) on a field both datasets take: 1000002 jobs.
    let dir = tempfile::tempdir().unwrap();
    let values: Vec<String> = (0..500001).map(|v| v.to_string()).collect();
    let second = GOOD
        .split("datasets:\n")
        .nth(1)
        .and_then(|t| t.split("analysis:").next())
        .unwrap()
        .replace("id: small", "id: other");
    let text = GOOD.replace("analysis:", &format!("{second}analysis:"));
    let spec = write(
        dir.path(),
        &format!(
            "{text}sweep:\n  grid:\n    datasets.*.mean: [{}]\n",
            values.join(",")
        ),
    );
    let o = bin(&["validate", spec.to_str().unwrap()]);
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("sweep: the sweep gives more than 1000000 jobs (up to 1000002"),
        "{err}"
    );
}

/// Reads a string column of a Parquet table.
fn column(path: &Path, name: &str) -> Vec<String> {
    use polars::prelude::{ParquetReader, SerReader};
    let df = ParquetReader::new(std::fs::File::open(path).unwrap())
        .finish()
        .unwrap();
    let c = df.column(name).unwrap().str().unwrap();
    (0..c.len())
        .map(|i| c.get(i).unwrap_or_default().to_string())
        .collect()
}

#[test]
fn run_fails_the_absurd_job_only_and_writes_the_good_ones_tables() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write(dir.path(), &with_big());
    let out = dir.path().join("out");
    let o = bin(&[
        "run",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("failed: big: needs about"), "{err}");
    let jobs = out.join("jobs.parquet");
    assert_eq!(column(&jobs, "job"), ["small", "big"]);
    assert_eq!(column(&jobs, "status"), ["ok", "failed"]);
    assert!(column(&jobs, "error")[1].contains("estimated before allocating"));
    let summary = column(&out.join("analysis_summary.parquet"), "dataset");
    assert!(!summary.is_empty() && summary.iter().all(|d| d == "small"));
    assert!(out.join("maps/small/mean.npy").is_file());
}

/// A job the estimate admits but whose allocation fails (the process's address space is
/// limited to 1.5 GiB, the job's stack needs 3.9 GB): that job fails, the other finishes.
#[test]
fn an_allocation_failure_fails_its_job_only() {
    use std::os::unix::process::CommandExt;
    let dir = tempfile::tempdir().unwrap();
    let spec = write(
        dir.path(),
        &GOOD.replace(
            "analysis:",
            "  - id: large\n    kind: filtered_noise\n    family: exponential\n    alpha_h: 1.0\n    alpha_v: 1.0\n    size: [64, 64]\n    samples: 60000\n    half_width: 2\nanalysis:",
        ),
    );
    let out = dir.path().join("out");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_isar-clutter"));
    cmd.args([
        "run",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
    .args(["--quiet", "--no-report", "--jobs", "1"]);
    // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: 3 << 29,
                rlim_max: 3 << 29,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let o = cmd.output().unwrap();
    let (_, err) = text_of(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("failed: large: ") && err.contains("allocate"),
        "{err}"
    );
    let jobs = out.join("jobs.parquet");
    assert_eq!(column(&jobs, "status"), ["ok", "failed"]);
    assert!(out.join("maps/small/mean.npy").is_file());
}
