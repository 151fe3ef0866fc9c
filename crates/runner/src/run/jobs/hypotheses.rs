//! The hypotheses job of a spec's `hypotheses` section (Tables 16 and 24): it reads the rows
//! that the analysis jobs of datasets named `plant_<letter>_<wind>` leave for it (their
//! statistics in the intermediate table `_plant_stats` and their `correlating_function`
//! fragment), takes the first sweep point of each dataset, and runs the tests of
//! [`crate::apps::hypotheses`] into `hypotheses`; its estimate of memory and work.

use super::{Context as JobContext, Inputs, JobKind, Rows, Status};
use crate::apps::hypotheses::{analysis_numbers, test, PlantStats};
use crate::io::results::{self, col};
use crate::physics::vegetation::parse_dataset_id;
use crate::run::plan::{Job, Plan};
use crate::run::tables::JobResult;
use anyhow::{Context, Result};
use ndarray::Array2;
use polars::prelude::*;

/// Name of the intermediate table of a plant's statistics.
pub const PLANT_STATS: &str = "_plant_stats";

/// The tests over the analysis jobs `inputs` (indices into the plan's jobs).
#[derive(Debug, Clone)]
pub struct HypothesesJob {
    /// The analysis jobs of plant datasets, in plan order.
    pub inputs: Vec<usize>,
}

impl HypothesesJob {
    /// The job over the plan's analysis jobs of datasets named `plant_<letter>_<wind>`.
    pub fn new(jobs: &[Job]) -> Self {
        let inputs = jobs
            .iter()
            .enumerate()
            .filter(|(_, j)| j.method.is_none() && parse_dataset_id(&j.dataset_id).is_some())
            .map(|(i, _)| i)
            .collect();
        HypothesesJob { inputs }
    }
}

/// An analysis job's intermediate rows for the tests: one row per level with the mean
/// correlation of H, V and D and the mean pixel variance; `None` for a dataset that is not a
/// plant or a job without an analysis.
///
/// # Errors
/// If the table cannot be built.
pub fn plant_stats(job: &Job, r: &JobResult) -> Result<Option<DataFrame>> {
    let (Some(a), Some(_), None) = (&r.analysis, &r.correlating, job.method) else {
        return Ok(None);
    };
    if parse_dataset_id(&job.dataset_id).is_none() {
        return Ok(None);
    }
    let (mean_variance, level_correlations) = analysis_numbers(a);
    let n = level_correlations.len();
    let dir = |k: usize| -> Vec<f64> { level_correlations.iter().map(|l| l[k]).collect() };
    Ok(Some(DataFrame::new_infer_height(vec![
        Column::new(col::DATASET.into(), vec![job.dataset_id.as_str(); n]),
        Column::new(col::LEVEL.into(), (1..=n as i64).collect::<Vec<_>>()),
        Column::new("mean_correlation_h".into(), dir(0)),
        Column::new("mean_correlation_v".into(), dir(1)),
        Column::new("mean_correlation_d".into(), dir(2)),
        Column::new("mean_pixel_variance".into(), vec![mean_variance; n]),
    ])?))
}

/// A plant's statistics back from its rows.
fn read_stats(rows: &Rows) -> Result<Option<PlantStats>> {
    let (Some(stats), Some(corr)) = (
        rows.table(PLANT_STATS),
        rows.table(results::CORRELATING_FUNCTION.name),
    ) else {
        return Ok(None);
    };
    let f = |df: &DataFrame, name: &str| -> Result<Vec<Option<f64>>> {
        Ok(df.column(name)?.f64()?.iter().collect())
    };
    let i = |df: &DataFrame, name: &str| -> Result<Vec<i64>> {
        Ok(df.column(name)?.i64()?.iter().flatten().collect())
    };
    let dataset = stats
        .column("dataset")?
        .str()?
        .get(0)
        .context("no rows")?
        .to_string();
    let (h, v, d) = (
        f(stats, "mean_correlation_h")?,
        f(stats, "mean_correlation_v")?,
        f(stats, "mean_correlation_d")?,
    );
    let nan = |x: Option<f64>| x.unwrap_or(f64::NAN);
    let level_correlations = (0..h.len())
        .map(|l| [nan(h[l]), nan(v[l]), nan(d[l])])
        .collect();
    let mean_variance = nan(f(stats, "mean_pixel_variance")?[0]);
    let (dy, dx, mc) = (i(corr, "dy")?, i(corr, "dx")?, f(corr, "mean_correlation")?);
    let r = dy.iter().copied().max().unwrap_or(0);
    let size = (2 * r + 1) as usize;
    // A store written before the magnitude column existed has none: NaN (H2's magnitude row
    // is then left out).
    let mm = match corr.column("mean_magnitude") {
        Ok(_) => f(corr, "mean_magnitude")?,
        Err(_) => vec![None; dy.len()],
    };
    let mut correlating = Array2::from_elem((size, size), f64::NAN);
    let mut magnitude = Array2::from_elem((size, size), f64::NAN);
    for k in 0..dy.len() {
        let at = [(dy[k] + r) as usize, (dx[k] + r) as usize];
        correlating[at] = nan(mc[k]);
        magnitude[at] = nan(mm[k]);
    }
    let Some((plant, wind)) = parse_dataset_id(&dataset) else {
        return Ok(None);
    };
    Ok(Some(PlantStats {
        dataset,
        plant,
        wind,
        mean_variance,
        level_correlations,
        correlating,
        magnitude,
    }))
}

