//! The dissertation's own claims judged: every comparative or conclusive sentence of chapters
//! 3-6 that its tables support (`reproduction/claims.yaml`, transcribed with its quote and a
//! reading into checks on table cells) is tried on the tool's numbers, with their spread, and
//! on the printed numbers. A claim `holds` when every check holds beyond the tie margin that
//! the repeats' spread gives, `fails` when one fails beyond it, and is `not decidable` (with
//! the reason) when a difference lies within the margin, when a cell it needs is not computed
//! by the reproduction (the table and the specs that would compute it are named), or when the
//! text gives no numbers to judge it on.
//!
//! A group of cells is read as the mean of their means; its spread is the mean of their
//! standard deviations (the bound for cells that move together, as cells of one run do). Two
//! groups differ beyond the tie margin when their difference exceeds
//! `2 sqrt(sd_a^2 / n_a + sd_b^2 / n_b)` (two standard errors of the difference of the
//! means). The printed numbers are one draw with no spread: they are judged with a zero margin.

use super::compare::{num, Summary};
use super::evaluated::{Evaluated, Stated};
use super::reference::Dissertation;
use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::fmt::Write as _;

/// The file's text, as committed.
pub const TEXT: &str = include_str!("../../reproduction/claims.yaml");

/// One cell of a printed table, by its labels.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CellRef {
    /// The table's number.
    pub table: u32,
    /// The row label as `reproduction/dissertation.yaml` spells it.
    pub row: String,
    /// The column label as `reproduction/dissertation.yaml` spells it.
    pub column: String,
}

/// One check of a claim; all of a claim's checks must hold.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Check {
    /// `factor * mean(lower) < mean(higher)`.
    Less {
        /// The cells that should be lower.
        lower: Vec<CellRef>,
        /// The cells that should be higher.
        higher: Vec<CellRef>,
        /// How many times lower (1 when absent; 10 for "an order of magnitude").
        #[serde(default)]
        factor: Option<f64>,
    },
    /// `|mean(a) - mean(b)|` at most `margin` (absolute) or `relative * max(|a|, |b|)`.
    Within {
        /// One side.
        a: Vec<CellRef>,
        /// The other side.
        b: Vec<CellRef>,
        /// The largest difference the claim allows, in the table's unit.
        #[serde(default)]
        margin: Option<f64>,
        /// The largest difference as a share of the larger magnitude.
        #[serde(default)]
        relative: Option<f64>,
    },
    /// The cells, in the order given, increase.
    Rises {
        /// The cells in increasing order.
        cells: Vec<CellRef>,
    },
    /// Conclusion cells ("Verified", "Not Verified"): the tool reaches the printed conclusion
    /// in most of its repeats.
    Verdict {
        /// The conclusion cells.
        cells: Vec<CellRef>,
    },
    /// A number the reproduction computes for a statement of the text (`figures:` of
    /// `dissertation.yaml`): the `nth` (from 0) computed statement whose quantity starts with
    /// `quantity`. With a stated number: the tool's within `margin` of it. Without one (an
    /// ordering, computed as a difference that the text says is positive): the tool's
    /// difference above zero.
    Stated {
        /// The start of the statement's quantity.
        quantity: String,
        /// Which of the statements with that quantity (several readings of one sentence).
        #[serde(default)]
        nth: usize,
        /// The largest difference from the stated number the claim's words allow.
        #[serde(default)]
        margin: Option<f64>,
    },
}

/// One claim of the text.
#[derive(Debug, Clone, Deserialize)]
pub struct Claim {
    /// A unique short name.
    pub id: String,
    /// The section it sits in.
    pub section: String,
    /// The sentence, as printed.
    pub quote: String,
    /// How it is read, in plain words.
    pub reading: String,
    /// The tables it rests on.
    #[serde(default)]
    pub tables: Vec<u32>,
    /// The figures it rests on.
    #[serde(default)]
    pub figures: Vec<u32>,
    /// The checks (empty when [`Claim::undecidable`] says why it cannot be judged).
    #[serde(default)]
    pub checks: Vec<Check>,
    /// Why the tables cannot decide it.
    #[serde(default)]
    pub undecidable: Option<String>,
    /// The transcriber's reading on the printed numbers (checked against [`judge`]'s).
    #[serde(default)]
    pub printed: Option<String>,
}

