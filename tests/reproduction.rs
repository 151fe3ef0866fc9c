//! The reproduction document (`isar-clutter reproduce`): the tables it can check in seconds
//! (Table 3 exactly, Table 4 within the spread of two seeded repeats) reproduced from real
//! runs of the shipped specs, a damaged run folder refused with the file named and no
//! document written, and a missing one named with its cells and claims not decidable.

use isar_clutter::reproduction::{self as rep, compare::Verdict, render, runs};
use std::path::{Path, PathBuf};

fn header() -> render::Header {
    render::Header {
        command: "test".into(),
        wall_s: None,
        machine: "test".into(),
        tool: "test".into(),
        repeats: 2,
        cnn_repeats: None,
        builds: vec![],
        plant_records: vec![],
        missing: vec![],
        job_time: vec![],
    }
}

/// The options of a quiet reproduction into `out` from the specs in `specs`, on 2 threads.
fn options(out: PathBuf, specs: PathBuf, repeats: usize) -> runs::Options {
    runs::Options {
        out,
        specs,
        repeats,
        cnn_repeats: None,
        threads: 2,
        write_only: false,
        only: Vec::new(),
        quiet: true,
        device: None,
    }
}

fn run(out: &Path, numbers: &[u32]) -> (runs::Coverage, Vec<runs::SpecRuns>) {
    let recipes = runs::Coverage::tables(numbers);
    let opts = options(out.to_path_buf(), PathBuf::from("experiments"), 2);
    let runs = runs::run_all(&opts, &recipes).unwrap();
    (recipes, runs)
}

/// Tables 3 (analytic: every cell to the printed 4 decimals) and 4 (estimates from 1000
/// samples of 64 x 64: within two standard deviations of two seeded repeats, the verdict rule
/// of the document). A change that moves a reproduced number out of that fails here.
#[test]
fn tables_3_and_4_match_the_dissertation() {
    let dir = tempfile::tempdir().unwrap();
    let (recipes, runs) = run(dir.path(), &[3, 4]);
    let doc = dir.path().join("reproduction.md");
    let (counts, missing) = rep::write(&recipes, &runs, &doc, &header()).unwrap();
    assert!(missing.is_empty(), "{missing:?}");
    // Table 3: 9 lags x 2 columns; Table 4: 3 levels x 3 directions.
    assert_eq!(
        counts.get(&Verdict::Matches).copied(),
        Some(18 + 9),
        "{counts:?}"
    );
    assert_eq!(counts.len(), 1, "{counts:?}");
    let text = std::fs::read_to_string(&doc).unwrap();
    assert!(text.contains("## Table 3: Correlation for Pixel Offsets"));
    // The build that computed the results is named (from the run folders' manifests).
    let builds = runs::builds(&runs);
    assert_eq!(builds.len(), 1, "{builds:?}");
    assert!(
        text.contains(&format!("- Results computed by: {} (", builds[0].0)),
        "{text}"
    );
    assert!(
        text.contains("| 1 | Correlation | 0.6481 | 0.6481 |"),
        "{text}"
    );
    // The plants' record of every folder (3 runs), as `sha256sum` hashes the committed file.
    let sum = std::process::Command::new("sha256sum")
        .arg("reproduction/plant_calibration.json")
        .output()
        .unwrap();
    let sum = String::from_utf8(sum.stdout).unwrap()[..12].to_string();
    assert_eq!(runs::plant_records(&runs), vec![(sum.clone(), 3)]);
    assert!(
        text.contains(&format!("{sum} (3 run(s)); this build's: {sum}")),
        "{text}"
    );
    // The folders' compute time by spec, from the jobs' own times in the manifests.
    let time = runs::job_time(&runs);
    assert_eq!(time.len(), 2, "{time:?}");
    // Table 3's exact construction runs once, Table 4's random statistic twice.
    for (t, runs) in time.iter().zip([1, 2]) {
        assert_eq!(t.runs, runs, "{t:?}");
        assert!(t.jobs > 0 && t.seconds > 0.0, "{t:?}");
    }
    assert!(
        text.contains("- Compute time of the folders (each job's own elapsed time")
            && text.contains("table4_exponential ")
            && text.contains("(2 run(s), "),
        "{text}"
    );
    // The repeats have their own seeds, recorded in their folders' names.
    let t4 = runs
        .iter()
        .find(|r| r.spec == "table4_exponential")
        .unwrap();
    assert_eq!(t4.runs.len(), 2);
    assert_ne!(t4.runs[0].0, t4.runs[1].0);
    assert_eq!(
        t4.runs[0].0, 20200403,
        "the first repeat runs with the spec's own seed"
    );
}

