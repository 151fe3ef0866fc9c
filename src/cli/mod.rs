//! The bodies of the binary's commands that do not belong in `main.rs`'s dispatch: one file per
//! family of commands.

pub mod models;