impl JobKind for HypothesesJob {
    fn id(&self) -> &str {
        "hypotheses"
    }

    fn kind(&self) -> &'static str {
        "hypotheses"
    }

    fn identity(&self) -> std::borrow::Cow<'_, str> {
        "".into()
    }

    fn seed(&self) -> Option<u64> {
        None
    }

    fn estimate(&self, plan: &Plan) -> crate::run::estimate::Estimate {
        estimate(plan, self.inputs.len())
    }

    fn key_material(&self, plan: &Plan) -> String {
        format!("{self:?}\n{:?}", plan.spec.hypotheses)
    }

    fn inputs(&self) -> Inputs {
        Inputs::Rows(self.inputs.clone())
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

    fn run(&self, cx: &JobContext) -> Result<Rows> {
        let mut stats: Vec<PlantStats> = vec![];
        for (job, rows) in &cx.inputs {
            let s = read_stats(rows).with_context(|| format!("rows of job {}", job.id()))?;
            // The first sweep point of each dataset.
            if let Some(s) = s.filter(|s| stats.iter().all(|t| t.dataset != s.dataset)) {
                stats.push(s);
            }
        }
        let rows = test(&stats);
        let table = DataFrame::new_infer_height(vec![
            Column::new(
                "hypothesis".into(),
                rows.iter().map(|r| r.hypothesis).collect::<Vec<_>>(),
            ),
            Column::new(
                "dataset".into(),
                rows.iter().map(|r| r.dataset.clone()).collect::<Vec<_>>(),
            ),
            Column::new(
                "statistic".into(),
                rows.iter().map(|r| r.statistic.clone()).collect::<Vec<_>>(),
            ),
            Column::new(
                "value".into(),
                rows.iter().map(|r| r.value).collect::<Vec<_>>(),
            ),
            Column::new(
                "verdict".into(),
                rows.iter().map(|r| r.verdict).collect::<Vec<_>>(),
            ),
        ])?;
        Ok(Rows {
            tables: vec![(results::HYPOTHESES.name, table)],
            ..Rows::default()
        })
    }

    fn status_row(&self, _plan: &Plan, _status: &Status) -> Option<Result<DataFrame>> {
        None
    }
}

/// The estimate of the hypotheses job over `inputs` plant datasets: each one's correlating
/// function (`(2 max_offset + 1)^2` cells) read back from its rows.
fn estimate(plan: &Plan, inputs: usize) -> crate::run::estimate::Estimate {
    let Some(hs) = &plan.spec.hypotheses else {
        return crate::run::estimate::Estimate::SMALL;
    };
    let r = hs.max_offset as f64;
    let mut sizes = crate::run::estimate::Sizes::default();
    sizes.add("hypotheses.max_offset", hs.max_offset, r / 4.0);
    let cells = inputs as f64 * (2.0 * r + 1.0).powi(2);
    crate::run::estimate::Estimate::new(
        crate::run::estimate::Estimate::SMALL.bytes as f64 + 48.0 * cells,
        crate::run::estimate::Estimate::SMALL.flops + 10.0 * cells,
    )
    .blaming(&sizes)
}
