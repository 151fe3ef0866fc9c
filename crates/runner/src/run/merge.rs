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
use crate::io::parquet::write_parquet;
use crate::io::results::{self, check_columns};
use crate::run::jobs::all::AllJobs;
use crate::run::jobs::{Inputs, JobKind, Outcome, Status};
use crate::run::plan::{self, Plan};
use crate::run::scheduler::{self, RunOptions};
use crate::run::{assembly, manifest, store, tables};
use anyhow::{bail, Context, Result};
use polars::prelude::DataFrame;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
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
    /// The master seed given in place of the spec's (`run --seed`); `None`: the spec's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
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
        seed: plan.seed_override,
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
    let plan = plan::load_seeded(&record.spec_file, record.seed)
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
    let ran = scheduler::execute(&plan, &jobs, &keys, &[], &redo, opts, &None, false);
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

/// Merges the store of a claimed folder: runs the jobs that read other jobs' rows, reads every
/// job's record (publishing its files, learning each table's layout), streams the tables and
/// the manifest's jobs from the packs in plan order ([`crate::run::assembly`]), removes stale
/// files (never the store), ends the manifest and marks the folder complete. Memory holds the
/// jobs in flight and one row group per table, not the run.
///
/// `ran`: the outcomes of the jobs this process has just run (their rows are not used: every
/// row is read from the store); a job among them that failed and could not be stored counts as
/// failed with its error instead of missing. Every job's record is read from the store, but its
/// files are not hashed again: the caller has verified every entry under this claim
/// ([`store::entry`]: `run` before it decides what to redo, `merge` before it redoes the
/// damaged ones) or has just written it.
///
/// # Errors
/// If a job is missing and not `partial`, or a file cannot be read or written.
///
/// Long because the merge's steps (read the records, run the row jobs, publish files, stream the
/// tables and the manifest) share the claimed folder and its layout.
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
    let mut unsaved: HashMap<usize, String> = ran
        .into_iter()
        .filter_map(|(i, o)| o.rows.err().map(|e| (i, e)))
        .collect();
    // The jobs over other jobs' rows (cheap): run now, from the rows of the jobs they read.
    let second: Vec<usize> = (0..jobs.len())
        .filter(|&i| matches!(jobs[i].inputs(), Inputs::Rows(_)))
        .collect();
    if !second.is_empty() {
        let earlier = rows_read_by(out, jobs, keys, &second)?;
        let ran = scheduler::execute(plan, jobs, keys, &earlier, &second, opts, &None, false);
        unsaved.extend(
            ran.into_iter()
                .filter_map(|(i, o)| o.rows.err().map(|e| (i, e))),
        );
    }
    // Pass 1, the records: files put in place, the tables' layout, what failed or is missing.
    let mut layout = assembly::Layout::new(tables::table_names(plan));
    let order: Vec<usize> = (0..jobs.len()).collect();
    // Bytes of each job's fragments (what reading it ahead holds), for the chunks of pass 2.
    let mut weight = vec![0u64; jobs.len()];
    for chunk in order.chunks(256) {
        let states: Vec<(State, Option<DataFrame>)> = chunk
            .par_iter()
            .map(|&i| {
                let state = state(out, &keys[i], unsaved.get(&i));
                if let State::Done(d) = &state {
                    store::publish(out, d).context("putting the jobs' files in place")?;
                }
                let row = status_row(plan, jobs[i], &state)?;
                Ok((state, row))
            })
            .collect::<Result<_>>()?;
        for (&i, (state, row)) in chunk.iter().zip(states) {
            match state {
                State::Done(d) => {
                    weight[i] = d.fragments.iter().map(|f| f.bytes).sum();
                    for (n, f) in d.fragments.iter().enumerate() {
                        layout.stored(&f.table, f.columns, f.rows, i, n);
                    }
                }
                State::Failed(error, _) => merged.failed.push((jobs[i].id().to_string(), error)),
                State::Missing(why) => {
                    merged.missing.push(jobs[i].id().to_string());
                    merged
                        .failed
                        .push((jobs[i].id().to_string(), missing_error(why)));
                }
            }
            if let Some(row) = row {
                layout.made(results::JOBS.name, &row);
            }
        }
    }
    if !merged.missing.is_empty() && !partial {
        bail!("{}", missing_message(out, &merged.missing));
    }
    // Pass 2, the rows: every table and the manifest's jobs, streamed in plan order.
    let t_tables = Instant::now();
    let mut sinks = assembly::Sinks::new(open_tables(plan, out, keys, &layout)?, opts.threads > 1)?;
    let mut manifest = manifest::Manifest::start(plan, opts.threads, out)?;
    let chunks = read_chunks(&order, &weight, (16 * opts.threads).max(32), 8 << 20);
    let read = |chunk: &[usize]| -> Result<Vec<Loaded>> {
        chunk
            .par_iter()
            .map(|&i| load(plan, out, jobs[i], &keys[i], unsaved.get(&i)))
            .collect()
    };
    // The next chunk is read on the pool while this thread appends the current one (and
    // encodes the row groups it completes), so that neither waits for the other.
    let mut next = chunks.first().map(|c| read(c)).transpose()?;
    // Stored results computed by another build of the tool (the store's keys do not hold the
    // tool's version): counted, and the first such build named.
    let this_build = crate::run::manifest::build_commit();
    let mut other_builds: (usize, Option<String>) = (0, None);
    for (c, chunk) in chunks.iter().enumerate() {
        let loaded = next.take().expect("read ahead");
        let (ahead, appended) = rayon::join(
            || chunks.get(c + 1).map(|c| read(c)).transpose(),
            || -> Result<()> {
                for (&i, l) in chunk.iter().zip(loaded) {
                    for (table, df) in l.tables.into_iter().chain(l.status) {
                        sinks.push(&table, df)?;
                    }
                    let outcome = match &l.error {
                        Some(e) => Err(e.as_str()),
                        None => Ok(l.timing.as_ref()),
                    };
                    manifest.job(jobs[i], outcome, l.elapsed_s, l.built_by.as_deref())?;
                    if l.error.is_none() && l.built_by.as_deref() != Some(this_build.as_str()) {
                        other_builds.0 += 1;
                        other_builds.1.get_or_insert_with(|| {
                            l.built_by.clone().unwrap_or_else(|| "not recorded".into())
                        });
                    }
                }
                Ok(())
            },
        );
        appended?;
        next = ahead?;
        release_free_memory(c);
    }
    let hashes = sinks.finish()?;
    if let (n, Some(build)) = other_builds {
        merged.notes.push(format!(
            "{n} job(s) were merged from results a different build of the tool computed \
             (first: {build}; this build: {this_build}): the job store reuses a result whatever \
             the tool's version; `run --fresh` computes them again"
        ));
    }
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
    outdir.each_written(|rel| {
        if !rel.starts_with("jobs") && rel != Path::new("manifest.json") {
            // A table written by its sink was hashed as it was written.
            let written = rel
                .to_str()
                .and_then(|r| r.strip_suffix(".parquet"))
                .and_then(|name| hashes.get(name));
            manifest.file(out, rel, written.map(String::as_str))?;
        }
        Ok(())
    })?;
    manifest.finish((start.elapsed().as_secs_f64(), tables_s))?;
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

