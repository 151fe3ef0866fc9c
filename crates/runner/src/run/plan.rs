//! From a spec file to a validated list of jobs: sweep expansion (grid axes in all
//! combinations, zip axes paired), readable job ids, and seeds derived from the master seed and
//! each job's canonical identity (never its position), so adding a job does not change the
//! others' random numbers.
//!
//! A sweep axis is a dotted field path: `datasets.<id>.<field>[.<sub>...]` (`<id>` may be `*`
//! for every dataset; a numeric component indexes a list, e.g. `datasets.d.r_h.0`) or
//! `analysis.<field>` or `synthesis.<field>`. An axis applies to the jobs of the datasets it
//! names (synthesis axes to the synthesis jobs only); jobs that the swept values do not touch
//! are not duplicated.
//!
//! With a `synthesis` section every dataset and sweep point gives an analysis job (the
//! original data, `source = original`) and one job per method (`<dataset>.<method>...`).

use crate::experiment::{
    self, AnalysisSpec, Ctx, Dataset, DatasetSpec, RawSpec, SpecError, SynthesisSpec,
};
use crate::run::params::Params;
use crate::seeds::{derive_seed, sha256_hex};
use crate::synthesis::Method;
use serde::Serialize;
use serde_json::Value as Json;
use serde_yaml_ng::Value as Yaml;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Most sweep points a spec may ask for: the product of the grid axes' lengths times the zip
/// axes' common length, counted (with checked multiplication) before anything is expanded, so a
/// sweep of `12^8` points is refused at once instead of exhausting memory. A larger study is
/// split into several specs.
pub const MAX_SWEEP_POINTS: usize = MAX_JOBS;

/// Most jobs a plan may hold (datasets x sweep points x (1 + synthesis methods), less the jobs
/// that sweep axes do not touch and are not duplicated). What sets it is the plan itself: a
/// job takes about 2.7 KB of it (283 MB for 100,000 tiny jobs, measured with `validate`), held
/// by `run`, `merge` and `status` alike, so a million jobs take about 3 GB and 20 s to expand;
/// the merge's tables and manifest are streamed and no longer grow with the jobs.
pub const MAX_JOBS: usize = 1_000_000;

/// One unit of work: a dataset under one sweep point.
#[derive(Debug, Clone)]
pub struct Job {
    /// Readable, file-name-safe id (`held.alpha_h=0.5`).
    pub id: String,
    /// The dataset's id.
    pub dataset_id: String,
    /// Validated dataset after the sweep's overrides.
    pub dataset: Dataset,
    /// Validated analysis settings after the sweep's overrides.
    pub analysis: AnalysisSpec,
    /// The synthesis method of a synthesis job (`None`: the analysis of the original data).
    pub method: Option<Method>,
    /// Validated synthesis settings of a synthesis job.
    pub synthesis: Option<SynthesisSpec>,
    /// Seed of the generated samples: hash of the master seed and the dataset identity, the
    /// same for every method of one dataset (common random numbers).
    pub generation_seed: u64,
    /// Swept values that apply to this job, by short key (`alpha_h`, `levels`).
    pub params: Params,
    /// Job seed: hash of the master seed and the job identity.
    pub seed: u64,
    /// Data seed: hash of the master seed and the dataset identity (dataset id and the
    /// dataset's own swept values), shared by jobs that see the same data.
    pub data_seed: u64,
    /// The noise floor an analysis job measures when the spec has metrics.
    pub noise_floor: Option<NoiseFloorPlan>,
}

impl Job {
    /// Canonical identity (JSON of the dataset id, the method and the swept values) from which
    /// the seeds are derived; made on demand, not held (about 150 bytes a job).
    pub fn identity(&self) -> String {
        identity(&self.dataset_id, self.method, &self.params)
    }
}

/// How an analysis job measures the metrics' noise floor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseFloorPlan {
    /// The original against an independent draw of `samples` samples from the synthetic model,
    /// generated from `seed` (hash of the master seed and the job identity).
    Draws {
        /// Samples of the independent draw (`synthesis.samples`).
        samples: usize,
        /// Data seed of the draw.
        seed: u64,
    },
    /// The first `floor(N/2)` samples against the last `floor(N/2)`.
    Halves,
}

