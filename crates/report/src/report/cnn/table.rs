//! The CNN applications' tables of `isar-clutter table` and the report: `classification`
//! (Tables 20/22's layout: one table per normalisation, methods down, training sizes across,
//! test accuracy in % as mean +- standard deviation over repeats, the `original` row
//! included), `classification_detail` (every statistic of every method and size: minimum,
//! maximum, training and validation accuracy, throughput) and `location` (target x method down,
//! SCR across, mean test accuracy in %, then the summary's SCR at 50 % and 90 % and the gain
//! over `original`). Their layout is fixed: `--filter` selects rows, `--pivot` does not apply.

use super::super::table::{layout, Format};
use super::groups::{group_name, load, Group, Stats};
use crate::io::results::{self, col, CnnApp};
use anyhow::{bail, Result};
use std::path::Path;

/// Tables 20/22: methods x training sizes, mean +- std of the test accuracy.
pub const CLASSIFICATION: &str = "classification";
/// Every statistic of each method and training size.
pub const CLASSIFICATION_DETAIL: &str = "classification_detail";
/// Target x method x SCR, with the SCR at 50 % and 90 % and the gain over `original`.
pub const LOCATION: &str = "location";

/// The tables of one application, in print order.
pub fn names_of(app: CnnApp) -> &'static [&'static str] {
    match app {
        CnnApp::Classification => &[CLASSIFICATION, CLASSIFICATION_DETAIL],
        CnnApp::Location => &[LOCATION],
    }
}

/// The CNN tables, in print order.
pub fn names() -> Vec<&'static str> {
    CnnApp::ALL
        .iter()
        .flat_map(|&a| names_of(a))
        .copied()
        .collect()
}

/// An accuracy in % with one decimal.
fn pct(v: f64) -> String {
    format!("{v:.1}")
}

/// An optional number with one decimal, `-` for none.
fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), pct)
}

/// `mean +- std` (`±` in HTML); the mean alone for a single repeat.
fn mean_std(s: &Stats, format: Format) -> String {
    let pm = if format == Format::Html { "±" } else { "+-" };
    match s.std {
        Some(sd) => format!("{} {pm} {}", pct(s.mean), pct(sd)),
        None => pct(s.mean),
    }
}

/// Training sizes and SCRs as printed in headers.
fn x_label(app: CnnApp, x: f64) -> String {
    match app {
        CnnApp::Classification => format!("N = {x}"),
        CnnApp::Location => format!("{x} dB"),
    }
}

/// How a cell summarises its repeats, for titles: `"mean +- sample std over 5 repeats"`,
/// `"1 repeat (no std)"`, or with unequal counts `"... over 2-3 repeats (n per cell)"` and
/// `true` (the cells then say their n). `spread` names the spread (empty: the mean alone).
fn repeats_note(counts: &[usize], spread: &str) -> (String, bool) {
    let (lo, hi) = (
        counts.iter().copied().min().unwrap_or(0),
        counts.iter().copied().max().unwrap_or(0),
    );
    match (lo, hi) {
        (1, 1) => ("1 repeat (no std)".into(), false),
        _ if lo == hi => (format!("mean{spread} over {lo} repeats"), false),
        _ => (
            format!("mean{spread} over {lo}-{hi} repeats (n per cell)"),
            true,
        ),
    }
}

/// Renders the CNN table `name` (one of [`names`]) of `dir`, keeping the rows that pass
/// `filters`. `Ok(None)` when the file is missing or no row passes, and, unless `strict`,
/// when a filter names a column the file lacks or a pivot is given.
///
/// # Errors
/// If `name` is not a CNN table, a file cannot be read, or (when `strict`) a filter names a
/// column the file lacks or a pivot is given (the layout is fixed).
pub fn render(
    dir: &Path,
    name: &str,
    filters: &[(String, Vec<String>)],
    pivot: Option<&str>,
    format: Format,
    strict: bool,
) -> Result<Option<String>> {
    if let Some(p) = pivot {
        if strict {
            bail!("table {name} has a fixed layout; --pivot {p} does not apply to it");
        }
        return Ok(None);
    }
    let Some(app) = CnnApp::ALL
        .iter()
        .copied()
        .find(|&a| names_of(a).contains(&name))
    else {
        bail!("no CNN table {name:?}; CNN tables: {}", names().join(", "));
    };
    let Some(groups) = load(dir, app, filters, strict)? else {
        return Ok(None);
    };
    let text = match app {
        CnnApp::Classification if name == CLASSIFICATION_DETAIL => {
            classification_detail(&groups, format)
        }
        CnnApp::Classification => groups
            .iter()
            .map(|g| classification(g, format))
            .collect::<Vec<_>>()
            .join("\n"),
        CnnApp::Location => location(dir, &groups, format)?,
    };
    Ok(Some(text))
}

/// The tables `names` of `dir` that have rows, rendered in `format`.
///
/// # Errors
/// As [`render`].
pub(super) fn tables(
    dir: &Path,
    names: &[&str],
    filters: &[(String, Vec<String>)],
    format: Format,
) -> Result<Vec<String>> {
    let mut out = vec![];
    for name in names {
        out.extend(render(dir, name, filters, None, format, false)?);
    }
    Ok(out)
}

