//! isar-clutter-report: figures, `report.html` and the comparison tables, rebuilt from the
//! files of a results folder (read through the results contract of `isar-clutter-tables`);
//! nothing of the runner. The lower crates' modules are re-exported under their own names.

#![warn(missing_docs)]

pub use isar_clutter_core::{alloc, error_text, location_grid, physics, seeds, stats, synthesis};
pub use isar_clutter_tables::io;

pub mod report;
