//! The CNN applications in the report and on the terminal (ch. 5.3): one section per
//! application of [`CnnApp`] with rows, its trainings read into one shape by [`groups`], its
//! tables from [`table`] (Tables 20/22 and the location table) and its figures from
//! [`figures`] (Figs. 66-67, 72-74, confusion matrices, training curves).

mod figures;
mod groups;
pub mod table;

use super::table::Format;
use super::task::Figure;
use crate::io::results::CnnApp;
use anyhow::Result;
use groups::load;
use std::path::Path;

/// One application's part of the report: its tables (HTML) and figures.
#[derive(Debug, Clone)]
pub struct Section {
    /// Anchor of the section on the page (`classification`, `location`).
    pub id: &'static str,
    /// Heading.
    pub title: &'static str,
    /// What the section shows, one paragraph.
    pub intro: String,
    /// Tables as HTML `<table>`s.
    pub tables: Vec<String>,
    /// Figures, in page order.
    pub figures: Vec<Figure>,
}

/// The sections of the applications whose tables `dir` holds (none, one or both), drawing
/// their figures into `figures/`.
///
/// # Errors
/// If a table cannot be read or a figure cannot be drawn.
pub fn sections(dir: &Path) -> Result<Vec<Section>> {
    let mut out = vec![];
    for &app in CnnApp::ALL {
        let Some(groups) = load(dir, app, &[], false)? else {
            continue;
        };
        let tables = table::tables(dir, table::names_of(app), &[], Format::Html)?;
        out.push(match app {
            CnnApp::Classification => Section {
                id: "classification",
                title: "Clutter classification (Tables 20/22, Figs. 66-67)",
                intro: "Networks trained on generated samples of each class (and on the few \
                        originals: method original) predict original data; test accuracy \
                        against the training size, mean and sample standard deviation over \
                        repeats."
                    .into(),
                tables,
                figures: figures::classification(dir, &groups)?,
            },
            CnnApp::Location => Section {
                id: "location",
                title: "Target location (Figs. 72-74)",
                intro: "Networks locate an 8x8 target on a 5x5 grid in clutter (chance 4 %); \
                        test accuracy against the signal-to-clutter ratio per method, and the \
                        SCR where the mean accuracy first reaches 50 % and 90 %."
                    .into(),
                tables,
                figures: figures::location(dir, &groups)?,
            },
        });
    }
    Ok(out)
}
