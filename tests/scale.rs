//! Scale: the peak memory of `run` and of `merge` does not grow with the number of jobs. Two
//! sweeps of tiny jobs, 300 and 1,200, both past one Parquet row group in their largest tables
//! (which is what the streaming assembly holds at most), run and merged; the peak RSS of the
//! larger is compared with the smaller's as a ratio (no timing). Before the tables were
//! streamed, memory grew by about 550 KB a job: the ratio was about 3.
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_isar-clutter");

/// A sweep of `n` tiny jobs (filtered noise 32 x 32, 50 samples, levels 2: 960 rows of
/// `analysis_maps` and 1,024 of `pixel_stats` a job), without map files.
fn spec(dir: &Path, n: usize) -> PathBuf {
    spec_with(dir, n, false)
}

/// [`spec`], with the default map files when `maps`.
fn spec_with(dir: &Path, n: usize, maps: bool) -> PathBuf {
    let values: Vec<String> = (0..n)
        .map(|i| format!("{:.4}", 1.0 + i as f64 * 1e-4))
        .collect();
    let path = dir.join(format!("tiny{n}.yaml"));
    fs::write(
        &path,
        format!(
            "name: tiny{n}\nseed: 7\ndatasets:\n  - id: t\n    kind: filtered_noise\n    \
             family: exponential\n    alpha_h: 1.0\n    alpha_v: 1.0\n    size: [32, 32]\n    \
             samples: 50\n    half_width: 4\nanalysis:\n  levels: 2\noutputs:\n  npy_maps: {maps}\n\
             sweep:\n  zip:\n    datasets.t.alpha_h: [{}]\n",
            values.join(", ")
        ),
    )
    .unwrap();
    path
}

/// Runs the tool with `args` and returns its peak resident set in bytes (`wait4`'s rusage of
/// that child alone; the child is reaped by that `wait4`, not by `Child::wait`). Linux counts
/// in it this test process's memory at the fork, a few MB here, far below the tool's.
#[allow(clippy::zombie_processes)]
fn peak_rss(args: &[&str]) -> u64 {
    let child = Command::new(BIN)
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: a zeroed rusage is a valid value to be filled.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our child, not waited for yet; both pointers are valid.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(r, pid, "wait4 failed");
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "{args:?} failed: {status}"
    );
    // Linux reports kilobytes.
    usage.ru_maxrss as u64 * 1024
}

#[test]
fn peak_memory_of_run_and_merge_does_not_grow_with_the_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let mut peaks = vec![];
    for n in [300, 1200] {
        let spec = spec(dir.path(), n);
        let out = dir.path().join(format!("out{n}"));
        let (s, o) = (spec.to_str().unwrap(), out.to_str().unwrap());
        let run = peak_rss(&["run", s, "--out", o, "--no-report", "-q", "--jobs", "2"]);
        let merge = peak_rss(&["merge", o, "--no-report", "-q", "--jobs", "2"]);
        peaks.push((n, run, merge));
    }
    let (small, large) = (peaks[0], peaks[1]);
    let mb = |b: u64| b as f64 / 1e6;
    for (what, a, b) in [("run", small.1, large.1), ("merge", small.2, large.2)] {
        let ratio = b as f64 / a as f64;
        assert!(
            ratio < 1.3,
            "{what}: peak RSS {:.0} MB for {} jobs against {:.0} MB for {} (ratio {ratio:.2})",
            mb(b),
            large.0,
            mb(a),
            small.0
        );
    }
}

/// Regular files under `dir` (not the tool's state; a file with two names counts twice) and
/// the bytes they take on disk (once per file).
fn census(dir: &Path) -> (u64, u64) {
    census_in(dir, &mut std::collections::HashSet::new())
}

fn census_in(dir: &Path, inodes: &mut std::collections::HashSet<u64>) -> (u64, u64) {
    use std::os::unix::fs::MetadataExt;
    let (mut files, mut bytes) = (0, 0);
    for e in fs::read_dir(dir).unwrap().flatten() {
        let path = e.path();
        if e.file_name() == ".isar-clutter" {
            continue;
        }
        let m = fs::symlink_metadata(&path).unwrap();
        if m.is_dir() {
            let (f, b) = census_in(&path, inodes);
            files += f;
            bytes += b;
        } else {
            files += 1;
            if inodes.insert(m.ino()) {
                bytes += m.blocks() * 512;
            }
        }
    }
    (files, bytes)
}

/// `validate`'s footprint of a sweep: the files exactly (each map named twice, in the store
/// and the folder, and one pack a job, without a folder where the job has no maps), and the bytes on disk within a factor of 1.5 either
/// way, with and without maps.
#[test]
fn the_footprint_validate_prints_is_what_the_run_writes() {
    let dir = tempfile::tempdir().unwrap();
    for maps in [true, false] {
        let spec = spec_with(dir.path(), 40, maps);
        let out = dir.path().join(format!("out{maps}"));
        let plan = isar_clutter::run::plan::load(&spec).unwrap();
        let f = isar_clutter::run::estimate::footprint(&plan, 40);
        let o = Command::new(BIN)
            .args([
                "run",
                spec.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .args(["--no-report", "-q"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (files, bytes) = census(&out);
        // The tables and the manifest besides the jobs' files.
        let tables = fs::read_dir(&out)
            .unwrap()
            .flatten()
            .filter(|e| e.path().is_file())
            .count() as u64;
        assert_eq!(f.files as u64, files - tables, "maps {maps}");
        if !maps {
            // A job without files is one entry in the store, its pack: no folder of its own,
            // the packs spread over folders named by their keys' first two digits.
            let mut packs = 0;
            for e in fs::read_dir(out.join("jobs")).unwrap().flatten() {
                if !e.path().is_dir() {
                    continue;
                }
                let fan = e.file_name().into_string().unwrap();
                assert_eq!(fan.len(), 2, "a job folder: {fan}");
                for p in fs::read_dir(e.path()).unwrap().flatten() {
                    let name = p.file_name().into_string().unwrap();
                    assert!(name.starts_with(&fan) && name.ends_with(".pack"), "{name}");
                    packs += 1;
                }
            }
            assert_eq!(packs, 40);
        }
        let estimated = f.tables + f.maps + f.store;
        let ratio = estimated / bytes as f64;
        assert!(
            (1.0 / 1.5..1.5).contains(&ratio),
            "maps {maps}: estimated {estimated:.0} bytes, {bytes} on disk"
        );
        // What validate prints.
        let o = Command::new(BIN)
            .args(["validate", spec.to_str().unwrap()])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            text.contains(&format!("{:.0} files", f.files)) && text.contains("outputs: about"),
            "{text}"
        );
    }
}
