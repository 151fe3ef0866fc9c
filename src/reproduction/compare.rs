//! A dissertation cell against the tool's repeats of it: the mean and spread of the repeats,
//! the difference, and the verdict (`matches`, `ordering holds`, `differs`), with the rules
//! written once here so that the document and the tests judge alike.
//!
//! - A **random** statistic (the tool's value changes with the seed) matches when the
//!   dissertation's value lies within two standard deviations of the tool's mean, the standard
//!   deviation being that of one repeat (the dissertation's value is itself one draw), widened
//!   by the uncertainty of the mean (`sd * sqrt(1 + 1/n)`), plus half a unit in the last place
//!   the dissertation printed.
//! - An **exact** statistic (the same for every seed: filter coefficients, exact expected
//!   values) matches when it rounds to the printed value: within half a unit in the last place.
//! - A cell that does not match gets `ordering holds` when its row keeps the dissertation's
//!   order (every pair of cells in the row compares the same way in both, ties in the
//!   dissertation's printed values excepted), else `differs`.
//! - A **conclusion** ("Verified", "Not Verified") is 1 or 0; the tool's is the share of its
//!   repeats that reach "verified", and it matches when that share is on the printed side of
//!   one half.

/// How the tool's value of a cell behaves under reseeding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spread {
    /// The same for every seed: compared to printed precision.
    Exact,
    /// Changes with the seed: compared within the repeats' spread.
    Random,
    /// A conclusion (a hypothesis verified or not): 1 or 0 per repeat; it matches when most
    /// repeats reach the printed conclusion.
    Conclusion,
}

/// The verdict on one cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Verdict {
    /// Within the statistic's sampling spread (or printed precision).
    Matches,
    /// Outside it, but the row ranks its cells as the dissertation does.
    OrderingHolds,
    /// Outside it, and the order differs too.
    Differs,
}

impl Verdict {
    /// The word the document prints.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Matches => "matches",
            Verdict::OrderingHolds => "ordering holds",
            Verdict::Differs => "differs",
        }
    }
}

/// The tool's repeats of one cell, summarised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Mean over the repeats.
    pub mean: f64,
    /// Standard deviation of one repeat (`1/(n-1)`; 0 for one repeat).
    pub sd: f64,
    /// Number of repeats.
    pub n: usize,
}

impl Summary {
    /// The mean and spread of `values` (non-empty; NaN where any value is).
    pub fn of(values: &[f64]) -> Summary {
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n as f64;
        let sd = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        Summary { mean, sd, n }
    }
}

/// A number as the document prints it: 4 significant digits, scientific below 1e-3.
pub fn num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        format!("{v:.3e}")
    } else {
        let digits = (3 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    }
}

/// Half a unit in the last decimal place of `printed` as the dissertation wrote it (`decimals`
/// digits after the point).
pub fn half_unit(decimals: u32) -> f64 {
    0.5 * 10f64.powi(-(decimals as i32))
}

/// The digits after the decimal point of `text` (`"0.6480"` -> 4, `"12"` -> 0, `"1e-3"` -> 3).
pub fn decimals_of(text: &str) -> u32 {
    let t = text.trim().trim_start_matches(['-', '+']);
    if let Some((mantissa, exp)) = t.split_once(['e', 'E']) {
        let m = decimals_of(mantissa) as i64;
        let e: i64 = exp.parse().unwrap_or(0);
        return (m - e).max(0) as u32;
    }
    t.split_once('.').map_or(0, |(_, f)| f.len() as u32)
}

/// The tolerance of a cell: what its difference from the dissertation may be and still match.
pub fn tolerance(spread: Spread, summary: &Summary, decimals: u32) -> f64 {
    let print = half_unit(decimals);
    match spread {
        Spread::Exact => print,
        Spread::Conclusion => 0.5 - f64::EPSILON,
        Spread::Random => 2.0 * summary.sd * (1.0 + 1.0 / summary.n.max(1) as f64).sqrt() + print,
    }
}

/// Whether `tool` lies within `tolerance` of `reference`.
pub fn matches(reference: f64, tool: f64, tolerance: f64) -> bool {
    (tool - reference).abs() <= tolerance
}

/// `Matches` when `tool` lies within `tolerance` of `reference`, else `Differs` (a row's
/// order may turn it into `OrderingHolds` later).
pub fn verdict(reference: f64, tool: f64, tolerance: f64) -> Verdict {
    if matches(reference, tool, tolerance) {
        Verdict::Matches
    } else {
        Verdict::Differs
    }
}

/// Whether the tool's row ranks its cells as the dissertation's does: every pair that the
/// dissertation orders strictly is ordered the same way by the tool (pairs the dissertation
/// prints equal, or where either side is missing, are not judged), and at least one pair is
/// judged (a row of one printed cell has no order to keep).
pub fn order_kept(reference: &[Option<f64>], tool: &[Option<f64>]) -> bool {
    let n = reference.len().min(tool.len());
    let mut compared = false;
    for i in 0..n {
        for j in i + 1..n {
            let (Some(ri), Some(rj), Some(ti), Some(tj)) =
                (reference[i], reference[j], tool[i], tool[j])
            else {
                continue;
            };
            if ri == rj {
                continue;
            }
            if (ri < rj) != (ti < tj) || ti == tj {
                return false;
            }
            compared = true;
        }
    }
    compared
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_as_printed() {
        assert_eq!(decimals_of("0.6480"), 4);
        assert_eq!(decimals_of("-12.5"), 1);
        assert_eq!(decimals_of("12"), 0);
        assert_eq!(decimals_of("1.5e-3"), 4);
        assert_eq!(decimals_of("2e3"), 0);
    }

    #[test]
    fn summary_is_the_sample_mean_and_sd() {
        let s = Summary::of(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(s.mean, 2.5);
        assert!((s.sd - (5.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert_eq!(Summary::of(&[7.0]).sd, 0.0);
    }

    #[test]
    fn exact_cells_match_to_printed_precision() {
        let s = Summary::of(&[0.648_054]);
        let tol = tolerance(Spread::Exact, &s, 4);
        assert!(matches(0.6481, s.mean, tol));
        assert!(!matches(0.6483, s.mean, tol));
    }

    #[test]
    fn random_cells_match_within_two_sd_of_one_draw() {
        // sd 0.1 over 4 repeats: tolerance 2 * 0.1 * sqrt(1.25) + 0.005 = 0.2286.
        let s = Summary {
            mean: 1.0,
            sd: 0.1,
            n: 4,
        };
        let tol = tolerance(Spread::Random, &s, 2);
        assert!((tol - (0.2 * 1.25f64.sqrt() + 0.005)).abs() < 1e-12);
        assert!(matches(1.22, s.mean, tol));
        assert!(!matches(1.24, s.mean, tol));
    }

    #[test]
    fn order_is_judged_on_strict_pairs_only() {
        let r = [Some(1.0), Some(2.0), Some(2.0), None];
        assert!(order_kept(
            &r,
            &[Some(10.0), Some(30.0), Some(20.0), Some(0.0)]
        ));
        assert!(!order_kept(&r, &[Some(30.0), Some(20.0), Some(25.0), None]));
        // A tie where the dissertation orders strictly is not the same order.
        assert!(!order_kept(&r, &[Some(5.0), Some(5.0), Some(6.0), None]));
        assert!(!order_kept(&[Some(83.3), None], &[Some(99.0), None]));
    }
}
