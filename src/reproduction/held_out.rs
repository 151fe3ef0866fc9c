//! Held-out similarity beside in-sample (what the dissertation's similarity tables cannot
//! show): every method of the similarity specs is fitted again on a seeded half of the
//! originals and its samples compared with the other half, which no fit saw
//! (`synthesis.held_out`); the floor of those comparisons is the two halves against each other.
//! A method that copies its fit data (the full covariance baseline draws from the sample
//! covariance of the very originals it is compared with) looks far better in sample than held
//! out; one that only estimates a few correlations per cell looks alike both ways.

use super::extract::{cmd, held_out, kl, rmse_average, Query, Tables};
use crate::io::results::value;
use crate::stats::metrics::name as metric_name;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// The similarity specs, the datasets of their rows and the tables they stand beside.
const SPECS: [(&str, &[&str], &str); 3] = [
    ("similarity_exponential", &["exponential"], "Tables 6-10"),
    (
        "similarity_nonexponential",
        &["nonexponential"],
        "Tables 6-10 (non-exponential rows)",
    ),
    (
        "similarity_plants",
        &[
            "plant_D_light",
            "plant_D_medium",
            "plant_E_light",
            "plant_E_medium",
        ],
        "Tables 11-15",
    ),
];

/// The rows of each dataset: the methods, then the floor.
const METHODS: [&str; 5] = [
    "full_covariance",
    "method1",
    "method2",
    "uncorrelated",
    value::NOISE_FLOOR,
];

/// The query of a measure for a dataset and a method.
type Measure = fn(&'static str, &'static str) -> Query;

/// The measures shown, each in sample and held out.
fn measures() -> [(&'static str, Measure); 3] {
    [
        ("correlation matrix distance", |d, m| cmd(d, m)),
        ("multiscale RMSE, levels 1-3", |d, m| {
            rmse_average(d, m, "average_levels_1_3")
        }),
        ("KL by 8x8 area (real)", |d, m| {
            kl(d, m, metric_name::KL_AREA, "re")
        }),
    ]
}

/// The document's section, or `None` where the runs lack the similarity specs.
/// `folders` gives a spec's run folders (every repeat).
///
/// # Errors
/// If a folder lacks a row (the file and the query are named): a run of a spec without
/// `synthesis.held_out`, for instance.
pub fn block<'a>(
    tables: &mut Tables,
    folders: &dyn Fn(&str) -> Vec<&'a Path>,
) -> Result<Option<String>> {
    if SPECS.iter().any(|(spec, _, _)| folders(spec).is_empty()) {
        return Ok(None);
    }
    let mut s = String::new();
    let _ = writeln!(s, "## Held-out similarity\n");
    let _ = writeln!(
        s,
        "The dissertation's similarity tables compare each method's samples with the originals \
         it was fitted on. Here each method is also fitted on a seeded half of the originals and \
         its samples (as many as in sample) compared with the other half, which no fit saw \
         (`synthesis.held_out: true` in the specs); the `noise_floor` row is the floor of each \
         reading (in sample: the spec's floor, an independent draw for the simulated data or the \
         two halves of the plants' samples; held out: the fit half against the held-out half). \
         Mean ± sd over the repeats.\n"
    );
    for (spec, datasets, beside) in SPECS {
        let dirs = folders(spec);
        let _ = writeln!(s, "### `experiments/{spec}.yaml` (beside {beside})\n");
        let heads: Vec<String> = measures()
            .iter()
            .flat_map(|(name, _)| [format!("{name}, in sample"), format!("{name}, held out")])
            .collect();
        let _ = writeln!(s, "| dataset | method | {} |", heads.join(" | "));
        let _ = writeln!(s, "|---|---|{}", "---:|".repeat(heads.len()));
        for &ds in datasets {
            for m in METHODS {
                let mut cells = Vec::new();
                for (_, query) in measures() {
                    let q = query(ds, m);
                    cells.push(tables.summary_over(&dirs, &q)?.show());
                    cells.push(tables.summary_over(&dirs, &held_out(&q))?.show());
                }
                let _ = writeln!(s, "| {ds} | {m} | {} |", cells.join(" | "));
            }
        }
        let _ = writeln!(s);
    }
    Ok(Some(s))
}
