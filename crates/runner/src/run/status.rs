//! `status OUT`: the jobs of a folder's plan, one line each with its shard and its state in
//! the job store (done, failed, damaged, missing), then the counts per shard and whether the
//! tables are merged.

use crate::run::jobs::all::AllJobs;
use crate::run::{record, store};
use anyhow::Result;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

/// One line per job of a folder's plan: id, shard, state (`done`, `failed`, `missing`) and the
/// error or reason; then the counts per shard.
///
/// # Errors
/// If the folder's spec cannot be loaded.
pub fn list(out: &Path) -> Result<String> {
    let (plan, record) = record::load(out)?;
    let all = AllJobs::new(&plan);
    let jobs = all.list();
    let shards = record.shards.unwrap_or(1);
    let assigned = store::assign(&plan, &jobs, shards)?;
    let mut text = String::new();
    let mut counts = vec![[0usize; 3]; shards];
    let width = jobs.iter().map(|j| j.id().len()).max().unwrap_or(3).max(3);
    writeln!(text, "{:<width$}  shard  state    detail", "job")?;
    // Every entry verified on the pool (each hashes the job's files).
    let states: Vec<(&str, String, usize)> = (0..jobs.len())
        .into_par_iter()
        .map(|i| {
            let key = store::key(jobs[i], &plan)?;
            Ok(match store::entry(out, &key) {
                store::Entry::Done(d) => ("done", format!("{:.2} s", d.elapsed_s), 0),
                store::Entry::Failed(f) => ("failed", f.error, 1),
                // A stored result that does not verify: the next run or merge redoes it.
                store::Entry::Missing(Some(why)) => ("damaged", why, 2),
                store::Entry::Missing(None) => ("missing", String::new(), 2),
            })
        })
        .collect::<Result<_>>()?;
    for ((i, job), (state, detail, n)) in jobs.iter().enumerate().zip(states) {
        let shard = match assigned[i] {
            Some(s) => {
                counts[s][n] += 1;
                s.to_string()
            }
            None => "merge".into(),
        };
        writeln!(
            text,
            "{:<width$}  {shard:<5}  {state:<7}  {detail}",
            job.id()
        )?;
    }
    for (s, [d, f, m]) in counts.iter().enumerate() {
        writeln!(
            text,
            "shard {s}/{shards}: {d} done, {f} failed, {m} missing"
        )?;
    }
    let complete = crate::io::outdir::check_complete(out).is_ok();
    writeln!(
        text,
        "{}",
        if complete {
            "merged: the tables and the manifest are complete"
        } else {
            "not merged: run `isar-clutter merge` once every shard is done"
        }
    )?;
    Ok(text)
}
