//! One classification training (ch. 5.3.1) as a job: its datasets' stacks, its method's fit,
//! its training, validation and test sets, the training, its rows, and its estimate of memory
//! and work.

use super::common::{fit_sizes, stacks, training, training_sizes};
use super::common::{
    group_seed, materialise_all, nan_none, record_tables, stacks_of, training_status, TrainingRow,
    CLASSIFICATION,
};
use crate::apps::cnn::classification::{compose, labelled, split_class, Normalise, Source};
use crate::apps::cnn::device::train_on_device;
use crate::apps::cnn::train::Labelled;
use crate::experiment::datasets::{C128, C64, USUAL_SAMPLES};
use crate::experiment::Materialised;
use crate::experiment::{ClassificationPlan, DataRef};
use crate::io::results::col;
use crate::run::estimate::Estimate;
use crate::run::estimate::Sizes;
use crate::run::jobs::{Context as JobContext, Inputs, JobKind, Rows, Status};
use crate::run::plan::Plan;
use crate::seeds::derive_seed;
use crate::synthesis::CostSize;
use crate::synthesis::FitOptions;
use anyhow::{Context, Result};
use ndarray::{s, Array3};
use num_complex::Complex64;
use polars::prelude::*;
use serde_json::json;
use std::sync::Arc;

/// One classification training.
#[derive(Debug, Clone)]
pub struct ClassificationJob {
    /// `classification.<normalise>.<method>.n<size>.r<repeat>`.
    pub id: String,
    /// Canonical identity (JSON).
    pub identity: String,
    /// Seed of the network's initial weights and shuffles.
    pub seed: u64,
    /// Seed of the samples (identity without the method).
    pub data_seed: u64,
    /// Normalisation.
    pub normalise: Normalise,
    /// Training-set source.
    pub source: Source,
    /// Total training-set size.
    pub train_size: usize,
    /// Repeat number, from 0.
    pub repeat: usize,
    /// The class datasets.
    pub classes: Arc<Vec<DataRef>>,
}

impl ClassificationJob {
    /// Every training of the plan's `classification` section (`cp`), in order normalisation,
    /// method, size, repeat.
    pub fn all(plan: &Plan, cp: &ClassificationPlan) -> Vec<ClassificationJob> {
        let classes = Arc::new(cp.classes.clone());
        let mut out = vec![];
        for &normalise in &cp.normalise {
            for &source in &cp.sources {
                for &n in &cp.spec.train_sizes {
                    for repeat in 0..cp.spec.repeats {
                        let paired = format!(
                            "{{\"app\":\"classification\",\"normalise\":\"{}\",\"train_size\":{n},\"repeat\":{repeat}}}",
                            normalise.as_str()
                        );
                        let identity = json!({
                            "app": "classification",
                            "normalise": normalise.as_str(),
                            "method": source.as_str(),
                            "train_size": n,
                            "repeat": repeat,
                        })
                        .to_string();
                        out.push(ClassificationJob {
                            id: format!(
                                "classification.{}.{}.n{n}.r{repeat}",
                                normalise.as_str(),
                                source.as_str()
                            ),
                            seed: derive_seed(plan.spec.seed, "cnn", &identity),
                            data_seed: derive_seed(plan.spec.seed, "cnn/samples", &paired),
                            identity,
                            normalise,
                            source,
                            train_size: n,
                            repeat,
                            classes: classes.clone(),
                        });
                    }
                }
            }
        }
        out
    }
}

/// The sets of a classification training, and how its training set was composed.
struct Sets {
    train: Labelled,
    validation: Labelled,
    test: Labelled,
    /// Generated samples in the training set.
    generated: usize,
    /// Original samples in the training set.
    originals: usize,
    /// Whether the validation set reuses originals of the training set.
    reused: bool,
}