#[test]
fn a_damaged_run_folder_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let (recipes, runs) = run(dir.path(), &[3]);
    let table = runs[0].runs[0].1.join("filter_correlation.parquet");
    let mut bytes = std::fs::read(&table).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0xff;
    std::fs::write(&table, bytes).unwrap();
    let doc = dir.path().join("reproduction.md");
    let err = format!(
        "{:#}",
        rep::write(&recipes, &runs, &doc, &header()).unwrap_err()
    );
    assert!(err.contains("filter_correlation.parquet"), "{err}");
    assert!(!doc.exists());
}

/// A run folder that is missing (never run, or deleted) does not stop the document: its
/// cells read the other repeats, and where none is left they are not computed and the claims
/// that need them are not decidable, naming the folder.
#[test]
fn a_missing_run_folder_is_named_and_its_claims_are_not_decidable() {
    let dir = tempfile::tempdir().unwrap();
    let (recipes, runs) = run(dir.path(), &[3, 4]);
    let t4: Vec<PathBuf> = runs
        .iter()
        .find(|r| r.spec == "table4_exponential")
        .unwrap()
        .runs
        .iter()
        .map(|(_, d)| d.clone())
        .collect();
    assert_eq!(t4.len(), 2);
    // One repeat deleted: the table reads the other.
    std::fs::remove_dir_all(&t4[1]).unwrap();
    let doc = dir.path().join("reproduction.md");
    rep::write(&recipes, &runs, &doc, &header()).unwrap();
    let text = std::fs::read_to_string(&doc).unwrap();
    let gone = t4[1].display().to_string();
    assert!(text.contains(&format!("{gone} (not run)")), "{text}");
    assert!(
        text.contains("`experiments/table4_exponential.yaml` (1 run(s))"),
        "{text}"
    );
    // Both deleted: Table 4's cells are not computed and its claims not decidable, naming
    // the folders.
    std::fs::remove_dir_all(&t4[0]).unwrap();
    rep::write(&recipes, &runs, &doc, &header()).unwrap();
    let text = std::fs::read_to_string(&doc).unwrap();
    let first = t4[0].display().to_string();
    let claim_lines: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("not decidable") && l.contains("Table 4's cell"))
        .collect();
    assert!(!claim_lines.is_empty(), "{text}");
    assert!(
        claim_lines
            .iter()
            .all(|l| l.contains(&first) && l.contains(&gone)),
        "{claim_lines:?}"
    );
    // Table 3 is still there.
    assert!(
        text.contains("| 1 | Correlation | 0.6481 | 0.6481 |"),
        "{text}"
    );
}

/// `run --seed N` replaces the spec's master seed for one run: the manifest says so, and a
/// sharded run's `merge` (which reads the spec again) uses the recorded seed, so the shards'
/// stored jobs are found.
#[test]
fn run_seed_is_recorded_and_merge_uses_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t3");
    let bin = env!("CARGO_BIN_EXE_isar-clutter");
    for shard in ["0", "1"] {
        let status = std::process::Command::new(bin)
            .args([
                "run",
                "experiments/table3_filter_correlation.yaml",
                "--seed",
                "5",
            ])
            .args(["--shards", "2", "--shard", shard, "-q", "--out"])
            .arg(&out)
            .status()
            .unwrap();
        assert!(status.success());
    }
    let merged = std::process::Command::new(bin)
        .args(["merge", "-q"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        merged.status.success(),
        "{}",
        String::from_utf8_lossy(&merged.stderr)
    );
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["master_seed"], 5);
    assert_eq!(manifest["master_seed_from"], "--seed");
}

