//! A dissertation cell against the tool's repeats of it: the mean and spread of the repeats,
//! the difference, and the verdict (`matches`, `differs`), with the rules
//! written once here so that the document and the tests judge alike.
//!
//! - A **random** statistic (the tool's value changes with the seed) matches when the
//!   dissertation's value lies within two standard deviations of the tool's mean, the standard
//!   deviation being that of one repeat (the dissertation's value is itself one draw), widened
//!   by the uncertainty of the mean (`sd * sqrt(1 + 1/n)`), plus half a unit in the last place
//!   the dissertation printed.
//! - An **exact** statistic (the same for every seed: filter coefficients, exact expected
//!   values) matches when it rounds to the printed value: within half a unit in the last place.
//! - A cell that does not match `differs`. Orderings are not judged cell by cell (a row of two
//!   noisy cells keeps or flips its order by chance): the text's own comparisons are, across
//!   methods and with a tie margin, in [`super::claims`]. `ordering holds` is left to the
//!   statements of figures that order without a number.
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

/// What an agreement in a table can show: the summary counts independent agreements apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Evidence {
    /// Cells that the data and the code fix (`Spread::Exact`: analytic values, exactly
    /// specified constructions): an agreement checks the code, not the science.
    Construction,
    /// Cells the stand-in plants were fitted to ([`calibrated_tables`]): agreement by design.
    Calibrated,
    /// A conclusion ("Verified", "Not Verified").
    Verdict,
    /// CNN accuracies (Tables 20, 22): a few trainings a cell, tolerances of 10-20 points.
    Cnn,
    /// An independent numerical agreement.
    Independent,
}

impl Evidence {
    /// The words the document prints.
    pub fn as_str(self) -> &'static str {
        match self {
            Evidence::Construction => "constructions and analytic values",
            Evidence::Calibrated => "calibration targets of the stand-in plants",
            Evidence::Verdict => "hypothesis verdicts",
            Evidence::Cnn => "CNN accuracies (wide spread)",
            Evidence::Independent => "independent numerical comparisons",
        }
    }
}

/// The tables the plants D-E fit of the compiled-in record took as targets (Tables 29-36, the
/// repeats 11-12, and with `calibrate-plants --kl` the KL Tables 13-15).
pub fn similarity_fit_tables() -> std::collections::BTreeSet<u32> {
    let r = crate::physics::vegetation::calibration::record();
    r.similarity
        .iter()
        .flat_map(|f| f.tables.iter().map(|t| t.table))
        .collect()
}

/// The tables the stand-in plants were fitted to (docs/definitions.md section 10), read from
/// the compiled-in record: Table 16 (plants A-C) and [`similarity_fit_tables`], so a record
/// fitted to more tables moves their cells out of the independent count.
pub fn calibrated_tables() -> Vec<u32> {
    let mut t = similarity_fit_tables();
    t.insert(16);
    t.into_iter().collect()
}

/// Tables whose cells repeat other tables' cells, with those tables: counted once, where the
/// source is.
pub const REPEATS: [(u32, &str); 2] = [
    (7, "Tables 25 and 27 (their Method 1 and Method 2 cells)"),
    (
        12,
        "Tables 29, 31, 33 and 35 (their Method 1 and Method 2 cells)",
    ),
];

/// For a table the plants D-E fit took as a target (per the compiled-in record), the sentence
/// the document prints beside it; `None` for the others.
pub fn fitted_note(number: u32) -> Option<String> {
    let tables = similarity_fit_tables();
    tables.contains(&number).then(|| {
        let all: Vec<String> = tables.iter().map(u32::to_string).collect();
        format!(
            "Table {number} is among the tables the stand-in plants D and E are fitted to \
             (`{}`: Tables {}), so its cells count as calibration targets, not as independent \
             agreements",
            crate::physics::vegetation::calibration::record().command,
            all.join(", ")
        )
    })
}

