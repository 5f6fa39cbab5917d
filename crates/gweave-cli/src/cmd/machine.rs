//! `gweave machine`: the built-in machine profiles, and profiles from what the printer says
//! about itself.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{anyhow, Context, Result};
use clap::{Args, Subcommand};
use gweave_sim::builtin::{self, BUILTIN};
use gweave_sim::from_m503;

use crate::common::{print_summary, read_text, write_bytes};
use crate::files::Files;

/// Machine profiles: the built-in ones, and one made from what a printer says about itself
/// (see docs/machine.md).
#[derive(Args, Debug)]
pub struct MachineArgs {
    #[command(subcommand)]
    pub command: MachineCommand,
}

#[derive(Subcommand, Debug)]
pub enum MachineCommand {
    /// The profiles built into gweave, which `--machine NAME` takes anywhere a profile file
    /// goes (`gweave sim part.gcode --machine prusa-mk3`).
    List,
    /// A built-in profile's text, comments included: the start of a profile of your own
    /// (`gweave machine show prusa-mk3 -o my-printer.toml`, then edit it).
    Show {
        /// The profile's name (`gweave machine list`).
        name: String,
        /// Where to write it; standard output without it.
        #[arg(short, long, value_name = "TOML")]
        output: Option<PathBuf>,
    },
    /// A profile from a Marlin board's `M503` report (paste the terminal's answer into a file;
    /// `echo:` and OctoPrint's `Recv:` prefixes are fine): steps per mm (M92), limits (M201,
    /// M203), accelerations (M204), jerk or junction deviation and the minimum segment time
    /// (M205), hotend and bed PID (M301, M304). The probe offset (M851) and anything not
    /// modelled is listed on standard error and kept as comments.
    ///
    /// Example: `gweave machine from-m503 m503.txt -o printer.toml`.
    FromM503 {
        /// The `M503` report.
        input: PathBuf,
        /// Where to write the profile (TOML); standard output without it.
        #[arg(short, long, value_name = "TOML")]
        output: Option<PathBuf>,
    },
}

pub fn run(args: MachineArgs) -> Result<ExitCode> {
    match args.command {
        MachineCommand::List => {
            print_summary(|out| {
                for b in BUILTIN {
                    writeln!(out, "{:<16} {}", b.name, b.summary())?;
                }
                writeln!(out, "(--machine NAME; `gweave machine show NAME -o mine.toml` to start your own)")
            })?;
            Ok(ExitCode::SUCCESS)
        }
        MachineCommand::Show { name, output } => {
            Files::new().write("-o", output.as_deref()).check()?;
            let b = builtin::find(&name).ok_or_else(|| {
                anyhow!("no built-in machine profile named {name:?} (built in: {})", builtin::names())
            })?;
            write_or_print(output, b.text)
        }
        MachineCommand::FromM503 { input, output } => {
            Files::new().read("INPUT", Some(&input)).write("-o", output.as_deref()).check()?;
            let made = from_m503(&read_text(&input)?).with_context(|| format!("in {}", input.display()))?;
            let mut text = format!("# Made by `gweave machine from-m503` from {}.\n", input.display());
            text.extend(made.used.iter().map(|u| format!("# used: {u}\n")));
            text.extend(made.notes.iter().map(|n| format!("# not used: {n}\n")));
            text.push('\n');
            text.push_str(&toml::to_string(&made.profile).context("writing the profile as TOML")?);
            for note in &made.notes {
                eprintln!("not used: {note}");
            }
            write_or_print(output, &text)
        }
    }
}

/// A profile's text to the file `-o` names, or to standard output.
fn write_or_print(output: Option<PathBuf>, text: &str) -> Result<ExitCode> {
    match output {
        Some(path) => write_bytes(&path, text.as_bytes())?,
        None => print_summary(|out| out.write_all(text.as_bytes()))?,
    }
    Ok(ExitCode::SUCCESS)
}
