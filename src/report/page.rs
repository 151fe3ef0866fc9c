//! The HTML page of the report: one self-contained document (inline CSS, relative links,
//! no network) with the summary tables, the figures and the provenance.

use super::*;

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:90%}caption{text-align:left;font-weight:bold;padding:.3em 0}
th,td{border:1px solid #ccc;padding:2px 6px}td.num{text-align:right;font-family:monospace}
figure{display:inline-block;margin:1em 1em 1em 0;vertical-align:top;max-width:100%}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:90%;max-width:700px}pre{background:#f6f6f6;padding:1em;overflow:auto;font-size:85%}
nav a{margin-right:1em}";

/// After the page has loaded, records on `<body>` how many images loaded (a browser test
/// reads it back); no network and no effect on the page otherwise.
const SCRIPT: &str = "window.addEventListener('load',function(){var im=document.images,ok=0;for(var i=0;i<im.length;i++){if(im[i].complete&&im[i].naturalWidth>0)ok++;}document.body.setAttribute('data-images-total',im.length);document.body.setAttribute('data-images-loaded',ok);});";

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

/// The HTML page: the standard tables, the CNN applications' sections, every job's and the
/// run-wide figures, the spec and the provenance.
pub(super) fn page(
    dir: &Path,
    manifest: &Json,
    figures: &[Figure],
    sections: &[cnn::Section],
) -> Result<String> {
    let name = manifest["spec"]["name"].as_str().unwrap_or("results");
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{} - isar-clutter report</title>\n<style>{STYLE}</style>\n<script>{SCRIPT}</script>\n</head>\n<body>\n",
        escape(name)
    );
    let _ = writeln!(h, "<h1>{}</h1>", escape(name));
    if let Some(d) = manifest["spec"]["description"].as_str() {
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
    let mut any = false;
    for def in table::standard() {
        if let Some(t) = table::render(dir, &def, &[], None, Format::Html, false)? {
            let _ = writeln!(h, "{t}<p>Data: {}</p>", link(Path::new(def.file)));
            any = true;
        }
    }
    if !any {
        let _ = writeln!(h, "<p>No tables with rows.</p>");
    }
    sections_html(&mut h, sections);
    let _ = writeln!(h, "<h2 id=\"figures\">Figures</h2>");
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
    let spec_yaml = serde_yaml_ng::to_string(&manifest["spec"]).unwrap_or_default();
    let _ = writeln!(
        h,
        "<h2 id=\"spec\">Spec</h2>\n<p>File {} (SHA-256 {}), with defaults filled in:</p>\n<pre>{}</pre>",
        escape(manifest["spec_file"].as_str().unwrap_or("?")),
        escape(manifest["spec_hash_sha256"].as_str().unwrap_or("?")),
        escape(&spec_yaml)
    );
    let _ = writeln!(h, "<h2 id=\"provenance\">Provenance</h2>\n<table><tbody>");
    let git = &manifest["git"];
    let rows = [
        (
            "tool",
            format!(
                "{} {}",
                manifest["tool"]["name"].as_str().unwrap_or("?"),
                manifest["tool"]["version"].as_str().unwrap_or("?")
            ),
        ),
        (
            "git commit",
            if git.is_null() {
                "not recorded".into()
            } else {
                format!(
                    "{} (dirty: {})",
                    git["commit"].as_str().unwrap_or("?"),
                    git["dirty"]
                )
            },
        ),
        ("master seed", manifest["master_seed"].to_string()),
        (
            "seed derivation",
            manifest["seed_derivation"]
                .as_str()
                .unwrap_or("")
                .to_string(),
        ),
        ("threads", manifest["threads"].to_string()),
        ("total time (s)", manifest["timings"]["total_s"].to_string()),
        ("finished (unix s)", manifest["finished_unix_s"].to_string()),
    ];
    for (k, v) in rows {
        let _ = writeln!(h, "<tr><th>{}</th><td>{}</td></tr>", escape(k), escape(&v));
    }
    let _ = writeln!(h, "</tbody></table>\n<table><thead><tr><th>job</th><th>dataset</th><th>method</th><th>status</th><th>seed</th><th>data seed</th><th>generation seed</th><th>elapsed (s)</th><th>error</th></tr></thead><tbody>");
    for j in manifest["jobs"].as_array().into_iter().flatten() {
        let s = |k: &str| match &j[k] {
            Json::Null => "-".to_string(),
            Json::String(s) => s.clone(),
            Json::Number(n) if k == "elapsed_s" => format!("{:.3}", n.as_f64().unwrap_or(0.0)),
            other => other.to_string(),
        };
        let _ = writeln!(
            h,
            "<tr>{}</tr>",
            [
                "job",
                "dataset",
                "method",
                "status",
                "seed",
                "data_seed",
                "generation_seed",
                "elapsed_s",
                "error"
            ]
            .iter()
            .map(|k| format!("<td>{}</td>", escape(&s(k))))
            .collect::<String>()
        );
    }
    let _ = writeln!(
        h,
        "</tbody></table>\n<p>Full record: {}. Tables: {}.</p>\n</body>\n</html>",
        link(Path::new("manifest.json")),
        [
            "analysis_maps.parquet",
            "analysis_summary.parquet",
            "pixel_stats.parquet",
            "jobs.parquet",
            "similarity.parquet",
            "model_order.parquet",
            "synthesis_params.parquet",
            "filter_correlation.parquet",
            "calibration.parquet",
            "calibration_summary.parquet",
            "classification.parquet",
            "location.parquet",
            "location_summary.parquet",
            "training_history.parquet",
            "confusion.parquet",
        ]
        .iter()
        .filter(|f| dir.join(f).exists())
        .map(|f| link(Path::new(f)))
        .collect::<Vec<_>>()
        .join(", ")
    );
    Ok(h)
}
