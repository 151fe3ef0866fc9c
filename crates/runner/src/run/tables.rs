//! The run's tables: each dataset job's fragment of every long-format table (one builder per
//! table, called on that job's result alone), the tables every run writes and their empty
//! forms; [`crate::run::assembly`] streams the fragments of all jobs in plan order into the
//! Parquet tables of the run.
//!
//! Table layout is a public contract (see `docs/spec.md`): `analysis_maps`,
//! `analysis_summary`, `pixel_stats`, `filter_correlation`, `jobs`, `synthesis_params`,
//! `similarity`, `model_order`, and with their sections `correlating_function`, `hypotheses`,
//! `calibration`, `calibration_summary`.

use crate::io::results::{self, col};
use crate::run::plan::{Job, Plan};
pub use crate::run::result::{FilterRow, JobResult, SimilarityOutcome, SynthesisOutcome};
use crate::stats::analysis::Direction;
use anyhow::{Context, Result};
use polars::prelude::*;
use serde_json::Value as Json;
use std::borrow::Cow;

/// Column builder for one table: rows are appended job by job, and the swept parameters are
/// added as columns at the end.
struct Table<'a> {
    plan: &'a Plan,
    jobs: Vec<&'a Job>,
    cols: Vec<(String, Values<'a>)>,
    /// Index of the column after the last one written: rows fill columns in declaration
    /// order, so the name lookup usually succeeds at once.
    next: usize,
}

/// Column types: nullable string, i64, u64, f64 and bool.
#[derive(Clone, Copy)]
enum Kind {
    S,
    I,
    U,
    F,
    B,
}

/// Column data.
enum Values<'a> {
    Str(Vec<Option<Cow<'a, str>>>),
    Int(Vec<Option<i64>>),
    UInt(Vec<u64>),
    Float(Vec<Option<f64>>),
    Bool(Vec<Option<bool>>),
}

impl<'a> Table<'a> {
    fn new<S: AsRef<str>>(plan: &'a Plan, names: &[(S, Kind)]) -> Self {
        let cols = names
            .iter()
            .map(|(n, k)| {
                let empty = match k {
                    Kind::S => Values::Str(vec![]),
                    Kind::I => Values::Int(vec![]),
                    Kind::U => Values::UInt(vec![]),
                    Kind::F => Values::Float(vec![]),
                    Kind::B => Values::Bool(vec![]),
                };
                (n.as_ref().to_string(), empty)
            })
            .collect();
        Table {
            plan,
            jobs: vec![],
            cols,
            next: 0,
        }
    }

