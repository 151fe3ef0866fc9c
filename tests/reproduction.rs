//! The reproduction document (`isar-clutter reproduce`): the tables it can check in seconds
//! (Table 3 exactly, Table 4 within the spread of two seeded repeats) reproduced from real
//! runs of the shipped specs, and a damaged run folder refused with the file named and no
//! document written.

use isar_clutter::reproduction::{self as rep, compare::Verdict, render};
use std::path::{Path, PathBuf};

fn header() -> render::Header {
    render::Header {
        command: "test".into(),
        wall_s: None,
        machine: "test".into(),
        tool: "test".into(),
        repeats: 2,
        builds: vec![],
    }
}

fn run(out: &Path, numbers: &[u32]) -> (rep::Coverage, Vec<rep::SpecRuns>) {
    let recipes = rep::Coverage::tables(numbers);
    let opts = rep::Options {
        out: out.to_path_buf(),
        specs: PathBuf::from("experiments"),
        repeats: 2,
        threads: 2,
        write_only: false,
        quiet: true,
    };
    let runs = rep::run_all(&opts, &recipes).unwrap();
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
    let counts = rep::write(&recipes, &runs, &doc, &header()).unwrap();
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
    let builds = rep::builds(&runs);
    assert_eq!(builds.len(), 1, "{builds:?}");
    assert!(
        text.contains(&format!("- Results computed by: {} (", builds[0].0)),
        "{text}"
    );
    assert!(
        text.contains("| 1 | Correlation | 0.6481 | 0.6481 |"),
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
    let numbers: Vec<u32> = rep::Coverage::all()
        .recipes
        .iter()
        .map(|r| r.number)
        .collect();
    let recipes = rep::Coverage::tables(&numbers);
    let opts = rep::Options {
        out: dir.path().to_path_buf(),
        specs: PathBuf::from("experiments"),
        repeats: 1,
        threads: 2,
        write_only: false,
        quiet: true,
    };
    let runs = rep::run_all(&opts, &recipes).unwrap();
    let doc = dir.path().join("reproduction.md");
    rep::write(&recipes, &runs, &doc, &header()).unwrap();
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
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
            .find(|x| x["number"].as_u64() == Some(n))
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
