//! Every job of a plan behind the one seam, in plan order: the dataset jobs (analysis and
//! synthesis), then the jobs of the run as a whole made from their spec sections (calibration,
//! hypotheses), then the CNN applications' jobs ([`super::cnn::jobs`]: the trainings and the
//! location summary). [`super::Inputs::Rows`] indices refer to this order.

use super::calibration::CalibrationJob;
use super::cnn;
use super::hypotheses::HypothesesJob;
use super::JobKind;
use crate::run::plan::Plan;

/// The jobs of one plan.
pub struct AllJobs<'a> {
    plan: &'a Plan,
    calibration: Option<CalibrationJob>,
    hypotheses: Option<HypothesesJob>,
    cnn: Vec<Box<dyn JobKind>>,
}

impl<'a> AllJobs<'a> {
    /// The jobs of `plan`.
    pub fn new(plan: &'a Plan) -> Self {
        let calibration = plan.spec.calibration.clone().map(|chain| CalibrationJob {
            chain,
            seed: plan.calibration_seed(),
        });
        let hypotheses = plan
            .spec
            .hypotheses
            .as_ref()
            .map(|_| HypothesesJob::new(&plan.jobs));
        let first_cnn = plan.jobs.len()
            + usize::from(calibration.is_some())
            + usize::from(hypotheses.is_some());
        AllJobs {
            plan,
            calibration,
            hypotheses,
            cnn: cnn::jobs(plan, first_cnn),
        }
    }

    /// Every job, in plan order.
    pub fn list(&self) -> Vec<&dyn JobKind> {
        let mut all: Vec<&dyn JobKind> = self.plan.jobs.iter().map(|j| j as &dyn JobKind).collect();
        if let Some(c) = &self.calibration {
            all.push(c);
        }
        if let Some(h) = &self.hypotheses {
            all.push(h);
        }
        all.extend(self.cnn.iter().map(|j| j.as_ref()));
        all
    }
}