    fn col(&mut self, name: &str) -> &mut Values<'a> {
        let at = match self.cols.get(self.next) {
            Some((n, _)) if n == name => self.next,
            _ => self
                .cols
                .iter()
                .position(|(n, _)| n == name)
                .expect("declared column"),
        };
        self.next = (at + 1) % self.cols.len();
        &mut self.cols[at].1
    }

    fn s(&mut self, name: &str, v: impl Into<Cow<'a, str>>) {
        self.s_opt(name, Some(v.into()))
    }
    fn s_opt(&mut self, name: &str, v: Option<Cow<'a, str>>) {
        if let Values::Str(c) = self.col(name) {
            c.push(v)
        }
    }
    fn i(&mut self, name: &str, v: i64) {
        self.i_opt(name, Some(v))
    }
    fn i_opt(&mut self, name: &str, v: Option<i64>) {
        if let Values::Int(c) = self.col(name) {
            c.push(v)
        }
    }
    fn b(&mut self, name: &str, v: Option<bool>) {
        if let Values::Bool(c) = self.col(name) {
            c.push(v)
        }
    }
    fn u(&mut self, name: &str, v: u64) {
        if let Values::UInt(c) = self.col(name) {
            c.push(v)
        }
    }
    fn f(&mut self, name: &str, v: Option<f64>) {
        if let Values::Float(c) = self.col(name) {
            c.push(v)
        }
    }

    /// Marks the end of one row of `job`.
    fn row(&mut self, job: &'a Job) {
        self.jobs.push(job);
    }

    fn finish(self) -> Result<DataFrame> {
        let mut columns: Vec<Column> = self
            .cols
            .into_iter()
            .map(|(n, v)| match v {
                Values::Str(v) => Column::new(
                    n.as_str().into(),
                    v.iter().map(|s| s.as_deref()).collect::<Vec<_>>(),
                ),
                Values::Int(v) => Column::new(n.as_str().into(), v),
                Values::UInt(v) => Column::new(n.as_str().into(), v),
                Values::Float(v) => Column::new(n.as_str().into(), v),
                Values::Bool(v) => Column::new(n.as_str().into(), v),
            })
            .collect();
        for (key, &numeric) in self.plan.param_keys.iter().zip(&self.plan.param_numeric) {
            let values: Vec<Option<&Json>> = self.jobs.iter().map(|j| j.params.get(key)).collect();
            // The column type follows every job's value, so it is the same in every table.
            let name: PlSmallStr = param_column(key, &columns).into();
            columns.push(if numeric {
                Column::new(
                    name,
                    values
                        .iter()
                        .map(|v| v.and_then(Json::as_f64))
                        .collect::<Vec<_>>(),
                )
            } else {
                let text = |v: &Json| match v {
                    Json::String(s) => s.clone(),
                    other => other.to_string(),
                };
                Column::new(name, values.iter().map(|v| v.map(text)).collect::<Vec<_>>())
            });
        }
        Ok(DataFrame::new_infer_height(columns)?)
    }
}

/// Column name of a swept parameter: its short key, or `swept_<key>` where a table already has
/// a column of that name (`levels` and `samples` in `jobs.parquet`, `mean_im` in
/// `pixel_stats.parquet`).
fn param_column(key: &str, columns: &[Column]) -> String {
    if columns.iter().any(|c| c.name().as_str() == key) {
        format!("swept_{key}")
    } else {
        key.to_string()
    }
}

fn opt(v: f64) -> Option<f64> {
    Some(v)
}

/// `analysis_maps`: one row per job, level, direction and cell.
pub fn analysis_maps<'a>(
    plan: &'a Plan,
    results: &[(&'a Job, &'a JobResult)],
) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::SOURCE, Kind::S),
            (col::LEVEL, Kind::I),
            (col::DIRECTION, Kind::S),
            (col::ROW, Kind::I),
            (col::COL, Kind::I),
            (col::CORRELATION, Kind::F),
            (col::COVARIANCE, Kind::F),
            (col::EXPECTED_CORRELATION, Kind::F),
        ],
    );
    for &(job, r) in results {
        let Some(analysis) = &r.analysis else {
            continue;
        };
        for lm in &analysis.levels {
            for d in Direction::ALL {
                let expected = r.expected.as_ref().map(|e| &e[lm.level - 1][d as usize]);
                for ((rc, &corr), &cov) in lm
                    .correlation(d)
                    .indexed_iter()
                    .zip(lm.covariance(d).iter())
                {
                    t.s(col::JOB, &job.id);
                    t.s(col::DATASET, &job.dataset_id);
                    t.s(col::SOURCE, r.source);
                    t.i(col::LEVEL, lm.level as i64);
                    t.s(col::DIRECTION, d.as_str());
                    t.i(col::ROW, rc.0 as i64);
                    t.i(col::COL, rc.1 as i64);
                    t.f(col::CORRELATION, opt(corr));
                    t.f(col::COVARIANCE, opt(cov));
                    t.f(col::EXPECTED_CORRELATION, expected.map(|e| e[rc]));
                    t.row(job);
                }
            }
        }
    }
    t.finish()
}

