//! The CNN trainings of the `classification` and `location` sections (ch. 5.3), one job per
//! training, and the location summary over them. A training job reads its datasets through the
//! scheduler's shared materialisation (every class stack, or the clutter stack, made once per
//! run), fits its method with the synthesis code, composes its training, validation and test
//! sets ([`crate::apps::cnn::classification`], [`crate::apps::cnn::location`]), trains
//! ([`crate::apps::cnn::train`]) and leaves rows in `classification` or `location`, its
//! per-epoch record in `training_history` and its confusion matrix in `confusion`.
//!
//! Seeds: the job's seed (master seed and identity) draws the network's initial weights and
//! its shuffles. The samples a training sees are drawn from seeds of the identity without the
//! method (common random numbers): every method of one size and repeat gets the same
//! originals, the same generation seed and the same initial weights, so method comparisons are
//! paired.

mod classification;
mod common;
mod fits;
mod location;

pub use classification::ClassificationJob;
pub use common::{CLASSIFICATION, CONFUSION, HISTORY, LOCATION, LOCATION_SUMMARY};
pub use location::{location_summary, LocationJob, LocationSummaryJob};

use crate::experiment::Applications;
use crate::run::jobs::JobKind;
use crate::run::plan::Plan;

/// The jobs of every CNN section of `plan`, in plan order (classification, then location and
/// its summary); `first` is the index the first of them takes in the plan's job list. The
/// applications are destructured whole, so a new one is named here by the compiler.
pub fn jobs(plan: &Plan, first: usize) -> Vec<Box<dyn JobKind>> {
    let Applications {
        classification,
        location,
    } = &plan.cnn;
    let mut out: Vec<Box<dyn JobKind>> = vec![];
    if let Some(c) = classification {
        out.extend(ClassificationJob::all(plan, c).into_iter().map(boxed));
    }
    if let Some(l) = location {
        let trainings = LocationJob::all(plan, l);
        let at = first + out.len();
        let inputs = (at..at + trainings.len()).collect();
        out.extend(trainings.into_iter().map(boxed));
        out.push(Box::new(LocationSummaryJob { inputs }));
    }
    out
}

/// A job behind the seam.
fn boxed<J: JobKind + 'static>(job: J) -> Box<dyn JobKind> {
    Box::new(job)
}
