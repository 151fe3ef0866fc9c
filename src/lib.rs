//! isar-clutter: a declarative batch experiment runner for the multiscale modelling and
//! simulation of clutter in ISAR imaging (Mitchell, 2020). A YAML spec names datasets and
//! analysis settings; the plan expands sweeps into seeded jobs; the runner analyses every
//! job's stack and writes Parquet tables, `.npy` maps and a manifest.
//!
//! Modules follow the data flow: [`spec`] -> [`plan`] -> [`data`] (with [`npy`] and
//! [`filters`]) -> [`analysis`] -> [`results`], driven by [`runner`]. The numerical kernels
//! ([`analysis`], [`filters`], [`lowrank`], [`cmd`]) are free of I/O; [`oracle`] holds their
//! slow references. [`alloc`] is the binary's allocator (large blocks mapped from the kernel).

#![warn(missing_docs)]

pub mod alloc;
pub mod analysis;
pub mod calibration;
pub mod cmd;
pub mod data;
pub mod figures;
pub mod filters;
pub mod fleishman;
pub mod hypotheses;
pub mod isar;
pub mod lowrank;
pub mod metrics;
pub mod mie;
pub mod model;
pub mod netcdf;
pub mod netcdf_stack;
pub mod npy;
pub mod oracle;
pub mod plan;
pub mod report;
pub mod results;
pub mod runner;
pub mod similarity;
pub mod spec;
pub mod synthesis;
pub mod table;
pub mod vegetation;
