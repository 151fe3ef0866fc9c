//! isar-clutter: a declarative batch experiment runner for the multiscale modelling and
//! simulation of clutter in ISAR imaging (Mitchell, 2020). A YAML spec names datasets and
//! analysis settings; the plan expands sweeps into seeded jobs; the scheduler runs them and the
//! table assembly writes Parquet tables, `.npy` maps, a manifest and a report.
//!
//! This crate is the top of the workspace (`docs/architecture.md` draws the layers): it
//! re-exports every crate's modules under one name and adds the reproduction of the
//! dissertation ([`reproduction`]) and the binary.
//!
//! - [`experiment`] (with the dataset kinds), [`run`]: the runner (`isar-clutter-runner`);
//! - [`report`]: figures, the HTML report and the comparison tables (`isar-clutter-report`);
//! - [`apps`]: the hypothesis tests and the CNN applications (`isar-clutter-apps`);
//! - [`io`]: file formats, Parquet tables and the results contract (`isar-clutter-tables` over
//!   the core's formats);
//! - [`stats`], [`synthesis`], [`physics`], [`seeds`], [`workflow`], [`alloc`]: the core
//!   (`isar-clutter-core`).

#![warn(missing_docs)]

pub use isar_clutter_apps::apps;
pub use isar_clutter_core::{
    alloc, error_text, physics, resources, seeds, stats, synthesis, workflow,
};
pub use isar_clutter_report::report;
pub use isar_clutter_runner::{experiment, run};
pub use isar_clutter_tables::io;

pub mod reproduction;
