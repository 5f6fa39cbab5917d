//! Lines a lenient run read past: counted, the first one named, never dropped silently.
//!
//! A strict run ([`Strictness::Strict`]) stops at the first malformed line with
//! `file:line:column`. A lenient one hands such a line to its pass like any other (its good words
//! still count; its state is what the firmware would make of it) and
//! [`Counting`](crate::pass::Counting) tallies it, so that `gweave stats --lenient` and
//! `gweave preview --lenient` say how much of the file they could not read, as `sim` and
//! `estimate` do. The driver (`pass`) sits above this module and uses its counts.
//!
//! ```
//! use gweave::{Run, StatsPass, Strictness};
//!
//! let text = b"G1 X1 F600\nG1 X1..2\nG1 X3\n";
//! let mut pass = StatsPass::new(None);
//! let ran = Run::text(text).strictness(Strictness::Lenient).run(&mut pass).unwrap();
//! assert_eq!((ran.malformed.malformed_lines, ran.malformed.first_malformed_line), (1, Some(2)));
//! ```

use serde::Serialize;

use crate::gcode::diag::Severity;
use crate::gcode::line::Block;

/// How strictly to treat malformed lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Strictness {
    /// The first error-level diagnostic stops the run with file, line and column.
    #[default]
    Strict,
    /// Diagnostics are left to the pass (lint, lossless copy).
    Lenient,
}

/// How many lines could not be read, and the first of them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct Malformed {
    /// Lines that could not be read.
    pub malformed_lines: u64,
    /// The first of them, 1-based.
    pub first_malformed_line: Option<u64>,
}

impl Malformed {
    /// Counts malformed line `line` (1-based).
    pub fn add(&mut self, line: u64) {
        self.malformed_lines += 1;
        self.first_malformed_line.get_or_insert(line);
    }

    /// Adds another file's count (a comparison reads two files); the first line named stays
    /// the first file's.
    pub fn merge(&mut self, other: Malformed) {
        self.malformed_lines += other.malformed_lines;
        if self.first_malformed_line.is_none() {
            self.first_malformed_line = other.first_malformed_line;
        }
    }
}

/// Whether a parsed line counts as malformed: it carries an error-level diagnostic (a
/// malformed word, a bad checksum). A line over [`MAX_LINE`](crate::gcode::reader::MAX_LINE)
/// counts too, when its last piece arrives (`Pass::long_line`).
#[inline]
pub(crate) fn is_malformed(block: &Block) -> bool {
    block.diagnostics.iter().any(|d| d.finding.severity() == Severity::Error)
}

/// A report with the malformed lines of its lenient read, in one JSON object (the report's
/// fields and `malformed_lines`, `first_malformed_line`).
#[derive(Debug, Clone, Serialize)]
pub struct WithMalformed<T> {
    /// The command's report.
    #[serde(flatten)]
    pub report: T,
    /// The malformed lines of its read.
    #[serde(flatten)]
    pub malformed: Malformed,
}

/// A transform's report as `--json` writes it: with the lines its lenient run read past
/// ([`WithMalformed`]); a strict run's report as it is (its count is always zero).
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum Transformed<'a, T> {
    /// A strict run's report, as it is.
    Strict(&'a T),
    /// A lenient run's report, with the lines it read past.
    Lenient(WithMalformed<&'a T>),
}

impl<'a, T> Transformed<'a, T> {
    /// The report as `--json` writes it after a run of this strictness.
    pub fn new(report: &'a T, malformed: Malformed, strictness: Strictness) -> Self {
        match strictness {
            Strictness::Strict => Transformed::Strict(report),
            Strictness::Lenient => Transformed::Lenient(WithMalformed { report, malformed }),
        }
    }
}
