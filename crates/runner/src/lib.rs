//! isar-clutter-runner: the experiment runner. The spec and the dataset kinds
//! ([`experiment`], each kind one file of [`experiment::datasets`]), and the run ([`run`]):
//! plan, job kinds, scheduler, job store, table assembly and manifest. The lower crates' modules are re-exported under their own names
//! (`crate::stats`, `crate::io`, `crate::apps`, ...), so that this crate's files name them as
//! the one-crate layout did.

#![warn(missing_docs)]

pub use isar_clutter_apps::apps;
pub use isar_clutter_core::{
    alloc, error_text, location_grid, physics, resources, seeds, stats, synthesis, workflow, TOOL,
};
pub use isar_clutter_tables::io;

pub mod experiment;
pub mod run;
