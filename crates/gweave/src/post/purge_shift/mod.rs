//! `purge-shift`: multi-colour on a mixing hotend without a wipe tower (the purge-shift seed, docs/seeds.md).
//!
//! After a change of tool or mix the old colour still fills the nozzle. Instead of purging it
//! into a tower, this pass moves every change *earlier* in the file by the purge amount: it walks
//! back along the old colour's extruding moves, summing what they put out of the nozzle, until the
//! purge is reached, splits that move at the exact point (the `split` module explains the maths) and puts the
//! change lines there. The purge is then printed inside the part, with the old colour's path, and
//! the new colour comes out clean where its own path begins.
//!
//! ## What moves and what stays
//! Only the *change lines* move: the `T<n>` and the mixing lines that belong to it (`M163`,
//! `M164`, `M165`, `M567`, `M563` directly before or after it, with nothing but comments in
//! between). Whether such a group is a change is decided by following the mixing state
//! ([`crate::colour::dialect::MixingState`]): the tool number, the active Marlin mix and the
//! active RepRapFirmware mix before and after the group must differ. Everything else a slicer
//! writes around a tool change (retract, `G92 E0`, travel, temperature for the next tool,
//! unretract) stays where it is: the travel belongs to the new colour's path. A retraction
//! belongs to the tool that makes it, though, so a moved change takes the tool-change retraction
//! and the new tool's unretraction with it (E-only moves at the new place, the file's taken out
//! where it was), leaving every tool with its own retraction (the `tool_retraction` module).
//!
//! ## Rules
//! - Only extruding moves (positive E with XY motion) count, and only for what leaves the nozzle:
//!   an extrusion made with a retraction in force first refills it, and that part is no purge
//!   (a refill prints nothing of the old colour). Retractions, unretractions,
//!   `G10`/`G11`, travels and extrude-only primes do not. The change is always put inside or
//!   directly before an extruding move, never inside a retract/travel/unretract sequence.
//! - The walk back stops at a layer change (unless `cross_layers`, then at the second one), at an
//!   extruding move whose feature is not allowed (default: the outer wall, so the colour seam stays
//!   inside), at the previous change, at homing, at a line whose meaning depends on the active tool
//!   (`M104`/`M109`/`M221`/`M900` without `T`), at mixing lines that are not part of the change
//!   (the change must not be moved before the definition of its own tool), at numbered or
//!   checksummed moves (which cannot be rewritten), at a `G10`/`G11` firmware retraction (kept
//!   per tool by the firmware), and outside the print proper.
//! - Too little room: the change goes as far back as allowed, a warning names layer, line and
//!   shortfall, and the fallback applies: accept the shortfall (`partial`), or purge it right
//!   after the change in a purge block (`block`) or on a small tower beside the part (`tower`),
//!   returning to the exact position (the `fallback` module).
//!
//! - A file sliced for a nozzle per tool (a dual extruder) is refused: there is nothing to purge,
//!   and a moved change would print before the new nozzle is heated (the `nozzles` module).
//!
//! ## Bounded memory
//! The pass streams. It holds back only the lines a later change could still be moved before:
//! a line is written out as soon as the purge held after it reaches the largest purge
//! any change can ask for, or when a barrier above passes. With layer crossing the window also
//! never reaches back past the previous layer's start, and `max_window_lines` caps it in any case.
//! So memory is the purge length plus at most one layer of lines (their text in one buffer of at
//! most twice theirs and 64 KiB, the `held_text` module), whatever the file size; the
//! report's `max_window_lines` says how many lines were ever held at once.
//!
//! ```
//! use gweave::post::purge_shift::{purge_shift_bytes, Rules};
//! let input = "M83\n;LAYER_CHANGE\n;TYPE:Perimeter\nG1 X0 Y0\nG1 X10 E1\nG1 X20 E1\nT1\nG1 X30 E1\n";
//! let (out, report) = purge_shift_bytes(Rules::fixed(1.5).unwrap(), input.as_bytes()).unwrap();
//! let out = String::from_utf8(out).unwrap();
//! assert_eq!(out, "M83\n;LAYER_CHANGE\n;TYPE:Perimeter\nG1 X0 Y0\nG1 X5 E0.5\nT1\nG1 X10 E0.5\nG1 X20 E1\nG1 X30 E1\n");
//! assert_eq!(report.changes.kept()[0].achieved_mm, 1.5);
//! ```

