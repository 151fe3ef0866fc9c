//! A figure of the report and the task that draws it: every figure is loaded first (its
//! inputs read), then drawn later in parallel, each a pure function of its inputs with files
//! of its own. The grids of heat maps most per-job figures are, their shared scale, and the
//! figure's record ([`Figure`]: its files and the data files it shows).

use super::figures::{self, Panel, Scale};
use anyhow::{Context, Result};
use ndarray::Array2;
use std::path::{Path, PathBuf};

/// One figure of the report.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Job the figure belongs to (empty for run-wide figures).
    pub job: String,
    /// Caption.
    pub caption: String,
    /// PNG and SVG, relative to the results folder.
    pub files: [PathBuf; 2],
    /// Files holding the figure's numbers, relative to the results folder.
    pub data: Vec<PathBuf>,
}

/// A figure whose inputs are loaded, to be drawn (or found unchanged) later, in parallel.
pub(super) type Task = Box<dyn FnOnce() -> Result<Figure> + Send>;

/// `p` relative to the results folder `dir`.
pub(super) fn rel(dir: &Path, p: &Path) -> PathBuf {
    p.strip_prefix(dir).unwrap_or(p).to_path_buf()
}

/// Rows of titled maps.
pub(super) type Grid = Vec<Vec<(String, Array2<f64>)>>;

/// The panels of a grid of titled maps, row by row, borrowing the maps.
pub(super) fn panels(rows: &Grid) -> Vec<Vec<Panel<'_>>> {
    rows.iter()
        .map(|r| {
            r.iter()
                .map(|(t, m)| Panel {
                    title: t.clone(),
                    map: m.view(),
                })
                .collect()
        })
        .collect()
}

/// A grid of maps to draw, and its record.
#[allow(clippy::too_many_arguments)]
pub(super) fn grid(
    dir: &Path,
    job: &str,
    stem: &str,
    caption: String,
    rows: Grid,
    scale: Scale,
    bar: &str,
    data: Vec<PathBuf>,
) -> Task {
    let (dir, job, stem, bar) = (
        dir.to_path_buf(),
        job.to_string(),
        stem.to_string(),
        bar.to_string(),
    );
    Box::new(move || draw_grid(&dir, &job, &stem, caption, &rows, scale, &bar, &data))
}

/// Draws a grid of maps now (see [`grid`]).
#[allow(clippy::too_many_arguments)]
fn draw_grid(
    dir: &Path,
    job: &str,
    stem: &str,
    caption: String,
    rows: &Grid,
    scale: Scale,
    bar: &str,
    data: &[PathBuf],
) -> Result<Figure> {
    let out = dir.join("figures").join(job);
    let panels = panels(rows);
    let files = figures::heatmap::heatmap_grid(&out, stem, &caption, &panels, scale, bar)
        .with_context(|| format!("drawing {stem} of {job}"))?;
    Ok(Figure {
        job: job.to_string(),
        caption,
        files: files.map(|f| rel(dir, &f)),
        data: data.iter().map(|d| rel(dir, d)).collect(),
    })
}

/// Largest absolute finite value of some maps (1 if none), for symmetric diverging scales.
pub(super) fn abs_max<'a>(maps: impl Iterator<Item = &'a Array2<f64>>) -> f64 {
    let m = maps
        .flat_map(|m| m.iter())
        .filter(|v| v.is_finite())
        .fold(0.0f64, |a, v| a.max(v.abs()));
    if m > 0.0 {
        m
    } else {
        1.0
    }
}