impl ClassificationJob {
    /// Each class's stack (consecutive in `all`) split into its fit and test parts; the method
    /// fitted on the fit part; the training and validation sets composed of originals and
    /// generated samples, balanced over the classes.
    fn sets(&self, plan: &Plan, all: &Array3<Complex64>) -> Result<Sets> {
        let cp = plan
            .cnn
            .classification
            .as_ref()
            .expect("a classification section");
        let k = self.classes.len();
        let mut sets = Sets {
            train: Labelled::default(),
            validation: Labelled::default(),
            test: Labelled::default(),
            generated: 0,
            originals: 0,
            reused: false,
        };
        let mut first = 0;
        for (c, class) in self.classes.iter().enumerate() {
            let n = class.dataset.shape().0;
            let stack = all.slice(s![first..first + n, .., ..]);
            first += n;
            let split_seed = derive_seed(plan.spec.seed, "cnn/classification/split", &class.id);
            let data = split_class(stack, cp.spec.holdout, self.normalise, split_seed);
            let options = FitOptions {
                half_width: cp.spec.half_width,
                levels: cp.spec.levels,
                negative_signs: cp.spec.negative_signs,
            };
            let model = match self.source {
                Source::Original => None,
                Source::Generated(m) => Some(
                    super::fits::fitted(data.fit.view(), m, options)
                        .with_context(|| format!("class {}", class.id))?,
                ),
            };
            // Balanced: N / k per class, the remainder to the first classes.
            let per_class = self.train_size / k + usize::from(c < self.train_size % k);
            let composition = compose(
                c,
                data.fit.view(),
                model.as_deref(),
                per_class,
                cp.spec.original_fraction,
                derive_seed(self.data_seed, "originals", &class.id),
                derive_seed(self.data_seed, "generate", &class.id),
                &mut sets.train,
                &mut sets.validation,
            );
            sets.generated += composition.generated;
            sets.originals += composition.originals;
            sets.reused |= composition.reused;
            labelled(data.test.view(), c, &mut sets.test);
        }
        Ok(sets)
    }
}

impl JobKind for ClassificationJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "classification"
    }

    fn identity(&self) -> std::borrow::Cow<'_, str> {
        self.identity.as_str().into()
    }

    fn seed(&self) -> Option<u64> {
        Some(self.seed)
    }

    fn inputs(&self) -> Inputs {
        Inputs::Dataset {
            data_seed: group_seed("cnn/classes", &self.classes),
            shared: true,
        }
    }

    fn estimate(&self, plan: &Plan) -> Estimate {
        estimate(plan, self)
    }

    fn key_material(&self, plan: &Plan) -> String {
        let cp = plan
            .cnn
            .classification
            .as_ref()
            .expect("a classification section");
        format!("{self:?}\n{:?}\n{:?}", cp.spec, cp.net)
    }

    fn input_files(&self) -> Vec<std::path::PathBuf> {
        self.classes
            .iter()
            .flat_map(|c| c.dataset.input_files())
            .collect()
    }

    fn materialise(&self) -> Result<Materialised> {
        materialise_all(&self.classes)
    }

    /// Makes the training, validation and test sets ([`ClassificationJob::sets`]), trains and
    /// evaluates the classifier, and makes the job's rows.
    fn run(&self, cx: &JobContext) -> Result<Rows> {
        let plan = cx.plan;
        let cp = plan
            .cnn
            .classification
            .as_ref()
            .expect("a classification section");
        let mut owned = None;
        let all = stacks_of(cx.shared, &self.classes, &mut owned)?;
        let Sets {
            train: train_set,
            validation,
            test,
            generated,
            originals,
            reused,
        } = self.sets(plan, &all)?;
        let trained = train_on_device(&cp.net, &cp.training, &train_set, &validation, self.seed)?;
        let (test_accuracy, confusion) = trained.evaluate(&test);
        let mut files = vec![];
        if cp.spec.save_networks {
            let dir = crate::io::results::files::network(cx.out, &self.id);
            let names: Vec<String> = self.classes.iter().map(|c| c.id.clone()).collect();
            crate::apps::cnn::store::save(&trained, &names, &self.id, self.seed, &dir)?;
            files.push(dir);
        }
        let protocol = if cp.spec.holdout > 0.0 {
            "holdout"
        } else {
            "dissertation (test = fit data)"
        };
        let row = DataFrame::new_infer_height(vec![
            Column::new(col::JOB.into(), [self.id.as_str()]),
            Column::new(col::METHOD.into(), [self.source.as_str()]),
            Column::new(col::NORMALISE.into(), [self.normalise.as_str()]),
            Column::new(col::TRAIN_SIZE.into(), [self.train_size as i64]),
            Column::new(col::REPEAT.into(), [self.repeat as i64]),
            Column::new(col::SEED.into(), [self.seed]),
            Column::new(col::TRAIN_ACCURACY.into(), [trained.train_accuracy]),
            Column::new(
                col::VALIDATION_ACCURACY.into(),
                [nan_none(trained.validation_accuracy)],
            ),
            Column::new(col::TEST_ACCURACY.into(), [test_accuracy]),
            Column::new(col::TEST_SAMPLES.into(), [test.len() as i64]),
            Column::new(col::EPOCHS.into(), [trained.epochs.len() as i64]),
            Column::new(col::TRAIN_SECONDS.into(), [trained.seconds]),
            Column::new(
                col::TRAIN_SAMPLES_PER_SECOND.into(),
                [trained.samples_per_second],
            ),
            Column::new(col::TRAIN_SAMPLES.into(), [train_set.len() as i64]),
            Column::new(col::TRAIN_GENERATED.into(), [generated as i64]),
            Column::new(col::TRAIN_ORIGINALS.into(), [originals as i64]),
            Column::new(col::VALIDATION_SAMPLES.into(), [validation.len() as i64]),
            Column::new(col::VALIDATION_REUSES_ORIGINALS.into(), [reused]),
            Column::new(col::PROTOCOL.into(), [protocol]),
        ])?;
        let mut tables = vec![(CLASSIFICATION, row)];
        tables.extend(record_tables(&self.id, &trained, &confusion)?);
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
        let cp = plan.cnn.classification.as_ref()?;
        let names: Vec<&str> = self.classes.iter().map(|c| c.id.as_str()).collect();
        Some(training_status(
            TrainingRow {
                id: &self.id,
                kind: "classification",
                dataset: &names.join(","),
                method: self.source.as_str(),
                seed: self.seed,
                samples: self.train_size,
            },
            &cp.net,
            status,
        ))
    }

    fn manifest(&self) -> serde_json::Value {
        json!({
            "normalise": self.normalise.as_str(),
            "method": self.source.as_str(),
            "train_size": self.train_size,
            "repeat": self.repeat,
            "samples_seed": self.data_seed,
        })
    }
}

