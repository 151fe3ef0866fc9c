//! The results folder's contract: the name of every Parquet table a run writes and the columns
//! it may hold, defined once for the runner that writes them and the report and the
//! reproduction that read them. A table's writer checks its columns against it
//! ([`check_columns`]: a column the contract does not declare is an error), and the readers name
//! tables and columns through these constants, so that a renamed column fails to compile (a
//! reader) or fails every test that writes the table (a writer).

use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

pub mod files;
pub mod maps;

/// A table of a results folder: `<name>.parquet`, with the columns it may hold (a table holds
/// a subset of them: a column only some datasets or metrics fill is left out when no row has
/// it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Table {
    /// The table's name (its file name without `.parquet`).
    pub name: &'static str,
    /// The columns it may hold, in the order the runner writes them.
    pub columns: &'static [&'static str],
    /// Prefixes of the columns it repeats once per decomposition level, `<prefix><level>` for
    /// the levels 1, 2, ... of the run (Method 2's `r_h1`, `r_h2`, ... in `synthesis_params`).
    pub per_level: &'static [&'static str],
}

impl Table {
    /// Whether it may hold `column`: one of its columns, or a level (`<prefix><level>`, the
    /// level from 1, no leading zero) of one of its per-level prefixes.
    pub fn declares(&self, column: &str) -> bool {
        self.columns.contains(&column)
            || self
                .per_level
                .iter()
                .filter_map(|p| column.strip_prefix(p))
                .any(|level| {
                    !level.is_empty()
                        && !level.starts_with('0')
                        && level.bytes().all(|b| b.is_ascii_digit())
                })
    }

    /// Its file name, `<name>.parquet`.
    pub fn file_name(&self) -> String {
        format!("{}.parquet", self.name)
    }

    /// Its path in the results folder `dir`.
    pub fn path(&self, dir: &Path) -> PathBuf {
        dir.join(self.file_name())
    }

    /// The table of the results folder `dir`; `Ok(None)` if the run wrote none.
    ///
    /// # Errors
    /// If the file exists but cannot be read; the message names it.
    pub fn read(&self, dir: &Path) -> Result<Option<polars::prelude::DataFrame>> {
        super::parquet::read_parquet(&self.path(dir))
    }
}

/// The values a reader selects similarity rows by, named once for the job that writes them and
/// the report and reproduction that read them.
pub mod value {
    /// `reference` of a row compared with every original (those the fit saw included).
    pub const IN_SAMPLE: &str = "in_sample";
    /// `reference` of a row compared with the half of the originals no fit saw; `test_set` of
    /// a location row tested on the originals no network saw.
    pub const HELD_OUT: &str = "held_out";
    /// `test_set` of a location row tested on every original, those seen included (the
    /// dissertation's protocol).
    pub const ALL: &str = "all";
    /// `method` of the rows that compare two independent draws of the original (the metric's
    /// floor).
    pub const NOISE_FLOOR: &str = "noise_floor";
}

