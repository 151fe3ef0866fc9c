//! What a dataset job computed (its analysis, fit, generation, metrics, expected maps and
//! timings) before it becomes table fragments, and the `.npy` maps it writes.

use crate::io::atomic::write_npy;
use crate::io::results::{col, maps as names};
use crate::stats::analysis::{Analysis, Direction};
use anyhow::Result;
use ndarray::Array2;
use std::path::{Path, PathBuf};

/// What one successful job computed.
pub struct JobResult {
    /// Whose statistics `analysis` holds: `original` for an analysis job, the method's name
    /// for the generated samples of a synthesis job.
    pub source: &'static str,
    /// The analysis (`None` for a synthesis job with `analyse_generated: false`).
    pub analysis: Option<Analysis>,
    /// A synthesis job's fit and generation.
    pub synthesis: Option<SynthesisOutcome>,
    /// Exact expected correlation maps per level (`[H, V, D]`) for synthetic data.
    pub expected: Option<Vec<[Array2<f64>; 3]>>,
    /// Filter lag correlations for synthetic data with spatially uniform filters.
    pub filter_rows: Vec<FilterRow>,
    /// Stack shape `(N, H, W)`.
    pub shape: (usize, usize, usize),
    /// Seconds spent loading or generating the data.
    pub data_s: f64,
    /// Seconds spent in the analysis kernel.
    pub analysis_s: f64,
    /// Bytes of stack data analysed.
    pub bytes: usize,
    /// The metrics: generated vs original (synthesis jobs) or the noise floor (analysis jobs).
    pub similarity: Option<SimilarityOutcome>,
    /// With `synthesis.held_out`, the same metrics against originals no fit saw: a synthesis
    /// job's samples from its method fitted on one seeded half of the originals against the
    /// other half; an analysis job's floor of those two halves.
    pub held_out: Option<SimilarityOutcome>,
    /// With `hypotheses`: the mean 2-D correlating function of the original and its pair counts.
    pub correlating: Option<crate::apps::hypotheses::Correlating>,
    /// Files and folders the job wrote (k-space samples, model folder, generated samples).
    pub files: Vec<PathBuf>,
}

/// The metrics one job computed.
pub struct SimilarityOutcome {
    /// What was compared with the original: a method's name, or `noise_floor`.
    pub compared: &'static str,
    /// For the noise floor: `draws` or `halves`.
    pub noise_floor: Option<&'static str>,
    /// Rows and KL maps.
    pub comparison: crate::stats::similarity::Comparison,
    /// Seconds spent on the metrics (and, for the noise floor, on its data).
    pub seconds: f64,
}

/// What a synthesis job fitted and generated.
pub struct SynthesisOutcome {
    /// Per-cell parameters of Methods 1 and 2.
    pub filter: Option<crate::synthesis::FilterModel>,
    /// Samples generated.
    pub samples: usize,
    /// Seconds spent fitting.
    pub fit_s: f64,
    /// Seconds spent generating.
    pub generate_s: f64,
}

/// One row of `filter_correlation.parquet` (Table 3).
#[derive(Debug, Clone, PartialEq)]
pub struct FilterRow {
    /// `H` or `V`.
    pub direction: Direction,
    /// Lag `d >= 0`.
    pub lag: usize,
    /// Tap `f(d)`.
    pub coefficient: f64,
    /// `rho(d)` (eq. 66).
    pub correlation: f64,
}

/// Writes a job's maps under `dir` (`mean.npy`, `variance.npy`,
/// `level{L}_{correlation,covariance}_{H,V,D}.npy`, `expected_level{L}_correlation_{H,V,D}.npy`).
///
/// # Errors
/// If a file cannot be written.
pub fn write_job_maps(dir: &Path, r: &JobResult) -> Result<()> {
    use rayon::prelude::*;
    let mut maps: Vec<(String, &Array2<f64>)> = vec![];
    if let Some(sim) = &r.similarity {
        let prefix = if sim.noise_floor.is_some() {
            names::NOISE_FLOOR
        } else {
            ""
        };
        for (stem, map) in &sim.comparison.maps {
            maps.push((names::comparison(prefix, stem), map));
        }
    }
    if let Some(analysis) = &r.analysis {
        write_npy(&names::file(dir, names::MEAN), &analysis.mean)?;
        maps.push((names::VARIANCE.into(), &analysis.variance));
    }
    for lm in r.analysis.iter().flat_map(|a| &a.levels) {
        for d in Direction::ALL {
            maps.push((
                names::level("", lm.level, col::CORRELATION, d),
                lm.correlation(d),
            ));
            maps.push((
                names::level("", lm.level, col::COVARIANCE, d),
                lm.covariance(d),
            ));
        }
    }
    for (l, expected) in r.expected.iter().flatten().enumerate() {
        for d in Direction::ALL {
            maps.push((
                names::level(names::EXPECTED, l + 1, col::CORRELATION, d),
                &expected[d as usize],
            ));
        }
    }
    maps.par_iter()
        .try_for_each(|(name, map)| write_npy(&names::file(dir, name), *map))
}
