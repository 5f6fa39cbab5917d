//! One file per subcommand.

mod cat;
mod check;
mod stats;

// gweave-sim: the virtual printer
pub(crate) mod estimate;
mod machine;
mod sim;
// binder-jet raster
mod raster;
mod slice_raster;
// the transforms of the registry (purge-shift, ...)
mod transform;
// mix
mod mix;
mod mix_colour;

// rotary (lathe-type) printing
mod rotary;
// serial: the virtual printer on a pty or loopback TCP
mod serve;

mod preview;

use std::process::ExitCode;

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    Stats(stats::StatsArgs),
    Check(check::CheckArgs),
    Cat(cat::CatArgs),
    // gweave-sim: the virtual printer
    Sim(sim::SimArgs),
    Estimate(estimate::EstimateArgs),
    Machine(machine::MachineArgs),
    Raster(Box<raster::RasterArgs>),
    SliceRaster(slice_raster::SliceRasterArgs),
    // the transforms of the registry (purge-shift, ...)
    #[command(flatten)]
    Transform(transform::Transforms),

    Rotary(rotary::RotaryArgs),
    Serve(serve::ServeArgs),
    // mix
    Mix(mix::MixArgs),

    Preview(preview::PreviewArgs),
}

impl Command {
    pub fn is_serve(&self) -> bool {
        matches!(self, Command::Serve(_))
    }
}

pub fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Stats(a) => stats::run(a),
        Command::Check(a) => check::run(a),
        Command::Cat(a) => cat::run(a),
        // gweave-sim: the virtual printer
        Command::Sim(a) => sim::run(a),
        Command::Estimate(a) => estimate::run(a),
        Command::Machine(a) => machine::run(a),
        Command::Raster(a) => raster::run(*a),
        Command::SliceRaster(a) => slice_raster::run(a),
        // the transforms of the registry (purge-shift, ...)
        Command::Transform(t) => t.run(),

        Command::Rotary(a) => rotary::run(a),
        Command::Serve(a) => serve::run(a),
        // mix
        Command::Mix(a) => mix::run(a),

        Command::Preview(a) => preview::run(a),
    }
}
