//! The dissertation's hypothesis tests on plant clutter (ch. 5.1, Table 24; docs/definitions.md
//! §8), run over datasets named `plant_<letter>_<wind>`: Table 16 (mean pixel variance), the mean
//! 2-D correlating function by offset (5.1.3), mean correlation by level (Figs. 52-53) and by
//! wind (Figs. 54-56), each with a verdict. Definitions and thresholds: `docs/hypotheses.md`.

use crate::stats::analysis::{Analysis, Direction};
use ndarray::{Array2, ArrayView3};
use num_complex::Complex64;
use rayon::prelude::*;

/// The names of the statistics the tests write (the `statistic` column of `hypotheses`), once
/// for the tests here and the readers of their rows (the reproduction's Table 24). A name that
/// ends in `_` is a prefix: the rows append what they compare (`variance_ratio_light_over_none`).
pub mod statistic {
    /// H1: the ratio of two mean pixel variances (`..._<hi>_over_<lo>`).
    pub const VARIANCE_RATIO: &str = "variance_ratio";
    /// H2: the rank correlation of separation with the correlating function's magnitude.
    pub const SPEARMAN_DISTANCE_VS_MAGNITUDE: &str = "spearman_distance_vs_magnitude";
    /// H2: the rank correlation of separation with its real part.
    pub const SPEARMAN_DISTANCE_VS_MEAN_CORRELATION: &str = "spearman_distance_vs_mean_correlation";
    /// H3: the fraction of level-to-level steps whose mean correlation decreases.
    pub const FRACTION_OF_LEVEL_STEPS: &str = "fraction_of_level_steps";
    /// H4: the fraction of levels whose correlation falls with the wind (`..._<hi>_vs_<lo>`).
    pub const LEVELS_DECREASING_FRACTION: &str = "levels_decreasing_fraction";
}

/// The mean 2-D correlating function by offset, `(2R+1) x (2R+1)` maps (row `dy + R`,
/// column `dx + R`).
#[derive(Debug, Clone, PartialEq)]
pub struct Correlating {
    /// The real part of the mean complex correlation coefficient.
    pub real: Array2<f64>,
    /// The magnitude of the mean complex correlation coefficient (5.1.3 plots it, Figs. 50-51).
    pub magnitude: Array2<f64>,
    /// Pixel pairs behind each value.
    pub pairs: Array2<usize>,
}

/// Mean 2-D correlating function: for every offset `(dy, dx)` with `|dy|, |dx| <= max_offset`,
/// the mean over pixel pairs `(p, p + (dy, dx))` inside the image (both finite, both with
/// non-zero variance) of their complex correlation coefficient over the samples, computed pair
/// by pair without the full covariance matrix; its real part and its magnitude.
pub fn correlating_function(x: ArrayView3<Complex64>, max_offset: usize) -> Correlating {
    let (n, h, w) = x.dim();
    let r = max_offset as isize;
    let mean = Array2::from_shape_fn((h, w), |(i, j)| {
        (0..n).map(|s| x[[s, i, j]]).sum::<Complex64>() / n as f64
    });
    let sd = Array2::from_shape_fn((h, w), |(i, j)| {
        ((0..n)
            .map(|s| (x[[s, i, j]] - mean[[i, j]]).norm_sqr())
            .sum::<f64>()
            / n as f64)
            .sqrt()
    });
    let size = 2 * max_offset + 1;
    let cells: Vec<(Complex64, usize)> = (0..size * size)
        .into_par_iter()
        .map(|k| {
            let (dy, dx) = ((k / size) as isize - r, (k % size) as isize - r);
            let (mut sum, mut pairs) = (Complex64::new(0.0, 0.0), 0usize);
            for i in 0..h as isize {
                for j in 0..w as isize {
                    let (i2, j2) = (i + dy, j + dx);
                    if i2 < 0 || j2 < 0 || i2 >= h as isize || j2 >= w as isize {
                        continue;
                    }
                    let (p, q) = ((i as usize, j as usize), (i2 as usize, j2 as usize));
                    let s = sd[p] * sd[q];
                    if !(s > 0.0 && s.is_finite()) {
                        continue;
                    }
                    let c: Complex64 = (0..n)
                        .map(|t| (x[[t, p.0, p.1]] - mean[p]) * (x[[t, q.0, q.1]] - mean[q]).conj())
                        .sum::<Complex64>()
                        / n as f64;
                    sum += c / s;
                    pairs += 1;
                }
            }
            (
                if pairs > 0 {
                    sum / pairs as f64
                } else {
                    Complex64::new(f64::NAN, f64::NAN)
                },
                pairs,
            )
        })
        .collect();
    let at = |a: usize, b: usize| cells[a * size + b];
    Correlating {
        real: Array2::from_shape_fn((size, size), |(a, b)| at(a, b).0.re),
        magnitude: Array2::from_shape_fn((size, size), |(a, b)| at(a, b).0.norm()),
        pairs: Array2::from_shape_fn((size, size), |(a, b)| at(a, b).1),
    }
}

