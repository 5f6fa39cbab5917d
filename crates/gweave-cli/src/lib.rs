//! The `gweave` command line, as a library so that the Python package installs the same CLI.
//!
//! Each subcommand lives in `cmd/<name>.rs`: clap arguments in, validated library config out,
//! the library does the work, and the subcommand prints a human summary or JSON.

mod cmd;
mod common;
mod progress;
pub mod raster_job;

use std::ffi::OsString;
use std::process::ExitCode;

use clap::Parser;

/// gweave: a G-code workbench for mixing hotends, rotary printers and binder jetting.
#[derive(Parser)]
#[command(name = "gweave", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: cmd::Command,
}

/// Runs the CLI with these arguments (the first is the program name) and returns the exit code.
pub fn run<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS };
        }
    };
    match cmd::run(cli.command) {
        Ok(code) => code,
        Err(e) => {
            if is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            eprintln!("gweave: error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}

/// A closed pipe (`gweave cat x | head`) is not an error.
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            || matches!(c.downcast_ref::<gweave::Error>(), Some(gweave::Error::Io { source, .. }) if source.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
