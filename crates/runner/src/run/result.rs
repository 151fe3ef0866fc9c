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

/// A job's real maps by name (`variance`, `level{L}_{correlation,covariance}_{H,V,D}`,
/// `expected_level{L}_correlation_{H,V,D}`, the similarity comparisons), in the order they are
/// written; the complex mean is apart (`mean`).
pub fn job_maps(r: &JobResult) -> Vec<(String, &Array2<f64>)> {
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
    maps
}

/// Writes a job's maps under `dir` (`mean.npy` and those of [`job_maps`], `.npy` each).
///
/// # Errors
/// If a file cannot be written.
pub fn write_job_maps(dir: &Path, r: &JobResult) -> Result<()> {
    use rayon::prelude::*;
    if let Some(analysis) = &r.analysis {
        write_npy(&names::file(dir, names::MEAN), &analysis.mean)?;
    }
    job_maps(r)
        .par_iter()
        .try_for_each(|(name, map)| write_npy(&names::file(dir, name), *map))
}

/// Stages a job's maps (the mean and those of [`job_maps`]) for the run's Zarr store: their
/// compressed chunks in one file, `path` ([`crate::io::zarr::write_staged`]).
///
/// # Errors
/// If the file cannot be written.
pub fn stage_job_maps(path: &Path, r: &JobResult) -> Result<()> {
    use crate::io::zarr::{chunk, Values};
    use rayon::prelude::*;
    let mut chunks: Vec<crate::io::zarr::Chunk> = job_maps(r)
        .par_iter()
        .map(|(name, m)| {
            let values = m.as_standard_layout();
            let v = values.as_slice().expect("standard layout");
            chunk(name, m.nrows(), m.ncols(), Values::F64(v))
        })
        .collect();
    if let Some(a) = &r.analysis {
        let values = a.mean.as_standard_layout();
        let v = values.as_slice().expect("standard layout");
        let mean = chunk(names::MEAN, a.mean.nrows(), a.mean.ncols(), Values::C128(v));
        chunks.insert(0, mean);
    }
    crate::io::zarr::write_staged(path, &chunks)
}