/// The whole file.
#[derive(Debug, Clone, Deserialize)]
pub struct Claims {
    /// Every claim, in the text's order.
    pub claims: Vec<Claim>,
}

/// A verdict on a claim or a check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Outcome {
    /// Every check holds beyond the tie margin.
    Holds,
    /// A check fails beyond the tie margin.
    Fails,
    /// A difference within the margin, a missing cell, or no numbers in the text.
    NotDecidable,
}

impl Outcome {
    /// The word the document prints.
    pub fn as_str(self) -> &'static str {
        match self {
            Outcome::Holds => "holds",
            Outcome::Fails => "fails",
            Outcome::NotDecidable => "not decidable",
        }
    }
}

/// A claim judged on both sides.
#[derive(Debug, Clone)]
pub struct Judged {
    /// On the tool's numbers, with what was compared (or why not).
    pub tool: (Outcome, String),
    /// On the printed numbers (`None` for a claim without checks).
    pub printed: Option<(Outcome, String)>,
}

impl Claims {
    /// The committed claims, checked against the reference: ids unique, every claim with
    /// checks or a reason, every cell label found in its table.
    ///
    /// # Errors
    /// Naming the claim and the label that does not resolve.
    pub fn load(d: &Dissertation) -> Result<Claims> {
        let c: Claims =
            serde_yaml_ng::from_str(TEXT).context("reading reproduction/claims.yaml")?;
        let mut ids = std::collections::BTreeSet::new();
        for claim in &c.claims {
            let at = format!("reproduction/claims.yaml, claim `{}`", claim.id);
            if !ids.insert(claim.id.as_str()) {
                bail!("{at}: the id is used twice");
            }
            if claim.checks.is_empty() == claim.undecidable.is_none() {
                bail!("{at}: give either `checks` or `undecidable`");
            }
            for check in &claim.checks {
                if let Check::Stated { quantity, .. } = check {
                    if !d
                        .figures
                        .iter()
                        .any(|f| f.quantity.starts_with(quantity.as_str()))
                    {
                        bail!("{at}: no statement of `figures:` starts with {quantity:?}");
                    }
                }
                if let Check::Within {
                    margin: None,
                    relative: None,
                    ..
                } = check
                {
                    bail!("{at}: a `within` check needs `margin` or `relative`");
                }
                for cell in check.cells() {
                    locate(d, cell).with_context(|| at.clone())?;
                }
            }
        }
        Ok(c)
    }
}

impl Check {
    /// Every cell the check reads.
    pub fn cells(&self) -> Vec<&CellRef> {
        match self {
            Check::Less { lower, higher, .. } => lower.iter().chain(higher).collect(),
            Check::Within { a, b, .. } => a.iter().chain(b).collect(),
            Check::Rises { cells } | Check::Verdict { cells } => cells.iter().collect(),
            Check::Stated { .. } => Vec::new(),
        }
    }
}

/// The (row, column) of `cell` in its printed table.
///
/// # Errors
/// If the table, the row or the column label is not in the reference.
pub fn locate(d: &Dissertation, cell: &CellRef) -> Result<(usize, usize)> {
    let t = d
        .table(cell.table)
        .with_context(|| format!("Table {} is not in the reference", cell.table))?;
    let r = t
        .rows
        .iter()
        .position(|x| *x == cell.row)
        .with_context(|| format!("Table {} has no row {:?}", cell.table, cell.row))?;
    let c = t
        .columns
        .iter()
        .position(|x| *x == cell.column)
        .with_context(|| format!("Table {} has no column {:?}", cell.table, cell.column))?;
    Ok((r, c))
}

/// A group of cells read as one value: the mean of their means, the mean of their standard
/// deviations, the fewest repeats.
fn pooled(values: &[Summary]) -> Summary {
    let k = values.len().max(1) as f64;
    Summary {
        mean: values.iter().map(|s| s.mean).sum::<f64>() / k,
        sd: values.iter().map(|s| s.sd).sum::<f64>() / k,
        n: values.iter().map(|s| s.n).min().unwrap_or(1).max(1),
    }
}

