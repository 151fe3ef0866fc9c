//! The merge's second pass, the rows: every table and the manifest's jobs streamed from the
//! job store's packs in plan order. The next chunk of jobs is read on the pool while this
//! thread appends the current one (and encodes the row groups it completes); memory holds the
//! jobs in flight and one row group per table, not the run.

use super::records::{self, missing_error, status_row, Records, State};
use crate::io::parquet::write_parquet;
use crate::io::results::{self, check_columns};
use crate::run::jobs::{JobKind, Status};
use crate::run::manifest::{self, Manifest};
use crate::run::plan::Plan;
use crate::run::value::Run;
use crate::run::{assembly, store, tables};
use anyhow::{bail, Context, Result};
use polars::prelude::DataFrame;
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// What the second pass wrote.
pub struct Streamed {
    /// The manifest, its jobs written, its files and end still to come.
    pub manifest: Manifest,
    /// Each table written by its sink, by name: its SHA-256 (hashed as it was written).
    pub hashes: BTreeMap<String, String>,
    /// Stored results that another build of the tool computed: how many and the first build,
    /// as a note (`None`: all this build's).
    pub other_builds: Option<String>,
}

/// Streams every table and the manifest's jobs from the store in plan order. `unsaved`: the
/// errors of jobs of this process whose outcome could not be stored.
///
/// # Errors
/// If a pack changed since the first pass, or a table or the manifest cannot be written.
pub fn stream(
    run: &Run,
    out: &Path,
    records: &Records,
    unsaved: &HashMap<usize, String>,
) -> Result<Streamed> {
    let (plan, jobs, threads) = (run.plan, &run.jobs, run.opts.threads);
    let mut sinks = assembly::Sinks::new(open_tables(run, out, &records.layout)?, threads > 1)?;
    let mut manifest = Manifest::start(plan, threads, out)?;
    let order: Vec<usize> = (0..jobs.len()).collect();
    let chunks = read_chunks(&order, &records.weight, (16 * threads).max(32), 8 << 20);
    let read = |chunk: &[usize]| -> Result<Vec<Loaded>> {
        chunk
            .par_iter()
            .map(|&i| load(plan, out, jobs[i], &run.keys[i], unsaved.get(&i)))
            .collect()
    };
    let mut next = chunks.first().map(|c| read(c)).transpose()?;
    // Stored results computed by another build of the tool (the store's keys do not hold the
    // tool's version): counted, and the first such build named.
    let this_build = manifest::build_commit();
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
    let other_builds = match other_builds {
        (n, Some(build)) => Some(format!(
            "{n} job(s) were merged from results a different build of the tool computed \
             (first: {build}; this build: {this_build}): the job store reuses a result whatever \
             the tool's version; `run --fresh` computes them again"
        )),
        _ => None,
    };
    Ok(Streamed {
        manifest,
        hashes,
        other_builds,
    })
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
        Ok(None) => records::state(out, key, unsaved),
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

/// The writers of the tables that have fragments (the others are written empty now, with
/// their columns), by name.
fn open_tables(
    run: &Run,
    out: &Path,
    layout: &assembly::Layout,
) -> Result<BTreeMap<String, assembly::Sink>> {
    let (plan, keys) = (run.plan, &run.keys);
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