/// `order` cut into the chunks pass 2 reads ahead: consecutive jobs, at most `jobs` of them, and
/// no more than one job past `bytes` of fragments (`weight`, a job's). Tiny jobs are read 32 at a
/// time on two threads (8 at a time, the pool's threads met and woke each other 12,500 times in
/// a merge of 100,000: `futex` was a tenth of its CPU samples; 64 at a time held 30 MB more),
/// big ones one or a few at a time.
fn read_chunks<'a>(
    order: &'a [usize],
    weight: &[u64],
    jobs: usize,
    bytes: u64,
) -> Vec<&'a [usize]> {
    let mut chunks = vec![];
    let (mut start, mut held) = (0, 0u64);
    for (n, &i) in order.iter().enumerate() {
        held += weight[i];
        if n + 1 - start >= jobs || held >= bytes {
            chunks.push(&order[start..=n]);
            (start, held) = (n + 1, 0);
        }
    }
    if start < order.len() {
        chunks.push(&order[start..]);
    }
    chunks
}

/// Hands the allocator's free memory back to the system every 64 calls (`n` counts them):
/// fragments are decoded on the pool's threads and freed on this one, and glibc's per-thread
/// arenas kept what they freed, so the resident memory of a merge grew with its jobs (by
/// 30 MB a thousand tiny jobs) while its heap did not.
fn release_free_memory(n: usize) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    if n % 64 == 63 {
        // SAFETY: no arguments beyond the padding to keep; glibc's own locking.
        unsafe { libc::malloc_trim(0) };
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    let _ = n;
}

/// A job's state in the store, as the merge reads it.
enum State {
    /// Its record (files not hashed again).
    Done(Box<store::Done>),
    /// Failed: the error and the wall time.
    Failed(String, f64),
    /// Not in the store: the reason where a record does not verify.
    Missing(Option<String>),
}