mod checks;
pub(crate) mod config;
mod fallback;
pub mod held_text;
mod nozzles;
mod options;
mod place;
pub mod report;
mod split;
mod tool_retraction;

use std::collections::VecDeque;
use std::io::{self, Write};
use std::path::Path;

pub use config::{ConfigError, Fallback, PurgeShiftConfig, Rules, TowerConfig};
pub use nozzles::SeparateNozzles;
pub use options::PurgeShiftOptions;
pub use report::{ChangeReport, PurgeShiftReport, RetractionMove, SplitPoint};

use crate::colour::dialect::MixingState;
use crate::eol::Eol;
use crate::error::Result;
use crate::firmware::MixingCode;
use crate::gcode::layers::{Feature, Region};
use crate::gcode::line::Block;
use crate::gcode::reader::RawLine;
use crate::gcode::retraction::ToolRetractions;
use crate::gcode::state::{Effect, StateOptions};
use crate::pass::{Ctx, Flow, OwnedLine, Pass, PassError, Step};
use crate::post::purge_block::{purge_start_pos, PurgeStart};
use crate::run::IN_MEMORY;
use crate::run::{Ran, Run, Source};
use checks::{require_markers, FeatureComments};
use fallback::{Spot, Surroundings};
use held_text::{HeldText, TextRef};
use nozzles::Nozzles;
use split::Splittable;
use tool_retraction::{EWord, Feeds};

/// What stops the walk back at a layer change (the report's `stopped_by`).
const LAYER_CHANGE: &str = "a layer change";
/// What stops a purge at an extrusion of a feature the rules keep it off (the outer wall by
/// default).
const KEPT_FEATURE: &str = "a feature that may not take the purge";
/// Extrusion below this is a rounding remainder, not a piece of move worth splitting off, mm.
const EPS_E_MM: f64 = 1e-6;
/// Mixing inputs and virtual tools followed to recognise changes of mix (Marlin allows up to 6
/// inputs in `M165` and 16 virtual tools by default; more costs nothing).
const MIX_INPUTS: usize = 8;
const MIX_TOOLS: usize = 64;

/// What a held line is to the walk back.
#[derive(Debug, Clone)]
enum Kind {
    /// An extruding move of an allowed feature: counts, and may be split.
    Extrude { e_mm: f64, split: Splittable },
    /// Passed over by the walk (travel, retraction, comments, `G92`...), with what it feeds
    /// and how the pass may rewrite it.
    Other(Feeds),
}

#[derive(Debug, Clone)]
struct Held {
    /// The line's text, in [`PurgeShift::text`].
    text: TextRef,
    /// Its number in the input (a line the pass wrote: the number of the line it stands for).
    number: u64,
    kind: Kind,
    layer: Option<u32>,
    feature: Feature,
    seq: u64,
    /// The active tool's retraction in force before the line (in the input), mm.
    retracted_mm: f64,
}

impl Held {
    fn e_mm(&self) -> f64 {
        match self.kind {
            Kind::Extrude { e_mm, .. } => e_mm,
            Kind::Other(_) => 0.0,
        }
    }

    /// What the line feeds, and how the pass may rewrite it. An extrusion feeds its E forwards
    /// and names it: it is never one of the E-only moves the pass takes out, so it does not
    /// carry the 50 bytes of [`Feeds`] that four lines in five would copy for nothing.
    fn feeds(&self) -> Feeds {
        match self.kind {
            Kind::Extrude { e_mm, .. } => Feeds { fed_mm: e_mm, e_only: None, e_word: EWord::Reads },
            Kind::Other(feeds) => feeds,
        }
    }

    /// What the line puts out of the nozzle, mm: its extrusion beyond the refill of the
    /// retraction in force before it. The first `retracted_mm` of its feed only bring the
    /// filament back to the nozzle (nothing of the old colour comes out there), so only the
    /// rest is purge.
    fn purge_mm(&self) -> f64 {
        (self.e_mm() - self.retracted_mm).max(0.0)
    }
}

/// What selects the colour: the tool, the active Marlin mix, the active RepRapFirmware mix.
#[derive(Debug, Clone, PartialEq)]
struct Colour {
    tool: u32,
    marlin: Vec<f64>,
    rrf: Option<Vec<f64>>,
}

