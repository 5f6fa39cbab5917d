//! One nozzle: the machine purge-shift is for, and the file sliced for several that it refuses.
//!
//! ## Why
//! The purge is the old colour still in the nozzle. On a mixing hotend (several inputs, one
//! nozzle) or a single-extruder multi-material printer (several filaments fed in turn into one
//! nozzle) the new colour comes out mixed with the old until that is flushed, and moving the
//! change earlier flushes it inside the part. On a machine with a nozzle per tool (a dual
//! extruder, a tool changer) nothing of the old colour is in the new nozzle: there is no purge to
//! move, and moving the change makes the new tool print the old tool's path *before* the file's
//! own `M109 T<n>` has heated its nozzle. The virtual printer's dual extruder refuses 13 cold
//! extrusions on Cura's dual-extrusion fixture purge-shifted by 2.5 mm. So such a file is refused
//! before anything is written, with the line that shows it and what to do instead.
//!
//! ## The evidence
//! - The slicer's setting: the PrusaSlicer family writes `; single_extruder_multi_material = 0`
//!   for a printer with a nozzle per extruder. It is evidence once the file changes to another
//!   tool after its first selection (a single-tool file has nothing to move); the refusal names
//!   that change's line. Not
//!   after `gweave mix`, which made the file one nozzle's and keeps the slicer's setting
//!   comments (its header line says it ran).
//! - The temperatures: `M104`/`M109` with `T<n>` set the nozzle of tool `n`. One nozzle has one
//!   temperature, so a file that holds two tools at different temperatures at once (compared
//!   at the first command after a run of temperature lines, which a slicer writes one tool a
//!   line; Cura's
//!   preheat of the next nozzle and standby of the last, a PrusaSlicer file's per-extruder
//!   temperatures) heats two nozzles. A file that sets every tool to the same temperature
//!   together (Slic3r's `M104 S200 T0`, `M104 S200 T1` at the start, written for every extruder
//!   it knows) may be one nozzle: it is accepted. `gweave mix` keeps only `T0`'s and turns the
//!   others into comments, so its output is accepted too. Tool temperatures without `T` are the
//!   active tool's and say nothing about how many nozzles there are.

use std::path::Path;

/// The PrusaSlicer family's setting for a printer with one nozzle shared by its extruders.
pub(crate) const SEMM_KEY: &str = "single_extruder_multi_material";

/// Tools whose temperature is followed (a file naming more is judged on the first ones).
const TOOLS: usize = 64;

/// What to do with a file for several nozzles (both refusals end with it).
const ADVICE: &str = "purge-shift moves colour changes on one nozzle (a mixing hotend, or a \
    single-extruder multi-material printer), where the old colour must be purged; on separate \
    nozzles it would make the new tool print before its nozzle is heated. Slice the file for a \
    single extruder multi material printer (PrusaSlicer: Printer Settings > General > Single \
    Extruder Multi Material), or run `gweave mix` on it first and purge-shift mix's output";

/// Why purge-shift refuses a file: it was sliced for a nozzle per tool (the module's
/// evidence). The driver names the file and the line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SeparateNozzles {
    /// The slicer's setting says so, and this line changes to another tool.
    #[error("the file was sliced for a nozzle per extruder (`; {SEMM_KEY} = 0`) and this line changes to T{tool}: {ADVICE}")]
    Setting {
        /// The tool changed to.
        tool: u32,
    },
    /// Two nozzles held at different temperatures at once (refused at the command after the
    /// temperature lines).
    #[error(
        "here, at the first command after the temperatures, T{tool}'s nozzle is at {celsius} °C \
         (set on line {line}) and T{other}'s at {other_celsius} °C (line {other_line}): the file \
         heats a nozzle per tool. {ADVICE}"
    )]
    Temperatures {
        /// The line that set the last temperature.
        line: u64,
        /// The tool it heats.
        tool: u32,
        /// To what, °C.
        celsius: f64,
        /// Another tool, held at another temperature.
        other: u32,
        /// Its temperature, °C.
        other_celsius: f64,
        /// The line that set it.
        other_line: u64,
    },
}

/// A tool's nozzle temperature as set by a line naming the tool.
#[derive(Debug, Clone, Copy)]
struct Heat {
    tool: u32,
    celsius: f64,
    line: u64,
}

