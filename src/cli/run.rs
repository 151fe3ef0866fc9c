//! The commands that run a spec and read its folder's progress: `run`, `merge`, `status`,
//! `validate` and `slurm`, each a function of its arguments.

use super::args::{MergeArgs, RunArgs, SlurmArgs, StatusArgs, ValidateArgs};
use super::pool;
use anyhow::{Context, Result};
use isar_clutter::run::estimate;
use isar_clutter::run::options::{self, RunOptions};
use isar_clutter::run::plan::{self, Plan};
use std::path::PathBuf;
use std::process::ExitCode;

/// `run`: every job of the spec (or its job table with `--dry-run`), then the report.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn run(a: RunArgs) -> Result<ExitCode> {
    let RunArgs {
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
        device,
    } = a;
    let mut plan = plan::load_seeded(&spec, seed)?;
    if let Some(device) = device {
        plan.set_training_device(device);
    }
    if dry_run {
        let largest = isar_clutter::run::check::check(&plan, estimate::limit(max_memory))?;
        print_jobs(&plan);
        println!("{largest}");
        return Ok(ExitCode::SUCCESS);
    }
    if let Some(line) = plan.resolve_training_device()? {
        // A fall back to the CPU is said even under --quiet.
        if !quiet || line.contains("(auto:") {
            eprintln!("CNN trainings on: {line}");
        }
    }
    let out = out.unwrap_or_else(|| PathBuf::from("outputs").join(&plan.spec.name));
    check_disk(&plan, &out)?;
    let mut opts = RunOptions::new(out, jobs.unwrap_or_else(options::default_threads));
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
            .context(
                "building the report (the results are written; retry with `isar-clutter report`)",
            )?;
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

/// `merge`: the tables, manifest and report of a folder from its job store.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn merge(a: MergeArgs) -> Result<ExitCode> {
    let MergeArgs {
        results,
        partial,
        no_report,
        jobs,
        quiet,
    } = a;
    let mut opts = RunOptions::new(
        results.clone(),
        jobs.unwrap_or_else(options::default_threads),
    );
    opts.quiet = quiet;
    opts.report_follows = !no_report;
    let merged = pool(jobs)?.install(|| isar_clutter::run::merge::merge(&opts, partial))?;
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
            .context(
                "building the report (the tables are written; retry with `isar-clutter report`)",
            )?;
    }
    Ok(if merged.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// `status`: the jobs of a folder, done, failed or missing.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn status(a: StatusArgs) -> Result<ExitCode> {
    let StatusArgs { results } = a;
    print!("{}", isar_clutter::run::status::list(&results)?);
    Ok(ExitCode::SUCCESS)
}

/// `validate`: checks a spec without running it.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn validate(a: ValidateArgs) -> Result<ExitCode> {
    let ValidateArgs { spec, max_memory } = a;
    let plan = plan::load(&spec)?;
    let largest = isar_clutter::run::check::check(&plan, estimate::limit(max_memory))?;
    let all = isar_clutter::run::jobs::all::AllJobs::new(&plan)
        .list()
        .len();
    let footprint = estimate::footprint(&plan, all);
    // Against the default output folder's file system (`run --out` checks its own).
    let disk = footprint.check_disk(&PathBuf::from("outputs").join(&plan.spec.name));
    if let Err(why) = &disk {
        anyhow::bail!("{}: `run` would refuse it: {why}", spec.display());
    }
    println!("{}: valid, {all} job(s)", spec.display());
    println!("{largest}");
    println!("{footprint}");
    if let Ok(Some(warning)) = disk {
        println!("warning: {warning}");
    }
    Ok(ExitCode::SUCCESS)
}

/// Refuses a run whose outputs cannot fit on the file system of `out`, or warns
/// ([`estimate::Footprint::check_disk`]), before anything is written.
///
/// # Errors
/// The refusal.
fn check_disk(plan: &Plan, out: &std::path::Path) -> Result<()> {
    let all = isar_clutter::run::jobs::all::AllJobs::new(plan)
        .list()
        .len();
    match estimate::footprint(plan, all).check_disk(out) {
        Err(why) => anyhow::bail!(why),
        Ok(Some(warning)) => eprintln!("warning: {warning}"),
        Ok(None) => {}
    }
    Ok(())
}

/// `slurm`: writes (and submits) the array and merge scripts.
///
/// # Errors
/// What the command cannot do, naming the file or the job.
pub fn slurm(a: SlurmArgs) -> Result<ExitCode> {
    let SlurmArgs {
        spec,
        shards,
        out,
        partition,
        time,
        cpus,
        mem,
        submit,
    } = a;
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
