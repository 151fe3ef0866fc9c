//! The record a run's folder keeps of its spec, `.isar-clutter/plan.json`: the spec file's
//! absolute path, its SHA-256, the job store's schema, the shard count and the master seed
//! given in place of the spec's. `merge OUT` and `status OUT` load the plan from it and need
//! nothing else; they refuse when the spec changed since the jobs ran.

use crate::io::outdir::STATE;
use crate::run::plan::{self, Plan};
use crate::run::store;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

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
pub fn write(out: &Path, plan: &Plan, shards: Option<usize>) -> Result<()> {
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
pub fn load(out: &Path) -> Result<(Plan, PlanRecord)> {
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
