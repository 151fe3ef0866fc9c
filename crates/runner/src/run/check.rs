//! The check of a whole plan before it runs (`validate`, `run --dry-run`): every job's memory
//! and work estimated ([`super::estimate`]) against the machine's memory or `--max-memory`,
//! the plan refused at the YAML path of the size to blame, and the largest job reported.

use super::estimate::{Estimate, Limit};
use super::jobs::all::AllJobs;
use super::plan::Plan;
use crate::experiment::SpecError;
use std::fmt;

/// The job of a plan with the largest peak memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Largest {
    /// The job's id.
    pub id: String,
    /// Its estimate.
    pub estimate: Estimate,
    /// The limit it was checked against (`None`: none known).
    pub limit: Option<Limit>,
}

impl fmt::Display for Largest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "largest job {}: {}", self.id, self.estimate)?;
        if let Some(l) = &self.limit {
            write!(f, " (limit: {l})")?;
        }
        Ok(())
    }
}

/// Estimates every job of `plan` and refuses the plan when one cannot fit under `limit`
/// (see [`limit`]) or passes [`super::estimate::MAX_FLOPS`]; returns the largest job.
///
/// # Errors
/// A [`SpecError`] at the YAML path of the blamed size ([`Estimate::blame`](super::estimate::Estimate)), or at the
/// dataset's path (`datasets[i]`) or the job's section when no size is above its usual value,
/// naming the job, its estimate and the limit.
pub fn check(plan: &Plan, limit: Option<Limit>) -> Result<Largest, SpecError> {
    let all = AllJobs::new(plan);
    let mut largest: Option<Largest> = None;
    for job in all.list() {
        let e = job.estimate(plan);
        if let Some(why) = e.exceeds(limit.as_ref()) {
            let dataset = plan
                .jobs
                .iter()
                .find(|j| j.id == job.id())
                .and_then(|j| plan.spec.datasets.iter().position(|d| d.id == j.dataset_id));
            let (at, advice) = match (&e.blame, dataset) {
                (Some(b), _) => (b.path.clone(), ""),
                (None, Some(i)) => (format!("datasets[{i}]"), "; make the dataset smaller"),
                (None, None) => (job.kind().to_string(), ""),
            };
            return Err(SpecError::at(
                &plan.file,
                at,
                format!("job {} {why}{advice}", job.id()),
            ));
        }
        if largest.as_ref().is_none_or(|l| e.bytes > l.estimate.bytes) {
            largest = Some(Largest {
                id: job.id().to_string(),
                estimate: e,
                limit,
            });
        }
    }
    Ok(largest.unwrap_or(Largest {
        id: "(none)".into(),
        estimate: Estimate::new(0.0, 0.0),
        limit,
    }))
}
