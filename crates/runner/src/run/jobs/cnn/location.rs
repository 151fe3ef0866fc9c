//! One location training (ch. 5.3.2) as a job, and the location summary over the trainings of
//! a target and method (the detection gain the dissertation reads off Figs. 73-74), each with
//! its estimate of memory and work.

use super::common::{fit_sizes, stacks, training, training_sizes};
use super::common::{
    group_seed, materialise_all, nan_none, record_tables, stacks_of, training_status, TrainingRow,
    LOCATION, LOCATION_SUMMARY,
};
use crate::apps::cnn::classification::Source;
use crate::apps::cnn::device::train_on_device;
use crate::apps::cnn::location::{self, Split, TargetKind, TestSet};
use crate::apps::cnn::train::Trained;
use crate::experiment::datasets::{C128, C64};
use crate::experiment::Materialised;
use crate::experiment::{DataRef, LocationPlan};
use crate::io::results::{col, value};
use crate::run::estimate::Estimate;
use crate::run::estimate::Sizes;
use crate::run::jobs::{Context as JobContext, Inputs, JobKind, Rows, Status};
use crate::run::plan::Plan;
use crate::seeds::derive_seed;
use crate::synthesis::CostSize;
use crate::synthesis::FitOptions;
use anyhow::Result;
use ndarray::{s, Array3};
use num_complex::{Complex32, Complex64};
use polars::prelude::*;
use serde_json::json;
use std::sync::Arc;

/// A test set's reading of a training: the set, the accuracy, its samples, its confusion
/// counts.
type Tested = (TestSet, f64, usize, Vec<Vec<usize>>);

/// The `test_set` value of rows tested on `set`.
fn test_set_value(set: TestSet) -> &'static str {
    match set {
        TestSet::HeldOut => value::HELD_OUT,
        TestSet::All => value::ALL,
    }
}

/// One location training.
#[derive(Debug, Clone)]
pub struct LocationJob {
    /// `location.<target>.<method>.scr<dB>.r<repeat>`.
    pub id: String,
    /// Canonical identity (JSON).
    pub identity: String,
    /// Seed of the network's initial weights, shuffles and training targets.
    pub seed: u64,
    /// Seed of the generated clutter (identity without the method).
    pub data_seed: u64,
    /// Target kind.
    pub target: TargetKind,
    /// Training-set source.
    pub source: Source,
    /// Signal-to-clutter ratio in dB.
    pub scr_db: f64,
    /// Repeat number, from 0.
    pub repeat: usize,
    /// The clutter dataset.
    pub clutter: Arc<Vec<DataRef>>,
}

/// `-12` -> `m12`, `2.5` -> `2.5`: an SCR for a job id.
fn scr_label(x: f64) -> String {
    let s = format!("{x}");
    match s.strip_prefix('-') {
        Some(rest) => format!("m{rest}"),
        None => s,
    }
}

impl LocationJob {
    /// Every training of the plan's `location` section (`lp`), in order target, method, SCR, repeat.
    pub fn all(plan: &Plan, lp: &LocationPlan) -> Vec<LocationJob> {
        let clutter = Arc::new(vec![lp.clutter.clone()]);
        let mut out = vec![];
        for &target in &lp.spec.targets {
            for &source in &lp.sources {
                for &scr in &lp.spec.scr_db {
                    for repeat in 0..lp.spec.repeats {
                        let paired = json!({
                            "app": "location",
                            "repeat": repeat,
                        })
                        .to_string();
                        let identity = json!({
                            "app": "location",
                            "target": target.as_str(),
                            "method": source.as_str(),
                            "scr_db": scr,
                            "repeat": repeat,
                        })
                        .to_string();
                        out.push(LocationJob {
                            id: format!(
                                "location.{}.{}.scr{}.r{repeat}",
                                target.as_str(),
                                source.as_str(),
                                scr_label(scr)
                            ),
                            seed: derive_seed(plan.spec.seed, "cnn", &identity),
                            data_seed: derive_seed(plan.spec.seed, "cnn/samples", &paired),
                            identity,
                            target,
                            source,
                            scr_db: scr,
                            repeat,
                            clutter: clutter.clone(),
                        });
                    }
                }
            }
        }
        out
    }
}

