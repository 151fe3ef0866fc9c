//! `manifest.json`: the provenance of a run (tool, git state at build time, the spec and its
//! hash, the master seed and how every seed derives from it, threads, timings) and every job
//! with its identity, seeds, status, error and timings.

use crate::io::atomic::atomic_write;
use crate::run::jobs::{JobKind, Outcome};
use crate::run::plan::Plan;
use anyhow::Result;
use serde_json::json;
use std::path::Path;

/// Commit and dirty flag of the source tree when the binary was built (null outside git).
fn git_state() -> serde_json::Value {
    match (
        env!("ISAR_CLUTTER_GIT_COMMIT"),
        env!("ISAR_CLUTTER_GIT_DIRTY"),
    ) {
        ("", _) => serde_json::Value::Null,
        (commit, dirty) => {
            json!({ "commit": commit, "dirty": dirty == "true", "recorded": "at build time" })
        }
    }
}

/// Writes `manifest.json`, last of a run's outputs: the tool, git state, spec, seeds and their
/// derivation, threads, timings and every job with its seeds, status and error.
///
/// `jobs` and `outcomes` are every job of the run and its outcome, in plan order; `timings`
/// the run's total and table-writing seconds; `written` the files the run wrote (relative to
/// `out`), listed with their sizes (and the tables' SHA-256) so that a reader can tell a
/// folder that was changed afterwards.
///
/// # Errors
/// If the file cannot be written.
pub fn write(
    plan: &Plan,
    jobs: &[&dyn JobKind],
    outcomes: &[Outcome],
    threads: usize,
    out: &Path,
    (total_s, tables_s): (f64, f64),
    written: &[std::path::PathBuf],
) -> Result<()> {
    let jobs: Vec<serde_json::Value> = jobs
        .iter()
        .zip(outcomes)
        .map(|(job, o)| {
            let mut entry = json!({
                "job": job.id(),
                "kind": job.kind(),
                "identity": job.identity(),
                "seed": job.seed(),
            });
            if let serde_json::Value::Object(fields) = job.manifest() {
                entry.as_object_mut().expect("an object").extend(fields);
            }
            let timing = o.rows.as_ref().ok().and_then(|r| r.timing.clone());
            entry["status"] = json!(if o.rows.is_ok() { "ok" } else { "failed" });
            entry["error"] = json!(o.rows.as_ref().err());
            entry["elapsed_s"] = json!(o.elapsed_s);
            entry["timing"] = json!(timing);
            entry
        })
        .collect();
    let unix = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let manifest = json!({
        "format": "isar-clutter-manifest/1",
        "tool": { "name": env!("CARGO_PKG_NAME"), "version": env!("CARGO_PKG_VERSION") },
        "git": git_state(),
        "spec_file": plan.file.display().to_string(),
        "spec_hash_sha256": plan.spec_hash,
        "spec": plan.spec,
        "master_seed": plan.spec.seed,
        "seed_derivation": "first 8 bytes (LE) of SHA-256('isar-clutter/v1/<job|data>/<master seed>/<identity>'); simulated data use ChaCha20 seeded with data_seed, stream = sample index; generated samples use the sample format below, seeded with generation_seed, stream = sample index",
        "sample_format": crate::synthesis::SAMPLE_FORMAT,
        "threads": threads,
        "calibration_seed": plan.spec.calibration.as_ref().map(|_| plan.calibration_seed()),
        "finished_unix_s": unix,
        "timings": { "total_s": total_s, "tables_s": tables_s },
        "jobs": jobs,
        "files": crate::io::outdir::file_records(out, written)?,
    });
    atomic_write(&out.join("manifest.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &manifest)?;
        Ok(())
    })
}
