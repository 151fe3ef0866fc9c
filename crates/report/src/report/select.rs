//! Which jobs get per-job figures. A run whose jobs with per-job figures (an ok job with a
//! `maps/<job>/` folder, a `samples/<job>.npy` or rows in `synthesis_params.parquet`) number at
//! most the limit ([`DEFAULT_FIGURE_JOBS`], or `report --figures-for N`) gets them for every
//! such job, as before; a bigger one gets them for `limit` of them spread evenly over the plan
//! order, the first and the last included ([`spread`]). The choice depends only on the
//! manifest's job list and the files present, never on thread count or timing, so two reports
//! of the same folder pick the same jobs. The rest stay reachable from the tables and files
//! the page links (`analysis_maps.parquet`, `pixel_stats.parquet`, `maps/<job>/`).

use anyhow::{bail, Result};
use std::collections::BTreeSet;
use std::path::Path;

/// The default limit: above the number of jobs with per-job figures of every shipped
/// experiment (at most 27, `model_order.yaml`), so that their reports are complete.
pub const DEFAULT_FIGURE_JOBS: usize = 50;

/// How many jobs get per-job figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FiguresFor {
    /// Every job with per-job figures, however many.
    All,
    /// At most this many (spread evenly over the plan order when there are more).
    Jobs(usize),
}

impl Default for FiguresFor {
    fn default() -> Self {
        FiguresFor::Jobs(DEFAULT_FIGURE_JOBS)
    }
}

impl std::fmt::Display for FiguresFor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FiguresFor::All => write!(f, "all"),
            FiguresFor::Jobs(n) => write!(f, "{n}"),
        }
    }
}

impl std::str::FromStr for FiguresFor {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Self> {
        match s.trim() {
            "all" => Ok(FiguresFor::All),
            n => match n.parse::<usize>() {
                Ok(n) => Ok(FiguresFor::Jobs(n)),
                Err(_) => bail!("{s:?}: expected `all` or a number of jobs (0 or more)"),
            },
        }
    }
}

/// Options of a report.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// How many jobs get per-job figures.
    pub figures_for: FiguresFor,
}

/// `k` distinct indices of `0..n`, spread evenly and in increasing order: `round(i (n - 1) /
/// (k - 1))` for `i = 0..k`, so the first (0) and the last (`n - 1`) are included when `k >= 2`;
/// `[0]` when `k == 1`; every index when `k >= n`.
pub fn spread(n: usize, k: usize) -> Vec<usize> {
    if k >= n {
        return (0..n).collect();
    }
    match k {
        0 => vec![],
        1 => vec![0],
        _ => (0..k)
            .map(|i| (i * (n - 1) + (k - 1) / 2) / (k - 1))
            .collect(),
    }
}

/// The jobs that get per-job figures, and what they were chosen from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Selection {
    /// The chosen jobs, in plan order.
    pub jobs: Vec<String>,
    /// How many jobs have per-job figures (the jobs were chosen from these).
    pub candidates: usize,
    /// Whether some candidates were left out (the report says so).
    pub limited: bool,
}

impl Selection {
    /// The chosen jobs as a set.
    pub fn set(&self) -> BTreeSet<&str> {
        self.jobs.iter().map(String::as_str).collect()
    }
}

/// Chooses among `candidates` (jobs with per-job figures, in plan order) as `figures_for` says.
pub fn choose(candidates: &[String], figures_for: FiguresFor) -> Selection {
    let n = candidates.len();
    let k = match figures_for {
        FiguresFor::All => n,
        FiguresFor::Jobs(k) => k.min(n),
    };
    Selection {
        jobs: spread(n, k)
            .into_iter()
            .map(|i| candidates[i].clone())
            .collect(),
        candidates: n,
        limited: k < n,
    }
}

/// The jobs of `ok` (plan order) with per-job figures in the results folder `dir`: a
/// `maps/<job>/` folder, maps in `maps.zarr`, a `samples/<job>.npy`, or a job of
/// `with_params` (the jobs with rows in `synthesis_params.parquet`).
pub fn candidates(dir: &Path, ok: &[String], with_params: &BTreeSet<String>) -> Vec<String> {
    use crate::io::results::files;
    // A store that cannot be read gives no candidates here; drawing a job's maps from it
    // says why.
    let in_store: BTreeSet<String> = crate::io::zarr::jobs(&files::maps_zarr(dir))
        .unwrap_or_default()
        .into_iter()
        .collect();
    ok.iter()
        .filter(|job| {
            with_params.contains(job.as_str())
                || files::maps(dir, job).is_dir()
                || in_store.contains(job.as_str())
                || files::samples(dir, job).is_file()
        })
        .cloned()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_is_bounded_distinct_and_keeps_both_ends() {
        assert_eq!(spread(0, 5), Vec::<usize>::new());
        assert_eq!(spread(3, 5), vec![0, 1, 2]);
        assert_eq!(spread(10, 0), Vec::<usize>::new());
        assert_eq!(spread(10, 1), vec![0]);
        assert_eq!(spread(10, 2), vec![0, 9]);
        assert_eq!(spread(5000, 5), vec![0, 1250, 2500, 3749, 4999]);
        for n in 1..60 {
            for k in 0..=n + 2 {
                let s = spread(n, k);
                assert_eq!(s.len(), k.min(n), "n {n} k {k}");
                assert!(s.windows(2).all(|w| w[0] < w[1]), "n {n} k {k}: {s:?}");
                assert!(s.iter().all(|&i| i < n));
                if k >= 2 {
                    assert_eq!((s[0], *s.last().unwrap()), (0, n - 1));
                }
            }
        }
    }

    #[test]
    fn figures_for_parses_all_and_numbers() {
        assert_eq!("all".parse::<FiguresFor>().unwrap(), FiguresFor::All);
        assert_eq!("12".parse::<FiguresFor>().unwrap(), FiguresFor::Jobs(12));
        assert_eq!("0".parse::<FiguresFor>().unwrap(), FiguresFor::Jobs(0));
        assert!("-1".parse::<FiguresFor>().is_err());
        assert!("some".parse::<FiguresFor>().is_err());
    }

    #[test]
    fn choose_keeps_small_runs_whole() {
        let jobs: Vec<String> = (0..7).map(|i| format!("j{i}")).collect();
        let all = choose(&jobs, FiguresFor::default());
        assert_eq!((all.jobs.len(), all.candidates, all.limited), (7, 7, false));
        let three = choose(&jobs, FiguresFor::Jobs(3));
        assert_eq!(three.jobs, ["j0", "j3", "j6"]);
        assert!(three.limited);
        assert_eq!(choose(&jobs, FiguresFor::All).jobs, jobs);
    }
}
