//! `gweave cat`: parse and write back, unchanged. The identity every transform builds on, and a
//! quick proof that gweave reads a file: the output is byte-identical to the input.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::pass::{Identity, Run, Strictness};

use crate::common::OutputArgs;
use crate::progress::Bar;

/// Parse a file and write it back byte for byte (checks that it parses).
///
/// Example: `gweave cat part.gcode -o copy.gcode` (then `cmp part.gcode copy.gcode`).
#[derive(Args, Debug)]
pub struct CatArgs {
    /// The G-code file to read.
    pub input: PathBuf,
    #[command(flatten)]
    pub out: OutputArgs,
    /// Copy malformed lines too instead of stopping at the first one.
    #[arg(long)]
    pub lenient: bool,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: CatArgs) -> Result<ExitCode> {
    let target = args.out.target()?;
    let mut bar = Bar::new(args.quiet);
    let mut run = Run::new(&args.input, &mut bar);
    if args.lenient {
        run.strictness = Strictness::Lenient;
    }
    run.transform(&mut Identity, &target)?;
    Ok(ExitCode::SUCCESS)
}
