//! The KL divergence's sampling floor beside each KL table of the document: the same estimator
//! between two independent stacks of the same data (the runs' `noise_floor` rows: an
//! independent draw of the true filter for the simulated data, the two halves of the 100
//! samples for the plants), with its constant `c = KL / (1/N + 1/M)`. Every value the
//! dissertation prints follows `c` of about 0.7-0.95 (docs/definitions.md section 6): a table
//! whose values sit at its floor says only that the generated data are not told apart from
//! the originals at that sample size.

use super::compare::{num, Summary};
use super::extract::{kl, Tables};
use crate::io::results::{col, value};
use crate::stats::metrics::name as metric_name;
use anyhow::Result;
use std::collections::BTreeMap;
use std::path::Path;

/// The KL tables by pixel and 8 x 8 area and the datasets of their rows.
const KL_TABLES: [(u32, &[&str]); 6] = [
    (8, &SIMULATED),
    (9, &SIMULATED),
    (10, &SIMULATED),
    (13, &PLANTS),
    (14, &PLANTS),
    (15, &PLANTS),
];
const SIMULATED: [&str; 2] = ["exponential", "nonexponential"];
const PLANTS: [&str; 4] = [
    "plant_D_light",
    "plant_D_medium",
    "plant_E_light",
    "plant_E_medium",
];

/// Per KL table, the sentence giving its floor; `folders(spec)` lists a spec's repeats.
///
/// # Errors
/// If a run folder lacks its noise floor rows (the file and the rows are named).
pub fn kl_floors<'a>(
    tables: &mut Tables,
    folders: &dyn Fn(&str) -> Vec<&'a Path>,
) -> Result<BTreeMap<u32, String>> {
    let mut out = BTreeMap::new();
    for (number, datasets) in KL_TABLES {
        let mut parts = Vec::new();
        for &ds in datasets {
            let mut cells = Vec::new();
            for (metric, what) in [
                (metric_name::KL_PIXEL, "per pixel"),
                (metric_name::KL_AREA, "per 8x8 area"),
            ] {
                let query = kl(ds, value::NOISE_FLOOR, metric, "re");
                let (mut values, mut c) = (Vec::new(), Vec::new());
                for dir in folders(query.spec) {
                    let v = tables.value(dir, &query)?;
                    let n = tables.value(
                        dir,
                        &super::extract::Query {
                            column: col::SAMPLES_ORIGINAL,
                            ..query.clone()
                        },
                    )?;
                    let m = tables.value(
                        dir,
                        &super::extract::Query {
                            column: col::SAMPLES_COMPARED,
                            ..query.clone()
                        },
                    )?;
                    let values_per_unit = if metric == metric_name::KL_AREA {
                        64.0
                    } else {
                        1.0
                    };
                    values.push(v);
                    c.push(v / (1.0 / (n * values_per_unit) + 1.0 / (m * values_per_unit)));
                }
                if values.is_empty() {
                    continue;
                }
                let (v, c) = (Summary::of(&values), Summary::of(&c));
                cells.push(format!("{what} {} (c = {})", v.show(), num(c.mean)));
            }
            if !cells.is_empty() {
                parts.push(format!("{ds}: {}", cells.join(", ")));
            }
        }
        if !parts.is_empty() {
            out.insert(
                number,
                format!(
                    "Floor of the tool's estimator (the same KL between two independent stacks \
                     of the same data, real part; c = KL / (1/N + 1/M), the printed values' c \
                     being 0.7-0.95): {}",
                    parts.join("; ")
                ),
            );
        }
    }
    Ok(out)
}
