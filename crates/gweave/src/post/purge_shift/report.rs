//! What the pass did: one entry per change, and totals against a wipe tower.
//!
//! The entries are the only part of the pass that grows with the file (about 230 bytes of JSON
//! a change). [`ChangeLog`] keeps the first [`KEPT_CHANGES`] in memory and writes the rest, as
//! they come, as JSON lines to an unnamed temporary file, read back one at a time when the
//! report is serialised: memory stays bounded, and the JSON report still has every entry.

use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Seek, SeekFrom, Write};

use serde::ser::{Error as _, SerializeSeq};
use serde::{Serialize, Serializer};
use serde_json::value::RawValue;

use crate::gcode::layers::Feature;
use crate::post::warning::Warning;

/// Where a change was split into a move.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SplitPoint {
    /// Input line number of the move that was split.
    pub line: u64,
    /// Fraction of that move printed before the change.
    pub fraction: f64,
    /// The split point, mm (X, Y, Z).
    pub point_mm: [f64; 3],
}

/// The retractions carried with a moved change of tool, so that each tool keeps its own
/// (`docs/purge-shift.md`): E-only moves inserted around the change lines and where they were.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RetractionMove {
    /// Filament fed by the old tool right before the change lines, mm (negative: retracted).
    pub old_mm: f64,
    /// Fed by the new tool right after them, mm.
    pub new_mm: f64,
    /// Fed by the new tool where the change was, mm.
    pub settle_mm: f64,
    /// The file's E-only tool-change retraction taken out where the change was (the old tool
    /// made it at the new place), mm.
    pub dropped_mm: f64,
    /// The file's unretraction after the change taken out (the new tool made it at the new
    /// place), mm.
    pub absorbed_mm: f64,
    /// Lines inserted right before the change lines.
    pub lines_before: u64,
    /// Lines inserted right after them (before a fallback's lines).
    pub lines_after: u64,
    /// Lines inserted where the change was.
    pub settle_lines: u64,
    /// How far the first of them is after the first change line, in output lines.
    pub settle_offset: u64,
}

/// One change of tool or mix.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChangeReport {
    /// The tool before the change.
    pub from_tool: u32,
    /// The tool after it.
    pub to_tool: u32,
    /// Input line numbers of the lines that moved (the `T` and its mix definition).
    pub change_lines: Vec<u64>,
    /// Output line number of the first moved line.
    pub output_line: u64,
    /// Purge asked for, mm of filament.
    pub requested_mm: f64,
    /// Purge done: `moved_mm + fallback_mm`.
    pub achieved_mm: f64,
    /// What is missing of the purge after the fallback (`partial`: all that could not move).
    pub shortfall_mm: f64,
    /// Purge printed along the old colour's path, by moving the change.
    pub moved_mm: f64,
    /// Purge extruded by the `block` or `tower` fallback right after the change.
    pub fallback_mm: f64,
    /// Lines the fallback inserted after the change lines and the new tool's unretraction.
    pub fallback_lines: u64,
    /// The retractions moved with the change (none when it did not move, or kept its tool).
    pub retraction: Option<RetractionMove>,
    /// Purge asked for, mm^3.
    pub requested_mm3: f64,
    /// Purge done, mm^3.
    pub achieved_mm3: f64,
    /// Layer (0-based) and feature where the change now sits.
    pub layer: Option<u32>,
    /// The feature where the change now sits.
    pub feature: Feature,
    /// Input line number of the move the change now precedes (or splits).
    pub at_line: u64,
    /// Where a move was split to place the change inside it.
    pub split: Option<SplitPoint>,
    /// Why the walk back stopped before the full purge, when it did.
    pub stopped_by: Option<&'static str>,
    /// Washout model: fraction of the old colour still coming out where the new colour's own
    /// path begins (1 = no purge at all).
    pub residual_fraction: Option<f64>,
    /// Washout model: filament of the new colour's own path, mm, printed before the old colour
    /// falls below the tolerance (the visible transition).
    pub transition_mm: Option<f64>,
}

