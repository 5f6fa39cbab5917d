//! The sum over several files of what `stats` and `check` report for each (`gweave stats
//! *.gcode`, `gweave check a.gcode b.gcode`): the figures that add up (lines, filament,
//! distances, times, findings); layers and extents, which do not, are left per file.

use serde::Serialize;

use crate::check::CheckReport;
use crate::malformed::WithMalformed;
use crate::stats::{Stats, ToolFilament};

/// `stats` over several files.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct StatsTotal {
    /// Files read.
    pub files: usize,
    /// Bytes over every file.
    pub bytes: u64,
    /// Lines over every file.
    pub lines: u64,
    /// Tool changes over every file.
    pub tool_changes: u64,
    /// Per tool number, over every file that used it.
    pub filament: Vec<ToolFilament>,
    /// Length of extruding moves, mm.
    pub print_mm: f64,
    /// Length of travel moves, mm.
    pub travel_mm: f64,
    /// Print time as length over feed rate, s.
    pub time_s: f64,
    /// Lines a lenient read could not use, over every file.
    pub malformed_lines: u64,
}

impl StatsTotal {
    /// The total of `files`.
    pub fn of<'a>(files: impl IntoIterator<Item = &'a WithMalformed<Stats>>) -> StatsTotal {
        let mut t = StatsTotal::default();
        for f in files {
            let s = &f.report;
            t.files += 1;
            t.bytes += s.bytes;
            t.lines += s.lines;
            t.tool_changes += u64::from(s.tool_changes);
            t.print_mm += s.print_mm;
            t.travel_mm += s.travel_mm;
            t.time_s += s.time_s;
            t.malformed_lines += f.malformed.malformed_lines;
            for tf in &s.filament {
                match t.filament.iter_mut().find(|x| x.tool == tf.tool) {
                    Some(x) => {
                        x.extruded_mm += tf.extruded_mm;
                        x.extruded_mm3 += tf.extruded_mm3;
                        x.fed_moving_mm += tf.fed_moving_mm;
                        x.primed_mm += tf.primed_mm;
                        x.as_prusaslicer_mm += tf.as_prusaslicer_mm;
                    }
                    None => t.filament.push(tf.clone()),
                }
            }
        }
        t.filament.sort_by_key(|x| x.tool);
        t
    }
}

/// `check` over several files.
#[derive(Debug, Clone, Default, Serialize, PartialEq, Eq)]
pub struct CheckTotal {
    /// Files checked.
    pub files: usize,
    /// Files with an error (or, with `strict`, a warning): those the exit code is 1 for.
    pub failed_files: usize,
    /// Lines over every file.
    pub lines: u64,
    /// Error-level findings over every file.
    pub errors: u64,
    /// Warning-level findings over every file.
    pub warnings: u64,
}

impl CheckTotal {
    /// The total of `reports`; with `strict` a warning fails a file too.
    pub fn of<'a>(reports: impl IntoIterator<Item = &'a CheckReport>, strict: bool) -> CheckTotal {
        let mut t = CheckTotal::default();
        for r in reports {
            t.files += 1;
            t.failed_files += usize::from(r.failed(strict));
            t.lines += r.lines;
            t.errors += r.errors;
            t.warnings += r.warnings;
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_total_counts_failed_files_as_the_exit_code_does() {
        let clean = CheckReport { lines: 10, ..Default::default() };
        let warned = CheckReport { lines: 5, warnings: 2, ..Default::default() };
        let failed = CheckReport { lines: 7, errors: 1, ..Default::default() };
        let t = CheckTotal::of([&clean, &warned, &failed], false);
        assert_eq!(t, CheckTotal { files: 3, failed_files: 1, lines: 22, errors: 1, warnings: 2 });
        assert_eq!(CheckTotal::of([&clean, &warned, &failed], true).failed_files, 2);
    }
}