/// `analysis_summary`: NaN-aware means per job, level and direction.
pub fn analysis_summary<'a>(
    plan: &'a Plan,
    results: &[(&'a Job, &'a JobResult)],
) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::SOURCE, Kind::S),
            (col::LEVEL, Kind::I),
            (col::DIRECTION, Kind::S),
            (col::MEAN_CORRELATION, Kind::F),
            (col::MEAN_COVARIANCE, Kind::F),
            (col::NAN_CELLS, Kind::I),
            (col::CELLS, Kind::I),
            (col::ROWS, Kind::I),
            (col::COLS, Kind::I),
            (col::EXPECTED_MEAN_CORRELATION, Kind::F),
        ],
    );
    for &(job, r) in results {
        let Some(analysis) = &r.analysis else {
            continue;
        };
        for lm in &analysis.levels {
            for d in Direction::ALL {
                let s = lm.summary(d);
                let (rows, cols) = lm.shape();
                let expected = r
                    .expected
                    .as_ref()
                    .map(|e| crate::stats::analysis::nan_mean(&e[lm.level - 1][d as usize]).0);
                t.s(col::JOB, &job.id);
                t.s(col::DATASET, &job.dataset_id);
                t.s(col::SOURCE, r.source);
                t.i(col::LEVEL, lm.level as i64);
                t.s(col::DIRECTION, d.as_str());
                t.f(col::MEAN_CORRELATION, opt(s.mean_correlation));
                t.f(col::MEAN_COVARIANCE, opt(s.mean_covariance));
                t.i(col::NAN_CELLS, s.nan_cells as i64);
                t.i(col::CELLS, (rows * cols) as i64);
                t.i(col::ROWS, rows as i64);
                t.i(col::COLS, cols as i64);
                t.f(col::EXPECTED_MEAN_CORRELATION, expected);
                t.row(job);
            }
        }
    }
    t.finish()
}

/// `pixel_stats`: per-pixel mean (real, imaginary) and variance.
pub fn pixel_stats<'a>(plan: &'a Plan, results: &[(&'a Job, &'a JobResult)]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::SOURCE, Kind::S),
            (col::ROW, Kind::I),
            (col::COL, Kind::I),
            (col::MEAN_RE, Kind::F),
            (col::MEAN_IM, Kind::F),
            (col::VARIANCE, Kind::F),
        ],
    );
    for &(job, r) in results {
        let Some(analysis) = &r.analysis else {
            continue;
        };
        for ((rc, m), &v) in analysis.mean.indexed_iter().zip(analysis.variance.iter()) {
            t.s(col::JOB, &job.id);
            t.s(col::DATASET, &job.dataset_id);
            t.s(col::SOURCE, r.source);
            t.i(col::ROW, rc.0 as i64);
            t.i(col::COL, rc.1 as i64);
            t.f(col::MEAN_RE, opt(m.re));
            t.f(col::MEAN_IM, opt(m.im));
            t.f(col::VARIANCE, opt(v));
            t.row(job);
        }
    }
    t.finish()
}

/// `filter_correlation`: lag correlations of uniform synthetic filters (Table 3).
pub fn filter_correlation<'a>(
    plan: &'a Plan,
    results: &[(&'a Job, &'a JobResult)],
) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::DIRECTION, Kind::S),
            (col::LAG, Kind::I),
            (col::FILTER_COEFFICIENT, Kind::F),
            (col::CORRELATION, Kind::F),
        ],
    );
    for &(job, r) in results {
        for row in &r.filter_rows {
            t.s(col::JOB, &job.id);
            t.s(col::DATASET, &job.dataset_id);
            t.s(col::DIRECTION, row.direction.as_str());
            t.i(col::LAG, row.lag as i64);
            t.f(col::FILTER_COEFFICIENT, opt(row.coefficient));
            t.f(col::CORRELATION, opt(row.correlation));
            t.row(job);
        }
    }
    t.finish()
}