impl NoiseFloorPlan {
    /// `draws` or `halves`.
    pub fn as_str(&self) -> &'static str {
        match self {
            NoiseFloorPlan::Draws { .. } => "draws",
            NoiseFloorPlan::Halves => "halves",
        }
    }
}

/// A validated experiment.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The spec file.
    pub file: PathBuf,
    /// SHA-256 of the spec file's bytes (hex).
    pub spec_hash: String,
    /// The parsed spec.
    pub spec: RawSpec,
    /// Dataset jobs in spec order (datasets, then sweep points); every job of the run, these
    /// and those of the run as a whole, is listed by [`crate::run::jobs::all::AllJobs`].
    pub jobs: Vec<Job>,
    /// Short keys of all swept parameters, sorted (the extra table columns).
    pub param_keys: Vec<String>,
    /// For each of `param_keys`, whether every job's value of it is a number: the column's
    /// type, the same in every table (a float column, else a string column). Found once here:
    /// each table fragment used to look at every job of the plan for it, which made a merge
    /// quadratic in its jobs.
    pub param_numeric: Vec<bool>,
    /// Whether a job fits the second- or fourth-order model (the `model_order` table has rows).
    /// Found once here, like `param_numeric`: each job's fragment looked at every job of the
    /// plan for it (a sixth of a 100,000-job run's CPU).
    pub model_orders: bool,
    /// Validated similarity metrics (empty: none).
    pub metrics: Vec<crate::stats::metrics::Metric>,
    /// The validated CNN sections (`classification`, `location`).
    pub cnn: experiment::Applications,
    /// The master seed given in place of the spec's ([`load_seeded`]); `None`: the spec's.
    /// `spec.seed` holds the seed in effect either way.
    pub seed_override: Option<u64>,
    /// Where the CNN trainings run, as [`Plan::resolve_training_device`] found it.
    pub training_device: Option<String>,
}

/// A parsed sweep axis.
#[derive(Debug, Clone)]
struct Axis {
    /// The axis as written, e.g. `datasets.held.alpha_h`.
    key: String,
    /// YAML path of the axis in the spec (`sweep.grid.<key>`).
    at: String,
    /// `Some(id)` for a dataset field (`*` = all), `None` for an analysis or synthesis field.
    dataset: Option<String>,
    /// Whether the axis sets a `synthesis` field.
    synthesis: bool,
    /// Field path below the dataset or analysis section.
    field: Vec<String>,
    /// Values.
    values: Vec<Yaml>,
    /// The values as JSON (as tables and identities hold them).
    json: Vec<Json>,
    /// The parameter's name in tables and job ids ([`Axis::short_of`]), shared by the jobs.
    short: Arc<str>,
}

impl Axis {
    /// The parameter's name in tables and job ids: the field path below the dataset or
    /// analysis section, and `synthesis.<field>` for synthesis fields (which share names with
    /// dataset fields such as `samples`).
    fn short_of(field: &[String], synthesis: bool) -> String {
        let field = field.join(".");
        if synthesis {
            format!("synthesis.{field}")
        } else {
            field
        }
    }

    /// Whether the axis sets a field of `ds`'s job for `method`: analysis axes apply to every
    /// job, synthesis axes to synthesis jobs, `*` to every dataset whose kind takes the field,
    /// an id to that dataset.
    fn applies_to(&self, ds: &DatasetSpec, method: Option<Method>) -> bool {
        if self.synthesis {
            return method.is_some();
        }
        match self.dataset.as_deref() {
            None => true,
            Some("*") => ds.fields().contains(&self.field[0].as_str()),
            Some(id) => id == ds.id,
        }
    }
}

/// Loads, parses and validates a spec file into a [`Plan`]. Nothing is written.
///
/// # Errors
/// A [`SpecError`] naming the file, the YAML path and (when the parser gives it) the line.
pub fn load(file: &Path) -> Result<Plan, SpecError> {
    load_seeded(file, None)
}

