//! The figures of one job: its correlation, expected-correlation and covariance maps by level
//! and direction, histograms of the correlation values, mean and variance, KL maps, the fitted
//! filter parameters and the first saved generated sample, read from `maps/<job>/`,
//! `samples/<job>.npy` and `synthesis_params.parquet`. Each is loaded here and drawn later, in
//! parallel, as a [`Task`].

use super::figures::{self, Scale};
use super::task::{abs_max, grid, rel, Figure, Grid, Task};
use crate::io::results::{self, col, maps as names};
use crate::stats::analysis::Direction;
use crate::stats::metrics::{map_stem, name as metric_name};
use anyhow::{Context, Result};
use ndarray::Array2;
use num_complex::Complex64;
use polars::prelude::DataType;
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// Reads a real 2-D map if the file exists.
fn map(path: &Path) -> Result<Option<Array2<f64>>> {
    if !path.exists() {
        return Ok(None);
    }
    Ok(Some(crate::io::npy::read_real_map(path)?))
}

/// Level x direction maps `<prefix>level{L}_<kind>_{H,V,D}.npy` for `L = 1, 2, ...` while present.
fn level_maps(maps: &Path, prefix: &str, kind: &str) -> Result<(Grid, Vec<PathBuf>)> {
    let (mut rows, mut files) = (vec![], vec![]);
    for level in 1.. {
        let mut row = vec![];
        for d in Direction::ALL {
            let f = names::file(maps, &names::level(prefix, level, kind, d));
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
pub(super) fn job_figures(dir: &Path, job: &str, params: Option<&Params>) -> Result<Vec<Task>> {
    let mut maps = crate::io::results::files::maps(dir, job);
    if !maps.is_dir() {
        if let Some(extracted) = zarr_maps(dir, job)? {
            maps = extracted;
        }
    }
    let mut out = correlation_figures(dir, job, &maps)?;
    out.extend(level_figures(dir, job, &maps)?);
    out.extend(moment_figures(dir, job, &maps)?);
    out.extend(kl_figures(dir, job, &maps)?);
    if let Some(p) = params {
        out.extend(p.figures(dir, job));
    }
    let sample_file = crate::io::results::files::samples(dir, job);
    if sample_file.exists() {
        out.push(example_sample(dir, job, &sample_file)?);
    }
    Ok(out)
}

/// A job's maps from the run's `maps.zarr` (`outputs: {zarr_maps: true}` without `.npy`
/// maps), written as the `.npy` files the figures read into `figures/<job>/maps/` (the
/// report's own folder: the figures' data then name files a reader can open); `None` where
/// the store does not hold the job.
fn zarr_maps(dir: &Path, job: &str) -> Result<Option<PathBuf>> {
    use ndarray_npy::WriteNpyExt;
    let root = crate::io::results::files::maps_zarr(dir);
    let Some(maps) = crate::io::zarr::read_job(&root, job)
        .with_context(|| format!("reading {job}'s maps from {}", root.display()))?
    else {
        return Ok(None);
    };
    let out = dir.join("figures").join(job).join("maps");
    std::fs::create_dir_all(&out)?;
    let mut seen = BTreeSet::new();
    for m in maps {
        // A name with a second size keeps the first, as `maps/<job>/` would hold one.
        if !seen.insert(m.name.clone()) {
            continue;
        }
        let path = names::file(&out, &m.name);
        let shape = (m.rows, m.cols);
        crate::io::atomic::atomic_write(&path, |w| {
            match (m.real, m.complex) {
                (Some(v), _) => Array2::from_shape_vec(shape, v)?.write_npy(w)?,
                (_, Some(v)) => Array2::from_shape_vec(shape, v)?.write_npy(w)?,
                _ => anyhow::bail!("no values"),
            }
            Ok(())
        })
        .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(Some(out))
}

/// The correlation maps by level and direction, and a histogram of their values per level
/// (Figs. 86-102).
fn correlation_figures(dir: &Path, job: &str, maps: &Path) -> Result<Vec<Task>> {
    let (corr, corr_files) = level_maps(maps, "", col::CORRELATION)?;
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
        col::CORRELATION,
        format!("{job}: directional correlation maps by level (rows) and direction (columns)"),
        corr,
        Scale::Diverging { lo: -1.0, hi: 1.0 },
        col::CORRELATION,
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
                col::CORRELATION,
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
    let (expected, files) = level_maps(maps, names::EXPECTED, col::CORRELATION)?;
    if !expected.is_empty() {
        out.push(grid(
            dir,
            job,
            col::EXPECTED_CORRELATION,
            format!("{job}: exact expected correlation maps of the synthetic model"),
            expected,
            Scale::Diverging { lo: -1.0, hi: 1.0 },
            col::CORRELATION,
            files,
        ));
    }
    let (cov, files) = level_maps(maps, "", col::COVARIANCE)?;
    if !cov.is_empty() {
        let m = abs_max(cov.iter().flatten().map(|(_, m)| m));
        out.push(grid(
            dir,
            job,
            col::COVARIANCE,
            format!("{job}: directional covariance maps by level and direction"),
            cov,
            Scale::Diverging { lo: -m, hi: m },
            col::COVARIANCE,
            files,
        ));
    }
    Ok(out)
}

/// The sample mean (real part) and the pixel variance.
fn moment_figures(dir: &Path, job: &str, maps: &Path) -> Result<Vec<Task>> {
    let mut out = vec![];
    let mean_file = names::file(maps, names::MEAN);
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
    let var_file = names::file(maps, names::VARIANCE);
    if let Some(v) = map(&var_file)? {
        out.push(grid(
            dir,
            job,
            col::VARIANCE,
            format!("{job}: pixel variance"),
            vec![vec![(col::VARIANCE.into(), v)]],
            Scale::Perceptual,
            col::VARIANCE,
            vec![var_file],
        ));
    }
    Ok(out)
}

/// The KL divergence maps (per pixel, per image area) of generated against original samples
/// and of the noise floor.
fn kl_figures(dir: &Path, job: &str, maps: &Path) -> Result<Vec<Task>> {
    let mut out = vec![];
    for prefix in ["", names::NOISE_FLOOR] {
        for metric in [metric_name::KL_PIXEL, metric_name::KL_AREA] {
            let files: Vec<PathBuf> = names::COMPONENTS
                .iter()
                .map(|c| names::file(maps, &names::comparison(prefix, &map_stem(metric, c))))
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
            let what = if metric == metric_name::KL_PIXEL {
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
                &names::comparison(prefix, metric),
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

/// `synthesis_params.parquet` indexed by job: each column read once, whatever the number of
/// jobs whose figures are drawn from it.
pub(super) struct Params {
    /// The rows of each job.
    rows: HashMap<String, Vec<usize>>,
    /// Level-1 cell row and column of each row.
    cells: Vec<(i64, i64)>,
    /// The parameter columns (`alpha_*`, `r_*`) in file order.
    columns: Vec<(String, Vec<Option<f64>>)>,
}

impl Params {
    /// `synthesis_params.parquet` of `dir`, if the run has one with rows.
    ///
    /// # Errors
    /// If the file cannot be read or lacks a column the tool writes.
    pub(super) fn load(dir: &Path) -> Result<Option<Params>> {
        let Some(df) = results::SYNTHESIS_PARAMS.read(dir)? else {
            return Ok(None);
        };
        if df.height() == 0 {
            return Ok(None);
        }
        let ints = |c: &str| -> Result<Vec<i64>> {
            Ok(df
                .column(c)?
                .cast(&DataType::Int64)?
                .i64()?
                .iter()
                .map(|v| v.unwrap_or(0))
                .collect())
        };
        let mut rows: HashMap<String, Vec<usize>> = HashMap::new();
        let jobs = df.column(col::JOB)?.cast(&DataType::String)?;
        for (i, job) in jobs.str()?.iter().enumerate() {
            if let Some(job) = job {
                rows.entry(job.to_string()).or_default().push(i);
            }
        }
        let cells = ints(col::ROW)?.into_iter().zip(ints(col::COL)?).collect();
        let columns = df
            .get_column_names()
            .iter()
            .map(|s| s.to_string())
            .filter(|n| n.starts_with("alpha_") || n.starts_with("r_"))
            .map(|name| -> Result<(String, Vec<Option<f64>>)> {
                let v = df
                    .column(&name)?
                    .cast(&DataType::Float64)?
                    .f64()?
                    .iter()
                    .collect();
                Ok((name, v))
            })
            .collect::<Result<_>>()?;
        Ok(Some(Params {
            rows,
            cells,
            columns,
        }))
    }

    /// The jobs with rows.
    pub(super) fn jobs(&self) -> BTreeSet<String> {
        self.rows.keys().cloned().collect()
    }

    /// Filter parameter maps of a Method 1 or 2 job (Figs. 25-27, 34-36).
    fn figures(&self, dir: &Path, job: &str) -> Option<Task> {
        let rows = self.rows.get(job)?;
        let h = rows.iter().map(|&i| self.cells[i].0).max().unwrap_or(0) as usize + 1;
        let w = rows.iter().map(|&i| self.cells[i].1).max().unwrap_or(0) as usize + 1;
        let mut maps: Vec<(String, Array2<f64>)> = vec![];
        for (name, v) in &self.columns {
            if rows.iter().all(|&i| v[i].is_none()) {
                continue;
            }
            let mut m = Array2::from_elem((h, w), f64::NAN);
            for &i in rows {
                let (r, c) = self.cells[i];
                m[[r as usize, c as usize]] = v[i].unwrap_or(f64::NAN);
            }
            maps.push((name.clone(), m));
        }
        if maps.is_empty() {
            return None;
        }
        // Horizontal parameters on the first row, vertical on the second.
        let (hz, vt): (Vec<_>, Vec<_>) = maps.into_iter().partition(|(n, _)| n.contains("_h"));
        let m = abs_max(hz.iter().chain(&vt).map(|(_, m)| m));
        let data = vec![results::SYNTHESIS_PARAMS.path(dir)];
        Some(grid(
            dir,
            job,
            "filter_parameters",
            format!("{job}: fitted filter parameters per level-1 cell (horizontal, vertical)"),
            vec![hz, vt].into_iter().filter(|r| !r.is_empty()).collect(),
            Scale::Diverging { lo: -m, hi: m },
            "parameter",
            data,
        ))
    }
}
