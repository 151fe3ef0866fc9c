//! Executes jobs: every job through the one seam ([`JobKind`]), in parallel on the installed
//! rayon pool; jobs that read the same dataset run as one group (the stack materialised once
//! when it is worth sharing); a job whose memory estimate exceeds the limit, or whose work is
//! absurd, fails before it allocates; each finished job is saved in the job store at once ([`crate::run::store`]). A
//! progress bar on a terminal (plain lines otherwise); a failed or panicking job is recorded
//! without stopping the others. Also the options of a run, its summary, and writing the
//! assembled tables. The order of a whole run is in [`crate::run::driver`].

use crate::run::jobs::{Context as JobContext, Inputs, JobKind, Outcome, Rows};
use crate::run::plan::Plan;
use crate::run::store;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::io::IsTerminal;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::time::Instant;

/// How to run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Output folder.
    pub out: PathBuf,
    /// Worker threads.
    pub threads: usize,
    /// Show a progress bar (otherwise one line per finished job on stderr).
    pub progress_bar: bool,
    /// Print progress at all.
    pub quiet: bool,
    /// Run one shard only: `(index, shards)`; its jobs go into the job store, and `merge`
    /// assembles the tables.
    pub shard: Option<(usize, usize)>,
    /// Redo every job, even those the job store holds.
    pub fresh: bool,
    /// Memory limit in bytes (`--max-memory`; the machine's memory when lower or unset): a job
    /// whose estimate ([`JobKind::estimate`]) exceeds it, or whose work passes
    /// [`crate::run::estimate::MAX_FLOPS`], fails without allocating anything.
    pub max_memory: Option<u64>,
    /// A report follows the run (`run` and `merge` without `--no-report`): the merge leaves
    /// an earlier report's figures in `figures/` for it, which keeps those whose inputs did
    /// not change and removes the others. Without it they go with everything else the run did
    /// not write.
    pub report_follows: bool,
}

impl RunOptions {
    /// Options with a progress bar when stderr is a terminal.
    pub fn new(out: PathBuf, threads: usize) -> Self {
        RunOptions {
            out,
            threads,
            progress_bar: std::io::stderr().is_terminal(),
            quiet: false,
            max_memory: None,
            shard: None,
            fresh: false,
            report_follows: false,
        }
    }
}

/// What a run did.
#[derive(Debug)]
pub struct RunSummary {
    /// Jobs run.
    pub total: usize,
    /// Jobs that failed.
    pub failed: Vec<(String, String)>,
    /// Output folder.
    pub out: PathBuf,
    /// Wall time in seconds.
    pub elapsed_s: f64,
    /// What claiming the folder did besides (a stale lock taken over, temporary files of an
    /// interrupted run removed), how many jobs the store already held, how many stale files of
    /// an earlier run went.
    pub notes: Vec<String>,
    /// Jobs skipped because the job store held their result.
    pub skipped: usize,
    /// Whether the tables and the manifest were written (not for a shard).
    pub merged: bool,
    /// The output folder, still claimed, of a merged run whose report follows
    /// ([`RunOptions::report_follows`]): the report is built under the run's claim
    /// (the report's `build_claimed`); dropping it releases the folder.
    pub claim: Option<crate::io::outdir::OutDir>,
}

/// Default number of worker threads: `RAYON_NUM_THREADS` when it is set to a positive
/// number (as rayon's own default honours it), otherwise the machine's available parallelism.
pub fn default_threads() -> usize {
    threads_from(std::env::var("RAYON_NUM_THREADS").ok().as_deref())
}

/// [`default_threads`] given the value of `RAYON_NUM_THREADS`.
fn threads_from(env: Option<&str>) -> usize {
    env.and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        })
}

/// The jobs of `wave` grouped by the dataset they read (its data seed), groups in order of
/// first appearance, jobs in plan order; every other job is a group of its own.
fn groups(jobs: &[&dyn JobKind], wave: &[usize]) -> Vec<Vec<usize>> {
    let mut groups: Vec<Vec<usize>> = vec![];
    // The group of each data seed (a lookup, not a scan, which was quadratic in the jobs).
    let mut of_seed: std::collections::HashMap<u64, usize> = Default::default();
    for &i in wave {
        let key = match jobs[i].inputs() {
            Inputs::Dataset { data_seed, .. } => Some(data_seed),
            _ => None,
        };
        match key.and_then(|k| of_seed.get(&k).copied()) {
            Some(g) => groups[g].push(i),
            None => {
                if let Some(k) = key {
                    of_seed.insert(k, groups.len());
                }
                groups.push(vec![i]);
            }
        }
    }
    groups
}

/// Runs the jobs `indices` on the installed rayon pool, grouped by the dataset they read,
/// with the outcomes of `earlier` jobs for those that read other jobs' rows; each job is saved
/// in the job store as it finishes. `keep_rows`: return every job's outcome with its rows;
/// otherwise the rows are dropped once stored and only the failed jobs' outcomes are returned,
/// so that memory is bounded by the jobs in flight (100,000 empty outcomes held 10-20 MB).
#[allow(clippy::too_many_arguments)]
pub fn execute(
    plan: &Plan,
    jobs: &[&dyn JobKind],
    keys: &[String],
    earlier: &[Option<Outcome>],
    indices: &[usize],
    opts: &RunOptions,
    bar: &Option<ProgressBar>,
    keep_rows: bool,
) -> Vec<(usize, Outcome)> {
    let commits = store::Commits::new(&opts.out);
    let done = groups(jobs, indices)
        .par_iter()
        .flat_map_iter(|g| run_group(plan, jobs, keys, earlier, g, opts, bar, keep_rows, &commits))
        .collect();
    commits.flush();
    done
}

