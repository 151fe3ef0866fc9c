//! Helpers of the scene readers' tests (`uavsar`, `geotiff`, `sicd`): a spec analysing one
//! dataset, its run, the comparison of two runs' tables and a refused validation.

use std::path::{Path, PathBuf};

/// The spec `dir/NAME.yaml` analysing the one dataset `{id: scene, FIELDS}` at 2 levels.
pub fn spec(dir: &Path, name: &str, fields: &str) -> PathBuf {
    let path = dir.join(format!("{name}.yaml"));
    std::fs::write(
        &path,
        format!("name: {name}\nseed: 3\ndatasets:\n  - {{id: scene, {fields}}}\nanalysis:\n  levels: 2\n"),
    )
    .unwrap();
    path
}

/// Runs the spec of `fields` into `dir/out_NAME` without a report; the folder.
pub fn run(dir: &Path, name: &str, fields: &str) -> PathBuf {
    let out = dir.join(format!("out_{name}"));
    super::run_spec(&spec(dir, name, fields), &out, &["--no-report"]);
    out
}

/// Asserts that the runs `a` and `b` wrote the same tables, value for value (the job tables,
/// with their timings, aside), and at least 3 of them.
pub fn assert_same_tables(a: &Path, b: &Path) {
    let (ta, tb) = (super::tables(a), super::tables(b));
    let names: Vec<&String> = ta.keys().filter(|n| !n.starts_with("jobs")).collect();
    assert!(names.len() >= 3, "tables: {names:?}");
    for n in names {
        assert!(
            ta[n].equals_missing(&tb[n]),
            "{n} differs between {} and {}:\n{}\n{}",
            a.display(),
            b.display(),
            ta[n],
            tb[n]
        );
    }
}

/// `isar-clutter validate` of the spec of `fields`: asserts that it is refused (exit 2) and
/// returns what it said.
pub fn refused(dir: &Path, name: &str, fields: &str) -> String {
    let o = super::bin(&["validate", spec(dir, name, fields).to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{name}: {}", super::text(&o));
    super::text(&o)
}

/// `isar-clutter validate` of the spec of `fields` succeeds.
pub fn assert_valid(dir: &Path, name: &str, fields: &str) {
    let o = super::bin(&["validate", spec(dir, name, fields).to_str().unwrap()]);
    assert!(o.status.success(), "{name}: {}", super::text(&o));
}

/// The `dataset_files` the manifest of the run `out` records for its first job.
pub fn dataset_files(out: &Path) -> serde_json::Value {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    m["jobs"][0]["dataset_files"].clone()
}
