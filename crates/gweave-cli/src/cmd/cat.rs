//! `gweave cat`: parse and write back, unchanged. The identity every transform builds on, and a
//! quick proof that gweave reads a file: the output is byte-identical to the input.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::CopyReport;
use gweave::{Container, Identity, Run, Strictness, Target};

use crate::common::{print_summary, OutputArgs, ReportArgs};
use crate::files::Files;

/// Parse a file and write it back byte for byte (checks that it parses).
///
/// Example: `gweave cat part.gcode -o copy.gcode` (then `cmp part.gcode copy.gcode`). With
/// `-o -` the copy goes to standard output and nothing else is printed.
#[derive(Args, Debug)]
pub struct CatArgs {
    /// The G-code file to read.
    pub input: PathBuf,
    #[command(flatten)]
    pub out: OutputArgs,
    /// Copy malformed lines too instead of stopping at the first one.
    #[arg(long)]
    pub lenient: bool,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: CatArgs) -> Result<ExitCode> {
    let target = args.out.target()?;
    args.report.refuse_json_with_stdout(target.is_stdout())?;
    Files::new()
        .read("INPUT", Some(&args.input))
        .target(&target, &args.input)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mut bar = args.report.quiet.bar();
    let strictness = if args.lenient { Strictness::Lenient } else { Strictness::Strict };
    let mut copy = Identity::default();
    Run::file(&args.input).progress(&mut bar).strictness(strictness).to(&target).run(&mut copy)?;
    drop(bar);
    if args.report.emit(&copy.report)? && !target.is_stdout() {
        print_summary(|out| print_human(out, &args.input, &target, &copy.report))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn print_human(out: &mut dyn Write, input: &Path, target: &Target, r: &CopyReport) -> io::Result<()> {
    match target {
        Target::File(dest) => writeln!(out, "{} -> {}", input.display(), dest.display())?,
        Target::InPlace { keep_backup: true, .. } => {
            writeln!(out, "{} (in place, kept {}.bak)", input.display(), input.display())?
        }
        Target::InPlace { keep_backup: false, .. } => writeln!(out, "{} (in place)", input.display())?,
        Target::Stdout(_) | Target::Scratch(_) => {}
    }
    // Binary G-code keeps no empty line, nor one of a lone `;` (as libbgcode's converter).
    let container = match target {
        Target::File(dest) => Container::of_output(dest),
        Target::InPlace { .. } => Container::of_output(input),
        Target::Stdout(container) => *container,
        Target::Scratch(_) => Container::Text,
    };
    let how = match container {
        Container::Bgcode => "written as binary G-code: empty lines and lone `;` not kept",
        _ => "copied byte for byte",
    };
    writeln!(out, "  lines           {} ({:.1} MB), {how}", r.lines, r.bytes as f64 / 1e6)?;
    if let Some(first) = r.malformed.first_malformed_line {
        writeln!(
            out,
            "  malformed       {} (copied as written; the first at line {first})",
            r.malformed.malformed_lines
        )?;
    }
    Ok(())
}