/// `jobs`: one row per dataset job `(job, error, elapsed_s)` with its status, error, seeds,
/// timing and parameters.
pub fn status_rows<'a>(
    plan: &'a Plan,
    rows: &[(&'a Job, Option<&'a str>, f64)],
) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::KIND, Kind::S),
            (col::METHOD, Kind::S),
            (col::STATUS, Kind::S),
            (col::ERROR, Kind::S),
            (col::SEED, Kind::U),
            (col::DATA_SEED, Kind::U),
            (col::GENERATION_SEED, Kind::U),
            (col::SAMPLES, Kind::I),
            (col::HEIGHT, Kind::I),
            (col::WIDTH, Kind::I),
            (col::LEVELS, Kind::I),
            (col::ELAPSED_S, Kind::F),
        ],
    );
    for &(job, error, elapsed_s) in rows {
        let (n, h, w) = job.dataset.shape();
        t.s(col::JOB, &job.id);
        t.s(col::DATASET, &job.dataset_id);
        t.s(col::KIND, job.dataset.kind());
        t.s_opt(col::METHOD, job.method.map(|m| m.as_str().into()));
        t.s(col::STATUS, if error.is_none() { "ok" } else { "failed" });
        t.s_opt(col::ERROR, error.map(Cow::Borrowed));
        t.u(col::SEED, job.seed);
        t.u(col::DATA_SEED, job.data_seed);
        t.u(col::GENERATION_SEED, job.generation_seed);
        t.i(col::SAMPLES, n as i64);
        t.i(col::HEIGHT, h as i64);
        t.i(col::WIDTH, w as i64);
        t.i(col::LEVELS, job.analysis.levels as i64);
        t.f(col::ELAPSED_S, opt(elapsed_s));
        t.row(job);
    }
    t.finish()
}

/// `synthesis_params`: one row per synthesis job of Methods 1 and 2 and level-1 cell, with the
/// fitted filter parameters (`alpha_h`, `alpha_v` for Method 1; `r_h1..r_hL`, `r_v1..r_vL` for
/// Method 2, `L` the largest of the run; null where a method has none), the RMS misfit of the
/// reached correlations and the number of directions whose target was unreachable (0-2).
pub fn synthesis_params<'a>(
    plan: &'a Plan,
    results: &[(&'a Job, &'a JobResult)],
) -> Result<DataFrame> {
    use crate::synthesis::CellParams;
    let fits: Vec<(&Job, &crate::synthesis::FilterModel)> = results
        .iter()
        .filter_map(|&(j, r)| {
            r.synthesis
                .as_ref()
                .and_then(|s| s.filter.as_ref())
                .map(|f| (j, f))
        })
        .collect();
    let l_max = fits
        .iter()
        .map(|(_, f)| match &f.params {
            CellParams::Dyadic { r_h, .. } => r_h.len(),
            CellParams::Exponential { .. } => 0,
        })
        .max()
        .unwrap_or(0);
    let mut names: Vec<(String, Kind)> = [
        (col::JOB, Kind::S),
        (col::DATASET, Kind::S),
        (col::METHOD, Kind::S),
        (col::ROW, Kind::I),
        (col::COL, Kind::I),
        (col::ALPHA_H, Kind::F),
        (col::ALPHA_V, Kind::F),
    ]
    .iter()
    .map(|(n, k)| (n.to_string(), *k))
    .collect();
    for prefix in [col::R_H, col::R_V] {
        names.extend((1..=l_max).map(|l| (col::per_level(prefix, l), Kind::F)));
    }
    names.extend([
        (col::RESIDUAL_H.to_string(), Kind::F),
        (col::RESIDUAL_V.to_string(), Kind::F),
        (col::CLAMPED.to_string(), Kind::I),
    ]);
    let mut t = Table::new(plan, &names);
    for (job, f) in fits {
        for ((r, c), &clamped) in f.clamped.indexed_iter() {
            t.s(col::JOB, &job.id);
            t.s(col::DATASET, &job.dataset_id);
            t.s(col::METHOD, job.method.map_or("", |m| m.as_str()));
            t.i(col::ROW, r as i64);
            t.i(col::COL, c as i64);
            let (alpha, rs) = match &f.params {
                CellParams::Exponential {
                    alpha_h, alpha_v, ..
                } => (Some((alpha_h[[r, c]], alpha_v[[r, c]])), None),
                CellParams::Dyadic { r_h, r_v } => (None, Some((r_h, r_v))),
            };
            t.f(col::ALPHA_H, alpha.map(|a| a.0));
            t.f(col::ALPHA_V, alpha.map(|a| a.1));
            for (prefix, idx) in [(col::R_H, 0), (col::R_V, 1)] {
                for l in 0..l_max {
                    let v = rs.and_then(|(h, v)| [h, v][idx].get(l)).map(|m| m[[r, c]]);
                    t.f(&col::per_level(prefix, l + 1), v);
                }
            }
            t.f(col::RESIDUAL_H, opt(f.residual_h[[r, c]]));
            t.f(col::RESIDUAL_V, opt(f.residual_v[[r, c]]));
            t.i(col::CLAMPED, clamped as i64);
            t.row(job);
        }
    }
    t.finish()
}

