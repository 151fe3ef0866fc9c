//! The one value a run is: its plan, every job of the plan in plan order behind the one seam,
//! each job's key in the job store, and the options (the output folder among them). The
//! driver ([`crate::run::driver`]), the scheduler ([`crate::run::scheduler`]: `execute`) and
//! the merge ([`crate::run::merge`]: `merge_claimed`) are its methods, so that the jobs and
//! their keys are listed once, here, and not passed from step to step.

use crate::run::jobs::all::AllJobs;
use crate::run::jobs::{Inputs, JobKind};
use crate::run::options::RunOptions;
use crate::run::plan::Plan;
use crate::run::store;
use anyhow::Result;
use std::path::Path;

/// A plan's jobs, keyed, with the options they run under.
pub struct Run<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// Every job, in plan order ([`AllJobs::list`]): [`Inputs::Rows`] indices refer to it.
    pub jobs: Vec<&'a dyn JobKind>,
    /// The job store's key of each job ([`store::key`]), by index.
    pub keys: Vec<String>,
    /// The options: the output folder, threads, shard, memory limit, progress.
    pub opts: &'a RunOptions,
}

impl<'a> Run<'a> {
    /// The jobs of `all` keyed (on the installed pool: input files are hashed by its threads).
    ///
    /// # Errors
    /// If an input file cannot be read for its hash.
    pub fn new(plan: &'a Plan, all: &'a AllJobs<'a>, opts: &'a RunOptions) -> Result<Self> {
        let jobs = all.list();
        let keys = jobs
            .iter()
            .map(|j| store::key(*j, plan))
            .collect::<Result<_>>()?;
        Ok(Run {
            plan,
            jobs,
            keys,
            opts,
        })
    }

    /// The output folder.
    pub fn out(&self) -> &Path {
        &self.opts.out
    }

    /// Whether job `i` reads other jobs' rows (the hypothesis tests, the location summary):
    /// such a job runs at the merge, from the rows of the jobs it reads.
    pub fn reads_rows(&self, i: usize) -> bool {
        matches!(self.jobs[i].inputs(), Inputs::Rows(_))
    }

    /// The id of job `i`.
    pub fn id(&self, i: usize) -> &str {
        self.jobs[i].id()
    }
}
