//! The `table` command: the comparison tables a reader of the dissertation expects, printed
//! from a results folder's Parquet files alone (no recomputation). Each table filters one
//! long-format file, groups its rows by key columns and spreads one column (the pivot, by
//! default the method) across the page, in aligned text for the terminal or in Markdown.

use crate::io::results::{self, col, Table};
use anyhow::{bail, Context, Result};
use polars::prelude::{DataFrame, DataType, StringChunked};
use std::collections::{BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::Path;

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Aligned columns.
    Text,
    /// GitHub-flavoured Markdown.
    Md,
    /// An HTML `<table>` with a caption (for the report).
    Html,
}

/// A table definition: which file, which rows, how to lay them out.
#[derive(Debug, Clone)]
pub struct TableDef {
    /// Name used by `--table`.
    pub name: &'static str,
    /// Title printed above the table.
    pub title: &'static str,
    /// The table of the results folder it reads.
    pub table: Table,
    /// Fixed filters `(column, accepted values)`.
    pub filters: Vec<(&'static str, Vec<&'static str>)>,
    /// Row key columns (swept parameter columns are added after them).
    pub rows: Vec<&'static str>,
    /// Column spread across the page.
    pub pivot: &'static str,
    /// Value columns (one block of pivot columns per value column).
    pub values: Vec<&'static str>,
    /// Header label of each value column's block (with several value columns).
    pub value_labels: Vec<&'static str>,
    /// Prefix of the pivot values in headers (`order ` for model order).
    pub pivot_prefix: &'static str,
    /// Label of a null pivot value.
    pub null_label: &'static str,
}

/// Row keys shown only where the kept rows hold more than one value: `reference` is
/// `in_sample` on every row of a run without `synthesis.held_out`.
const SHOWN_WHEN_VARIED: [&str; 1] = [col::REFERENCE];

/// Whether the kept rows of `column` hold one value (or none).
fn single_value(column: &StringChunked, keep: &[bool]) -> bool {
    let mut seen = None;
    for (v, _) in column.iter().zip(keep).filter(|(_, k)| **k) {
        match seen {
            None => seen = Some(v),
            Some(s) if s != v => return false,
            Some(_) => {}
        }
    }
    true
}

/// The standard tables, in print order.
pub fn standard() -> Vec<TableDef> {
    vec![
        TableDef {
            name: "rmse",
            title: "Multiscale correlation RMSE, eq. 25 (Tables 6, 26, 28): original vs each method; noise_floor = two independent stacks of the original; reference held_out = against originals no fit saw",
            table: results::SIMILARITY,
            filters: vec![(col::METRIC, vec!["multiscale_rmse"])],
            rows: vec![
                col::DATASET,
                col::REFERENCE,
                col::STATISTIC,
                col::LEVEL,
                col::DIRECTION,
            ],
            pivot: col::METHOD,
            values: vec![col::VALUE],
            value_labels: vec![],
            pivot_prefix: "",
            null_label: "-",
        },
        TableDef {
            name: "cmd",
            title: "Correlation matrix distance, eq. 24 (Tables 7, 25, 27)",
            table: results::SIMILARITY,
            filters: vec![(col::METRIC, vec!["cmd"])],
            rows: vec![col::DATASET, col::REFERENCE],
            pivot: col::METHOD,
            values: vec![col::VALUE],
            value_labels: vec![],
            pivot_prefix: "",
            null_label: "-",
        },
        TableDef {
            name: "kl",
            title: "Mean KL divergence by pixel and by image area (Tables 8-10)",
            table: results::SIMILARITY,
            filters: vec![
                (col::METRIC, vec!["kl_pixel", "kl_area"]),
                (col::STATISTIC, vec!["mean"]),
            ],
            rows: vec![col::DATASET, col::REFERENCE, col::METRIC, col::COMPONENT],
            pivot: col::METHOD,
            values: vec![col::VALUE],
            value_labels: vec![],
            pivot_prefix: "",
            null_label: "-",
        },
        TableDef {
            name: "model_order",
            title: "Model order, per-pixel KL in dB (Tables 1-2): mean and worst pixel",
            table: results::MODEL_ORDER,
            filters: vec![],
            rows: vec![col::DATASET, col::COMPONENT],
            pivot: col::MODEL_ORDER,
            values: vec![col::KL_MEAN_DB, col::KL_WORST_DB],
            value_labels: vec!["mean dB", "worst dB"],
            pivot_prefix: "order ",
            null_label: "noise_floor",
        },
        TableDef {
            name: "hypotheses",
            title: "Hypothesis tests (Table 24; Table 16 = mean pixel variance); definitions in docs/hypotheses.md",
            table: results::HYPOTHESES,
            filters: vec![],
            rows: vec![col::HYPOTHESIS, col::DATASET, col::STATISTIC],
            pivot: col::VERDICT,
            values: vec![col::VALUE],
            value_labels: vec![],
            pivot_prefix: "",
            null_label: "value",
        },
        TableDef {
            name: "calibration",
            title: "Sphere calibration (Figs. 11-14): calibrated vs Mie, dB and degrees; inner = central 90 % of the band",
            table: results::CALIBRATION_SUMMARY,
            filters: vec![],
            rows: vec![col::STATISTIC],
            pivot: col::BAND,
            values: vec![col::VALUE],
            value_labels: vec![],
            pivot_prefix: "",
            null_label: "-",
        },
        TableDef {
            name: "summary",
            title: "Mean directional correlation by level (Table 4); source = original or the method",
            table: results::ANALYSIS_SUMMARY,
            filters: vec![],
            rows: vec![col::DATASET, col::LEVEL, col::DIRECTION],
            pivot: col::SOURCE,
            values: vec![col::MEAN_CORRELATION],
            value_labels: vec![],
            pivot_prefix: "",
            null_label: "-",
        },
    ]
}