/// [`load`] with the master seed `seed` in place of the spec's `seed` (`None`: the spec's):
/// a repeat of the experiment with other random numbers (`run --seed`, `reproduce`). Every
/// seed of the plan derives from it; the spec's hash is that of its file, unchanged.
///
/// # Errors
/// As [`load`].
pub fn load_seeded(file: &Path, seed: Option<u64>) -> Result<Plan, SpecError> {
    let bytes = std::fs::read(file)
        .map_err(|e| SpecError::at(file, ".", format!("cannot read the spec: {e}")))?;
    let text = String::from_utf8(bytes.clone())
        .map_err(|_| SpecError::at(file, ".", "the spec is not UTF-8 text"))?;
    let text = experiment::strip_bom(&text).to_string();
    let mut spec = experiment::parse(&text, file)?;
    if let Some(seed) = seed {
        spec.seed = seed;
    }
    let raw: Yaml =
        serde_yaml_ng::from_str(&text).map_err(|e| SpecError::at(file, ".", e.to_string()))?;
    let ctx = Ctx { file };
    check_top(&spec, raw.get("analysis").is_some(), &ctx)?;
    let metrics = experiment::check_metrics(&spec.metrics, spec.synthesis.as_ref(), &ctx)?;
    let axes = parse_axes(&spec, &ctx)?;
    let points = sweep_points(&axes, &ctx)?;
    let mut jobs = expand(&spec, &raw, &ctx, &axes, &points)?;
    for job in &mut jobs {
        check_job_metrics(&spec, &metrics, &ctx, job)?;
    }
    assign_ids(&mut jobs);
    jobs.shrink_to_fit();
    // The stacks the analysis jobs read, which the CNN sections name by dataset id (listed
    // only when a section asks: each holds a copy of its dataset).
    let stacks = || -> Vec<crate::experiment::DataRef> {
        jobs.iter()
            .filter(|j| j.method.is_none())
            .map(|j| crate::experiment::DataRef {
                id: j.dataset_id.clone(),
                dataset: j.dataset.clone(),
                data_seed: j.data_seed,
            })
            .collect()
    };
    let cnn = experiment::Applications::validate(spec.cnn(), &ctx, stacks)?;
    let mut param_keys: Vec<String> = axes.iter().map(|a| a.short.to_string()).collect();
    param_keys.sort();
    param_keys.dedup();
    let param_numeric = param_keys
        .iter()
        .map(|key| {
            jobs.iter()
                .filter_map(|j| j.params.get(key))
                .all(Json::is_number)
        })
        .collect();
    let model_orders = jobs
        .iter()
        .any(|j| j.method.and_then(Method::model_order).is_some());
    Ok(Plan {
        seed_override: seed,
        file: file.to_path_buf(),
        spec_hash: sha256_hex(text.as_bytes()),
        spec,
        jobs,
        param_keys,
        param_numeric,
        model_orders,
        metrics,
        cnn,
        training_device: None,
    })
}

/// The jobs of the spec: every dataset at every sweep point, analysed and synthesised with each
/// method, the axes that apply to it setting its parameters; a job whose identity repeats
/// another's (an axis that does not apply) is listed once. Ids and metrics come after.
///
/// # Errors
/// When two axes set the same parameter of a dataset, or the jobs pass [`MAX_JOBS`].
fn expand(
    spec: &RawSpec,
    raw: &Yaml,
    ctx: &Ctx,
    axes: &[Axis],
    points: &[Vec<(usize, usize)>],
) -> Result<Vec<Job>, SpecError> {
    let mut jobs: Vec<Job> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let methods: Vec<Option<Method>> = std::iter::once(None)
        .chain(
            spec.synthesis
                .iter()
                .flat_map(|s| s.methods.iter().copied().map(Some)),
        )
        .collect();
    for (i, ds) in spec.datasets.iter().enumerate() {
        for point in points {
            for &method in &methods {
                let applied: Vec<&(usize, usize)> = point
                    .iter()
                    .filter(|(a, _)| axes[*a].applies_to(ds, method))
                    .collect();
                let pairs = applied
                    .iter()
                    .map(|&&(a, v)| (axes[a].short.clone(), axes[a].json[v].clone()))
                    .collect();
                let params = Params::new(pairs).map_err(|key| {
                    let axis = applied
                        .iter()
                        .map(|&&(a, _)| &axes[a])
                        .filter(|axis| axis.short == key)
                        .nth(1)
                        .expect("a key given twice");
                    ctx.err(
                        &axis.at,
                        format!("another sweep axis also sets `{key}` of dataset {}", ds.id),
                    )
                })?;
                let identity = identity(&ds.id, method, &params);
                // Identities seen, by their 128-bit hash (a collision, about 2^-100 for a
                // million jobs, would drop a job): a set of the strings held a second copy
                // of every identity while the plan was built.
                if !seen.insert(xxhash_rust::xxh3::xxh3_128(identity.as_bytes())) {
                    continue;
                }
                if jobs.len() == MAX_JOBS {
                    return Err(too_many_jobs(spec, points.len(), methods.len(), ctx));
                }
                let job = build_job(
                    spec,
                    raw,
                    ctx,
                    (i, ds, method),
                    axes,
                    &applied,
                    params,
                    identity,
                )?;
                jobs.push(job);
            }
        }
    }
    Ok(jobs)
}

