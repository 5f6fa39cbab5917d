//! What the pass did: one entry per change, and totals against a wipe tower.

use serde::Serialize;

use crate::gcode::layers::Feature;

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

/// One change of tool or mix.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChangeReport {
    pub from_tool: u32,
    pub to_tool: u32,
    /// Input line numbers of the lines that moved (the `T` and its mix definition).
    pub change_lines: Vec<u64>,
    /// Output line number of the first moved line.
    pub output_line: u64,
    pub requested_mm: f64,
    pub achieved_mm: f64,
    pub shortfall_mm: f64,
    pub requested_mm3: f64,
    pub achieved_mm3: f64,
    /// Layer (0-based) and feature where the change now sits.
    pub layer: Option<u32>,
    pub feature: Feature,
    /// Input line number of the move the change now precedes (or splits).
    pub at_line: u64,
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

/// The whole run.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct PurgeShiftReport {
    pub changes: Vec<ChangeReport>,
    /// Changes outside the print proper (start/end G-code), left alone.
    pub untouched_changes: u64,
    pub requested_mm: f64,
    pub achieved_mm: f64,
    pub shortfall_mm: f64,
    /// Filament a wipe tower purging the same amount would have wasted, and so what printing the
    /// purge inside the part saves: mm of filament and mm^3.
    pub saved_mm: f64,
    pub saved_mm3: f64,
    pub filament_diameter_mm: f64,
    /// Most lines ever held back at once (the bounded window).
    pub max_window_lines: usize,
    /// The first warnings (at most [`MAX_WARNINGS`]; every change's shortfall is in `changes`).
    pub warnings: Vec<String>,
    /// How many warnings there were in all.
    pub warnings_total: u64,
}

/// Warnings kept as text: past this they are only counted, so the report stays small.
pub const MAX_WARNINGS: usize = 1000;

impl PurgeShiftReport {
    pub(crate) fn warn(&mut self, text: String) {
        self.warnings_total += 1;
        if self.warnings.len() < MAX_WARNINGS {
            self.warnings.push(text);
        }
    }

    /// A short human summary (what the CLI prints).
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let full = self.changes.iter().filter(|c| c.shortfall_mm <= 1e-9).count();
        let _ = writeln!(s, "changes moved    {} ({} with the full purge)", self.changes.len(), full);
        let _ = writeln!(
            s,
            "purge            {:.2} of {:.2} mm requested (short by {:.2} mm)",
            self.achieved_mm, self.requested_mm, self.shortfall_mm
        );
        let _ = writeln!(
            s,
            "saved vs tower   {:.2} mm of filament ({:.1} mm3, {} mm filament)",
            self.saved_mm, self.saved_mm3, self.filament_diameter_mm
        );
        if self.untouched_changes > 0 {
            let _ = writeln!(s, "outside print    {} changes left alone", self.untouched_changes);
        }
        let _ = writeln!(s, "window           at most {} lines held", self.max_window_lines);
        for c in self.changes.iter().take(20) {
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
        if self.changes.len() > 20 {
            let _ = writeln!(s, "  ... {} more (see --json)", self.changes.len() - 20);
        }
        s
    }
}
