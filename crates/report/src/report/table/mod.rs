//! The `table` command: the comparison tables a reader of the dissertation expects, printed
//! from a results folder's Parquet files alone (no recomputation). Each table filters one
//! long-format file, groups its rows by key columns and spreads one column (the pivot, by
//! default the method) across the page, in aligned text for the terminal or in Markdown.

use crate::io::results::{self, col, Table};
use crate::stats::metrics::name as metric_name;
use anyhow::{bail, Context, Result};
use polars::prelude::{DataFrame, DataType, StringChunked};
use std::collections::{BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::Path;

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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
            filters: vec![(col::METRIC, vec![metric_name::MULTISCALE_RMSE])],
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
            filters: vec![(col::METRIC, vec![metric_name::CMD])],
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
                (col::METRIC, vec![metric_name::KL_PIXEL, metric_name::KL_AREA]),
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

/// Column `name` as [`strings`], or all null where the table has no such column (one written
/// before the column existed).
///
/// # Errors
/// As [`strings`].
pub(super) fn optional_strings(df: &DataFrame, name: &str) -> Result<Vec<Option<String>>> {
    if has_column(df, name) {
        strings(df, name)
    } else {
        Ok(vec![None; df.height()])
    }
}

/// Column `name` as [`floats`], or all null where the table has no such column.
///
/// # Errors
/// As [`floats`].
pub(super) fn optional_floats(df: &DataFrame, name: &str) -> Result<Vec<Option<f64>>> {
    if has_column(df, name) {
        floats(df, name)
    } else {
        Ok(vec![None; df.height()])
    }
}

/// Whether `df` has a column `name`.
fn has_column(df: &DataFrame, name: &str) -> bool {
    df.get_column_names().iter().any(|c| c.as_str() == name)
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
    let mut keys = row_keys(def, &names, pivot);
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
    let mut rows = pivoted_rows(
        &key_cols,
        &pivot_col,
        def.null_label,
        &keep,
        job_col.as_ref(),
        limit,
    );
    let col_order = std::mem::take(&mut rows.columns);
    // Drop key columns that are constant "-" (e.g. level for CMD rows).
    let used: Vec<usize> = (0..keys.len()).filter(|&k| rows.set[k]).collect();
    let mut header: Vec<String> = used.iter().map(|&k| keys[k].clone()).collect();
    header.extend(value_headers(def, &col_order));
    let total_rows = rows.marked.len();
    let by_job = job_col.is_some() && limit.is_some_and(|l| total_rows > l.max_rows);
    let shown: Vec<usize> = match limit {
        Some(l) if total_rows > l.max_rows => (0..total_rows)
            .filter(|&r| !by_job || rows.marked[r])
            .take(l.max_rows)
            .collect(),
        _ => (0..total_rows).collect(),
    };
    let body = shown_body(
        def,
        &rows,
        &shown,
        (&key_cols, &used),
        (&pivot_col, &col_order),
        &value_cols,
    );
    Ok(Some(Rendered {
        text: layout(def.title, &header, &body, used.len(), format),
        rows: body.len(),
        total_rows,
        by_job,
    }))
}

/// The shown rows' cells, from a second pass over the table's rows: each shown row's used
/// keys (`keys`: every key column and the indices of those shown), then its values under each
/// pivot column (`pivot`: the pivot column and the columns' order), `-` where it has none.
fn shown_body(
    def: &TableDef,
    rows: &Pivoted,
    shown: &[usize],
    (key_cols, used): (&[StringChunked], &[usize]),
    (pivot_col, col_order): (&StringChunked, &[String]),
    value_cols: &[Vec<Option<f64>>],
) -> Vec<Vec<String>> {
    let total_rows = rows.marked.len();
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
    shown_keys
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
        .collect()
}

/// The row keys of a rendered table: the definition's, the pivot of the definition when it is
/// overridden, then the swept parameters (any column the contract does not declare for the
/// table); never the pivot itself.
fn row_keys(def: &TableDef, names: &[String], pivot: &str) -> Vec<String> {
    let mut keys: Vec<String> = def
        .rows
        .iter()
        .chain(std::iter::once(&def.pivot))
        .map(|s| s.to_string())
        .filter(|k| k != pivot && names.contains(k))
        .collect();
    for n in names {
        if !def.table.declares(n) && !keys.contains(n) && n != pivot {
            keys.push(n.clone());
        }
    }
    keys
}

/// The value columns' headers: each value under each pivot column (`col_order`), labelled
/// with the value's label or name when the table shows several values.
fn value_headers(def: &TableDef, col_order: &[String]) -> Vec<String> {
    let mut header = vec![];
    for (v, name) in def.values.iter().enumerate() {
        for c in col_order {
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
    header
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
mod tests;