impl Plan {
    /// Seed of the simulated calibration measurements (hash of the master seed).
    pub fn calibration_seed(&self) -> u64 {
        derive_seed(self.spec.seed, "calibration", "")
    }
}

/// Checks the metrics against one job's data and sets an analysis job's noise floor.
fn check_job_metrics(
    spec: &RawSpec,
    metrics: &[crate::stats::metrics::Metric],
    ctx: &Ctx,
    job: &mut Job,
) -> Result<(), SpecError> {
    use crate::experiment::NoiseFloor;
    let (n, h, w) = job.dataset.shape();
    for (i, m) in metrics.iter().enumerate() {
        if let crate::stats::metrics::Metric::KlArea(_, block) = m {
            if *block > h.min(w) {
                return Err(ctx.err(
                    format!("metrics[{i}].kl_area.block"),
                    format!(
                        "block {block} is larger than the {h}x{w} images of dataset {}",
                        job.dataset_id
                    ),
                ));
            }
        }
    }
    let (Some(syn), None, false) = (&spec.synthesis, job.method, metrics.is_empty()) else {
        return Ok(());
    };
    // Datasets that can be drawn again: filtered noise (cheap: the default), simulated plants
    // (as costly as the dataset itself: only when `draws` is asked for).
    let drawable = job.dataset.redrawable();
    let draws = NoiseFloorPlan::Draws {
        samples: syn.samples,
        seed: derive_seed(spec.seed, "noise_floor", &job.identity()),
    };
    job.noise_floor = match (spec.noise_floor, drawable) {
        (NoiseFloor::None, _) => None,
        (NoiseFloor::Auto, Some(true)) | (NoiseFloor::Draws, Some(_)) => Some(draws),
        (NoiseFloor::Draws, None) => {
            return Err(ctx.err(
                "noise_floor",
                format!(
                    "`draws` needs a synthetic or simulated dataset; {} is read from a file \
                     (use `halves`)",
                    job.dataset_id
                ),
            ))
        }
        (NoiseFloor::Halves | NoiseFloor::Auto, _) => {
            if n < 4 {
                return Err(ctx.err(
                    "noise_floor",
                    format!(
                        "`halves` needs at least 4 samples; dataset {} has {n}",
                        job.dataset_id
                    ),
                ));
            }
            Some(NoiseFloorPlan::Halves)
        }
    };
    Ok(())
}

/// Document-level checks: name, unique dataset ids.
fn check_top(spec: &RawSpec, analysis_given: bool, ctx: &Ctx) -> Result<(), SpecError> {
    if spec.name.is_empty()
        || !spec
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c))
        || spec.name.starts_with('.')
    {
        return Err(ctx.err("name", format!("name {:?} must be non-empty ASCII letters, digits, `_`, `-` or `.` (it names the output folder)", spec.name)));
    }
    if spec.datasets.is_empty() && spec.calibration.is_none() {
        return Err(ctx.err("datasets", "at least one dataset is needed"));
    }
    let text_has_analysis = spec.datasets.is_empty() || analysis_given;
    if !text_has_analysis {
        return Err(ctx.err(
            "analysis",
            "missing field `analysis` (levels of the multiscale analysis)",
        ));
    }
    if let Some(c) = &spec.calibration {
        c.check()
            .map_err(|(field, msg)| ctx.err(format!("calibration.{field}"), msg))?;
    }
    let mut ids = HashMap::new();
    for (i, d) in spec.datasets.iter().enumerate() {
        if let Some(j) = ids.insert(d.id.clone(), i) {
            return Err(ctx.err(
                format!("datasets[{i}].id"),
                format!("dataset id {:?} is already used by datasets[{j}]", d.id),
            ));
        }
    }
    Ok(())
}

