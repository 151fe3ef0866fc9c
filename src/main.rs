//! The `isar-clutter` command line: `run` an experiment spec, `validate` it, or print its job
//! table with `run --dry-run`. Errors print their cause chain; a run with failed jobs exits 1.

/// Large blocks come straight from the kernel (see [`isar_clutter::alloc`]).
#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
mod cli;
use cli::models::{fit_command, generate_command, mat_output, Generation, Input};
use isar_clutter::run::estimate;
use isar_clutter::run::plan::{self, Plan};
use isar_clutter::run::scheduler::{self, RunOptions};
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
        /// Worker threads (default: RAYON_NUM_THREADS, else all cores). Results do not
        /// depend on it.
        #[arg(long)]
        jobs: Option<usize>,
        /// Print the job table and exit without running anything.
        #[arg(long)]
        dry_run: bool,
        /// No progress output.
        #[arg(long, short)]
        quiet: bool,
        /// Do not build figures/ and report.html at the end. An earlier report in the folder
        /// goes with the run's other stale files (it would not follow the new tables);
        /// `isar-clutter report DIR` builds it again.
        #[arg(long)]
        no_report: bool,
        /// Redo every job, even those whose result the job store (OUT/jobs/) already holds.
        #[arg(long)]
        fresh: bool,
        /// Split the jobs into N shards (balanced by estimated work) and run one of them:
        /// `--shard I`, or SLURM_ARRAY_TASK_ID / JOB_COMPLETION_INDEX when omitted. A shard
        /// writes only into the job store; `merge OUT` assembles the tables.
        #[arg(long, value_name = "N")]
        shards: Option<usize>,
        /// The shard to run, 0 <= I < N (with --shards).
        #[arg(long, value_name = "I", requires = "shards")]
        shard: Option<usize>,
        /// Refuse a job whose estimated peak memory exceeds SIZE (bytes, or e.g. 512M, 8G;
        /// default: the machine's memory).
        #[arg(long, value_name = "SIZE", value_parser = isar_clutter::run::estimate::parse_size)]
        max_memory: Option<u64>,
        /// Master seed in place of the spec's `seed`: the same experiment with other random
        /// numbers (a repeat). Recorded in the folder; `merge`, `status` and `report` use it.
        #[arg(long, value_name = "N")]
        seed: Option<u64>,
    },
    /// Reproduce the dissertation's tables: run the specs they need (each random statistic
    /// repeated with other master seeds) into OUT/<spec>/seed-<seed>/, resuming what the job
    /// store holds, and write DOC from those folders: every table's cells, printed beside the
    /// tool's mean and spread, with a verdict.
    Reproduce {
        /// Where the runs go.
        #[arg(long, default_value = "outputs/reproduction")]
        out: PathBuf,
        /// The folder of the specs.
        #[arg(long, default_value = "experiments")]
        specs: PathBuf,
        /// The document to write.
        #[arg(long, default_value = "docs/reproduction.md")]
        doc: PathBuf,
        /// Runs of each spec with random statistics (the first with the spec's own seed).
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Worker threads of each run (default: RAYON_NUM_THREADS, else all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Write the document from the folders in OUT without running anything.
        #[arg(long)]
        write_only: bool,
        /// No progress output.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Fit the stand-in plants' amplitude and wind-response factors to the dissertation's
    /// Table 16 and write the fit record that the presets use (rebuild to apply it).
    CalibratePlants {
        /// Samples per simulation.
        #[arg(long, default_value_t = 100)]
        samples: usize,
        /// Seed of the simulations.
        #[arg(long, default_value_t = 16)]
        seed: u64,
        /// The record to write.
        #[arg(long, default_value = "reproduction/plant_calibration.json")]
        out: PathBuf,
    },
    /// (Re)build figures/ and report.html of a results folder from its files.
    Report {
        /// The results folder of a run (outputs/<name>).
        results: PathBuf,
        /// Worker threads (default: RAYON_NUM_THREADS, else all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Read a folder whose run is in progress, was interrupted, or whose files changed
        /// since its manifest (refused otherwise).
        #[arg(long)]
        allow_incomplete: bool,
        /// Per-job figures for at most N jobs (spread evenly over the plan order, the first
        /// and the last included), or `all`; a run with at most N jobs with figures gets them
        /// for every job.
        #[arg(long, value_name = "N|all", default_value_t)]
        figures_for: isar_clutter::report::select::FiguresFor,
    },
    /// Print comparison tables (methods side by side) from a results folder's Parquet files.
    Table {
        /// The results folder of a run (outputs/<name>).
        results: PathBuf,
        /// One table: rmse, cmd, kl, model_order, hypotheses, calibration, summary,
        /// classification, classification_detail or location (default: every table with rows).
        #[arg(long)]
        table: Option<String>,
        /// text (aligned columns) or md (Markdown).
        #[arg(long, value_enum, default_value = "text")]
        format: isar_clutter::report::table::Format,
        /// Column spread across the page (default: method; model_order for model_order;
        /// source for summary), e.g. `--pivot dataset`.
        #[arg(long)]
        pivot: Option<String>,
        /// Keep rows whose column has one of the values: `--filter dataset=exp,dyadic`
        /// (repeatable).
        #[arg(long, value_parser = isar_clutter::report::table::parse_filter)]
        filter: Vec<(String, Vec<String>)>,
        /// Read a folder whose run is in progress, was interrupted, or whose files changed
        /// since its manifest (refused otherwise).
        #[arg(long)]
        allow_incomplete: bool,
    },
    /// Assemble the tables, the manifest and the report of a folder from its job store (after
    /// every shard of `run --shards N` finished).
    Merge {
        /// The output folder the shards wrote into.
        results: PathBuf,
        /// Merge even when jobs are missing (they are listed as failed; the folder stays
        /// marked incomplete).
        #[arg(long)]
        partial: bool,
        /// Do not build figures/ and report.html.
        #[arg(long)]
        no_report: bool,
        /// Worker threads (default: RAYON_NUM_THREADS, else all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// No progress output.
        #[arg(long, short)]
        quiet: bool,
    },
    /// List the jobs of an output folder: done, failed or missing, per shard.
    Status {
        /// The output folder.
        results: PathBuf,
    },
    /// Check a spec (syntax, types, files, sizes) without running it.
    Validate {
        /// The experiment spec (YAML).
        spec: PathBuf,
        /// Refuse a job whose estimated peak memory exceeds SIZE (bytes, or e.g. 512M, 8G;
        /// default: the machine's memory).
        #[arg(long, value_name = "SIZE", value_parser = isar_clutter::run::estimate::parse_size)]
        max_memory: Option<u64>,
    },
    /// Write (and with --submit, submit) Slurm scripts running a spec in shards: an array job
    /// (`run --shards N`, one task per shard) and a merge job after it (`merge OUT`).
    Slurm {
        /// The experiment spec (YAML).
        spec: PathBuf,
        /// Number of shards: array tasks, each running its share of the jobs.
        #[arg(long)]
        shards: usize,
        /// Output folder (default: outputs/<name>); the scripts go to OUT/slurm/.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Slurm partition of both jobs.
        #[arg(long)]
        partition: Option<String>,
        /// Time limit of each job (sbatch --time, e.g. 2:00:00).
        #[arg(long)]
        time: Option<String>,
        /// CPUs per array task (and the worker threads of each shard).
        #[arg(long, default_value_t = 1)]
        cpus: usize,
        /// Memory of each job (sbatch --mem, e.g. 8G).
        #[arg(long)]
        mem: Option<String>,
        /// Submit both jobs with sbatch (the merge job with --dependency=afterok).
        #[arg(long)]
        submit: bool,
    },
    /// Fit a synthesis model to a stack and save it as a model folder.
    Fit {
        /// The stack: .npy of complex64, complex128 or real values, [N, H, W]; or a MATLAB
        /// .mat file (v5, or v7.3 in a build with the mat73 feature) holding a numeric 3-D
        /// array, H x W x N.
        #[arg(long)]
        input: PathBuf,
        /// .mat input: the variable to read (default: the file's only numeric 3-D array).
        #[arg(long, value_name = "NAME")]
        var: Option<String>,
        /// Axis order of the input: nhw or hwn (default: nhw for .npy, hwn, MATLAB's
        /// H x W x N, for .mat).
        #[arg(long)]
        layout: Option<String>,
        /// method1, method2, full_covariance, uncorrelated or fourth_order.
        #[arg(long)]
        method: String,
        /// The model folder to write.
        #[arg(long)]
        out: PathBuf,
        /// Filter half-width K of Methods 1 and 2.
        #[arg(long, default_value_t = 8)]
        half_width: usize,
        /// Dyadic parameters L of Method 2.
        #[arg(long, default_value_t = 3)]
        levels: usize,
        /// Method 1's signs of a negative correlation's filter: multiscale (dissertation
        /// §4.2.4) or alternating.
        #[arg(long, default_value = "multiscale")]
        negative_signs: String,
        /// Worker threads (default: RAYON_NUM_THREADS, else all cores).
        #[arg(long)]
        jobs: Option<usize>,
    },
    /// Generate samples from a model folder into a [M, H, W] complex64 .npy, or a MATLAB .mat
    /// holding an H x W x M single complex array, in constant memory.
    Generate {
        /// The model folder (from `fit` or a run's models/<job>).
        #[arg(long)]
        model: PathBuf,
        /// Number of samples M.
        #[arg(long)]
        samples: usize,
        /// Seed of the generation (sample s draws from stream s of the seed).
        #[arg(long)]
        seed: u64,
        /// How samples are drawn from the seed: 2 (ChaCha8 and f32, the format of models fitted
        /// by this version) or 1 (ChaCha20 and f64, earlier models). Default: the model's.
        #[arg(long, value_name = "FORMAT", value_parser = clap::value_parser!(u32).range(1..=2))]
        sample_format: Option<u32>,
        /// The .npy or .mat (by its extension) to write. A .npy gets NAME.npy.json beside
        /// it: the model, seed and sample format that write it again. An existing file is
        /// replaced only if the tool wrote it and it holds nothing the tool did not write.
        #[arg(long)]
        out: PathBuf,
        /// .mat output: the MAT version, 7.3 (default: HDF5, any size; needs the mat73
        /// feature) or 5 (at most 2 GB).
        #[arg(long, value_name = "VERSION", value_parser = ["7.3", "5"])]
        mat_version: Option<String>,
        /// .mat output: the class of the values (default single).
        #[arg(long, value_enum, value_name = "CLASS")]
        mat_class: Option<isar_clutter::io::mat::MatClass>,
        /// .mat output: the name of the variable (default samples).
        #[arg(long, value_name = "NAME")]
        var: Option<String>,
        /// Samples generated per block (memory: two blocks, one generated while the other is
        /// written).
        #[arg(long, default_value_t = 256)]
        chunk: usize,
        /// .npy output: write through the page cache instead of with direct I/O (O_DIRECT,
        /// used where the file system allows it: the bytes go to the disk without a copy).
        #[arg(long)]
        buffered: bool,
        /// Worker threads (default: RAYON_NUM_THREADS, else all cores). The file does not
        /// depend on it.
        #[arg(long)]
        jobs: Option<usize>,
    },
}

fn main() -> ExitCode {
    isar_clutter::alloc::tune_malloc();
    // A closed stdout (`isar-clutter validate SPEC | head -1`) ends the process quietly, as it
    // does other Unix tools, instead of a panic in `println!` (Rust ignores SIGPIPE).
    #[cfg(unix)]
    // SAFETY: restores the default disposition of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    match real_main() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", isar_clutter::error_text(&e));
            ExitCode::from(2)
        }
    }
}

