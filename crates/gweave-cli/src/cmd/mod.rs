//! One file per subcommand.

mod cat;
mod check;
mod stats;

// serial: the virtual printer on a pty or loopback TCP
mod serve;

use std::process::ExitCode;

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    Stats(stats::StatsArgs),
    Check(check::CheckArgs),
    Cat(cat::CatArgs),
    Serve(serve::ServeArgs),
}

pub fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Stats(a) => stats::run(a),
        Command::Check(a) => check::run(a),
        Command::Cat(a) => cat::run(a),
        Command::Serve(a) => serve::run(a),
    }
}
