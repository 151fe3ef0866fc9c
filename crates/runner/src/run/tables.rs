//! The run's tables: each dataset job's fragment of every long-format table (one builder per
//! table, called on that job's result alone), the tables every run writes and their empty
//! forms; [`crate::run::assembly`] streams the fragments of all jobs in plan order into the
//! Parquet tables of the run.
//!
//! Table layout is a public contract (see `docs/spec.md`): `analysis_maps`,
//! `analysis_summary`, `pixel_stats`, `filter_correlation`, `jobs`, `synthesis_params`,
//! `similarity`, `model_order`, and with their sections `correlating_function`, `hypotheses`,
//! `calibration`, `calibration_summary`.

use crate::io::results;
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("source", Kind::S),
            ("level", Kind::I),
            ("direction", Kind::S),
            ("row", Kind::I),
            ("col", Kind::I),
            ("correlation", Kind::F),
            ("covariance", Kind::F),
            ("expected_correlation", Kind::F),
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
                    t.s("job", &job.id);
                    t.s("dataset", &job.dataset_id);
                    t.s("source", r.source);
                    t.i("level", lm.level as i64);
                    t.s("direction", d.as_str());
                    t.i("row", rc.0 as i64);
                    t.i("col", rc.1 as i64);
                    t.f("correlation", opt(corr));
                    t.f("covariance", opt(cov));
                    t.f("expected_correlation", expected.map(|e| e[rc]));
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("source", Kind::S),
            ("level", Kind::I),
            ("direction", Kind::S),
            ("mean_correlation", Kind::F),
            ("mean_covariance", Kind::F),
            ("nan_cells", Kind::I),
            ("cells", Kind::I),
            ("rows", Kind::I),
            ("cols", Kind::I),
            ("expected_mean_correlation", Kind::F),
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
                t.s("job", &job.id);
                t.s("dataset", &job.dataset_id);
                t.s("source", r.source);
                t.i("level", lm.level as i64);
                t.s("direction", d.as_str());
                t.f("mean_correlation", opt(s.mean_correlation));
                t.f("mean_covariance", opt(s.mean_covariance));
                t.i("nan_cells", s.nan_cells as i64);
                t.i("cells", (rows * cols) as i64);
                t.i("rows", rows as i64);
                t.i("cols", cols as i64);
                t.f("expected_mean_correlation", expected);
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("source", Kind::S),
            ("row", Kind::I),
            ("col", Kind::I),
            ("mean_re", Kind::F),
            ("mean_im", Kind::F),
            ("variance", Kind::F),
        ],
    );
    for &(job, r) in results {
        let Some(analysis) = &r.analysis else {
            continue;
        };
        for ((rc, m), &v) in analysis.mean.indexed_iter().zip(analysis.variance.iter()) {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("source", r.source);
            t.i("row", rc.0 as i64);
            t.i("col", rc.1 as i64);
            t.f("mean_re", opt(m.re));
            t.f("mean_im", opt(m.im));
            t.f("variance", opt(v));
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("direction", Kind::S),
            ("lag", Kind::I),
            ("filter_coefficient", Kind::F),
            ("correlation", Kind::F),
        ],
    );
    for &(job, r) in results {
        for row in &r.filter_rows {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("direction", row.direction.as_str());
            t.i("lag", row.lag as i64);
            t.f("filter_coefficient", opt(row.coefficient));
            t.f("correlation", opt(row.correlation));
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("kind", Kind::S),
            ("method", Kind::S),
            ("status", Kind::S),
            ("error", Kind::S),
            ("seed", Kind::U),
            ("data_seed", Kind::U),
            ("generation_seed", Kind::U),
            ("samples", Kind::I),
            ("height", Kind::I),
            ("width", Kind::I),
            ("levels", Kind::I),
            ("elapsed_s", Kind::F),
        ],
    );
    for &(job, error, elapsed_s) in rows {
        let (n, h, w) = job.dataset.shape();
        t.s("job", &job.id);
        t.s("dataset", &job.dataset_id);
        t.s("kind", job.dataset.kind());
        t.s_opt("method", job.method.map(|m| m.as_str().into()));
        t.s("status", if error.is_none() { "ok" } else { "failed" });
        t.s_opt("error", error.map(Cow::Borrowed));
        t.u("seed", job.seed);
        t.u("data_seed", job.data_seed);
        t.u("generation_seed", job.generation_seed);
        t.i("samples", n as i64);
        t.i("height", h as i64);
        t.i("width", w as i64);
        t.i("levels", job.analysis.levels as i64);
        t.f("elapsed_s", opt(elapsed_s));
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
        ("job", Kind::S),
        ("dataset", Kind::S),
        ("method", Kind::S),
        ("row", Kind::I),
        ("col", Kind::I),
        ("alpha_h", Kind::F),
        ("alpha_v", Kind::F),
    ]
    .iter()
    .map(|(n, k)| (n.to_string(), *k))
    .collect();
    for dir in ["h", "v"] {
        names.extend((1..=l_max).map(|l| (format!("r_{dir}{l}"), Kind::F)));
    }
    names.extend([
        ("residual_h".to_string(), Kind::F),
        ("residual_v".to_string(), Kind::F),
        ("clamped".to_string(), Kind::I),
    ]);
    let mut t = Table::new(plan, &names);
    for (job, f) in fits {
        for ((r, c), &clamped) in f.clamped.indexed_iter() {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("method", job.method.map_or("", |m| m.as_str()));
            t.i("row", r as i64);
            t.i("col", c as i64);
            let (alpha, rs) = match &f.params {
                CellParams::Exponential {
                    alpha_h, alpha_v, ..
                } => (Some((alpha_h[[r, c]], alpha_v[[r, c]])), None),
                CellParams::Dyadic { r_h, r_v } => (None, Some((r_h, r_v))),
            };
            t.f("alpha_h", alpha.map(|a| a.0));
            t.f("alpha_v", alpha.map(|a| a.1));
            for (dir, idx) in [("h", 0), ("v", 1)] {
                for l in 0..l_max {
                    let v = rs.and_then(|(h, v)| [h, v][idx].get(l)).map(|m| m[[r, c]]);
                    t.f(&format!("r_{dir}{}", l + 1), v);
                }
            }
            t.f("residual_h", opt(f.residual_h[[r, c]]));
            t.f("residual_v", opt(f.residual_v[[r, c]]));
            t.i("clamped", clamped as i64);
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("method", Kind::S),
            ("metric", Kind::S),
            ("level", Kind::I),
            ("direction", Kind::S),
            ("component", Kind::S),
            ("statistic", Kind::S),
            ("value", Kind::F),
            ("units", Kind::I),
            ("samples_original", Kind::I),
            ("samples_compared", Kind::I),
            ("noise_floor", Kind::S),
            ("reference", Kind::S),
            ("bins", Kind::I),
            ("smoothing", Kind::F),
            ("symmetric", Kind::B),
            ("db", Kind::B),
            ("mean_over_bins", Kind::B),
            ("bias_correction", Kind::S),
            ("block", Kind::I),
            ("cmd_form", Kind::S),
        ],
    );
    let outcomes = results.iter().flat_map(|&(job, r)| {
        [(&r.similarity, "in_sample"), (&r.held_out, "held_out")]
            .into_iter()
            .filter_map(move |(sim, reference)| Some((job, sim.as_ref()?, reference)))
    });
    for (job, sim, reference) in outcomes {
        for row in &sim.comparison.rows {
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.s("method", sim.compared);
            t.s("metric", row.metric);
            t.i_opt("level", row.level.map(|l| l as i64));
            t.s_opt("direction", row.direction.map(|d| d.as_str().into()));
            t.s_opt("component", row.component.map(Into::into));
            t.s("statistic", row.statistic);
            t.f("value", Some(row.value).filter(|v| !v.is_nan()));
            t.i("units", row.units as i64);
            t.i("samples_original", sim.comparison.samples.0 as i64);
            t.i("samples_compared", sim.comparison.samples.1 as i64);
            t.s_opt("noise_floor", sim.noise_floor.map(Into::into));
            t.s("reference", reference);
            t.i_opt("bins", row.kl.map(|k| k.bins as i64));
            t.f("smoothing", row.kl.map(|k| k.smoothing));
            t.b("symmetric", row.kl.map(|k| k.symmetric));
            t.b("db", row.kl.map(|k| k.db));
            t.b("mean_over_bins", row.kl.map(|k| k.mean_over_bins));
            t.s_opt(
                "bias_correction",
                row.kl.map(|k| k.bias_correction.as_str().into()),
            );
            t.i_opt("block", row.block.map(|b| b as i64));
            t.s_opt("cmd_form", row.form.as_deref().map(Into::into));
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("model_order", Kind::I),
            ("component", Kind::S),
            ("kl_mean_db", Kind::F),
            ("kl_worst_db", Kind::F),
            ("pixels", Kind::I),
            ("samples_original", Kind::I),
            ("samples_compared", Kind::I),
            ("bins", Kind::I),
            ("smoothing", Kind::F),
            ("symmetric", Kind::B),
            ("mean_over_bins", Kind::B),
            ("bias_correction", Kind::S),
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
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.i_opt("model_order", order);
            t.s("component", component);
            t.f(
                "kl_mean_db",
                Some(to_db(mean.value)).filter(|v| !v.is_nan()),
            );
            t.f(
                "kl_worst_db",
                Some(to_db(max.value)).filter(|v| !v.is_nan()),
            );
            t.i("pixels", mean.units as i64);
            t.i("samples_original", sim.comparison.samples.0 as i64);
            t.i("samples_compared", sim.comparison.samples.1 as i64);
            t.i("bins", kl.bins as i64);
            t.f("smoothing", Some(kl.smoothing));
            t.b("symmetric", Some(kl.symmetric));
            t.b("mean_over_bins", Some(kl.mean_over_bins));
            t.s("bias_correction", kl.bias_correction.as_str());
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
            ("job", Kind::S),
            ("dataset", Kind::S),
            ("dy", Kind::I),
            ("dx", Kind::I),
            ("distance", Kind::F),
            ("mean_correlation", Kind::F),
            ("mean_magnitude", Kind::F),
            ("pairs", Kind::I),
        ],
    );
    for &(job, r) in results {
        let Some(cf) = &r.correlating else {
            continue;
        };
        let half = (cf.real.nrows() / 2) as i64;
        for ((a, b), &v) in cf.real.indexed_iter() {
            let (dy, dx) = (a as i64 - half, b as i64 - half);
            t.s("job", &job.id);
            t.s("dataset", &job.dataset_id);
            t.i("dy", dy);
            t.i("dx", dx);
            t.f("distance", Some(((dy * dy + dx * dx) as f64).sqrt()));
            t.f("mean_correlation", Some(v).filter(|v| !v.is_nan()));
            let m = cf.magnitude[[a, b]];
            t.f("mean_magnitude", Some(m).filter(|m| !m.is_nan()));
            t.i("pairs", cf.pairs[[a, b]] as i64);
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
    if name == "jobs" {
        return status_rows(plan, &[]);
    }
    match dataset_tables(plan).into_iter().find(|(n, _)| *n == name) {
        Some((_, build)) => build(plan, &[]),
        None => Ok(DataFrame::empty()),
    }
}
