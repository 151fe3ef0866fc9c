//! From the job store to the results: `merge` reads every job's record and fragments from
//! `OUT/jobs/<key>/`, runs the jobs that read other jobs' rows (the hypothesis tests), puts the
//! jobs' files in place (hard links), assembles the tables, removes what an earlier run wrote
//! and this one has not, and writes the manifest last. `run` without shards ends with the same
//! merge, so both paths share one table assembly. `status` lists each job's state per shard.
//!
//! The folder remembers its spec in `.isar-clutter/plan.json` (the spec file's absolute path,
//! its SHA-256, the schema and the shard count), so that `merge OUT` and `status OUT` need
//! nothing else, and refuse when the spec changed since the shards ran.

use crate::io::outdir::{OutDir, Purpose, STATE};
use crate::run::jobs::all::AllJobs;
use crate::run::jobs::{Inputs, JobKind, Outcome, Rows};
use crate::run::plan::{self, Plan};
use crate::run::scheduler::{self, RunOptions};
use crate::run::{manifest, store};
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What `.isar-clutter/plan.json` records.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlanRecord {
    /// The spec file, absolute.
    pub spec_file: PathBuf,
    /// SHA-256 of the spec file when the jobs ran.
    pub spec_hash: String,
    /// [`store::SCHEMA`].
    pub schema: u32,
    /// Shards of the last sharded run (`None`: a run of every job).
    pub shards: Option<usize>,
}

/// Records the spec of a run in its folder.
///
/// # Errors
/// If the spec path cannot be resolved or the record written.
pub fn record_plan(out: &Path, plan: &Plan, shards: Option<usize>) -> Result<()> {
    let record = PlanRecord {
        spec_file: std::path::absolute(&plan.file)
            .with_context(|| format!("resolving {}", plan.file.display()))?,
        spec_hash: plan.spec_hash.clone(),
        schema: store::SCHEMA,
        shards,
    };
    crate::io::atomic::atomic_write(&out.join(STATE).join("plan.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &record)?;
        Ok(())
    })
}

/// The plan of a folder's run, loaded from its recorded spec.
///
/// # Errors
/// If the folder has no record (not a run's folder), the spec cannot be loaded, or it changed
/// since the jobs ran.
pub fn load_plan(out: &Path) -> Result<(Plan, PlanRecord)> {
    let path = out.join(STATE).join("plan.json");
    let text = std::fs::read(&path).with_context(|| {
        format!(
            "{} holds no run of isar-clutter (no {STATE}/plan.json)",
            out.display()
        )
    })?;
    let record: PlanRecord =
        serde_json::from_slice(&text).with_context(|| format!("reading {}", path.display()))?;
    if record.schema != store::SCHEMA {
        bail!(
            "{}: its jobs were stored with schema {} by another version of the tool (this one \
             reads {}); rerun them with this version",
            out.display(),
            record.schema,
            store::SCHEMA
        );
    }
    let plan = plan::load(&record.spec_file)
        .with_context(|| format!("loading the spec of {}", out.display()))?;
    if plan.spec_hash != record.spec_hash {
        bail!(
            "{} changed since the jobs of {} ran: rerun them with this spec (`run` resumes what \
             still holds), or restore the spec they ran with",
            record.spec_file.display(),
            out.display()
        );
    }
    Ok((plan, record))
}

/// What a merge did.
#[derive(Debug, Clone, Default)]
pub struct Merged {
    /// Failed jobs: id and error.
    pub failed: Vec<(String, String)>,
    /// Jobs missing from the store (merged with `partial` only).
    pub missing: Vec<String>,
    /// Things worth saying.
    pub notes: Vec<String>,
}

