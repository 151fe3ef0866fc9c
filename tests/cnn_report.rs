//! The CNN applications in `table` and the report (issue 14, item 4), on two tiny runs (about
//! 2 s and 7 s): `table --table classification` prints Table 20/22's layout (methods down,
//! training sizes across, mean +- std over repeats, the original row) with the numbers of
//! `classification.parquet`; `table --table location` prints target x method by SCR with the
//! summary's columns; the report has both sections, references the accuracy, confusion,
//! training-curve and example figures, and they exist; `report` redraws them byte for byte.

use polars::prelude::DataType;
use std::path::Path;
use std::process::Command;

const CLASSIFICATION: &str = "name: cnn_report_class
seed: 5
datasets:
  - {id: a, kind: filtered_noise, family: exponential, alpha_h: 4.0, alpha_v: 0.3, size: [32, 32], samples: 40}
  - {id: b, kind: filtered_noise, family: exponential, alpha_h: 0.3, alpha_v: 4.0, size: [32, 32], samples: 40}
analysis:
  levels: 1
classification:
  classes: [a, b]
  normalise: zero_mean_unit_variance
  methods: [original, method1, uncorrelated]
  train_sizes: [40, 100]
  repeats: 2
  training: {epochs: 3, batch_size: 32}
";

const LOCATION: &str = "name: cnn_report_loc
seed: 6
datasets:
  - {id: clutter, kind: filtered_noise, family: dyadic, r_h: [0.5, 0.3, 0.1], r_v: [0.4, 0.2, 0.1], size: [64, 64], samples: 200}
analysis:
  levels: 3
location:
  clutter: clutter
  fit_samples: 100
  methods: [original, method2]
  generated_samples: 400
  targets: [constant]
  scr_db: [-20, 10]
  repeats: 1
  training: {epochs: 3}
";

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
}

