//! The calibration job of a spec's `calibration` section: the simulated sphere measured
//! through the chain and calibrated (Figs. 11-14), giving `calibration` (one row per
//! frequency: `freq_ghz, mie_dbsm, raw_db, calibrated_dbsm, error_db, phase_error_deg`) and
//! `calibration_summary` (`band, statistic, value`); its estimate of memory and work.

use super::{Context as JobContext, Inputs, JobKind, Rows, Status};
use crate::experiment::datasets::{chain_sizes, mie};
use crate::io::results::{self, col};
use crate::physics::calibration::{calibrate, simulate, summary, CalibrationRow, ChainParams};
use crate::run::estimate::Estimate;
use crate::run::estimate::Sizes;
use crate::run::plan::Plan;
use anyhow::Result;
use polars::prelude::*;

/// The calibration of one chain, seeded from the master seed.
#[derive(Debug, Clone)]
pub struct CalibrationJob {
    /// The chain's parameters.
    pub chain: ChainParams,
    /// Seed of the simulated measurements ([`Plan::calibration_seed`]).
    pub seed: u64,
}

impl JobKind for CalibrationJob {
    fn id(&self) -> &str {
        "calibration"
    }

    fn kind(&self) -> &'static str {
        "calibration"
    }

    fn identity(&self) -> std::borrow::Cow<'_, str> {
        "".into()
    }

    fn seed(&self) -> Option<u64> {
        Some(self.seed)
    }

    fn estimate(&self, _plan: &Plan) -> Estimate {
        estimate(&self.chain)
    }

    fn key_material(&self, plan: &Plan) -> String {
        format!("{self:?}\n{:?}", plan.spec.calibration)
    }

    fn inputs(&self) -> Inputs {
        Inputs::Nothing
    }

    fn input_files(&self) -> Vec<std::path::PathBuf> {
        vec![]
    }

    fn materialise(&self) -> Result<crate::experiment::Materialised> {
        super::no_dataset(self)
    }

    fn manifest(&self) -> serde_json::Value {
        serde_json::json!({})
    }

    fn run(&self, _cx: &JobContext) -> Result<Rows> {
        let rows = calibrate(&self.chain, &simulate(&self.chain, self.seed));
        let col = |name: &str, f: &dyn Fn(&CalibrationRow) -> f64| {
            Column::new(name.into(), rows.iter().map(f).collect::<Vec<f64>>())
        };
        let table = DataFrame::new_infer_height(vec![
            col("freq_ghz", &|r| r.freq / 1e9),
            col("mie_dbsm", &|r| r.mie_db),
            col("raw_db", &|r| r.raw_db),
            col("calibrated_dbsm", &|r| r.calibrated_db),
            col("error_db", &|r| r.error_db),
            col("phase_error_deg", &|r| r.phase_error_deg),
        ])?;
        let s = summary(&rows);
        let summary = DataFrame::new_infer_height(vec![
            Column::new(col::BAND.into(), s.iter().map(|x| x.0).collect::<Vec<_>>()),
            Column::new(
                "statistic".into(),
                s.iter().map(|x| x.1).collect::<Vec<_>>(),
            ),
            Column::new(col::VALUE.into(), s.iter().map(|x| x.2).collect::<Vec<_>>()),
        ])?;
        Ok(Rows {
            tables: vec![
                (results::CALIBRATION.name, table),
                (results::CALIBRATION_SUMMARY.name, summary),
            ],
            ..Rows::default()
        })
    }

    fn status_row(&self, _plan: &Plan, _status: &Status) -> Option<Result<DataFrame>> {
        None
    }
}

/// The estimate of the `calibration` section's job: about 256 bytes a frequency point (the
/// grid, the four measurements, the gated differences, the rows and the FFTs' buffers), three
/// Mie series of the sphere, the chamber clutter of four measurements and the time gates'
/// FFTs.
fn estimate(chain: &ChainParams) -> Estimate {
    let n = chain.points as f64;
    let (mie_bytes, mie_flops) = mie(chain, 3.0);
    let clutter = chain.clutter.len() as f64;
    let mut sizes = Sizes::default();
    chain_sizes("calibration", chain, &mut sizes);
    Estimate::new(
        Estimate::SMALL.bytes as f64 + 256.0 * n + mie_bytes,
        Estimate::SMALL.flops
            + mie_flops
            + 4.0 * n * (30.0 * clutter + 60.0)
            + 40.0 * n * n.max(2.0).log2(),
    )
    .blaming(&sizes)
}