/// Follows the evidence of separate nozzles through the file.
#[derive(Debug, Default)]
pub(crate) struct Nozzles {
    /// The slicer's setting says a nozzle per extruder (and no `gweave mix` ran since).
    separate_by_setting: bool,
    /// The temperature of each tool named, as last set.
    heats: Vec<Heat>,
    /// A temperature was set since the last comparison.
    unchecked: bool,
    /// A tool was selected (a change group was read).
    selected: bool,
}

impl Nozzles {
    /// The evidence in the file's ends: its settings `set` (with [`SEMM_KEY`] among the keys
    /// looked up) and `ends` (its header, where an earlier `gweave mix` wrote its line).
    pub(crate) fn new(set: &std::collections::BTreeMap<&str, String>, ends: &[u8]) -> Nozzles {
        let separate = set.get(SEMM_KEY).is_some_and(|v| v == "0");
        let mixed =
            || crate::post::metadata::earlier_runs(ends).is_ok_and(|runs| runs.iter().any(|r| r.is("mix")));
        Nozzles { separate_by_setting: separate && !mixed(), ..Nozzles::default() }
    }

    /// A line of a change group goes from tool `from` to `to`. The file's first selects the
    /// tool it prints with (PrusaSlicer starts a print on the second extruder with `T1`), the
    /// evidence is a change after it.
    pub(crate) fn tool_change(&mut self, from: u32, to: u32) -> Result<(), SeparateNozzles> {
        let first = !std::mem::replace(&mut self.selected, true);
        if self.separate_by_setting && from != to && !first {
            return Err(SeparateNozzles::Setting { tool: to });
        }
        Ok(())
    }

    /// Follows the line `block` (number `line`): a hotend temperature for a named tool. The
    /// temperatures are compared after a run of temperature lines, at the next command: a
    /// slicer sets its tools one line after the other (Slic3r's `M104 S210 T0`, `M104 S210 T1`),
    /// and one nozzle is between two temperatures only while it reads them.
    #[inline]
    pub(crate) fn line(
        &mut self,
        block: &crate::gcode::line::Block,
        line: u64,
    ) -> Result<(), SeparateNozzles> {
        let c = block.command;
        if c.is_m(104) || c.is_m(109) {
            return self.heat(block, line);
        }
        if self.unchecked && !block.is_empty() {
            self.unchecked = false;
            return self.compare();
        }
        Ok(())
    }

    /// A hotend temperature line (`block`, number `line`), kept if it names its tool.
    fn heat(&mut self, block: &crate::gcode::line::Block, line: u64) -> Result<(), SeparateNozzles> {
        // Marlin's `M109 R` waits for heating or cooling to the temperature; `S` wins.
        let Some(celsius) = block.get(b'S').or_else(|| block.get(b'R')).filter(|c| c.is_finite()) else {
            return Ok(());
        };
        let Some(tool) = block.get(b'T').filter(|t| (0.0..f64::from(u32::MAX)).contains(t)) else {
            return Ok(());
        };
        let heat = Heat { tool: tool as u32, celsius, line };
        match self.heats.iter().position(|h| h.tool == heat.tool) {
            Some(i) => self.heats[i] = heat,
            None if self.heats.len() < TOOLS => self.heats.push(heat),
            None => return Ok(()),
        }
        self.unchecked = true;
        Ok(())
    }

    /// Two nozzles held at different temperatures: the last one set, and another. Off (or a
    /// negative, meaningless target) holds no nozzle at a temperature.
    fn compare(&self) -> Result<(), SeparateNozzles> {
        let on = || self.heats.iter().filter(|h| h.celsius > 0.0);
        let Some(last) = on().max_by_key(|h| h.line) else { return Ok(()) };
        match on().find(|h| h.celsius != last.celsius) {
            Some(other) => Err(SeparateNozzles::Temperatures {
                line: last.line,
                tool: last.tool,
                celsius: last.celsius,
                other: other.tool,
                other_celsius: other.celsius,
                other_line: other.line,
            }),
            None => Ok(()),
        }
    }
}

