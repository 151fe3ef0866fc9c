//! `manifest.json`: the provenance of a run (tool, git state at build time, the spec and its
//! hash, the master seed and how every seed derives from it, threads, timings) and every job
//! with its identity, seeds, status, error and timings; written as a stream, job by job.

use crate::io::atomic::Staged;
use crate::io::manifest as format;
use crate::run::jobs::JobKind;
use crate::run::plan::Plan;
use anyhow::Result;
use std::io::Write;
use std::path::Path;

/// The commit the binary was built from, `+dirty` when the tree had changes (`unknown`
/// outside git).
pub fn build_commit() -> String {
    match (
        env!("ISAR_CLUTTER_GIT_COMMIT"),
        env!("ISAR_CLUTTER_GIT_DIRTY"),
    ) {
        ("", _) => "unknown".into(),
        (commit, "true") => format!("{commit}+dirty"),
        (commit, _) => commit.into(),
    }
}

/// Commit and dirty flag of the source tree when the binary was built (`None` outside git).
fn git_state() -> Option<format::Git> {
    match (
        env!("ISAR_CLUTTER_GIT_COMMIT"),
        env!("ISAR_CLUTTER_GIT_DIRTY"),
    ) {
        ("", _) => None,
        (commit, dirty) => Some(format::Git {
            commit: commit.into(),
            dirty: dirty == "true",
            recorded: "at build time".into(),
        }),
    }
}

/// `manifest.json`, written as the merge goes: the provenance first ([`Manifest::start`]),
/// then every job in plan order as the merge reads it ([`Manifest::job`]: its id, kind,
/// identity, seed, its own fields, status, error and timings, one line each), then the files
/// the run wrote ([`Manifest::file`]) and the timings ([`Manifest::finish`]), which puts the file in place: last of
/// a run's outputs. Nothing of it is held in memory but the line being written, so that a
/// sweep of 100,000 jobs writes its manifest in bounded memory.
pub struct Manifest {
    file: Staged,
    jobs: usize,
    /// Files written so far (`None`: the list is not open yet).
    files: Option<usize>,
}

impl Manifest {
    /// Starts the manifest of `plan` in `out`: the tool, git state, spec, seeds and their
    /// derivation, threads.
    ///
    /// # Errors
    /// If the file cannot be written.
    pub fn start(plan: &Plan, threads: usize, out: &Path) -> Result<Manifest> {
        let head = format::Manifest {
            format: format::FORMAT.into(),
            tool: format::Tool {
                name: crate::TOOL.into(),
                version: env!("CARGO_PKG_VERSION").into(),
            },
            git: git_state(),
            spec_file: plan.file.display().to_string(),
            spec_hash_sha256: plan.spec_hash.clone(),
            spec: serde_json::to_value(&plan.spec)?,
            master_seed: Some(plan.spec.seed),
            master_seed_from: if plan.seed_override.is_some() { "--seed" } else { "spec" }.into(),
            seed_derivation: "first 8 bytes (LE) of SHA-256('isar-clutter/v1/<job|data>/<master seed>/<identity>'); simulated data use ChaCha20 seeded with data_seed, stream = sample index; generated samples use the sample format below, seeded with generation_seed, stream = sample index".into(),
            sample_format: Some(crate::synthesis::SAMPLE_FORMAT),
            threads: Some(threads),
            calibration_seed: plan.spec.calibration.as_ref().map(|_| plan.calibration_seed()),
            plant_calibration_sha256: Some(crate::seeds::sha256_hex(
                crate::physics::vegetation::calibration::RECORD.as_bytes(),
            )),
            training_device: plan.training_device.clone(),
            ..Default::default()
        };
        let text = serde_json::to_string_pretty(&head)?;
        let mut file = Staged::new(&format::path(out));
        // The object left open after its last field, for the jobs.
        let open = text.strip_suffix("\n}").unwrap_or(&text);
        write!(file, "{open},\n  \"jobs\": [")?;
        Ok(Manifest {
            file,
            jobs: 0,
            files: None,
        })
    }

    /// Appends the entry of `job`: its outcome (`Ok` with its timings, or the error), wall
    /// time and `computed_by`, the build of the tool that computed a stored result (null for
    /// a failed job or a record that did not keep it).
    ///
    /// # Errors
    /// If the file cannot be written.
    pub fn job(
        &mut self,
        job: &dyn JobKind,
        outcome: std::result::Result<Option<&serde_json::Value>, &str>,
        elapsed_s: f64,
        built_by: Option<&str>,
    ) -> Result<()> {
        let mut entry = serde_json::to_value(format::Job {
            job: job.id().into(),
            kind: job.kind().into(),
            identity: job.identity().into_owned(),
            seed: job.seed(),
            status: if outcome.is_ok() { "ok" } else { "failed" }.into(),
            error: outcome.err().map(str::to_string),
            elapsed_s: Some(elapsed_s),
            timing: outcome.ok().flatten().cloned(),
            computed_by: built_by.map(str::to_string),
            ..Default::default()
        })?;
        // The kind's own fields (a dataset job's `dataset`, `data_seed`, ...).
        if let (serde_json::Value::Object(entry), serde_json::Value::Object(fields)) =
            (&mut entry, job.manifest())
        {
            entry.extend(fields);
        }
        let sep = if self.jobs == 0 { "" } else { "," };
        write!(self.file, "{sep}\n    {}", serde_json::to_string(&entry)?)?;
        self.jobs += 1;
        Ok(())
    }

    /// Appends a file the run wrote (`rel`, relative to `out`) with its size and, for a table,
    /// its SHA-256 (`sha256` where it is known, computed as the table was written; otherwise
    /// the table is read for it), so that a reader can tell a folder that was changed
    /// afterwards; a file that is not there is left out.
    ///
    /// # Errors
    /// If the file cannot be written, or a table read for its hash.
    pub fn file(&mut self, out: &Path, rel: &Path, sha256: Option<&str>) -> Result<()> {
        let Some((key, rec)) = crate::io::outdir::file_record_hashed(out, rel, sha256)? else {
            return Ok(());
        };
        let sep = match self.files {
            None => {
                self.open_files()?;
                ""
            }
            Some(_) => ",",
        };
        write!(
            self.file,
            "{sep}\n    {}: {}",
            serde_json::to_string(&key)?,
            serde_json::to_string(&rec)?
        )?;
        self.files = Some(self.files.unwrap_or(0) + 1);
        Ok(())
    }

    /// Closes the list of jobs and opens the object of files.
    fn open_files(&mut self) -> Result<()> {
        let end = if self.jobs == 0 { "]" } else { "\n  ]" };
        write!(self.file, "{end},\n  \"files\": {{")?;
        Ok(())
    }

    /// Ends the manifest with the run's total and table-writing seconds and the time it
    /// finished, and puts it in place.
    ///
    /// # Errors
    /// If the file cannot be written.
    pub fn finish(mut self, (total_s, tables_s): (f64, f64)) -> Result<()> {
        match self.files {
            None => {
                self.open_files()?;
                write!(self.file, "}}")?;
            }
            Some(_) => write!(self.file, "\n  }}")?,
        }
        let unix = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0);
        let timings = format::Timings { total_s, tables_s };
        write!(
            self.file,
            ",\n  \"timings\": {},\n  \"finished_unix_s\": {unix}\n}}\n",
            serde_json::to_string(&timings)?
        )?;
        self.file.commit()
    }
}