impl LocationJob {
    /// The clutter of the training and the validation set (single precision, sample after
    /// sample) and how many samples were generated: `original`'s samples of the split, halved
    /// by the protocol; or a method fitted on the split's fit part generating
    /// `generated_samples`, half for training and half for validation.
    fn training_clutter(
        &self,
        plan: &Plan,
        split: &Split,
        all: &Array3<Complex64>,
    ) -> Result<(Vec<Complex32>, Vec<Complex32>, usize)> {
        let lp = plan.cnn.location.as_ref().expect("a location section");
        Ok(match self.source {
            Source::Original => {
                let originals = split.originals(&all.view());
                let t = lp.spec.original_training();
                (
                    location::single(&originals.slice(s![..t, .., ..])),
                    location::single(&originals.slice(s![t.., .., ..])),
                    0,
                )
            }
            Source::Generated(m) => {
                let options = FitOptions {
                    half_width: lp.spec.half_width,
                    levels: lp.spec.levels,
                    negative_signs: lp.spec.negative_signs,
                };
                let model = super::fits::fitted(split.fit(&all.view()).view(), m, options)?;
                let g = lp.spec.generated_samples;
                let gen_seed = derive_seed(self.data_seed, "generate", &self.clutter[0].id);
                let half = g / 2;
                let tr = model.try_generate_c64(gen_seed, 0, half)?;
                let va = model.try_generate_c64(gen_seed, half, g - half)?;
                (
                    tr.into_raw_vec_and_offset().0,
                    va.into_raw_vec_and_offset().0,
                    g,
                )
            }
        })
    }

    /// The training's rows of `location.parquet`: one per test set (`tests`: the set, its
    /// accuracy, its samples and confusion), the training's columns repeated; `train_n`: the
    /// training samples, `generated` how many of them were generated.
    fn rows(
        &self,
        trained: &Trained,
        tests: &[Tested],
        (train_n, generated): (usize, usize),
        p_c: f64,
    ) -> Result<DataFrame> {
        let k = tests.len();
        Ok(DataFrame::new_infer_height(vec![
            Column::new(col::JOB.into(), vec![self.id.as_str(); k]),
            Column::new(col::TARGET.into(), vec![self.target.as_str(); k]),
            Column::new(col::METHOD.into(), vec![self.source.as_str(); k]),
            Column::new(col::SCR_DB.into(), vec![self.scr_db; k]),
            Column::new(col::REPEAT.into(), vec![self.repeat as i64; k]),
            Column::new(col::SEED.into(), vec![self.seed; k]),
            Column::new(
                col::TEST_SET.into(),
                tests
                    .iter()
                    .map(|t| test_set_value(t.0))
                    .collect::<Vec<_>>(),
            ),
            Column::new(col::TRAIN_ACCURACY.into(), vec![trained.train_accuracy; k]),
            Column::new(
                col::VALIDATION_ACCURACY.into(),
                vec![nan_none(trained.validation_accuracy); k],
            ),
            Column::new(
                col::TEST_ACCURACY.into(),
                tests.iter().map(|t| t.1).collect::<Vec<_>>(),
            ),
            Column::new(
                col::TEST_SAMPLES.into(),
                tests.iter().map(|t| t.2 as i64).collect::<Vec<_>>(),
            ),
            Column::new(col::EPOCHS.into(), vec![trained.epochs.len() as i64; k]),
            Column::new(col::TRAIN_SECONDS.into(), vec![trained.seconds; k]),
            Column::new(
                col::TRAIN_SAMPLES_PER_SECOND.into(),
                vec![trained.samples_per_second; k],
            ),
            Column::new(col::TRAIN_SAMPLES.into(), vec![train_n as i64; k]),
            Column::new(col::TRAIN_GENERATED.into(), vec![generated as i64; k]),
            Column::new(col::CLUTTER_POWER.into(), vec![p_c; k]),
        ])?)
    }
}

