//! From the job store to the results: `merge` reads every job's record and fragments from
//! `OUT/jobs/<key>/`, runs the jobs that read other jobs' rows (the hypothesis tests, the
//! location summary), puts the jobs' files in place (hard links), assembles the tables, removes
//! what an earlier run wrote and this one has not, and writes the manifest last. `run` without
//! shards ends with the same merge ([`Run::merge_claimed`]), so both paths share one table
//! assembly. The passes are children: [`records`] (the records, the files, the tables' layout)
//! and [`rows`] (the tables and the manifest's jobs, streamed).

pub mod records;
pub mod rows;

use crate::io::outdir::{OutDir, Purpose};
use crate::run::jobs::all::AllJobs;
use crate::run::jobs::{Inputs, Outcome};
use crate::run::options::RunOptions;
use crate::run::value::Run;
use crate::run::{record, store};
use anyhow::{bail, Result};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::time::Instant;

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

/// `merge OUT` (`opts.out`): claims the folder and merges its store, first running again the
/// jobs whose stored result does not verify.
///
/// # Errors
/// As [`Run::merge_claimed`]; also if the folder's spec cannot be loaded or changed, or (not
/// `partial`) jobs are missing from the store.
pub fn merge(opts: &RunOptions, partial: bool) -> Result<Merged> {
    let start = Instant::now();
    let out = opts.out.as_path();
    let (plan, rec) = record::load(out)?;
    let sharded = rec.shards.is_some();
    let all = AllJobs::new(&plan);
    let run = Run::new(&plan, &all, opts)?;
    // Refuse before touching anything when jobs are missing.
    if !partial {
        let missing = run.missing_jobs();
        if !missing.is_empty() {
            bail!("{}", missing_message(out, &missing, sharded));
        }
    }
    let outdir = OutDir::claim(out, Some(&plan.spec.name), Purpose::Run)?;
    // The folder is ours now (no shard is writing): a job whose stored result does not verify
    // (damaged, or changed since) is run again here rather than merged.
    let mut damaged = vec![];
    let redo: Vec<usize> = (0..run.jobs.len())
        .filter(|&i| !run.reads_rows(i))
        .filter(|&i| match store::entry(out, &run.keys[i]) {
            store::Entry::Missing(Some(why)) => {
                damaged.push(format!("{} ({why})", run.id(i)));
                true
            }
            _ => false,
        })
        .collect();
    let ran = run.execute(&redo, &[], None);
    let mut merged = run.merge_claimed(&outdir, partial, start, ran)?;
    if !damaged.is_empty() {
        merged.notes.insert(0, store::damaged_note(&damaged));
    }
    merged.notes.splice(0..0, outdir.notes.iter().cloned());
    Ok(merged)
}

/// What to do about jobs missing from the store: run their shards when the folder's last run
/// was sharded, otherwise run the spec into it again (which resumes from the store).
fn missing_message(out: &Path, missing: &[String], sharded: bool) -> String {
    let shown: Vec<&str> = missing.iter().take(20).map(String::as_str).collect();
    let advice = if sharded {
        format!(
            "run their shards (see `isar-clutter status {}`)",
            out.display()
        )
    } else {
        format!(
            "run the spec into it again (`isar-clutter run SPEC --out {}` resumes from its \
             job store)",
            out.display()
        )
    };
    format!(
        "{} lacks {} job(s): {}{}; {advice}, or merge what is there with --partial",
        out.display(),
        missing.len(),
        shown.join(", "),
        if missing.len() > 20 { ", ..." } else { "" },
    )
}