/// The purge-shift pass. Run it over a file with [`purge_shift`] (a [`crate::run::Run`] says
/// the input, the output and the strictness), or over text with [`purge_shift_bytes`].
pub struct PurgeShift {
    rules: Rules,
    window: VecDeque<Held>,
    /// The held lines' text.
    text: HeldText,
    /// What the held lines put out of the nozzle (`Held::purge_mm`), mm.
    window_purge_mm: f64,
    /// Why the window starts where it does (the last barrier).
    floor: &'static str,
    layer_start_seq: Option<u64>,
    seq: u64,
    group: Vec<OwnedLine>,
    group_tail: Vec<OwnedLine>,
    group_before: Option<Colour>,
    /// The group started inside the print proper.
    group_in_print: bool,
    /// Where the group stands in the input: the machine, the layer and the feature there.
    group_spot: Option<Spot>,
    group_layer: Option<u32>,
    group_feature: Feature,
    env: Surroundings,
    mixing: MixingState,
    colour: Colour,
    /// Lines written, with the ending each had.
    emitted: Eol,
    report: PurgeShiftReport,
    features: FeatureComments,
    /// The nozzle's retraction and each tool's, as the input has them.
    tools: ToolRetractions,
    /// The active tool's retraction before the line being read, mm.
    line_retracted_mm: f64,
    /// The old tool's retraction in force at the group, and what the new tool has parked, mm.
    group_retracted_mm: f64,
    group_parked_mm: f64,
    /// What is still to be taken out of the file's unretraction after the last moved change
    /// (the new tool made it at the new place), mm.
    owed_mm: f64,
    /// The file's E (file units) a `G92 E` must put back before the next line that reads E,
    /// after an E-only move was taken out in absolute E.
    e_reset: Option<f64>,
    /// The evidence of a nozzle per tool, which the pass refuses (the nozzles module).
    nozzles: Nozzles,
}

impl PurgeShift {
    /// The pass, with these rules.
    pub fn new(rules: Rules) -> Self {
        // MixingState::new only fails for zero tools.
        let mixing = MixingState::new(MIX_INPUTS, MIX_TOOLS).expect("constant sizes are valid");
        let colour = Colour { tool: 0, marlin: mixing.active_mix().ratios().to_vec(), rrf: None };
        let report =
            PurgeShiftReport { filament_diameter_mm: rules.filament_diameter_mm(), ..Default::default() };
        PurgeShift {
            rules,
            window: VecDeque::new(),
            text: HeldText::default(),
            window_purge_mm: 0.0,
            floor: "start of the print",
            layer_start_seq: None,
            seq: 0,
            group: Vec::new(),
            group_tail: Vec::new(),
            group_before: None,
            group_in_print: false,
            group_spot: None,
            group_layer: None,
            group_feature: Feature::Unknown,
            env: Surroundings::default(),
            mixing,
            colour,
            emitted: Eol::default(),
            report,
            features: FeatureComments::default(),
            tools: ToolRetractions::default(),
            line_retracted_mm: 0.0,
            group_retracted_mm: 0.0,
            group_parked_mm: 0.0,
            owed_mm: 0.0,
            e_reset: None,
            nozzles: Nozzles::default(),
        }
    }

    /// The state options the input must be read with (the print-proper markers).
    pub fn state_options(&self) -> StateOptions {
        StateOptions { markers: self.rules.markers().clone(), ..StateOptions::default() }
    }

    /// What the run did so far.
    pub fn report(&self) -> &PurgeShiftReport {
        &self.report
    }

    /// What the run did, the pass consumed.
    pub fn into_report(self) -> PurgeShiftReport {
        self.report
    }

    fn emit(&mut self, out: &mut dyn Write, bytes: &[u8], eol: &[u8]) -> io::Result<()> {
        self.emitted.line(out, bytes, eol)
    }

    fn emit_line(&mut self, out: &mut dyn Write, line: &OwnedLine) -> io::Result<()> {
        self.emit(out, &line.bytes, &line.eol)
    }

    fn emit_raw(&mut self, out: &mut dyn Write, ctx: &Ctx<'_>) -> io::Result<()> {
        self.emit(out, ctx.line.bytes, ctx.line.eol)
    }

