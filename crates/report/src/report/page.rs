//! The HTML page of the report: one self-contained document (inline CSS, relative links,
//! no network) with the summary tables, the figures and the provenance. In the report of a big
//! run the page says which jobs have figures and where the others' numbers are (when there are
//! more jobs with figures than the limit of [`super::select`]), and every table over jobs is
//! bounded ([`TABLE_ROWS`]).

use super::cnn;
use super::select::Selection;
use super::table::{self, escape, Format, RowLimit};
use super::task::Figure;
use crate::io::manifest::{Job, Manifest};
use crate::io::results;
use anyhow::Result;
use serde_json::Value as Json;
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::Path;

/// The most rows a table shows in the report of a big run (some jobs without their figures, or
/// more jobs than this): a bigger table shows the rows of the jobs with figures (see
/// [`RowLimit`]), and the provenance lists the jobs with figures and those not ok. Smaller
/// runs' tables are shown whole.
pub const TABLE_ROWS: usize = 500;

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:90%}caption{text-align:left;font-weight:bold;padding:.3em 0}
th,td{border:1px solid #ccc;padding:2px 6px}td.num{text-align:right;font-family:monospace}
figure{display:inline-block;margin:1em 1em 1em 0;vertical-align:top;max-width:100%}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:90%;max-width:700px}pre{background:#f6f6f6;padding:1em;overflow:auto;font-size:85%}
nav a{margin-right:1em}";

/// After the page has loaded, records on `<body>` how many images loaded (a browser test
/// reads it back); no network and no effect on the page otherwise.
const SCRIPT: &str = "window.addEventListener('load',function(){var im=document.images,ok=0;for(var i=0;i<im.length;i++){if(im[i].complete&&im[i].naturalWidth>0)ok++;}document.body.setAttribute('data-images-total',im.length);document.body.setAttribute('data-images-loaded',ok);});";

/// A relative link to `p`, showing its path.
fn link(p: &Path) -> String {
    let s = p.to_string_lossy();
    format!("<a href=\"{}\">{}</a>", escape(&s), escape(&s))
}

/// One figure with its caption and links.
fn figure_html(f: &Figure) -> String {
    let png = f.files[0].to_string_lossy();
    let data: Vec<String> = f.data.iter().map(|d| link(d)).collect();
    format!(
        "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{} ({}; data: {})</figcaption></figure>",
        escape(&png),
        escape(&f.caption),
        escape(&f.caption),
        link(&f.files[1]),
        data.join(", ")
    )
}

/// The CNN applications' sections: heading, what it shows, tables, figures.
fn sections_html(h: &mut String, sections: &[cnn::Section]) {
    for s in sections {
        let _ = writeln!(
            h,
            "<h2 id=\"{}\">{}</h2>\n<p>{}</p>",
            s.id,
            escape(s.title),
            escape(&s.intro)
        );
        for t in &s.tables {
            let _ = writeln!(h, "{t}");
        }
        for f in &s.figures {
            let _ = writeln!(h, "{}", figure_html(f));
        }
    }
}

/// The HTML page: the standard tables, the CNN applications' sections, the run-wide and the
/// chosen jobs' figures (`figures`, in that order), the spec and the provenance.
pub(super) fn page(
    dir: &Path,
    (manifest, unreadable): (&Manifest, Option<&str>),
    selection: &Selection,
    figures: &[Figure],
    sections: &[cnn::Section],
) -> Result<String> {
    let name = manifest.spec["name"].as_str().unwrap_or("results");
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{} - isar-clutter report</title>\n<style>{STYLE}</style>\n<script>{SCRIPT}</script>\n</head>\n<body>\n",
        escape(name)
    );
    let _ = writeln!(h, "<h1>{}</h1>", escape(name));
    if let Some(why) = unreadable {
        let _ = writeln!(
            h,
            "<p><strong>Incomplete:</strong> manifest.json could not be read ({}); this page lacks \
             the spec, the provenance and the per-job figures it lists.</p>",
            escape(why)
        );
    }
    if let Some(d) = manifest.spec["description"].as_str() {
        let _ = writeln!(h, "<p>{}</p>", escape(d));
    }
    let apps: String = sections
        .iter()
        .map(|s| format!("<a href=\"#{}\">{}</a>", s.id, escape(s.title)))
        .collect();
    let _ = writeln!(
        h,
        "<nav><a href=\"#tables\">Tables</a>{apps}<a href=\"#figures\">Figures</a><a href=\"#spec\">Spec</a><a href=\"#provenance\">Provenance</a></nav>"
    );
    let _ = writeln!(h, "<h2 id=\"tables\">Tables</h2>");
    let chosen = selection.set();
    // A big run's report: some jobs without their figures, or more jobs than a table shows.
    let big = selection.limited || manifest.jobs.len() > TABLE_ROWS;
    let limit = big.then_some(RowLimit {
        jobs: &chosen,
        max_rows: TABLE_ROWS,
    });
    tables_html(&mut h, dir, limit)?;
    sections_html(&mut h, sections);
    let _ = writeln!(h, "<h2 id=\"figures\">Figures</h2>");
    if selection.limited {
        selection_html(&mut h, dir, selection);
    }
    figures_html(&mut h, figures);
    let spec_yaml = serde_yaml_ng::to_string(&manifest.spec).unwrap_or_default();
    let _ = writeln!(
        h,
        "<h2 id=\"spec\">Spec</h2>\n<p>File {} (SHA-256 {}), with defaults filled in:</p>\n<pre>{}</pre>",
        escape(&manifest.spec_file),
        escape(&manifest.spec_hash_sha256),
        escape(&spec_yaml)
    );
    provenance_html(&mut h, dir, manifest, big.then_some(&chosen));
    Ok(h)
}