impl Run<'_> {
    /// The ids of the jobs (run by shards, not at the merge) whose result the store lacks.
    pub fn missing_jobs(&self) -> Vec<String> {
        (0..self.jobs.len())
            .filter(|&i| !self.reads_rows(i))
            // A stored result that does not verify is redone by the merge itself.
            .filter(|&i| {
                matches!(
                    store::entry_verified_earlier(self.out(), &self.keys[i]),
                    store::Entry::Missing(None)
                )
            })
            .map(|i| self.id(i).to_string())
            .collect()
    }

    /// Merges the store of a claimed folder: runs the jobs that read other jobs' rows, reads
    /// every job's record (publishing its files, learning each table's layout:
    /// [`records::read`]), streams the tables and the manifest's jobs from the packs in plan
    /// order ([`rows::stream`]), removes stale files (never the store), ends the manifest and
    /// marks the folder complete.
    ///
    /// `ran`: the outcomes of the failed jobs this process has just run (every row is read from
    /// the store); one that could not be stored counts as failed with its error instead of
    /// missing. Every job's record is read from the store, but its files are not hashed again:
    /// the caller has verified every entry under this claim ([`store::entry`]: `run` before it
    /// decides what to redo, `merge` before it redoes the damaged ones) or has just written it.
    ///
    /// # Errors
    /// If a job is missing and not `partial`, or a file cannot be read or written.
    pub fn merge_claimed(
        &self,
        outdir: &OutDir,
        partial: bool,
        start: Instant,
        ran: Vec<(usize, Outcome)>,
    ) -> Result<Merged> {
        let out = outdir.root();
        let mut unsaved: HashMap<usize, String> = failures(ran);
        unsaved.extend(self.run_row_jobs()?);
        let mut records = records::read(self, out, &unsaved)?;
        let mut merged = Merged {
            failed: std::mem::take(&mut records.failed),
            missing: std::mem::take(&mut records.missing),
            notes: vec![],
        };
        if !merged.missing.is_empty() && !partial {
            let sharded = record::load(out).is_ok_and(|(_, r)| r.shards.is_some());
            bail!("{}", missing_message(out, &merged.missing, sharded));
        }
        let t_tables = Instant::now();
        let streamed = rows::stream(self, out, &records, &unsaved)?;
        merged.notes.extend(streamed.other_builds);
        let tables_s = t_tables.elapsed().as_secs_f64();
        let mut manifest = streamed.manifest;
        if self.plan.spec.outputs.zarr_maps {
            merged.notes.extend(self.pack_maps(out)?);
        }
        merged.notes.extend(self.remove_stale(outdir)?);
        outdir.each_written(|rel| {
            if !rel.starts_with("jobs") && rel != Path::new("manifest.json") {
                manifest.file(out, rel, written_hash(&streamed.hashes, rel))?;
            }
            Ok(())
        })?;
        manifest.finish((start.elapsed().as_secs_f64(), tables_s))?;
        if merged.missing.is_empty() {
            outdir.complete()?;
        } else {
            merged.notes.push(mark_incomplete(outdir, &merged.missing)?);
        }
        Ok(merged)
    }

    /// Runs the jobs over other jobs' rows (cheap) from the rows of the jobs they read, loaded
    /// from the store. The errors of those that failed and could not be stored.
    fn run_row_jobs(&self) -> Result<Vec<(usize, String)>> {
        let second: Vec<usize> = (0..self.jobs.len())
            .filter(|&i| self.reads_rows(i))
            .collect();
        if second.is_empty() {
            return Ok(vec![]);
        }
        let mut earlier: Vec<Option<Outcome>> = (0..self.jobs.len()).map(|_| None).collect();
        for &i in &second {
            let Inputs::Rows(from) = self.jobs[i].inputs() else {
                continue;
            };
            for k in from {
                if earlier[k].is_some() {
                    continue;
                }
                let entry = store::entry_verified_earlier(self.out(), &self.keys[k]);
                if let store::Entry::Done(d) = entry {
                    earlier[k] = Some(Outcome {
                        rows: Ok(store::load_rows(self.out(), &d)?),
                        elapsed_s: d.elapsed_s,
                    });
                }
            }
        }
        Ok(failures(self.execute(&second, &earlier, None))
            .into_iter()
            .collect())
    }

    /// Removes everything an earlier run wrote that this one did not (the store stays: its
    /// keys are a cache that a later run of an earlier spec reads again; so do the figures when
    /// a report follows: it draws again only those whose inputs changed). An earlier report's
    /// page goes in any case (a report that follows writes it again from this run's files); it
    /// is not counted. The note saying how many went, if any.
    /// Packs every dataset job's staged maps into `maps.zarr` (`outputs: {zarr_maps: true}`);
    /// a note naming the jobs without maps (failed ones), if any.
    fn pack_maps(&self, out: &Path) -> Result<Option<String>> {
        use crate::io::results::files;
        let jobs: Vec<(String, std::path::PathBuf)> = (self.plan.jobs.iter())
            .map(|j| (j.id.clone(), files::staged_maps(out, &j.id)))
            .collect();
        let attributes = serde_json::json!({
            "spec": self.plan.spec.name,
            "master_seed": self.plan.spec.seed,
            "levels": self.plan.spec.analysis.levels,
        });
        let packed = crate::io::zarr::pack(&files::maps_zarr(out), &jobs, attributes)?;
        Ok((!packed.missing.is_empty()).then(|| {
            let shown: Vec<&str> = packed.missing.iter().take(5).map(String::as_str).collect();
            format!(
                "maps.zarr: {} job(s) have no maps (their chunks are NaN): {}",
                packed.missing.len(),
                shown.join(", ")
            )
        }))
    }

    fn remove_stale(&self, outdir: &OutDir) -> Result<Option<String>> {
        let out = outdir.root();
        let page = Path::new("report.html");
        let had_page = out.join(page).is_file();
        let report_follows = self.opts.report_follows;
        let cache = |p: &Path| p.starts_with("jobs") || report_follows && p.starts_with("figures");
        let removed = outdir.remove_stale(|p| p == page || !cache(p))?;
        let stale = removed.saturating_sub(usize::from(had_page && !out.join(page).exists()));
        Ok((stale > 0).then(|| {
            format!("removed {stale} file(s) an earlier run wrote that this run does not have")
        }))
    }
}

