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
        Some(Command::Profile(args)) => commands::profile(args),
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
