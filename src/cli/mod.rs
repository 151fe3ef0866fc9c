//! The binary's commands: the grammar ([`args`]) and one function per command, grouped by
//! family: running a spec ([`run`]), reading results ([`results`]), models ([`models`]).

pub mod args;
pub mod models;
pub mod results;
pub mod run;

/// A rayon pool of `jobs` threads (default: all cores).
///
/// # Errors
/// If the pool's threads cannot be started.
pub fn pool(jobs: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or_else(isar_clutter::run::options::default_threads))
        .build()?)
}
