//! The library's error type: every failure names the file and, for bad input, the line and column.

use std::io;
use std::path::{Path, PathBuf};

use crate::gcode::diag::Finding;

/// A result whose error is the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Why an engine operation failed; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: io::Error,
    },

    /// A line cannot be read (a strict run stops at the first).
    #[error("{}:{line}:{column}: {finding}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// The line number, from 1.
        line: u64,
        /// The column, from 1.
        column: u32,
        /// What is wrong.
        finding: Finding,
    },

    /// A pass refused a line (or, without a line, the end of the file): `source` is the pass's
    /// own typed error (`downcast_ref` it), the file and position the driver's.
    #[error("{}: {source}", place(path, *line, *column))]
    Pass {
        /// The file read.
        path: PathBuf,
        /// The 1-based line refused, if the refusal is about a line.
        line: Option<u64>,
        /// The 1-based column within it, if the pass knows one.
        column: Option<u32>,
        /// The pass's own error.
        source: Box<dyn std::error::Error + Send + Sync>,
    },

    // The messages below name the engine's options ([`Target::InPlace`](crate::gcode::writer::Target::InPlace) and its fields) in
    // words, not by a front end's spelling: the CLI's `--in-place` is Python's `in_place=True`.
    /// An output that is the input itself, not [`Target::InPlace`](crate::gcode::writer::Target::InPlace).
    #[error("refusing to overwrite the input file {}: the output names the file being read; name another output file, or replace the input in place", path.display())]
    WouldOverwriteInput {
        /// The input.
        path: PathBuf,
    },

    /// A read-only input for [`Target::InPlace`](crate::gcode::writer::Target::InPlace), without `force`.
    #[error("{} is read-only: it is replaced in place only when forced", path.display())]
    ReadOnly {
        /// The input.
        path: PathBuf,
    },

    /// An input for [`Target::InPlace`](crate::gcode::writer::Target::InPlace) that is not a
    /// file of the user's: a pipe, a device, or a system alias such as `/dev/stdin`.
    #[error("{} cannot be replaced in place: it is a pipe, a device or a system name of an open file (under /dev or /proc); name the file itself, or write the output elsewhere", path.display())]
    NotAFileToReplace {
        /// The input.
        path: PathBuf,
    },

    /// [`Target::InPlace`](crate::gcode::writer::Target::InPlace) found no free backup name for the input.
    #[error(
        "{} exists and is not a copy of the input, and {}.1 .. .{} are all taken: move old backups away or replace the input without a backup",
        path.display(),
        path.display(),
        slots
    )]
    BackupSlotsFull {
        /// The input.
        path: PathBuf,
        /// How many older backups are kept (`gcode::writer::BACKUP_SLOTS`).
        slots: u32,
    },

    /// [`Target::InPlace`](crate::gcode::writer::Target::InPlace) with standard input.
    #[error("replacing in place needs an input file")]
    InPlaceWithoutInput,

    /// A configuration file is invalid.
    #[error("{}: {message}", path.display())]
    Config {
        /// The configuration file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },

    /// An invalid argument (the message says which and why).
    #[error("{0}")]
    Invalid(String),

    /// A print-proper marker asked for is not in the file (or not in order).
    #[error("{}: the print-proper marker `;{marker}` {detail}", path.display())]
    MissingMarker {
        /// The file.
        path: PathBuf,
        /// The marker's text, without the `;`.
        marker: String,
        /// What is wrong: missing, or out of order.
        detail: String,
    },

    /// A command that writes `E` words was given a file whose extruder is another axis.
    #[error(
        "{}: the file is for {flavour}, whose extruder is the {} axis; this command writes E moves, which that machine would not extrude",
        path.display(),
        char::from(*letter)
    )]
    ForeignExtruder {
        /// The file.
        path: PathBuf,
        /// The file's firmware flavour.
        flavour: String,
        /// The letter of that firmware's extruder axis.
        letter: u8,
    },
}

/// `file`, `file:line` or `file:line:column`.
fn place(path: &Path, line: Option<u64>, column: Option<u32>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!("{}:{l}:{c}", path.display()),
        (Some(l), None) => format!("{}:{l}", path.display()),
        _ => path.display().to_string(),
    }
}

/// An error's message followed by its causes, `: `-separated, each once: a cause whose text
/// the message already holds is not repeated. A settings file's error is one line this way
/// (`printer.toml: [bed] x_mm = -1 is out of range: ...`).
pub fn with_causes(e: &(dyn std::error::Error + 'static)) -> String {
    let mut message = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !message.contains(&text) {
            message = format!("{message}: {text}");
        }
        cause = c.source();
    }
    message
}

impl Error {
    /// An [`Error::Io`] on `path`.
    pub fn io(path: impl AsRef<Path>, source: io::Error) -> Self {
        Error::Io { path: path.as_ref().to_path_buf(), source }
    }
}