impl JobKind for LocationJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "location"
    }

    fn identity(&self) -> std::borrow::Cow<'_, str> {
        self.identity.as_str().into()
    }

    fn seed(&self) -> Option<u64> {
        Some(self.seed)
    }

    fn inputs(&self) -> Inputs {
        Inputs::Dataset {
            data_seed: group_seed("cnn/clutter", &self.clutter),
            shared: true,
        }
    }

    fn estimate(&self, plan: &Plan) -> Estimate {
        estimate(plan, self)
    }

    /// The training (its identity, seeds and clutter), the section's settings it reads and the
    /// resolved training and network; not the section's lists of the other trainings
    /// (methods, targets, SCRs, repeats), so that a spec grown by an SCR point or a method
    /// runs only the new trainings on resume.
    fn key_material(&self, plan: &Plan) -> String {
        let lp = plan.cnn.location.as_ref().expect("a location section");
        let s = &lp.spec;
        format!(
            "{self:?}\nfit_samples={} originals={} generated_samples={} half_width={} \
             levels={} negative_signs={:?} test_sets={:?} save_networks={}\n{:?}\n{:?}",
            s.fit_samples,
            s.originals(),
            s.generated_samples,
            s.half_width,
            s.levels,
            s.negative_signs,
            s.test_sets,
            s.save_networks,
            lp.training,
            lp.net
        )
    }

    fn input_files(&self) -> Vec<std::path::PathBuf> {
        self.clutter[0].dataset.input_files()
    }

    fn materialise(&self) -> Result<Materialised> {
        materialise_all(&self.clutter)
    }

    /// Fits and generates the training clutter, adds the targets, trains and evaluates the
    /// location network, and makes the job's rows.
    fn run(&self, cx: &JobContext) -> Result<Rows> {
        let plan = cx.plan;
        let lp = plan.cnn.location.as_ref().expect("a location section");
        let mut owned = None;
        let all = stacks_of(cx.shared, &self.clutter, &mut owned)?;
        let (n, h, w) = all.dim();
        let split = Split::new(
            n,
            derive_seed(plan.spec.seed, "cnn/location/split", &self.clutter[0].id),
            lp.spec.fit_samples,
            lp.spec.originals(),
        );
        let p_c = location::clutter_power(&all.view());
        let amp = location::amplitude(p_c, self.scr_db);
        let constant =
            location::constant_pattern(derive_seed(plan.spec.seed, "cnn/location/constant", ""));
        let (train_clutter, val_clutter, generated) = self.training_clutter(plan, &split, &all)?;
        let targets = |clutter: &[Complex32], seed: u64| {
            location::with_targets(clutter, w, h * w, self.target, &constant, amp, seed)
        };
        let train_set = targets(&train_clutter, derive_seed(self.seed, "targets", "train"));
        let validation = targets(
            &val_clutter,
            derive_seed(self.seed, "targets", "validation"),
        );
        let trained = train_on_device(&lp.net, &lp.training, &train_set, &validation, self.seed)?;
        // Every test set places its targets from the same seed (a set's samples are a
        // permutation's tail, so the two sets differ in which sample gets which target).
        let test_seed = derive_seed(
            plan.spec.seed,
            "cnn/location/test",
            &format!("{}/{}", self.target.as_str(), self.scr_db),
        );
        let mut tests = vec![];
        for &set in &lp.spec.test_sets {
            let test = targets(
                &location::single(&split.test(&all.view(), set).view()),
                test_seed,
            );
            let (accuracy, confusion) = trained.evaluate(&test);
            tests.push((set, accuracy, test.len(), confusion));
        }
        let mut files = vec![];
        if lp.spec.save_networks {
            let dir = crate::io::results::files::network(cx.out, &self.id);
            let names = location::output_names();
            crate::apps::cnn::store::save(&trained, &names, &self.id, self.seed, &dir)?;
            files.push(dir);
        }
        // Example training images (one per grid row) for the report (Fig. 72).
        if self.repeat == 0 {
            let path = crate::io::results::files::example(cx.out, &self.id);
            crate::io::atomic::write_npy(&path, &location::examples(&train_set, h, w))?;
            files.push(path);
        }
        let row = self.rows(&trained, &tests, (train_set.len(), generated / 2), p_c)?;
        // The confusion counts are those of the first test set listed.
        let confusion = &tests.first().expect("at least one test set").3;
        let mut tables = vec![(LOCATION, row)];
        tables.extend(record_tables(&self.id, &trained, confusion)?);
        Ok(Rows {
            tables,
            files,
            timing: Some(json!({
                "train_s": trained.seconds,
                "train_samples_per_s": trained.samples_per_second,
            })),
        })
    }

    fn status_row(&self, plan: &Plan, status: &Status) -> Option<Result<DataFrame>> {
        let lp = plan.cnn.location.as_ref()?;
        Some(training_status(
            TrainingRow {
                id: &self.id,
                kind: "location",
                dataset: &self.clutter[0].id,
                method: self.source.as_str(),
                seed: self.seed,
                samples: match self.source {
                    Source::Original => lp.spec.original_training(),
                    Source::Generated(_) => lp.spec.generated_samples / 2,
                },
            },
            &lp.net,
            status,
        ))
    }

    fn manifest(&self) -> serde_json::Value {
        json!({
            "target": self.target.as_str(),
            "method": self.source.as_str(),
            "scr_db": self.scr_db,
            "repeat": self.repeat,
            "samples_seed": self.data_seed,
        })
    }
}

