//! The commands that read finished results or write the reproduction: `report`, `table`,
//! `reproduce` and `calibrate-plants`, each a function of its arguments.

use super::args::{CalibratePlantsArgs, ReportArgs, ReproduceArgs, TableArgs};
use super::pool;
use anyhow::Result;
use isar_clutter::run::options;
use std::process::ExitCode;

/// `table`: the standard comparison tables (or one) of a results folder.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn table(a: TableArgs) -> Result<ExitCode> {
    let TableArgs {
        results,
        table,
        format,
        pivot,
        filter,
        allow_incomplete,
    } = a;
    if !allow_incomplete {
        isar_clutter::io::outdir::check_complete(&results)?;
    }
    table_command(
        &results,
        table.as_deref(),
        format.into(),
        pivot.as_deref(),
        &filter,
    )?;
    Ok(ExitCode::SUCCESS)
}

/// `calibrate-plants`: the stand-in plants fitted to Table 16 (A-C) and Tables 29-36 (D-E),
/// written as the fit record.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn calibrate_plants(a: CalibratePlantsArgs) -> Result<ExitCode> {
    use isar_clutter::reproduction::calibrate::{calibrate_plants, Part};
    let CalibratePlantsArgs {
        samples,
        seed,
        seeds,
        part,
        kl,
        out,
    } = a;
    let part = match part.as_str() {
        "variance" => Part::Variance,
        "similarity" => Part::Similarity,
        _ => Part::All,
    };
    calibrate_plants(samples, (seed, seeds), part, kl, &out)?;
    Ok(ExitCode::SUCCESS)
}

/// `reproduce`: the specs the dissertation's tables need, then the reproduction document.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn reproduce(a: ReproduceArgs) -> Result<ExitCode> {
    let ReproduceArgs {
        out,
        specs,
        doc,
        repeats,
        cnn_repeats,
        jobs,
        write_only,
        only,
        quiet,
        device,
    } = a;
    use isar_clutter::reproduction::{self as rep, render, runs};
    let opts = runs::Options {
        out,
        specs,
        repeats,
        cnn_repeats,
        threads: jobs.unwrap_or_else(options::default_threads),
        write_only,
        only: only.clone(),
        quiet,
        device,
    };
    let start = std::time::Instant::now();
    let coverage = runs::Coverage::all();
    let runs = runs::run_all(&opts, &coverage)?;
    if !only.is_empty() {
        eprintln!(
            "ran {} in {:.1} s; no document written (run without --only, or with --write-only)",
            only.join(", "),
            start.elapsed().as_secs_f64()
        );
        return Ok(ExitCode::SUCCESS);
    }
    if !write_only {
        runs::record_wall(&opts.out, start.elapsed().as_secs_f64(), repeats)?;
    }
    let header = render::Header {
        command: match cnn_repeats {
            Some(c) => format!("isar-clutter reproduce --repeats {repeats} --cnn-repeats {c}"),
            None => format!("isar-clutter reproduce --repeats {repeats}"),
        },
        wall_s: runs::recorded_wall(&opts.out),
        machine: render::machine(),
        tool: format!(
            "isar-clutter {} (commit {})",
            env!("CARGO_PKG_VERSION"),
            isar_clutter::run::manifest::build_commit()
        ),
        repeats,
        cnn_repeats,
        builds: vec![],
        plant_records: vec![],
        missing: vec![],
        job_time: vec![],
    };
    let (counts, missing) = rep::write(&coverage, &runs, &doc, &header)?;
    for m in &missing {
        eprintln!(
            "warning: {}: {}: the document names it; its cells and claims use the other repeats",
            m.dir.display(),
            m.why
        );
    }
    let n = |v| counts.get(&v).copied().unwrap_or(0);
    eprintln!(
        "{}: {} cells match, {} differ",
        doc.display(),
        n(rep::compare::Verdict::Matches),
        n(rep::compare::Verdict::Differs)
    );
    Ok(ExitCode::SUCCESS)
}

/// `report`: figures/ and report.html of a results folder.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn report(a: ReportArgs) -> Result<ExitCode> {
    let ReportArgs {
        results,
        jobs,
        allow_incomplete,
        figures_for,
    } = a;
    let t = std::time::Instant::now();
    let options = isar_clutter::report::select::Options { figures_for };
    let report = pool(jobs)?
        .install(|| isar_clutter::report::build_with(&results, allow_incomplete, &options))?;
    let selection = &report.selection;
    eprintln!(
        "{} ({} figures{}, {:.2} s)",
        report.html.display(),
        report.figures.len(),
        if selection.limited {
            format!(
                "; per-job figures for {} of {} jobs",
                selection.jobs.len(),
                selection.candidates
            )
        } else {
            String::new()
        },
        t.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// Prints the standard tables (or one) of a results folder.
fn table_command(
    results: &std::path::Path,
    name: Option<&str>,
    format: isar_clutter::report::table::Format,
    pivot: Option<&str>,
    filters: &[(String, Vec<String>)],
) -> Result<()> {
    use isar_clutter::report::catalog::{names, render_named};
    if !results.is_dir() {
        anyhow::bail!("{} is not a results folder", results.display());
    }
    let chosen: Vec<&str> = match name {
        None => names(),
        Some(n) => vec![n],
    };
    let mut printed = 0;
    for table in chosen {
        if let Some(text) = render_named(results, table, filters, pivot, format, name.is_some())? {
            if printed > 0 {
                println!();
            }
            print!("{text}");
            printed += 1;
        }
    }
    if printed == 0 {
        anyhow::bail!(
            "no table of {} has rows{}",
            results.display(),
            if filters.is_empty() && pivot.is_none() {
                ""
            } else {
                " with these filters and pivot (name one with --table to see why)"
            }
        );
    }
    Ok(())
}