/// The names of the columns, each once (several tables share `job`, `dataset`, ...).
pub mod col {
    /// `job`: the job's id.
    pub const JOB: &str = "job";
    /// `dataset`: the dataset's id in the spec.
    pub const DATASET: &str = "dataset";
    /// `source`: `original` or the method whose generated samples were analysed.
    pub const SOURCE: &str = "source";
    /// `level`: the wavelet level (1 = finest).
    pub const LEVEL: &str = "level";
    /// `direction`: `horizontal`, `vertical` or `diagonal` (`h`/`v` in filter tables).
    pub const DIRECTION: &str = "direction";
    /// `row`: the pixel's or map cell's row.
    pub const ROW: &str = "row";
    /// `col`: the pixel's or map cell's column.
    pub const COL: &str = "col";
    /// `correlation`: a correlation coefficient.
    pub const CORRELATION: &str = "correlation";
    /// `covariance`: a covariance.
    pub const COVARIANCE: &str = "covariance";
    /// `expected_correlation`: the correlation the dataset was built with, where known.
    pub const EXPECTED_CORRELATION: &str = "expected_correlation";
    /// `mean_correlation`: the mean correlation over the cells.
    pub const MEAN_CORRELATION: &str = "mean_correlation";
    /// `mean_covariance`: the mean covariance over the cells.
    pub const MEAN_COVARIANCE: &str = "mean_covariance";
    /// `nan_cells`: cells without a value.
    pub const NAN_CELLS: &str = "nan_cells";
    /// `cells`: cells in all.
    pub const CELLS: &str = "cells";
    /// `rows`: the map's rows.
    pub const ROWS: &str = "rows";
    /// `cols`: the map's columns.
    pub const COLS: &str = "cols";
    /// `expected_mean_correlation`: the mean correlation the dataset was built with, where known.
    pub const EXPECTED_MEAN_CORRELATION: &str = "expected_mean_correlation";
    /// `mean_re`: the pixel's mean, real part.
    pub const MEAN_RE: &str = "mean_re";
    /// `mean_im`: the pixel's mean, imaginary part.
    pub const MEAN_IM: &str = "mean_im";
    /// `variance`: the pixel's variance.
    pub const VARIANCE: &str = "variance";
    /// `lag`: the lag in pixels.
    pub const LAG: &str = "lag";
    /// `filter_coefficient`: the filter coefficient at the lag.
    pub const FILTER_COEFFICIENT: &str = "filter_coefficient";
    /// `kind`: the job's kind (analysis, synthesis, ...).
    pub const KIND: &str = "kind";
    /// `method`: the synthesis method (or `original`).
    pub const METHOD: &str = "method";
    /// `status`: `ok` or `failed`.
    pub const STATUS: &str = "status";
    /// `error`: the failed job's error.
    pub const ERROR: &str = "error";
    /// `seed`: the job's seed, derived from the master seed and its identity.
    pub const SEED: &str = "seed";
    /// `data_seed`: the seed of the dataset's random draws.
    pub const DATA_SEED: &str = "data_seed";
    /// `generation_seed`: the seed of the generated samples.
    pub const GENERATION_SEED: &str = "generation_seed";
    /// `samples`: the dataset's samples.
    pub const SAMPLES: &str = "samples";
    /// `height`: image height in pixels.
    pub const HEIGHT: &str = "height";
    /// `width`: image width in pixels.
    pub const WIDTH: &str = "width";
    /// `levels`: analysis levels.
    pub const LEVELS: &str = "levels";
    /// `elapsed_s`: the job's wall time in seconds.
    pub const ELAPSED_S: &str = "elapsed_s";
    /// `alpha_h`: Method 1's horizontal alpha.
    pub const ALPHA_H: &str = "alpha_h";
    /// `alpha_v`: Method 1's vertical alpha.
    pub const ALPHA_V: &str = "alpha_v";
    /// `residual_h`: the horizontal fit's residual.
    pub const RESIDUAL_H: &str = "residual_h";
    /// `residual_v`: the vertical fit's residual.
    pub const RESIDUAL_V: &str = "residual_v";
    /// `clamped`: whether the fit was clamped to its bounds.
    pub const CLAMPED: &str = "clamped";
    /// `r_h<level>`: Method 2's horizontal correlation at a level ([`super::Table::per_level`]).
    pub const R_H: &str = "r_h";
    /// `r_v<level>`: Method 2's vertical correlation at a level ([`super::Table::per_level`]).
    pub const R_V: &str = "r_v";