/// `similarity`: one row per job, metric and statistic: each synthesis job's generated samples
/// against the original (`method` = the method), and each analysis job's noise floor (`method`
/// = `noise_floor`, `noise_floor` = `draws` or `halves`), with the metric's parameters (null
/// where a metric has none); `reference` = `in_sample`, or `held_out` for the comparisons with
/// originals no fit saw (`synthesis.held_out`).
pub fn similarity<'a>(plan: &'a Plan, results: &[(&'a Job, &'a JobResult)]) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::METHOD, Kind::S),
            (col::METRIC, Kind::S),
            (col::LEVEL, Kind::I),
            (col::DIRECTION, Kind::S),
            (col::COMPONENT, Kind::S),
            (col::STATISTIC, Kind::S),
            (col::VALUE, Kind::F),
            (col::UNITS, Kind::I),
            (col::SAMPLES_ORIGINAL, Kind::I),
            (col::SAMPLES_COMPARED, Kind::I),
            (col::NOISE_FLOOR, Kind::S),
            (col::REFERENCE, Kind::S),
            (col::BINS, Kind::I),
            (col::SMOOTHING, Kind::F),
            (col::SYMMETRIC, Kind::B),
            (col::DB, Kind::B),
            (col::MEAN_OVER_BINS, Kind::B),
            (col::BIAS_CORRECTION, Kind::S),
            (col::BLOCK, Kind::I),
            (col::CMD_FORM, Kind::S),
        ],
    );
    let outcomes = results.iter().flat_map(|&(job, r)| {
        [
            (&r.similarity, results::value::IN_SAMPLE),
            (&r.held_out, results::value::HELD_OUT),
        ]
        .into_iter()
        .filter_map(move |(sim, reference)| Some((job, sim.as_ref()?, reference)))
    });
    for (job, sim, reference) in outcomes {
        for row in &sim.comparison.rows {
            t.s(col::JOB, &job.id);
            t.s(col::DATASET, &job.dataset_id);
            t.s(col::METHOD, sim.compared);
            t.s(col::METRIC, row.metric);
            t.i_opt(col::LEVEL, row.level.map(|l| l as i64));
            t.s_opt(col::DIRECTION, row.direction.map(|d| d.as_str().into()));
            t.s_opt(col::COMPONENT, row.component.map(Into::into));
            t.s(col::STATISTIC, row.statistic);
            t.f(col::VALUE, Some(row.value).filter(|v| !v.is_nan()));
            t.i(col::UNITS, row.units as i64);
            t.i(col::SAMPLES_ORIGINAL, sim.comparison.samples.0 as i64);
            t.i(col::SAMPLES_COMPARED, sim.comparison.samples.1 as i64);
            t.s_opt(col::NOISE_FLOOR, sim.noise_floor.map(Into::into));
            t.s(col::REFERENCE, reference);
            t.i_opt(col::BINS, row.kl.map(|k| k.bins as i64));
            t.f(col::SMOOTHING, row.kl.map(|k| k.smoothing));
            t.b(col::SYMMETRIC, row.kl.map(|k| k.symmetric));
            t.b(col::DB, row.kl.map(|k| k.db));
            t.b(col::MEAN_OVER_BINS, row.kl.map(|k| k.mean_over_bins));
            t.s_opt(
                col::BIAS_CORRECTION,
                row.kl.map(|k| k.bias_correction.as_str().into()),
            );
            t.i_opt(col::BLOCK, row.block.map(|b| b as i64));
            t.s_opt(col::CMD_FORM, row.form.as_deref().map(Into::into));
            t.row(job);
        }
    }
    t.finish()
}

