//! One file per subcommand.

mod cat;
mod check;
mod stats;

// purge-shift
mod purge_shift;

use std::process::ExitCode;

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    Stats(stats::StatsArgs),
    Check(check::CheckArgs),
    Cat(cat::CatArgs),
    // purge-shift
    PurgeShift(purge_shift::PurgeShiftArgs),
}

pub fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Stats(a) => stats::run(a),
        Command::Check(a) => check::run(a),
        Command::Cat(a) => cat::run(a),
        // purge-shift
        Command::PurgeShift(a) => purge_shift::run(a),
    }
}