    /// `<prefix><level>`: a per-level column ([`super::Table::per_level`]) at `level` (from 1).
    pub fn per_level(prefix: &str, level: usize) -> String {
        format!("{prefix}{level}")
    }
    /// `metric`: the metric's name.
    pub const METRIC: &str = "metric";
    /// `component`: `re`, `im` or `magnitude`.
    pub const COMPONENT: &str = "component";
    /// `statistic`: the name of the statistic in the row.
    pub const STATISTIC: &str = "statistic";
    /// `value`: the value of the row's statistic or metric.
    pub const VALUE: &str = "value";
    /// `units`: the value's units.
    pub const UNITS: &str = "units";
    /// `samples_original`: samples of the original.
    pub const SAMPLES_ORIGINAL: &str = "samples_original";
    /// `samples_compared`: samples compared with it.
    pub const SAMPLES_COMPARED: &str = "samples_compared";
    /// `noise_floor`: the metric between two independent draws of the original.
    pub const NOISE_FLOOR: &str = "noise_floor";
    /// `reference`: the originals a similarity row compares with: `in_sample` (all of them,
    /// those the method was fitted on) or `held_out` (a half no fit saw).
    pub const REFERENCE: &str = "reference";
    /// `bins`: histogram bins.
    pub const BINS: &str = "bins";
    /// `smoothing`: the histograms' smoothing.
    pub const SMOOTHING: &str = "smoothing";
    /// `symmetric`: whether the KL divergence is symmetrised.
    pub const SYMMETRIC: &str = "symmetric";
    /// `db`: the value in dB, where the metric has one.
    pub const DB: &str = "db";
    /// `mean_over_bins`: whether the KL divergence's sum over bins is divided by their count.
    pub const MEAN_OVER_BINS: &str = "mean_over_bins";
    /// `bias_correction`: how the KL divergence's sampling floor is removed (`none`, `resplit`).
    pub const BIAS_CORRECTION: &str = "bias_correction";
    /// `block`: the block of a blockwise metric.
    pub const BLOCK: &str = "block";
    /// `cmd_form`: the CMD term's form.
    pub const CMD_FORM: &str = "cmd_form";
    /// `model_order`: the model order (1 = mean, 2 = variance, ...).
    pub const MODEL_ORDER: &str = "model_order";
    /// `kl_mean_db`: the mean KL divergence over pixels, dB.
    pub const KL_MEAN_DB: &str = "kl_mean_db";
    /// `kl_worst_db`: the largest KL divergence over pixels, dB.
    pub const KL_WORST_DB: &str = "kl_worst_db";
    /// `pixels`: pixels compared.
    pub const PIXELS: &str = "pixels";
    /// `dy`: the row offset.
    pub const DY: &str = "dy";
    /// `dx`: the column offset.
    pub const DX: &str = "dx";
    /// `distance`: the offset's length in pixels.
    pub const DISTANCE: &str = "distance";
    /// `mean_magnitude`: the mean magnitude of the correlation.
    pub const MEAN_MAGNITUDE: &str = "mean_magnitude";
    /// `pairs`: pixel pairs averaged.
    pub const PAIRS: &str = "pairs";
    /// `freq_ghz`: frequency in GHz.
    pub const FREQ_GHZ: &str = "freq_ghz";
    /// `mie_dbsm`: the exact Mie response, dBsm.
    pub const MIE_DBSM: &str = "mie_dbsm";
    /// `raw_db`: the raw sphere measurement, dB.
    pub const RAW_DB: &str = "raw_db";
    /// `calibrated_dbsm`: the calibrated sphere, dBsm.
    pub const CALIBRATED_DBSM: &str = "calibrated_dbsm";
    /// `error_db`: calibrated minus Mie, dB.
    pub const ERROR_DB: &str = "error_db";
    /// `phase_error_deg`: the phase error, degrees.
    pub const PHASE_ERROR_DEG: &str = "phase_error_deg";
    /// `band`: the frequency band of a summary row.
    pub const BAND: &str = "band";
    /// `hypothesis`: the hypothesis (H1-H4).
    pub const HYPOTHESIS: &str = "hypothesis";
    /// `verdict`: the test's verdict.
    pub const VERDICT: &str = "verdict";
    /// `normalise`: the normalisation of the images.
    pub const NORMALISE: &str = "normalise";
    /// `train_size`: training samples per class.
    pub const TRAIN_SIZE: &str = "train_size";
    /// `repeat`: the repeat's index.
    pub const REPEAT: &str = "repeat";
    /// `train_accuracy`: accuracy on the training set.
    pub const TRAIN_ACCURACY: &str = "train_accuracy";
    /// `validation_accuracy`: accuracy on the validation set.
    pub const VALIDATION_ACCURACY: &str = "validation_accuracy";
    /// `test_accuracy`: accuracy on the test set.
    pub const TEST_ACCURACY: &str = "test_accuracy";
    /// `test_samples`: test samples.
    pub const TEST_SAMPLES: &str = "test_samples";
    /// `test_set`: the originals a location network was tested on (`held_out` or `all`).
    pub const TEST_SET: &str = "test_set";
    /// `epochs`: epochs trained.
    pub const EPOCHS: &str = "epochs";
    /// `train_seconds`: the training's wall time in seconds.
    pub const TRAIN_SECONDS: &str = "train_seconds";
    /// `train_samples_per_second`: training throughput.
    pub const TRAIN_SAMPLES_PER_SECOND: &str = "train_samples_per_second";
    /// `train_samples`: training samples in all.
    pub const TRAIN_SAMPLES: &str = "train_samples";
    /// `train_generated`: generated training samples.
    pub const TRAIN_GENERATED: &str = "train_generated";
    /// `train_originals`: original training samples.
    pub const TRAIN_ORIGINALS: &str = "train_originals";
    /// `validation_samples`: validation samples.
    pub const VALIDATION_SAMPLES: &str = "validation_samples";
    /// `validation_reuses_originals`: whether validation reuses originals the generator was fitted to.
    pub const VALIDATION_REUSES_ORIGINALS: &str = "validation_reuses_originals";
    /// `protocol`: the training protocol.
    pub const PROTOCOL: &str = "protocol";
    /// `true_class`: the true class.
    pub const TRUE_CLASS: &str = "true_class";
    /// `predicted_class`: the predicted class.
    pub const PREDICTED_CLASS: &str = "predicted_class";
    /// `count`: how many test samples.
    pub const COUNT: &str = "count";
    /// `epoch`: the epoch.
    pub const EPOCH: &str = "epoch";
    /// `loss`: the training loss.
    pub const LOSS: &str = "loss";
    /// `batch_accuracy`: the last batch's accuracy.
    pub const BATCH_ACCURACY: &str = "batch_accuracy";
    /// `target`: the target kind (`constant`, `stochastic`).
    pub const TARGET: &str = "target";
    /// `scr_db`: signal-to-clutter ratio, dB.
    pub const SCR_DB: &str = "scr_db";
    /// `clutter_power`: the clutter's mean power.
    pub const CLUTTER_POWER: &str = "clutter_power";
    /// `scr_50_db`: the SCR of 50% accuracy, dB.
    pub const SCR_50_DB: &str = "scr_50_db";
    /// `scr_90_db`: the SCR of 90% accuracy, dB.
    pub const SCR_90_DB: &str = "scr_90_db";
    /// `gain_50_db`: the gain at 50% over the original, dB.
    pub const GAIN_50_DB: &str = "gain_50_db";
    /// `gain_90_db`: the gain at 90% over the original, dB.
    pub const GAIN_90_DB: &str = "gain_90_db";
    /// `best_mean_accuracy`: the best mean accuracy over SCRs.
    pub const BEST_MEAN_ACCURACY: &str = "best_mean_accuracy";
    /// `scr_points`: SCR points measured.
    pub const SCR_POINTS: &str = "scr_points";
}

