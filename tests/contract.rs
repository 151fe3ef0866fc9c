//! The results contract (`crates/tables/src/io/results.rs`) between the runner that writes a results folder
//! and the report and reproduction that read it: a writer's undeclared column is refused, the
//! comparison tables read only declared columns, a run's tables hold only declared columns
//! (and its swept parameters, and the levels of its per-level columns), and its manifest reads
//! back through the contract's struct.

mod common;

use isar_clutter::io::manifest::{self, Manifest};
use isar_clutter::io::results::{self, check_columns, col};
use std::collections::BTreeSet;

#[test]
fn an_undeclared_column_or_table_is_refused_naming_it() {
    let ok = [col::JOB, col::DATASET, col::VALUE];
    check_columns("similarity", ok, &[]).unwrap();
    let e = check_columns("similarity", [col::JOB, "valeu"], &[]).unwrap_err();
    assert!(e.to_string().contains("\"valeu\""), "{e}");
    let e = check_columns("similarities", ok, &[]).unwrap_err();
    assert!(e.to_string().contains("\"similarities\""), "{e}");
    // A swept parameter's column, under its key or `swept_<key>`, and intermediate tables.
    let swept = ["r_h".to_string(), "samples".to_string()];
    check_columns("similarity", ["r_h", "swept_samples"], &swept).unwrap();
    assert!(check_columns("similarity", ["swept_r_v"], &swept).is_err());
    check_columns("_plant_stats", ["anything"], &[]).unwrap();
    // Per-level columns: any level of a prefix the table repeats by level, nothing else.
    check_columns("synthesis_params", ["r_h4", "r_v12"], &[]).unwrap();
    for bad in ["r_h0", "r_hx", "r_h", "r_h04"] {
        assert!(
            check_columns("synthesis_params", [bad], &[]).is_err(),
            "{bad}"
        );
    }
    assert!(check_columns("similarity", ["r_h4"], &[]).is_err());
}

#[test]
fn a_deeper_method_2_writes_its_levels_beyond_the_third() {
    // A 4-level Method 2 fit (the contract once listed levels 1-3 only, and such a run failed
    // at the merge on `r_h4`): its parameters reach synthesis_params, every level's.
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("s.yaml");
    std::fs::write(
        &spec,
        "name: deep\nseed: 5\ndatasets:\n  - id: d\n    kind: filtered_noise\n    \
         family: dyadic\n    r_h: [0.4, 0.3, 0.2, 0.1]\n    r_v: [0.3, 0.2, 0.1, 0.05]\n    \
         size: [32, 32]\n    samples: 40\n    half_width: 16\nanalysis:\n  levels: 4\n\
         synthesis:\n  methods: [method2]\n  samples: 10\n  half_width: 16\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    common::run_spec(&spec, &out, &["--no-report"]);
    let df = isar_clutter::io::parquet::read_parquet(&results::SYNTHESIS_PARAMS.path(&out))
        .unwrap()
        .unwrap();
    for c in ["r_h1", "r_h4", "r_v1", "r_v4"] {
        let v = df.column(c).unwrap().f64().unwrap();
        assert!(v.iter().flatten().all(f64::is_finite), "{c}");
        assert_eq!(v.null_count(), 0, "{c}");
    }
    assert!(df.column("r_h5").is_err());
}

#[test]
fn the_contract_names_each_table_and_column_once() {
    let names: BTreeSet<&str> = results::ALL.iter().map(|t| t.name).collect();
    assert_eq!(names.len(), results::ALL.len());
    for t in results::ALL {
        let cols: BTreeSet<&str> = t.columns.iter().copied().collect();
        assert_eq!(cols.len(), t.columns.len(), "{} repeats a column", t.name);
        assert_eq!(results::table(t.name), Some(t));
    }
}

#[test]
fn the_comparison_tables_read_only_declared_columns() {
    for def in isar_clutter::report::table::standard() {
        let declared = def.table.columns;
        let read = def
            .rows
            .iter()
            .chain(&def.values)
            .chain(std::iter::once(&def.pivot))
            .chain(def.filters.iter().map(|(c, _)| c));
        for c in read {
            assert!(
                declared.contains(c),
                "table {} reads {c}, which {} does not declare",
                def.name,
                def.table.name
            );
        }
    }
}

#[test]
fn a_run_writes_only_declared_columns() {
    // Analysis, synthesis, similarity and model order with a swept parameter: every table the
    // run writes holds the contract's columns and the swept key's.
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("s.yaml");
    std::fs::write(
        &spec,
        "name: contract\nseed: 3\ndatasets:\n  - id: d\n    kind: filtered_noise\n    \
         family: exponential\n    alpha_h: 0.5\n    alpha_v: 0.3\n    size: [8, 8]\n    \
         samples: 20\nanalysis:\n  levels: 2\nsynthesis:\n  methods: [method1]\n  \
         samples: 20\nmetrics: [multiscale_rmse, kl_pixel]\nsweep:\n  grid:\n    \
         datasets.d.samples: [20, 24]\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    common::run_spec(&spec, &out, &["--no-report"]);
    let swept = isar_clutter::run::plan::load(&spec).unwrap().param_keys;
    assert!(!swept.is_empty());
    let mut seen = 0;
    for e in std::fs::read_dir(&out).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_none_or(|x| x != "parquet") {
            continue;
        }
        let name = p.file_stem().unwrap().to_str().unwrap().to_string();
        let df = isar_clutter::io::parquet::read_parquet(&p)
            .unwrap()
            .unwrap();
        let cols: Vec<&str> = df.get_column_names().iter().map(|c| c.as_str()).collect();
        check_columns(&name, cols, &swept).unwrap();
        seen += 1;
    }
    assert!(seen >= 6, "only {seen} tables written");

    // The manifest reads back through the contract's struct, with the fields the job kinds
    // add (a renamed field there reads as absent here).
    let m = Manifest::read(&out).unwrap();
    assert_eq!(m.format, manifest::FORMAT);
    assert_eq!(m.tool.name, "isar-clutter");
    // The folder's marker names the tool as every version has (a folder of an earlier run is
    // the tool's own).
    let owner = std::fs::read_to_string(out.join(".isar-clutter/owner.json")).unwrap();
    let owner: serde_json::Value = serde_json::from_str(&owner).unwrap();
    assert_eq!(owner["tool"], "isar-clutter");
    assert_eq!(m.master_seed, Some(3));
    assert!(m.timings.is_some_and(|t| t.total_s > 0.0));
    assert!(m.finished_unix_s.is_some());
    let jobs = isar_clutter::io::results::JOBS.read(&out).unwrap().unwrap();
    assert_eq!(m.jobs.len(), jobs.height());
    assert!(m
        .jobs
        .iter()
        .all(|j| j.ok() && j.seed.is_some() && !j.identity.is_empty()));
    assert!(m
        .jobs
        .iter()
        .all(|j| j.dataset.as_deref() == Some("d") && j.data_seed.is_some()));
    let synthesis: Vec<_> = m.jobs.iter().filter(|j| j.kind == "synthesis").collect();
    assert_eq!(synthesis.len(), 2);
    assert!(synthesis
        .iter()
        .all(|j| j.method.as_deref() == Some("method1") && j.generation_seed.is_some()));
}