/// Parses the sweep's axis keys and checks their targets exist.
fn parse_axes(spec: &RawSpec, ctx: &Ctx) -> Result<Vec<Axis>, SpecError> {
    let mut axes = Vec::new();
    for (section, map) in [("grid", &spec.sweep.grid), ("zip", &spec.sweep.zip)] {
        for (key, values) in map {
            let at = format!("sweep.{section}.{key}");
            let parts: Vec<String> = key.split('.').map(str::to_string).collect();
            let (dataset, field) = match parts.first().map(String::as_str) {
                Some("datasets") if parts.len() >= 3 => {
                    let id = &parts[1];
                    if id != "*" && !spec.datasets.iter().any(|d| &d.id == id) {
                        return Err(ctx.err(at, format!("no dataset with id {id:?}")));
                    }
                    (Some(id.clone()), parts[2..].to_vec())
                }
                Some("analysis") if parts.len() >= 2 => (None, parts[1..].to_vec()),
                Some("synthesis") if parts.len() >= 2 && spec.synthesis.is_some() => {
                    (None, parts[1..].to_vec())
                }
                _ => {
                    return Err(ctx.err(
                        at,
                        "a sweep axis is `datasets.<id>.<field>`, `analysis.<field>` or `synthesis.<field>` (with a synthesis section)",
                    ));
                }
            };
            if dataset.as_deref() == Some("*")
                && !spec
                    .datasets
                    .iter()
                    .any(|d| d.fields().contains(&field[0].as_str()))
            {
                return Err(ctx.err(&at, format!("no dataset takes the field `{}`", field[0])));
            }
            if field.first().is_some_and(|f| f == "id" || f == "kind") {
                return Err(ctx.err(at, "`id` and `kind` cannot be swept"));
            }
            if values.is_empty() {
                return Err(ctx.err(at, "a sweep axis needs at least one value"));
            }
            let synthesis = key.starts_with("synthesis.");
            let json = values
                .iter()
                .map(|v| serde_json::to_value(v).expect("YAML values are JSON"))
                .collect();
            axes.push(Axis {
                short: Axis::short_of(&field, synthesis).into(),
                synthesis,
                key: key.clone(),
                at,
                dataset,
                field,
                values: values.clone(),
                json,
            });
        }
    }
    Ok(axes)
}

/// The error of a plan past [`MAX_JOBS`], with the upper bound of its job count.
fn too_many_jobs(spec: &RawSpec, points: usize, methods: usize, ctx: &Ctx) -> SpecError {
    let bound = spec
        .datasets
        .len()
        .saturating_mul(points)
        .saturating_mul(methods);
    ctx.err(
        "sweep",
        format!(
            "the sweep gives more than {MAX_JOBS} jobs (up to {bound}: {} dataset(s) x {points} \
             point(s) x {methods} job(s) per point); at most {MAX_JOBS} (split the spec)",
            spec.datasets.len()
        ),
    )
}

/// Number of sweep points: the product of the grid axes' lengths times the zip axes' common
/// length (1 without axes), `None` when it overflows `usize`. Nothing is expanded.
fn count_points(axes: &[Axis], grid: &[usize], zip: &[usize]) -> Option<usize> {
    let zip_len = zip.first().map_or(1, |&a| axes[a].values.len());
    grid.iter()
        .try_fold(zip_len, |n, &a| n.checked_mul(axes[a].values.len()))
}

