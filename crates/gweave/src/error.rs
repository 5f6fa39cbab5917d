//! The library's error type: every failure names the file and, for bad input, the line and column.

use std::io;
use std::path::{Path, PathBuf};

use crate::gcode::diag::Finding;

pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: io::Error },

    #[error("{}:{line}:{column}: {finding}", path.display())]
    Syntax { path: PathBuf, line: u64, column: u32, finding: Finding },

    /// A pass refused a line (or, without a line, the end of the file): `source` is the pass's
    /// own typed error (`downcast_ref` it), the file and position the driver's.
    #[error("{}: {source}", place(path, *line, *column))]
    Pass {
        path: PathBuf,
        line: Option<u64>,
        column: Option<u32>,
        source: Box<dyn std::error::Error + Send + Sync>,
    },

    #[error("refusing to overwrite the input {} (use --in-place to replace it)", path.display())]
    WouldOverwriteInput { path: PathBuf },

    #[error("{} is read-only: --in-place would replace it (add --force to replace it anyway)", path.display())]
    ReadOnly { path: PathBuf },

    #[error(
        "{} exists and is not a copy of the input, and {}.1 .. .{} are all taken: move old backups away or use --no-backup",
        path.display(),
        path.display(),
        crate::gcode::writer::BACKUP_SLOTS
    )]
    BackupSlotsFull { path: PathBuf },

    #[error("--in-place needs an input file")]
    InPlaceWithoutInput,

    #[error("{}: {message}", path.display())]
    Config { path: PathBuf, message: String },

    #[error("{0}")]
    Invalid(String),

    /// A print-proper marker asked for is not in the file (or not in order).
    #[error("{}: the print-proper marker `;{marker}` {detail}", path.display())]
    MissingMarker { path: PathBuf, marker: String, detail: String },

    /// A command that writes `E` words was given a file whose extruder is another axis.
    #[error(
        "{}: the file is for {flavour}, whose extruder is the {} axis; this command writes E moves, which that machine would not extrude",
        path.display(),
        char::from(*letter)
    )]
    ForeignExtruder { path: PathBuf, flavour: String, letter: u8 },
}

/// `file`, `file:line` or `file:line:column`.
fn place(path: &Path, line: Option<u64>, column: Option<u32>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!("{}:{l}:{c}", path.display()),
        (Some(l), None) => format!("{}:{l}", path.display()),
        _ => path.display().to_string(),
    }
}

impl Error {
    pub fn io(path: impl AsRef<Path>, source: io::Error) -> Self {
        Error::Io { path: path.as_ref().to_path_buf(), source }
    }
}
