//! Placing a change: the walk back along the old colour's extruding moves to where the purge
//! is found, the split there, and what is written in its place (the held lines, the first half,
//! the change lines between the two parts of its retraction bracket, a fallback purge for what the
//! walk could not find, the second half, and the new tool brought to its parked retraction where
//! the change was). The module docs of `purge_shift` explain the rules; `split` the maths of the
//! split; `tool_retraction` the bracket.

use std::io::{self, Write};

use super::fallback::{write_fallback, Spot};
use super::report::{ChangeReport, RetractionMove, SplitPoint};
use super::split::{split, Splittable};
use super::tool_retraction::{write_bracket, Bracket, EWord};
use super::{Fallback, Held, Kind, PurgeShift, EPS_E_MM, KEPT_FEATURE, LAYER_CHANGE};
use crate::gcode::state::{X, Y, Z};
use crate::pass::OwnedLine;
use crate::post::purge_block::{purge_start_pos, PurgeStart};
use crate::post::warning::{Shortfall, Warning};

impl PurgeShift {
    /// Walks back from the change, places it, writes the window and the group.
    pub(super) fn shift(
        &mut self,
        out: &mut dyn Write,
        from_tool: u32,
        group: &[OwnedLine],
    ) -> io::Result<()> {
        let to_tool = self.colour.tool;
        let (requested_mm, known) = self.rules.purge_mm(from_tool, to_tool);
        if !known {
            self.report.warn(Warning::NoPurgeAmount {
                line: group[0].number,
                from_tool,
                to_tool,
                used_mm: requested_mm,
            });
        }
        // Walk back: `need` is what is still to be found.
        let mut need = requested_mm;
        let mut place: Option<(usize, Option<f64>)> = None;
        let mut earliest = None;
        // Only what leaves the nozzle counts: an extrusion first refills the retraction in
        // force before it, and the purge is the end of the move, past that refill.
        for i in (0..self.window.len()).rev() {
            let (e_mm, purge_mm) = (self.window[i].e_mm(), self.window[i].purge_mm());
            if purge_mm <= 0.0 {
                continue;
            }
            if purge_mm >= need - EPS_E_MM {
                let head = (e_mm - need).max(0.0);
                place = Some(if head <= EPS_E_MM { (i, None) } else { (i, Some(head / e_mm)) });
                need = 0.0;
                break;
            }
            need -= purge_mm;
            earliest = Some(i);
        }
        let place = place.or(earliest.map(|i| (i, None)));
        let moved_mm = requested_mm - need;
        let mut change = ChangeReport {
            from_tool,
            to_tool,
            change_lines: group.iter().map(|l| l.number).collect(),
            output_line: 0,
            requested_mm,
            achieved_mm: moved_mm,
            shortfall_mm: need,
            moved_mm,
            fallback_mm: 0.0,
            fallback_lines: 0,
            retraction: None,
            requested_mm3: self.rules.mm3(requested_mm),
            achieved_mm3: 0.0,
            layer: self.group_layer,
            feature: self.group_feature,
            at_line: group[0].number,
            split: None,
            stopped_by: (need > 0.0).then_some(self.floor),
            residual_fraction: None,
            transition_mm: None,
        };
        let held: Vec<Held> = self.window.drain(..).collect();
        self.window_purge_mm = 0.0;
        let (at, fraction) = place.unwrap_or((held.len(), None));
        // The held lines after the change's new place (after the first half of a split).
        let moved_from = if fraction.is_some() && at < held.len() { at + 1 } else { at };
        // The slicer's tool-change retraction: the E-only retractions after the last line that
        // feeds forward, taken out where the change was (the old tool makes it at the new place).
        let tail = (moved_from..held.len()).rev().take_while(|&i| held[i].feeds().fed_mm <= 0.0).last();
        let drops = |i: usize| {
            tail.is_some_and(|t| i >= t) && held[i].feeds().e_only.is_some() && held[i].feeds().fed_mm < 0.0
        };
        // Each tool keeps its retraction (the tool_retraction module): what the old tool had in
        // force where the change now goes, inside or before an extrusion.
        let bracket = held.get(at).filter(|_| from_tool != to_tool).map(|h| {
            let head_mm = fraction.map_or(0.0, |t| t * h.e_mm());
            let r_place_mm = (h.retracted_mm - head_mm).max(0.0);
            let dropped_mm: f64 =
                (moved_from..held.len()).filter(|&i| drops(i)).map(|i| -held[i].feeds().fed_mm).sum();
            Bracket::new(r_place_mm, self.group_retracted_mm, self.group_parked_mm, dropped_mm)
        });
        let feed_mm_min = self.rules.block.retract_feed_mm_min;
        // Where the machine is when the change runs: before the move it now precedes, at the
        // split point, or (not moved) where the change was.
        let mut spot = self.group_spot;
        if let Some(h) = held.get(at) {
            change.layer = h.layer;
            change.feature = h.feature;
            change.at_line = h.number;
            if let Kind::Extrude { split: s, .. } = &h.kind {
                spot = Some(spot_of(s, &s.mv.from));
            }
        }
        for h in &held[..at] {
            self.emit_held(out, h)?;
        }
        let mut rest = at;
        if let (Some(t), Some(h)) = (fraction, held.get(at)) {
            if let Kind::Extrude { split: s, .. } = &h.kind {
                let halves = split(self.text.bytes(h.text), s, t);
                self.emitted.line(out, &halves.first, self.text.eol(h.text))?;
                let at_split = spot_of(s, &s.end_of(&halves.first));
                let lines = bracket.map(|b| (b, write_bracket(&at_split, b.old_mm, b.new_mm, feed_mm_min)));
                self.emit_change(out, group, &mut change, Some(at_split), lines)?;
                match &halves.second {
                    Some(second) => self.emitted.line(out, second, self.text.eol(h.text))?,
                    None => self.emit_held(out, h)?,
                }
                let p = halves.point;
                change.split = Some(SplitPoint { line: h.number, fraction: t, point_mm: [p[X], p[Y], p[Z]] });
                rest = at + 1;
            }
        }
        if change.split.is_none() {
            let lines =
                bracket.zip(spot).map(|(b, s)| (b, write_bracket(&s, b.old_mm, b.new_mm, feed_mm_min)));
            self.emit_change(out, group, &mut change, spot, lines)?;
        }
        for (i, h) in held.iter().enumerate().skip(rest) {
            match h.feeds().e_only.filter(|_| bracket.is_some() && drops(i)) {
                Some(e) => {
                    let eol = self.text.eol(h.text).to_vec();
                    self.emit_text(out, &e.feeding(self.text.bytes(h.text), 0.0), &eol)?;
                    if !e.relative_e {
                        self.e_reset = Some(e.e_after());
                    }
                }
                None => {
                    let reset = self.owed_e_reset(h.feeds().e_word);
                    if !reset.is_empty() {
                        let eol = self.text.eol(h.text).to_vec();
                        self.emit_text(out, &reset, &eol)?;
                    }
                    self.emit_held(out, h)?;
                }
            }
        }
        self.owed_mm = bracket.map_or(0.0, |b| b.absorbed_mm);
        // Where the change was, the new tool is brought to the retraction it had parked.
        if let (Some(b), Some(here)) = (bracket, self.group_spot) {
            let [mut head, tail] = write_bracket(&here, 0.0, b.settle_mm, feed_mm_min);
            if !head.is_empty() {
                // Its E words are the file's: E put back first if a line was taken out.
                head.splice(0..0, self.owed_e_reset(EWord::Reads));
            }
            let eol = group.last().map_or_else(|| b"\n".to_vec(), |l| l.eol.clone());
            let offset = self.emitted.lines() + 1 - change.output_line;
            let written = self.emit_text(out, &head, &eol)? + self.emit_text(out, &tail, &eol)?;
            if let Some(r) = change.retraction.as_mut().filter(|_| written > 0) {
                (r.settle_lines, r.settle_offset) = (written, offset);
            }
        }
        self.text.written_up_to(self.window.front().map(|f| f.text));
        self.floor = "the previous change";
        change.achieved_mm3 = self.rules.mm3(change.achieved_mm);
        if let Some(w) = &self.rules.washout {
            change.residual_fraction = Some(w.residual_fraction(change.achieved_mm3));
            let clean_mm3 = w.purge_for_tolerance_mm3(self.rules.tolerance).unwrap_or(0.0);
            change.transition_mm = Some((clean_mm3 - change.achieved_mm3).max(0.0) / self.rules.mm3(1.0));
        }
        self.report.add(change)
    }

