//! What the reproduction document shows, evaluated: a table's cells (printed beside the
//! tool's repeats, with the difference and verdict), a table as a whole ([`Evaluated`]), and a
//! statement of the text beside the tool's number ([`Stated`]). The document's writer
//! (`reproduction::write`) makes them; the claims, the solver's statements and the renderer
//! read them.

use super::compare::{Spread, Summary, Verdict};

/// One cell of the document.
#[derive(Debug, Clone)]
pub struct Cell {
    /// The printed value (`None`: not a number, or empty).
    pub printed: Option<f64>,
    /// The tool's repeats summarised (`None`: the tool does not compute this cell).
    pub tool: Option<Summary>,
    /// The difference tool - printed.
    pub difference: Option<f64>,
    /// The verdict, where both sides are numbers.
    pub verdict: Option<Verdict>,
    /// The tolerance the verdict used.
    pub tolerance: Option<f64>,
    /// The tool's value in the first repeat (the spec's own seed): what a rerun of the spec
    /// gives again (`reproduction::write` records it for the quick tests).
    pub first: Option<f64>,
}

/// One table of the document: the recipe's cells evaluated.
#[derive(Debug, Clone)]
pub struct Evaluated {
    /// The table's number.
    pub number: u32,
    /// The specs and repeats read.
    pub sources: Vec<(String, usize)>,
    /// Rows of cells.
    pub cells: Vec<Vec<Cell>>,
    /// How the values behave under reseeding.
    pub spread: Spread,
    /// Why the values may differ.
    pub differs_because: &'static str,
    /// The reading of the table ([`super::extract::Recipe::protocol`]).
    pub protocol: Option<&'static str>,
    /// The KL estimator's floor at the table's sizes, in words ([`super::floors`]; KL tables only).
    pub floor: Option<String>,
    /// The folders of its specs that are missing or incomplete (`reproduction::runs::Missing::show`): its
    /// cells read the others, and are not computed where none is left.
    pub missing: Vec<String>,
}

/// A statement of the text beside the tool's number.
#[derive(Debug, Clone)]
pub struct Stated {
    /// The statement's quantity (as the reference words it).
    pub quantity: String,
    /// The tool's number over the repeats.
    pub tool: Summary,
    /// The stated number, if the text gives one.
    pub printed: Option<f64>,
    /// The verdict where both are numbers.
    pub verdict: Option<Verdict>,
    /// What the tool computed.
    pub computed: String,
    /// Why it may differ (empty: nothing to add).
    pub differs_because: String,
    /// The unit of the tool's number where it is not the reference's.
    pub unit: Option<&'static str>,
    /// Repeats run.
    pub repeats: usize,
    /// Repeats that gave a value (those `tool` summarises).
    pub given: usize,
    /// Of those, the repeats whose value is a lower bound ([`super::extract::Statement::censor`]).
    pub bounded: usize,
    /// One exact computation (no repeats, no spread).
    pub exact: bool,
    /// The folders it reads that are missing or incomplete (`reproduction::runs::Missing::show`).
    pub missing: Vec<String>,
}
