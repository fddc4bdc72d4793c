//! The `vkrad` command line: its grammar (`args`), one function per
//! subcommand (`commands`), the progress line and Ctrl-C (`progress`) and
//! the printed summaries (`print`). The work itself is in the library.

use std::process::ExitCode;
use std::sync::atomic::Ordering;

use clap::Parser;

mod args;
mod commands;
mod print;
mod progress;
mod view;

use args::{Cli, Command};
use progress::INTERRUPTED;

/// Runs the command line in `std::env::args` and returns the exit status:
/// 0, 1 on an error (printed), 130 when Ctrl-C stopped the work.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Devices) => commands::devices(),
        Some(Command::Formfactors(args)) => commands::formfactors(args),
        Some(Command::Mesh(args)) => commands::mesh_only(args),
        Some(Command::Bench(args)) => commands::bench(args),
        Some(Command::Profile(args)) => commands::profile(args),
        Some(Command::View(args)) => view::view(args),
        Some(Command::Help { topic }) => commands::help(topic.as_deref()),
        None => commands::render(cli.render),
    };
    match result {
        // The partial result was written; the exit status still says so.
        Ok(()) if INTERRUPTED.load(Ordering::SeqCst) => ExitCode::from(130),
        Ok(()) => ExitCode::SUCCESS,
        // Stopped where there was nothing to write yet (the solve's mesh).
        Err(e) if INTERRUPTED.load(Ordering::SeqCst) => {
            eprintln!("\n{e:#}: nothing written");
            ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