/// `analysis_maps`: every dataset's correlation and covariance maps, a row per level, direction and map cell.
pub const ANALYSIS_MAPS: Table = Table {
    name: "analysis_maps",
    columns: &[
        col::JOB,
        col::DATASET,
        col::SOURCE,
        col::LEVEL,
        col::DIRECTION,
        col::ROW,
        col::COL,
        col::CORRELATION,
        col::COVARIANCE,
        col::EXPECTED_CORRELATION,
    ],
    per_level: &[],
};

/// `analysis_summary`: the maps' means, a row per job, source, level and direction.
pub const ANALYSIS_SUMMARY: Table = Table {
    name: "analysis_summary",
    columns: &[
        col::JOB,
        col::DATASET,
        col::SOURCE,
        col::LEVEL,
        col::DIRECTION,
        col::MEAN_CORRELATION,
        col::MEAN_COVARIANCE,
        col::NAN_CELLS,
        col::CELLS,
        col::ROWS,
        col::COLS,
        col::EXPECTED_MEAN_CORRELATION,
    ],
    per_level: &[],
};

/// `pixel_stats`: every pixel's mean and variance over the samples.
pub const PIXEL_STATS: Table = Table {
    name: "pixel_stats",
    columns: &[
        col::JOB,
        col::DATASET,
        col::SOURCE,
        col::ROW,
        col::COL,
        col::MEAN_RE,
        col::MEAN_IM,
        col::VARIANCE,
    ],
    per_level: &[],
};

