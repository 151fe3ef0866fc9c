//! The report draws only what changed (issue 16, item 3): a rerun with unchanged inputs
//! leaves every figure file as it was (same inode, same modification time), a changed map
//! redraws exactly the figures drawn from it, a deleted or edited figure is drawn again (byte
//! for byte as before), a user's own files in `figures/` are never touched, `run --no-report`
//! still removes the tool's old figures, and the files do not depend on the thread count.

mod common;

use common::bin;
use common::run_spec as run;
use std::collections::BTreeMap;
use std::fs;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::Output;

const SPEC: &str = "name: report_cache
seed: 5
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 40
    half_width: 3
analysis:
  levels: 2
sweep:
  grid:
    datasets.d.alpha_v: [0.5, 2.0]
";

/// The figures of each job of [`SPEC`] (relative to `figures/<job>/`, without extension).
const JOB_FIGURES: [&str; 7] = [
    "correlation",
    "histogram_level1",
    "histogram_level2",
    "expected_correlation",
    "covariance",
    "mean",
    "variance",
];

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn setup(dir: &Path) -> (PathBuf, PathBuf) {
    let spec = dir.join("spec.yaml");
    fs::write(&spec, SPEC).unwrap();
    let out = dir.join("out");
    run(&spec, &out, &[]);
    (spec, out)
}

/// Every file under `figures/`: (inode, modification time in ns, bytes).
fn snapshot(out: &Path) -> BTreeMap<PathBuf, (u64, i64, Vec<u8>)> {
    fn walk(root: &Path, dir: &Path, into: &mut BTreeMap<PathBuf, (u64, i64, Vec<u8>)>) {
        for e in fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, into);
            } else {
                let m = fs::metadata(&p).unwrap();
                let ns = m.mtime() * 1_000_000_000 + m.mtime_nsec();
                let rel = p.strip_prefix(root).unwrap().to_path_buf();
                into.insert(rel, (m.ino(), ns, fs::read(&p).unwrap()));
            }
        }
    }
    let mut out_map = BTreeMap::new();
    walk(out, &out.join("figures"), &mut out_map);
    out_map
}

/// The job ids of the run, from its per-job figure folders.
fn jobs(out: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(out.join("figures"))
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn drawn(out: &Path) -> Vec<String> {
    isar_clutter::report::build(out, false).unwrap().drawn
}

#[test]
fn a_rerun_with_unchanged_inputs_redraws_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (spec, out) = setup(dir.path());
    let jobs = jobs(&out);
    assert_eq!(jobs.len(), 2, "{jobs:?}");
    let before = snapshot(&out);
    // Every figure of both jobs (PNG and SVG) and the sweep's curves.
    assert!(
        before.len() > 2 * 2 * JOB_FIGURES.len(),
        "{:?}",
        before.keys()
    );
    run(&spec, &out, &[]);
    assert_eq!(snapshot(&out), before, "a rerun rewrote figures");
    ok(&bin(&["report", out.to_str().unwrap()]));
    assert_eq!(snapshot(&out), before, "`report` rewrote figures");
    assert_eq!(drawn(&out), Vec::<String>::new());
    assert!(out.join("report.html").is_file());
}

#[test]
fn a_changed_map_redraws_exactly_the_figures_drawn_from_it() {
    use ndarray_npy::{ReadNpyExt, WriteNpyExt};
    let dir = tempfile::tempdir().unwrap();
    let (_, out) = setup(dir.path());
    let job = &jobs(&out)[0];
    let before = snapshot(&out);
    // The variance map changes (same size, so the folder still matches its manifest).
    let path = out.join("maps").join(job).join("variance.npy");
    let mut v = ndarray::Array2::<f64>::read_npy(fs::File::open(&path).unwrap()).unwrap();
    v[[3, 4]] *= 3.0;
    v.write_npy(fs::File::create(&path).unwrap()).unwrap();
    assert_eq!(drawn(&out), vec![format!("figures/{job}/variance")]);
    let after = snapshot(&out);
    for (rel, file) in &before {
        let changed = after[rel] != *file;
        let expected = rel
            .to_string_lossy()
            .starts_with(&format!("figures/{job}/variance."));
        assert_eq!(changed, expected, "{}", rel.display());
    }
}

#[test]
fn a_deleted_or_edited_figure_is_drawn_again_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let (_, out) = setup(dir.path());
    let job = &jobs(&out)[1];
    let before = snapshot(&out);
    let figures = out.join("figures").join(job);
    fs::remove_file(figures.join("mean.png")).unwrap();
    let mut svg = fs::read(figures.join("correlation.svg")).unwrap();
    svg.extend_from_slice(b"<!-- my note -->");
    fs::write(figures.join("correlation.svg"), svg).unwrap();
    assert_eq!(
        drawn(&out),
        vec![
            format!("figures/{job}/correlation"),
            format!("figures/{job}/mean")
        ]
    );
    let after = snapshot(&out);
    for (rel, (_, _, bytes)) in &before {
        assert_eq!(&after[rel].2, bytes, "{} differs", rel.display());
    }
    // The other figures were not written again.
    let same_file = |rel: &Path| after[rel].0 == before[rel].0 && after[rel].1 == before[rel].1;
    assert!(same_file(&PathBuf::from(format!(
        "figures/{job}/variance.png"
    ))));
    assert!(!same_file(&PathBuf::from(format!(
        "figures/{job}/mean.png"
    ))));
}

#[test]
fn a_users_own_files_in_figures_are_never_touched() {
    let dir = tempfile::tempdir().unwrap();
    let (spec, out) = setup(dir.path());
    let job = &jobs(&out)[0];
    let mine = [
        out.join("figures").join("poster.png"),
        out.join("figures").join(job).join("annotated.svg"),
    ];
    for m in &mine {
        fs::write(m, b"mine").unwrap();
    }
    let check = |when: &str| {
        for m in &mine {
            assert_eq!(fs::read(m).unwrap(), b"mine", "{when}: {}", m.display());
        }
    };
    run(&spec, &out, &[]);
    check("rerun");
    // A spec with another sweep: one job goes (its figures with it), one comes.
    fs::write(&spec, SPEC.replace("[0.5, 2.0]", "[0.5, 1.5]")).unwrap();
    run(&spec, &out, &[]);
    check("changed spec");
    assert!(out.join("figures").join(job).join("mean.png").is_file());
    // Without a report the tool's figures go, the user's stay.
    run(&spec, &out, &["--no-report"]);
    check("--no-report");
    assert!(!out.join("figures").join(job).join("mean.png").exists());
    assert!(!out.join("report.html").exists());
    // And the next report draws them all again.
    ok(&bin(&["report", out.to_str().unwrap()]));
    check("report");
    assert!(out.join("figures").join(job).join("mean.png").is_file());
}

#[test]
fn figures_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let (_, out) = setup(dir.path());
    let sidecar = out.join(".isar-clutter/figures.json");
    let mut drawn_by = vec![];
    for jobs in ["1", "2", "3"] {
        fs::remove_file(&sidecar).unwrap(); // everything is drawn again
        ok(&bin(&["report", out.to_str().unwrap(), "--jobs", jobs]));
        let files: BTreeMap<PathBuf, Vec<u8>> = snapshot(&out)
            .into_iter()
            .map(|(k, (_, _, b))| (k, b))
            .collect();
        drawn_by.push(files);
    }
    assert!(!drawn_by[0].is_empty());
    assert_eq!(drawn_by[0], drawn_by[1]);
    assert_eq!(drawn_by[0], drawn_by[2]);
}
