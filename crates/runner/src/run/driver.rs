//! A run from start to end: claim the output folder, record the spec, key every job, skip
//! those the job store already holds (resume), run the rest (all, or one shard's) with the
//! scheduler, and, for a run that is not a shard, merge the store into the tables, files and
//! manifest ([`Run::merge_claimed`]). `main`'s `run` command is this function.

use crate::io::outdir::{OutDir, Purpose};
use crate::run::jobs::all::AllJobs;
use crate::run::jobs::Outcome;
use crate::run::options::{RunOptions, RunSummary};
use crate::run::plan::Plan;
use crate::run::value::Run;
use crate::run::{record, scheduler, store};
use anyhow::{bail, Result};
use rayon::ThreadPool;
use std::time::Instant;

/// Runs the jobs of `plan` (all, or one shard's) into the job store of the output folder,
/// skipping those whose result the store already holds (unless `fresh`), then, for a run that
/// is not a shard, merges the store into the tables, the files and the manifest
/// ([`Run::merge_claimed`]).
///
/// # Errors
/// Only for failures outside the jobs (an output folder that is not the tool's or is locked,
/// the store, tables, manifest), and when jobs of this run failed without a record in the
/// store (a full disk: the error names them and their causes, and nothing is merged); a
/// failed job is recorded in the store, in `jobs.parquet` (or,
/// for a job of the run as a whole, in the manifest) and in the returned summary. A run that
/// stops with an error leaves its folder marked in progress, which `table` and `report` refuse.
pub fn run(plan: &Plan, opts: &RunOptions) -> Result<RunSummary> {
    let start = Instant::now();
    let purpose = match opts.shard {
        Some((index, _)) => Purpose::Shard { index },
        None => Purpose::Run,
    };
    let outdir = OutDir::claim(&opts.out, Some(&plan.spec.name), purpose)?;
    let mut notes = outdir.notes.clone();
    record::write(&opts.out, plan, opts.shard.map(|(_, n)| n))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.max(1))
        .build()?;
    let all = AllJobs::new(plan);
    store::load_hash_memo(&opts.out);
    // On the run's pool: input files are hashed by its threads.
    let run = pool.install(|| Run::new(plan, &all, opts))?;
    let mut inputs: Vec<std::path::PathBuf> =
        run.jobs.iter().flat_map(|j| j.input_files()).collect();
    inputs.sort();
    inputs.dedup();
    store::save_hash_memo(&opts.out, &inputs)?;
    let mine = run.mine()?;
    let (todo, skipped) = run.todo(&mine, &pool, &mut notes);
    let bar = scheduler::progress(todo.len(), opts);
    // Every job's rows go as soon as they are stored: the merge streams them back from the
    // store, so that a run's memory does not grow with its jobs; `done` holds the failed ones.
    let done: Vec<(usize, Outcome)> = pool.install(|| run.execute(&todo, &[], bar.as_ref()));
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    crate::io::npy::release_offered();
    let mut summary = RunSummary {
        total: mine.len(),
        failed: done
            .iter()
            .filter_map(|(i, o)| {
                o.rows
                    .as_ref()
                    .err()
                    .map(|e| (run.id(*i).into(), e.clone()))
            })
            .collect(),
        out: opts.out.clone(),
        elapsed_s: 0.0,
        notes,
        skipped,
        merged: false,
        claim: None,
    };
    if opts.shard.is_none() {
        // The folder stays in progress for a shard: `merge` writes the tables and the manifest.
        let unstored = run.unstored(&todo, &done);
        if !unstored.is_empty() {
            bail!("{}", unstored_message(&opts.out, &unstored));
        }
        let merged = pool.install(|| run.merge_claimed(&outdir, false, start, done))?;
        summary.notes.extend(merged.notes);
        summary.failed = merged.failed;
        summary.total = run.jobs.len();
        summary.merged = true;
        summary.claim = opts.report_follows.then_some(outdir);
    }
    summary.elapsed_s = start.elapsed().as_secs_f64();
    Ok(summary)
}

impl Run<'_> {
    /// This run's jobs: a shard's share, or every job but those that read other jobs' rows
    /// (they run at the merge).
    fn mine(&self) -> Result<Vec<usize>> {
        Ok(match self.opts.shard {
            Some((index, shards)) => {
                let assigned = store::assign(self.plan, &self.jobs, shards)?;
                (0..self.jobs.len())
                    .filter(|&i| assigned[i] == Some(index))
                    .collect()
            }
            None => (0..self.jobs.len())
                .filter(|&i| !self.reads_rows(i))
                .collect(),
        })
    }

    /// The jobs of `mine` to run (all with `fresh`; otherwise those the store does not hold or
    /// holds damaged, each entry verified on `pool`) and the number skipped; what was redone
    /// and skipped goes into `notes`.
    fn todo(
        &self,
        mine: &[usize],
        pool: &ThreadPool,
        notes: &mut Vec<String>,
    ) -> (Vec<usize>, usize) {
        let mut damaged = vec![];
        let (todo, skipped): (Vec<usize>, Vec<usize>) = mine.iter().partition(|&&i| {
            if self.opts.fresh {
                return true;
            }
            match pool.install(|| store::entry(self.out(), &self.keys[i])) {
                store::Entry::Done(_) => false,
                store::Entry::Missing(Some(why)) => {
                    damaged.push(format!("{} ({why})", self.id(i)));
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
        (todo, skipped.len())
    }

    /// The jobs of `todo` whose outcome could not be stored (a full disk, say), with why: the
    /// merge would refuse them as a shard's jobs not run yet. `done`: the failed outcomes.
    fn unstored(&self, todo: &[usize], done: &[(usize, Outcome)]) -> Vec<String> {
        todo.iter()
            // Written a moment ago by this process: the record's presence, not its files' hashes.
            .filter(|&&i| {
                matches!(
                    store::entry_verified_earlier(self.out(), &self.keys[i]),
                    store::Entry::Missing(_)
                )
            })
            .map(|&i| {
                let why = done
                    .iter()
                    .find(|(d, _)| *d == i)
                    .and_then(|(_, o)| o.rows.as_ref().err())
                    .map_or("no record", String::as_str);
                format!("{}: {why}", self.id(i))
            })
            .collect()
    }
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
