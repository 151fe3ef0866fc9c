//! The run-wide figures: curves over every numeric swept parameter (the mean correlation by
//! level and direction, the similarity summaries) and the calibration's spectra, drawn from the
//! run's Parquet tables. They come first among the report's figures.

use super::figures;
use super::task::{rel, Figure, Task};
use crate::io::results::{self, col, Table};
use anyhow::{Context, Result};
use polars::prelude::{
    ArrowDataType, ArrowSchema, DataType, ParquetReader, SerReader, StringChunked,
};
use std::collections::BTreeMap;
use std::path::Path;

/// The calibration's spectra (Figs. 11-14): Mie, raw and calibrated sphere, and the error.
pub(super) fn calibration_figures(dir: &Path) -> Result<Vec<Task>> {
    let path = results::CALIBRATION.path(dir);
    let Some(df) = crate::io::parquet::read_parquet(&path)? else {
        return Ok(vec![]);
    };
    let col = |c: &str| -> Result<Vec<f64>> {
        Ok(df
            .column(c)?
            .f64()?
            .iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect())
    };
    let f = col(col::FREQ_GHZ)?;
    let series =
        |c: &str| -> Result<Vec<(f64, f64)>> { Ok(f.iter().copied().zip(col(c)?).collect()) };
    let spectra = vec![
        ("Mie (exact)".to_string(), series(col::MIE_DBSM)?),
        ("raw sphere measurement".into(), series(col::RAW_DB)?),
        ("calibrated sphere".into(), series(col::CALIBRATED_DBSM)?),
    ];
    let error = vec![("calibrated - Mie".to_string(), series(col::ERROR_DB)?)];
    Ok(vec![
        curves_task(
            dir,
            "calibration_spectra",
            "Sphere calibration: Mie, raw and calibrated response".into(),
            spectra,
            ["frequency (GHz)", "dB (dBsm for Mie and calibrated)"],
            &path,
        ),
        curves_task(
            dir,
            "calibration_error",
            "Sphere calibration: calibrated minus Mie".into(),
            error,
            ["frequency (GHz)", "error (dB)"],
            &path,
        ),
    ])
}

/// A run-wide figure of named curves (`figures/<stem>`) to draw, drawn from the table `data`.
pub(super) fn curves_task(
    dir: &Path,
    stem: &str,
    caption: String,
    series: Vec<(String, Vec<(f64, f64)>)>,
    [x_label, y_label]: [&str; 2],
    data: &Path,
) -> Task {
    let (dir, stem, data) = (dir.to_path_buf(), stem.to_string(), data.to_path_buf());
    let (x_label, y_label) = (x_label.to_string(), y_label.to_string());
    Box::new(move || {
        let refs: Vec<(&str, &[(f64, f64)])> = series
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_slice()))
            .collect();
        let files = figures::charts::curves(
            &dir.join("figures"),
            &stem,
            &caption,
            &refs,
            &x_label,
            &y_label,
        )
        .with_context(|| format!("drawing {stem}"))?;
        Ok(Figure {
            job: String::new(),
            caption,
            files: files.map(|f| rel(&dir, &f)),
            data: vec![rel(&dir, &data)],
        })
    })
}

/// Curves over every numeric swept parameter: the mean correlation per level and direction
/// (per dataset and source), and each method's similarity summaries (`average_level_1` of the
/// multiscale RMSE, the CMD) per dataset.
pub(super) fn sweep_figures(dir: &Path) -> Result<Vec<Task>> {
    let mut out = curve_figures(
        dir,
        results::ANALYSIS_SUMMARY,
        col::MEAN_CORRELATION,
        &[col::DATASET, col::SOURCE, col::LEVEL, col::DIRECTION],
        &|r| {
            Some((
                format!("{} ({})", r.get(col::DATASET), r.get(col::SOURCE)),
                format!("level {} {}", r.get(col::LEVEL), r.get(col::DIRECTION)),
            ))
        },
    )?;
    out.extend(curve_figures(
        dir,
        results::SIMILARITY,
        col::VALUE,
        &[col::STATISTIC, col::DATASET, col::METHOD, col::REFERENCE],
        &|r| {
            let what = match r.get(col::STATISTIC) {
                "average_level_1" => "multiscale RMSE, average level 1",
                "average_levels_1_3" => "multiscale RMSE, average levels 1-3",
                "distance" => "correlation matrix distance",
                _ => return None,
            };
            let series = match r.get(col::REFERENCE) {
                results::value::HELD_OUT => format!("{} (held out)", r.get(col::METHOD)),
                _ => r.get(col::METHOD).to_string(),
            };
            Some((format!("{}: {what}", r.get(col::DATASET)), series))
        },
    )?);
    Ok(out)
}

/// The points of each series of a figure, by series name.
type Series<'a> = BTreeMap<&'a str, Vec<(f64, f64)>>;

/// A row of a table, read as display strings (`-` for null or a column the table lacks).
struct Row<'a> {
    /// The columns read, by name, as strings.
    text: &'a [(&'a str, StringChunked)],
    /// The row.
    i: usize,
}