/// Runs `spec` into a fresh folder (with its report) and returns the temp dir and the folder.
fn run(spec: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("spec.yaml");
    std::fs::write(&path, spec).unwrap();
    let out = tmp.path().join("out");
    let o = bin()
        .args(["run", path.to_str().unwrap(), "--quiet", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (tmp, out)
}

/// `table OUT ARGS...`: its stdout, or a panic with its stderr.
fn table(out: &Path, args: &[&str]) -> String {
    let o = bin().arg("table").arg(out).args(args).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

/// Test accuracies (%) of `method` at `column = x` in a run's table.
fn accuracies(out: &Path, file: &str, method: &str, column: &str, x: f64) -> Vec<f64> {
    let df = isar_clutter::io::parquet::read_parquet(&out.join(file))
        .unwrap()
        .unwrap();
    let col = |c: &str| {
        df.column(c)
            .unwrap()
            .cast(&DataType::Float64)
            .unwrap()
            .f64()
            .unwrap()
            .iter()
            .collect::<Vec<_>>()
    };
    let (xs, acc) = (col(column), col("test_accuracy"));
    let methods: Vec<Option<String>> = df
        .column("method")
        .unwrap()
        .str()
        .unwrap()
        .iter()
        .map(|v| v.map(str::to_string))
        .collect();
    (0..df.height())
        .filter(|&i| methods[i].as_deref() == Some(method) && xs[i] == Some(x))
        .map(|i| 100.0 * acc[i].unwrap())
        .collect()
}

/// The `src` and `href` values of a page.
fn references(html: &str) -> Vec<String> {
    let mut out = vec![];
    for attr in ["src=\"", "href=\""] {
        for piece in html.split(attr).skip(1) {
            out.push(piece[..piece.find('"').unwrap()].replace("&amp;", "&"));
        }
    }
    out
}

/// Every figure `stem` is on the page (PNG and SVG links) and exists as a real PNG.
fn assert_figures(out: &Path, html: &str, stems: &[&str]) {
    let refs = references(html);
    for r in refs.iter().filter(|r| !r.starts_with('#')) {
        assert!(out.join(r).is_file(), "the report references missing {r}");
    }
    for stem in stems {
        for ext in ["png", "svg"] {
            let f = format!("figures/{stem}.{ext}");
            assert!(refs.contains(&f), "the report does not show {f}");
        }
        let png = std::fs::read(out.join(format!("figures/{stem}.png"))).unwrap();
        assert_eq!(&png[1..4], b"PNG", "{stem}");
        assert!(png.len() > 5_000, "{stem}.png is {} bytes", png.len());
    }
}

#[test]
fn classification_table_has_table_20s_layout_and_the_report_its_figures() {
    let (_tmp, out) = run(CLASSIFICATION);
    let text = table(&out, &["--table", "classification"]);
    assert!(
        text.starts_with(
            "Prediction accuracy on original data (Tables 20/22), zero_mean_unit_variance"
        ),
        "{text}"
    );
    assert!(text.contains("over 2 repeats"), "{text}");
    assert!(text.contains("protocol: holdout"), "{text}");
    let lines: Vec<&str> = text.lines().collect();
    let header = lines
        .iter()
        .find(|l| l.starts_with("method"))
        .expect("a header");
    let columns: Vec<&str> = header
        .split("  ")
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .collect();
    assert_eq!(columns, ["method", "N = 40", "N = 100"], "{text}");
    // One row per method, the original row included, in the spec's order; every cell is
    // `mean +- std` and equals the statistics of the Parquet rows.
    let rows: Vec<&str> = lines
        .iter()
        .skip_while(|l| !l.starts_with("---"))
        .skip(1)
        .copied()
        .collect();
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r.split_whitespace().next().unwrap())
        .collect();
    assert_eq!(names, ["original", "method1", "uncorrelated"], "{text}");
    for (row, method) in rows.iter().zip(&names) {
        let cells: Vec<&str> = row[method.len()..]
            .split("  ")
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect();
        assert_eq!(cells.len(), 2, "{row}");
        for (cell, n) in cells.iter().zip([40.0, 100.0]) {
            let (mean, std) = cell.split_once(" +- ").unwrap_or_else(|| panic!("{cell}"));
            let v = accuracies(&out, "classification.parquet", method, "train_size", n);
            assert_eq!(v.len(), 2, "{method} N = {n}");
            let m = (v[0] + v[1]) / 2.0;
            let s = (v[0] - v[1]).abs() / 2f64.sqrt();
            assert_eq!(mean, format!("{m:.1}"), "{method} N = {n}");
            assert_eq!(std, format!("{s:.1}"), "{method} N = {n}");
        }
    }
    // Markdown, the detail table, and a pivot refused by name.
    let md = table(&out, &["--table", "classification", "--format", "md"]);
    assert!(md.contains("| method "), "{md}");
    let detail = table(&out, &["--table", "classification_detail"]);
    assert!(
        detail.contains("test min") && detail.contains("validation mean"),
        "{detail}"
    );
    assert_eq!(
        detail
            .lines()
            .filter(|l| l.contains("zero_mean_unit_variance"))
            .count(),
        6
    );
    let filtered = table(
        &out,
        &["--table", "classification", "--filter", "method=method1"],
    );
    assert!(
        filtered.contains("method1") && !filtered.contains("uncorrelated"),
        "{filtered}"
    );
    let o = bin()
        .arg("table")
        .arg(&out)
        .args(["--table", "classification", "--pivot", "dataset"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("fixed layout"));
    // Every table with rows, the new ones among them.
    assert!(table(&out, &[]).contains("Tables 20/22"));

    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2 id=\"classification\">"), "no section");
    assert!(
        html.contains("Prediction accuracy on original data"),
        "no table"
    );
    let stems = [
        "classification_accuracy_zero_mean_unit_variance",
        "classification_confusion_zero_mean_unit_variance",
        "classification_training_zero_mean_unit_variance",
    ];
    assert_figures(&out, &html, &stems);
    assert!(
        html.contains("classes: 0 = a, 1 = b"),
        "class names in the caption"
    );
    // Figures are drawn from the files alone, deterministically.
    let before: Vec<Vec<u8>> = stems
        .iter()
        .map(|s| std::fs::read(out.join(format!("figures/{s}.png"))).unwrap())
        .collect();
    let o = bin().arg("report").arg(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (s, b) in stems.iter().zip(before) {
        assert_eq!(
            std::fs::read(out.join(format!("figures/{s}.png"))).unwrap(),
            b,
            "{s}"
        );
    }
    assert_eq!(
        std::fs::read_to_string(out.join("report.html")).unwrap(),
        html
    );
}

#[test]
fn location_table_and_report_show_accuracy_against_scr() {
    let (_tmp, out) = run(LOCATION);
    let text = table(&out, &["--table", "location"]);
    assert!(text.starts_with("Target location (Figs. 73-74)"), "{text}");
    let header = text
        .lines()
        .find(|l| l.starts_with("target"))
        .expect("a header");
    for h in [
        "method",
        "-20 dB",
        "10 dB",
        "SCR 50 % (dB)",
        "gain 90 % (dB)",
    ] {
        assert!(header.contains(h), "{header}");
    }
    for method in ["original", "method2"] {
        let row = text
            .lines()
            .find(|l| l.starts_with("constant") && l.split_whitespace().nth(1) == Some(method))
            .unwrap_or_else(|| panic!("no row for {method}:\n{text}"));
        let cells: Vec<&str> = row.split_whitespace().collect();
        for (k, scr) in [-20.0, 10.0].iter().enumerate() {
            let v = accuracies(&out, "location.parquet", method, "scr_db", *scr);
            assert_eq!(cells[2 + k], format!("{:.1}", v[0]), "{method} at {scr} dB");
        }
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2 id=\"location\">"), "no section");
    assert_figures(
        &out,
        &html,
        &[
            "location_accuracy_constant",
            "location_confusion_constant",
            "location_training_constant",
            "location_examples_constant",
        ],
    );
    assert!(
        html.contains("examples/location.constant."),
        "examples linked as data"
    );
}