/// `filter_correlation`: the correlations a dataset's correlating filters give, by lag (Table 3).
pub const FILTER_CORRELATION: Table = Table {
    name: "filter_correlation",
    columns: &[
        col::JOB,
        col::DATASET,
        col::DIRECTION,
        col::LAG,
        col::FILTER_COEFFICIENT,
        col::CORRELATION,
    ],
    per_level: &[],
};

/// `jobs`: a row per job: what it was, its seeds and how it ended.
pub const JOBS: Table = Table {
    name: "jobs",
    columns: &[
        col::JOB,
        col::DATASET,
        col::KIND,
        col::METHOD,
        col::STATUS,
        col::ERROR,
        col::SEED,
        col::DATA_SEED,
        col::GENERATION_SEED,
        col::SAMPLES,
        col::HEIGHT,
        col::WIDTH,
        col::LEVELS,
        col::ELAPSED_S,
    ],
    per_level: &[],
};

/// `synthesis_params`: a fitted model's parameters at every pixel.
pub const SYNTHESIS_PARAMS: Table = Table {
    name: "synthesis_params",
    columns: &[
        col::JOB,
        col::DATASET,
        col::METHOD,
        col::ROW,
        col::COL,
        col::ALPHA_H,
        col::ALPHA_V,
        col::RESIDUAL_H,
        col::RESIDUAL_V,
        col::CLAMPED,
    ],
    per_level: &[col::R_H, col::R_V],
};

/// `similarity`: the metrics between the original and the generated samples.
pub const SIMILARITY: Table = Table {
    name: "similarity",
    columns: &[
        col::JOB,
        col::DATASET,
        col::METHOD,
        col::METRIC,
        col::LEVEL,
        col::DIRECTION,
        col::COMPONENT,
        col::STATISTIC,
        col::VALUE,
        col::UNITS,
        col::SAMPLES_ORIGINAL,
        col::SAMPLES_COMPARED,
        col::NOISE_FLOOR,
        col::REFERENCE,
        col::BINS,
        col::SMOOTHING,
        col::SYMMETRIC,
        col::DB,
        col::MEAN_OVER_BINS,
        col::BIAS_CORRECTION,
        col::BLOCK,
        col::CMD_FORM,
    ],
    per_level: &[],
};

/// `model_order`: the model-order KL tests (Tables 24-28).
pub const MODEL_ORDER: Table = Table {
    name: "model_order",
    columns: &[
        col::JOB,
        col::DATASET,
        col::MODEL_ORDER,
        col::COMPONENT,
        col::KL_MEAN_DB,
        col::KL_WORST_DB,
        col::PIXELS,
        col::SAMPLES_ORIGINAL,
        col::SAMPLES_COMPARED,
        col::BINS,
        col::SMOOTHING,
        col::SYMMETRIC,
        col::MEAN_OVER_BINS,
        col::BIAS_CORRECTION,
    ],
    per_level: &[],
};