/// `merge OUT`: claims the folder and merges its store.
///
/// # Errors
/// As [`merge_claimed`]; also if the folder's spec cannot be loaded or changed.
pub fn merge(out: &Path, opts: &RunOptions, partial: bool) -> Result<Merged> {
    let start = Instant::now();
    let (plan, _) = load_plan(out)?;
    let all = AllJobs::new(&plan);
    let jobs = all.list();
    let keys: Vec<String> = jobs
        .iter()
        .map(|j| store::key(*j, &plan))
        .collect::<Result<_>>()?;
    // Refuse before touching anything when jobs are missing.
    if !partial {
        let missing = missing_jobs(out, &jobs, &keys);
        if !missing.is_empty() {
            bail!("{}", missing_message(out, &missing));
        }
    }
    let outdir = OutDir::claim(out, Some(&plan.spec.name), Purpose::Run)?;
    // The folder is ours now (no shard is writing): a job whose stored result does not verify
    // (damaged, or changed since) is run again here rather than merged.
    let mut damaged = vec![];
    let redo: Vec<usize> = (0..jobs.len())
        .filter(|&i| !matches!(jobs[i].inputs(), Inputs::Rows(_)))
        .filter(|&i| match store::entry(out, &keys[i]) {
            store::Entry::Missing(Some(why)) => {
                damaged.push(format!("{} ({why})", jobs[i].id()));
                true
            }
            _ => false,
        })
        .collect();
    let ran = scheduler::execute(&plan, &jobs, &keys, &[], &redo, opts, &None, true);
    let mut merged = merge_claimed(&plan, &jobs, &keys, &outdir, opts, partial, start, ran)?;
    if !damaged.is_empty() {
        merged.notes.insert(0, store::damaged_note(&damaged));
    }
    merged.notes.splice(0..0, outdir.notes.iter().cloned());
    Ok(merged)
}

/// The ids of the jobs (run by shards, not at the merge) whose result the store lacks.
fn missing_jobs(out: &Path, jobs: &[&dyn JobKind], keys: &[String]) -> Vec<String> {
    jobs.iter()
        .zip(keys)
        .filter(|(j, _)| !matches!(j.inputs(), Inputs::Rows(_)))
        // A stored result that does not verify is redone by the merge itself.
        .filter(|(_, k)| {
            matches!(
                store::entry_verified_earlier(out, k),
                store::Entry::Missing(None)
            )
        })
        .map(|(j, _)| j.id().to_string())
        .collect()
}

fn missing_message(out: &Path, missing: &[String]) -> String {
    let shown: Vec<&str> = missing.iter().take(20).map(String::as_str).collect();
    format!(
        "{} lacks {} job(s): {}{}; run their shards (see `isar-clutter status {}`), or merge \
         what is there with --partial",
        out.display(),
        missing.len(),
        shown.join(", "),
        if missing.len() > 20 { ", ..." } else { "" },
        out.display()
    )
}

