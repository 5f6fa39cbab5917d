//! `--format`: how a command's G-code output is stored, for every command that writes G-code
//! (cat, mix, purge-shift, rotary wrap and tube, raster). A file's name says it (`.gz`,
//! `.bgcode`: `gweave::Container::of_output`); standard output has no name, so
//! `-o - --format bgcode` is how a pipe carries binary G-code. With a file, `--format` must
//! agree with the name: a `.gcode` file holding binary G-code would fool the next program.

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use gweave::{Container, Target};
use std::path::Path;

/// How the output G-code is stored.
#[derive(Args, Debug, Clone, Copy)]
pub struct FormatArgs {
    /// How the output G-code is stored: text, gz (gzip) or bgcode (Prusa binary G-code). A
    /// file's name already says it (`.gz`, `.bgcode`); this is for `-o -` [default: by the
    /// output's name; text on standard output].
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<Format>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    Text,
    Gz,
    Bgcode,
}

impl Format {
    fn container(self) -> Container {
        match self {
            Format::Text => Container::Text,
            Format::Gz => Container::Gzip,
            Format::Bgcode => Container::Bgcode,
        }
    }
}

fn name(c: Container) -> &'static str {
    match c {
        Container::Text => "text",
        Container::Gzip => "gz",
        Container::Bgcode => "bgcode",
    }
}

impl FormatArgs {
    /// The target `-o OUT` names: `-` is standard output, stored as `--format` says (text by
    /// default); a file must be named for the container `--format` asks for.
    pub fn target(&self, output: &Path) -> Result<Target> {
        if output == Path::new("-") {
            return Ok(Target::Stdout(self.format.map_or(Container::Text, Format::container)));
        }
        if let Some(wanted) = self.format.map(Format::container) {
            let named = Container::of_output(output);
            if named != wanted {
                bail!(
                    "--format {} but -o {} is named for {}: a file's name says how it is stored (.gcode, .gcode.gz, .bgcode); --format is for -o -",
                    name(wanted),
                    output.display(),
                    name(named)
                );
            }
        }
        Ok(Target::File(output.to_path_buf()))
    }

    /// The target `--in-place` names: the input, refused with `--format`.
    pub fn in_place(&self, keep_backup: bool, force: bool) -> Result<Target> {
        if self.format.is_some() {
            bail!("--format does not go with --in-place: the file keeps the kind its name says")
        }
        Ok(Target::InPlace { keep_backup, force })
    }
}
