//! Do the similarity measures predict the deep-learning result? (dissertation 5.3.4.2: the
//! classification experiments evaluate the generation methods so "that the similarity measures
//! are a good indicator of deep learning network performance"). For each generation method,
//! its similarity to the originals of the four CNN classes (plants D and E, light and medium
//! wind: the rows of Tables 11-15, from `experiments/similarity_plants.yaml`) beside its CNN
//! test accuracy (Tables 20 and 22, each protocol, mean over training sizes and repeats), and
//! per measure the Spearman rank correlation between closeness (the measure's negative: a
//! smaller distance is closer) and accuracy over the methods: 1 when the measure ranks the
//! methods as the networks do.

use super::extract::{self, Query, Tables};
use crate::stats::metrics::name as metric_name;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// The generation methods both the similarity and the CNN tables have.
const METHODS: [&str; 3] = ["method1", "method2", "full_covariance"];
/// The CNN classes, as similarity datasets.
const CLASSES: [&str; 4] = [
    "plant_D_light",
    "plant_D_medium",
    "plant_E_light",
    "plant_E_medium",
];

/// A similarity measure: its name and its query for a class and a method.
type Measure = (&'static str, fn(&'static str, &'static str) -> Query);

fn measures() -> [Measure; 4] {
    [
        ("average RMSE, levels 1-3 (Table 11)", |d, m| {
            extract::rmse_average(d, m, "average_levels_1_3")
        }),
        ("correlation matrix distance (Tables 12, 29-35)", |d, m| {
            extract::cmd(d, m)
        }),
        ("KL by pixel, real part (Tables 13-15)", |d, m| {
            extract::kl(d, m, metric_name::KL_PIXEL, "re")
        }),
        ("KL by 8x8 area, real part (Tables 13-15)", |d, m| {
            extract::kl(d, m, metric_name::KL_AREA, "re")
        }),
    ]
}

/// Spearman's rank correlation of `a` and `b` (no ties expected; ties take their first rank).
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let rank = |v: &[f64]| -> Vec<f64> {
        let mut order: Vec<usize> = (0..v.len()).collect();
        order.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
        let mut r = vec![0.0; v.len()];
        for (k, &i) in order.iter().enumerate() {
            r[i] = k as f64;
        }
        r
    };
    let (ra, rb) = (rank(a), rank(b));
    let n = a.len() as f64;
    let d2: f64 = ra.iter().zip(&rb).map(|(x, y)| (x - y) * (x - y)).sum();
    1.0 - 6.0 * d2 / (n * (n * n - 1.0))
}

/// The CNN tables' readings: table, normalisation, spec, protocol.
const READINGS: [(u32, &str, &str, &str); 4] = [
    (
        20,
        "zero_mean",
        super::cnn::DISSERTATION,
        "dissertation's protocol",
    ),
    (20, "zero_mean", super::cnn::HELD_OUT, "held-out"),
    (
        22,
        "zero_mean_unit_variance",
        super::cnn::DISSERTATION,
        "dissertation's protocol",
    ),
    (
        22,
        "zero_mean_unit_variance",
        super::cnn::HELD_OUT,
        "held-out",
    ),
];

/// Measure x method: each measure's mean over the classes and the repeats in `dirs`.
fn distances(tables: &mut Tables, dirs: &[&Path]) -> Result<Vec<Vec<f64>>> {
    let mut distance = Vec::new();
    for (_, query) in measures() {
        let mut row = Vec::new();
        for m in METHODS {
            let mut sum = 0.0;
            for c in CLASSES {
                sum += tables.summary_over(dirs, &query(c, m))?.mean;
            }
            row.push(sum / CLASSES.len() as f64);
        }
        distance.push(row);
    }
    Ok(distance)
}

