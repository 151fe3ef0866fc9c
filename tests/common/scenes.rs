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

/// The window and cut the scene tests use, as dataset fields: patches of 8 on a stride of
/// 8 x 6 inside rows 2..38 and columns 1..29 of a 40 x 30 scene, around the box at rows
/// 10..14, columns 10..14 (14 places).
pub const CUT_FIELDS: &str = "window: {row: 2, col: 1, size: [36, 28]}, cut: {patch: 8, \
                              stride: [8, 6], avoid: [{row: 10, col: 10, size: [4, 4]}]}";

/// `isar-clutter cut` of `inputs` into `out` with the options of [`CUT_FIELDS`] (and
/// `extra`); what it said on stderr.
pub fn cut_cli(inputs: &[PathBuf], out: &Path, extra: &[&str]) -> String {
    cut_cli_in(inputs, out, &["--window", "2:38,1:29"], extra)
}

/// [`cut_cli`] with the window given by `place` (`--window ...` or `--map-box ...`).
pub fn cut_cli_in(inputs: &[PathBuf], out: &Path, place: &[&str], extra: &[&str]) -> String {
    let mut args: Vec<String> = vec!["cut".into()];
    for i in inputs {
        args.extend(["--input".into(), i.display().to_string()]);
    }
    let options = ["--patch", "8", "--stride", "8x6"];
    args.extend(
        options
            .iter()
            .chain(place)
            .chain(&["--avoid", "10:14,10:14"])
            .map(|a| a.to_string()),
    );
    args.extend(extra.iter().map(|a| a.to_string()));
    args.extend(["--out".into(), out.display().to_string()]);
    let o = super::bin(&args);
    assert!(o.status.success(), "{}", super::text(&o));
    super::text(&o)
}