/// Sweep points as lists of `(axis index, value index)`; refused above [`MAX_SWEEP_POINTS`]
/// (counted before they are expanded).
fn sweep_points(axes: &[Axis], ctx: &Ctx) -> Result<Vec<Vec<(usize, usize)>>, SpecError> {
    let grid: Vec<usize> = (0..axes.len())
        .filter(|&a| axes[a].at.starts_with("sweep.grid."))
        .collect();
    let zip: Vec<usize> = (0..axes.len())
        .filter(|&a| axes[a].at.starts_with("sweep.zip."))
        .collect();
    if let Some(&first) = zip.first() {
        let n = axes[first].values.len();
        if let Some(&bad) = zip.iter().find(|&&a| axes[a].values.len() != n) {
            return Err(ctx.err(
                &axes[bad].at,
                format!(
                    "zip axes must have equal lengths: {} has {n} values, {} has {}",
                    axes[first].key,
                    axes[bad].key,
                    axes[bad].values.len()
                ),
            ));
        }
    }
    check_point_count(axes, &grid, &zip, ctx)?;
    let mut points: Vec<Vec<(usize, usize)>> = vec![vec![]];
    for &a in &grid {
        points = points
            .into_iter()
            .flat_map(|p| {
                (0..axes[a].values.len()).map(move |v| {
                    let mut q = p.clone();
                    q.push((a, v));
                    q
                })
            })
            .collect();
    }
    if let Some(&first) = zip.first() {
        let n = axes[first].values.len();
        points = points
            .into_iter()
            .flat_map(|p| {
                let zip = zip.clone();
                (0..n).map(move |v| {
                    let mut q = p.clone();
                    q.extend(zip.iter().map(|&a| (a, v)));
                    q
                })
            })
            .collect();
    }
    Ok(points)
}

/// Refuses a sweep of more than [`MAX_SWEEP_POINTS`] points, naming the count and the axes'
/// lengths (grid axes, then the zip axes' common length).
fn check_point_count(
    axes: &[Axis],
    grid: &[usize],
    zip: &[usize],
    ctx: &Ctx,
) -> Result<(), SpecError> {
    let count = count_points(axes, grid, zip);
    if count.is_some_and(|n| n <= MAX_SWEEP_POINTS) {
        return Ok(());
    }
    let lens: Vec<String> = grid
        .iter()
        .chain(zip.first())
        .map(|&a| axes[a].values.len().to_string())
        .collect();
    let count = count.map_or_else(|| format!("more than {}", usize::MAX), |n| n.to_string());
    Err(ctx.err(
        "sweep",
        format!(
            "sweep gives {count} points ({}); at most {MAX_SWEEP_POINTS} (split the spec)",
            lens.join(" x ")
        ),
    ))
}

/// Canonical identity of a dataset under some swept values.
fn identity(dataset: &str, method: Option<Method>, params: &Params) -> String {
    #[derive(Serialize)]
    struct Id<'a> {
        dataset: &'a str,
        #[serde(skip_serializing_if = "Option::is_none")]
        method: Option<Method>,
        params: &'a Params,
    }
    serde_json::to_string(&Id {
        dataset,
        method,
        params,
    })
    .expect("serialisable")
}