impl Row<'_> {
    fn get(&self, column: &str) -> &str {
        self.text
            .iter()
            .find(|(c, _)| *c == column)
            .and_then(|(_, v)| v.get(self.i))
            .unwrap_or("-")
    }
}

/// The columns of a table of `schema` that `curve_figures` reads: `y`, those of `columns` the
/// table has, and the swept parameters (the float columns the contract of `table` does not
/// declare), returned apart as well. Only these are read: a sweep of 100,000 jobs has 3 million
/// rows of `analysis_summary`.
fn curve_columns(
    schema: &ArrowSchema,
    table: Table,
    y: &str,
    columns: &[&str],
) -> (Vec<String>, Vec<String>) {
    let axes: Vec<String> = schema
        .iter()
        .filter(|(name, field)| {
            !table.declares(name.as_str()) && field.dtype() == &ArrowDataType::Float64
        })
        .map(|(name, _)| name.to_string())
        .collect();
    let read: Vec<String> = std::iter::once(y)
        .chain(columns.iter().copied())
        .filter(|c| schema.contains(c))
        .map(str::to_string)
        .chain(axes.iter().cloned())
        .collect();
    (axes, read)
}

/// Draws `y` against every numeric swept column of `file`: `pick` maps a row (of which it reads
/// the `columns`) to its figure (title) and series (legend name), or `None` to leave it out. A
/// figure needs two distinct x values.
///
/// Long because it groups the rows by curve and by axis, keeps the axes with two x values and makes
/// the tasks in one pass over the table.
fn curve_figures(
    dir: &Path,
    table: Table,
    y: &str,
    columns: &[&str],
    pick: &dyn Fn(&Row) -> Option<(String, String)>,
) -> Result<Vec<Task>> {
    let path = table.path(dir);
    if !path.exists() {
        return Ok(vec![]);
    }
    let file = std::fs::File::open(&path).with_context(|| format!("opening {}", path.display()))?;
    let mut reader = ParquetReader::new(file);
    let schema = reader
        .schema()
        .with_context(|| format!("reading the columns of {}", path.display()))?;
    let (axes, read) = curve_columns(&schema, table, y, columns);
    if axes.is_empty() {
        return Ok(vec![]);
    }
    let df = reader
        .with_columns(Some(read))
        .finish()
        .with_context(|| format!("reading {}", path.display()))?;
    let text: Vec<(&str, StringChunked)> = columns
        .iter()
        .filter_map(|&name| df.column(name).ok().map(|c| (name, c)))
        .map(|(name, c)| -> Result<(&str, StringChunked)> {
            Ok((
                name,
                c.cast(&DataType::String)?.str()?.rechunk().into_owned(),
            ))
        })
        .collect::<Result<_>>()?;
    let yv: Vec<Option<f64>> = df
        .column(y)?
        .cast(&DataType::Float64)?
        .f64()?
        .iter()
        .collect();
    // Each row's (figure, series), whatever the axis: an index into `keys`, the distinct
    // pairs (a few per dataset), not a pair of strings a row.
    let mut keys: Vec<(String, String)> = Vec::new();
    let mut index: BTreeMap<(String, String), u32> = BTreeMap::new();
    let picked: Vec<Option<u32>> = (0..df.height())
        .map(|i| {
            let key = yv[i]
                .is_some()
                .then(|| pick(&Row { text: &text, i }))
                .flatten()?;
            Some(*index.entry(key).or_insert_with_key(|k| {
                keys.push(k.clone());
                keys.len() as u32 - 1
            }))
        })
        .collect();
    let mut out = vec![];
    for axis in axes {
        let x: Vec<Option<f64>> = df.column(&axis)?.f64()?.iter().collect();
        let mut groups: BTreeMap<&str, Series> = BTreeMap::new();
        for i in 0..df.height() {
            let (Some(xv), Some(v), Some(k)) = (x[i], yv[i], picked[i]) else {
                continue;
            };
            let (figure, series) = &keys[k as usize];
            groups
                .entry(figure)
                .or_default()
                .entry(series)
                .or_default()
                .push((xv, v));
        }
        for (title, series) in groups {
            let distinct: std::collections::BTreeSet<u64> =
                series.values().flatten().map(|p| p.0.to_bits()).collect();
            if distinct.len() < 2 {
                continue;
            }
            let series: Vec<(String, Vec<(f64, f64)>)> = series
                .into_iter()
                .map(|(k, mut v)| {
                    v.sort_by(|a, b| a.0.total_cmp(&b.0));
                    (k.to_string(), v)
                })
                .collect();
            let safe = |s: &str| -> String {
                s.chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect()
            };
            let stem = format!("sweep_{}_{}", safe(title), safe(&axis));
            let caption = format!("{title} against {axis}");
            let y_label = if y == col::VALUE {
                "value"
            } else {
                "mean correlation"
            };
            out.push(curves_task(
                dir,
                &stem,
                caption,
                series,
                [&axis, y_label],
                &path,
            ));
        }
    }
    Ok(out)
}
