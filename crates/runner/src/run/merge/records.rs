//! The merge's first pass, the records: every job's state in the store read (its record, not
//! its fragments), its files put in place, each table's layout learnt from the fragments'
//! shapes, the jobs that failed or are missing listed. Also a job's state as both passes read
//! it, and its status row in `jobs.parquet`.

use crate::io::results;
use crate::run::assembly;
use crate::run::jobs::{JobKind, Status};
use crate::run::plan::Plan;
use crate::run::store;
use crate::run::tables;
use crate::run::value::Run;
use anyhow::{Context, Result};
use polars::prelude::DataFrame;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// What the first pass learnt.
pub struct Records {
    /// Each table's layout: its widest fragment and its rows.
    pub layout: assembly::Layout,
    /// Bytes of each job's fragments (what reading it ahead holds), by job index.
    pub weight: Vec<u64>,
    /// Failed jobs (the missing among them): id and error.
    pub failed: Vec<(String, String)>,
    /// Jobs missing from the store.
    pub missing: Vec<String>,
}

/// Reads every job's record in plan order, 256 at a time on the pool: publishes a finished
/// job's files and notes its fragments' shapes in the layout. `unsaved`: the errors of jobs of
/// this process whose outcome could not be stored (failed, not missing).
///
/// # Errors
/// If a job's files cannot be put in place or its status row made.
pub fn read(run: &Run, out: &Path, unsaved: &HashMap<usize, String>) -> Result<Records> {
    let mut records = Records {
        layout: assembly::Layout::new(tables::table_names(run.plan)),
        weight: vec![0u64; run.jobs.len()],
        failed: vec![],
        missing: vec![],
    };
    let order: Vec<usize> = (0..run.jobs.len()).collect();
    for chunk in order.chunks(256) {
        let states: Vec<(State, Option<DataFrame>)> = chunk
            .par_iter()
            .map(|&i| {
                let state = state(out, &run.keys[i], unsaved.get(&i));
                if let State::Done(d) = &state {
                    store::publish(out, d).context("putting the jobs' files in place")?;
                }
                let row = status_row(run.plan, run.jobs[i], &state)?;
                Ok((state, row))
            })
            .collect::<Result<_>>()?;
        for (&i, (state, row)) in chunk.iter().zip(states) {
            records.note(i, run.id(i), state);
            if let Some(row) = row {
                records.layout.made(results::JOBS.name, &row);
            }
        }
    }
    Ok(records)
}

impl Records {
    /// Notes job `i`'s state: its fragments' shapes, or its failure.
    fn note(&mut self, i: usize, id: &str, state: State) {
        match state {
            State::Done(d) => {
                self.weight[i] = d.fragments.iter().map(|f| f.bytes).sum();
                for (n, f) in d.fragments.iter().enumerate() {
                    self.layout.stored(&f.table, f.columns, f.rows, i, n);
                }
            }
            State::Failed(error, _) => self.failed.push((id.to_string(), error)),
            State::Missing(why) => {
                self.missing.push(id.to_string());
                self.failed.push((id.to_string(), missing_error(why)));
            }
        }
    }
}

/// A job's state in the store, as the merge reads it.
pub enum State {
    /// Its record (files not hashed again).
    Done(Box<store::Done>),
    /// Failed: the error and the wall time.
    Failed(String, f64),
    /// Not in the store: the reason where a record does not verify.
    Missing(Option<String>),
}

/// The state of the job with `key`; `unsaved`: the error of a job of this process whose
/// outcome could not be stored.
pub fn state(out: &Path, key: &str, unsaved: Option<&String>) -> State {
    match store::entry_verified_earlier(out, key) {
        store::Entry::Done(d) => State::Done(Box::new(d)),
        store::Entry::Failed(f) => State::Failed(f.error, f.elapsed_s),
        store::Entry::Missing(_) if unsaved.is_some() => {
            State::Failed(unsaved.cloned().unwrap_or_default(), 0.0)
        }
        store::Entry::Missing(why) => State::Missing(why),
    }
}

/// The error a job missing from the store gets in the tables of a partial merge.
pub fn missing_error(why: Option<String>) -> String {
    format!(
        "missing from the job store (merged with --partial){}",
        why.map(|w| format!(": {w}")).unwrap_or_default()
    )
}

/// The status row of a job in `jobs.parquet` (jobs of the run as a whole have none).
///
/// # Errors
/// If the row cannot be made.
pub fn status_row(plan: &Plan, job: &dyn JobKind, state: &State) -> Result<Option<DataFrame>> {
    let missing;
    let (error, elapsed_s) = match state {
        State::Done(d) => (None, d.elapsed_s),
        State::Failed(e, s) => (Some(e.as_str()), *s),
        State::Missing(why) => {
            missing = missing_error(why.clone());
            (Some(missing.as_str()), 0.0)
        }
    };
    job.status_row(plan, &Status { error, elapsed_s })
        .transpose()
}