/// Per target and method: the SCR where mean test accuracy first reaches 50 % and 90 %, and
/// the gain over `original` (positive: reached at a lower SCR).
#[derive(Debug, Clone)]
pub struct LocationSummaryJob {
    /// The location jobs (indices into the plan's job list).
    pub inputs: Vec<usize>,
}

impl JobKind for LocationSummaryJob {
    fn id(&self) -> &str {
        "location_summary"
    }

    fn kind(&self) -> &'static str {
        "location_summary"
    }

    fn identity(&self) -> std::borrow::Cow<'_, str> {
        "".into()
    }

    fn seed(&self) -> Option<u64> {
        None
    }

    fn key_material(&self, plan: &Plan) -> String {
        format!("{self:?}\n{:?}", plan.spec.location)
    }

    fn inputs(&self) -> Inputs {
        Inputs::Rows(self.inputs.clone())
    }

    fn estimate(&self, _plan: &Plan) -> Estimate {
        Estimate::SMALL
    }

    fn input_files(&self) -> Vec<std::path::PathBuf> {
        vec![]
    }

    fn materialise(&self) -> Result<crate::experiment::Materialised> {
        crate::run::jobs::no_dataset(self)
    }

    fn manifest(&self) -> serde_json::Value {
        serde_json::json!({})
    }

    fn run(&self, cx: &JobContext) -> Result<Rows> {
        let frames: Vec<DataFrame> = cx
            .inputs
            .iter()
            .filter_map(|(_, r)| r.table(LOCATION).cloned())
            .collect();
        let table = location_summary(&frames)?;
        Ok(Rows {
            tables: vec![(LOCATION_SUMMARY, table)],
            ..Rows::default()
        })
    }

    fn status_row(&self, _plan: &Plan, _status: &Status) -> Option<Result<DataFrame>> {
        None
    }
}

/// The identity of a summary row: target, test set, method.
type SummaryKey = (String, String, String);

/// One row of the location summary: its key, SCR at 50 % and 90 %, best mean accuracy, SCR
/// points.
type SummaryRow = (SummaryKey, Option<f64>, Option<f64>, f64, usize);

/// Mean accuracies by SCR of one key: `(scr_db, accuracies over repeats)`.
type ByScr = Vec<(f64, Vec<f64>)>;

