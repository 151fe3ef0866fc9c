//! The `isar-clutter` command line: `run` an experiment spec, `validate` it, or print its job
//! table with `run --dry-run`. Errors print their cause chain; a run with failed jobs exits 1.

/// Large blocks come straight from the kernel (see [`isar_clutter::alloc`]).
#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
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
        Command::Report {
            results,
            jobs,
            allow_incomplete,
        } => {
            let t = std::time::Instant::now();
            let report =
                pool(jobs)?.install(|| isar_clutter::report::build(&results, allow_incomplete))?;
            eprintln!(
                "{} ({} figures, {:.2} s)",
                report.html.display(),
                report.figures.len(),
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
            let largest = estimate::check(&plan, estimate::limit(max_memory))?;
            let all = isar_clutter::run::jobs::all::AllJobs::new(&plan)
                .list()
                .len();
            println!("{}: valid, {all} job(s)", spec.display());
            println!("{largest}");
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
            jobs,
        } => {
            let input = Input {
                path: &input,
                var: var.as_deref(),
                layout: layout.as_deref(),
            };
            pool(jobs)?.install(|| fit_command(&input, &method, &out, half_width, levels))?;
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
        } => {
            let plan = plan::load(&spec)?;
            if dry_run {
                let largest = estimate::check(&plan, estimate::limit(max_memory))?;
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

/// The seed, number, block size and sample format of a `generate`.
struct Generation {
    seed: u64,
    samples: usize,
    chunk: usize,
    /// `--sample-format`, overriding the model's.
    sample_format: Option<u32>,
    /// `--buffered`: write the `.npy` through the page cache, not with direct I/O.
    buffered: bool,
}

/// `generate`: check the output (a `.npy`, or the `.mat` `mat` describes), load the model,
/// stream the samples into the file.
fn generate_command(
    model: &std::path::Path,
    out: &std::path::Path,
    mat: Option<&isar_clutter::io::mat::MatOutput>,
    run: &Generation,
    jobs: Option<usize>,
) -> Result<()> {
    // Held until the samples are in place: a second `generate` into `out` is refused.
    let _lock = isar_clutter::io::outdir::lock_output(out, "generate")?;
    match mat {
        Some(_) => isar_clutter::io::mat::write::check_replaceable(out)?,
        None => {
            use isar_clutter::io::model::{is_generated_npy, is_generation_record, record_path};
            isar_clutter::io::outdir::check_file_output(out, "samples .npy", is_generated_npy)?;
            isar_clutter::io::outdir::check_file_output(
                &record_path(out),
                "generation record",
                is_generation_record,
            )?;
        }
    }
    clear_dead_temporaries(out)?;
    let (mut m, _) = isar_clutter::io::model::load(model)?;
    if let Some(format) = run.sample_format {
        m.sample_format = format;
    }
    if let Some(mat) = mat {
        let (h, w) = m.shape();
        isar_clutter::io::mat::write::check_output(mat, (h, w, run.samples))
            .with_context(|| format!("{} was not written", out.display()))?;
    }
    let record =
        isar_clutter::io::model::GenerationRecord::new(model, &m, run.seed, run.samples, out);
    let bar = indicatif::ProgressBar::new(run.samples as u64);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let t = std::time::Instant::now();
    let progress = |done: usize| bar.set_position(done as u64);
    pool(jobs)?.install(|| match mat {
        Some(mat) => isar_clutter::io::model::generate_to_mat(
            &m,
            run.seed,
            run.samples,
            run.chunk,
            out,
            mat,
            progress,
        ),
        None => isar_clutter::io::model::generate_to_npy(
            &m,
            run.seed,
            (run.samples, run.chunk),
            out,
            if run.buffered {
                isar_clutter::io::stream::WriteMode::Buffered
            } else {
                isar_clutter::io::stream::WriteMode::Direct
            },
            progress,
        )
        .and_then(|_| isar_clutter::io::model::write_generation_record(out, &record)),
    })?;
    bar.finish_and_clear();
    let s = t.elapsed().as_secs_f64();
    let again = match mat {
        Some(_) => String::new(),
        None => format!(
            " (how to write it again: {})",
            isar_clutter::io::model::record_path(out).display()
        ),
    };
    eprintln!(
        "{} sample(s) (format {}) -> {}{again} in {s:.2} s ({:.0} samples/s)",
        run.samples,
        m.sample_format,
        out.display(),
        run.samples as f64 / s
    );
    Ok(())
}

/// The stack `fit` reads: a `.npy`, or a `.mat` variable; `layout` as given.
struct Input<'a> {
    path: &'a std::path::Path,
    var: Option<&'a str>,
    layout: Option<&'a str>,
}

impl Input<'_> {
    /// The stack, whether its axes are `[H, W, N]`, and its name for the model's `source`.
    fn load(&self) -> Result<(isar_clutter::io::npy::Stack, bool, String)> {
        use isar_clutter::io::mat::{is_mat_path, MatFile};
        let mat = is_mat_path(self.path);
        let hwn = match self.layout {
            None => mat,
            Some("nhw") => false,
            Some("hwn") => true,
            Some(other) => anyhow::bail!("unknown layout {other:?}: nhw or hwn"),
        };
        if !mat {
            if self.var.is_some() {
                anyhow::bail!(
                    "--var names a variable of a .mat input; {} is read as .npy",
                    self.path.display()
                );
            }
            let stack = isar_clutter::io::npy::Stack::load(self.path)?;
            return Ok((stack, hwn, self.path.display().to_string()));
        }
        let file = MatFile::open(self.path)?;
        let name = file.stack_variable(self.var)?.name.clone();
        let stack = isar_clutter::io::npy::Stack::Generated(file.read_stack(Some(&name))?);
        Ok((
            stack,
            hwn,
            format!("{} (variable {name})", self.path.display()),
        ))
    }
}

/// The `.mat` output `generate` writes, from `--out`'s extension and the `.mat` options
/// (`None`: a `.npy`, where no `.mat` option may be given).
fn mat_output(
    out: &std::path::Path,
    version: Option<&str>,
    class: Option<isar_clutter::io::mat::MatClass>,
    var: Option<String>,
) -> Result<Option<isar_clutter::io::mat::MatOutput>> {
    use isar_clutter::io::mat::{is_mat_path, MatClass, MatOutput, MatVersion};
    if !is_mat_path(out) {
        if version.is_some() || class.is_some() || var.is_some() {
            anyhow::bail!(
                "--mat-version, --mat-class and --var apply to a .mat output; {} is written as                  .npy",
                out.display()
            );
        }
        return Ok(None);
    }
    Ok(Some(MatOutput {
        version: match version {
            Some("5") => MatVersion::V5,
            _ => MatVersion::V73,
        },
        class: class.unwrap_or(MatClass::Single),
        variable: var.unwrap_or_else(|| "samples".into()),
    }))
}

/// `fit`: load, analyse, fit, save.
fn fit_command(
    input: &Input,
    method: &str,
    out: &std::path::Path,
    half_width: usize,
    levels: usize,
) -> Result<()> {
    use isar_clutter::synthesis::{fit, FitOptions, Method};
    // Held until the model folder is in place: a second `fit` into `out` is refused.
    let _lock = isar_clutter::io::outdir::lock_output(out, "fit")?;
    let method: Method =
        serde_json::from_value(serde_json::Value::String(method.into())).map_err(|_| {
            anyhow::anyhow!(
                "unknown method {method:?}: method1, method2, full_covariance, uncorrelated or fourth_order"
            )
        })?;
    let (stack, hwn, source) = input.load()?;
    let depth = if method == Method::Method2 { levels } else { 1 };
    let analysis = stack
        .analyse(hwn, depth)
        .with_context(|| format!("analysing {source}"))?;
    let full = matches!(method, Method::FullCovariance | Method::FourthOrder)
        .then(|| stack.to_complex128(hwn));
    let model = fit(
        method,
        &analysis,
        full.as_ref().map(|s| s.view()),
        FitOptions {
            half_width,
            levels: depth,
        },
    )
    .with_context(|| format!("fitting {} to {source}", method.as_str()))?;
    let info = isar_clutter::io::model::ModelInfo::new(
        &model,
        &analysis,
        half_width,
        depth,
        source.clone(),
    );
    save_model(&model, &info, out)?;
    eprintln!(
        "{} fitted to {source} ({} samples of {}x{}) -> {}",
        method.as_str(),
        info.samples_fitted,
        info.height,
        info.width,
        out.display()
    );
    Ok(())
}

/// Removes what killed writers of `out` left beside it (a `generate` or `fit` stopped by
/// `kill -9` or a crash), saying so on stderr.
fn clear_dead_temporaries(out: &std::path::Path) -> Result<()> {
    for name in isar_clutter::io::outdir::remove_dead_temporaries_of(out)? {
        eprintln!(
            "removed {name}: a killed writer of {} left it",
            out.display()
        );
    }
    Ok(())
}

/// Saves a model folder at `out`: refused if `out` is a file, or a folder that is neither
/// empty nor a model folder holding only model files; written into a temporary folder beside
/// it and swapped in whole, so an earlier model's files never mix with the new one's.
fn save_model(
    model: &isar_clutter::synthesis::Model,
    info: &isar_clutter::io::model::ModelInfo,
    out: &std::path::Path,
) -> Result<()> {
    if let Ok(m) = std::fs::symlink_metadata(out) {
        if !m.is_dir() {
            anyhow::bail!(
                "{} exists and is not a folder: --out names the model folder to write \
                 (nothing was changed)",
                out.display()
            );
        }
        let entries: Vec<_> = std::fs::read_dir(out)
            .with_context(|| format!("cannot read {}", out.display()))?
            .flatten()
            .collect();
        let foreign: Vec<String> = entries
            .iter()
            .filter(|e| {
                let name = e.file_name();
                !(e.path().is_file() && isar_clutter::io::model::FILES.iter().any(|f| name == **f))
            })
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        let is_model = out.join("model.json").is_file();
        if !entries.is_empty() && (!is_model || !foreign.is_empty()) {
            anyhow::bail!(
                "{} is not empty and is not a model folder the tool wrote ({}): choose a new \
                 or empty folder for --out (nothing was changed)",
                out.display(),
                if is_model {
                    format!("it also holds {}", foreign.join(", "))
                } else {
                    "no model.json".to_string()
                }
            );
        }
    }
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "model".into());
    clear_dead_temporaries(out)?;
    let tmp = out.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let saved = isar_clutter::io::model::save(model, info, &tmp)
        .and_then(|()| isar_clutter::io::atomic::swap_in_dir(&tmp, out));
    match saved {
        Ok(true) => {
            // `tmp` now holds the earlier model (model files only, checked above).
            std::fs::remove_dir_all(&tmp)
                .with_context(|| format!("removing the earlier model {}", tmp.display()))?;
            Ok(())
        }
        Ok(false) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            Err(e).with_context(|| format!("writing the model folder {}", out.display()))
        }
    }
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