/// Every table the document covers, rerun once at the dissertation's sizes with the specs' own
/// seeds (the first repeat of `make reproduce`), gives the numbers `docs/reproduction.json`
/// records for that repeat. A change that moves a reproduced number by more than a tenth of
/// its sampling spread (the standard deviation over the document's repeats; for an exact
/// value, or one without spread, 1e-9 of it) fails here, naming the table and cell, and asks
/// for `make reproduce` to write the document again. Floating-point differences between CPUs
/// (the f32 kernels' paths) are far below that.
#[test]
fn every_covered_table_gives_the_numbers_the_document_records() {
    let dir = tempfile::tempdir().unwrap();
    // The CNN tables' specs train hundreds of networks: `cnn_tables_read_every_repeat` checks
    // their reading on a small run instead.
    let recipes = runs::Coverage {
        recipes: runs::Coverage::all()
            .recipes
            .into_iter()
            .filter(|r| !r.runs_once())
            .collect(),
        statements: Vec::new(),
        solver: false,
    };
    let opts = options(dir.path().to_path_buf(), PathBuf::from("experiments"), 1);
    let runs = runs::run_all(&opts, &recipes).unwrap();
    let doc = dir.path().join("reproduction.md");
    rep::write(&recipes, &runs, &doc, &header()).unwrap();
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    // The summary's ten largest differences say why, each table among them under one reason.
    let text = std::fs::read_to_string(&doc).unwrap();
    let block = text
        .split("The ten largest relative differences:")
        .nth(1)
        .and_then(|b| b.split("\n## ").next())
        .expect("the summary lists the largest differences");
    let rows: Vec<&str> = block
        .lines()
        .filter(|l| l.starts_with("| "))
        .skip(1)
        .collect();
    assert_eq!(rows.len(), 10, "{block}");
    let whys: Vec<&str> = block
        .lines()
        .filter(|l| l.starts_with("Why (Tables "))
        .collect();
    for row in rows {
        let n = row.split('|').nth(1).unwrap().trim();
        let listed = |w: &&&str| {
            let tables = w["Why (Tables ".len()..].split("):").next().unwrap();
            tables.split(", ").any(|t| t == n)
        };
        assert_eq!(whys.iter().filter(listed).count(), 1, "Table {n}: {block}");
    }
    let fresh = read(&doc.with_extension("json"));
    let recorded = read(Path::new("docs/reproduction.json"));
    let tables = |v: &serde_json::Value| -> Vec<serde_json::Value> {
        v["tables"].as_array().unwrap().clone()
    };
    let recorded_tables = tables(&recorded);
    let mut checked = 0;
    for t in tables(&fresh) {
        let n = t["number"].as_u64().unwrap();
        let r = recorded_tables
            .iter()
            .find(|x| x["number"].as_u64() == Some(n) && x["protocol"] == t["protocol"])
            .unwrap_or_else(|| panic!("Table {n} is not in docs/reproduction.json"));
        for (i, (row, rrow)) in t["cells"]
            .as_array()
            .unwrap()
            .iter()
            .zip(r["cells"].as_array().unwrap())
            .enumerate()
        {
            for (j, (c, rc)) in row
                .as_array()
                .unwrap()
                .iter()
                .zip(rrow.as_array().unwrap())
                .enumerate()
            {
                let at = format!("Table {n}, row {}, column {}", i + 1, j + 1);
                assert_eq!(c.is_null(), rc.is_null(), "{at}: computed in one only");
                if c.is_null() {
                    continue;
                }
                let (got, want) = (c["first"].as_f64(), rc["first"].as_f64());
                match (got, want) {
                    (Some(g), Some(w)) => {
                        let sd = rc["sd"].as_f64().unwrap_or(0.0);
                        let tol = (0.1 * sd).max(1e-9 * w.abs()).max(1e-300);
                        assert!(
                            (g - w).abs() <= tol,
                            "{at}: {g} now, {w} in docs/reproduction.json (tolerance {tol}): \
                             run `make reproduce` if the change is meant"
                        );
                    }
                    (g, w) => assert_eq!(g.is_none(), w.is_none(), "{at}: NaN in one only"),
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 300, "only {checked} cells compared");
}

/// The CNN tables (20 and 22) read every repeat of a training as one draw, under the three
/// protocols, from one run of each spec: here two small specs under the names the recipes
/// read (two classes of filtered noise, 32 x 32, one epoch, 2 repeats), so that the reading
/// and the document's blocks are checked in seconds; the numbers of the full specs are the
/// document's (`make reproduce`).
#[test]
fn cnn_tables_read_every_repeat_under_every_protocol() {
    let dir = tempfile::tempdir().unwrap();
    let specs = dir.path().join("specs");
    std::fs::create_dir_all(&specs).unwrap();
    for (name, holdout, protocol) in [
        (rep::cnn::HELD_OUT, "0.2", "matlab"),
        (rep::cnn::DISSERTATION, "0", "matlab"),
        (rep::cnn::EQUAL_STEPS, "0", "equal_steps"),
    ] {
        std::fs::write(
            specs.join(format!("{name}.yaml")),
            format!(
                "name: {name}\nseed: 3\ndatasets:\n\
                 \x20 - {{id: a, kind: filtered_noise, family: exponential, alpha_h: 4.0, alpha_v: 0.2, size: [32, 32], samples: 64}}\n\
                 \x20 - {{id: b, kind: filtered_noise, family: exponential, alpha_h: 0.2, alpha_v: 4.0, size: [32, 32], samples: 64}}\nanalysis:\n  levels: 2\n\
                 classification:\n  classes: [a, b]\n  normalise: [zero_mean, zero_mean_unit_variance]\n\
                 \x20 holdout: {holdout}\n  methods: [original, method1, method2, full_covariance]\n\
                 \x20 train_sizes: [100, 250, 500, 1000]\n  repeats: 2\n\
                 \x20 training: {{epochs: 1, batch_size: 128, protocol: {protocol}}}\n"
            ),
        )
        .unwrap();
    }
    let coverage = runs::Coverage {
        recipes: rep::cnn::recipes(),
        statements: Vec::new(),
        solver: false,
    };
    assert!(coverage.recipes.iter().all(|r| r.runs_once()));
    let opts = options(dir.path().join("out"), specs, 5);
    let runs = runs::run_all(&opts, &coverage).unwrap();
    // Run once each, whatever `repeats` says: the spec repeats inside.
    assert!(runs.iter().all(|r| r.runs.len() == 1), "{runs:?}");
    let doc = dir.path().join("reproduction.md");
    rep::write(&coverage, &runs, &doc, &header()).unwrap();
    let values: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(doc.with_extension("json")).unwrap())
            .unwrap();
    let tables = values["tables"].as_array().unwrap();
    assert_eq!(tables.len(), 6, "Tables 20 and 22, three protocols each");
    for t in tables {
        let cells = t["cells"].as_array().unwrap();
        assert_eq!(cells.len(), 4);
        for (r, row) in cells.iter().enumerate() {
            for (c, cell) in row.as_array().unwrap().iter().enumerate() {
                // The originals' row has its one printed cell (100 samples).
                if r == 3 && c > 0 {
                    assert!(cell.is_null());
                    continue;
                }
                assert_eq!(
                    cell["n"], 2,
                    "Table {}, {r} {c}: one value a repeat",
                    t["number"]
                );
                let first = cell["first"].as_f64().unwrap();
                assert!((0.0..=100.0).contains(&first), "{first}");
            }
        }
    }
    let text = std::fs::read_to_string(&doc).unwrap();
    assert_eq!(text.matches("### The dissertation's protocol").count(), 2);
    assert_eq!(text.matches("### Held-out testing").count(), 2);
    assert_eq!(text.matches("### Equal optimisation steps").count(), 2);
    assert_eq!(text.matches("Headline:").count(), 6);
}

/// Fig. 74's ordering statements read from small runs of a stochastic-target spec under the
/// reproduction's name (64 x 64 clutter, 5 methods, 2 SCR points, one epoch, 2 repeats): each
/// link is the difference of two methods' mean test accuracies over the SCR points, read from
/// `location.parquet` of the same repeat, and its verdict is `ordering holds` exactly where
/// that difference is positive.
#[test]
fn fig_74_links_are_differences_of_mean_accuracy_over_the_scr_points() {
    use polars::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let specs = dir.path().join("specs");
    std::fs::create_dir_all(&specs).unwrap();
    let name = rep::cnn::STOCHASTIC;
    std::fs::write(
        specs.join(format!("{name}.yaml")),
        format!(
            "name: {name}\nseed: 5\ndatasets:\n\
             \x20 - {{id: clutter, kind: filtered_noise, family: exponential, alpha_h: 2.0, alpha_v: 0.5, size: [64, 64], samples: 60}}\n\
             analysis:\n  levels: 2\nlocation:\n  clutter: clutter\n  fit_samples: 20\n\
             \x20 methods: [original, uncorrelated, method1, method2, full_covariance]\n\
             \x20 generated_samples: 40\n  targets: [stochastic]\n  scr_db: [0, 20]\n  repeats: 1\n\
             \x20 training: {{epochs: 1, batch_size: 16}}\n"
        ),
    )
    .unwrap();
    let coverage = runs::Coverage {
        recipes: Vec::new(),
        statements: rep::cnn::stochastic_location(),
        solver: false,
    };
    let opts = options(dir.path().join("out"), specs, 2);
    let runs = runs::run_all(&opts, &coverage).unwrap();
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0].runs.len(), 2, "two repeats");
    // The mean test accuracy (%) of `method` in a run, read here directly.
    let mean = |folder: &Path, method: &str| -> f64 {
        let file = std::fs::File::open(folder.join("location.parquet")).unwrap();
        let df = ParquetReader::new(file).finish().unwrap();
        let m = df.column("method").unwrap().str().unwrap().clone();
        let a = df.column("test_accuracy").unwrap().f64().unwrap().clone();
        let v: Vec<f64> = m
            .iter()
            .zip(a.iter())
            .filter(|(m, _)| *m == Some(method))
            .map(|(_, a)| a.unwrap() * 100.0)
            .collect();
        assert_eq!(v.len(), 2, "two SCR points of {method}");
        v.iter().sum::<f64>() / 2.0
    };
    let dissertation = rep::reference::Dissertation::load().unwrap();
    let mut tables = rep::extract::Tables::default();
    for (st, (better, worse)) in coverage.statements.iter().zip([
        ("uncorrelated", "original"),
        ("method1", "uncorrelated"),
        ("method2", "method1"),
        ("full_covariance", "method2"),
    ]) {
        let stated = rep::evaluate_statement(st, &dissertation, &runs, &mut tables).unwrap();
        let diffs: Vec<f64> = runs[0]
            .runs
            .iter()
            .map(|(_, f)| mean(f, better) - mean(f, worse))
            .collect();
        let want = (diffs[0] + diffs[1]) / 2.0;
        assert!(
            (stated.tool.mean - want).abs() < 1e-9,
            "{better} - {worse}: {} against {want}",
            stated.tool.mean
        );
        let verdict = if want > 0.0 {
            Verdict::OrderingHolds
        } else {
            Verdict::Differs
        };
        assert_eq!(stated.verdict, Some(verdict), "{better} - {worse}");
        assert!(stated.quantity.starts_with("Stochastic target location"));
    }
}

