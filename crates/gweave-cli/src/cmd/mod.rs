//! One file per subcommand.

mod cat;
mod check;
mod stats;

// binder-jet raster
mod raster;
mod slice_raster;
// mix
mod mix;

use std::process::ExitCode;

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    Stats(stats::StatsArgs),
    Check(check::CheckArgs),
    Cat(cat::CatArgs),
    Raster(Box<raster::RasterArgs>),
    SliceRaster(slice_raster::SliceRasterArgs),
    // mix
    Mix(mix::MixArgs),
}

pub fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Stats(a) => stats::run(a),
        Command::Check(a) => check::run(a),
        Command::Cat(a) => cat::run(a),
        Command::Raster(a) => raster::run(*a),
        Command::SliceRaster(a) => slice_raster::run(a),
        // mix
        Command::Mix(a) => mix::run(a),
    }
}
