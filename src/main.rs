//! The `isar-clutter` binary: parses the command line ([`cli::args`]) and hands each command to
//! its function in [`cli`]. Errors print their cause chain and exit 2; a run with failed jobs
//! exits 1.

/// Large blocks come straight from the kernel (see [`isar_clutter::alloc`]).
#[global_allocator]
static GLOBAL: isar_clutter::alloc::LargeMapAlloc = isar_clutter::alloc::LargeMapAlloc;

use anyhow::Result;
use clap::Parser;
use cli::args::{Cli, Command};
use std::process::ExitCode;

mod cli;

fn main() -> ExitCode {
    isar_clutter::alloc::tune_malloc();
    // A closed stdout (`isar-clutter validate SPEC | head -1`) ends the process quietly, as it
    // does other Unix tools, instead of a panic in `println!` (Rust ignores SIGPIPE).
    #[cfg(unix)]
    // SAFETY: restores the default disposition of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    match real_main() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", isar_clutter::error_text(&e));
            ExitCode::from(2)
        }
    }
}

/// The command line's command, run.
fn real_main() -> Result<ExitCode> {
    match Cli::parse().command {
        Command::Run(a) => cli::run::run(a),
        Command::Merge(a) => cli::run::merge(a),
        Command::Status(a) => cli::run::status(a),
        Command::Validate(a) => cli::run::validate(a),
        Command::Slurm(a) => cli::run::slurm(a),
        Command::Report(a) => cli::results::report(a),
        Command::Table(a) => cli::results::table(a),
        Command::Reproduce(a) => cli::results::reproduce(a),
        Command::CalibratePlants(a) => cli::results::calibrate_plants(a),
        Command::Fit(a) => cli::models::fit(a).map(|()| ExitCode::SUCCESS),
        Command::Generate(a) => cli::models::generate(a).map(|()| ExitCode::SUCCESS),
        Command::Cut(a) => cli::models::cut(a).map(|()| ExitCode::SUCCESS),
    }
}
