//! The report of a results folder: figures drawn from the run's `.npy` maps and Parquet tables
//! (under `figures/`), and `report.html`, one self-contained page (relative links only, no
//! network) with the summary tables, every figure with links to its SVG and to the files that
//! hold its numbers, the spec and the provenance from `manifest.json`. Everything is rebuilt
//! from files, so `isar-clutter report DIR` regenerates it without rerunning anything.

pub mod catalog;
pub mod cnn;
pub mod figures;
mod page;
pub mod table;

use anyhow::{Context, Result};
use figures::{Panel, Scale};
use ndarray::Array2;
use num_complex::Complex64;
use page::page;
use polars::prelude::{DataFrame, DataType};
use rayon::prelude::*;
use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use table::{escape, Format};

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

/// What [`build`] wrote.
#[derive(Debug, Clone)]
pub struct Report {
    /// `report.html`.
    pub html: PathBuf,
    /// The figures, in report order.
    pub figures: Vec<Figure>,
    /// The figures drawn this time (the others were found unchanged), as paths relative to the
    /// results folder without extension (`figures/<job>/<stem>`), sorted.
    pub drawn: Vec<String>,
}

/// A figure whose inputs are loaded, to be drawn (or found unchanged) later, in parallel.
type Task = Box<dyn FnOnce() -> Result<Figure> + Send>;

/// Builds `figures/` and `report.html` in the results folder `dir`, and removes the figures an
/// earlier report drew that this one does not (only files the tool's records list: see
/// [`crate::io::outdir`]). Figures whose inputs did not change since the last report are kept
/// as they are ([`figures::cache`]); the others are drawn in parallel on the current rayon
/// pool, with the same files whatever its size.
///
/// # Errors
/// If `dir` is not a complete run's folder (in progress, interrupted, or changed since its
/// manifest; accepted with `allow_incomplete`), is locked by a run, `manifest.json` is
/// unreadable, a table or map cannot be read, or a file cannot be written.
pub fn build(dir: &Path, allow_incomplete: bool) -> Result<Report> {
    use crate::io::outdir::{OutDir, Purpose};
    let outdir = OutDir::claim(dir, None, Purpose::Report { allow_incomplete })?;
    build_claimed(&outdir)
}