/// A column read as display strings (`None` for null).
pub(super) fn strings(df: &DataFrame, name: &str) -> Result<Vec<Option<String>>> {
    let col = df
        .column(name)
        .with_context(|| format!("no column {name:?}"))?;
    let s = col.cast(&DataType::String)?;
    Ok(s.str()?.iter().map(|v| v.map(str::to_string)).collect())
}

/// A column read as display strings in place (`None` for null): a row's value is borrowed
/// with `get`, not copied (a sweep of 100,000 jobs has 3 million rows of `analysis_summary`).
pub(super) fn texts(df: &DataFrame, name: &str) -> Result<StringChunked> {
    let col = df
        .column(name)
        .with_context(|| format!("no column {name:?}"))?;
    Ok(col.cast(&DataType::String)?.str()?.rechunk().into_owned())
}

/// The rows of a pivoted table, found in one pass over the kept rows of its table without
/// keeping their keys: a key (the key columns' values, null as `-`) is known by a 128-bit hash
/// of it, so a table of millions of rows holds a number a row, not strings.
struct Pivoted {
    /// The pivoted row of each table row, in order of first appearance (`u32::MAX`: not kept).
    row_of: Vec<u32>,
    /// Per pivoted row: whether it holds a value of a job the limit keeps (or of no job).
    marked: Vec<bool>,
    /// Per key column: whether any kept row has a value other than `-` in it.
    set: Vec<bool>,
    /// The pivot's values (null as `null_label`), in order of first appearance.
    columns: Vec<String>,
}

/// The hash identifying a key: two SipHash passes with different prefixes.
fn key_hash(key_cols: &[StringChunked], i: usize) -> u128 {
    use std::hash::{Hash, Hasher};
    let half = |salt: u8| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        salt.hash(&mut h);
        for c in key_cols {
            c.get(i).unwrap_or("-").hash(&mut h);
        }
        h.finish()
    };
    (u128::from(half(0)) << 64) | u128::from(half(1))
}

/// [`Pivoted`] of the rows `keep` selects.
fn pivoted_rows(
    key_cols: &[StringChunked],
    pivot_col: &StringChunked,
    null_label: &str,
    keep: &[bool],
    job_col: Option<&StringChunked>,
    limit: Option<RowLimit>,
) -> Pivoted {
    let mut out = Pivoted {
        row_of: vec![u32::MAX; keep.len()],
        marked: Vec::new(),
        set: vec![false; key_cols.len()],
        columns: Vec::new(),
    };
    let mut ids: HashMap<u128, u32> = HashMap::new();
    let mut seen: std::collections::HashSet<&str> = std::collections::HashSet::new();
    for i in (0..keep.len()).filter(|&i| keep[i]) {
        let n = out.marked.len() as u32;
        let r = *ids.entry(key_hash(key_cols, i)).or_insert_with(|| {
            out.marked.push(false);
            n
        });
        out.row_of[i] = r;
        for (k, c) in key_cols.iter().enumerate() {
            out.set[k] |= c.get(i).unwrap_or("-") != "-";
        }
        if let (Some(jobs), Some(limit)) = (job_col, limit) {
            out.marked[r as usize] |= jobs.get(i).is_none_or(|j| limit.jobs.contains(j));
        }
        let p = pivot_col.get(i).unwrap_or(null_label);
        if seen.insert(p) {
            out.columns.push(p.to_string());
        }
    }
    out
}