/// `model_order` (ch. 3.2, Tables 1-2): from the per-pixel KL (`kl_pixel`) of the
/// second-order model (the `uncorrelated` method: a Gaussian with the pixel's mean and
/// variance, `model_order` 2) and the fourth-order model (`fourth_order`, 4), the mean and the
/// worst pixel's KL in dB per component; the noise floor's rows have a null `model_order`.
pub fn model_order<'a>(plan: &'a Plan, results: &[(&'a Job, &'a JobResult)]) -> Result<DataFrame> {
    use crate::synthesis::Method;
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::MODEL_ORDER, Kind::I),
            (col::COMPONENT, Kind::S),
            (col::KL_MEAN_DB, Kind::F),
            (col::KL_WORST_DB, Kind::F),
            (col::PIXELS, Kind::I),
            (col::SAMPLES_ORIGINAL, Kind::I),
            (col::SAMPLES_COMPARED, Kind::I),
            (col::BINS, Kind::I),
            (col::SMOOTHING, Kind::F),
            (col::SYMMETRIC, Kind::B),
            (col::MEAN_OVER_BINS, Kind::B),
            (col::BIAS_CORRECTION, Kind::S),
        ],
    );
    for &(job, r) in results.iter().filter(|_| plan.model_orders) {
        let Some(sim) = &r.similarity else { continue };
        let order = match job.method.map(Method::model_order) {
            Some(None) => continue,
            order => order.flatten(),
        };
        for component in ["re", "im"] {
            let stat = |name: &str| {
                sim.comparison.rows.iter().find(|w| {
                    w.metric == crate::stats::metrics::name::KL_PIXEL
                        && w.component == Some(component)
                        && w.statistic == name
                })
            };
            let (Some(mean), Some(max)) = (stat("mean"), stat("max")) else {
                continue;
            };
            let kl = mean.kl.expect("KL rows carry their options");
            let to_db = |v: f64| {
                if kl.db {
                    v
                } else {
                    crate::stats::metrics::db(v)
                }
            };
            t.s(col::JOB, &job.id);
            t.s(col::DATASET, &job.dataset_id);
            t.i_opt(col::MODEL_ORDER, order);
            t.s(col::COMPONENT, component);
            t.f(
                col::KL_MEAN_DB,
                Some(to_db(mean.value)).filter(|v| !v.is_nan()),
            );
            t.f(
                col::KL_WORST_DB,
                Some(to_db(max.value)).filter(|v| !v.is_nan()),
            );
            t.i(col::PIXELS, mean.units as i64);
            t.i(col::SAMPLES_ORIGINAL, sim.comparison.samples.0 as i64);
            t.i(col::SAMPLES_COMPARED, sim.comparison.samples.1 as i64);
            t.i(col::BINS, kl.bins as i64);
            t.f(col::SMOOTHING, Some(kl.smoothing));
            t.b(col::SYMMETRIC, Some(kl.symmetric));
            t.b(col::MEAN_OVER_BINS, Some(kl.mean_over_bins));
            t.s(col::BIAS_CORRECTION, kl.bias_correction.as_str());
            t.row(job);
        }
    }
    t.finish()
}

