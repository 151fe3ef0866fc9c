//! The CNN applications' figures, run-wide under `figures/`: accuracy against training size
//! per method with error bars (Figs. 66-67, one per normalisation) and against SCR per method
//! (Figs. 73-74, one per target); for one representative training per normalisation or target
//! (see [`Representative`]) its confusion matrix on the test set and every method's validation
//! accuracy by epoch; and the location's example training images, `|x|` in dB with the 8x8
//! target outlined (Fig. 72). Everything is drawn from the run's files, in a fixed order.

use super::super::figures::charts::{self, Point};
use super::super::figures::heatmap::{heatmap_grid_with, GridOptions};
use super::super::figures::{Panel, Scale};
use super::super::task::{rel, Figure};
use super::groups::{Group, Representative};
use crate::io::results::{self, col, CnnApp};
use crate::location_grid::{centre, GRID, TARGET};
use anyhow::{Context, Result};
use ndarray::{Array2, Axis};
use polars::prelude::DataFrame;
use std::path::{Path, PathBuf};

/// Labels of the example images `examples/<job>.npy` holds, one per grid row.
const EXAMPLE_LABELS: [usize; 5] = [0, 6, 12, 18, 24];
/// Dynamic range of the example images' colour scale (dB below their peak).
const EXAMPLE_RANGE_DB: f64 = 50.0;