/// One dataset's inputs to the tests: the numbers of its analysis that they use.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantStats {
    /// Dataset id.
    pub dataset: String,
    /// Plant letter and wind, parsed from `plant_<letter>_<wind>`.
    pub plant: String,
    /// Wind (`none`, `light`, `medium`).
    pub wind: String,
    /// Mean over the finite pixels of the pixel variance (Table 16).
    pub mean_variance: f64,
    /// Per level `1..=L`, the mean correlation of directions H, V and D.
    pub level_correlations: Vec<[f64; 3]>,
    /// The mean 2-D correlating function (row `dy + R`, column `dx + R`): real part.
    pub correlating: Array2<f64>,
    /// Its magnitude (NaN where the run's table has none: stored before the column existed).
    pub magnitude: Array2<f64>,
}

/// The numbers of an analysis that the tests use: the mean over the finite pixels of the pixel
/// variance, and per level the mean correlation of directions H, V and D.
pub fn analysis_numbers(analysis: &Analysis) -> (f64, Vec<[f64; 3]>) {
    (
        crate::stats::metrics::finite_mean(&analysis.variance).0,
        analysis
            .levels
            .iter()
            .map(|l| Direction::ALL.map(|d| l.summary(d).mean_correlation))
            .collect(),
    )
}

impl PlantStats {
    /// Mean of the level-`l` (0-based) mean correlations over H, V, D.
    fn level_mean(&self, l: usize) -> f64 {
        self.level_correlations[l].iter().sum::<f64>() / 3.0
    }
}

/// One row of `hypotheses.parquet`.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// `table16`, `H1`..`H4`.
    pub hypothesis: &'static str,
    /// Dataset (or `plant_<letter>` / `light` for comparisons across datasets).
    pub dataset: String,
    /// What `value` is.
    pub statistic: String,
    /// The value.
    pub value: f64,
    /// `verified` or `not verified`; `None` for plain statistics.
    pub verdict: Option<&'static str>,
}

fn verdict(ok: bool) -> Option<&'static str> {
    Some(if ok { "verified" } else { "not verified" })
}

/// Spearman rank correlation of two equally long sequences (average ranks for ties).
pub fn spearman(x: &[f64], y: &[f64]) -> f64 {
    fn ranks(v: &[f64]) -> Vec<f64> {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        let mut r = vec![0.0; v.len()];
        let mut i = 0;
        while i < idx.len() {
            let mut j = i;
            while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
                j += 1;
            }
            for &k in &idx[i..=j] {
                r[k] = (i + j) as f64 / 2.0;
            }
            i = j + 1;
        }
        r
    }
    let (rx, ry) = (ranks(x), ranks(y));
    let n = x.len() as f64;
    let (mx, my) = (rx.iter().sum::<f64>() / n, ry.iter().sum::<f64>() / n);
    let cov: f64 = rx.iter().zip(&ry).map(|(a, b)| (a - mx) * (b - my)).sum();
    let vx: f64 = rx.iter().map(|a| (a - mx).powi(2)).sum();
    let vy: f64 = ry.iter().map(|b| (b - my).powi(2)).sum();
    cov / (vx * vy).sqrt()
}