/// `correlating_function`: one row per analysis job and offset `(dy, dx)`: the mean over pixel
/// pairs of the complex correlation at that offset (5.1.3), its real part and its magnitude,
/// the offset's length and the pairs used.
pub fn correlating_function<'a>(
    plan: &'a Plan,
    results: &[(&'a Job, &'a JobResult)],
) -> Result<DataFrame> {
    let mut t = Table::new(
        plan,
        &[
            (col::JOB, Kind::S),
            (col::DATASET, Kind::S),
            (col::DY, Kind::I),
            (col::DX, Kind::I),
            (col::DISTANCE, Kind::F),
            (col::MEAN_CORRELATION, Kind::F),
            (col::MEAN_MAGNITUDE, Kind::F),
            (col::PAIRS, Kind::I),
        ],
    );
    for &(job, r) in results {
        let Some(cf) = &r.correlating else {
            continue;
        };
        let half = (cf.real.nrows() / 2) as i64;
        for ((a, b), &v) in cf.real.indexed_iter() {
            let (dy, dx) = (a as i64 - half, b as i64 - half);
            t.s(col::JOB, &job.id);
            t.s(col::DATASET, &job.dataset_id);
            t.i(col::DY, dy);
            t.i(col::DX, dx);
            t.f(col::DISTANCE, Some(((dy * dy + dx * dx) as f64).sqrt()));
            t.f(col::MEAN_CORRELATION, Some(v).filter(|v| !v.is_nan()));
            let m = cf.magnitude[[a, b]];
            t.f(col::MEAN_MAGNITUDE, Some(m).filter(|m| !m.is_nan()));
            t.i(col::PAIRS, cf.pairs[[a, b]] as i64);
            t.row(job);
        }
    }
    t.finish()
}

/// A builder of one table's fragment from dataset jobs' results.
pub type Builder = for<'a> fn(&'a Plan, &[(&'a Job, &'a JobResult)]) -> Result<DataFrame>;

/// The tables every run writes (empty when no job contributes), with the builder of a dataset
/// job's fragment; `jobs` comes from [`status_rows`].
pub const STANDARD: [(&str, Option<Builder>); 8] = [
    (results::ANALYSIS_MAPS.name, Some(analysis_maps)),
    (results::ANALYSIS_SUMMARY.name, Some(analysis_summary)),
    (results::PIXEL_STATS.name, Some(pixel_stats)),
    (results::FILTER_CORRELATION.name, Some(filter_correlation)),
    (results::JOBS.name, None),
    (results::SYNTHESIS_PARAMS.name, Some(synthesis_params)),
    (results::SIMILARITY.name, Some(similarity)),
    (results::MODEL_ORDER.name, Some(model_order)),
];

/// The tables a dataset job contributes to in this plan, with their builders.
fn dataset_tables(plan: &Plan) -> Vec<(&'static str, Builder)> {
    let mut tables: Vec<(&'static str, Builder)> = STANDARD
        .iter()
        .filter_map(|&(name, b)| b.map(|b| (name, b)))
        .collect();
    if plan.spec.hypotheses.is_some() {
        tables.push((results::CORRELATING_FUNCTION.name, correlating_function));
    }
    tables
}

/// A dataset job's fragments of every table it contributes to.
///
/// # Errors
/// If a fragment cannot be built.
pub fn fragments(
    plan: &Plan,
    job: &Job,
    result: &JobResult,
) -> Result<Vec<(&'static str, DataFrame)>> {
    dataset_tables(plan)
        .into_iter()
        .map(|(name, build)| {
            let df = build(plan, &[(job, result)]).with_context(|| format!("building {name}"))?;
            Ok((name, df))
        })
        .collect()
}

/// The tables every run of `plan` writes, even when empty: the standard ones and those of its
/// sections, in this order.
pub fn table_names(plan: &Plan) -> Vec<&'static str> {
    let mut names: Vec<&'static str> = STANDARD.iter().map(|(n, _)| *n).collect();
    for (n, _) in dataset_tables(plan) {
        if !names.contains(&n) {
            names.push(n);
        }
    }
    names
}

/// The empty table `name` with its columns.
///
/// # Errors
/// If the table's builder fails.
pub fn empty(plan: &Plan, name: &str) -> Result<DataFrame> {
    if name == results::JOBS.name {
        return status_rows(plan, &[]);
    }
    match dataset_tables(plan).into_iter().find(|(n, _)| *n == name) {
        Some((_, build)) => build(plan, &[]),
        None => Ok(DataFrame::empty()),
    }
}