/// The standard tables (at most `limit`'s rows each, and then a note saying which), each with
/// a link to its file.
fn tables_html(h: &mut String, dir: &Path, limit: Option<RowLimit>) -> Result<()> {
    let mut any = false;
    for def in table::standard() {
        let Some(t) = table::render_limited(dir, &def, &[], None, Format::Html, false, limit)?
        else {
            continue;
        };
        let _ = write!(h, "{}<p>", t.text);
        if t.rows < t.total_rows {
            let _ = write!(
                h,
                "{} of its {} rows: {}; every row in the file, or with <code>isar-clutter table \
                 DIR --table {}</code>. ",
                t.rows,
                t.total_rows,
                if t.by_job {
                    "those of the jobs with figures (below)"
                } else {
                    "the first"
                },
                def.name
            );
        }
        let _ = writeln!(h, "Data: {}</p>", link(Path::new(&def.table.file_name())));
        any = true;
    }
    if !any {
        let _ = writeln!(h, "<p>No tables with rows.</p>");
    }
    Ok(())
}

/// The figures, under a heading per job (the run-wide ones first, under their own).
fn figures_html(h: &mut String, figures: &[Figure]) {
    let mut current = None;
    for f in figures {
        if current != Some(&f.job) {
            let title = if f.job.is_empty() {
                "Run-wide figures"
            } else {
                f.job.as_str()
            };
            let _ = writeln!(h, "<h3>{}</h3>", escape(title));
            current = Some(&f.job);
        }
        let _ = writeln!(h, "{}", figure_html(f));
    }
}

