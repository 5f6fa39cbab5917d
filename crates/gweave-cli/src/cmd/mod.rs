//! One file per subcommand.

mod cat;
mod check;
mod stats;

mod preview;

use std::process::ExitCode;

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    Stats(stats::StatsArgs),
    Check(check::CheckArgs),
    Cat(cat::CatArgs),

    Preview(preview::PreviewArgs),
}

pub fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Stats(a) => stats::run(a),
        Command::Check(a) => check::run(a),
        Command::Cat(a) => cat::run(a),

        Command::Preview(a) => preview::run(a),
    }
}
