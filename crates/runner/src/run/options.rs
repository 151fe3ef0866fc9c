//! The options of a run (folder, threads, shard, memory limit, progress) and what a run did:
//! the values the command line and the reproduction hand the runner, and the summary they print.
//! The default thread count honours `RAYON_NUM_THREADS` as rayon does.

use std::io::IsTerminal;
use std::path::PathBuf;

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
/// number (as rayon's own default honours it; capped at
/// [`crate::resources::max_threads`]), otherwise the machine's available parallelism.
pub fn default_threads() -> usize {
    threads_from(std::env::var("RAYON_NUM_THREADS").ok().as_deref())
}

/// [`default_threads`] given the value of `RAYON_NUM_THREADS`.
fn threads_from(env: Option<&str>) -> usize {
    env.and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .map(|n| n.min(crate::resources::max_threads()))
        .unwrap_or_else(|| {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        })
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
        let most = crate::resources::max_threads();
        assert_eq!(super::threads_from(Some("100000")), most);
        assert_eq!(super::threads_from(Some("many")), all);
    }
}