/// Reading x method: the mean test accuracy (%) over the sizes and the repeats.
fn accuracies<'a>(
    tables: &mut Tables,
    folders: &dyn Fn(&str) -> Vec<&'a Path>,
) -> Result<Vec<Vec<f64>>> {
    let mut accuracy = Vec::new();
    for &(_, normalise, spec, _) in &READINGS {
        let dirs = folders(spec);
        let mut row = Vec::new();
        for m in METHODS {
            let q = super::cnn::accuracy(spec, normalise, m, None);
            row.push(tables.summary_over(&dirs, &q)?.mean);
        }
        accuracy.push(row);
    }
    Ok(accuracy)
}

/// The document's block, or `None` where the runs lack the similarity or the CNN specs.
/// `folders` gives a spec's run folders (every repeat).
///
/// # Errors
/// If a table cannot be read or a query selects no row.
pub fn block<'a>(
    tables: &mut Tables,
    folders: &dyn Fn(&str) -> Vec<&'a Path>,
) -> Result<Option<String>> {
    let similarity = folders("similarity_plants");
    if similarity.is_empty() || READINGS.iter().any(|r| folders(r.2).is_empty()) {
        return Ok(None);
    }
    let distance = distances(tables, &similarity)?;
    let accuracy = accuracies(tables, folders)?;
    let mut s = String::new();
    let _ = writeln!(s, "## Similarity measures against CNN accuracy (5.3.4.2)\n");
    let _ = writeln!(
        s,
        "Each generation method's similarity to the originals of the four CNN classes (the \
         stand-in plants D and E, light and medium wind; `experiments/similarity_plants.yaml`, \
         mean over the classes and repeats: smaller is closer) beside its CNN test accuracy (%, \
         mean over the training sizes 100-1000 and the repeats). The last rows: Spearman's rank \
         correlation between each measure's closeness and each accuracy over the {} methods \
         (1: the measure ranks the methods as the networks do; -1: the reverse).\n",
        METHODS.len()
    );
    let _ = writeln!(s, "| | {} |", METHODS.join(" | "));
    let _ = writeln!(s, "|---|{}", "---:|".repeat(METHODS.len()));
    for ((name, _), row) in measures().iter().zip(&distance) {
        let cells: Vec<String> = row.iter().map(|v| format!("{v:.4}")).collect();
        let _ = writeln!(s, "| {name} | {} |", cells.join(" | "));
    }
    for ((table, _, _, protocol), row) in READINGS.iter().zip(&accuracy) {
        let cells: Vec<String> = row.iter().map(|v| format!("{v:.1}")).collect();
        let _ = writeln!(
            s,
            "| accuracy, Table {table} ({protocol}) | {} |",
            cells.join(" | ")
        );
    }
    let _ = writeln!(s);
    let heads: Vec<String> = READINGS
        .iter()
        .map(|(t, _, _, p)| format!("Table {t} ({p})"))
        .collect();
    let _ = writeln!(s, "| rank correlation | {} |", heads.join(" | "));
    let _ = writeln!(s, "|---|{}", "---:|".repeat(READINGS.len()));
    for ((name, _), d) in measures().iter().zip(&distance) {
        let closeness: Vec<f64> = d.iter().map(|v| -v).collect();
        let rho: Vec<String> = accuracy
            .iter()
            .map(|a| format!("{:.1}", spearman(&closeness, a)))
            .collect();
        let _ = writeln!(s, "| {name} | {} |", rho.join(" | "));
    }
    let _ = writeln!(s);
    Ok(Some(s))
}

#[cfg(test)]
mod tests {
    use super::spearman;

    /// Spearman's rho against its definition on three values: the same order 1, the reverse
    /// -1, one swap of neighbours 0.5.
    #[test]
    fn spearman_of_three() {
        assert_eq!(spearman(&[1.0, 2.0, 3.0], &[10.0, 20.0, 30.0]), 1.0);
        assert_eq!(spearman(&[1.0, 2.0, 3.0], &[30.0, 20.0, 10.0]), -1.0);
        assert_eq!(spearman(&[1.0, 2.0, 3.0], &[20.0, 10.0, 30.0]), 0.5);
    }
}
