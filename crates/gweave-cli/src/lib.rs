//! The `gweave` command line, as a library so that the Python package installs the same CLI.
//!
//! Each subcommand lives in `cmd/<name>.rs`: clap arguments in, validated library config out,
//! the library does the work, and the subcommand prints a human summary or JSON. The transforms
//! of the registry (`gweave_sim::transform::transforms`: `purge-shift`, ...) have no file of
//! their own: `cmd/transform.rs` derives their subcommands from it.

mod args;
mod cmd;
mod common;
mod files;
mod format;
mod options;
mod per_file;
mod progress;
mod signals;

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

/// The clap description of every command, for tests that hold all of them to one vocabulary
/// (`tests/vocabulary.rs`) and for the Python package's flag-to-keyword map.
pub fn command() -> clap::Command {
    <Cli as clap::CommandFactory>::command()
}

/// Runs the CLI with these arguments (the first is the program name) and returns the exit code.
pub fn run<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS };
        }
    };
    // `serve` handles Ctrl-C itself (it stops and removes its pty link); every other command
    // removes its temporary files and exits.
    let guard = if cli.command.is_serve() { Ok(None) } else { signals::Cleanup::install() };
    let result = guard.map_err(anyhow::Error::from).and_then(|_guard| cmd::run(cli.command));
    match result {
        Ok(code) => code,
        Err(e) => {
            if is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            // Stopped from outside (Ctrl-C in Python's `gweave.main()`): the caller says so.
            if is_stopped(&e) {
                return ExitCode::from(130);
            }
            eprintln!("gweave: error: {e}");
            // A cause already quoted by the message above it (a context that repeats an I/O
            // error's text) is not printed again.
            let mut shown = e.to_string();
            for cause in e.chain().skip(1) {
                let text = cause.to_string();
                if !shown.contains(&text) {
                    eprintln!("  caused by: {text}");
                }
                shown = text;
            }
            // A strict run stopped at a line it cannot read: the way past it, which a new user
            // would not find from the message alone.
            if e.chain()
                .any(|c| matches!(c.downcast_ref::<gweave::Error>(), Some(gweave::Error::Syntax { .. })))
            {
                eprintln!("  hint: --lenient reads past such lines (a transform copies them unchanged)");
            }
            ExitCode::FAILURE
        }
    }
}

/// A run stopped by its caller ([`gweave::is_stopped`]), whatever error it unwound with.
fn is_stopped(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(gweave::is_stopped))
}

/// A closed pipe (`gweave cat x | head`) is not an error.
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            || matches!(c.downcast_ref::<gweave::Error>(), Some(gweave::Error::Io { source, .. }) if source.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