/// The state of the job with `key`; `unsaved`: the error of a job of this process whose
/// outcome could not be stored.
fn state(out: &Path, key: &str, unsaved: Option<&String>) -> State {
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
fn missing_error(why: Option<String>) -> String {
    format!(
        "missing from the job store (merged with --partial){}",
        why.map(|w| format!(": {w}")).unwrap_or_default()
    )
}

/// The status row of a job in `jobs.parquet` (jobs of the run as a whole have none).
fn status_row(plan: &Plan, job: &dyn JobKind, state: &State) -> Result<Option<DataFrame>> {
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

/// What pass 2 needs of one job: its fragments (read from its pack), its status row, and its
/// manifest entry's outcome.
struct Loaded {
    tables: Vec<(String, DataFrame)>,
    status: Option<(String, DataFrame)>,
    error: Option<String>,
    timing: Option<serde_json::Value>,
    elapsed_s: f64,
    /// The build that computed a stored result (`None`: failed, or not recorded).
    built_by: Option<String>,
}

/// Reads one job for pass 2.
fn load(
    plan: &Plan,
    out: &Path,
    job: &dyn JobKind,
    key: &str,
    unsaved: Option<&String>,
) -> Result<Loaded> {
    let state = match store::read_pack(out, key) {
        Ok(Some((done, body))) => {
            let tables = (0..done.fragments.len())
                .map(|n| {
                    Ok((
                        done.fragments[n].table.clone(),
                        store::fragment(&done, &body, n)?,
                    ))
                })
                .collect::<Result<Vec<_>>>()?;
            let row = job.status_row(
                plan,
                &Status {
                    error: None,
                    elapsed_s: done.elapsed_s,
                },
            );
            return Ok(Loaded {
                tables,
                status: row
                    .transpose()?
                    .map(|df| (results::JOBS.name.to_string(), df)),
                error: None,
                timing: done.timing,
                elapsed_s: done.elapsed_s,
                built_by: done.built_by,
            });
        }
        Ok(None) => state(out, key, unsaved),
        Err(why) => bail!(
            "{}: the job store's result of {} changed during the merge: {why}; merge again",
            out.display(),
            job.id()
        ),
    };
    let row = status_row(plan, job, &state)?;
    let (error, elapsed_s) = match state {
        State::Failed(e, s) => (e, s),
        State::Missing(why) => (missing_error(why), 0.0),
        State::Done(_) => unreachable!("a pack was read above"),
    };
    Ok(Loaded {
        tables: vec![],
        status: row.map(|df| (results::JOBS.name.to_string(), df)),
        error: Some(error),
        timing: None,
        elapsed_s,
        built_by: None,
    })
}

/// The rows of the jobs that `second`'s jobs read, loaded from the store (the others `None`).
fn rows_read_by(
    out: &Path,
    jobs: &[&dyn JobKind],
    keys: &[String],
    second: &[usize],
) -> Result<Vec<Option<Outcome>>> {
    let mut earlier: Vec<Option<Outcome>> = (0..jobs.len()).map(|_| None).collect();
    for &i in second {
        let Inputs::Rows(from) = jobs[i].inputs() else {
            continue;
        };
        for k in from {
            if earlier[k].is_some() {
                continue;
            }
            if let store::Entry::Done(d) = store::entry_verified_earlier(out, &keys[k]) {
                earlier[k] = Some(Outcome {
                    rows: Ok(store::load_rows(out, &d)?),
                    elapsed_s: d.elapsed_s,
                });
            }
        }
    }
    Ok(earlier)
}

/// The writers of the tables that have fragments (the others are written empty now, with
/// their columns), by name.
fn open_tables(
    plan: &Plan,
    out: &Path,
    keys: &[String],
    layout: &assembly::Layout,
) -> Result<BTreeMap<String, assembly::Sink>> {
    let mut sinks = BTreeMap::new();
    for t in &layout.tables {
        let widest = match &t.widest {
            None => {
                let mut df = tables::empty(plan, &t.name)?;
                check_columns(
                    &t.name,
                    df.get_column_names().into_iter().map(|n| n.as_str()),
                    &plan.param_keys,
                )?;
                write_parquet(&out.join(format!("{}.parquet", t.name)), &mut df)?;
                continue;
            }
            Some(assembly::Widest::Made(df)) => df.clone(),
            Some(assembly::Widest::Stored { job, index }) => {
                let (done, body) = store::read_pack(out, &keys[*job])
                    .map_err(|why| anyhow::anyhow!("{}: {why}", out.display()))?
                    .with_context(|| {
                        format!("{}: a job's result went during the merge", out.display())
                    })?;
                store::fragment(&done, &body, *index)?.clear()
            }
        };
        check_columns(
            &t.name,
            widest.get_column_names().into_iter().map(|n| n.as_str()),
            &plan.param_keys,
        )?;
        if t.rows == 0 {
            // Fragments without rows: the table is their widest columns.
            write_parquet(
                &out.join(format!("{}.parquet", t.name)),
                &mut widest.clone(),
            )?;
            continue;
        }
        sinks.insert(
            t.name.clone(),
            assembly::Sink::new(out, &t.name, &widest, t.rows)?,
        );
    }
    Ok(sinks)
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

#[cfg(test)]
mod tests {
    use super::read_chunks;

    #[test]
    fn read_chunks_cover_the_order_bounded_by_jobs_and_bytes() {
        let order: Vec<usize> = (0..10).collect();
        let weight = [1, 1, 1, 50, 1, 1, 1, 1, 1, 1];
        let chunks = read_chunks(&order, &weight, 4, 10);
        assert_eq!(
            chunks,
            vec![&[0, 1, 2, 3][..], &[4, 5, 6, 7][..], &[8, 9][..]]
        );
        let chunks = read_chunks(&order, &weight, 100, 3);
        assert_eq!(
            chunks,
            vec![&[0, 1, 2][..], &[3][..], &[4, 5, 6][..], &[7, 8, 9][..]]
        );
        assert!(read_chunks(&[], &[], 4, 10).is_empty());
    }
}