    /// Writes a held line as it was read (or written by the pass), ending included.
    fn emit_held(&mut self, out: &mut dyn Write, h: &Held) -> io::Result<()> {
        self.emitted.whole_line(out, self.text.whole(h.text))
    }

    /// Writes every held line: nothing before this point can take a change any more.
    fn flush(&mut self, out: &mut dyn Write, reason: &'static str) -> io::Result<()> {
        while let Some(h) = self.window.pop_front() {
            self.emit_held(out, &h)?;
        }
        self.text.written_up_to(None);
        self.window_purge_mm = 0.0;
        self.floor = reason;
        Ok(())
    }

    fn pop_front(&mut self, out: &mut dyn Write) -> io::Result<()> {
        if let Some(h) = self.window.pop_front() {
            self.window_purge_mm -= h.purge_mm();
            self.emit_held(out, &h)?;
            self.text.written_up_to(self.window.front().map(|f| f.text));
        }
        Ok(())
    }

    fn push(&mut self, out: &mut dyn Write, held: Held) -> io::Result<()> {
        self.window_purge_mm += held.purge_mm();
        self.window.push_back(held);
        self.report.max_window_lines = self.report.max_window_lines.max(self.window.len());
        // The front line is no longer needed once the moves after it hold the largest purge.
        while let Some(front) = self.window.front() {
            let after_front = self.window_purge_mm - front.purge_mm();
            if after_front >= self.rules.max_purge_mm + EPS_E_MM {
                self.pop_front(out)?;
            } else if self.window.len() > self.rules.max_window_lines {
                self.pop_front(out)?;
                self.floor = "the window limit (max_window_lines)";
            } else {
                break;
            }
        }
        Ok(())
    }

    /// A line starts a layer: changes may not move before it (or, crossing layers, not before the
    /// previous layer's start).
    fn layer_start(&mut self, out: &mut dyn Write) -> io::Result<()> {
        if !self.rules.cross_layers {
            return self.flush(out, LAYER_CHANGE);
        }
        if let Some(prev) = self.layer_start_seq {
            while self.window.front().is_some_and(|h| h.seq < prev) {
                self.pop_front(out)?;
                self.floor = "the second layer change back";
            }
        }
        self.layer_start_seq = Some(self.seq);
        Ok(())
    }

    fn follow_mixing(&mut self, ctx: &Ctx<'_>) {
        // A malformed mixing line changes nothing in the firmware either, and a tool beyond the
        // followed virtual tools is still a change of tool number (the colour records it).
        let _ = self.mixing.follow_line(ctx.line.bytes, ctx.block);
        self.colour = Colour {
            tool: ctx.state.tool,
            marlin: self.mixing.active_mix().ratios().to_vec(),
            rrf: self.mixing.rrf_mix(ctx.state.tool).map(<[f64]>::to_vec),
        };
    }

    /// The group of change lines has ended: move it if it changed the colour.
    fn close_group(&mut self, out: &mut dyn Write) -> io::Result<()> {
        let Some(before) = self.group_before.take() else { return Ok(()) };
        let in_print = self.group_in_print;
        let group = std::mem::take(&mut self.group);
        if before != self.colour && in_print {
            self.shift(out, before.tool, &group)?;
        } else {
            if before != self.colour {
                self.report.untouched_changes += 1;
            }
            self.flush(out, "mixing lines that are not a change")?;
            for line in &group {
                self.emit_line(out, line)?;
            }
        }
        let tail = std::mem::take(&mut self.group_tail);
        for line in tail {
            let text = self.text.push(&line.bytes, &line.eol);
            let held = self.held(text, line.number, Kind::Other(Feeds::written(0.0)), None, Feature::Unknown);
            self.push(out, held)?;
        }
        Ok(())
    }

    /// Writes `\n`-separated lines with the ending `eol`; returns how many.
    fn emit_text(&mut self, out: &mut dyn Write, text: &[u8], eol: &[u8]) -> io::Result<u64> {
        let mut n = 0;
        for line in text.split(|&b| b == b'\n').filter(|l| !l.is_empty()) {
            self.emit(out, line, eol)?;
            n += 1;
        }
        Ok(n)
    }

