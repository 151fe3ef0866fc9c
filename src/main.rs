//! The `isar-clutter` command line: `run` an experiment spec, `validate` it, or print its job
//! table with `run --dry-run`. Errors print their cause chain; a run with failed jobs exits 1.

use anyhow::Result;
use clap::{Parser, Subcommand};
use isar_clutter::plan::{self, Plan};
use isar_clutter::runner::{self, RunOptions};
use std::path::PathBuf;
use std::process::ExitCode;

/// Multiscale modelling and simulation of ISAR clutter: declarative batch experiments.
#[derive(Parser)]
#[command(name = "isar-clutter", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run every job of a spec and write the results to outputs/<name>/ (or --out).
    Run {
        /// The experiment spec (YAML).
        spec: PathBuf,
        /// Output folder (default: outputs/<name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads (default: all cores). Results do not depend on it.
        #[arg(long)]
        jobs: Option<usize>,
        /// Print the job table and exit without running anything.
        #[arg(long)]
        dry_run: bool,
        /// No progress output.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Check a spec (syntax, types, files, sizes) without running it.
    Validate {
        /// The experiment spec (YAML).
        spec: PathBuf,
    },
}

fn main() -> ExitCode {
    match real_main() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn real_main() -> Result<ExitCode> {
    match Cli::parse().command {
        Command::Validate { spec } => {
            let plan = plan::load(&spec)?;
            println!("{}: valid, {} job(s)", spec.display(), plan.jobs.len());
            Ok(ExitCode::SUCCESS)
        }
        Command::Run {
            spec,
            out,
            jobs,
            dry_run,
            quiet,
        } => {
            let plan = plan::load(&spec)?;
            if dry_run {
                print_jobs(&plan);
                return Ok(ExitCode::SUCCESS);
            }
            let out = out.unwrap_or_else(|| PathBuf::from("outputs").join(&plan.spec.name));
            let mut opts = RunOptions::new(out, jobs.unwrap_or_else(runner::default_threads));
            opts.quiet = quiet;
            let summary = runner::run(&plan, &opts)?;
            let ok = summary.total - summary.failed.len();
            eprintln!(
                "{}: {ok}/{} job(s) ok in {:.2} s -> {}",
                plan.spec.name,
                summary.total,
                summary.elapsed_s,
                summary.out.display()
            );
            for (job, err) in &summary.failed {
                eprintln!("  failed: {job}: {err}");
            }
            Ok(if summary.failed.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            })
        }
    }
}

/// Prints the job table of `--dry-run`.
fn print_jobs(plan: &Plan) {
    let rows: Vec<[String; 7]> = plan
        .jobs
        .iter()
        .map(|j| {
            let (n, h, w) = j.dataset.shape();
            [
                j.id.clone(),
                j.dataset.kind().to_string(),
                format!("{n}x{h}x{w}"),
                j.analysis.levels.to_string(),
                j.seed.to_string(),
                j.data_seed.to_string(),
                serde_json::to_string(&j.params).unwrap_or_default(),
            ]
        })
        .collect();
    let head = [
        "job",
        "kind",
        "NxHxW",
        "levels",
        "seed",
        "data_seed",
        "params",
    ];
    let width: Vec<usize> = (0..7)
        .map(|c| {
            rows.iter()
                .map(|r| r[c].len())
                .chain([head[c].len()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |cells: [&str; 7]| {
        let s: Vec<String> = cells
            .iter()
            .zip(&width)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        println!("{}", s.join("  ").trim_end());
    };
    line(head);
    for r in &rows {
        line([&r[0], &r[1], &r[2], &r[3], &r[4], &r[5], &r[6]]);
    }
    println!("{} job(s), master seed {}", plan.jobs.len(), plan.spec.seed);
}