/// Merges the store of a claimed folder: reads every job's outcome, runs the jobs that read
/// other jobs' rows, publishes the files, writes the tables, removes stale files (never the
/// store), writes the manifest and marks the folder complete. `ran`: the outcomes of the jobs
/// this process has just run and stored, whose rows are taken as they are instead of read back
/// from their fragments (the same rows); every job's record is read from the store all the
/// same, but its files are not hashed again: the caller has verified every entry under this
/// claim ([`store::entry`]: `run` before it decides what to redo, `merge` before it redoes the
/// damaged ones) or has just written it.
///
/// # Errors
/// If a job is missing and not `partial`, or a file cannot be read or written.
#[allow(clippy::too_many_arguments)]
pub fn merge_claimed(
    plan: &Plan,
    jobs: &[&dyn JobKind],
    keys: &[String],
    outdir: &OutDir,
    opts: &RunOptions,
    partial: bool,
    start: Instant,
    ran: Vec<(usize, Outcome)>,
) -> Result<Merged> {
    let out = outdir.root();
    let mut merged = Merged::default();
    let mut kept: Vec<Option<Rows>> = (0..jobs.len()).map(|_| None).collect();
    for (i, o) in ran {
        kept[i] = o.rows.ok();
    }
    let mut outcomes: Vec<Option<Outcome>> = (0..jobs.len()).map(|_| None).collect();
    let mut done = vec![];
    let mut second = vec![];
    for (i, job) in jobs.iter().enumerate() {
        if matches!(job.inputs(), Inputs::Rows(_)) {
            second.push(i);
            continue;
        }
        // Verified under this claim already (see above), or written by this process.
        outcomes[i] = Some(match store::entry_verified_earlier(out, &keys[i]) {
            store::Entry::Done(d) => {
                let rows = match kept[i].take() {
                    // As `load_rows` gives them: the files as the record lists them.
                    Some(rows) => Rows {
                        files: d.files.keys().map(PathBuf::from).collect(),
                        ..rows
                    },
                    None => store::load_rows(out, &d)?,
                };
                let o = Outcome {
                    rows: Ok(rows),
                    elapsed_s: d.elapsed_s,
                };
                done.push(d);
                o
            }
            store::Entry::Failed(f) => Outcome {
                rows: Err(f.error),
                elapsed_s: f.elapsed_s,
            },
            store::Entry::Missing(why) => {
                merged.missing.push(job.id().to_string());
                Outcome {
                    rows: Err(format!(
                        "missing from the job store (merged with --partial){}",
                        why.map(|w| format!(": {w}")).unwrap_or_default()
                    )),
                    elapsed_s: 0.0,
                }
            }
        });
    }
    if !merged.missing.is_empty() && !partial {
        bail!("{}", missing_message(out, &merged.missing));
    }
    // The jobs over other jobs' rows (cheap): run now, from the merged rows.
    let ran = scheduler::execute(plan, jobs, keys, &outcomes, &second, opts, &None, true);
    for (i, o) in ran {
        if let store::Entry::Done(d) = store::entry_verified_earlier(out, &keys[i]) {
            done.push(d);
        }
        outcomes[i] = Some(o);
    }
    let outcomes: Vec<Outcome> = outcomes
        .into_iter()
        .map(|o| o.expect("every job has an outcome"))
        .collect();
    done.par_iter()
        .try_for_each(|d| store::publish(out, d))
        .context("putting the jobs' files in place")?;
    let t_tables = Instant::now();
    let run_opts = RunOptions {
        out: out.to_path_buf(),
        ..opts.clone()
    };
    scheduler::write_tables(plan, jobs, &outcomes, &run_opts)?;
    let tables_s = t_tables.elapsed().as_secs_f64();
    // Everything an earlier run wrote that this one did not (the store stays: its keys are a
    // cache that a later run of an earlier spec reads again; so do the figures when a report
    // follows: it draws again only those whose inputs changed). An earlier report's page goes
    // in any case (a report that follows writes it again from this run's files); it is not
    // counted.
    let page = Path::new("report.html");
    let had_page = out.join(page).is_file();
    let cache = |p: &Path| p.starts_with("jobs") || opts.report_follows && p.starts_with("figures");
    let removed = outdir.remove_stale(|p| p == page || !cache(p))?;
    let stale = removed.saturating_sub(usize::from(had_page && !out.join(page).exists()));
    if stale > 0 {
        merged.notes.push(format!(
            "removed {stale} file(s) an earlier run wrote that this run does not have"
        ));
    }
    merged.failed = jobs
        .iter()
        .zip(&outcomes)
        .filter_map(|(job, o)| {
            o.rows
                .as_ref()
                .err()
                .map(|e| (job.id().to_string(), e.clone()))
        })
        .collect();
    let written: Vec<PathBuf> = outdir
        .written()
        .into_iter()
        .filter(|p| !p.starts_with("jobs"))
        .collect();
    manifest::write(
        plan,
        jobs,
        &outcomes,
        opts.threads,
        out,
        (start.elapsed().as_secs_f64(), tables_s),
        &written,
    )?;
    if merged.missing.is_empty() {
        outdir.complete()?;
    } else {
        let shown: Vec<&str> = merged.missing.iter().take(10).map(String::as_str).collect();
        outdir.mark_incomplete(&format!(
            "merged with --partial while {} job(s) were missing from the job store ({}{})",
            merged.missing.len(),
            shown.join(", "),
            if merged.missing.len() > 10 {
                ", ..."
            } else {
                ""
            }
        ))?;
        merged.notes.push(format!(
            "{} job(s) missing: the folder stays marked incomplete (`table` and `report` need \
             --allow-incomplete)",
            merged.missing.len()
        ));
    }
    Ok(merged)
}

/// One line per job of a folder's plan: id, shard, state (`done`, `failed`, `missing`) and the
/// error or reason; then the counts per shard.
///
/// # Errors
/// If the folder's spec cannot be loaded.
pub fn status(out: &Path) -> Result<String> {
    use std::fmt::Write as _;
    let (plan, record) = load_plan(out)?;
    let all = AllJobs::new(&plan);
    let jobs = all.list();
    let shards = record.shards.unwrap_or(1);
    let assigned = store::assign(&plan, &jobs, shards)?;
    let mut text = String::new();
    let mut counts = vec![[0usize; 3]; shards];
    let width = jobs.iter().map(|j| j.id().len()).max().unwrap_or(3).max(3);
    writeln!(text, "{:<width$}  shard  state    detail", "job")?;
    for (i, job) in jobs.iter().enumerate() {
        let key = store::key(*job, &plan)?;
        let (state, detail, n) = match store::entry(out, &key) {
            store::Entry::Done(d) => ("done", format!("{:.2} s", d.elapsed_s), 0),
            store::Entry::Failed(f) => ("failed", f.error, 1),
            // A stored result that does not verify: the next run or merge redoes it.
            store::Entry::Missing(Some(why)) => ("damaged", why, 2),
            store::Entry::Missing(None) => ("missing", String::new(), 2),
        };
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
