//! The figures of a hypotheses run on plant datasets (`plant_<letter>_<wind>`; dissertation
//! §5.1, docs/hypotheses.md), drawn from its tables: the magnitude of the mean 2-D correlating
//! function per plant and wind with its horizontal and vertical cuts through the origin (Figs.
//! 50-51), the mean correlation by decomposition level for each wind (Figs. 52-53), and for each
//! level the mean correlation against the wind (Figs. 54-56); and, from the jobs'
//! `kspace/<job>.mean.npy`, the mean k-space image of each plant (Fig. 48).

use super::figures::{self, Panel, Scale};
use super::runwide::curves_task;
use super::task::{rel, Figure, Task};
use crate::io::results::{self, col};
use crate::physics::vegetation::parse_dataset_id;
use anyhow::{Context, Result};
use ndarray::Array2;
use polars::prelude::{DataFrame, DataType};
use std::collections::BTreeMap;
use std::path::Path;

/// The winds in the order of motion (the x axis of Figs. 54-56).
const WINDS: [&str; 3] = ["none", "light", "medium"];

/// Where `wind` falls in [`WINDS`] (after them if it is none of them).
fn wind_rank(wind: &str) -> usize {
    WINDS.iter().position(|x| *x == wind).unwrap_or(WINDS.len())
}

/// Maps keyed by (wind rank, plant), in that order, as rows of `(title, map)`: a row per wind.
fn rows_by_wind(
    maps: BTreeMap<(usize, String), (String, Array2<f64>)>,
) -> Vec<Vec<(String, Array2<f64>)>> {
    let mut rows: Vec<Vec<(String, Array2<f64>)>> = vec![];
    let mut last = None;
    for ((w, _), titled) in maps {
        if last != Some(w) {
            rows.push(vec![]);
            last = Some(w);
        }
        rows.last_mut().expect("a row").push(titled);
    }
    rows
}