/// `s` times `f`.
fn scaled(s: Summary, f: f64) -> Summary {
    Summary {
        mean: s.mean * f,
        sd: s.sd * f.abs(),
        n: s.n,
    }
}

/// Two standard errors of the difference of two groups' means.
fn tie(a: Summary, b: Summary) -> f64 {
    2.0 * (a.sd.powi(2) / a.n.max(1) as f64 + b.sd.powi(2) / b.n.max(1) as f64).sqrt()
}

/// A difference `diff` with tie margin `tie` against the `allowed` one: within it beyond the
/// margin, outside it beyond the margin, or a tie.
fn within(diff: f64, tie: f64, allowed: f64) -> Outcome {
    if diff + tie <= allowed {
        Outcome::Holds
    } else if diff - tie > allowed {
        Outcome::Fails
    } else {
        Outcome::NotDecidable
    }
}

/// Where a side's numbers come from.
pub enum Side<'a> {
    /// The tool's repeats.
    Tool(&'a [Evaluated], &'a [Stated]),
    /// The printed tables.
    Printed,
}

/// The value of one cell on `side`, or why there is none.
fn value(d: &Dissertation, side: &Side, cell: &CellRef) -> std::result::Result<Summary, String> {
    let (r, c) = locate(d, cell).map_err(|e| format!("{e:#}"))?;
    let t = d.table(cell.table).expect("located");
    match side {
        Side::Printed => t
            .number_at(r, c)
            .or_else(|| t.conclusion_at(r, c))
            .map(|v| Summary::of(&[v]))
            .ok_or_else(|| {
                format!(
                    "Table {} prints no number at {:?} / {:?}",
                    t.number, cell.row, cell.column
                )
            }),
        Side::Tool(evaluated, _) => {
            let Some(e) = evaluated.iter().find(|e| e.number == cell.table) else {
                return Err(format!(
                    "Table {} is not reproduced (no recipe reads it from the run folders)",
                    cell.table
                ));
            };
            e.cells
                .get(r)
                .and_then(|row| row.get(c))
                .and_then(|x| x.tool)
                .ok_or_else(|| {
                    let specs: Vec<String> = e
                        .sources
                        .iter()
                        .map(|(s, _)| format!("experiments/{s}.yaml"))
                        .collect();
                    let missing = if e.missing.is_empty() {
                        String::new()
                    } else {
                        format!("; missing or incomplete: {}", e.missing.join("; "))
                    };
                    format!(
                        "Table {}'s cell {:?} / {:?} is not computed (read from {}{missing})",
                        cell.table,
                        cell.row,
                        cell.column,
                        specs.join(", ")
                    )
                })
        }
    }
}

/// The group of `cells` on `side`.
fn group(d: &Dissertation, side: &Side, cells: &[CellRef]) -> std::result::Result<Summary, String> {
    let values = cells
        .iter()
        .map(|c| value(d, side, c))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    if values.is_empty() {
        return Err("a check with no cells".into());
    }
    Ok(pooled(&values))
}

/// `lower` below `higher` beyond the margin: holds, fails, or a tie.
fn ordered(lower: Summary, higher: Summary) -> Outcome {
    let m = tie(lower, higher);
    if higher.mean - lower.mean > m {
        Outcome::Holds
    } else if lower.mean - higher.mean > m {
        Outcome::Fails
    } else if m == 0.0 {
        // Equal printed numbers: the claim's strict order does not hold.
        Outcome::Fails
    } else {
        Outcome::NotDecidable
    }
}