/// Runs one group of jobs: its shared dataset materialised once (no lock: the group owns it)
/// when worth it, then its jobs in parallel; each job's panic or error is its own outcome.
#[allow(clippy::too_many_arguments)]
fn run_group(
    plan: &Plan,
    jobs: &[&dyn JobKind],
    keys: &[String],
    earlier: &[Option<Outcome>],
    group: &[usize],
    opts: &RunOptions,
    bar: &Option<ProgressBar>,
    keep_rows: bool,
    commits: &store::Commits,
) -> Vec<(usize, Outcome)> {
    let limit = crate::run::estimate::limit(opts.max_memory);
    // A job that cannot fit fails before anything is allocated for it.
    let too_big = |job: &dyn JobKind| job.estimate(plan).exceeds(limit.as_ref());
    let first = jobs[group[0]];
    let shared = (group.len() > 1
        && group.iter().all(|&i| too_big(jobs[i]).is_none())
        && matches!(first.inputs(), Inputs::Dataset { shared: true, .. }))
    .then(|| {
        catch_unwind(AssertUnwindSafe(|| {
            first.materialise().map_err(|e| crate::error_text(&e))
        }))
        .unwrap_or_else(|p| Err(format!("dataset panicked: {}", panic_message(&p))))
    });
    group
        .par_iter()
        .map(|&index| {
            let job = jobs[index];
            let t = Instant::now();
            let dir = store::begin(&opts.out, &keys[index]);
            let rows = match (&shared, too_big(job)) {
                _ if dir.is_err() => Err(dir
                    .as_ref()
                    .map_or_else(crate::error_text, |_| String::new())),
                (_, Some(reason)) => Err(reason),
                (Some(Err(e)), _) => Err(e.clone()),
                _ => {
                    let inputs = match job.inputs() {
                        Inputs::Rows(from) => from
                            .iter()
                            .filter_map(|&k| {
                                let rows = earlier[k].as_ref()?.rows.as_ref().ok()?;
                                Some((jobs[k], rows))
                            })
                            .collect(),
                        _ => vec![],
                    };
                    let cx = JobContext {
                        plan,
                        out: dir.as_ref().expect("checked above"),
                        shared: shared.as_ref().and_then(|r| r.as_ref().ok()),
                        inputs,
                    };
                    catch_unwind(AssertUnwindSafe(|| job.run(&cx)))
                        .unwrap_or_else(|p| {
                            Err(anyhow::anyhow!("job panicked: {}", panic_message(&p)))
                        })
                        .map_err(|e| crate::error_text(&e))
                }
            };
            let mut outcome = Outcome {
                rows,
                elapsed_s: t.elapsed().as_secs_f64(),
            };
            // Into the store at once; a store that cannot be written fails the job.
            match store::save(&opts.out, &keys[index], job, &outcome) {
                Ok(()) => commits.saved(),
                Err(e) => {
                    outcome.rows = Err(format!("saving the result: {}", crate::error_text(&e)))
                }
            }
            report(bar, opts, job, &outcome);
            if !keep_rows {
                // Stored: the job's memory goes now, not at the end of the run.
                outcome.rows = outcome.rows.map(|_| Rows::default());
            }
            (index, outcome)
        })
        .filter(|(_, o)| keep_rows || o.rows.is_err())
        .collect()
}

/// A progress bar over `n` jobs when stderr is a terminal and the run is not quiet.
pub fn progress(n: usize, opts: &RunOptions) -> Option<ProgressBar> {
    (opts.progress_bar && !opts.quiet).then(|| {
        let bar = ProgressBar::new(n as u64);
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} jobs [{elapsed_precise}] {msg}")
                .expect("valid template"),
        );
        bar
    })
}

fn report(bar: &Option<ProgressBar>, opts: &RunOptions, job: &dyn JobKind, o: &Outcome) {
    let status = match &o.rows {
        Ok(_) => "ok".to_string(),
        Err(e) => format!("FAILED: {e}"),
    };
    match bar {
        Some(b) => {
            if o.rows.is_err() {
                b.println(format!("{}: {status}", job.id()));
            }
            b.set_message(job.id().to_string());
            b.inc(1);
        }
        None if !opts.quiet => eprintln!("{} {status} ({:.3} s)", job.id(), o.elapsed_s),
        None => {}
    }
}

fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

#[cfg(test)]
mod tests {
    #[test]
    fn rayon_num_threads_sets_the_default() {
        assert_eq!(super::threads_from(Some("1")), 1);
        assert_eq!(super::threads_from(Some(" 3 ")), 3);
        let all = super::threads_from(None);
        assert!(all >= 1);
        assert_eq!(super::threads_from(Some("0")), all);
        assert_eq!(super::threads_from(Some("many")), all);
    }
}