/// The tests over the datasets (see `docs/hypotheses.md`): Table 16's mean pixel variances,
/// then H1-H4 in turn from the same rows.
pub fn test(stats: &[PlantStats]) -> Vec<Row> {
    let mut rows: Vec<Row> = stats
        .iter()
        .map(|s| {
            row(
                "table16",
                &s.dataset,
                "mean_pixel_variance",
                s.mean_variance,
                None,
            )
        })
        .collect();
    let by = ByPlant::new(stats);
    rows.extend(h1_variance_rises_with_motion_and_leaf_size(&by));
    rows.extend(stats.iter().flat_map(h2_correlation_falls_with_separation));
    rows.extend(stats.iter().flat_map(h3_correlation_falls_with_level));
    rows.extend(h4_correlation_falls_with_motion(&by));
    rows
}

/// One row of the hypotheses table.
fn row(
    hypothesis: &'static str,
    dataset: &str,
    statistic: &str,
    value: f64,
    verdict: Option<&'static str>,
) -> Row {
    Row {
        hypothesis,
        dataset: dataset.to_string(),
        statistic: statistic.to_string(),
        value,
        verdict,
    }
}

/// The datasets by plant and wind.
struct ByPlant<'a> {
    stats: &'a [PlantStats],
    /// The plants, sorted, each once.
    plants: Vec<&'a str>,
}

impl<'a> ByPlant<'a> {
    fn new(stats: &'a [PlantStats]) -> Self {
        let mut plants: Vec<&str> = stats.iter().map(|s| s.plant.as_str()).collect();
        plants.sort();
        plants.dedup();
        ByPlant { stats, plants }
    }

    /// The dataset of `plant` in `wind`.
    fn find(&self, plant: &str, wind: &str) -> Option<&'a PlantStats> {
        self.stats
            .iter()
            .find(|s| s.plant == plant && s.wind == wind)
    }

    /// Each plant's pairs of datasets in successive winds (none -> light, light -> medium):
    /// the plant, the lower and the higher wind, and their datasets.
    fn wind_steps(
        &self,
    ) -> Vec<(
        &'a str,
        &'static str,
        &'static str,
        &'a PlantStats,
        &'a PlantStats,
    )> {
        let mut steps = vec![];
        for &p in &self.plants {
            for (lo, hi) in [("none", "light"), ("light", "medium")] {
                if let (Some(a), Some(b)) = (self.find(p, lo), self.find(p, hi)) {
                    steps.push((p, lo, hi, a, b));
                }
            }
        }
        steps
    }
}

/// H1: variance increases with motion (wind), per plant, and with leaf size: in light wind,
/// A (very large leaves) > B (medium) > C (small).
fn h1_variance_rises_with_motion_and_leaf_size(by: &ByPlant) -> Vec<Row> {
    let mut rows = vec![];
    for (p, lo, hi, a, b) in by.wind_steps() {
        let ratio = b.mean_variance / a.mean_variance;
        rows.push(row(
            "H1",
            &format!("plant_{p}"),
            &format!("{}_{hi}_over_{lo}", statistic::VARIANCE_RATIO),
            ratio,
            verdict(ratio > 1.0),
        ));
    }
    if let (Some(a), Some(b), Some(c)) = (
        by.find("A", "light"),
        by.find("B", "light"),
        by.find("C", "light"),
    ) {
        let (va, vb, vc) = (a.mean_variance, b.mean_variance, c.mean_variance);
        rows.push(row(
            "H1",
            "light",
            &format!("{}_A_over_B", statistic::VARIANCE_RATIO),
            va / vb,
            verdict(va > vb),
        ));
        rows.push(row(
            "H1",
            "light",
            &format!("{}_B_over_C", statistic::VARIANCE_RATIO),
            vb / vc,
            verdict(vb > vc),
        ));
    }
    rows
}

/// H2: correlation decreases with pixel separation: the rank correlation of the offset's length
/// with the magnitude of the mean correlating function (what 5.1.3 plots), and with its real
/// part (the other reading).
fn h2_correlation_falls_with_separation(s: &PlantStats) -> Vec<Row> {
    let mut rows = vec![];
    for (map, statistic) in [
        (&s.magnitude, statistic::SPEARMAN_DISTANCE_VS_MAGNITUDE),
        (
            &s.correlating,
            statistic::SPEARMAN_DISTANCE_VS_MEAN_CORRELATION,
        ),
    ] {
        let r = (map.nrows() / 2) as isize;
        let (mut dist, mut corr) = (vec![], vec![]);
        for ((a, b), &v) in map.indexed_iter() {
            let (dy, dx) = (a as isize - r, b as isize - r);
            if (dy, dx) != (0, 0) && v.is_finite() {
                dist.push(((dy * dy + dx * dx) as f64).sqrt());
                corr.push(v);
            }
        }
        if corr.is_empty() {
            continue;
        }
        let rho = spearman(&dist, &corr);
        rows.push(row("H2", &s.dataset, statistic, rho, verdict(rho < 0.0)));
    }
    rows
}