/// One check on `side`: its outcome and what was compared.
fn check(d: &Dissertation, side: &Side, ch: &Check) -> (Outcome, String) {
    let got = || -> std::result::Result<(Outcome, String), String> {
        Ok(match ch {
            Check::Less {
                lower,
                higher,
                factor,
            } => {
                let f = factor.unwrap_or(1.0);
                let (lo, hi) = (group(d, side, lower)?, group(d, side, higher)?);
                let scaled = scaled(lo, f);
                let label = if f == 1.0 {
                    format!("{} < {}", lo.show(), hi.show())
                } else {
                    format!("{f} x {} < {}", lo.show(), hi.show())
                };
                (ordered(scaled, hi), label)
            }
            Check::Within {
                a,
                b,
                margin,
                relative,
            } => {
                let (x, y) = (group(d, side, a)?, group(d, side, b)?);
                let allowed = match (margin, relative) {
                    (Some(m), _) => *m,
                    (None, Some(r)) => r * x.mean.abs().max(y.mean.abs()),
                    (None, None) => return Err("a `within` check without a margin".into()),
                };
                let diff = (x.mean - y.mean).abs();
                let outcome = within(diff, tie(x, y), allowed);
                (
                    outcome,
                    format!(
                        "|{} - {}| = {} against {}",
                        x.show(),
                        y.show(),
                        num(diff),
                        num(allowed)
                    ),
                )
            }
            Check::Rises { cells } => {
                let groups = cells
                    .iter()
                    .map(|c| group(d, side, std::slice::from_ref(c)))
                    .collect::<std::result::Result<Vec<_>, _>>()?;
                let steps: Vec<Outcome> = groups.windows(2).map(|w| ordered(w[0], w[1])).collect();
                let shown: Vec<String> = groups.iter().map(|g| g.show()).collect();
                (worst(&steps), shown.join(" -> "))
            }
            Check::Verdict { cells } => {
                let mut outs = Vec::new();
                let mut shown = Vec::new();
                for c in cells {
                    let printed = value(d, &Side::Printed, c)?.mean;
                    let share = value(d, side, c)?;
                    let reached = if printed > 0.5 {
                        share.mean
                    } else {
                        1.0 - share.mean
                    };
                    outs.push(if reached > 0.5 {
                        Outcome::Holds
                    } else if reached < 0.5 {
                        Outcome::Fails
                    } else {
                        Outcome::NotDecidable
                    });
                    let word = if printed > 0.5 {
                        "verified"
                    } else {
                        "not verified"
                    };
                    shown.push(format!(
                        "{word} in {} of {}",
                        (reached * share.n as f64).round(),
                        share.n
                    ));
                }
                (worst(&outs), shown.join("; "))
            }
            Check::Stated {
                quantity,
                nth,
                margin,
            } => stated_check(side, quantity, *nth, *margin)?,
        })
    };
    got().unwrap_or_else(|why| (Outcome::NotDecidable, why))
}

/// A [`Check::Stated`] on `side`: the printed side has only the text's own words (a stated
/// number agrees with itself; an ordering without a number has nothing to judge it on).
fn stated_check(
    side: &Side,
    quantity: &str,
    nth: usize,
    margin: Option<f64>,
) -> std::result::Result<(Outcome, String), String> {
    let Side::Tool(_, stated) = side else {
        return Ok(match margin {
            Some(_) => (Outcome::Holds, "the text's own number".into()),
            None => (Outcome::NotDecidable, "the text gives no number".into()),
        });
    };
    let st = stated
        .iter()
        .filter(|s| s.quantity.starts_with(quantity))
        .nth(nth)
        .ok_or_else(|| {
            format!("no computed statement {nth} of {quantity:?} (its runs are not in the folders)")
        })?;
    if st.given == 0 && !st.missing.is_empty() {
        return Err(format!(
            "{quantity:?}: no complete run folder (missing or incomplete: {})",
            st.missing.join("; ")
        ));
    }
    if st.given == 0 {
        return Err(format!("{quantity:?}: no repeat gave a value"));
    }
    let (tool, zero) = (st.tool, Summary::of(&[0.0]));
    Ok(match (st.printed, margin) {
        // A lower bound: above the stated number plus the margin it fails; below, it cannot
        // tell.
        (Some(p), Some(m)) if st.bounded > 0 => {
            let o = match within((tool.mean - p).abs(), tie(tool, zero), m) {
                Outcome::Fails if tool.mean > p => Outcome::Fails,
                _ => Outcome::NotDecidable,
            };
            (
                o,
                format!(
                    "≥ {} (a lower bound in {} of {} repeats) against the stated {} ± {}",
                    tool.show(),
                    st.bounded,
                    st.given,
                    num(p),
                    num(m)
                ),
            )
        }
        (Some(p), Some(m)) => {
            let o = within((tool.mean - p).abs(), tie(tool, zero), m);
            (
                o,
                format!("{} against the stated {} ± {}", tool.show(), num(p), num(m)),
            )
        }
        (None, None) => (
            ordered(zero, tool),
            format!("{} > 0 ({})", tool.show(), st.computed),
        ),
        _ => {
            return Err(format!(
                "{quantity:?}: a stated number needs a margin, an ordering none"
            ))
        }
    })
}