/// A file-name-safe form of a group name.
fn safe(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// Draws named curves of accuracies in % (y from 0 to 100) into `figures/<stem>`.
fn plot(
    dir: &Path,
    stem: &str,
    title: &str,
    curves: &[(String, Vec<Point>)],
    labels: (&str, &str),
) -> Result<[PathBuf; 2]> {
    let refs: Vec<(&str, &[Point])> = curves
        .iter()
        .map(|(m, c)| (m.as_str(), c.as_slice()))
        .collect();
    charts::error_curves(
        &dir.join("figures"),
        stem,
        title,
        &refs,
        labels,
        Some(0.0..100.0),
    )
    .with_context(|| format!("drawing {stem}"))
}

/// Records a figure drawn into `figures/`.
fn figure(dir: &Path, caption: String, files: [PathBuf; 2], data: &[&str]) -> Figure {
    Figure {
        job: String::new(),
        caption,
        files: files.map(|f| rel(dir, &f)),
        data: data.iter().map(PathBuf::from).collect(),
    }
}

/// The classification's figures: per normalisation, accuracy against training size, the
/// representative training's confusion matrix and the training curves.
pub(super) fn classification(dir: &Path, groups: &[Group]) -> Result<Vec<Figure>> {
    let history = results::TRAINING_HISTORY.read(dir)?;
    let confusion = results::CONFUSION.read(dir)?;
    // One group's figures after another's, each group's drawn while the others are.
    let per_group = |g: &Group| -> Result<Vec<Figure>> {
        let mut out = vec![];
        let stem = format!("classification_accuracy_{}", safe(&g.name));
        let caption = format!(
            "Classification, {}: prediction accuracy on original data against the training \
             size, per method (Figs. 66-67); mean and sample std over repeats",
            g.name
        );
        let title = format!("{}: accuracy against training size", g.name);
        out.extend(accuracy(
            dir,
            g,
            &stem,
            (&title, caption),
            ("training size N", CnnApp::Classification),
        )?);
        let Some(rep) = g.representative(CnnApp::Classification) else {
            return Ok(out);
        };
        let what = format!(
            "{} at N = {}, repeat {} ({}: the best generated method at the largest size)",
            rep.method, rep.x, rep.repeat, rep.job
        );
        if let Some(c) = &confusion {
            let names = class_names(dir, &rep.job)?;
            let stem = format!("classification_confusion_{}", safe(&g.name));
            out.extend(confusion_figure(
                dir,
                c,
                &rep,
                &stem,
                &names,
                &what,
                CnnApp::Classification,
            )?);
        }
        if let Some(h) = &history {
            let stem = format!("classification_training_{}", safe(&g.name));
            let caption = format!(
                "Classification, {}: validation accuracy by epoch at N = {}, repeat {}, per method",
                g.name, rep.x, rep.repeat
            );
            out.extend(training_curves(dir, h, g, &rep, &stem, caption)?);
        }
        Ok(out)
    };
    in_parallel(groups, per_group)
}

/// `figures` of every group, in the groups' order, drawn in parallel.
fn in_parallel(
    groups: &[Group],
    figures: impl Fn(&Group) -> Result<Vec<Figure>> + Sync + Send,
) -> Result<Vec<Figure>> {
    use rayon::prelude::*;
    let per_group: Vec<Vec<Figure>> = groups.par_iter().map(figures).collect::<Result<_>>()?;
    Ok(per_group.into_iter().flatten().collect())
}

/// The location's figures: per target, accuracy against SCR, the representative training's
/// confusion matrix, the training curves and example training images.
pub(super) fn location(dir: &Path, groups: &[Group]) -> Result<Vec<Figure>> {
    let history = results::TRAINING_HISTORY.read(dir)?;
    let confusion = results::CONFUSION.read(dir)?;
    let per_group = |g: &Group| -> Result<Vec<Figure>> {
        let mut out = vec![];
        let stem = format!("location_accuracy_{}", safe(&g.name));
        let caption = format!(
            "Target location, {} target: test accuracy against SCR, per method (Figs. 73-74); \
             mean and sample std over repeats; chance is 4 %",
            g.name
        );
        let title = format!("{} target: accuracy against SCR", g.name);
        out.extend(accuracy(
            dir,
            g,
            &stem,
            (&title, caption),
            ("SCR (dB)", CnnApp::Location),
        )?);
        let Some(rep) = g.representative(CnnApp::Location).filter(|_| g.details) else {
            return Ok(out);
        };
        let what = format!(
            "{} at SCR {} dB, repeat {} ({}: the best generated method over the sweep, at the \
             lowest SCR where its mean accuracy reaches 50 %, else the highest SCR)",
            rep.method, rep.x, rep.repeat, rep.job
        );
        if let Some(c) = &confusion {
            let stem = format!("location_confusion_{}", safe(&g.name));
            out.extend(confusion_figure(
                dir,
                c,
                &rep,
                &stem,
                &[],
                &what,
                CnnApp::Location,
            )?);
        }
        if let Some(h) = &history {
            let stem = format!("location_training_{}", safe(&g.name));
            let caption = format!(
                "Target location, {} target: validation accuracy by epoch at SCR {} dB, repeat \
                 {}, per method",
                g.name, rep.x, rep.repeat
            );
            out.extend(training_curves(dir, h, g, &rep, &stem, caption)?);
        }
        out.extend(examples(dir, g, &rep)?);
        Ok(out)
    };
    in_parallel(groups, per_group)
}

/// Test accuracy (%) against x per method, with error bars.
fn accuracy(
    dir: &Path,
    g: &Group,
    stem: &str,
    (title, caption): (&str, String),
    (x_label, app): (&str, CnnApp),
) -> Result<Option<Figure>> {
    let curves: Vec<(String, Vec<Point>)> = g
        .methods
        .iter()
        .map(|m| (m.clone(), g.curve(m)))
        .filter(|(_, c)| !c.is_empty())
        .collect();
    if curves.is_empty() {
        return Ok(None);
    }
    let files = plot(dir, stem, title, &curves, (x_label, "test accuracy (%)"))?;
    Ok(Some(figure(
        dir,
        caption,
        files,
        &[&app.table().file_name()],
    )))
}

/// The class names of a classification job: `jobs.parquet`'s `dataset` (the class ids,
/// comma-separated), else the spec's `classification.classes` in `manifest.json`; empty when
/// neither says.
fn class_names(dir: &Path, job: &str) -> Result<Vec<String>> {
    use super::super::table::strings;
    if let Some(df) = results::JOBS.read(dir)? {
        let (jobs, data) = (strings(&df, col::JOB)?, strings(&df, col::DATASET)?);
        if let Some(Some(d)) = jobs
            .iter()
            .zip(&data)
            .find(|(j, _)| j.as_deref() == Some(job))
            .map(|(_, d)| d)
        {
            return Ok(d.split(',').map(str::to_string).collect());
        }
    }
    let spec = crate::io::manifest::Manifest::read(dir)
        .map(|m| m.spec)
        .unwrap_or_default();
    Ok(spec["classification"]["classes"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|c| c.as_str().map(str::to_string))
        .collect())
}

/// The confusion matrix (`[true, predicted]` counts on the test set) of the representative
/// training, counts written into the cells when there are few classes.
fn confusion_figure(
    dir: &Path,
    df: &DataFrame,
    rep: &Representative,
    stem: &str,
    names: &[String],
    what: &str,
    app: CnnApp,
) -> Result<Option<Figure>> {
    use super::super::table::{floats, strings};
    let (jobs, t, p, n) = (
        strings(df, col::JOB)?,
        floats(df, col::TRUE_CLASS)?,
        floats(df, col::PREDICTED_CLASS)?,
        floats(df, col::COUNT)?,
    );
    let cells: Vec<(usize, usize, f64)> = (0..df.height())
        .filter(|&i| jobs[i].as_deref() == Some(rep.job.as_str()))
        .filter_map(|i| Some((t[i]? as usize, p[i]? as usize, n[i]?)))
        .collect();
    let Some(k) = cells.iter().map(|c| c.0.max(c.1) + 1).max() else {
        return Ok(None);
    };
    let mut map = Array2::<f64>::zeros((k, k));
    for (a, b, v) in cells {
        map[[a, b]] += v;
    }
    let classes = match app {
        CnnApp::Classification if !names.is_empty() => names
            .iter()
            .enumerate()
            .map(|(i, n)| format!("{i} = {n}"))
            .collect::<Vec<_>>()
            .join(", "),
        CnnApp::Classification => "class indices".into(),
        CnnApp::Location => format!(
            "location 5 i + j = target centred at row 8 + 12 i, column 8 + 12 j (i, j < {GRID})"
        ),
    };
    let caption = format!("Confusion matrix on the test set of {what}; classes: {classes}");
    let title = format!("confusion matrix: {} ({})", rep.method, app_group(app, rep));
    // The class names over the panel when they fit, else in the caption only.
    let panel = match app {
        CnnApp::Classification if !names.is_empty() && classes.len() <= 32 => classes.clone(),
        _ => format!("test set, repeat {}", rep.repeat),
    };
    let panels = vec![vec![Panel {
        title: panel,
        map: map.view(),
    }]];
    let (x_label, y_label) = match app {
        CnnApp::Classification => ("predicted class", "true class"),
        CnnApp::Location => ("predicted location", "true location"),
    };
    let options = GridOptions {
        x_label,
        y_label,
        annotate: true,
        boxes: vec![],
    };
    let files = heatmap_grid_with(
        &dir.join("figures"),
        stem,
        &title,
        &panels,
        (Scale::Perceptual, "test samples"),
        &options,
    )
    .with_context(|| format!("drawing {stem}"))?;
    Ok(Some(figure(
        dir,
        caption,
        files,
        &[&results::CONFUSION.file_name()],
    )))
}

/// Where a representative training sits, for titles.
fn app_group(app: CnnApp, rep: &Representative) -> String {
    match app {
        CnnApp::Classification => format!("N = {}", rep.x),
        CnnApp::Location => format!("SCR {} dB", rep.x),
    }
}

/// Validation accuracy (%) by epoch of every method's training at the representative x and
/// repeat.
fn training_curves(
    dir: &Path,
    df: &DataFrame,
    g: &Group,
    rep: &Representative,
    stem: &str,
    caption: String,
) -> Result<Option<Figure>> {
    use super::super::table::{floats, strings};
    let title = format!("{}: validation accuracy by epoch", g.name);
    let (jobs, epoch, val) = (
        strings(df, col::JOB)?,
        floats(df, col::EPOCH)?,
        floats(df, col::VALIDATION_ACCURACY)?,
    );
    let mut series: Vec<(String, Vec<Point>)> = vec![];
    for m in &g.methods {
        let Some(r) = g.at(m, rep.x).find(|r| r.repeat == rep.repeat) else {
            continue;
        };
        let pts: Vec<Point> = (0..df.height())
            .filter(|&i| jobs[i].as_deref() == Some(r.job.as_str()))
            .filter_map(|i| Some((epoch[i]?, 100.0 * val[i]?, 0.0)))
            .collect();
        if !pts.is_empty() {
            series.push((m.clone(), pts));
        }
    }
    if series.is_empty() {
        return Ok(None);
    }
    let labels = ("epoch", "validation accuracy (%)");
    let files = plot(dir, stem, &title, &series, labels)?;
    Ok(Some(figure(
        dir,
        caption,
        files,
        &[&results::TRAINING_HISTORY.file_name()],
    )))
}

/// Fig. 72: the example training images of every method at the representative SCR (rows) and
/// five locations (columns), `20 log10 |x|` on one scale spanning [`EXAMPLE_RANGE_DB`] below
/// the peak, each target's 8x8 footprint outlined.
fn examples(dir: &Path, g: &Group, rep: &Representative) -> Result<Option<Figure>> {
    let mut rows: super::super::task::Grid = vec![];
    let mut files = vec![];
    for m in &g.methods {
        let Some(r) = g.at(m, rep.x).find(|r| r.repeat == 0) else {
            continue;
        };
        let path = results::files::example(dir, &r.job);
        if !path.is_file() {
            continue;
        }
        let stack = crate::io::npy::Stack::load(&path)?.try_to_complex128(false)?;
        let row = stack
            .axis_iter(Axis(0))
            .zip(EXAMPLE_LABELS)
            .map(|(img, l)| {
                let db = img.mapv(|z| 20.0 * z.norm().log10());
                (format!("{m}, location {l}"), db)
            })
            .collect();
        rows.push(row);
        files.push(rel(dir, &path));
    }
    if rows.is_empty() {
        return Ok(None);
    }
    let peak = rows
        .iter()
        .flatten()
        .flat_map(|(_, m)| m.iter().copied())
        .filter(|v| v.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    let floor = peak - EXAMPLE_RANGE_DB;
    for (_, m) in rows.iter_mut().flatten() {
        m.mapv_inplace(|v| if v.is_finite() { v.max(floor) } else { floor });
    }
    let panels = super::super::task::panels(&rows);
    let half = TARGET / 2;
    let boxes = rows
        .iter()
        .flat_map(|r| {
            r.iter()
                .zip(EXAMPLE_LABELS)
                .map(|(_, l)| {
                    let (cr, cc) = centre(l);
                    vec![[cr - half, cc - half, TARGET, TARGET]]
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let options = GridOptions {
        boxes,
        ..GridOptions::default()
    };
    let stem = format!("location_examples_{}", safe(&g.name));
    let title = format!("{} target: training images at SCR {} dB", g.name, rep.x);
    let out = heatmap_grid_with(
        &dir.join("figures"),
        &stem,
        &title,
        &panels,
        (Scale::Perceptual, "|x| (dB)"),
        &options,
    )
    .with_context(|| format!("drawing {stem}"))?;
    let at: Vec<String> = EXAMPLE_LABELS
        .iter()
        .map(|&l| {
            let (r, c) = centre(l);
            format!("{l} at ({r}, {c})")
        })
        .collect();
    let caption = format!(
        "Target location, {} target: example training images (Fig. 72), |x| in dB ({} dB \
         range), one row per method at SCR {} dB (repeat 0), the 8x8 target outlined; \
         locations (centre row, column): {}",
        g.name,
        EXAMPLE_RANGE_DB,
        rep.x,
        at.join(", ")
    );
    let data: Vec<String> = files.iter().map(|f| f.to_string_lossy().into()).collect();
    let data: Vec<&str> = data.iter().map(String::as_str).collect();
    Ok(Some(figure(dir, caption, out, &data)))
}
