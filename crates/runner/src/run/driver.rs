//! A run from start to end: claim the output folder, record the spec, key every job, skip
//! those the job store already holds (resume), run the rest (all, or one shard's) with the
//! scheduler, and, for a run that is not a shard, merge the store into the tables, files and
//! manifest ([`crate::run::merge`]). `main`'s `run` command is this function.

use crate::io::outdir::{OutDir, Purpose};
use crate::run::jobs::all::AllJobs;
use crate::run::jobs::{Inputs, Outcome};
use crate::run::plan::Plan;
use crate::run::scheduler::{self, RunOptions, RunSummary};
use crate::run::{merge, store};
use anyhow::{bail, Result};
use std::time::Instant;

/// Runs the jobs of `plan` (all, or one shard's) into the job store of the output folder,
/// skipping those whose result the store already holds (unless `fresh`), then, for a run that
/// is not a shard, merges the store into the tables, the files and the manifest
/// ([`crate::run::merge`]).
///
/// # Errors
/// Only for failures outside the jobs (an output folder that is not the tool's or is locked,
/// the store, tables, manifest), and when jobs of this run failed without a record in the
/// store (a full disk: the error names them and their causes, and nothing is merged); a
/// failed job is recorded in the store, in `jobs.parquet` (or,
/// for a job of the run as a whole, in the manifest) and in the returned summary. A run that
/// stops with an error leaves its folder marked in progress, which `table` and `report` refuse.
///
/// Long because it is a run from start to end in order (claim, key, skip what the store holds,
/// execute, merge), each step a few lines.
pub fn run(plan: &Plan, opts: &RunOptions) -> Result<RunSummary> {
    let start = Instant::now();
    let purpose = match opts.shard {
        Some((index, _)) => Purpose::Shard { index },
        None => Purpose::Run,
    };
    let outdir = OutDir::claim(&opts.out, Some(&plan.spec.name), purpose)?;
    let mut notes = outdir.notes.clone();
    merge::record_plan(&opts.out, plan, opts.shard.map(|(_, n)| n))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.max(1))
        .build()?;
    let all = AllJobs::new(plan);
    let jobs = all.list();
    store::load_hash_memo(&opts.out);
    // On the run's pool: input files are hashed by its threads.
    let keys: Vec<String> = pool.install(|| {
        jobs.iter()
            .map(|j| store::key(*j, plan))
            .collect::<Result<_>>()
    })?;
    let mut inputs: Vec<std::path::PathBuf> = jobs.iter().flat_map(|j| j.input_files()).collect();
    inputs.sort();
    inputs.dedup();
    store::save_hash_memo(&opts.out, &inputs)?;
    // This run's jobs: a shard's share, or every job; jobs that read other jobs' rows run at
    // the merge.
    let mine: Vec<usize> = match opts.shard {
        Some((index, shards)) => {
            let assigned = store::assign(plan, &jobs, shards)?;
            (0..jobs.len())
                .filter(|&i| assigned[i] == Some(index))
                .collect()
        }
        None => (0..jobs.len())
            .filter(|&i| !matches!(jobs[i].inputs(), Inputs::Rows(_)))
            .collect(),
    };
    let mut damaged = vec![];
    let (todo, skipped): (Vec<usize>, Vec<usize>) = mine.iter().partition(|&&i| {
        if opts.fresh {
            return true;
        }
        match pool.install(|| store::entry(&opts.out, &keys[i])) {
            store::Entry::Done(_) => false,
            store::Entry::Missing(Some(why)) => {
                damaged.push(format!("{} ({why})", jobs[i].id()));
                true
            }
            _ => true,
        }
    });
    if !damaged.is_empty() {
        notes.push(store::damaged_note(&damaged));
    }
    if !skipped.is_empty() {
        notes.push(format!(
            "resumed: {} job(s) already done in the job store were skipped (--fresh redoes them)",
            skipped.len()
        ));
    }
    let bar = scheduler::progress(todo.len(), opts);
    // Every job's rows go as soon as they are stored: the merge streams them back from the
    // store, so that a run's memory does not grow with its jobs; `done` holds the failed ones.
    let done: Vec<(usize, Outcome)> =
        pool.install(|| scheduler::execute(plan, &jobs, &keys, &[], &todo, opts, &bar, false));
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    crate::io::npy::release_offered();
    let mut failed: Vec<(String, String)> = done
        .iter()
        .filter_map(|(i, o)| {
            o.rows
                .as_ref()
                .err()
                .map(|e| (jobs[*i].id().to_string(), e.clone()))
        })
        .collect();
    if opts.shard.is_some() {
        // The folder stays in progress: `merge` writes the tables and the manifest.
        return Ok(RunSummary {
            total: mine.len(),
            failed,
            out: opts.out.clone(),
            elapsed_s: start.elapsed().as_secs_f64(),
            notes,
            skipped: skipped.len(),
            merged: false,
            claim: None,
        });
    }
    // A job whose outcome could not be stored (a full disk, say) is missing from the store,
    // and the merge would refuse it as a shard's job not run yet: say that it failed, and why.
    let unstored: Vec<String> = todo
        .iter()
        // Written a moment ago by this process: the record's presence, not its files' hashes.
        .filter(|&&i| {
            matches!(
                store::entry_verified_earlier(&opts.out, &keys[i]),
                store::Entry::Missing(_)
            )
        })
        .map(|&i| {
            let why = done
                .iter()
                .find(|(d, _)| *d == i)
                .and_then(|(_, o)| o.rows.as_ref().err())
                .map_or("no record", String::as_str);
            format!("{}: {why}", jobs[i].id())
        })
        .collect();
    if !unstored.is_empty() {
        bail!("{}", unstored_message(&opts.out, &unstored));
    }
    let merged = pool
        .install(|| merge::merge_claimed(plan, &jobs, &keys, &outdir, opts, false, start, done))?;
    notes.extend(merged.notes);
    failed = merged.failed;
    Ok(RunSummary {
        total: jobs.len(),
        failed,
        out: opts.out.clone(),
        elapsed_s: start.elapsed().as_secs_f64(),
        notes,
        skipped: skipped.len(),
        merged: true,
        claim: opts.report_follows.then_some(outdir),
    })
}

/// The error of a run some of whose jobs failed without a record in the job store: the jobs
/// and their errors (the first 3), and what to do.
fn unstored_message(out: &std::path::Path, unstored: &[String]) -> String {
    let shown: Vec<&str> = unstored.iter().take(3).map(String::as_str).collect();
    format!(
        "{} job(s) failed and their outcome could not be saved in the job store {}: {}{}; \
         nothing was merged: free space (or fix what the errors name) and run again, which \
         redoes only the jobs not stored",
        unstored.len(),
        out.join("jobs").display(),
        shown.join("; "),
        match unstored.len() - shown.len() {
            0 => String::new(),
            more => format!("; and {more} more"),
        }
    )
}
