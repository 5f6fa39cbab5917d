//! Arguments every command spells the same way (docs/pipeline.md, "One vocabulary"), flattened
//! into each subcommand with `#[command(flatten)]` so that one name has one meaning and one
//! help text everywhere.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Args;
use gweave_sim::MachineProfile;

use crate::progress::Bar;

/// `-q`: quiet on standard output and standard error alike, except for what went wrong. Part of
/// [`ReportArgs`](crate::common::ReportArgs), which decides with it whether a summary prints.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct Quiet {
    /// No progress bar and no human summary; errors, warnings and findings still print, and
    /// --json and --report still write.
    #[arg(short, long)]
    pub quiet: bool,
}

impl Quiet {
    /// The progress bar, drawn only without -q (and only on a terminal, for large inputs).
    pub fn bar(&self) -> Bar {
        Bar::new(self.quiet)
    }
}

/// `--lenient`: read past malformed lines instead of stopping at the first.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct Lenient {
    /// Read past malformed lines (a malformed number, a bad checksum, a line over 256 KiB)
    /// instead of stopping at the first: they are counted, the first one named, and otherwise
    /// ignored.
    #[arg(long)]
    pub lenient: bool,
}

impl Lenient {
    pub fn strictness(&self) -> gweave::Strictness {
        if self.lenient {
            gweave::Strictness::Lenient
        } else {
            gweave::Strictness::Strict
        }
    }
}

/// `--machine`: the virtual printer's profile for `serve`, helped as `sim`'s option
/// ([`gweave_sim::reading::SimOptions`]) is declared.
#[derive(Args, Debug, Clone, Default)]
pub struct MachineArg {
    #[arg(long = "machine", id = "machine", value_name = "TOML|NAME", help = machine_help())]
    pub path: Option<PathBuf>,
}

fn machine_help() -> String {
    use gweave::JobOptions;
    gweave_sim::reading::SimOptions::spec("machine").map(|s| s.help()).unwrap_or_default()
}

impl MachineArg {
    /// The profile, or the built-in printer without `--machine`. Files the profile names (a
    /// thermistor table) are read from its folder.
    pub fn load(&self) -> Result<MachineProfile> {
        Ok(gweave_sim::builtin::load_machine(self.path.as_deref())?)
    }
}

/// A `--machine` value: a profile file, or a built-in profile's name where no such file exists.
pub fn load_machine(value: &Path) -> Result<MachineProfile> {
    Ok(gweave_sim::builtin::load_machine(Some(value))?)
}