/// The estimate of one classification training of `plan`.
fn estimate(plan: &Plan, job: &ClassificationJob) -> Estimate {
    let Some(cp) = &plan.cnn.classification else {
        return Estimate::SMALL;
    };
    let spec = &cp.spec;
    let mut sizes = Sizes::default();
    let stacks = stacks(plan, &job.classes, &mut sizes);
    let pixels = cp.net.height as f64 * cp.net.width as f64;
    let originals: f64 = stacks.samples.iter().sum();
    let size = job.train_size as f64;
    if let Some(i) = spec.train_sizes.iter().position(|&n| n == job.train_size) {
        let at = format!("classification.train_sizes[{i}]");
        sizes.add(at, job.train_size, size / USUAL_SAMPLES);
    }
    // Per class, one after the other: its normalised split, its model and its generated part.
    let k = cp.classes.len().max(1) as f64;
    let (mut per_class, mut fit_flops) = (0.0f64, 0.0);
    for &n in &stacks.samples {
        let fit = n - crate::apps::cnn::classification::held_out(n as usize, spec.holdout) as f64;
        let (model_bytes, flops) = match job.source {
            Source::Original => (0.0, 0.0),
            Source::Generated(m) => {
                let generated = (size / k).ceil();
                let cost = m.cost(&CostSize {
                    fitted: fit,
                    generated,
                    pixels,
                    half_width: spec.half_width as f64,
                });
                (
                    cost.model_bytes + C64 * generated * pixels,
                    cost.fit_flops + cost.generate_flops,
                )
            }
        };
        per_class = per_class.max(C128 * n * pixels + model_bytes);
        fit_flops += flops;
    }
    if let Source::Generated(m) = job.source {
        fit_sizes("classification", m, spec.half_width, &mut sizes);
    }
    // `original` trains on the fit originals at most.
    let train_n = match job.source {
        Source::Original => size.min(originals),
        Source::Generated(_) => size,
    };
    training_sizes("classification.training", &cp.training, train_n, &mut sizes);
    let (bytes, flops) = training(&cp.net, &cp.training, train_n, originals);
    Estimate::new(
        stacks.bytes + per_class + bytes,
        stacks.flops + fit_flops + flops,
    )
    .blaming(&sizes)
}