    /// Writes the change lines between the two parts of its retraction bracket, then the
    /// fallback purge of what the move back could not find, and warns about that shortfall.
    fn emit_change(
        &mut self,
        out: &mut dyn Write,
        group: &[OwnedLine],
        change: &mut ChangeReport,
        spot: Option<Spot>,
        bracket: Option<(Bracket, [Vec<u8>; 2])>,
    ) -> io::Result<()> {
        let eol = group.last().map_or_else(|| b"\n".to_vec(), |l| l.eol.clone());
        let (b, [before, after]) = match bracket {
            Some((b, lines)) => (Some(b), lines),
            None => (None, Default::default()),
        };
        let lines_before = self.emit_text(out, &before, &eol)?;
        change.output_line = self.emitted.lines() + 1;
        for line in group {
            self.emit_line(out, line)?;
        }
        let lines_after = self.emit_text(out, &after, &eol)?;
        change.retraction = b.filter(|_| lines_before + lines_after > 0).map(|b| RetractionMove {
            old_mm: b.old_mm,
            new_mm: b.new_mm,
            settle_mm: b.settle_mm,
            dropped_mm: b.dropped_mm,
            absorbed_mm: b.absorbed_mm,
            lines_before,
            lines_after,
            settle_lines: 0,
            settle_offset: 0,
        });
        let short_mm = change.shortfall_mm;
        if short_mm <= 1e-9 {
            return Ok(());
        }
        let (from, to) = (change.from_tool, change.to_tool);
        let label = format!("T{from}->T{to} shortfall");
        let text = spot.and_then(|spot| {
            write_fallback(&self.rules, &mut self.env, &spot, change.layer, short_mm, &label)
        });
        let then = match (&text, spot) {
            (Some(_), _) => Shortfall::Purged(self.rules.fallback.name()),
            (None, Some(s)) if s.inches && self.rules.fallback != Fallback::Partial => Shortfall::Inches,
            // A change that opens its layer, as `gweave mix` writes them, cannot move at all
            // unless the purge may reach into the layer below.
            _ if change.moved_mm == 0.0 && change.stopped_by == Some(LAYER_CHANGE) => {
                Shortfall::OpensItsLayer
            }
            _ if change.stopped_by == Some(KEPT_FEATURE) => Shortfall::KeptOffAFeature,
            _ => Shortfall::Accepted,
        };
        self.report.warn(Warning::PurgeShort {
            layer: change.layer,
            line: change.change_lines[0],
            from_tool: from,
            to_tool: to,
            short_mm,
            moved_mm: change.moved_mm,
            requested_mm: change.requested_mm,
            stopped_by: change.stopped_by.unwrap_or_default(),
            then,
        });
        if let Some(text) = text {
            for line in text.split(|&b| b == b'\n').filter(|l| !l.is_empty()) {
                self.emit(out, line, &eol)?;
                change.fallback_lines += 1;
            }
            change.fallback_mm = short_mm;
            change.achieved_mm += short_mm;
            change.shortfall_mm = 0.0;
        }
        Ok(())
    }
}

/// The machine at `pos` on the held move `s` (the move's own modes; no retraction in force
/// before an extruding move).
fn spot_of(s: &Splittable, pos: &crate::gcode::state::Position) -> Spot {
    Spot {
        start: PurgeStart {
            pos: purge_start_pos(pos),
            absolute_xyz: !s.relative_axes,
            relative_e: s.relative_e,
            feed_mm_min: s.mv.feed_mm_min,
            rapid_mode: s.mv.rapid,
            retracted_mm: 0.0,
        },
        inches: s.inches,
    }
}