/// [`build`] in a folder this process has claimed already: a run's, right after its manifest
/// (the run holds the lock, and the folder is complete).
///
/// # Errors
/// As [`build`], but for the claim.
pub fn build_claimed(outdir: &crate::io::outdir::OutDir) -> Result<Report> {
    let dir = outdir.root();
    let manifest: Json =
        serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).with_context(|| {
            format!(
                "{} is not a results folder (no manifest.json)",
                dir.display()
            )
        })?)
        .with_context(|| format!("reading {}", dir.join("manifest.json").display()))?;
    let jobs: Vec<String> = manifest["jobs"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter(|j| j["status"] == "ok")
                .filter_map(|j| j["job"].as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    let cache = figures::cache::FigureCache::open(dir)?;
    let params = synthesis_params(dir)?;
    let per_job: Vec<Vec<Task>> = jobs
        .par_iter()
        .map(|job| job_figures(dir, job, params.as_ref()))
        .collect::<Result<_>>()?;
    let mut tasks: Vec<Task> = per_job.into_iter().flatten().collect();
    tasks.extend(sweep_figures(dir)?);
    tasks.extend(calibration_figures(dir)?);
    // Every figure is a pure function of its loaded inputs and has files of its own: drawn in
    // any order on any number of threads, the files are the same.
    let mut figures: Vec<Figure> = tasks.into_par_iter().map(|t| t()).collect::<Result<_>>()?;
    let sections = cnn::sections(dir)?;
    let html = page(dir, &manifest, &figures, &sections)?;
    figures.extend(sections.into_iter().flat_map(|s| s.figures));
    let path = dir.join("report.html");
    crate::io::atomic::atomic_write(&path, |w| {
        use std::io::Write;
        w.write_all(html.as_bytes())?;
        Ok(())
    })?;
    let summary = cache.finish()?;
    // Figures of jobs that are gone or failed this time, of parameters no longer swept (those
    // found unchanged were not written by this claim, but are this report's).
    outdir.remove_stale(|p| {
        (p.starts_with("figures") && !summary.kept.contains(p)) || p == Path::new("report.html")
    })?;
    Ok(Report {
        html: path,
        figures,
        drawn: summary.drawn.into_iter().collect(),
    })
}

/// Reads a real 2-D map if the file exists.
fn map(path: &Path) -> Result<Option<Array2<f64>>> {
    if !path.exists() {
        return Ok(None);
    }
    Ok(Some(crate::io::npy::read_real_map(path)?))
}

fn rel(dir: &Path, p: &Path) -> PathBuf {
    p.strip_prefix(dir).unwrap_or(p).to_path_buf()
}

/// Rows of titled maps.
type Grid = Vec<Vec<(String, Array2<f64>)>>;

/// The panels of a grid of titled maps, row by row, borrowing the maps.
fn panels(rows: &Grid) -> Vec<Vec<Panel<'_>>> {
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
fn grid(
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
fn abs_max<'a>(maps: impl Iterator<Item = &'a Array2<f64>>) -> f64 {
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

/// Level x direction maps `<prefix>level{L}_<kind>_{H,V,D}.npy` for `L = 1, 2, ...` while present.
fn level_maps(maps: &Path, prefix: &str, kind: &str) -> Result<(Grid, Vec<PathBuf>)> {
    let (mut rows, mut files) = (vec![], vec![]);
    for level in 1.. {
        let mut row = vec![];
        for d in ["H", "V", "D"] {
            let f = maps.join(format!("{prefix}level{level}_{kind}_{d}.npy"));
            if let Some(m) = map(&f)? {
                row.push((format!("level {level}, {d}"), m));
                files.push(f);
            }
        }
        if row.is_empty() {
            break;
        }
        rows.push(row);
    }
    Ok((rows, files))
}

/// The figures of one job, from `maps/<job>/`, `samples/<job>.npy` and the synthesis
/// parameters.
fn job_figures(dir: &Path, job: &str, params: Option<&DataFrame>) -> Result<Vec<Task>> {
    let maps = dir.join("maps").join(job);
    let mut out = correlation_figures(dir, job, &maps)?;
    out.extend(level_figures(dir, job, &maps)?);
    out.extend(moment_figures(dir, job, &maps)?);
    out.extend(kl_figures(dir, job, &maps)?);
    if let Some(p) = params {
        out.extend(parameter_figures(dir, job, p)?);
    }
    let sample_file = dir.join("samples").join(format!("{job}.npy"));
    if sample_file.exists() {
        out.push(example_sample(dir, job, &sample_file)?);
    }
    Ok(out)
}

/// The correlation maps by level and direction, and a histogram of their values per level
/// (Figs. 86-102).
fn correlation_figures(dir: &Path, job: &str, maps: &Path) -> Result<Vec<Task>> {
    let (corr, corr_files) = level_maps(maps, "", "correlation")?;
    if corr.is_empty() {
        return Ok(vec![]);
    }
    let values: Vec<(String, Vec<f64>)> = corr
        .iter()
        .flat_map(|row| row.iter())
        .map(|(t, m)| {
            (
                t.clone(),
                m.iter().copied().filter(|v| v.is_finite()).collect(),
            )
        })
        .collect();
    let mut out = vec![grid(
        dir,
        job,
        "correlation",
        format!("{job}: directional correlation maps by level (rows) and direction (columns)"),
        corr,
        Scale::Diverging { lo: -1.0, hi: 1.0 },
        "correlation",
        corr_files.clone(),
    )];
    for (level, (sets, files)) in values.chunks(3).zip(corr_files.chunks(3)).enumerate() {
        let level = level + 1;
        let (sets, files) = (sets.to_vec(), files.to_vec());
        let (dir, job) = (dir.to_path_buf(), job.to_string());
        out.push(Box::new(move || {
            let stem = format!("histogram_level{level}");
            let caption = format!("{job}: histogram of the level-{level} correlation map values");
            let refs: Vec<(&str, &[f64])> = sets
                .iter()
                .map(|(t, v)| (t.as_str(), v.as_slice()))
                .collect();
            let files_drawn = figures::charts::histograms(
                &dir.join("figures").join(&job),
                &stem,
                &caption,
                &refs,
                30,
                "correlation",
            )
            .with_context(|| format!("drawing {stem} of {job}"))?;
            Ok(Figure {
                job,
                caption,
                files: files_drawn.map(|f| rel(&dir, &f)),
                data: files.iter().map(|f| rel(&dir, f)).collect(),
            })
        }));
    }
    Ok(out)
}

/// The exact expected correlation maps of a synthetic model, and the covariance maps.
fn level_figures(dir: &Path, job: &str, maps: &Path) -> Result<Vec<Task>> {
    let mut out = vec![];
    let (expected, files) = level_maps(maps, "expected_", "correlation")?;
    if !expected.is_empty() {
        out.push(grid(
            dir,
            job,
            "expected_correlation",
            format!("{job}: exact expected correlation maps of the synthetic model"),
            expected,
            Scale::Diverging { lo: -1.0, hi: 1.0 },
            "correlation",
            files,
        ));
    }
    let (cov, files) = level_maps(maps, "", "covariance")?;
    if !cov.is_empty() {
        let m = abs_max(cov.iter().flatten().map(|(_, m)| m));
        out.push(grid(
            dir,
            job,
            "covariance",
            format!("{job}: directional covariance maps by level and direction"),
            cov,
            Scale::Diverging { lo: -m, hi: m },
            "covariance",
            files,
        ));
    }
    Ok(out)
}

/// The sample mean (real part) and the pixel variance.
fn moment_figures(dir: &Path, job: &str, maps: &Path) -> Result<Vec<Task>> {
    let mut out = vec![];
    let mean_file = maps.join("mean.npy");
    if mean_file.exists() {
        use ndarray_npy::ReadNpyExt;
        let mean = Array2::<Complex64>::read_npy(
            std::fs::File::open(&mean_file)
                .with_context(|| format!("opening {}", mean_file.display()))?,
        )
        .with_context(|| format!("reading {}", mean_file.display()))?;
        let re = mean.mapv(|z| z.re);
        let m = abs_max(std::iter::once(&re));
        out.push(grid(
            dir,
            job,
            "mean",
            format!("{job}: sample mean, real part"),
            vec![vec![("mean (real part)".into(), re)]],
            Scale::Diverging { lo: -m, hi: m },
            "mean",
            vec![mean_file],
        ));
    }
    let var_file = maps.join("variance.npy");
    if let Some(v) = map(&var_file)? {
        out.push(grid(
            dir,
            job,
            "variance",
            format!("{job}: pixel variance"),
            vec![vec![("variance".into(), v)]],
            Scale::Perceptual,
            "variance",
            vec![var_file],
        ));
    }
    Ok(out)
}

/// The KL divergence maps (per pixel, per image area) of generated against original samples
/// and of the noise floor.
fn kl_figures(dir: &Path, job: &str, maps: &Path) -> Result<Vec<Task>> {
    let mut out = vec![];
    for prefix in ["", "noise_floor_"] {
        for metric in ["kl_pixel", "kl_area"] {
            let files: Vec<PathBuf> = ["re", "im"]
                .iter()
                .map(|c| maps.join(format!("{prefix}{metric}_{c}.npy")))
                .collect();
            let loaded: Vec<Option<Array2<f64>>> =
                files.iter().map(|f| map(f)).collect::<Result<_>>()?;
            if !loaded.iter().all(Option::is_some) {
                continue;
            }
            let row: Vec<(String, Array2<f64>)> = ["real part", "imaginary part"]
                .iter()
                .zip(loaded.into_iter().flatten())
                .map(|(t, m)| (t.to_string(), m))
                .collect();
            let what = if metric == "kl_pixel" {
                "per pixel"
            } else {
                "per image area"
            };
            let whose = if prefix.is_empty() {
                "generated vs original"
            } else {
                "noise floor"
            };
            out.push(grid(
                dir,
                job,
                &format!("{prefix}{metric}"),
                format!("{job}: KL divergence {what} ({whose})"),
                vec![row],
                Scale::Perceptual,
                "KL divergence",
                files,
            ));
        }
    }
    Ok(out)
}

/// The first generated sample's real part (Figs. 47, 49, 72).
fn example_sample(dir: &Path, job: &str, file: &Path) -> Result<Task> {
    let stack = crate::io::npy::Stack::load(file)?.to_complex128(false);
    let first = stack.index_axis(ndarray::Axis(0), 0).mapv(|z| z.re);
    let m = abs_max(std::iter::once(&first));
    Ok(grid(
        dir,
        job,
        "sample",
        format!("{job}: first generated sample, real part"),
        vec![vec![("sample 0 (real part)".into(), first)]],
        Scale::Diverging { lo: -m, hi: m },
        "amplitude",
        vec![file.to_path_buf()],
    ))
}

/// `synthesis_params.parquet`, if the run has one with rows.
fn synthesis_params(dir: &Path) -> Result<Option<DataFrame>> {
    let df = crate::io::atomic::read_parquet(&dir.join("synthesis_params.parquet"))?;
    Ok(df.filter(|df| df.height() > 0))
}

/// Filter parameter maps of a Method 1 or 2 job (Figs. 25-27, 34-36).
fn parameter_figures(dir: &Path, job: &str, df: &DataFrame) -> Result<Vec<Task>> {
    let strs = |c: &str| -> Result<Vec<Option<String>>> {
        Ok(df
            .column(c)?
            .cast(&DataType::String)?
            .str()?
            .iter()
            .map(|v| v.map(str::to_string))
            .collect())
    };
    let ints = |c: &str| -> Result<Vec<i64>> {
        Ok(df
            .column(c)?
            .cast(&DataType::Int64)?
            .i64()?
            .iter()
            .map(|v| v.unwrap_or(0))
            .collect())
    };
    let jobs = strs("job")?;
    let rows: Vec<usize> = (0..df.height())
        .filter(|&i| jobs[i].as_deref() == Some(job))
        .collect();
    if rows.is_empty() {
        return Ok(vec![]);
    }
    let (r, c) = (ints("row")?, ints("col")?);
    let h = rows.iter().map(|&i| r[i]).max().unwrap_or(0) as usize + 1;
    let w = rows.iter().map(|&i| c[i]).max().unwrap_or(0) as usize + 1;
    let names: Vec<String> = df
        .get_column_names()
        .iter()
        .map(|s| s.to_string())
        .filter(|n| n.starts_with("alpha_") || n.starts_with("r_"))
        .collect();
    let mut maps: Vec<(String, Array2<f64>)> = vec![];
    for name in names {
        let v: Vec<Option<f64>> = df
            .column(&name)?
            .cast(&DataType::Float64)?
            .f64()?
            .iter()
            .collect();
        if rows.iter().all(|&i| v[i].is_none()) {
            continue;
        }
        let mut m = Array2::from_elem((h, w), f64::NAN);
        for &i in &rows {
            m[[r[i] as usize, c[i] as usize]] = v[i].unwrap_or(f64::NAN);
        }
        maps.push((name, m));
    }
    if maps.is_empty() {
        return Ok(vec![]);
    }
    // Horizontal parameters on the first row, vertical on the second.
    let (hz, vt): (Vec<_>, Vec<_>) = maps.into_iter().partition(|(n, _)| n.contains("_h"));
    let m = abs_max(hz.iter().chain(&vt).map(|(_, m)| m));
    let data = vec![dir.join("synthesis_params.parquet")];
    Ok(vec![grid(
        dir,
        job,
        "filter_parameters",
        format!("{job}: fitted filter parameters per level-1 cell (horizontal, vertical)"),
        vec![hz, vt].into_iter().filter(|r| !r.is_empty()).collect(),
        Scale::Diverging { lo: -m, hi: m },
        "parameter",
        data,
    )])
}

/// The calibration's spectra (Figs. 11-14): Mie, raw and calibrated sphere, and the error.
fn calibration_figures(dir: &Path) -> Result<Vec<Task>> {
    let path = dir.join("calibration.parquet");
    let Some(df) = crate::io::atomic::read_parquet(&path)? else {
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
    let f = col("freq_ghz")?;
    let series =
        |c: &str| -> Result<Vec<(f64, f64)>> { Ok(f.iter().copied().zip(col(c)?).collect()) };
    let spectra = vec![
        ("Mie (exact)".to_string(), series("mie_dbsm")?),
        ("raw sphere measurement".into(), series("raw_db")?),
        ("calibrated sphere".into(), series("calibrated_dbsm")?),
    ];
    let error = vec![("calibrated - Mie".to_string(), series("error_db")?)];
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
fn curves_task(
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
fn sweep_figures(dir: &Path) -> Result<Vec<Task>> {
    let mut out = curve_figures(dir, "analysis_summary.parquet", "mean_correlation", &|r| {
        Some((
            format!("{} ({})", r["dataset"], r["source"]),
            format!("level {} {}", r["level"], r["direction"]),
        ))
    })?;
    out.extend(curve_figures(dir, "similarity.parquet", "value", &|r| {
        let what = match r["statistic"].as_str() {
            "average_level_1" => "multiscale RMSE, average level 1",
            "average_levels_1_3" => "multiscale RMSE, average levels 1-3",
            "distance" => "correlation matrix distance",
            _ => return None,
        };
        Some((format!("{}: {what}", r["dataset"]), r["method"].clone()))
    })?);
    Ok(out)
}

/// A row of a table as display strings, by column name.
type Row = BTreeMap<String, String>;

/// Draws `y` against every numeric swept column of `file`: `pick` maps a row to its figure
/// (title) and series (legend name), or `None` to leave it out. A figure needs two distinct
/// x values.
fn curve_figures(
    dir: &Path,
    file: &str,
    y: &str,
    pick: &dyn Fn(&Row) -> Option<(String, String)>,
) -> Result<Vec<Task>> {
    let path = dir.join(file);
    let Some(df) = crate::io::atomic::read_parquet(&path)? else {
        return Ok(vec![]);
    };
    let axes: Vec<String> = df
        .columns()
        .iter()
        .filter(|c| {
            !table::LIBRARY_COLUMNS.contains(&c.name().as_str()) && c.dtype() == &DataType::Float64
        })
        .map(|c| c.name().to_string())
        .collect();
    let text: Vec<(String, Vec<String>)> = df
        .columns()
        .iter()
        .map(|c| -> Result<(String, Vec<String>)> {
            let s = c.cast(&DataType::String)?;
            let v = s
                .str()?
                .iter()
                .map(|v| v.unwrap_or("-").to_string())
                .collect();
            Ok((c.name().to_string(), v))
        })
        .collect::<Result<_>>()?;
    let yv: Vec<Option<f64>> = df
        .column(y)?
        .cast(&DataType::Float64)?
        .f64()?
        .iter()
        .collect();
    let mut out = vec![];
    for axis in axes {
        let x: Vec<Option<f64>> = df.column(&axis)?.f64()?.iter().collect();
        let mut groups: BTreeMap<String, BTreeMap<String, Vec<(f64, f64)>>> = BTreeMap::new();
        for i in 0..df.height() {
            let (Some(xv), Some(v)) = (x[i], yv[i]) else {
                continue;
            };
            let row: Row = text
                .iter()
                .map(|(k, v)| (k.clone(), v[i].clone()))
                .collect();
            if let Some((figure, series)) = pick(&row) {
                groups
                    .entry(figure)
                    .or_default()
                    .entry(series)
                    .or_default()
                    .push((xv, v));
            }
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
                    (k, v)
                })
                .collect();
            let safe = |s: &str| -> String {
                s.chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect()
            };
            let stem = format!("sweep_{}_{}", safe(&title), safe(&axis));
            let caption = format!("{title} against {axis}");
            let y_label = if y == "value" {
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