fn real_main() -> Result<ExitCode> {
    match Cli::parse().command {
        Command::Table {
            results,
            table,
            format,
            pivot,
            filter,
            allow_incomplete,
        } => {
            if !allow_incomplete {
                isar_clutter::io::outdir::check_complete(&results)?;
            }
            table_command(
                &results,
                table.as_deref(),
                format,
                pivot.as_deref(),
                &filter,
            )?;
            Ok(ExitCode::SUCCESS)
        }
        Command::CalibratePlants { samples, seed, out } => {
            isar_clutter::reproduction::calibrate_plants(samples, seed, &out)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Reproduce {
            out,
            specs,
            doc,
            repeats,
            jobs,
            write_only,
            quiet,
        } => {
            use isar_clutter::reproduction::{self as rep, render};
            let opts = rep::Options {
                out,
                specs,
                repeats,
                threads: jobs.unwrap_or_else(scheduler::default_threads),
                write_only,
                quiet,
            };
            let start = std::time::Instant::now();
            let coverage = rep::Coverage::all();
            let runs = rep::run_all(&opts, &coverage)?;
            if !write_only {
                rep::record_wall(&opts.out, start.elapsed().as_secs_f64(), repeats)?;
            }
            let header = render::Header {
                command: format!("isar-clutter reproduce --repeats {repeats}"),
                wall_s: rep::recorded_wall(&opts.out),
                machine: render::machine(),
                tool: format!(
                    "isar-clutter {} (commit {})",
                    env!("CARGO_PKG_VERSION"),
                    isar_clutter::run::manifest::build_commit()
                ),
                repeats,
                builds: vec![],
            };
            let counts = rep::write(&coverage, &runs, &doc, &header)?;
            let n = |v| counts.get(&v).copied().unwrap_or(0);
            eprintln!(
                "{}: {} matches, {} ordering holds, {} differs",
                doc.display(),
                n(rep::compare::Verdict::Matches),
                n(rep::compare::Verdict::OrderingHolds),
                n(rep::compare::Verdict::Differs)
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Report {
            results,
            jobs,
            allow_incomplete,
            figures_for,
        } => {
            let t = std::time::Instant::now();
            let options = isar_clutter::report::select::Options { figures_for };
            let report = pool(jobs)?.install(|| {
                isar_clutter::report::build_with(&results, allow_incomplete, &options)
            })?;
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
        Command::Merge {
            results,
            partial,
            no_report,
            jobs,
            quiet,
        } => {
            let mut opts = RunOptions::new(
                results.clone(),
                jobs.unwrap_or_else(scheduler::default_threads),
            );
            opts.quiet = quiet;
            opts.report_follows = !no_report;
            let merged = pool(jobs)?
                .install(|| isar_clutter::run::merge::merge(&results, &opts, partial))?;
            for note in &merged.notes {
                eprintln!("note: {note}");
            }
            for (job, err) in &merged.failed {
                eprintln!("  failed: {job}: {err}");
            }
            eprintln!(
                "merged {} ({} failed, {} missing)",
                results.display(),
                merged.failed.len() - merged.missing.len(),
                merged.missing.len()
            );
            if !no_report {
                pool(jobs)?
                    .install(|| isar_clutter::report::build(&results, !merged.missing.is_empty()))
                    .context("building the report (the tables are written; retry with `isar-clutter report`)")?;
            }
            Ok(if merged.failed.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            })
        }
        Command::Status { results } => {
            print!("{}", isar_clutter::run::merge::status(&results)?);
            Ok(ExitCode::SUCCESS)
        }
        Command::Validate { spec, max_memory } => {
            let plan = plan::load(&spec)?;
            let largest = isar_clutter::run::check::check(&plan, estimate::limit(max_memory))?;
            let all = isar_clutter::run::jobs::all::AllJobs::new(&plan)
                .list()
                .len();
            println!("{}: valid, {all} job(s)", spec.display());
            println!("{largest}");
            println!("{}", estimate::footprint(&plan, all));
            Ok(ExitCode::SUCCESS)
        }
        Command::Slurm {
            spec,
            shards,
            out,
            partition,
            time,
            cpus,
            mem,
            submit,
        } => {
            use isar_clutter::run::slurm;
            let out = match out {
                Some(out) => out,
                None => PathBuf::from("outputs").join(&plan::load(&spec)?.spec.name),
            };
            let mut opts = slurm::SlurmOptions::new(spec, out, shards)?;
            (opts.partition, opts.time, opts.cpus, opts.mem) = (partition, time, cpus, mem);
            let scripts = slurm::write_scripts(&opts)?;
            println!("{}\n{}", scripts.array.display(), scripts.merge.display());
            if scripts.shards > scripts.jobs {
                eprintln!(
                    "note: {} shards for {} job(s): some shards have nothing to do",
                    scripts.shards, scripts.jobs
                );
            }
            if submit {
                let (array, merge) = slurm::submit(&scripts)?;
                println!(
                    "submitted array job {array} ({} shards) and merge job {merge} (afterok)",
                    scripts.shards
                );
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Fit {
            input,
            var,
            layout,
            method,
            out,
            half_width,
            levels,
            negative_signs,
            jobs,
        } => {
            let input = Input {
                path: &input,
                var: var.as_deref(),
                layout: layout.as_deref(),
            };
            pool(jobs)?.install(|| {
                fit_command(&input, &method, &out, half_width, levels, &negative_signs)
            })?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Generate {
            model,
            samples,
            seed,
            out,
            chunk,
            jobs,
            mat_version,
            mat_class,
            var,
            sample_format,
            buffered,
        } => {
            let mat = mat_output(&out, mat_version.as_deref(), mat_class, var)?;
            let run = Generation {
                seed,
                samples,
                chunk,
                sample_format,
                buffered,
            };
            generate_command(&model, &out, mat.as_ref(), &run, jobs)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Run {
            spec,
            out,
            jobs,
            dry_run,
            quiet,
            no_report,
            max_memory,
            fresh,
            shards,
            shard,
            seed,
        } => {
            let plan = plan::load_seeded(&spec, seed)?;
            if dry_run {
                let largest = isar_clutter::run::check::check(&plan, estimate::limit(max_memory))?;
                print_jobs(&plan);
                println!("{largest}");
                return Ok(ExitCode::SUCCESS);
            }
            let out = out.unwrap_or_else(|| PathBuf::from("outputs").join(&plan.spec.name));
            let mut opts = RunOptions::new(out, jobs.unwrap_or_else(scheduler::default_threads));
            opts.quiet = quiet;
            opts.max_memory = max_memory;
            opts.fresh = fresh;
            opts.shard = shard_option(shards, shard)?;
            opts.report_follows = !no_report && opts.shard.is_none();
            let summary = isar_clutter::run::driver::run(&plan, &opts)?;
            for note in &summary.notes {
                eprintln!("note: {note}");
            }
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
            if let Some((i, n)) = opts.shard {
                eprintln!(
                    "shard {i}/{n}: when every shard is done, `isar-clutter merge {}`",
                    summary.out.display()
                );
            } else if !no_report {
                let t = std::time::Instant::now();
                // Under the run's claim: the folder was complete a moment ago and is still locked.
                let report = pool(jobs)?
                    .install(|| match &summary.claim {
                        Some(claim) => isar_clutter::report::build_claimed(claim),
                        None => isar_clutter::report::build(&summary.out, false),
                    })
                    .context("building the report (the results are written; retry with `isar-clutter report`)")?;
                if !quiet {
                    eprintln!(
                        "report: {} ({} figures, {:.2} s)",
                        report.html.display(),
                        report.figures.len(),
                        t.elapsed().as_secs_f64()
                    );
                }
            }
            Ok(if summary.failed.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            })
        }
    }
}

/// The shard of `run --shards N [--shard I]`: `I` from the flag, else from
/// `SLURM_ARRAY_TASK_ID` or `JOB_COMPLETION_INDEX` (Kubernetes indexed jobs).
fn shard_option(shards: Option<usize>, shard: Option<usize>) -> Result<Option<(usize, usize)>> {
    let Some(n) = shards else { return Ok(None) };
    if n == 0 {
        anyhow::bail!("--shards must be at least 1");
    }
    let i = match shard {
        Some(i) => i,
        None => {
            let (var, value) = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"]
                .iter()
                .find_map(|v| std::env::var(v).ok().map(|x| (*v, x)))
                .with_context(|| {
                    "--shards without --shard: set --shard I, or run as a Slurm array task \
                     (SLURM_ARRAY_TASK_ID) or a Kubernetes indexed job (JOB_COMPLETION_INDEX)"
                })?;
            value
                .trim()
                .parse()
                .with_context(|| format!("{var}={value:?} is not a shard index"))?
        }
    };
    if i >= n {
        anyhow::bail!("--shard {i} is not below --shards {n} (shards are 0..{n})");
    }
    Ok(Some((i, n)))
}

/// A rayon pool of `jobs` threads (default: all cores).
fn pool(jobs: Option<usize>) -> Result<rayon::ThreadPool> {
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or_else(scheduler::default_threads))
        .build()?)
}

/// Prints the job table of `--dry-run`.
fn print_jobs(plan: &Plan) {
    let mut rows: Vec<[String; 7]> = plan
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
    // The jobs of the run as a whole (calibration, hypotheses, CNN trainings).
    let all = isar_clutter::run::jobs::all::AllJobs::new(plan);
    for j in all.list().into_iter().skip(plan.jobs.len()) {
        rows.push([
            j.id().to_string(),
            j.kind().to_string(),
            "-".into(),
            "-".into(),
            j.seed().map_or("-".into(), |s| s.to_string()),
            "-".into(),
            j.manifest().to_string(),
        ]);
    }
    let total = rows.len();
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
    println!("{total} job(s), master seed {}", plan.spec.seed);
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