/// Applies overrides and validates one job.
#[allow(clippy::too_many_arguments)]
fn build_job(
    spec: &RawSpec,
    raw: &Yaml,
    ctx: &Ctx,
    (index, ds, method): (usize, &DatasetSpec, Option<Method>),
    axes: &[Axis],
    applied: &[&(usize, usize)],
    params: Params,
    identity: String,
) -> Result<Job, SpecError> {
    let mut ds_value = raw["datasets"][index].clone();
    let mut an_value = raw["analysis"].clone();
    let mut syn_value = raw["synthesis"].clone();
    let mut data_params = Vec::new();
    for &&(a, v) in applied {
        let axis = &axes[a];
        let target = if axis.dataset.is_some() {
            &mut ds_value
        } else if axis.synthesis {
            &mut syn_value
        } else {
            &mut an_value
        };
        set_path(target, &axis.field, axis.values[v].clone()).map_err(|m| ctx.err(&axis.at, m))?;
        if axis.dataset.is_some() {
            data_params.push((axis.short.clone(), axis.json[v].clone()));
        }
    }
    let swept = || {
        applied
            .iter()
            .map(|&&(a, v)| {
                format!(
                    "{} = {}",
                    axes[a].key,
                    serde_json::to_string(&axes[a].values[v]).unwrap_or_default()
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let typed = |e: serde_path_to_error::Error<serde_yaml_ng::Error>, section: &str| {
        let first = applied
            .first()
            .map(|&&(a, _)| axes[a].at.clone())
            .unwrap_or_else(|| section.to_string());
        ctx.err(
            first,
            format!("with {}: {section}.{}: {}", swept(), e.path(), e.inner()),
        )
    };
    let (dataset_spec, analysis, synthesis) = if applied.is_empty() {
        (ds.clone(), spec.analysis.clone(), spec.synthesis.clone())
    } else {
        let d: DatasetSpec = serde_path_to_error::deserialize(ds_value)
            .map_err(|e| typed(e, &format!("datasets[{index}]")))?;
        let a: AnalysisSpec =
            serde_path_to_error::deserialize(an_value).map_err(|e| typed(e, "analysis"))?;
        let s: Option<SynthesisSpec> =
            serde_path_to_error::deserialize(syn_value).map_err(|e| typed(e, "synthesis"))?;
        (d, a, s)
    };
    let synthesis = synthesis.filter(|_| method.is_some());
    let dataset = dataset_spec
        .check(ctx, &format!("datasets[{index}]"), analysis.levels)
        .map_err(|mut e| {
            if !applied.is_empty() {
                e.message = format!("{} (with {})", e.message, swept());
            }
            e
        })?;
    if let Some(s) = &synthesis {
        let (_, h, w) = dataset.shape();
        s.check(ctx, &analysis, h, w).map_err(|mut e| {
            if !applied.is_empty() {
                e.message = format!("{} (with {})", e.message, swept());
            }
            e
        })?;
    }
    let data_params = Params::new(data_params).expect("keys checked with the job's");
    let data_identity = self::identity(&ds.id, None, &data_params);
    Ok(Job {
        method,
        synthesis,
        generation_seed: derive_seed(spec.seed, "generate", &data_identity),
        id: String::new(),
        dataset_id: ds.id.clone(),
        dataset,
        analysis,
        seed: derive_seed(spec.seed, "job", &identity),
        data_seed: derive_seed(spec.seed, "data", &data_identity),
        params,
        noise_floor: None,
    })
}

/// Sets the value at a dotted field path inside a YAML mapping (numeric parts index lists).
fn set_path(target: &mut Yaml, field: &[String], value: Yaml) -> Result<(), String> {
    let (last, walk) = field.split_last().ok_or("empty field path")?;
    let mut cur = target;
    for part in walk {
        cur = step(cur, part)?;
    }
    match cur {
        Yaml::Mapping(m) => {
            m.insert(Yaml::String(last.clone()), value);
            Ok(())
        }
        Yaml::Sequence(s) => {
            let i: usize = last
                .parse()
                .map_err(|_| format!("`{last}` is not a list index"))?;
            let len = s.len();
            *s.get_mut(i)
                .ok_or(format!("index {i} is past the list's {len} entries"))? = value;
            Ok(())
        }
        _ => Err(format!("cannot set `{last}` inside a scalar")),
    }
}

fn step<'a>(cur: &'a mut Yaml, part: &str) -> Result<&'a mut Yaml, String> {
    match cur {
        Yaml::Mapping(m) => m.get_mut(part).ok_or(format!(
            "no field `{part}` to descend into (set it in the dataset first)"
        )),
        Yaml::Sequence(s) => {
            let i: usize = part
                .parse()
                .map_err(|_| format!("`{part}` is not a list index"))?;
            s.get_mut(i).ok_or(format!("no list entry {i}"))
        }
        _ => Err(format!("cannot descend into `{part}` of a scalar")),
    }
}

/// Sets every job's readable id ([`crate::run::ids::readable_ids`]).
fn assign_ids(jobs: &mut [Job]) {
    let parts: Vec<crate::run::ids::IdParts> = jobs
        .iter()
        .map(|j| crate::run::ids::IdParts {
            dataset: &j.dataset_id,
            method: j.method.map(Method::as_str),
            params: &j.params,
            identity: j.identity(),
        })
        .collect();
    let ids = crate::run::ids::readable_ids(&parts);
    for (job, id) in jobs.iter_mut().zip(ids) {
        job.id = id;
    }
}
