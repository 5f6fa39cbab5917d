//! Arguments every command spells the same way (docs/pipeline.md, "One vocabulary"), flattened
//! into each subcommand with `#[command(flatten)]` so that one name has one meaning and one
//! help text everywhere.

use anyhow::Result;
use clap::Args;
use serde::Serialize;

use crate::common::ReportArgs;
use crate::progress::Bar;

/// `-q`: quiet on standard output and standard error alike, except for what went wrong.
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

    /// Writes the JSON asked for (`--json`, `--report`); returns whether the human summary
    /// prints: neither --json nor -q.
    pub fn emit<T: Serialize>(&self, report: &ReportArgs, value: &T) -> Result<bool> {
        Ok(report.emit(value)? && !self.quiet)
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
    pub fn strictness(&self) -> gweave::pass::Strictness {
        if self.lenient {
            gweave::pass::Strictness::Lenient
        } else {
            gweave::pass::Strictness::Strict
        }
    }
}
