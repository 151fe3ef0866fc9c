//! Executes jobs ([`Run::execute`]): every job through the one seam ([`JobKind`]), in parallel
//! on the installed rayon pool; jobs that read the same dataset run as one group (the stack
//! materialised once when it is worth sharing); a job whose memory estimate exceeds the limit,
//! or whose work is absurd, fails before it allocates; each finished job is saved in the job
//! store at once ([`crate::run::store`]). A progress bar on a terminal (plain lines otherwise);
//! a failed or panicking job is recorded without stopping the others. Jobs whose memory
//! estimates would together pass the limit (`--max-memory`, or the machine's memory) when run
//! at once are run in consecutive waves that fit ([`memory_waves`]). The order of a whole run
//! is in [`crate::run::driver`].

use crate::run::jobs::{Context as JobContext, Inputs, JobKind, Outcome, Rows};
use crate::run::options::RunOptions;
use crate::run::store;
use crate::run::value::Run;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

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

/// The jobs (positions in `bytes`, each job's estimated peak) cut into waves that run one
/// after the other, so that the jobs running together never hold more than `limit` bytes:
/// one wave when any `threads` of them fit together (the usual case), otherwise consecutive
/// runs of jobs, in order, whose bytes together fit (a job alone always makes a wave; the
/// scheduler refuses one above the limit before it allocates).
pub fn memory_waves(bytes: &[u64], limit: Option<u64>, threads: usize) -> Vec<Vec<usize>> {
    let all = || vec![(0..bytes.len()).collect::<Vec<_>>()];
    let Some(limit) = limit else { return all() };
    let mut largest = bytes.to_vec();
    largest.sort_unstable_by(|a, b| b.cmp(a));
    let together = largest
        .iter()
        .take(threads.max(1))
        .fold(0u64, |s, &b| s.saturating_add(b));
    if together <= limit {
        return all();
    }
    let mut waves: Vec<Vec<usize>> = vec![];
    let mut held = 0u64;
    for (k, &b) in bytes.iter().enumerate() {
        match waves.last_mut() {
            Some(wave) if held.saturating_add(b) <= limit => wave.push(k),
            _ => {
                waves.push(vec![k]);
                held = 0;
            }
        }
        held = held.saturating_add(b);
    }
    waves
}

impl Run<'_> {
    /// Runs the jobs `indices` on the installed rayon pool, grouped by the dataset they read,
    /// with the outcomes of `earlier` jobs for those that read other jobs' rows (empty when
    /// none do); each job is saved in the job store as it finishes and its rows dropped then,
    /// so that memory is bounded by the jobs in flight (100,000 outcomes held 10-20 MB). The
    /// outcomes of the failed jobs, which the caller reports (a failure that could not be
    /// stored among them).
    pub fn execute(
        &self,
        indices: &[usize],
        earlier: &[Option<Outcome>],
        bar: Option<&ProgressBar>,
    ) -> Vec<(usize, Outcome)> {
        let commits = store::Commits::new(self.out());
        let limit = crate::run::estimate::limit(self.opts.max_memory);
        // Every job estimated once: why it cannot run (it then fails before it allocates and
        // holds nothing) or the bytes it holds.
        let mut refused: HashMap<usize, String> = HashMap::new();
        let bytes: Vec<u64> = indices
            .iter()
            .map(|&i| {
                let estimate = self.jobs[i].estimate(self.plan);
                match estimate.exceeds(limit.as_ref()) {
                    Some(why) => {
                        refused.insert(i, why);
                        0
                    }
                    None => estimate.bytes,
                }
            })
            .collect();
        let threads = rayon::current_num_threads();
        let mut failed = vec![];
        for wave in memory_waves(&bytes, limit.map(|l| l.bytes), threads) {
            let wave: Vec<usize> = wave.into_iter().map(|k| indices[k]).collect();
            failed.extend(
                groups(&self.jobs, &wave)
                    .par_iter()
                    .flat_map_iter(|g| self.run_group(g, (earlier, &refused), bar, &commits))
                    .collect::<Vec<_>>(),
            );
        }
        commits.flush();
        failed
    }

    /// Runs one group of jobs: its shared dataset materialised once (no lock: the group owns
    /// it) when worth it, then its jobs in parallel; each job's panic or error is its own
    /// outcome. The failed jobs' outcomes.
    fn run_group(
        &self,
        group: &[usize],
        (earlier, refused): (&[Option<Outcome>], &HashMap<usize, String>),
        bar: Option<&ProgressBar>,
        commits: &store::Commits,
    ) -> Vec<(usize, Outcome)> {
        let (plan, jobs, opts) = (self.plan, &self.jobs, self.opts);
        // A job that cannot fit fails before anything is allocated for it.
        let too_big = |i: usize| refused.get(&i).cloned();
        let first = jobs[group[0]];
        let shared = (group.len() > 1
            && group.iter().all(|&i| too_big(i).is_none())
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
                let dir = store::begin(&opts.out, &self.keys[index]);
                let rows = match (&shared, too_big(index)) {
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
                match store::save(&opts.out, &self.keys[index], job, &outcome) {
                    Ok(()) => commits.saved(),
                    Err(e) => {
                        outcome.rows = Err(format!("saving the result: {}", crate::error_text(&e)))
                    }
                }
                report(bar, opts, job, &outcome);
                // Stored: the job's memory goes now, not at the end of the run.
                outcome.rows = outcome.rows.map(|_| Rows::default());
                (index, outcome)
            })
            .filter(|(_, o)| o.rows.is_err())
            .collect()
    }
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

fn report(bar: Option<&ProgressBar>, opts: &RunOptions, job: &dyn JobKind, o: &Outcome) {
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
    use super::memory_waves;

    #[test]
    fn jobs_that_fit_together_are_one_wave_and_others_run_in_waves_that_fit() {
        let mib = 1u64 << 20;
        assert_eq!(
            memory_waves(&[380 * mib; 4], None, 2),
            vec![vec![0, 1, 2, 3]]
        );
        assert_eq!(
            memory_waves(&[100 * mib; 4], Some(600 * mib), 2),
            vec![vec![0, 1, 2, 3]]
        );
        // Two 380 MiB jobs do not fit under 600 MiB together: one after the other.
        assert_eq!(
            memory_waves(&[380 * mib, 380 * mib], Some(600 * mib), 2),
            vec![vec![0], vec![1]]
        );
        // One thread: jobs never run together, one wave.
        assert_eq!(
            memory_waves(&[380 * mib; 3], Some(600 * mib), 1),
            vec![vec![0, 1, 2]]
        );
        let bytes = [300, 200, 100, 500, 50, 50, 600].map(|b| b * mib);
        let waves = memory_waves(&bytes, Some(600 * mib), 4);
        assert_eq!(waves, vec![vec![0, 1, 2], vec![3, 4, 5], vec![6]]);
        for wave in &waves {
            assert!(wave.iter().map(|&k| bytes[k]).sum::<u64>() <= 600 * mib);
        }
    }
}
