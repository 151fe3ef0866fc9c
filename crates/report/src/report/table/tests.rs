//! Tests of the comparison tables: pivoting, filters, limits and layouts, with a slow oracle
//! for the pivot's keys on seeded random input.

use super::*;
use polars::prelude::*;

/// `analysis_summary.parquet` of 10 jobs `j0..j9` (alpha_h = 0..9), three directions each:
/// 30 rows of the summary table. With `job: false` the file has no `job` column.
fn summary(dir: &Path, job: bool) {
    let n = 30;
    let mut cols = vec![
        Column::new("dataset".into(), vec!["d"; n]),
        Column::new("source".into(), vec!["original"; n]),
        Column::new("level".into(), vec![1i64; n]),
        Column::new(
            "direction".into(),
            (0..n).map(|i| ["H", "V", "D"][i % 3]).collect::<Vec<_>>(),
        ),
        Column::new(
            "mean_correlation".into(),
            (0..n).map(|i| i as f64 / 100.0).collect::<Vec<_>>(),
        ),
        Column::new(
            "alpha_h".into(),
            (0..n).map(|i| (i / 3) as f64).collect::<Vec<_>>(),
        ),
    ];
    if job {
        let ids: Vec<String> = (0..n).map(|i| format!("j{}", i / 3)).collect();
        cols.insert(0, Column::new("job".into(), ids));
    }
    let mut df = DataFrame::new(n, cols).unwrap();
    crate::io::parquet::write_parquet(&dir.join("analysis_summary.parquet"), &mut df).unwrap();
}

#[test]
fn a_long_table_keeps_the_chosen_jobs_rows_up_to_the_bound() {
    let tmp = tempfile::tempdir().unwrap();
    let def = standard()
        .into_iter()
        .find(|d| d.name == "summary")
        .unwrap();
    let jobs: BTreeSet<&str> = ["j0", "j9"].into_iter().collect();
    let render = |max_rows| {
        let limit = RowLimit {
            jobs: &jobs,
            max_rows,
        };
        render_limited(
            tmp.path(),
            &def,
            &[],
            None,
            Format::Text,
            false,
            Some(limit),
        )
        .unwrap()
        .unwrap()
    };
    summary(tmp.path(), true);
    let whole = render(30);
    assert_eq!(
        (whole.rows, whole.total_rows, whole.by_job),
        (30, 30, false)
    );
    assert_eq!(
        whole.text,
        super::render(tmp.path(), &def, &[], None, Format::Text, false)
            .unwrap()
            .unwrap()
    );
    let cut = render(10);
    assert_eq!((cut.rows, cut.total_rows, cut.by_job), (6, 30, true));
    let values: Vec<&str> = cut.text.lines().skip(4).map(|l| l.trim_end()).collect();
    assert!(
        values.iter().take(3).all(|l| l.contains(" 0.0 ")),
        "{values:?}"
    );
    assert!(
        values.iter().skip(3).all(|l| l.contains(" 9.0 ")),
        "{values:?}"
    );
    let tight = render(4);
    assert_eq!((tight.rows, tight.by_job), (4, true));
    // Without a job column: the first rows.
    summary(tmp.path(), false);
    let first = render(10);
    assert_eq!(
        (first.rows, first.total_rows, first.by_job),
        (10, 30, false)
    );
}

/// [`pivoted_rows`] against the obvious pass that keeps every key as strings, on seeded
/// random columns with nulls, `-` and repeated keys, some rows filtered out.
#[test]
fn pivoted_rows_match_the_exact_keys() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let n = 2000;
    let mut pick = |choices: &[Option<&str>]| -> StringChunked {
        (0..n)
            .map(|_| choices[rng.random_range(0..choices.len())])
            .collect()
    };
    let keys = vec![
        pick(&[Some("a"), Some("b"), None, Some("-")]),
        pick(&[Some("1"), Some("2"), Some("3")]),
        pick(&[None, Some("-")]),
    ];
    let pivot = pick(&[Some("x"), None, Some("y")]);
    let jobs = pick(&[Some("j1"), Some("j2"), Some("j3"), None]);
    let keep: Vec<bool> = (0..n).map(|_| rng.random_bool(0.8)).collect();
    let chosen: BTreeSet<&str> = ["j2"].into_iter().collect();
    let limit = RowLimit {
        jobs: &chosen,
        max_rows: 5,
    };
    let got = pivoted_rows(&keys, &pivot, "null", &keep, Some(&jobs), Some(limit));
    // The oracle: keys kept whole.
    let mut order: Vec<Vec<String>> = vec![];
    let mut marked: Vec<bool> = vec![];
    let mut columns: Vec<String> = vec![];
    for i in (0..n).filter(|&i| keep[i]) {
        let key: Vec<String> = keys
            .iter()
            .map(|c| c.get(i).unwrap_or("-").to_string())
            .collect();
        let r = match order.iter().position(|k| *k == key) {
            Some(r) => r,
            None => {
                order.push(key);
                marked.push(false);
                order.len() - 1
            }
        };
        assert_eq!(got.row_of[i], r as u32, "row {i}");
        marked[r] |= jobs.get(i).is_none_or(|j| chosen.contains(j));
        let p = pivot.get(i).unwrap_or("null").to_string();
        if !columns.contains(&p) {
            columns.push(p);
        }
    }
    assert!((0..n).all(|i| keep[i] || got.row_of[i] == u32::MAX));
    assert_eq!(got.marked, marked);
    assert_eq!(got.columns, columns);
    let set: Vec<bool> = (0..keys.len())
        .map(|k| order.iter().any(|key| key[k] != "-"))
        .collect();
    assert_eq!(got.set, set);
    assert_eq!(set, [true, true, false]);
}
