//! isar-clutter-apps: what is built on the statistics, the hypothesis tests (ch. 5.1) and the
//! CNN applications (networks in burn, training, the fast CPU kernels). The core crate's
//! modules are re-exported under their own names, so that this crate's files name them as the
//! one-crate layout did (`crate::stats`, `crate::io`, ...).

#![warn(missing_docs)]

pub use isar_clutter_core::{alloc, io, location_grid, physics, seeds, stats, synthesis};

pub mod apps;