/// Fig. 73's gain statements: per repeat the originals' crossing minus each method's, and a
/// repeat counted as a lower bound exactly where a method's crossing is the lowest SCR swept
/// (its network already at the level there) or the originals' network never reaches the
/// level (read at the highest SCR swept), both read here directly from the tables.
#[test]
fn fig_73_gains_count_the_repeats_that_only_bound_them() {
    use polars::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let specs = dir.path().join("specs");
    std::fs::create_dir_all(&specs).unwrap();
    let name = "cnn_location_gain";
    std::fs::write(
        specs.join(format!("{name}.yaml")),
        format!(
            "name: {name}\nseed: 7\ndatasets:\n\
             \x20 - {{id: clutter, kind: filtered_noise, family: exponential, alpha_h: 2.0, alpha_v: 0.5, size: [64, 64], samples: 60}}\n\
             analysis:\n  levels: 2\nlocation:\n  clutter: clutter\n  fit_samples: 20\n\
             \x20 original_samples: 40\n  methods: [original, method1, method2]\n\
             \x20 generated_samples: 40\n  targets: [constant]\n  scr_db: [30, 50]\n  repeats: 1\n\
             \x20 test_sets: [held_out, all]\n  training: {{epochs: 8, batch_size: 8}}\n"
        ),
    )
    .unwrap();
    let statements: Vec<_> = rep::cnn::gain_statements()
        .into_iter()
        .filter(|st| st.terms[0].0.spec == name)
        .collect();
    assert_eq!(
        statements.len(),
        4,
        "the gain at 50 % and at 90 %, tested on the held-out and on all originals"
    );
    let coverage = runs::Coverage {
        recipes: Vec::new(),
        statements: statements.clone(),
        solver: false,
    };
    let opts = options(dir.path().join("out"), specs, 2);
    let runs = runs::run_all(&opts, &coverage).unwrap();
    let read = |folder: &Path, file: &str| {
        let f = std::fs::File::open(folder.join(file)).unwrap();
        ParquetReader::new(f).finish().unwrap()
    };
    // The crossing of `method` at `column` in a run's summary, tested on `set` (NaN: not
    // reached).
    let crossing = |folder: &Path, set: &str, method: &str, column: &str| -> f64 {
        let df = read(folder, "location_summary.parquet");
        let m = df.column("method").unwrap().str().unwrap().clone();
        let t = df.column("test_set").unwrap().str().unwrap().clone();
        let x = df.column(column).unwrap().f64().unwrap().clone();
        let i = (0..df.height())
            .find(|&i| m.get(i) == Some(method) && t.get(i) == Some(set))
            .unwrap();
        x.get(i).unwrap_or(f64::NAN)
    };
    let dissertation = rep::reference::Dissertation::load().unwrap();
    let mut tables = rep::extract::Tables::default();
    let readings = [
        ("held_out", "scr_50_db"),
        ("held_out", "scr_90_db"),
        ("all", "scr_50_db"),
        ("all", "scr_90_db"),
    ];
    for (st, (set, column)) in statements.iter().zip(readings) {
        let stated = rep::evaluate_statement(st, &dissertation, &runs, &mut tables).unwrap();
        let mut values = vec![];
        let mut bounded = 0;
        for (_, f) in &runs[0].runs {
            let mut base = crossing(f, set, "original", column);
            let m = ["method1", "method2"].map(|m| crossing(f, set, m, column));
            // Reached by no `original` network up to 50 dB: above it, a lower bound.
            let above = base.is_nan() && m.iter().all(|x| x.is_finite());
            if above {
                base = 50.0;
            }
            let v = (2.0 * base - m[0] - m[1]) / 2.0;
            if v.is_finite() {
                values.push(v);
                bounded += usize::from(m.contains(&30.0) || above);
            }
        }
        assert_eq!(stated.given, values.len(), "{set} {column}");
        assert_eq!(stated.bounded, bounded, "{set} {column}");
        if !values.is_empty() {
            let want = values.iter().sum::<f64>() / values.len() as f64;
            assert!((stated.tool.mean - want).abs() < 1e-9, "{set} {column}");
        }
        eprintln!(
            "{set} {column}: {} value(s), {bounded} bound(s)",
            values.len()
        );
        if column == "scr_50_db" {
            // At 30 dB every network of this spec already finds the target half the time.
            assert!(bounded > 0, "a bounded case is tested");
        }
    }
}

