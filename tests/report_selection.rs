//! The report of a big sweep (issue 31, item 4): per-job figures for a bounded, deterministic
//! selection. A sweep of 24 tiny jobs reported with `--figures-for 5` draws figures for exactly
//! 5 jobs, spread evenly over the plan order with the first and the last included, says so on
//! the page (which jobs, and where the others' numbers are), lists only those jobs in the
//! provenance table, and gives the same page and figures on a second report and with one
//! thread; a smaller limit removes the figures of the jobs it leaves out, and the default limit
//! (above every shipped experiment) draws every job's figures with no note, as before.

mod common;

use common::{bin, run_spec, text};
use std::collections::BTreeSet;
use std::fs;
use std::path::Path;

/// Sweep values of `alpha_h`: 24 jobs, `d.alpha_h=1.00` ... `d.alpha_h=1.23` in plan order.
fn spec() -> String {
    let values: Vec<String> = (0..24)
        .map(|i| format!("{:.2}", 1.0 + 0.01 * i as f64))
        .collect();
    format!(
        "name: report_selection
seed: 3
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 1.0
    size: [16, 16]
    samples: 20
    half_width: 3
analysis:
  levels: 2
sweep:
  zip:
    datasets.d.alpha_h: [{}]
",
        values.join(", ")
    )
}

/// The job ids of the sweep, in plan order, as the manifest has them.
fn plan_jobs(out: &Path) -> Vec<String> {
    let m: serde_json::Value =
        serde_json::from_slice(&fs::read(out.join("manifest.json")).unwrap()).unwrap();
    m["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["job"].as_str().unwrap().to_string())
        .collect()
}

/// The jobs with a folder under `figures/`.
fn figure_jobs(out: &Path) -> BTreeSet<String> {
    fs::read_dir(out.join("figures"))
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect()
}

/// Every figure file, relative to `figures/`, with its bytes.
fn figure_files(out: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = vec![];
    let mut stack = vec![out.join("figures")];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).unwrap().flatten() {
            if e.path().is_dir() {
                stack.push(e.path());
            } else {
                let rel = e.path().strip_prefix(out).unwrap().display().to_string();
                files.push((rel, fs::read(e.path()).unwrap()));
            }
        }
    }
    files.sort();
    files
}

fn report(out: &Path, extra: &[&str]) -> String {
    let mut args = vec!["report", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = bin(&args);
    assert!(o.status.success(), "{}", text(&o));
    text(&o)
}

#[test]
fn a_big_sweep_gets_figures_for_a_bounded_documented_selection() {
    let tmp = tempfile::tempdir().unwrap();
    let spec_path = tmp.path().join("spec.yaml");
    fs::write(&spec_path, spec()).unwrap();
    let out = tmp.path().join("out");
    run_spec(&spec_path, &out, &["--no-report"]);
    let jobs = plan_jobs(&out);
    assert_eq!(jobs.len(), 24);

    // Five jobs, spread evenly over the plan order: indices round(i * 23 / 4).
    let said = report(&out, &["--figures-for", "5"]);
    assert!(
        said.contains("per-job figures for 5 of 24 jobs"),
        "the command does not say what it drew: {said}"
    );
    let chosen: Vec<String> = [0, 6, 12, 17, 23]
        .iter()
        .map(|&i| jobs[i].clone())
        .collect();
    assert_eq!(
        figure_jobs(&out),
        chosen.iter().cloned().collect::<BTreeSet<_>>()
    );
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("Per-job figures for 5 of 24 jobs"),
        "the page does not say how many jobs have figures"
    );
    assert!(html.contains(&format!("Jobs with figures: {}.", chosen.join(", "))));
    assert!(html.contains("<code>maps/&lt;job&gt;/</code>"));
    assert!(html.contains("<a href=\"analysis_maps.parquet\">"));
    for job in &jobs {
        let has_figures = html.contains(&format!("src=\"figures/{job}/"));
        let in_provenance = html.contains(&format!("<tr><td>{job}</td>"));
        let is_chosen = chosen.contains(job);
        assert_eq!(has_figures, is_chosen, "{job}: figures on the page");
        assert_eq!(
            in_provenance, is_chosen,
            "{job}: row of the provenance table"
        );
    }
    assert!(html.contains("The table lists 5 of the run's 24 jobs"));
    // The run-wide curves over the swept parameter come before every job's figures.
    let curves = html.find("src=\"figures/sweep_").expect("no sweep curves");
    let first_job = html.find(&format!("src=\"figures/{}/", chosen[0])).unwrap();
    assert!(
        curves < first_job,
        "the sweep curves come after the jobs' figures"
    );

    // Deterministic: the same page and files again, and with one thread (figures drawn anew).
    let files = figure_files(&out);
    report(&out, &["--figures-for", "5"]);
    assert_eq!(fs::read_to_string(out.join("report.html")).unwrap(), html);
    fs::remove_dir_all(out.join("figures")).unwrap();
    report(&out, &["--figures-for", "5", "--jobs", "1"]);
    assert_eq!(fs::read_to_string(out.join("report.html")).unwrap(), html);
    assert_eq!(figure_files(&out), files);

    // A smaller limit: first and last only, and the figures of the others go.
    report(&out, &["--figures-for", "2"]);
    assert_eq!(
        figure_jobs(&out),
        [jobs[0].clone(), jobs[23].clone()].into_iter().collect()
    );

    // The default limit is above this run: every job's figures, no note, every job listed.
    let said = report(&out, &[]);
    assert!(!said.contains("per-job figures for"), "{said}");
    assert_eq!(figure_jobs(&out), jobs.iter().cloned().collect());
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(!html.contains("id=\"selection\""));
    assert!(!html.contains("The table lists"));
    assert!(jobs
        .iter()
        .all(|j| html.contains(&format!("<tr><td>{j}</td>"))));
    // `all` is the same as a limit above the run.
    report(&out, &["--figures-for", "all"]);
    assert_eq!(fs::read_to_string(out.join("report.html")).unwrap(), html);

    // A bad limit is refused with the accepted forms.
    let o = bin(&["report", out.to_str().unwrap(), "--figures-for", "some"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("expected `all` or a number of jobs"),
        "{}",
        text(&o)
    );
}
