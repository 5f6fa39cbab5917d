//! Arguments shared by subcommands: where output goes, and machine-readable reports.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use std::fmt::Display;
use std::str::FromStr;

use anyhow::{bail, Context, Result};
use clap::Args;
use gweave::gcode::writer::write_file;
use gweave::range::Quantity;
use gweave::{Range, Target};
use serde::Serialize;

use crate::args::Quiet;
use crate::per_file::{Named, PerFile};

/// Where a transform writes.
#[derive(Args, Debug)]
pub struct OutputArgs {
    /// Output file (`-` for standard output). Written to a temporary file and renamed into place.
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// Replace the input file (as PrusaSlicer post-processing scripts are called).
    #[arg(long, conflicts_with = "output")]
    pub in_place: bool,
    /// With --in-place, do not keep `<input>.bak` (an older `.bak` that is not a copy of the
    /// input is otherwise moved to the first free `.bak.1` .. `.bak.9`).
    #[arg(long, requires = "in_place")]
    pub no_backup: bool,
    /// With --in-place, replace the file even if it is read-only.
    #[arg(long, requires = "in_place")]
    pub force: bool,
    #[command(flatten)]
    pub format: crate::format::FormatArgs,
}

impl OutputArgs {
    pub fn target(&self) -> Result<Target> {
        match (&self.output, self.in_place) {
            (_, true) => self.format.in_place(!self.no_backup, self.force),
            (Some(p), false) => self.format.target(p),
            (None, false) => {
                bail!("say where to write: -o OUT, -o - for standard output, or --in-place")
            }
        }
    }
}

/// What a command reports and where: machine-readable output (`--json`, `--report`) and `-q`.
#[derive(Args, Debug)]
pub struct ReportArgs {
    /// Print the result as JSON on standard output instead of the human summary.
    #[arg(long)]
    pub json: bool,
    /// Also write the result as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    #[command(flatten)]
    pub quiet: Quiet,
}

impl ReportArgs {
    /// Refuses `--json` when the command's output goes to standard output (`-o -`): the JSON
    /// would follow the G-code or picture and spoil it.
    pub fn refuse_json_with_stdout(&self, to_stdout: bool) -> Result<()> {
        if self.json && to_stdout {
            bail!("--json and -o - would both write to standard output: write the report with --report FILE, or the output to a file");
        }
        Ok(())
    }

    /// Writes the JSON report file if asked; returns whether the human summary should print:
    /// neither --json nor -q.
    pub fn emit<T: Serialize>(&self, value: &T) -> Result<bool> {
        Ok(self.emit_result(value)? && !self.quiet.quiet)
    }

    /// [`ReportArgs::emit`] for a command over several files (`stats`, `check`): one file's
    /// report as it is, several as `{"files": [{"path", ...report}], "total"}`.
    pub fn emit_per_file<R: Serialize, T: Serialize>(
        &self,
        inputs: &[PathBuf],
        reports: &[R],
        total: impl FnOnce() -> T,
    ) -> Result<bool> {
        match reports {
            [one] => self.emit(one),
            _ => {
                let files = inputs.iter().zip(reports);
                let files = files.map(|(p, r)| Named { path: p.display().to_string(), report: r }).collect();
                self.emit(&PerFile { files, total: total() })
            }
        }
    }

    /// [`ReportArgs::emit`] for a command whose text is its result, not a summary
    /// (`mix --predict`): -q does not hide it.
    /// The JSON is streamed to its destination, never held whole in memory (a report may carry
    /// an entry per line or per change of a large file). The command has checked the report's
    /// path against its other files (`crate::files`) before it started.
    pub fn emit_result<T: Serialize>(&self, value: &T) -> Result<bool> {
        if let Some(path) = &self.report {
            write_file(path, |out| -> Result<()> {
                serde_json::to_writer_pretty(&mut *out, value)?;
                Ok(writeln!(out)?)
            })
            .map_err(|e| naming("--report", path, e))?;
        }
        if self.json {
            print_summary(|stdout| {
                serde_json::to_writer_pretty(&mut *stdout, value)?;
                writeln!(stdout)
            })?;
            return Ok(false);
        }
        Ok(true)
    }
}

/// Prints a summary on standard output. Unlike `println!`, which panics, a full or closed
/// standard output is an error here (`gweave stats x > /dev/full`); a closed pipe stays quiet
/// (see `is_broken_pipe`).
pub fn print_summary(print: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<()> {
    let mut out = io::BufWriter::new(io::stdout().lock());
    print(&mut out).and_then(|()| out.flush()).context("writing to standard output")
}

/// A clap value parser for one number within `range`:
/// `#[arg(long, value_parser = in_range(MANDREL_DIAMETER_MM))]`. Clap then refuses
/// `--mandrel-diameter 1e-9` before anything is read, naming the flag and the range
/// (`invalid value '1e-9' for '--mandrel-diameter <MM>': out of range: 1 to 1000 mm`), so every
/// numeric flag is bounded the same way, by the range the library states once.
pub fn in_range<T>(range: Range<T>) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: Quantity + FromStr,
    T::Err: Display,
{
    move |text| {
        let v: T = text.trim().parse().map_err(|e| format!("{e}; the range is {range}"))?;
        if range.contains(v) {
            Ok(v)
        } else {
            Err(format!("out of range: {range}"))
        }
    }
}

/// Writes `bytes` to `path` through a temporary file renamed into place (see `write_file`).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_file(path, |out| -> Result<()> { Ok(out.write_all(bytes)?) })
        .map_err(|e| naming("writing", path, e))
}

/// A failed write of `path` as one line that names the file once: the engine's I/O errors name
/// it already (`/x/r.json: No such file or directory`), an error while writing does not.
fn naming(what: &str, path: &Path, e: anyhow::Error) -> anyhow::Error {
    match e.downcast_ref::<gweave::Error>() {
        Some(named @ gweave::Error::Io { .. }) => anyhow::anyhow!("{what}: {named}"),
        _ => anyhow::anyhow!("{what} {}: {e:#}", path.display()),
    }
}

/// A text file the user named (a profile, a G-code snippet), with its name in the error.
pub fn read_text(path: &Path) -> Result<String> {
    gweave::settings::read_text(path).with_context(|| format!("reading {}", path.display()))
}

/// The lines a lenient read went past, as every summary reports them (nothing when none).
pub fn print_malformed(out: &mut dyn Write, m: &gweave::Malformed) -> io::Result<()> {
    if let Some(first) = m.first_malformed_line {
        let n = m.malformed_lines;
        writeln!(out, "  malformed       {n} lines read past (first: line {first}; see gweave check)")?;
    }
    Ok(())
}

/// A duration as `1h 02m 03s`.
pub fn hms(t_s: f64) -> String {
    let t = t_s.round() as u64;
    format!("{}h {:02}m {:02}s", t / 3600, t / 60 % 60, t % 60)
}