/// `correlating_function`: the plants' correlating function over pixel offsets (Figs. 52-56).
pub const CORRELATING_FUNCTION: Table = Table {
    name: "correlating_function",
    columns: &[
        col::JOB,
        col::DATASET,
        col::DY,
        col::DX,
        col::DISTANCE,
        col::MEAN_CORRELATION,
        col::MEAN_MAGNITUDE,
        col::PAIRS,
    ],
    per_level: &[],
};

/// `calibration`: the sphere calibration's spectra (Figs. 11-14).
pub const CALIBRATION: Table = Table {
    name: "calibration",
    columns: &[
        col::FREQ_GHZ,
        col::MIE_DBSM,
        col::RAW_DB,
        col::CALIBRATED_DBSM,
        col::ERROR_DB,
        col::PHASE_ERROR_DEG,
    ],
    per_level: &[],
};

/// `calibration_summary`: the calibration's error statistics by band.
pub const CALIBRATION_SUMMARY: Table = Table {
    name: "calibration_summary",
    columns: &[col::BAND, col::STATISTIC, col::VALUE],
    per_level: &[],
};

/// `hypotheses`: the hypothesis tests H1-H4 (ch. 5.1).
pub const HYPOTHESES: Table = Table {
    name: "hypotheses",
    columns: &[
        col::HYPOTHESIS,
        col::DATASET,
        col::STATISTIC,
        col::VALUE,
        col::VERDICT,
    ],
    per_level: &[],
};

/// `classification`: the clutter classification trainings (Tables 20, 22).
pub const CLASSIFICATION: Table = Table {
    name: "classification",
    columns: &[
        col::JOB,
        col::METHOD,
        col::NORMALISE,
        col::TRAIN_SIZE,
        col::REPEAT,
        col::SEED,
        col::TRAIN_ACCURACY,
        col::VALIDATION_ACCURACY,
        col::TEST_ACCURACY,
        col::TEST_SAMPLES,
        col::EPOCHS,
        col::TRAIN_SECONDS,
        col::TRAIN_SAMPLES_PER_SECOND,
        col::TRAIN_SAMPLES,
        col::TRAIN_GENERATED,
        col::TRAIN_ORIGINALS,
        col::VALIDATION_SAMPLES,
        col::VALIDATION_REUSES_ORIGINALS,
        col::PROTOCOL,
    ],
    per_level: &[],
};

/// `confusion`: the classification trainings' confusion counts.
pub const CONFUSION: Table = Table {
    name: "confusion",
    columns: &[col::JOB, col::TRUE_CLASS, col::PREDICTED_CLASS, col::COUNT],
    per_level: &[],
};

/// `training_history`: every training's loss and accuracies by epoch.
pub const TRAINING_HISTORY: Table = Table {
    name: "training_history",
    columns: &[
        col::JOB,
        col::EPOCH,
        col::LOSS,
        col::BATCH_ACCURACY,
        col::VALIDATION_ACCURACY,
    ],
    per_level: &[],
};

/// `location`: the target location trainings (Figs. 73-74).
pub const LOCATION: Table = Table {
    name: "location",
    columns: &[
        col::JOB,
        col::TARGET,
        col::METHOD,
        col::SCR_DB,
        col::REPEAT,
        col::SEED,
        col::TEST_SET,
        col::TRAIN_ACCURACY,
        col::VALIDATION_ACCURACY,
        col::TEST_ACCURACY,
        col::TEST_SAMPLES,
        col::EPOCHS,
        col::TRAIN_SECONDS,
        col::TRAIN_SAMPLES_PER_SECOND,
        col::TRAIN_SAMPLES,
        col::TRAIN_GENERATED,
        col::CLUTTER_POWER,
    ],
    per_level: &[],
};