    /// The machine as `state` leaves it, with the retraction in force (the file's E-only
    /// retractions and a firmware `G10`).
    fn spot_here(&self, state: &crate::gcode::state::State) -> Spot {
        Spot {
            start: PurgeStart {
                pos: purge_start_pos(&state.pos),
                absolute_xyz: state.absolute(),
                relative_e: state.relative_e(),
                feed_mm_min: state.feed_mm_min,
                rapid_mode: state.motion == crate::gcode::state::Motion::Rapid,
                retracted_mm: self.tools.nozzle_mm(),
            },
            inches: state.inches,
        }
    }

    fn held(&mut self, text: TextRef, number: u64, kind: Kind, layer: Option<u32>, feature: Feature) -> Held {
        self.seq += 1;
        Held { text, number, kind, layer, feature, seq: self.seq, retracted_mm: self.line_retracted_mm }
    }
}

/// `M104`/`M109`/`M221`/`M900` without `T` act on the active tool: a change must not pass them.
fn tool_dependent(block: &Block) -> bool {
    let c = block.command;
    (c.is_m(104) || c.is_m(109) || c.is_m(221) || c.is_m(900)) && !block.has(b'T')
}

/// A line that belongs to a change group.
fn is_change_line(block: &Block) -> bool {
    let c = block.command;
    c.tool().is_some() || c.m().is_some_and(MixingCode::goes_with_a_tool_change)
}

impl Pass for PurgeShift {
    /// Plain moves' words are not read: the pass asks only whether a move names E or F
    /// ([`Block::names`]), and a move it splits is read again whole.
    fn reads_words(&self) -> bool {
        false
    }