/// Entries held in memory; later ones go to a temporary file.
pub const KEPT_CHANGES: usize = 1000;

/// The per-change entries: the first [`KEPT_CHANGES`] in memory (this dereferences to them),
/// the rest spilled to a temporary file; all of them serialise, in order, as one JSON array.
#[derive(Debug, Default)]
pub struct ChangeLog {
    kept: Vec<ChangeReport>,
    spill: Option<BufWriter<File>>,
    total: usize,
    /// Lines written above the pass's output after it ran (a header), added to the spilled
    /// entries' `output_line` as they are read back.
    spilled_line_offset: u64,
}

impl ChangeLog {
    /// Adds an entry: in memory while there is room, else as a JSON line in the spill file.
    pub fn push(&mut self, change: ChangeReport) -> io::Result<()> {
        self.total += 1;
        if self.kept.len() < KEPT_CHANGES {
            self.kept.push(change);
            return Ok(());
        }
        let spill = match &mut self.spill {
            Some(s) => s,
            None => self.spill.insert(BufWriter::new(tempfile::tempfile()?)),
        };
        serde_json::to_writer(&mut *spill, &change)?;
        spill.write_all(b"\n")
    }

    /// All entries, those in memory and those spilled.
    pub fn total(&self) -> usize {
        self.total
    }

    /// The entries held in memory: the first [`KEPT_CHANGES`] changes (all of them when
    /// [`Self::spilled`] is 0; the rest are only in the JSON report).
    pub fn kept(&self) -> &[ChangeReport] {
        &self.kept
    }

    /// Entries in the spill file (0 for a file with up to [`KEPT_CHANGES`] changes).
    pub fn spilled(&self) -> usize {
        self.total - self.kept.len()
    }

    /// Lines were inserted above every change in the output (the run's header, written after
    /// the pass): the output line numbers move down by `lines`.
    pub fn offset_output_lines(&mut self, lines: u64) {
        for c in &mut self.kept {
            c.output_line += lines;
        }
        self.spilled_line_offset += lines;
    }

    /// Writes out what is buffered of the spill file (the pass calls it at the end).
    pub fn flush(&mut self) -> io::Result<()> {
        self.spill.as_mut().map_or(Ok(()), |s| s.flush())
    }
}

impl Serialize for ChangeLog {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.total))?;
        for c in &self.kept {
            seq.serialize_element(c)?;
        }
        if let Some(spill) = &self.spill {
            // `&File` reads and seeks through a shared reference; the pass flushed the buffer.
            let mut file = spill.get_ref();
            file.seek(SeekFrom::Start(0)).map_err(S::Error::custom)?;
            for line in BufReader::new(file).lines() {
                let line = line.map_err(S::Error::custom)?;
                // Written by `push` as one JSON object per line: passed on as it is, checked
                // but not rebuilt into a tree.
                if self.spilled_line_offset == 0 {
                    let entry: &RawValue = serde_json::from_str(&line).map_err(S::Error::custom)?;
                    seq.serialize_element(entry)?;
                } else {
                    let mut entry: serde_json::Value =
                        serde_json::from_str(&line).map_err(S::Error::custom)?;
                    if let Some(n) = entry.get_mut("output_line").and_then(|n| n.as_u64()) {
                        entry["output_line"] = (n + self.spilled_line_offset).into();
                    }
                    seq.serialize_element(&entry)?;
                }
            }
        }
        seq.end()
    }
}

