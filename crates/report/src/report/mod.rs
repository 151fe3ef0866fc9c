//! The report of a results folder: figures drawn from the run's `.npy` maps and Parquet tables
//! (under `figures/`), and `report.html`, one self-contained page (relative links only, no
//! network) with the summary tables, the run-wide figures (curves over the swept parameters,
//! calibration), the per-job figures with links to their SVG and to the files that hold their
//! numbers, the spec and the provenance from `manifest.json`. Per-job figures are drawn for
//! every job of a run up to [`select::DEFAULT_FIGURE_JOBS`] jobs with figures, and for a
//! bounded, evenly spread selection of a bigger one ([`select`]), so that the report of a big
//! sweep costs about as much as that of a small one. Everything is rebuilt from files, so
//! `isar-clutter report DIR` regenerates it without rerunning anything.

pub mod catalog;
pub mod cnn;
pub mod figures;
mod jobs;
mod page;
mod plants;
mod runwide;
pub mod select;
pub mod table;
pub mod task;

use crate::io::manifest::Manifest;
use anyhow::Result;
use page::page;
use rayon::prelude::*;
use select::{Options, Selection};
use std::path::{Path, PathBuf};
use task::{Figure, Task};

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
    /// The jobs with per-job figures.
    pub selection: Selection,
}

/// Builds `figures/` and `report.html` in the results folder `dir` with the default
/// [`Options`], and removes the figures an earlier report drew that this one does not (only
/// files the tool's records list: see [`crate::io::outdir`]). Figures whose inputs did not
/// change since the last report are kept as they are ([`figures::cache`]); the others are
/// drawn in parallel on the current rayon pool, with the same files whatever its size.
///
/// # Errors
/// If `dir` is not a complete run's folder (in progress, interrupted, or changed since its
/// manifest; accepted with `allow_incomplete`), is locked by a run, `manifest.json` is
/// unreadable, a table or map cannot be read, or a file cannot be written.
pub fn build(dir: &Path, allow_incomplete: bool) -> Result<Report> {
    build_with(dir, allow_incomplete, &Options::default())
}

/// [`build`] with `options`.
///
/// # Errors
/// As [`build`].
pub fn build_with(dir: &Path, allow_incomplete: bool, options: &Options) -> Result<Report> {
    use crate::io::outdir::{OutDir, Purpose};
    let outdir = OutDir::claim(dir, None, Purpose::Report { allow_incomplete })?;
    build_from(&outdir, options, allow_incomplete)
}

/// [`build`] in a folder this process has claimed already: a run's, right after its manifest
/// (the run holds the lock, and the folder is complete).
///
/// # Errors
/// As [`build`], but for the claim.
pub fn build_claimed(outdir: &crate::io::outdir::OutDir) -> Result<Report> {
    build_claimed_with(outdir, &Options::default())
}

/// [`build_claimed`] with `options`.
///
/// # Errors
/// As [`build_claimed`].
pub fn build_claimed_with(outdir: &crate::io::outdir::OutDir, options: &Options) -> Result<Report> {
    build_from(outdir, options, false)
}

/// The report of a claimed folder; with `allow_incomplete`, a `manifest.json` that cannot be
/// read (missing or damaged) does not stop it: the page says so and lacks the spec, the
/// provenance and the per-job figures, which the manifest lists.
fn build_from(
    outdir: &crate::io::outdir::OutDir,
    options: &Options,
    allow_incomplete: bool,
) -> Result<Report> {
    let dir = outdir.root();
    let (manifest, unreadable) = match Manifest::read(dir) {
        Ok(m) => (m, None),
        Err(e) if allow_incomplete => (Manifest::default(), Some(crate::error_text(&e))),
        Err(e) => return Err(e),
    };
    let cache = figures::cache::FigureCache::open(dir)?;
    let params = jobs::Params::load(dir)?;
    let with_params = params.as_ref().map(jobs::Params::jobs).unwrap_or_default();
    let candidates = select::candidates(dir, &manifest.ok_jobs(), &with_params);
    let selection = select::choose(&candidates, options.figures_for);
    // The run-wide figures first (the curves over the swept parameters, the calibration),
    // then the chosen jobs' figures in plan order.
    let mut tasks = runwide::sweep_figures(dir)?;
    tasks.extend(runwide::calibration_figures(dir)?);
    tasks.extend(plants::plant_figures(dir)?);
    let per_job: Vec<Vec<Task>> = selection
        .jobs
        .par_iter()
        .map(|job| jobs::job_figures(dir, job, params.as_ref()))
        .collect::<Result<_>>()?;
    tasks.extend(per_job.into_iter().flatten());
    // Every figure is a pure function of its loaded inputs and has files of its own: drawn in
    // any order on any number of threads, the files are the same.
    let mut figures: Vec<Figure> = tasks.into_par_iter().map(|t| t()).collect::<Result<_>>()?;
    let sections = cnn::sections(dir)?;
    let html = page(
        dir,
        (&manifest, unreadable.as_deref()),
        &selection,
        &figures,
        &sections,
    )?;
    figures.extend(sections.into_iter().flat_map(|s| s.figures));
    let path = dir.join("report.html");
    crate::io::atomic::atomic_write(&path, |w| {
        use std::io::Write;
        w.write_all(html.as_bytes())?;
        Ok(())
    })?;
    let summary = cache.finish()?;
    // Figures of jobs that are gone, failed or not chosen this time, of parameters no longer
    // swept (those found unchanged were not written by this claim, but are this report's).
    outdir.remove_stale(|p| {
        (p.starts_with("figures") && !summary.kept.contains(p)) || p == Path::new("report.html")
    })?;
    Ok(Report {
        html: path,
        figures,
        drawn: summary.drawn.into_iter().collect(),
        selection,
    })
}