    /// A line too long to read (only a lenient run gets here): nothing is moved across it, and
    /// the lines held back go out before it, so that it keeps its place.
    fn long_line(&mut self, piece: &RawLine<'_>, out: &mut dyn Write) -> Result<(), PassError> {
        self.close_group(out)?;
        self.flush(out, "a line too long to read")?;
        out.write_all(piece.bytes)?;
        Ok(out.write_all(piece.eol)?)
    }

    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        let structure = &ctx.state.structure;
        let in_print = structure.region == Region::Print;
        self.nozzles.line(ctx.block, ctx.line.number).map_err(PassError::refuse)?;
        self.line_retracted_mm = self.tools.active_mm();
        self.tools.follow(ctx.state.tool, ctx.effect);
        // What the surroundings follow (the print's extent, the file's own retraction) only
        // the tower fallback reads.
        if let (Effect::Move(m), Fallback::Tower) = (ctx.effect, self.rules.fallback) {
            self.env.observe(m, in_print);
        }
        if is_change_line(ctx.block) {
            if self.owed_mm > 0.0 {
                self.settle_owed(ctx, out)?;
            }
            self.env.tool_change();
            if self.group_before.is_none() {
                self.group_before = Some(self.colour.clone());
                self.group_in_print = in_print;
                self.group_spot = Some(self.spot_here(ctx.state));
                self.group_layer = structure.layer;
                self.group_feature = structure.feature;
                self.group_retracted_mm = self.line_retracted_mm;
            }
            self.group_parked_mm = self.tools.active_mm();
            self.nozzles.tool_change(self.colour.tool, ctx.state.tool).map_err(PassError::refuse)?;
            self.follow_mixing(ctx);
            let tail = std::mem::take(&mut self.group_tail);
            self.group.extend(tail);
            self.group.push(OwnedLine::from_raw(&ctx.line));
            return Ok(Flow::Continue);
        }
        if self.group_before.is_some() {
            if ctx.block.is_empty() {
                self.group_tail.push(OwnedLine::from_raw(&ctx.line));
                return Ok(Flow::Continue);
            }
            self.close_group(out)?;
        }
        if self.owed_mm > 0.0 && self.absorb(ctx, out, Feeds::of(ctx))? {
            return Ok(Flow::Continue);
        }
        if self.e_reset.is_some() {
            let reset = self.owed_e_reset(EWord::of(ctx.block));
            self.hold_text(out, &reset, &ctx.line, 0.0)?;
        }
        if !in_print {
            self.flush(out, "the start of the print proper")?;
            return self.emit_raw(out, ctx).map(|()| Flow::Continue).map_err(PassError::from);
        }
        if structure.layer_started {
            self.layer_start(out)?;
        }
        let kind = match ctx.effect {
            Effect::Move(m) if m.is_extruding() => {
                self.features.extrusion(structure.feature);
                if !self.rules.allowed.contains(structure.feature) {
                    self.flush(out, KEPT_FEATURE)?;
                    return self.emit_raw(out, ctx).map(|()| Flow::Continue).map_err(PassError::from);
                }
                if ctx.block.line_number.is_some() || ctx.block.checksum.is_some() {
                    self.flush(out, "a numbered line")?;
                    return self.emit_raw(out, ctx).map(|()| Flow::Continue).map_err(PassError::from);
                }
                let state = ctx.state;
                let split = Splittable {
                    mv: *m,
                    relative_axes: !state.absolute(),
                    relative_e: state.relative_e(),
                    inches: state.inches,
                };
                Kind::Extrude { e_mm: m.e_mm(), split }
            }
            Effect::Home { .. } => {
                self.flush(out, "homing")?;
                return self.emit_raw(out, ctx).map(|()| Flow::Continue).map_err(PassError::from);
            }
            // The firmware keeps a G10 per tool and a G11 recovers only the tool it retracted:
            // E moves cannot carry it across a moved change, so the change stays after it.
            Effect::FirmwareRetract { .. } => {
                self.flush(out, "a firmware retraction")?;
                return self.emit_raw(out, ctx).map(|()| Flow::Continue).map_err(PassError::from);
            }
            _ if tool_dependent(ctx.block) => {
                self.flush(out, "a command for the active tool")?;
                return self.emit_raw(out, ctx).map(|()| Flow::Continue).map_err(PassError::from);
            }
            // What the line feeds is read only for a line held back (not for one written at once).
            _ => Kind::Other(Feeds::of(ctx)),
        };
        let text = self.text.push_whole(crate::eol::with_ending(&ctx.line), ctx.line.eol.len());
        let held = self.held(text, ctx.line.number, kind, structure.layer, structure.feature);
        self.push(out, held)?;
        Ok(Flow::Continue)
    }

    fn finish(&mut self, state: &crate::gcode::state::State, out: &mut dyn Write) -> Result<(), PassError> {
        self.close_group(out)?;
        self.flush(out, "the end of the file")?;
        if self.owed_mm > 0.0 {
            // The file ended before the new tool's unretraction: it ends retracted as there.
            let spot = self.spot_here(state);
            let [retract, restore] = self.owed_retraction(&spot);
            self.owed_mm = 0.0;
            self.emit_text(out, &retract, b"\n")?;
            self.emit_text(out, &restore, b"\n")?;
        }
        if let Some(w) = self.features.warning(self.rules.allowed) {
            self.report.warn_first(w);
        }
        let r = &mut self.report;
        r.saved_mm = r.moved_mm;
        r.saved_mm3 = self.rules.mm3(r.moved_mm);
        Ok(r.changes.flush()?)
    }
}

/// Runs the pass as `run` says (input, output, strictness, progress).
pub fn purge_shift(rules: Rules, run: Run<'_>) -> Result<(PurgeShiftReport, Ran)> {
    let mut run = run.writes_e();
    run.flavour()?;
    let nozzles = match run.source() {
        Source::File(path) => {
            let ends = crate::gcode::ends::read_ends(path).map_err(|e| crate::Error::io(path, e))?;
            nozzles::ends_checks(&ends, path)?
        }
        Source::Text(text) => nozzles::ends_checks(text, Path::new(IN_MEMORY))?,
    };
    if rules.markers().begin.is_some() {
        match run.source() {
            Source::File(path) => {
                let file = std::fs::File::open(path).map_err(|e| crate::Error::io(path, e))?;
                require_markers(file, path, rules.markers())?;
            }
            Source::Text(text) => require_markers(text, Path::new(IN_MEMORY), rules.markers())?,
        }
    }
    let mut pass = PurgeShift::new(rules);
    pass.nozzles = nozzles;
    let ran = run.options(pass.state_options()).run(&mut pass)?;
    Ok((pass.into_report(), ran))
}

/// [`purge_shift`] of a whole text in memory, strictly (tests, examples).
pub fn purge_shift_bytes(rules: Rules, input: &[u8]) -> Result<(Vec<u8>, PurgeShiftReport)> {
    let (report, ran) = purge_shift(rules, Run::text(input).to_memory())?;
    Ok((ran.output, report))
}