/// What agreement in Table `number`, read with `spread`, shows.
pub fn evidence(number: u32, spread: Spread) -> Evidence {
    match spread {
        Spread::Exact => Evidence::Construction,
        Spread::Conclusion => Evidence::Verdict,
        Spread::Random if calibrated_tables().contains(&number) => Evidence::Calibrated,
        Spread::Random if number == 20 || number == 22 => Evidence::Cnn,
        Spread::Random => Evidence::Independent,
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
    /// The document's form: `mean ± sd` over several repeats, the mean alone for one.
    pub fn show(self) -> String {
        if self.n > 1 {
            format!("{} ± {}", num(self.mean), num(self.sd))
        } else {
            short_num(self.mean)
        }
    }

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

/// A number that may be a value as printed: its shortest exact form where that has at most six
/// significant digits (`1.6979`, `0.0044`, `3.53e-6`: a printed value shown as printed), else
/// [`num`]'s four (a computed value).
pub fn short_num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let s = if (1e-3..1e5).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    };
    let mantissa = s.split('e').next().unwrap_or("");
    let digits = mantissa
        .chars()
        .filter(char::is_ascii_digit)
        .collect::<String>();
    if digits.trim_start_matches('0').len() <= 6 {
        s
    } else {
        num(v)
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

/// A printed value as the dissertation printed it: with its column's `decimals` digits after
/// the point (a trailing zero the file lost comes back, nothing is rounded away), in
/// E-notation with as many digits below `1e-3`.
pub fn printed_num(v: f64, decimals: u32) -> String {
    let a = v.abs();
    if v != 0.0 && a < 1e-3 && a.is_finite() {
        let exponent = a.log10().floor() as i32;
        let mantissa = (decimals as i32 + exponent).max(0) as usize;
        format!("{v:.mantissa$E}")
    } else {
        let d = decimals as usize;
        format!("{v:.d$}")
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

/// `Matches` when `tool` lies within `tolerance` of `reference`, else `Differs`.
pub fn verdict(reference: f64, tool: f64, tolerance: f64) -> Verdict {
    if matches(reference, tool, tolerance) {
        Verdict::Matches
    } else {
        Verdict::Differs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tables a record names as fitted are calibration targets, the rest independent: the
    /// committed record's own tables (and Table 16) move out of the independent count, Table 1
    /// and Tables 6-10 (simulated data, no fit) stay in it.
    #[test]
    fn the_record_decides_which_tables_are_calibration_targets() {
        let r = crate::physics::vegetation::calibration::record();
        let fitted: Vec<u32> = r
            .similarity
            .iter()
            .flat_map(|f| f.tables.iter().map(|t| t.table))
            .collect();
        assert!(!fitted.is_empty());
        for t in fitted.iter().copied().chain([16]) {
            assert_eq!(
                evidence(t, Spread::Random),
                Evidence::Calibrated,
                "Table {t}"
            );
        }
        for t in [1, 2, 6, 8, 9, 10, 25, 26] {
            assert_eq!(
                evidence(t, Spread::Random),
                Evidence::Independent,
                "Table {t}"
            );
            assert!(fitted_note(t).is_none(), "Table {t}");
        }
        let note = fitted_note(fitted[0]).expect("a fitted table has a note");
        assert!(note.contains(&r.command), "{note}");
        assert_eq!(evidence(20, Spread::Random), Evidence::Cnn);
    }

    /// Table 16's printed 1.6979 and 0.0044 and Table 8's 3.53E-6 stay as printed; a computed
    /// mean gets four digits.
    #[test]
    fn printed_values_are_shown_as_printed() {
        assert_eq!(short_num(1.6979), "1.6979");
        assert_eq!(short_num(1.1305), "1.1305");
        assert_eq!(short_num(0.0044), "0.0044");
        assert_eq!(short_num(-21.53), "-21.53");
        assert_eq!(short_num(3.53e-6), "3.53e-6");
        assert_eq!(short_num((0.3215 + 1.1305 + 1.6979) / 3.0), "1.050");
        assert_eq!(short_num(1.592_345_678), "1.592");
    }

    #[test]
    fn decimals_as_printed() {
        assert_eq!(decimals_of("0.6480"), 4);
        assert_eq!(decimals_of("-12.5"), 1);
        assert_eq!(decimals_of("12"), 0);
        assert_eq!(decimals_of("1.5e-3"), 4);
        assert_eq!(decimals_of("2e3"), 0);
    }

    #[test]
    fn printed_values_keep_their_printed_digits() {
        // Table 16 prints 1.6979 and 1.1305 in a column of four decimals; Table 8 prints
        // 3.53E-06; Table 1 prints -21.90 (the file reads -21.9).
        assert_eq!(printed_num(1.6979, 4), "1.6979");
        assert_eq!(printed_num(1.1305, 4), "1.1305");
        assert_eq!(printed_num(3.53e-6, decimals_of("3.53E-06")), "3.53E-6");
        assert_eq!(printed_num(-21.9, 2), "-21.90");
        assert_eq!(printed_num(0.0145, decimals_of("1.45E-02")), "0.0145");
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
}