/// The errors of the failed outcomes, by job index.
fn failures(ran: Vec<(usize, Outcome)>) -> HashMap<usize, String> {
    ran.into_iter()
        .filter_map(|(i, o)| o.rows.err().map(|e| (i, e)))
        .collect()
}

/// The SHA-256 of a table its sink wrote (hashed as it was written), for the file `rel`.
fn written_hash<'h>(hashes: &'h BTreeMap<String, String>, rel: &Path) -> Option<&'h str> {
    rel.to_str()
        .and_then(|r| r.strip_suffix(".parquet"))
        .and_then(|name| hashes.get(name))
        .map(String::as_str)
}

/// Marks a folder merged with jobs missing as incomplete; the note saying so.
fn mark_incomplete(outdir: &OutDir, missing: &[String]) -> Result<String> {
    let shown: Vec<&str> = missing.iter().take(10).map(String::as_str).collect();
    outdir.mark_incomplete(&format!(
        "merged with --partial while {} job(s) were missing from the job store ({}{})",
        missing.len(),
        shown.join(", "),
        if missing.len() > 10 { ", ..." } else { "" }
    ))?;
    Ok(format!(
        "{} job(s) missing: the folder stays marked incomplete (`table` and `report` need \
         --allow-incomplete)",
        missing.len()
    ))
}

#[cfg(test)]
mod tests {
    #[test]
    fn missing_jobs_are_advised_by_how_the_folder_was_run() {
        let out = std::path::Path::new("/r/out");
        let missing = vec!["a".to_string(), "b".to_string()];
        let sharded = super::missing_message(out, &missing, true);
        assert!(
            sharded.contains(
                "lacks 2 job(s): a, b; run their shards (see `isar-clutter status /r/out`)"
            ),
            "{sharded}"
        );
        let whole = super::missing_message(out, &missing, false);
        assert!(
            !whole.contains("shard")
                && whole.contains("`isar-clutter run SPEC --out /r/out` resumes"),
            "{whole}"
        );
    }
}
