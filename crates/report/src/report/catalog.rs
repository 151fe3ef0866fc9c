//! The catalogue of every table `isar-clutter table` prints: the pivot tables of
//! [`super::table`] and the CNN tables of [`super::cnn::table`], found by name.

use super::cnn;
use super::table::{render, standard, Format};
use anyhow::{bail, Result};
use std::path::Path;

/// Names of every table `isar-clutter table` prints, in print order: the pivot tables of
/// [`standard`], then the CNN tables of [`cnn::table`].
pub fn names() -> Vec<&'static str> {
    standard()
        .iter()
        .map(|d| d.name)
        .chain(cnn::table::names())
        .collect()
}

/// Renders the table called `name` (one of [`names`]): a pivot table by [`render`], a CNN
/// table by [`cnn::table::render`]. `Ok(None)` as they say.
///
/// # Errors
/// If no table has that name, or as [`render`].
pub fn render_named(
    dir: &Path,
    name: &str,
    filters: &[(String, Vec<String>)],
    pivot: Option<&str>,
    format: Format,
    strict: bool,
) -> Result<Option<String>> {
    match standard().iter().find(|d| d.name == name) {
        Some(def) => render(dir, def, filters, pivot, format, strict),
        None if cnn::table::names().contains(&name) => {
            cnn::table::render(dir, name, filters, pivot, format, strict)
        }
        None => bail!("no table {name:?}; tables: {}", names().join(", ")),
    }
}