/// The provenance: the tool, commit, seeds, threads and time, then the jobs' table (with
/// `chosen`, a big run's: only the jobs with figures and those not ok, at most
/// [`TABLE_ROWS`]) and the links to the full record and the tables.
fn provenance_html(
    h: &mut String,
    dir: &Path,
    manifest: &Manifest,
    chosen: Option<&BTreeSet<&str>>,
) {
    let _ = writeln!(h, "<h2 id=\"provenance\">Provenance</h2>\n<table><tbody>");
    // Numbers as JSON prints them (`null` for one the manifest lacks).
    let json = |v: Json| v.to_string();
    let rows = [
        (
            "tool",
            format!("{} {}", manifest.tool.name, manifest.tool.version),
        ),
        (
            "git commit",
            match &manifest.git {
                None => "not recorded".into(),
                Some(git) => format!("{} (dirty: {})", git.commit, git.dirty),
            },
        ),
        ("master seed", json(manifest.master_seed.into())),
        ("seed derivation", manifest.seed_derivation.clone()),
        ("threads", json(manifest.threads.into())),
        (
            "total time (s)",
            json(manifest.timings.map(|t| t.total_s).into()),
        ),
        ("finished (unix s)", json(manifest.finished_unix_s.into())),
    ];
    for (k, v) in rows {
        let _ = writeln!(h, "<tr><th>{}</th><td>{}</td></tr>", escape(k), escape(&v));
    }
    let _ = writeln!(h, "</tbody></table>\n<table><thead><tr><th>job</th><th>dataset</th><th>method</th><th>status</th><th>seed</th><th>data seed</th><th>generation seed</th><th>elapsed (s)</th><th>error</th></tr></thead><tbody>");
    let jobs = &manifest.jobs;
    let shown: Vec<&Job> = match chosen {
        Some(chosen) => jobs
            .iter()
            .filter(|j| !j.ok() || chosen.contains(j.job.as_str()))
            .take(TABLE_ROWS)
            .collect(),
        None => jobs.iter().collect(),
    };
    for j in &shown {
        let s = |k: &str| match j.field(k) {
            Json::Null => "-".to_string(),
            Json::String(s) => s.clone(),
            Json::Number(n) if k == "elapsed_s" => format!("{:.3}", n.as_f64().unwrap_or(0.0)),
            other => other.to_string(),
        };
        let _ = writeln!(
            h,
            "<tr>{}</tr>",
            Job::COLUMNS
                .iter()
                .map(|k| format!("<td>{}</td>", escape(&s(k))))
                .collect::<String>()
        );
    }
    let note = if shown.len() < jobs.len() {
        format!(
            "The table lists {} of the run's {} jobs: those with figures and those not ok (at \
             most {TABLE_ROWS}); every job's seeds, status and time are in {} and in the full \
             record. ",
            shown.len(),
            jobs.len(),
            link(Path::new(&results::JOBS.file_name())),
        )
    } else {
        String::new()
    };
    let _ = writeln!(
        h,
        "</tbody></table>\n<p>{note}Full record: {}. Tables: {}.</p>\n</body>\n</html>",
        link(Path::new(crate::io::manifest::FILE)),
        results::ALL
            .iter()
            .filter(|t| t.path(dir).exists())
            .map(|t| link(Path::new(&t.file_name())))
            .collect::<Vec<_>>()
            .join(", ")
    );
}

/// The note of a big run's report on which jobs have figures, and where the others' are.
fn selection_html(h: &mut String, dir: &Path, selection: &Selection) {
    let files: Vec<String> = [results::ANALYSIS_MAPS, results::PIXEL_STATS]
        .iter()
        .filter(|t| t.path(dir).exists())
        .map(|t| link(Path::new(&t.file_name())))
        .collect();
    let _ = writeln!(
        h,
        "<p id=\"selection\">Per-job figures for {} of {} jobs: the run has more jobs with \
         figures than the report draws (<code>isar-clutter report DIR --figures-for N</code> sets \
         how many, <code>--figures-for all</code> draws every job's), so they are drawn for jobs \
         spread evenly over the plan order, the first and the last included. The rest are in {}{}\
         <code>maps/&lt;job&gt;/</code> (the <code>.npy</code> maps). Jobs with figures: {}.</p>",
        selection.jobs.len(),
        selection.candidates,
        files.join(", "),
        if files.is_empty() {
            ""
        } else {
            " (by job) and "
        },
        selection
            .jobs
            .iter()
            .map(|j| escape(j))
            .collect::<Vec<_>>()
            .join(", ")
    );
}