/// The evidence `ends` (a file's ends, or all of a text) gives before the pass, `path` naming
/// it in errors: the settings looked up once for both checks of the file's ends.
pub(crate) fn ends_checks(ends: &[u8], path: &Path) -> crate::error::Result<Nozzles> {
    let set = super::checks::ends_settings(ends);
    super::checks::refuse_wipe_tower(&set, path)?;
    Ok(Nozzles::new(&set, ends))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::lexer::parse_line_lean;
    use crate::gcode::line::Block;
    use crate::gcode::reader::{LineReader, Part};

    /// The first refusal on `text`'s temperature lines, and its line.
    fn heats(text: &str) -> Option<(u64, SeparateNozzles)> {
        let mut nozzles = Nozzles::default();
        let mut reader = LineReader::new(text.as_bytes());
        let mut block = Block::default();
        while let Some(line) = reader.next_line().unwrap() {
            assert_eq!(line.part, Part::Whole);
            parse_line_lean(&line, &mut block);
            if let Err(e) = nozzles.line(&block, line.number) {
                return Some((line.number, e));
            }
        }
        None
    }

    #[test]
    fn two_nozzles_at_different_temperatures_are_refused_at_the_second() {
        // Cura: T1 preheated to T0's temperature, then T0 to standby while T1 prints.
        let cura = "M109 S215\nM104 T1 S215\nG1 X1 E1\nT1\nM109 S215\nM104 T0 S200\nM104 S195\nG1 E-6.5\n";
        let (line, e) = heats(cura).unwrap();
        assert_eq!(line, 8, "the command after the temperature lines");
        assert_eq!(
            e,
            SeparateNozzles::Temperatures {
                line: 6,
                tool: 0,
                celsius: 200.0,
                other: 1,
                other_celsius: 215.0,
                other_line: 2
            }
        );
        assert!(
            e.to_string().starts_with(
                "here, at the first command after the temperatures, T0's nozzle is at 200 °C (set on \
                 line 6) and T1's at 215 °C (line 2): "
            ),
            "{e}"
        );
    }

    #[test]
    fn every_tool_at_one_temperature_may_be_one_nozzle() {
        // Slic3r heats every extruder it knows, together; the end switches them off.
        let slic3r = "M104 S200 T0 ; set temperature\nM104 S200 T1\nG28\nM109 S200 T0\nM109 S200 T1\nG1 X1\n\
                      M104 S210 T0\n; comment\nM104 S210 T1\nG1 X2 E1\nT1\nG1 X3 E1\nM104 S0 T0\nG1 X4\nM84\n";
        assert_eq!(heats(slic3r), None);
        // Without T the line is the active tool's; a nozzle switched off holds no temperature.
        assert_eq!(heats("M104 T0 S215\nT1\nM104 S190\nG1 X1\nM104 T0 S0\nM104 T1 S190\nG1 X2\n"), None);
        // `gweave mix`'s output: only T0 named.
        assert_eq!(
            heats("M104 S215 T0\n;M104 S215 T1 ; gweave mix\nM109 S210 ; wait\nM104 S200 T0\nG1 X1\n"),
            None
        );
    }

    #[test]
    fn the_setting_refuses_a_change_of_tool_unless_mix_ran() {
        let mut set = std::collections::BTreeMap::new();
        set.insert(SEMM_KEY, "0".to_owned());
        let mut slicer = Nozzles::new(&set, b"; generated by PrusaSlicer\n");
        assert_eq!(slicer.tool_change(0, 0), Ok(()));
        assert_eq!(slicer.tool_change(0, 0), Ok(()));
        assert_eq!(slicer.tool_change(0, 1), Err(SeparateNozzles::Setting { tool: 1 }));
        // A print on the second extruder alone starts with `T1`: a selection, not a change.
        let mut second = Nozzles::new(&set, b"");
        assert_eq!(second.tool_change(0, 1), Ok(()));
        assert_eq!(second.tool_change(1, 0), Err(SeparateNozzles::Setting { tool: 0 }));
        let header = crate::post::metadata::header_line("mix -c mix.toml");
        let mut mixed = Nozzles::new(&set, format!("{header}\n; generated by PrusaSlicer\n").as_bytes());
        mixed.tool_change(0, 0).unwrap();
        assert_eq!(mixed.tool_change(0, 1), Ok(()));
        set.insert(SEMM_KEY, "1".to_owned());
        let mut semm = Nozzles::new(&set, b"");
        semm.tool_change(0, 0).unwrap();
        assert_eq!(semm.tool_change(0, 1), Ok(()));
    }
}