/// Table 20 or 22 for one normalisation.
fn classification(g: &Group, format: Format) -> String {
    let mut counts = vec![];
    let body: Vec<Vec<String>> = g
        .methods
        .iter()
        .map(|m| {
            let mut line = vec![m.clone()];
            for &x in &g.xs {
                let cell = g.stats(m, x);
                counts.extend(cell.map(|s| s.n));
                line.push(cell.map_or_else(|| "-".into(), |s| mean_std(&s, format)));
            }
            line
        })
        .collect();
    let (note, per_cell) = repeats_note(&counts, " +- sample std");
    let body = if per_cell {
        g.methods
            .iter()
            .zip(body)
            .map(|(m, mut line)| {
                for (k, &x) in g.xs.iter().enumerate() {
                    if let Some(s) = g.stats(m, x) {
                        line[k + 1] = format!("{} (n={})", line[k + 1], s.n);
                    }
                }
                line
            })
            .collect()
    } else {
        body
    };
    let protocols = g.distinct(|r| r.protocol.clone().unwrap_or_else(|| "-".into()));
    let tests = g.distinct(|r| r.test_samples.map(|v| v as i64));
    let test_note = match tests.as_slice() {
        [Some(n)] => format!(", {n} test samples"),
        _ => String::new(),
    };
    let title = format!(
        "Prediction accuracy on original data (Tables 20/22), {}: test accuracy in %, {note}; \
         protocol: {}{test_note}",
        g.name,
        protocols.join(", ")
    );
    let mut header = vec![col::METHOD.to_string()];
    header.extend(g.xs.iter().map(|&x| x_label(CnnApp::Classification, x)));
    layout(&title, &header, &body, 1, format)
}

/// Every statistic per normalisation, method and training size.
fn classification_detail(groups: &[Group], format: Format) -> String {
    let header: Vec<String> = [
        col::NORMALISE,
        col::METHOD,
        "N",
        "repeats",
        "test mean",
        "test std",
        "test min",
        "test max",
        "train mean",
        "validation mean",
        "samples/s",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mean = |v: Vec<f64>| Stats::of(&v).map(|s| s.mean);
    let mut body = vec![];
    for g in groups {
        for m in &g.methods {
            for &x in &g.xs {
                let Some(s) = g.stats(m, x) else { continue };
                let rows: Vec<_> = g.at(m, x).collect();
                let speed = mean(rows.iter().filter_map(|r| r.samples_per_second).collect());
                body.push(vec![
                    g.name.clone(),
                    m.clone(),
                    x.to_string(),
                    s.n.to_string(),
                    pct(s.mean),
                    opt(s.std),
                    pct(s.min),
                    pct(s.max),
                    opt(mean(rows.iter().filter_map(|r| r.train).collect())),
                    opt(mean(rows.iter().filter_map(|r| r.validation).collect())),
                    speed.map_or_else(|| "-".into(), |v| format!("{v:.0}")),
                ]);
            }
        }
    }
    layout(
        "Classification trainings: accuracies in % over repeats (test = prediction on original \
         data; std = sample std), training throughput in samples/s",
        &header,
        &body,
        3,
        format,
    )
}

/// The location summary's `(scr_50, scr_90, gain_50, gain_90)` per `(group, method)` (the
/// group's name as [`group_name`] makes it from the target and test set).
type Summary = Vec<((String, String), [Option<f64>; 4])>;

/// `location_summary.parquet`, if present.
fn summary(dir: &Path) -> Result<Summary> {
    use super::super::table::{floats, optional_strings, strings};
    let path = results::LOCATION_SUMMARY.path(dir);
    let Some(df) = crate::io::parquet::read_parquet(&path)? else {
        return Ok(vec![]);
    };
    let (t, m) = (strings(&df, col::TARGET)?, strings(&df, col::METHOD)?);
    let sets = optional_strings(&df, col::TEST_SET)?;
    let cols = [
        col::SCR_50_DB,
        col::SCR_90_DB,
        col::GAIN_50_DB,
        col::GAIN_90_DB,
    ]
    .iter()
    .map(|c| floats(&df, c))
    .collect::<Result<Vec<_>>>()?;
    Ok((0..df.height())
        .filter_map(|i| {
            let key = (
                group_name(t[i].as_deref()?, sets[i].as_deref()),
                m[i].clone()?,
            );
            Some((key, [cols[0][i], cols[1][i], cols[2][i], cols[3][i]]))
        })
        .collect())
}

/// Target x method by SCR, with the summary's columns.
fn location(dir: &Path, groups: &[Group], format: Format) -> Result<String> {
    let summary = summary(dir)?;
    let mut xs: Vec<f64> = groups.iter().flat_map(|g| g.xs.iter().copied()).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let mut header = vec![col::TARGET.to_string(), col::METHOD.to_string()];
    header.extend(xs.iter().map(|&x| x_label(CnnApp::Location, x)));
    header.extend(
        [
            "SCR 50 % (dB)",
            "SCR 90 % (dB)",
            "gain 50 % (dB)",
            "gain 90 % (dB)",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    let mut counts = vec![];
    let mut body = vec![];
    for g in groups {
        for m in &g.methods {
            let mut line = vec![g.name.clone(), m.clone()];
            for &x in &xs {
                let s = g.stats(m, x);
                counts.extend(s.map(|s| s.n));
                line.push(opt(s.map(|s| s.mean)));
            }
            let found = summary
                .iter()
                .find(|(k, _)| k.0 == g.name && k.1 == *m)
                .map_or([None; 4], |(_, v)| *v);
            line.extend(found.iter().map(|v| opt(*v)));
            body.push(line);
        }
    }
    let (note, _) = repeats_note(&counts, "");
    let title = format!(
        "Target location (Figs. 73-74): test accuracy in %, {note}, by SCR; the SCR where \
         the mean first reaches 50 % and 90 % (interpolated; - = never) and its gain over \
         original (dB, positive = reached at a lower SCR); chance = 4 %"
    );
    Ok(layout(&title, &header, &body, 2, format))
}
