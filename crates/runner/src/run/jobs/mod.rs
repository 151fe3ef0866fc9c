//! The one seam for job kinds. Every kind of job (a dataset's analysis or synthesis, the
//! calibration, the hypothesis tests, and next the CNN trainings) implements [`JobKind`]: it
//! says who it is (id, canonical identity, seed), what it reads ([`Inputs`]), and runs into
//! [`Rows`]: fragments of the run's tables plus the files it wrote. The scheduler runs jobs
//! through this trait only, and the table assembly ([`crate::run::assembly`])
//! streams the fragments in plan order, so neither grows a branch per kind. A job's rows
//! are what a durable job store persists.
//!
//! A new kind of job: a file here with a struct that implements [`JobKind`], listed by
//! [`all::AllJobs`] from its spec section.

pub mod all;
pub mod calibration;
pub mod cnn;
pub mod dataset;
pub mod hypotheses;

use crate::experiment::Materialised;
use crate::run::estimate::Estimate;
use crate::run::plan::Plan;
use anyhow::Result;
use polars::prelude::DataFrame;
use std::path::{Path, PathBuf};

/// What a job produced: fragments of tables (by table name; names starting with `_` are
/// intermediate rows for other jobs and are not written as tables) and the files it wrote.
#[derive(Default)]
pub struct Rows {
    /// Table fragments in the order the job made them.
    pub tables: Vec<(&'static str, DataFrame)>,
    /// Files (or folders) the job wrote into the output folder.
    pub files: Vec<PathBuf>,
    /// The job's timings for the manifest.
    pub timing: Option<serde_json::Value>,
}

impl Rows {
    /// The fragment of table `name`, if the job made one.
    pub fn table(&self, name: &str) -> Option<&DataFrame> {
        self.tables
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, df)| df)
    }
}

/// What a job reads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Inputs {
    /// Nothing but its own parameters and seed.
    Nothing,
    /// A dataset: jobs with the same data seed read the same stack and run as one group;
    /// `shared` says the stack is worth materialising once for the group.
    Dataset {
        /// The data seed (group key).
        data_seed: u64,
        /// Whether the group's jobs share one materialisation.
        shared: bool,
    },
    /// The rows of other jobs (indices into the plan's job list), available once they ran.
    Rows(Vec<usize>),
}

/// Outcome of one job.
pub struct Outcome {
    /// The job's rows, or the error's message (with its cause chain).
    pub rows: Result<Rows, String>,
    /// Wall time of the job in seconds.
    pub elapsed_s: f64,
}

/// What the scheduler hands a running job.
pub struct Context<'a> {
    /// The plan the job belongs to.
    pub plan: &'a Plan,
    /// The output folder.
    pub out: &'a Path,
    /// The group's shared dataset, when the group has one.
    pub shared: Option<&'a Materialised>,
    /// The rows of the jobs named in [`Inputs::Rows`] that succeeded, in plan order.
    pub inputs: Vec<(&'a dyn JobKind, &'a Rows)>,
}

/// Status of a finished job, as the table assembly records it.
pub struct Status<'a> {
    /// `Ok` or the error with its cause chain.
    pub error: Option<&'a str>,
    /// Wall time in seconds.
    pub elapsed_s: f64,
}

/// Every kind of job.
pub trait JobKind: Send + Sync {
    /// Readable, file-name-safe id (`held.alpha_h=0.5`, `calibration`).
    fn id(&self) -> &str;
    /// The kind's name (`analysis`, `synthesis`, `calibration`, `hypotheses`).
    fn kind(&self) -> &'static str;
    /// Canonical identity from which the seed is derived (made on demand where the job's
    /// fields give it: a plan of 100,000 jobs held 15 MB of identities).
    fn identity(&self) -> std::borrow::Cow<'_, str>;
    /// The job's seed (derived from the master seed and the identity); `None` for a job that
    /// draws no random numbers.
    fn seed(&self) -> Option<u64>;
    /// What the job reads.
    fn inputs(&self) -> Inputs;
    /// Peak memory and work of the job, from its validated parameters alone (nothing is
    /// allocated); the scheduler fails a job whose estimate exceeds the memory limit
    /// ([`crate::run::estimate::Estimate::exceeds`]) instead of running it ([`Estimate::SMALL`]
    /// for a small job).
    fn estimate(&self, plan: &Plan) -> Estimate;
    /// Everything besides kind, identity and seed that the job's result depends on, as text
    /// for its key in the job store ([`crate::run::store::key`]): its validated parameters and
    /// the plan-wide settings its rows read.
    fn key_material(&self, plan: &Plan) -> String;
    /// Files the job reads, whose content hashes go into its key.
    fn input_files(&self) -> Vec<PathBuf>;
    /// Materialises the dataset a group of jobs shares (called once per group with
    /// [`Inputs::Dataset`] `shared`; a job that reads none answers [`no_dataset`]).
    ///
    /// # Errors
    /// If the data cannot be made.
    fn materialise(&self) -> Result<Materialised>;
    /// Runs the job.
    ///
    /// # Errors
    /// Any failure of the job; it is recorded and the other jobs go on.
    fn run(&self, cx: &Context) -> Result<Rows>;
    /// The job's row of `jobs.parquet` (status, seeds, shape), or `None` for jobs of the run as
    /// a whole, which the manifest lists.
    fn status_row(&self, plan: &Plan, status: &Status) -> Option<Result<DataFrame>>;
    /// The fields of the job's entry in `manifest.json` beside its id, kind, identity, seed,
    /// status and timings (which the manifest takes from the trait and the outcome).
    fn manifest(&self) -> serde_json::Value;
}

/// [`JobKind::materialise`] of a job that reads no dataset: an error naming it.
///
/// # Errors
/// Always.
pub fn no_dataset(job: &dyn JobKind) -> Result<Materialised> {
    anyhow::bail!("job {} reads no dataset", job.id())
}