/// H3: correlation decreases as the decomposition level increases: the fraction of the level
/// steps (every direction) that decrease, verified at 3/4, then each level's mean.
fn h3_correlation_falls_with_level(s: &PlantStats) -> Vec<Row> {
    let levels = s.level_correlations.len();
    let (mut down, mut steps) = (0, 0);
    for d in Direction::ALL {
        for l in 1..levels {
            let (a, b) = (
                s.level_correlations[l - 1][d as usize],
                s.level_correlations[l][d as usize],
            );
            if a.is_finite() && b.is_finite() {
                steps += 1;
                down += usize::from(b < a);
            }
        }
    }
    let frac = down as f64 / steps.max(1) as f64;
    let mut rows = vec![row(
        "H3",
        &s.dataset,
        &format!("{}_decreasing", statistic::FRACTION_OF_LEVEL_STEPS),
        frac,
        verdict(frac >= 0.75),
    )];
    for l in 0..levels {
        rows.push(row(
            "H3",
            &s.dataset,
            &format!("mean_correlation_level{}", l + 1),
            s.level_mean(l),
            None,
        ));
    }
    rows
}

/// H4: correlation decreases with increased motion, judged at every level as the
/// dissertation's 5.1.5 does (its "not verified" came from levels 2 and 3): one row per level,
/// then the reading over all levels (verified when every level decreases).
fn h4_correlation_falls_with_motion(by: &ByPlant) -> Vec<Row> {
    let mut rows = vec![];
    for (p, lo, hi, a, b) in by.wind_steps() {
        let levels = a.level_correlations.len().min(b.level_correlations.len());
        let mut down = 0;
        for l in 0..levels {
            let diff = b.level_mean(l) - a.level_mean(l);
            down += usize::from(diff < 0.0);
            rows.push(row(
                "H4",
                &format!("plant_{p}"),
                &format!("level{}_correlation_{hi}_minus_{lo}", l + 1),
                diff,
                verdict(diff < 0.0),
            ));
        }
        rows.push(row(
            "H4",
            &format!("plant_{p}"),
            &format!("{}_{hi}_vs_{lo}", statistic::LEVELS_DECREASING_FRACTION),
            down as f64 / levels.max(1) as f64,
            verdict(levels > 0 && down == levels),
        ));
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;

    #[test]
    fn spearman_of_monotone_and_reversed_sequences() {
        assert!((spearman(&[1.0, 2.0, 3.0, 4.0], &[10.0, 20.0, 25.0, 99.0]) - 1.0).abs() < 1e-12);
        assert!((spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
    }

    #[test]
    fn correlating_function_matches_a_known_shift_structure() {
        // x(i, j) = z(i, j) + z(i, j + 1): horizontal lag-1 correlation 1/2, none vertically,
        // and lag 0 is exactly 1. Deterministic pseudo-random z with many samples.
        let (n, h, w) = (4000, 6, 7);
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let z = Array3::from_shape_simple_fn((n, h, w + 1), || Complex64::new(next(), next()));
        let x = Array3::from_shape_fn((n, h, w), |(s, i, j)| z[[s, i, j]] + z[[s, i, j + 1]]);
        let Correlating {
            real: c,
            magnitude,
            pairs,
        } = correlating_function(x.view(), 2);
        assert!((magnitude[[2, 3]] - c[[2, 3]].abs()).abs() < 0.03);
        assert!((c[[2, 2]] - 1.0).abs() < 1e-12);
        assert!((c[[2, 3]] - 0.5).abs() < 0.03, "{}", c[[2, 3]]);
        assert!((c[[2, 1]] - 0.5).abs() < 0.03);
        assert!(c[[3, 2]].abs() < 0.03 && c[[2, 4]].abs() < 0.03);
        assert_eq!(pairs[[2, 3]], h * (w - 1));
        assert_eq!(pairs[[0, 0]], (h - 2) * (w - 2));
    }
}