/// An `original` network that never reaches the level in the SCRs swept gives its repeat a
/// gain read at the highest SCR and counted as a lower bound, not a missing value; a method
/// already at the level at the lowest SCR bounds it too (tables written here, one repeat).
#[test]
fn an_originals_network_below_the_level_bounds_the_gain_at_the_highest_scr() {
    use polars::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("seed-1");
    std::fs::create_dir_all(&folder).unwrap();
    let methods = ["original", "method1", "method2"];
    let mut summary = df!(
        "target" => ["constant"; 3],
        "test_set" => ["held_out"; 3],
        "method" => methods,
        "scr_50_db" => [Some(10.0), Some(-8.0), Some(-5.0)],
        "scr_90_db" => [None, Some(2.0), Some(4.0)],
    )
    .unwrap();
    let mut location = df!(
        "target" => ["constant"; 6],
        "test_set" => ["held_out"; 6],
        "method" => methods.iter().flat_map(|m| [*m; 2]).collect::<Vec<_>>(),
        "scr_db" => [-8.0, 20.0].repeat(3),
    )
    .unwrap();
    for (name, df) in [
        ("location_summary", &mut summary),
        ("location", &mut location),
    ] {
        let f = std::fs::File::create(folder.join(format!("{name}.parquet"))).unwrap();
        ParquetWriter::new(f).finish(df).unwrap();
    }
    let runs = vec![runs::SpecRuns {
        spec: "cnn_location_gain",
        runs: vec![(1, folder)],
    }];
    let statements = rep::cnn::gain_statements();
    let dissertation = rep::reference::Dissertation::load().unwrap();
    let mut tables = rep::extract::Tables::default();
    // 50 %: original at 10 dB, Method 1 already at -8 dB (the lowest swept): a bound.
    let at_50 = rep::evaluate_statement(&statements[0], &dissertation, &runs, &mut tables).unwrap();
    assert_eq!((at_50.given, at_50.bounded), (1, 1));
    assert!((at_50.tool.mean - (18.0 + 15.0) / 2.0).abs() < 1e-12);
    // 90 %: original never (read at +20 dB), the methods at 2 and 4 dB.
    let at_90 = rep::evaluate_statement(&statements[1], &dissertation, &runs, &mut tables).unwrap();
    assert_eq!((at_90.given, at_90.bounded), (1, 1));
    assert!((at_90.tool.mean - (18.0 + 16.0) / 2.0).abs() < 1e-12);
}
