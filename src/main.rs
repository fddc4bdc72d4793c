//! `vkrad`: the command line. Parsing and printing only (`cli`); the work
//! is in the library (`vkrad::app` and below).

use std::process::ExitCode;
use std::sync::atomic::Ordering;

use clap::Parser;

mod cli;

use cli::args::{Cli, Command};
use cli::commands;
use cli::progress::INTERRUPTED;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Devices) => commands::devices(),
        Some(Command::Formfactors(args)) => commands::formfactors(args),
        Some(Command::Mesh(args)) => commands::mesh_only(args),
        Some(Command::Bench(args)) => commands::bench(args),
        None => commands::render(cli.render),
    };
    match result {
        // The partial result was written; the exit status still says so.
        Ok(()) if INTERRUPTED.load(Ordering::SeqCst) => ExitCode::from(130),
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