/// A failing part fails the whole; else an undecided part leaves it undecided.
fn worst(parts: &[Outcome]) -> Outcome {
    if parts.contains(&Outcome::Fails) {
        Outcome::Fails
    } else if parts.contains(&Outcome::NotDecidable) || parts.is_empty() {
        Outcome::NotDecidable
    } else {
        Outcome::Holds
    }
}

/// `claim` on `side`: the outcome of all its checks, and what each compared.
pub fn judge(d: &Dissertation, side: &Side, claim: &Claim) -> (Outcome, String) {
    if claim.checks.is_empty() {
        let why = claim.undecidable.clone().unwrap_or_default();
        return (Outcome::NotDecidable, why);
    }
    let parts: Vec<(Outcome, String)> = claim.checks.iter().map(|c| check(d, side, c)).collect();
    let outcome = worst(&parts.iter().map(|p| p.0).collect::<Vec<_>>());
    let text: Vec<String> = parts.into_iter().map(|(_, t)| t).collect();
    (outcome, text.join("; "))
}

/// Every claim judged on the tool's `evaluated` tables and `stated` numbers, and on the
/// printed ones.
pub fn judge_all(
    d: &Dissertation,
    claims: &Claims,
    evaluated: &[Evaluated],
    stated: &[Stated],
) -> Vec<Judged> {
    claims
        .claims
        .iter()
        .map(|c| Judged {
            tool: judge(d, &Side::Tool(evaluated, stated), c),
            printed: (!c.checks.is_empty()).then(|| judge(d, &Side::Printed, c)),
        })
        .collect()
}

/// The summary's lines on the claims: how many, and their outcomes on both sides.
pub fn summary(s: &mut String, judged: &[(Claim, Judged)]) {
    let count = |o: Outcome, printed: bool| {
        judged
            .iter()
            .filter(|(_, j)| {
                if printed {
                    j.printed.as_ref().is_some_and(|p| p.0 == o)
                } else {
                    j.tool.0 == o
                }
            })
            .count()
    };
    let no_numbers = judged.iter().filter(|(c, _)| c.checks.is_empty()).count();
    let _ = writeln!(
        s,
        "**The text's claims** ({} comparative or conclusive sentences of chapters 3-6, \
         listed below): on the tool's numbers {} hold, {} fail, {} are not decidable ({} \
         because the text gives no numbers to judge them on, the rest within the spread or \
         missing a cell). On the dissertation's own printed numbers: {} hold, {} fail, the \
         rest have none to be judged on.\n",
        judged.len(),
        count(Outcome::Holds, false),
        count(Outcome::Fails, false),
        count(Outcome::NotDecidable, false),
        no_numbers,
        count(Outcome::Holds, true),
        count(Outcome::Fails, true),
    );
}

/// The section listing every claim with its quote, reading and both verdicts.
pub fn section(s: &mut String, judged: &[(Claim, Judged)]) {
    let _ = writeln!(s, "## The text's claims\n");
    let _ = writeln!(
        s,
        "Each comparative or conclusive sentence, as printed, with how it is read and its \
         verdict on the tool's numbers (mean ± sd of one repeat; two groups differ when \
         their means are more than two standard errors apart) and on the printed ones.\n"
    );
    for (c, j) in judged {
        let printed = match &j.printed {
            Some((o, text)) => format!(" Printed: **{}** ({text}).", o.as_str()),
            None => String::new(),
        };
        let _ = writeln!(
            s,
            "- **{}** — §{} \"{}\" {} Tool: {}.{printed}",
            j.tool.0.as_str(),
            c.section,
            c.quote.trim(),
            c.reading.trim(),
            j.tool.1,
        );
    }
    let _ = writeln!(s);
}

#[cfg(test)]
mod tests;