/// The summary of `location` rows (see [`LocationSummaryJob`]): one row per target, test set
/// and method, each method's gain taken over `original` of the same target and test set.
///
/// # Errors
/// If the rows lack a column.
pub fn location_summary(frames: &[DataFrame]) -> Result<DataFrame> {
    use std::collections::BTreeMap;
    let mut acc: BTreeMap<SummaryKey, ByScr> = BTreeMap::new();
    let mut order: Vec<SummaryKey> = vec![];
    for df in frames {
        let t = df.column(col::TARGET)?.str()?.clone();
        let ts = df.column(col::TEST_SET)?.str()?.clone();
        let m = df.column(col::METHOD)?.str()?.clone();
        let s = df.column(col::SCR_DB)?.f64()?.clone();
        let a = df.column(col::TEST_ACCURACY)?.f64()?.clone();
        for i in 0..df.height() {
            let (Some(t), Some(ts), Some(m), Some(s), Some(a)) =
                (t.get(i), ts.get(i), m.get(i), s.get(i), a.get(i))
            else {
                continue;
            };
            let key = (t.to_string(), ts.to_string(), m.to_string());
            if !order.contains(&key) {
                order.push(key.clone());
            }
            let v = acc.entry(key).or_default();
            match v.iter_mut().find(|(x, _)| *x == s) {
                Some((_, list)) => list.push(a),
                None => v.push((s, vec![a])),
            }
        }
    }
    // Grouped by target and test set, the methods in the spec's order within each.
    let mut groups: Vec<(String, String)> = vec![];
    for k in &order {
        if !groups.iter().any(|g| g.0 == k.0 && g.1 == k.1) {
            groups.push((k.0.clone(), k.1.clone()));
        }
    }
    order.sort_by_key(|k| groups.iter().position(|g| g.0 == k.0 && g.1 == k.1));
    let mut rows: Vec<SummaryRow> = vec![];
    for key in &order {
        let mut pts: Vec<(f64, f64)> = acc[key]
            .iter()
            .map(|(s, a)| (*s, a.iter().sum::<f64>() / a.len() as f64))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let best = pts.iter().map(|p| p.1).fold(f64::NAN, f64::max);
        rows.push((
            key.clone(),
            location::crossing(&pts, 0.5),
            location::crossing(&pts, 0.9),
            best,
            pts.len(),
        ));
    }
    let gain = |key: &SummaryKey, x: Option<f64>, pick: fn(&SummaryRow) -> Option<f64>| {
        let base = rows
            .iter()
            .find(|r| r.0 .0 == key.0 && r.0 .1 == key.1 && r.0 .2 == "original")
            .and_then(pick);
        match (base, x) {
            (Some(b), Some(x)) => Some(b - x),
            _ => None,
        }
    };
    let g50: Vec<Option<f64>> = rows.iter().map(|r| gain(&r.0, r.1, |r| r.1)).collect();
    let g90: Vec<Option<f64>> = rows.iter().map(|r| gain(&r.0, r.2, |r| r.2)).collect();
    let text =
        |f: fn(&SummaryKey) -> &String| rows.iter().map(|r| f(&r.0).clone()).collect::<Vec<_>>();
    Ok(DataFrame::new_infer_height(vec![
        Column::new(col::TARGET.into(), text(|k| &k.0)),
        Column::new(col::TEST_SET.into(), text(|k| &k.1)),
        Column::new(col::METHOD.into(), text(|k| &k.2)),
        Column::new(
            col::SCR_50_DB.into(),
            rows.iter().map(|r| r.1).collect::<Vec<_>>(),
        ),
        Column::new(
            col::SCR_90_DB.into(),
            rows.iter().map(|r| r.2).collect::<Vec<_>>(),
        ),
        Column::new(col::GAIN_50_DB.into(), g50),
        Column::new(col::GAIN_90_DB.into(), g90),
        Column::new(
            col::BEST_MEAN_ACCURACY.into(),
            rows.iter().map(|r| r.3).collect::<Vec<_>>(),
        ),
        Column::new(
            col::SCR_POINTS.into(),
            rows.iter().map(|r| r.4 as i64).collect::<Vec<_>>(),
        ),
    ])?)
}

/// The estimate of one location training of `plan`.
fn estimate(plan: &Plan, job: &LocationJob) -> Estimate {
    let Some(lp) = &plan.cnn.location else {
        return Estimate::SMALL;
    };
    let spec = &lp.spec;
    let mut sizes = Sizes::default();
    let stacks = stacks(plan, &job.clutter, &mut sizes);
    let pixels = lp.net.height as f64 * lp.net.width as f64;
    let n: f64 = stacks.samples.iter().sum();
    let fit = spec.fit_samples as f64;
    sizes.add("location.fit_samples", spec.fit_samples, fit / 100.0);
    let (train_n, model_bytes, fit_flops) = match job.source {
        Source::Original => (spec.original_training() as f64, 0.0, 0.0),
        Source::Generated(m) => {
            let g = spec.generated_samples as f64;
            sizes.add(
                "location.generated_samples",
                spec.generated_samples,
                g / 5000.0,
            );
            fit_sizes("location", m, spec.half_width, &mut sizes);
            let cost = m.cost(&CostSize {
                fitted: fit,
                generated: g,
                pixels,
                half_width: spec.half_width as f64,
            });
            (
                g / 2.0,
                cost.model_bytes + C64 * g * pixels,
                cost.fit_flops + cost.generate_flops,
            )
        }
    };
    training_sizes("location.training", &lp.training, train_n, &mut sizes);
    // The fit and test clutter as complex128 selections, the training sets with targets.
    let (bytes, flops) = training(&lp.net, &lp.training, train_n, n);
    Estimate::new(
        stacks.bytes + C128 * n * pixels + model_bytes + bytes,
        stacks.flops + fit_flops + flops,
    )
    .blaming(&sizes)
}
