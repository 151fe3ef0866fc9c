//! Where each dissertation cell is found in the tool's outputs: for every table the
//! reproduction covers, the spec that produces it and, per cell, a query (a Parquet table of
//! the run, the rows' filter and the column) that yields the tool's value of that cell. The
//! map from a printed table to the tool's columns lives here and nowhere else.

use super::compare::{Spread, Summary};
use crate::apps::hypotheses::statistic;
use crate::io::results::{self, col, value, Table};
use crate::stats::metrics::name as metric_name;
use anyhow::{bail, Context, Result};
use polars::prelude::{
    BooleanChunked, ChunkCompareEq, ChunkFull, DataFrame, DataType, ParquetReader, SerReader,
};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A filter value.
#[derive(Debug, Clone, PartialEq)]
pub enum Key {
    /// A string column's value.
    S(&'static str),
    /// An integer column's value.
    I(i64),
    /// A string column's value starting with this.
    Prefix(&'static str),
}

/// The tool's value of one cell in one run: the single row of `table` that every filter
/// selects, its `column`, times `scale`.
#[derive(Debug, Clone)]
pub struct Query {
    /// The spec under `experiments/` whose runs hold the value (name without `.yaml`).
    pub spec: &'static str,
    /// The Parquet table of the run.
    pub table: Table,
    /// `(column, value)` pairs every selected row has.
    pub filters: Vec<(&'static str, Key)>,
    /// The value's column.
    pub column: &'static str,
    /// Multiplies the value (100 for a percentage).
    pub scale: f64,
    /// The value is a conclusion over every selected row (at least one): 1 when each row's
    /// `verdict` is `verified`, else 0 (`column` is then unused).
    pub all_verified: bool,
    /// Every selected row (at least one) is one repeat of the statistic: the spec repeats it
    /// inside one run (the CNN trainings' `repeats`), so the spec is run once and the spread
    /// is that of the rows.
    pub each_row: bool,
    /// The value is the mean over every selected row (at least one): a curve's average, as
    /// the mean test accuracy over the SCR points of a location experiment.
    pub mean_rows: bool,
    /// The value is the least over every selected row (at least one): the lowest SCR a
    /// location experiment swept.
    pub min_rows: bool,
    /// The value is the greatest over every selected row (at least one): the highest SCR a
    /// location experiment swept.
    pub max_rows: bool,
}

/// How the tool reproduces one dissertation table.
#[derive(Debug, Clone)]
pub struct Recipe {
    /// The table's number.
    pub number: u32,
    /// How its values behave under reseeding.
    pub spread: Spread,
    /// Per row, per column: the query of the cell (`None`: a cell the tool does not compute).
    pub cells: Vec<Vec<Option<Query>>>,
    /// Why the tool's values may differ from the printed ones (data, construction, protocol).
    pub differs_because: &'static str,
    /// Which of several readings of the table this is (the CNN tables under the
    /// dissertation's protocol and under held-out testing); `None` for a table read one way.
    pub protocol: Option<&'static str>,
}

impl Recipe {
    /// Its specs repeat the statistic inside one run ([`Query::each_row`]): run once, and
    /// too long for the quick test that reruns every table.
    pub fn runs_once(&self) -> bool {
        self.cells.iter().flatten().flatten().any(|q| q.each_row)
    }
}

/// The query of `column` in the one row of `table` that `filters` select in a run of `spec`
/// (scale 1, no flags).
pub(super) fn q(
    spec: &'static str,
    table: Table,
    filters: Vec<(&'static str, Key)>,
    column: &'static str,
) -> Query {
    Query {
        spec,
        table,
        filters,
        column,
        scale: 1.0,
        all_verified: false,
        each_row: false,
        mean_rows: false,
        min_rows: false,
        max_rows: false,
    }
}

const T3: &str = "table3_filter_correlation";
const DIRECTIONS: [&str; 3] = ["H", "V", "D"];
const METHODS3: [&str; 3] = ["full_covariance", "method1", "method2"];

/// The spec whose runs hold `dataset`.
fn spec_of(dataset: &str) -> &'static str {
    match dataset {
        "exponential" => "similarity_exponential",
        "nonexponential" => "similarity_nonexponential",
        _ => "similarity_plants",
    }
}

/// Similarity rows of `dataset` under `method` and `metric`, compared with all the originals
/// (`reference` = `in_sample`, what the dissertation's tables print).
fn sim(
    dataset: &'static str,
    method: &'static str,
    metric: &'static str,
) -> Vec<(&'static str, Key)> {
    vec![
        (col::DATASET, Key::S(dataset)),
        (col::METHOD, Key::S(method)),
        (col::METRIC, Key::S(metric)),
        (col::REFERENCE, Key::S(value::IN_SAMPLE)),
    ]
}

/// `query` (a similarity query) on the rows compared with originals no fit saw
/// (`reference` = `held_out`).
pub(super) fn held_out(query: &Query) -> Query {
    let mut q = query.clone();
    for (column, want) in &mut q.filters {
        if *column == col::REFERENCE {
            *want = Key::S(value::HELD_OUT);
        }
    }
    q
}

/// The average directional RMSE `statistic` (`average_level_1`, `average_levels_1_3`) of
/// `method`'s samples against `dataset`'s originals.
pub(super) fn rmse_average(
    dataset: &'static str,
    method: &'static str,
    statistic: &'static str,
) -> Query {
    let mut f = sim(dataset, method, metric_name::MULTISCALE_RMSE);
    f.push((col::STATISTIC, Key::S(statistic)));
    q(spec_of(dataset), results::SIMILARITY, f, col::VALUE)
}

/// The correlation matrix distance of `method`'s samples to `dataset`'s originals.
pub(super) fn cmd(dataset: &'static str, method: &'static str) -> Query {
    q(
        spec_of(dataset),
        results::SIMILARITY,
        sim(dataset, method, metric_name::CMD),
        col::VALUE,
    )
}

/// The mean KL divergence `metric` (`kl_pixel`, `kl_area`) of `part` (`re`, `im`) of
/// `method`'s samples against `dataset`'s originals.
pub(super) fn kl(
    dataset: &'static str,
    method: &'static str,
    metric: &'static str,
    part: &'static str,
) -> Query {
    let mut f = sim(dataset, method, metric);
    f.push((col::COMPONENT, Key::S(part)));
    f.push((col::STATISTIC, Key::S("mean")));
    q(spec_of(dataset), results::SIMILARITY, f, col::VALUE)
}

/// The directional RMSE of level `level`, direction `d`, in percent (the appendix tables).
fn rmse_percent(dataset: &'static str, method: &'static str, level: i64, d: &'static str) -> Query {
    let mut f = sim(dataset, method, metric_name::MULTISCALE_RMSE);
    f.push((col::STATISTIC, Key::S("rmse")));
    f.push((col::LEVEL, Key::I(level)));
    f.push((col::DIRECTION, Key::S(d)));
    Query {
        scale: 100.0,
        ..q(spec_of(dataset), results::SIMILARITY, f, col::VALUE)
    }
}

/// Tables 6 and 11: average RMSE at level 1 and levels 1-3 for full covariance, Method 1 and
/// Method 2, one row per dataset.
fn summary_rows(datasets: &[&'static str]) -> Vec<Vec<Option<Query>>> {
    datasets
        .iter()
        .map(|&ds| {
            METHODS3
                .iter()
                .flat_map(|&m| {
                    [
                        Some(rmse_average(ds, m, "average_level_1")),
                        Some(rmse_average(ds, m, "average_levels_1_3")),
                    ]
                })
                .collect()
        })
        .collect()
}

/// Tables 8-10 and 13-15: mean KL divergence by pixel and by 8 x 8 area, real and imaginary.
fn kl_rows(datasets: &[&'static str], method: &'static str) -> Vec<Vec<Option<Query>>> {
    datasets
        .iter()
        .map(|&ds| {
            vec![
                Some(kl(ds, method, metric_name::KL_PIXEL, "re")),
                Some(kl(ds, method, metric_name::KL_PIXEL, "im")),
                Some(kl(ds, method, metric_name::KL_AREA, "re")),
                Some(kl(ds, method, metric_name::KL_AREA, "im")),
            ]
        })
        .collect()
}

/// Tables 26, 28, 30, ...: RMSE (in percent) by level and direction, one column per method.
fn by_level(dataset: &'static str) -> Vec<Vec<Option<Query>>> {
    (1..=3)
        .flat_map(|level| {
            DIRECTIONS.iter().map(move |&d| {
                METHODS3
                    .iter()
                    .map(|&m| Some(rmse_percent(dataset, m, level, d)))
                    .collect()
            })
        })
        .collect()
}

const SIMULATED: &str = "The original data are the tool's own simulation of the construction the \
    text states; the dissertation's samples are not public, and its similarity values are one \
    draw each";
const KL: &str = "The dissertation names neither the histogram nor the treatment of empty bins \
    behind its KL divergence; every value it prints follows one sampling-floor law, KL about \
    c (1/N + 1/M) with c near 0.7-0.95, which the tool's estimator here reproduces (32 bins over \
    both sets' range, 0.5 pseudo-counts, symmetric, the sum over bins divided by their count; \
    docs/definitions.md section 6): the values are that floor, and the floor beside the table \
    says how far each lies above it. Two groups of printed values follow no estimator's floor at \
    the stated sizes: the non-exponential rows fit N = M = 1000 samples, not the 100 that the \
    captions of Figs. 113-116 state and the tool generates (so the tool's values, the floor of \
    100 samples, are about ten times the printed ones per pixel), and the full covariance's \
    8x8-area values of Table 8 (3.4-3.8e-6) lie 8-11 dB below every floor";
const KL_PLANTS: &str = "The histogram behind the KL divergence is not stated; the tool's (32 \
    bins, 0.5 pseudo-counts, symmetric, the mean over bins: docs/definitions.md section 6) has \
    the floor law every printed value follows. The measured plants are not public: the tool's \
    values come from its simulated stand-in plants D and E (docs/definitions.md section 10)";
const PLANTS: &str = "The measured plants are not public: the tool's values come from its \
    simulated stand-in plants D and E (docs/definitions.md section 10), whose wind response and \
    receiver noise are fitted to published tables (`isar-clutter calibrate-plants`, residuals in \
    reproduction/plant_calibration.json); two free parameters per plant cannot place all 30 \
    cells of a plant and wind";

/// Every table the reproduction covers but the CNN tables ([`super::cnn`]).
pub fn recipes() -> Vec<Recipe> {
    let mut r = vec![
        Recipe {
            number: 3,
            spread: Spread::Exact,
            cells: (0..=8)
                .map(|lag| {
                    let f = || vec![(col::DIRECTION, Key::S("H")), (col::LAG, Key::I(lag))];
                    vec![
                        Some(q(
                            T3,
                            results::FILTER_CORRELATION,
                            f(),
                            col::FILTER_COEFFICIENT,
                        )),
                        Some(q(T3, results::FILTER_CORRELATION, f(), col::CORRELATION)),
                    ]
                })
                .collect(),
            differs_because: "",
            protocol: None,
        },
        Recipe {
            number: 4,
            spread: Spread::Random,
            cells: (1..=3)
                .map(|level| {
                    DIRECTIONS
                        .iter()
                        .map(|&d| {
                            Some(q(
                                "table4_exponential",
                                results::ANALYSIS_SUMMARY,
                                vec![
                                    (col::SOURCE, Key::S("original")),
                                    (col::LEVEL, Key::I(level)),
                                    (col::DIRECTION, Key::S(d)),
                                ],
                                col::MEAN_CORRELATION,
                            ))
                        })
                        .collect()
                })
                .collect(),
            differs_because: SIMULATED,
            protocol: None,
        },
    ];
    // Tables 6-10 combine the exponential (1000 samples) and non-exponential (100 samples)
    // runs: one spec each, so those tables read two specs.
    similarity_tables(
        &mut r,
        &["exponential", "nonexponential"],
        (6, 25),
        Reasons {
            similarity: SIMULATED,
            kl: KL,
        },
    );
    similarity_tables(
        &mut r,
        &[
            "plant_D_light",
            "plant_D_medium",
            "plant_E_light",
            "plant_E_medium",
        ],
        (11, 29),
        Reasons {
            similarity: PLANTS,
            kl: KL_PLANTS,
        },
    );
    model_order(&mut r);
    r
}

/// The stand-in plants of Tables 1, 2 and 16, by printed row: plants A-C, no and light wind.
const PLANTS_ABC: [&str; 6] = [
    "plant_A_none",
    "plant_A_light",
    "plant_B_none",
    "plant_B_light",
    "plant_C_none",
    "plant_C_light",
];

const MODEL_ORDER: &str = "The measured plants are not public: the tool's values come from its \
    simulated stand-in plants, calibrated to Table 16's variances only (docs/definitions.md \
    section 10); the dissertation gives one value \
    per model where the tool measures the real and imaginary parts apart (the real part is \
    shown), and names neither the histogram behind its KL divergence nor the number of \
    generated samples (the tool: the estimator whose floor law the printed KL values follow, \
    docs/definitions.md section 6, and 5000 samples)";

/// The KL divergence `column` (dB, real part) of the model of `order` on dataset `ds` in a run
/// of `spec` (Tables 1-2 and the statements on them).
fn model_kl(spec: &'static str, ds: &'static str, order: i64, column: &'static str) -> Query {
    q(
        spec,
        results::MODEL_ORDER,
        vec![
            (col::DATASET, Key::S(ds)),
            (col::MODEL_ORDER, Key::I(order)),
            (col::COMPONENT, Key::S("re")),
        ],
        column,
    )
}

/// Tables 1 and 2 (model order: mean and worst-case KL divergence in dB, 2nd- and 4th-order
/// models) and Table 16 (mean pixel variance by plant and wind).
fn model_order(r: &mut Vec<Recipe>) {
    for (number, column) in [(1, col::KL_MEAN_DB), (2, col::KL_WORST_DB)] {
        r.push(Recipe {
            number,
            spread: Spread::Random,
            cells: PLANTS_ABC
                .iter()
                .map(|&ds| {
                    [2, 4]
                        .iter()
                        .map(|&order| Some(model_kl("model_order", ds, order, column)))
                        .collect()
                })
                .collect(),
            differs_because: MODEL_ORDER,
            protocol: None,
        });
    }
    // Table 16: rows no wind, light wind; columns plants A, B, C.
    r.push(Recipe {
        number: 16,
        spread: Spread::Random,
        cells: [0, 1]
            .iter()
            .map(|&wind| {
                (0..3)
                    .map(|plant| {
                        Some(q(
                            "hypotheses",
                            results::HYPOTHESES,
                            vec![
                                (col::HYPOTHESIS, Key::S("table16")),
                                (col::DATASET, Key::S(PLANTS_ABC[2 * plant + wind])),
                                (col::STATISTIC, Key::S("mean_pixel_variance")),
                            ],
                            col::VALUE,
                        ))
                    })
                    .collect()
            })
            .collect(),
        differs_because: "These cells are the calibration's targets: the stand-in plants A-C are \
            fitted to them (reproduction/plant_calibration.json: simulations of 100 samples from \
            the record's seeds), so the fit's own simulations match; the repeats here use other \
            seeds, and each differs by the statistic's sampling spread",
        protocol: None,
    });
    // Table 24: the hypotheses' conclusions, each over every plant and wind pair.
    let h = |hypothesis: &'static str, statistic: Key| {
        Some(Query {
            all_verified: true,
            ..q(
                "hypotheses",
                results::HYPOTHESES,
                vec![
                    (col::HYPOTHESIS, Key::S(hypothesis)),
                    (col::STATISTIC, statistic),
                ],
                col::VERDICT,
            )
        })
    };
    r.push(Recipe {
        number: 24,
        spread: Spread::Conclusion,
        cells: vec![
            vec![h("H1", Key::Prefix(statistic::VARIANCE_RATIO))],
            vec![h("H2", Key::S(statistic::SPEARMAN_DISTANCE_VS_MAGNITUDE))],
            vec![h("H3", Key::Prefix(statistic::FRACTION_OF_LEVEL_STEPS))],
            vec![h("H4", Key::Prefix(statistic::LEVELS_DECREASING_FRACTION))],
        ],
        differs_because: "The stand-in plants are simulated, not the measured ones; the tool's \
            thresholds are its own (docs/hypotheses.md), the dissertation judged by eye from \
            its figures; H4 is judged at every level, as the dissertation's 5.1.5 does",
        protocol: None,
    });
}

/// The reasons one family of similarity tables gives for differing: the summaries and the
/// correlation matrix tables, and the KL tables.
struct Reasons {
    similarity: &'static str,
    kl: &'static str,
}

/// One family of similarity tables, the generated data against the originals of `datasets`
/// (one row of each summary table per dataset): Tables `summary`..`summary + 4` (average
/// RMSE, correlation matrix distance of Methods 1 and 2, KL of full covariance, Method 1 and
/// Method 2) and, per dataset `i`, Tables `appendix + 2 i` (correlation matrix distance of the
/// three methods) and `appendix + 2 i + 1` (RMSE by level and direction). Tables 6-10 and
/// 25-28 (simulated data), 11-15 and 29-36 (plants D and E) are the two families.
fn similarity_tables(
    r: &mut Vec<Recipe>,
    datasets: &[&'static str],
    (summary, appendix): (u32, u32),
    reasons: Reasons,
) {
    let recipe = |number, cells, differs_because| Recipe {
        number,
        spread: Spread::Random,
        cells,
        differs_because,
        protocol: None,
    };
    r.push(recipe(summary, summary_rows(datasets), reasons.similarity));
    let cmd_rows = datasets
        .iter()
        .map(|&ds| vec![Some(cmd(ds, "method1")), Some(cmd(ds, "method2"))])
        .collect();
    r.push(recipe(summary + 1, cmd_rows, reasons.similarity));
    for (k, method) in METHODS3.iter().enumerate() {
        r.push(recipe(
            summary + 2 + k as u32,
            kl_rows(datasets, method),
            reasons.kl,
        ));
    }
    for (i, &ds) in datasets.iter().enumerate() {
        let number = appendix + 2 * i as u32;
        let cmd3 = vec![METHODS3.iter().map(|&m| Some(cmd(ds, m))).collect()];
        r.push(recipe(number, cmd3, reasons.similarity));
        r.push(recipe(number + 1, by_level(ds), reasons.similarity));
    }
}

/// The specs a recipe reads, in first use.
pub fn specs_of(recipe: &Recipe) -> Vec<&'static str> {
    let mut specs = Vec::new();
    for query in recipe.cells.iter().flatten().flatten() {
        if !specs.contains(&query.spec) {
            specs.push(query.spec);
        }
    }
    specs
}

/// The Parquet tables of one run folder, read once each.
#[derive(Default)]
pub struct Tables {
    read: HashMap<(PathBuf, &'static str), DataFrame>,
}

impl Tables {
    /// The value of `query` in the run in `dir`.
    ///
    /// # Errors
    /// If the table cannot be read (the file is named), or the filters select no row or
    /// several (the query and the folder are named).
    pub fn value(&mut self, dir: &Path, query: &Query) -> Result<f64> {
        let picked = self.picked(dir, query)?;
        if query.all_verified && picked.height() > 0 {
            let verdicts = picked.column(col::VERDICT)?.str()?.clone();
            let all = verdicts.iter().all(|v| v == Some("verified"));
            return Ok(f64::from(u8::from(all)));
        }
        if query.mean_rows && picked.height() > 0 {
            let v = column_values(&picked, query)?;
            return Ok(v.iter().sum::<f64>() / v.len() as f64);
        }
        if query.min_rows && picked.height() > 0 {
            let v = column_values(&picked, query)?;
            return Ok(v.iter().copied().fold(f64::INFINITY, f64::min));
        }
        if query.max_rows && picked.height() > 0 {
            let v = column_values(&picked, query)?;
            return Ok(v.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        }
        if picked.height() != 1 {
            bail!(
                "{}/{}.parquet: {} row(s) where {:?} (expected one)",
                dir.display(),
                query.table.name,
                picked.height(),
                query.filters
            );
        }
        Ok(column_values(&picked, query)?[0])
    }

    /// The mean and spread of `query` over the runs in `dirs`: every value
    /// [`Tables::values`] gives in each.
    ///
    /// # Errors
    /// As [`Tables::values`].
    pub fn summary_over(&mut self, dirs: &[&Path], query: &Query) -> Result<Summary> {
        let mut values = Vec::new();
        for dir in dirs {
            values.extend(self.values(dir, query)?);
        }
        Ok(Summary::of(&values))
    }

    /// The values of `query` in the run in `dir`: every selected row's where the rows are
    /// repeats ([`Query::each_row`]: at least one), else the one [`Tables::value`].
    ///
    /// # Errors
    /// As [`Tables::value`]; for rows that are repeats, if no row is selected.
    pub fn values(&mut self, dir: &Path, query: &Query) -> Result<Vec<f64>> {
        if !query.each_row {
            return Ok(vec![self.value(dir, query)?]);
        }
        let picked = self.picked(dir, query)?;
        if picked.height() == 0 {
            bail!(
                "{}/{}.parquet: no row where {:?}",
                dir.display(),
                query.table.name,
                query.filters
            );
        }
        column_values(&picked, query)
    }

    /// The rows of `query`'s table in `dir` that its filters select, in the table's order.
    fn picked(&mut self, dir: &Path, query: &Query) -> Result<DataFrame> {
        let key = (dir.to_path_buf(), query.table.name);
        if !self.read.contains_key(&key) {
            let path = query.table.path(dir);
            let file = std::fs::File::open(&path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let df = ParquetReader::new(file)
                .finish()
                .with_context(|| format!("cannot read {} as Parquet", path.display()))?;
            self.read.insert(key.clone(), df);
        }
        let df = &self.read[&key];
        let mut mask = BooleanChunked::full("m".into(), true, df.height());
        for (column, want) in &query.filters {
            let col = df.column(column).with_context(|| {
                format!(
                    "{}/{}.parquet has no column {column}",
                    dir.display(),
                    query.table.name
                )
            })?;
            let hit = match want {
                Key::S(s) => col.str()?.equal(*s),
                Key::I(i) => col.cast(&DataType::Int64)?.i64()?.equal(*i),
                Key::Prefix(p) => col
                    .str()?
                    .iter()
                    .map(|v| Some(v.is_some_and(|v| v.starts_with(p))))
                    .collect(),
            };
            mask = &mask & &hit;
        }
        Ok(df.filter(&mask)?)
    }
}

/// `query.column` of every row of `picked`, times `query.scale` (a null is NaN).
fn column_values(picked: &DataFrame, query: &Query) -> Result<Vec<f64>> {
    Ok(picked
        .column(query.column)?
        .cast(&DataType::Float64)?
        .f64()?
        .iter()
        .map(|v| v.unwrap_or(f64::NAN) * query.scale)
        .collect())
}

/// A number the text states (not a table cell), computed by the tool: per repeat, the mean
/// over `terms` of `a - b`, each term's queries read from the same repeat of their specs.
#[derive(Debug, Clone)]
pub struct Statement {
    /// The start of the statement's `quantity` in the reference (`figures:`).
    pub quantity: &'static str,
    /// The differences averaged.
    pub terms: Vec<(Query, Query)>,
    /// What the tool's number is, in words.
    pub computed: &'static str,
    /// Why it may differ.
    pub differs_because: &'static str,
    /// The text states only an ordering, `a` above `b` (no number): the verdict is
    /// `ordering holds` where the tool's mean is above zero, else `differs`.
    pub ordering: bool,
    /// The unit of the tool's number where it is not the reference's (`None`: the same).
    pub unit: Option<&'static str>,
    /// Per term (or none), the least value its `b` can take in the run (a [`Query::min_rows`]):
    /// where `b` is at it, the level was already reached at the lowest point swept, and the
    /// repeat's difference `a - b` is a lower bound.
    pub censor: Vec<Query>,
    /// Per term (or none), the greatest value its `a` can take in the run (a
    /// [`Query::max_rows`]): where `a` has no value (the level was not reached in the range
    /// swept, so it lies above that value) and `b` has one, the repeat's difference is taken
    /// with that value and is a lower bound.
    pub censor_above: Vec<Query>,
}

/// A statement the text gives a number for (not an ordering), in the reference's unit.
pub(super) fn number(
    quantity: &'static str,
    terms: Vec<(Query, Query)>,
    computed: &'static str,
    differs_because: &'static str,
) -> Statement {
    Statement {
        quantity,
        terms,
        computed,
        differs_because,
        ordering: false,
        unit: None,
        censor: Vec::new(),
        censor_above: Vec::new(),
    }
}

/// The statements the reproduction computes from the model-order runs (the CNN ones are
/// [`super::cnn`]'s).
pub fn statements() -> Vec<Statement> {
    // 3.2: half resolution improves the worst-case KL divergence by about 1 dB: the worst
    // pixel's KL (dB, real part) at full minus at half resolution, over plants A-C, no and
    // light wind, both models.
    let terms = PLANTS_ABC
        .iter()
        .flat_map(|&ds| {
            [2, 4].map(|order| {
                (
                    model_kl("model_order", ds, order, col::KL_WORST_DB),
                    model_kl("model_order_half", ds, order, col::KL_WORST_DB),
                )
            })
        })
        .collect();
    // 6.1: the 4th-order model improves on the 2nd-order one by less than 1 dB: the mean
    // image KL divergence (dB, real part, Table 1's column) of the 2nd- minus the 4th-order
    // model, over plants A-C, no and light wind.
    let orders = PLANTS_ABC
        .iter()
        .map(|&ds| {
            let mean = |order| model_kl("model_order", ds, order, col::KL_MEAN_DB);
            (mean(2), mean(4))
        })
        .collect();
    vec![
        number(
            "Half-resolution",
            terms,
            "worst-pixel KL divergence (dB, real part) at full resolution minus at \
                half resolution (experiments/model_order_half.yaml: 8 GHz x 25.5 degrees), mean \
                over plants A-C, no and light wind, 2nd- and 4th-order models",
            MODEL_ORDER,
        ),
        number(
            "KL divergence improvement of the 4th-order",
            orders,
            "mean-image KL divergence (dB, real part; Table 1) of the 2nd-order model \
                minus the 4th-order model's, mean over plants A-C, no and light wind (a \
                positive number: the 4th order is better)",
            MODEL_ORDER,
        ),
    ]
}