/// The whole run.
#[derive(Debug, Serialize, Default)]
pub struct PurgeShiftReport {
    /// Every change of tool or mix, in file order.
    pub changes: ChangeLog,
    /// Changes outside the print proper (start/end G-code), left alone.
    pub untouched_changes: u64,
    /// Purge asked for over all changes, mm.
    pub requested_mm: f64,
    /// Purge done over all changes, mm.
    pub achieved_mm: f64,
    /// Purge missing over all changes, mm.
    pub shortfall_mm: f64,
    /// Of the achieved purge: moved into the old colour's path, and purged by the fallback.
    pub moved_mm: f64,
    /// Purged by the fallback, mm.
    pub fallback_mm: f64,
    /// Changes that got the whole purge (moved and fallback together).
    pub full_changes: u64,
    /// Filament a wipe tower purging the same amount would have wasted, and so what printing the
    /// purge inside the part saves: mm of filament and mm^3 (the moved purge; a fallback's
    /// purge is waste like the tower's).
    pub saved_mm: f64,
    /// What a tower would have wasted, mm^3.
    pub saved_mm3: f64,
    /// Filament diameter used for the volumes, mm.
    pub filament_diameter_mm: f64,
    /// Most lines ever held back at once (the bounded window).
    pub max_window_lines: usize,
    /// The first warnings (at most [`MAX_WARNINGS`]; every change's shortfall is in `changes`).
    pub warnings: Vec<Warning>,
    /// How many warnings there were in all.
    pub warnings_total: u64,
}

/// Warnings kept as text: past this they are only counted, so the report stays small.
pub const MAX_WARNINGS: usize = 1000;

impl PurgeShiftReport {
    /// Counts a change into the totals and logs its entry.
    pub(crate) fn add(&mut self, c: ChangeReport) -> io::Result<()> {
        self.requested_mm += c.requested_mm;
        self.achieved_mm += c.achieved_mm;
        self.shortfall_mm += c.shortfall_mm;
        self.moved_mm += c.moved_mm;
        self.fallback_mm += c.fallback_mm;
        self.full_changes += u64::from(c.shortfall_mm <= 1e-9);
        self.changes.push(c)
    }

    pub(crate) fn warn(&mut self, text: Warning) {
        self.warnings_total += 1;
        if self.warnings.len() < MAX_WARNINGS {
            self.warnings.push(text);
        }
    }

    /// A warning about the whole file, put before the per-change ones (the CLI shows the first
    /// few only).
    pub(crate) fn warn_first(&mut self, text: Warning) {
        self.warnings_total += 1;
        self.warnings.insert(0, text);
        self.warnings.truncate(MAX_WARNINGS);
    }

    /// A short human summary (what the CLI prints).
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let total = self.changes.total();
        let _ = writeln!(s, "changes moved    {} ({} with the full purge)", total, self.full_changes);
        let _ = writeln!(
            s,
            "purge            {:.2} of {:.2} mm requested (short by {:.2} mm)",
            self.achieved_mm, self.requested_mm, self.shortfall_mm
        );
        if self.fallback_mm > 0.0 {
            let _ = writeln!(
                s,
                "fallback         {:.2} mm purged after the change ({:.2} mm moved into the part)",
                self.fallback_mm, self.moved_mm
            );
        }
        let _ = writeln!(
            s,
            "saved vs tower   {:.2} mm of filament ({:.1} mm3, {} mm filament)",
            self.saved_mm, self.saved_mm3, self.filament_diameter_mm
        );
        if self.untouched_changes > 0 {
            let _ = writeln!(s, "outside print    {} changes left alone", self.untouched_changes);
        }
        let _ = writeln!(s, "window           at most {} lines held", self.max_window_lines);
        for c in self.changes.kept().iter().take(20) {
            let layer = c.layer.map_or("-".to_string(), |l| l.to_string());
            let _ = writeln!(
                s,
                "  T{}->T{}  line {:>7} -> {:>7}  layer {:>4}  {:<13} {:.3}/{:.3} mm{}",
                c.from_tool,
                c.to_tool,
                c.change_lines.first().copied().unwrap_or(0),
                c.output_line,
                layer,
                c.feature.name(),
                c.achieved_mm,
                c.requested_mm,
                c.residual_fraction.map(|r| format!("  residual {:.1} %", r * 100.0)).unwrap_or_default()
            );
        }
        if total > 20 {
            let _ = writeln!(s, "  ... {} more (see --json)", total - 20);
        }
        s
    }
}
