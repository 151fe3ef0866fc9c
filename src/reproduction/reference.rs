//! The dissertation's tables as printed (`reproduction/dissertation.yaml`, compiled into the
//! tool): the reference side of every comparison the reproduction document makes.

use anyhow::{bail, Context, Result};
use serde::Deserialize;

/// The file's text, as committed.
pub const TEXT: &str = include_str!("../../reproduction/dissertation.yaml");

/// One printed cell.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum Printed {
    /// A number.
    Number(f64),
    /// Text ("Verified", "-").
    Text(String),
}

impl Printed {
    /// The number, if the cell is one.
    pub fn number(&self) -> Option<f64> {
        match self {
            Printed::Number(v) => Some(*v),
            Printed::Text(_) => None,
        }
    }
}

/// One table of the dissertation.
#[derive(Debug, Clone, Deserialize)]
pub struct Table {
    /// Its number (1-36).
    pub number: u32,
    /// The caption.
    pub title: String,
    /// The dissertation section it sits in.
    pub section: String,
    /// `result` or `description`.
    pub kind: String,
    /// The construction behind its numbers, as the text states it.
    pub setting: String,
    /// `dB`, `%` or empty.
    pub unit: String,
    /// Row labels.
    pub rows: Vec<String>,
    /// Column labels.
    pub columns: Vec<String>,
    /// One list per row (`None`: an empty printed cell).
    pub values: Vec<Vec<Option<Printed>>>,
    /// What is odd about the printed table.
    #[serde(default)]
    pub notes: Option<String>,
}

impl Table {
    /// The printed number of cell (`r`, `c`).
    pub fn number_at(&self, r: usize, c: usize) -> Option<f64> {
        self.values.get(r)?.get(c)?.as_ref()?.number()
    }

    /// The printed conclusion of cell (`r`, `c`) as a number: 1 for a text starting with
    /// "Verified", 0 for one starting with "Not Verified" (`None` otherwise).
    pub fn conclusion_at(&self, r: usize, c: usize) -> Option<f64> {
        match self.values.get(r)?.get(c)?.as_ref()? {
            Printed::Text(t) if t.starts_with("Verified") => Some(1.0),
            Printed::Text(t) if t.starts_with("Not Verified") => Some(0.0),
            _ => None,
        }
    }

    /// Decimals printed in column `c`: the most any of its numbers shows (a printed trailing
    /// zero is lost when the file is read as numbers, the column's other cells keep it).
    pub fn decimals(&self, c: usize) -> u32 {
        self.values
            .iter()
            .filter_map(|row| row.get(c)?.as_ref()?.number())
            .map(|v| super::compare::decimals_of(&format!("{v}")))
            .max()
            .unwrap_or(0)
    }
}

/// A number the text states for a figure.
#[derive(Debug, Clone, Deserialize)]
pub struct FigureStatement {
    /// The figure (`None`: the text's, not a figure's).
    pub figure: Option<serde_yaml_ng::Value>,
    /// Its section.
    pub section: String,
    /// What the number is.
    pub quantity: String,
    /// The number (`None`: the text orders without a number).
    pub value: Option<serde_yaml_ng::Value>,
    /// Its unit.
    #[serde(default)]
    pub unit: Option<String>,
    /// The sentence that states it.
    pub quote: String,
}

impl FigureStatement {
    /// The stated number, where the value is one (not a bound such as `< 1`, nor absent).
    pub fn number(&self) -> Option<f64> {
        self.value.as_ref().and_then(serde_yaml_ng::Value::as_f64)
    }
}

/// The whole file.
#[derive(Debug, Clone, Deserialize)]
pub struct Dissertation {
    /// Tables 1-36.
    pub tables: Vec<Table>,
    /// The numbers stated for figures.
    #[serde(default)]
    pub figures: Vec<FigureStatement>,
}

impl Dissertation {
    /// The committed reference, checked: every table's rows have one value per column.
    ///
    /// # Errors
    /// If the file does not parse or a table is ragged.
    pub fn load() -> Result<Dissertation> {
        let d: Dissertation =
            serde_yaml_ng::from_str(TEXT).context("reading reproduction/dissertation.yaml")?;
        for t in &d.tables {
            if t.values.len() != t.rows.len() || t.values.iter().any(|r| r.len() != t.columns.len())
            {
                bail!(
                    "reproduction/dissertation.yaml: Table {} is ragged",
                    t.number
                );
            }
        }
        Ok(d)
    }

    /// Table `number`.
    pub fn table(&self, number: u32) -> Option<&Table> {
        self.tables.iter().find(|t| t.number == number)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_committed_reference_loads_with_every_table() {
        let d = Dissertation::load().unwrap();
        let mut numbers: Vec<u32> = d.tables.iter().map(|t| t.number).collect();
        numbers.sort();
        assert_eq!(numbers, (1..=36).collect::<Vec<_>>());
        let t3 = d.table(3).unwrap();
        assert_eq!(t3.number_at(1, 1), Some(0.6481));
        assert_eq!(t3.decimals(1), 4);
    }
}