/// A run-wide figure (`figures/<stem>`) of heatmap panels, a row of `rows` each, on one colour
/// scale, drawn from the files `data` (relative to `dir`).
fn heatmap_task(
    dir: &Path,
    stem: &'static str,
    caption: String,
    rows: Vec<Vec<(String, Array2<f64>)>>,
    scale: (Scale, &'static str),
    [x_label, y_label]: [String; 2],
    data: Vec<std::path::PathBuf>,
) -> Task {
    let dir = dir.to_path_buf();
    Box::new(move || {
        let panels: Vec<Vec<Panel>> = rows
            .iter()
            .map(|row| {
                row.iter()
                    .map(|(title, m)| Panel {
                        title: title.clone(),
                        map: m.view(),
                    })
                    .collect()
            })
            .collect();
        let options = figures::heatmap::GridOptions {
            x_label: &x_label,
            y_label: &y_label,
            ..Default::default()
        };
        let files = figures::heatmap::heatmap_grid_with(
            &dir.join("figures"),
            stem,
            &caption,
            &panels,
            scale,
            &options,
        )
        .with_context(|| format!("drawing {stem}"))?;
        Ok(Figure {
            job: String::new(),
            caption,
            files: files.map(|f| rel(&dir, &f)),
            data,
        })
    })
}

/// The plant figures of the run in `dir` (none when it has no plant datasets).
///
/// # Errors
/// If a table cannot be read or lacks a column.
pub(super) fn plant_figures(dir: &Path) -> Result<Vec<Task>> {
    let mut tasks = correlating_figures(dir)?;
    tasks.extend(level_figures(dir)?);
    tasks.extend(kspace_figure(dir)?);
    Ok(tasks)
}

/// A column as strings (`""` for nulls).
fn strings(df: &DataFrame, c: &str) -> Result<Vec<String>> {
    let s = df.column(c)?.cast(&DataType::String)?;
    Ok(s.str()?
        .iter()
        .map(|v| v.unwrap_or_default().to_string())
        .collect())
}

/// A column as floats (NaN for nulls).
fn floats(df: &DataFrame, c: &str) -> Result<Vec<f64>> {
    let s = df.column(c)?.cast(&DataType::Float64)?;
    Ok(s.f64()?.iter().map(|v| v.unwrap_or(f64::NAN)).collect())
}

/// Figs. 50-51: per plant dataset the magnitude of the mean correlating function over the
/// offsets `-R..=R` (a heatmap grid, a row per wind), and its cuts through the origin.
fn correlating_figures(dir: &Path) -> Result<Vec<Task>> {
    let path = results::CORRELATING_FUNCTION.path(dir);
    let Some(df) = crate::io::parquet::read_parquet(&path)? else {
        return Ok(vec![]);
    };
    if df.column(col::MEAN_MAGNITUDE).is_err() {
        return Ok(vec![]); // written before the magnitude was stored
    }
    let (datasets, dy, dx, mag) = (
        strings(&df, col::DATASET)?,
        floats(&df, col::DY)?,
        floats(&df, col::DX)?,
        floats(&df, col::MEAN_MAGNITUDE)?,
    );
    let reach = dy.iter().chain(&dx).fold(0.0f64, |m, v| m.max(v.abs())) as usize;
    let side = 2 * reach + 1;
    // Plant datasets in (wind, plant) order, each with its map of magnitudes.
    let mut maps: BTreeMap<(usize, String), (String, Array2<f64>)> = BTreeMap::new();
    for i in 0..datasets.len() {
        let Some((plant, wind)) = parse_dataset_id(&datasets[i]) else {
            continue;
        };
        let w = wind_rank(&wind);
        let (_, map) = maps.entry((w, plant)).or_insert_with(|| {
            (
                datasets[i].clone(),
                Array2::from_elem((side, side), f64::NAN),
            )
        });
        let (r, c) = (dy[i] + reach as f64, dx[i] + reach as f64);
        if r >= 0.0 && c >= 0.0 && (r as usize) < side && (c as usize) < side {
            map[[r as usize, c as usize]] = mag[i];
        }
    }
    if maps.is_empty() {
        return Ok(vec![]);
    }
    let cut = |horizontal: bool| -> Vec<(String, Vec<(f64, f64)>)> {
        maps.values()
            .map(|(id, m)| {
                let pts = (0..side)
                    .map(|k| {
                        let v = if horizontal {
                            m[[reach, k]]
                        } else {
                            m[[k, reach]]
                        };
                        (k as f64 - reach as f64, v)
                    })
                    .collect();
                (id.clone(), pts)
            })
            .collect()
    };
    let mut tasks = vec![
        curves_task(
            dir,
            "plants_correlating_horizontal",
            "Mean correlating function magnitude through the origin, horizontal (dy = 0; \
             Figs. 50-51)"
                .into(),
            cut(true),
            ["dx (pixels)", "|mean correlation|"],
            &path,
        ),
        curves_task(
            dir,
            "plants_correlating_vertical",
            "Mean correlating function magnitude through the origin, vertical (dx = 0; \
             Figs. 50-51)"
                .into(),
            cut(false),
            ["dy (pixels)", "|mean correlation|"],
            &path,
        ),
    ];
    let caption = format!(
        "Magnitude of the mean 2-D correlating function, offsets -{reach}..{reach} (rows dy, \
         columns dx; Figs. 50-51)"
    );
    tasks.push(heatmap_task(
        dir,
        "plants_correlating_function",
        caption,
        rows_by_wind(maps),
        (Scale::Diverging { lo: -1.0, hi: 1.0 }, "|mean correlation|"),
        [format!("dx + {reach}"), format!("dy + {reach}")],
        vec![rel(dir, &path)],
    ));
    Ok(tasks)
}

/// Figs. 52-56 from the mean correlation of the original plant data by level and direction
/// (H and V, as the dissertation plots them): by level for each wind, and against the wind
/// for each level.
fn level_figures(dir: &Path) -> Result<Vec<Task>> {
    let path = results::ANALYSIS_SUMMARY.path(dir);
    let Some(df) = crate::io::parquet::read_parquet(&path)? else {
        return Ok(vec![]);
    };
    let (datasets, sources, directions) = (
        strings(&df, col::DATASET)?,
        strings(&df, col::SOURCE)?,
        strings(&df, col::DIRECTION)?,
    );
    let (levels, values) = (
        floats(&df, col::LEVEL)?,
        floats(&df, col::MEAN_CORRELATION)?,
    );
    // (plant, wind, level, direction) -> mean correlation.
    let mut at: BTreeMap<(String, usize, usize, String), f64> = BTreeMap::new();
    for i in 0..datasets.len() {
        let Some((plant, wind)) = parse_dataset_id(&datasets[i]) else {
            continue;
        };
        let Some(w) = WINDS.iter().position(|x| *x == wind) else {
            continue;
        };
        if sources[i] != "original" || !matches!(directions[i].as_str(), "H" | "V") {
            continue;
        }
        at.insert(
            (plant, w, levels[i] as usize, directions[i].clone()),
            values[i],
        );
    }
    if at.is_empty() {
        return Ok(vec![]);
    }
    let mut tasks = vec![];
    let winds: std::collections::BTreeSet<usize> = at.keys().map(|k| k.1).collect();
    for &w in &winds {
        let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for ((plant, _, level, dir_), v) in at.iter().filter(|(k, _)| k.1 == w) {
            series
                .entry(format!("plant {plant} {dir_}"))
                .or_default()
                .push((*level as f64, *v));
        }
        tasks.push(curves_task(
            dir,
            &format!("plants_correlation_by_level_{}", WINDS[w]),
            format!(
                "Mean correlation by decomposition level, {} wind (Figs. 52-53)",
                WINDS[w]
            ),
            series.into_iter().collect(),
            ["decomposition level", "mean correlation"],
            &path,
        ));
    }
    let levels: std::collections::BTreeSet<usize> = at.keys().map(|k| k.2).collect();
    for &l in &levels {
        let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for ((plant, w, _, dir_), v) in at.iter().filter(|(k, _)| k.2 == l) {
            series
                .entry(format!("plant {plant} {dir_}"))
                .or_default()
                .push((*w as f64, *v));
        }
        tasks.push(curves_task(
            dir,
            &format!("plants_correlation_by_wind_level_{l}"),
            format!(
                "Level {l} mean correlation against the wind (0 none, 1 light, 2 medium; \
                 Figs. 54-56)"
            ),
            series.into_iter().collect(),
            ["wind (0 none, 1 light, 2 medium)", "mean correlation"],
            &path,
        ));
    }
    Ok(tasks)
}

/// Fig. 48: `20 log10 |mean E(f, phi)|` of each plant dataset's analysis job (rows frequency,
/// columns azimuth), a row of panels per wind, on one colour scale.
fn kspace_figure(dir: &Path) -> Result<Vec<Task>> {
    let folder = crate::io::results::files::kspace_root(dir);
    let Ok(entries) = std::fs::read_dir(&folder) else {
        return Ok(vec![]);
    };
    let mut found: BTreeMap<(usize, String), (String, std::path::PathBuf)> = BTreeMap::new();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(job) = name
            .strip_suffix(".npy")
            .and_then(|n| n.strip_suffix(crate::io::results::files::KSPACE_MEAN))
        else {
            continue;
        };
        // The analysis job of a dataset has the dataset's id (plus swept values, if any).
        let id = job.split('.').next().unwrap_or(job);
        let Some((plant, wind)) = parse_dataset_id(id) else {
            continue;
        };
        let w = wind_rank(&wind);
        found
            .entry((w, plant))
            .or_insert((job.to_string(), e.path()));
    }
    if found.is_empty() {
        return Ok(vec![]);
    }
    let mut maps = BTreeMap::new();
    let mut data = vec![];
    for (key, (job, path)) in found {
        let mean: Array2<num_complex::Complex64> =
            ndarray_npy::read_npy(&path).with_context(|| format!("reading {}", path.display()))?;
        maps.insert(key, (job, mean.mapv(|z| 20.0 * z.norm().log10())));
        data.push(rel(dir, &path));
    }
    Ok(vec![heatmap_task(
        dir,
        "plants_mean_kspace",
        "Mean k-space image, 20 log10 |mean E(f, phi)| (rows frequency, columns azimuth; Fig. 48)"
            .to_string(),
        rows_by_wind(maps),
        (Scale::Perceptual, "dB"),
        ["azimuth index".to_string(), "frequency index".to_string()],
        data,
    )])
}