/// `location_summary`: the location accuracy's SCR thresholds and gains over the original.
pub const LOCATION_SUMMARY: Table = Table {
    name: "location_summary",
    columns: &[
        col::TARGET,
        col::TEST_SET,
        col::METHOD,
        col::SCR_50_DB,
        col::SCR_90_DB,
        col::GAIN_50_DB,
        col::GAIN_90_DB,
        col::BEST_MEAN_ACCURACY,
        col::SCR_POINTS,
    ],
    per_level: &[],
};

/// Declares [`CnnApp`] and its list [`CnnApp::ALL`] from one list of variants, so that the
/// list cannot miss one.
macro_rules! cnn_apps {
    ($($(#[$doc:meta])* $variant:ident),* $(,)?) => {
        /// A CNN application's trainings as the report reads them: one table of trainings,
        /// split into groups (tables and figures) by one column and swept along another. A new
        /// application is a variant here, beside its table; the compiler then names each place
        /// of the report that shows it (its section, its tables' layout, its figures' labels).
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum CnnApp {
            $($(#[$doc])* $variant),*
        }

        impl CnnApp {
            /// Every application, in report order.
            pub const ALL: &'static [CnnApp] = &[$(CnnApp::$variant),*];
        }
    };
}

cnn_apps! {
    /// Clutter classification (Tables 19-22, Figs. 66-67): [`CLASSIFICATION`].
    Classification,
    /// Target location (Figs. 68-74): [`LOCATION`] (and its summary [`LOCATION_SUMMARY`]).
    Location,
}

impl CnnApp {
    /// The table of its trainings.
    pub fn table(self) -> Table {
        match self {
            CnnApp::Classification => CLASSIFICATION,
            CnnApp::Location => LOCATION,
        }
    }

    /// The column that splits its trainings into tables and figures.
    pub fn group_column(self) -> &'static str {
        match self {
            CnnApp::Classification => col::NORMALISE,
            CnnApp::Location => col::TARGET,
        }
    }

    /// The column across the page (tables) and along the x axis (figures).
    pub fn x_column(self) -> &'static str {
        match self {
            CnnApp::Classification => col::TRAIN_SIZE,
            CnnApp::Location => col::SCR_DB,
        }
    }
}

/// Every table a run can write.
pub const ALL: [Table; 17] = [
    ANALYSIS_MAPS,
    ANALYSIS_SUMMARY,
    PIXEL_STATS,
    FILTER_CORRELATION,
    JOBS,
    SYNTHESIS_PARAMS,
    SIMILARITY,
    MODEL_ORDER,
    CORRELATING_FUNCTION,
    CALIBRATION,
    CALIBRATION_SUMMARY,
    HYPOTHESES,
    CLASSIFICATION,
    CONFUSION,
    TRAINING_HISTORY,
    LOCATION,
    LOCATION_SUMMARY,
];

/// The table named `name`, if the contract has it.
pub fn table(name: &str) -> Option<Table> {
    ALL.iter().copied().find(|t| t.name == name)
}

/// Checks the columns a writer is about to write as the table `name`: the table must be one of
/// the contract's and every column one it declares ([`Table::declares`]), or a swept parameter's (a key of `swept`,
/// or `swept_<key>` where the table has a column of the key's name); intermediate tables,
/// named `_...`, are the runner's own and not checked.
///
/// # Errors
/// Naming the table and the undeclared column.
pub fn check_columns<'a>(
    name: &str,
    columns: impl IntoIterator<Item = &'a str>,
    swept: &[String],
) -> Result<()> {
    if name.starts_with('_') {
        return Ok(());
    }
    let Some(t) = table(name) else {
        bail!(
            "the table {name:?} is not in the results contract (crates/tables/src/io/results.rs)"
        );
    };
    for c in columns {
        let param = swept
            .iter()
            .any(|k| k == c || c.strip_prefix("swept_") == Some(k.as_str()));
        if !param && !t.declares(c) {
            bail!(
                "the table {name:?} would get the column {c:?}, which the results contract \
                 (crates/tables/src/io/results.rs) does not declare"
            );
        }
    }
    Ok(())
}
