//! isar-clutter-tables: the results folder's files above the core crate's formats: Parquet
//! tables read and written atomically (polars), the contract of a results folder (its tables'
//! names and columns, `manifest.json`'s format), under the same `io` module as the core's
//! formats (re-exported), so that the runner and the report name one `io`.

#![warn(missing_docs)]

pub mod io;