/// A column read as f64.
pub(super) fn floats(df: &DataFrame, name: &str) -> Result<Vec<Option<f64>>> {
    let col = df
        .column(name)
        .with_context(|| format!("no column {name:?}"))?;
    let s = col.cast(&DataType::Float64)?;
    Ok(s.f64()?.iter().collect())
}

/// Formats a value with four significant digits (scientific below 1e-3).
pub fn format_value(v: f64) -> String {
    if v.is_nan() {
        "NaN".into()
    } else if v == 0.0 || (v.abs() >= 1e-3 && v.abs() < 1e5) {
        let digits = (3 - v.abs().log10().floor().max(-1.0) as i32).clamp(0, 6) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

/// Renders one table from `dir`, with extra `filters` (`column=value[,value]`) and an optional
/// pivot override. `Ok(None)` when the file is missing or no row passes the filters, and, unless
/// `strict`, when a filter or the pivot names a column this table lacks.
///
/// # Errors
/// If the file cannot be read, or (when `strict`) a filter or pivot names a column the file
/// lacks.
pub fn render(
    dir: &Path,
    def: &TableDef,
    filters: &[(String, Vec<String>)],
    pivot: Option<&str>,
    format: Format,
    strict: bool,
) -> Result<Option<String>> {
    Ok(render_limited(dir, def, filters, pivot, format, strict, None)?.map(|r| r.text))
}

/// A bound on the rows of a table in the report of a big run: a table with more than
/// `max_rows` rows shows only its rows holding a value of one of `jobs` (or of no job), when
/// its file has a `job` column, and at most the first `max_rows` of those.
#[derive(Debug, Clone, Copy)]
pub(super) struct RowLimit<'a> {
    /// The jobs whose rows are kept (the jobs with figures).
    pub jobs: &'a BTreeSet<&'a str>,
    /// The most rows a table shows.
    pub max_rows: usize,
}

/// A rendered table, and how many of its rows it shows.
#[derive(Debug, Clone)]
pub(super) struct Rendered {
    /// The table.
    pub text: String,
    /// Rows shown.
    pub rows: usize,
    /// Rows of the whole table.
    pub total_rows: usize,
    /// Whether the rows were restricted to the [`RowLimit`]'s jobs.
    pub by_job: bool,
}

/// [`render`], bounded by `limit` when one is given.
///
/// # Errors
/// As [`render`].
///
/// Long because it pivots, labels and lays out the table in two passes over its rows (the
/// pivoted rows and the pivot's columns, then the shown rows' keys and cells), each step
/// reading the maps of the one before.
pub(super) fn render_limited(
    dir: &Path,
    def: &TableDef,
    filters: &[(String, Vec<String>)],
    pivot: Option<&str>,
    format: Format,
    strict: bool,
    limit: Option<RowLimit>,
) -> Result<Option<Rendered>> {
    let path = def.table.path(dir);
    let Some(df) = crate::io::parquet::read_parquet(&path)? else {
        return Ok(None);
    };
    let names: Vec<String> = df
        .get_column_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let all_filters: Vec<(String, Vec<String>)> = def
        .filters
        .iter()
        .map(|(c, v)| (c.to_string(), v.iter().map(|s| s.to_string()).collect()))
        .chain(filters.iter().cloned())
        .collect();
    let Some(keep) = kept_rows(&df, &path, &all_filters, strict)? else {
        return Ok(None);
    };
    let pivot = pivot.unwrap_or(def.pivot);
    if !names.iter().any(|n| n == pivot) {
        if !strict {
            return Ok(None);
        }
        bail!(
            "{}: no column {pivot:?} to pivot on (columns: {})",
            path.display(),
            names.join(", ")
        );
    }
    // Row keys: the definition's, the pivot of the definition when it is overridden, then the
    // swept parameters; never the pivot itself.
    let mut keys: Vec<String> = def
        .rows
        .iter()
        .chain(std::iter::once(&def.pivot))
        .map(|s| s.to_string())
        .filter(|k| k != pivot && names.contains(k))
        .collect();
    for n in &names {
        // Any column the contract does not declare for the table is a swept parameter.
        if !def.table.columns.contains(&n.as_str()) && !keys.contains(n) && n != pivot {
            keys.push(n.clone());
        }
    }
    let mut key_cols: Vec<StringChunked> =
        keys.iter().map(|k| texts(&df, k)).collect::<Result<_>>()?;
    // A column that only some runs vary (`reference`) is a key where its kept rows differ.
    for k in (0..keys.len()).rev() {
        if SHOWN_WHEN_VARIED.contains(&keys[k].as_str()) && single_value(&key_cols[k], &keep) {
            keys.remove(k);
            key_cols.remove(k);
        }
    }
    let pivot_col = texts(&df, pivot)?;
    let value_cols: Vec<Vec<Option<f64>>> = def
        .values
        .iter()
        .map(|v| floats(&df, v))
        .collect::<Result<_>>()?;
    // With a limit: whether a row of the table holds a value of a job it keeps (or of no job).
    let job_col = match limit {
        Some(_) if names.iter().any(|n| n == col::JOB) => Some(texts(&df, col::JOB)?),
        _ => None,
    };
    let rows = pivoted_rows(
        &key_cols,
        &pivot_col,
        def.null_label,
        &keep,
        job_col.as_ref(),
        limit,
    );
    let col_order = rows.columns;
    // Drop key columns that are constant "-" (e.g. level for CMD rows).
    let used: Vec<usize> = (0..keys.len()).filter(|&k| rows.set[k]).collect();
    let mut header: Vec<String> = used.iter().map(|&k| keys[k].clone()).collect();
    for (v, name) in def.values.iter().enumerate() {
        for c in &col_order {
            let c = if c == def.null_label {
                c.clone()
            } else {
                format!("{}{c}", def.pivot_prefix)
            };
            header.push(match def.value_labels.get(v) {
                Some(label) if def.values.len() > 1 => format!("{label}, {c}"),
                None if def.values.len() > 1 => format!("{name}, {c}"),
                _ => c,
            });
        }
    }
    let total_rows = rows.marked.len();
    let by_job = job_col.is_some() && limit.is_some_and(|l| total_rows > l.max_rows);
    let shown: Vec<usize> = match limit {
        Some(l) if total_rows > l.max_rows => (0..total_rows)
            .filter(|&r| !by_job || rows.marked[r])
            .take(l.max_rows)
            .collect(),
        _ => (0..total_rows).collect(),
    };
    // The shown rows' keys and cells, from a second pass over the table's rows.
    let mut at: Vec<Option<usize>> = vec![None; total_rows];
    for (p, &r) in shown.iter().enumerate() {
        at[r] = Some(p);
    }
    let mut shown_keys: Vec<Option<Vec<String>>> = vec![None; shown.len()];
    let mut cells: HashMap<(usize, usize, usize), f64> = HashMap::new();
    let col_index: HashMap<&str, usize> = col_order
        .iter()
        .enumerate()
        .map(|(c, p)| (p.as_str(), c))
        .collect();
    for (i, &r) in rows.row_of.iter().enumerate() {
        let Some(p) = at.get(r as usize).copied().flatten() else {
            continue;
        };
        if shown_keys[p].is_none() {
            shown_keys[p] = Some(
                key_cols
                    .iter()
                    .map(|c| c.get(i).unwrap_or("-").to_string())
                    .collect(),
            );
        }
        let c = col_index[pivot_col.get(i).unwrap_or(def.null_label)];
        for (v, vals) in value_cols.iter().enumerate() {
            if let Some(x) = vals[i] {
                cells.entry((p, c, v)).or_insert(x);
            }
        }
    }
    let body: Vec<Vec<String>> = shown_keys
        .iter()
        .enumerate()
        .map(|(p, key)| {
            let key = key.as_ref().expect("a shown row has a table row");
            let mut line: Vec<String> = used.iter().map(|&k| key[k].clone()).collect();
            for v in 0..def.values.len() {
                for c in 0..col_order.len() {
                    line.push(
                        cells
                            .get(&(p, c, v))
                            .map_or_else(|| "-".into(), |&x| format_value(x)),
                    );
                }
            }
            line
        })
        .collect();
    Ok(Some(Rendered {
        text: layout(def.title, &header, &body, used.len(), format),
        rows: body.len(),
        total_rows,
        by_job,
    }))
}

/// Which rows of `df` (read from `path`) pass every filter `(column, accepted values)`, the
/// values compared as display strings. `Ok(None)` when none does, and, unless `strict`, when a
/// filter names a column `df` lacks.
///
/// # Errors
/// If a column cannot be read, or (when `strict`) a filter names a column `df` lacks.
pub(super) fn kept_rows(
    df: &DataFrame,
    path: &Path,
    filters: &[(String, Vec<String>)],
    strict: bool,
) -> Result<Option<Vec<bool>>> {
    let names: Vec<String> = df
        .get_column_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let mut keep = vec![true; df.height()];
    for (col, accepted) in filters {
        if !names.contains(col) {
            if !strict {
                return Ok(None);
            }
            bail!(
                "{}: no column {col:?} to filter on (columns: {})",
                path.display(),
                names.join(", ")
            );
        }
        let values = texts(df, col)?;
        for (k, v) in keep.iter_mut().zip(values.iter()) {
            *k &= v.is_some_and(|v| accepted.iter().any(|a| a == v));
        }
    }
    Ok(keep.contains(&true).then_some(keep))
}

/// Lays out a header and rows; the first `keys` columns are left-aligned, values right-aligned.
pub(super) fn layout(
    title: &str,
    header: &[String],
    body: &[Vec<String>],
    keys: usize,
    f: Format,
) -> String {
    let mut out = String::new();
    let widths: Vec<usize> = (0..header.len())
        .map(|c| {
            body.iter()
                .map(|r| r[c].len())
                .chain(std::iter::once(header[c].len()))
                .max()
                .unwrap_or(0)
        })
        .collect();
    let cell = |c: usize, s: &str| {
        if c < keys {
            format!("{s:<w$}", w = widths[c])
        } else {
            format!("{s:>w$}", w = widths[c])
        }
    };
    let line =
        |r: &[String]| -> Vec<String> { r.iter().enumerate().map(|(c, s)| cell(c, s)).collect() };
    match f {
        Format::Text => {
            let _ = writeln!(out, "{title}\n");
            let _ = writeln!(out, "{}", line(header).join("  "));
            let _ = writeln!(
                out,
                "{}",
                widths
                    .iter()
                    .map(|w| "-".repeat(*w))
                    .collect::<Vec<_>>()
                    .join("  ")
            );
            for r in body {
                let _ = writeln!(out, "{}", line(r).join("  "));
            }
        }
        Format::Html => {
            let _ = writeln!(out, "<table>\n<caption>{}</caption>", escape(title));
            let row = |cells: &[String], tag: &str| -> String {
                cells
                    .iter()
                    .enumerate()
                    .map(|(c, s)| {
                        let class = if c < keys { "key" } else { "num" };
                        format!("<{tag} class=\"{class}\">{}</{tag}>", escape(s))
                    })
                    .collect()
            };
            let _ = writeln!(
                out,
                "<thead><tr>{}</tr></thead>\n<tbody>",
                row(header, "th")
            );
            for r in body {
                let _ = writeln!(out, "<tr>{}</tr>", row(r, "td"));
            }
            let _ = writeln!(out, "</tbody>\n</table>");
        }
        Format::Md => {
            let _ = writeln!(out, "**{title}**\n");
            let _ = writeln!(out, "| {} |", line(header).join(" | "));
            let rule: Vec<String> = widths
                .iter()
                .enumerate()
                .map(|(c, w)| {
                    if c < keys {
                        format!(":{}", "-".repeat(w.saturating_sub(1).max(2)))
                    } else {
                        format!("{}:", "-".repeat(w.saturating_sub(1).max(2)))
                    }
                })
                .collect();
            let _ = writeln!(out, "| {} |", rule.join(" | "));
            for r in body {
                let _ = writeln!(out, "| {} |", line(r).join(" | "));
            }
        }
    }
    out
}

/// Parses a `--filter` argument `column=value[,value...]`.
///
/// # Errors
/// If there is no `=`.
pub fn parse_filter(s: &str) -> Result<(String, Vec<String>)> {
    let (c, v) = s
        .split_once('=')
        .with_context(|| format!("filter {s:?}: expected column=value[,value...]"))?;
    Ok((
        c.trim().to_string(),
        v.split(',').map(|x| x.trim().to_string()).collect(),
    ))
}

/// Escapes text for HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
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
}
