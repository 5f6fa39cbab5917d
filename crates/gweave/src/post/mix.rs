//! `gweave mix`: slicer G-code for a mixing hotend (the mixing seed, docs/seeds.md). The slicer knows one extruder, or
//! several; the printer has one nozzle fed by N filaments whose ratios the firmware mixes.
//!
//! What the pass does, streaming, one line at a time:
//!
//! 1. Before the file first moves filament (the start G-code's prime line, or the first layer
//!    if nothing extrudes earlier) it defines the mixes as virtual tools (Marlin
//!    `M163`/`M164`, RepRapFirmware `M563`/`M567`) and selects the first, so the prime line
//!    already runs on the first mix; `[purge] initial_mm` then purges whatever the chamber held. With `M165` direct mixing the mix itself is written at each change instead.
//! 2. It decides the wanted mix: per layer (or height) from the schedule and gradients for a
//!    single-tool file; per slicer tool from the map for a multi-tool file. The slicer's `T<n>`
//!    lines become comments: the virtual tool is selected right before the next extrusion, after
//!    the slicer's own heating, travel and unretraction, so nothing ever changes mid-move and the
//!    purge happens where the nozzle is about to print.
//! 3. When the wanted mix differs from the one in force, before that extrusion it writes the
//!    selection (and, for gradients that outgrow the firmware's tools, the redefinition of a
//!    free tool) and a purge block (`crate::post::purge_block`). No change, no purge. On the one
//!    nozzle the block also primes what the slicer tool left behind retracted and the new tool
//!    will never undo (a first change to a tool; a refill of its own when there is no purge).
//! 4. Moves faster in Z than the cap are split or slowed ([`crate::post::zcap`]).
//! 5. Optionally, the slicer's tool-change retraction (the retraction right before a `T<n>`) and
//!    the matching unretraction after the tool is next selected are removed: one nozzle needs no
//!    multi-material unload. Removed E moves become `G92 E` so the file's E positions still hold.
//!    This looks back over at most [`HOLD_LINES`] lines (between a retraction and a `T<n>`).
//!
//! 6. A hotend temperature the slicer sets for one of its tools (`M104`/`M109 ... T<n>`) is for
//!    the one nozzle only while that tool prints: for the tool printing it is the nozzle's
//!    (`T0` kept as written, another `T` dropped, since Marlin's mixing build has one hotend and
//!    answers `M104 T1` with "Invalid extruder"); for any other tool (a preheat before a change,
//!    a standby after one) it becomes a comment, since on the one nozzle it would either do
//!    nothing or set the idle tool's standby under the tool printing.
//!
//! Every other line is copied byte for byte; new lines use the profile's number format and the
//! file's line endings.
//!
//! Before and after (the seed's schedule, layer 10 turns Pink):
//!
//! ```text
//! ;LAYER:10                        ;LAYER:10
//! G0 F9000 X120 Y80 Z2.1           G0 Z2.1 F200
//!                                  G0 X120 Y80 F9000
//! G1 F1800 X125 Y80 E410.2         ; gweave mix: Orange -> Pink
//!                                  T1
//!                                  ; gweave mix: purge Orange -> Pink, 25 mm
//!                                  ... (see purge_block)
//!                                  ; gweave mix: end purge
//!                                  G1 F1800 X125 Y80 E410.2
//! ```

pub mod card;
pub mod job;
pub mod options;
pub use options::MixOptions;
pub mod profile;
mod purge_table;
pub mod report;
pub mod schedule;
pub mod wizard;

use std::collections::BTreeMap;
use std::io::{self, Write};

use crate::colour::dialect::{marlin_m163_m164, marlin_m165, rrf_m563, rrf_m567};
use crate::colour::purge::{flush_volume_mm3, mm3_to_filament_mm, Washout};
use crate::eol::Eol;
use crate::gcode::flavour::flavour_of_comment;
use crate::gcode::layers::Region;
use crate::gcode::lexer::parse_line;
use crate::gcode::line::Block;
use crate::gcode::number::NumberFormat;
use crate::gcode::retraction::{write_e_only, write_e_reset, Retraction, ToolRetractions};
use crate::gcode::state::{Effect, Motion, Move, State, E, X, Y, Z};
use crate::pass::{Ctx, Flow, Pass, PassError, Step};
use crate::post::purge_block::{purge_start_pos, write_purge, write_refill, PurgeMotion, PurgeStart};
use crate::post::warning::Warning;
use crate::post::zcap::ZCap;
use crate::run::{Ran, Run};

use crate::firmware::{Firmware, MixCommands};
use profile::{MixProfile, PurgeMode, ZCapMode};
use report::{Accounting, MixReport};
use schedule::{Plan, Slot};

/// Lines held back, at most, between a slicer retraction and the `T<n>` it may belong to.
pub const HOLD_LINES: usize = 32;

/// Errors of the mix pass.
#[derive(Debug, thiserror::Error)]
pub enum MixPassError {
    /// The profile is inconsistent (the message says how).
    #[error("mix profile: {0}")]
    Config(String),
    /// Nothing the options and profile ask can be done as they stand: the sentence names the
    /// options that would (each front end spells them: [`crate::options::Said::spelled`]).
    #[error("{0}")]
    Needs(crate::options::Said),
    /// A profile key out of its range (it names the table and the key).
    #[error(transparent)]
    Range(#[from] crate::range::OutOfRange),
    /// A value given that the profile cannot take, or a line of the input it cannot handle
    /// (the pass driver names the file and the line: [`crate::Error::Pass`]).
    #[error("{0}")]
    Input(String),
    /// A mix cannot be made (its colour, its ratios).
    #[error(transparent)]
    Mix(#[from] crate::colour::MixError),
    /// The engine failed (reading, writing, a malformed line).
    #[error(transparent)]
    Engine(#[from] crate::Error),
}

/// A held line: its output, and what to write instead if it turns out to be a tool-change
/// retraction (its retraction in mm).
struct Held {
    bytes: Vec<u8>,
    retraction: Option<(Vec<u8>, f64)>,
}

/// The `gweave mix` pass; see the module docs.
pub struct MixPass {
    plan: Plan,
    profile: MixProfile,
    zcap: Option<ZCap>,
    motion: PurgeMotion,
    started: bool,
    /// `[purge] initial_mm` is still to be purged, before the first move of filament.
    initial_purge_due: bool,
    /// The mix the firmware prints with now.
    active: Option<usize>,
    wanted: Option<usize>,
    active_tool: Option<u32>,
    /// What the two shared tools hold.
    rotating: [Option<usize>; 2],
    slicer_tool: u32,
    decided_layer: Option<u32>,
    /// The one nozzle's retraction in force, and per slicer tool, as the slicer sees it (a
    /// nozzle per tool), what the tool printing will undo itself.
    retractions: ToolRetractions,
    /// Dropped tool-change retraction per slicer tool, to drop again from its unretraction, mm.
    owed_mm: BTreeMap<u32, f64>,
    held: Vec<Held>,
    feed_before: f64,
    rapid_before: bool,
    /// The file's line endings, for the lines the pass writes.
    eol: Eol,
    /// Lines before the current line, `\n`-separated.
    pre: Vec<u8>,
    /// The current line's replacement, `\n`-separated (empty: keep the line).
    repl: Vec<u8>,
    replaced: bool,
    acc: Accounting,
    /// The flavour the file names in a comment, as the pass met it.
    flavour: Option<String>,
}

impl MixPass {
    /// A pass for `profile`, with every mix resolved up front.
    pub fn new(profile: MixProfile) -> Result<Self, MixPassError> {
        let plan = Plan::new(&profile)?;
        let cap = profile.z_cap.max_z_feed_mm_min;
        let zcap = (cap > 0.0).then_some(ZCap { max_z_feed_mm_min: cap, mode: profile.z_cap.mode });
        let motion = profile.purge.motion(cap);
        let acc = Accounting::new(&plan, &profile.hardware);
        let initial_purge_due = profile.purge.initial_mm > 0.0;
        Ok(MixPass {
            plan,
            profile,
            zcap,
            motion,
            started: false,
            initial_purge_due,
            active: None,
            wanted: None,
            active_tool: None,
            rotating: [None; 2],
            slicer_tool: 0,
            decided_layer: None,
            retractions: ToolRetractions::default(),
            owed_mm: BTreeMap::new(),
            held: Vec::new(),
            feed_before: 0.0,
            rapid_before: false,
            eol: Eol::default(),
            pre: Vec::new(),
            repl: Vec::new(),
            replaced: false,
            acc,
            flavour: None,
        })
    }

    /// The resolved mixes and schedule.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The mix the firmware prints with after the lines seen so far (an index into
    /// [`Plan::mixes`]), for passes that colour the print line by line.
    pub fn active_mix(&self) -> Option<usize> {
        self.active
    }

    /// The report, after the run.
    pub fn into_report(self) -> MixReport {
        MixReport { flavour: self.flavour, ..self.acc.finish(&self.profile.hardware) }
    }

    fn fmt(&self) -> &NumberFormat {
        &self.profile.numbers
    }

    fn decimals(&self) -> crate::colour::dialect::Decimals {
        self.plan.decimals
    }

    /// Mix definitions and the first selection, before the first move of filament or the first
    /// line of the print proper, whichever comes first.
    fn start_print(&mut self, state: &State) -> Result<(), MixPassError> {
        self.started = true;
        let hw = &self.profile.hardware;
        let n = hw.inputs.len();
        let to_come = if self.plan.steps_to_come() { " and gradient steps as their layers come" } else { "" };
        let mut text = format!(
            "; gweave mix: {} mixes{to_come}, {} inputs, {:?} dialect\n",
            self.plan.mixes.len(),
            n,
            hw.dialect()
        );
        let drives: Vec<u32> = (0..n as u32).collect();
        let define_rrf_tool = |t: u32, text: &mut String| -> Result<(), MixPassError> {
            let line =
                rrf_m563(t, &drives, hw.rrf_heater).map_err(|e| MixPassError::Config(e.to_string()))?;
            text.push_str(&line);
            text.push('\n');
            // A new RepRapFirmware tool heats to its own active temperature (0 unless set).
            if let Some(&c) = state.thermal.hotend_c.first().filter(|c| **c > 0.0) {
                text.push_str(&format!("M568 P{t} S{c} R{c}\n"));
            }
            Ok(())
        };
        for m in &self.plan.mixes {
            let Slot::Fixed(t) = m.slot else { continue };
            text.push_str(&format!("; {} = T{t}, predicted {}\n", m.label, m.predicted.to_hex()));
            match hw.dialect() {
                MixCommands::Marlin => {
                    for l in marlin_m163_m164(&m.mix, t as usize, self.plan.decimals) {
                        text.push_str(&l);
                        text.push('\n');
                    }
                }
                MixCommands::RepRapFirmware => {
                    define_rrf_tool(t, &mut text)?;
                    text.push_str(&rrf_m567(&m.mix, t, self.plan.decimals));
                    text.push('\n');
                }
                MixCommands::MarlinDirect => {}
            }
        }
        if hw.dialect().defines_tools() && self.plan.mixes.iter().any(|m| m.slot == Slot::Rotating) {
            for t in self.plan.rotating_tools {
                define_rrf_tool(t, &mut text)?;
            }
        }
        self.pre.extend_from_slice(text.as_bytes());
        let first = self.plan.initial(self.slicer_tool)?;
        self.acc.learn(&self.plan);
        self.select(first)?;
        self.wanted = Some(first);
        Ok(())
    }

    /// Writes what makes `mix` the active one (definition if needed, then selection).
    fn select(&mut self, mix: usize) -> Result<(), MixPassError> {
        let m = &self.plan.mixes[mix];
        let mut text = String::new();
        match m.slot {
            Slot::Fixed(t) => {
                text.push_str(&format!("T{t}\n"));
                self.active_tool = Some(t);
            }
            Slot::Direct => {
                let line =
                    marlin_m165(&m.mix, self.decimals()).map_err(|e| MixPassError::Config(e.to_string()))?;
                text.push_str(&line);
                text.push('\n');
            }
            Slot::Rotating => {
                let tools = self.plan.rotating_tools;
                let k = match self.rotating.iter().position(|r| *r == Some(mix)) {
                    Some(k) => k,
                    // The shared tool not printing now.
                    None => usize::from(self.active_tool == Some(tools[0])),
                };
                let t = tools[k];
                if self.rotating[k] != Some(mix) {
                    text.push_str(&format!("; {} = T{t}, predicted {}\n", m.label, m.predicted.to_hex()));
                    match self.profile.hardware.dialect() {
                        MixCommands::RepRapFirmware => {
                            text.push_str(&rrf_m567(&m.mix, t, self.decimals()));
                            text.push('\n');
                        }
                        // Direct mixing has no tools to rotate; were it to, a virtual tool is
                        // what Marlin would store.
                        MixCommands::Marlin | MixCommands::MarlinDirect => {
                            for l in marlin_m163_m164(&m.mix, t as usize, self.decimals()) {
                                text.push_str(&l);
                                text.push('\n');
                            }
                        }
                    }
                    self.rotating[k] = Some(mix);
                }
                text.push_str(&format!("T{t}\n"));
                self.active_tool = Some(t);
                self.acc.set_tool(mix, t);
            }
        }
        self.pre.extend_from_slice(text.as_bytes());
        self.active = Some(mix);
        Ok(())
    }

    /// Purge length for a change from `from` to `to`, mm of filament.
    fn purge_mm(&self, from: usize, to: usize) -> Result<f64, MixPassError> {
        let p = &self.profile.purge;
        let (a, b) = (&self.plan.mixes[from], &self.plan.mixes[to]);
        if p.mode == PurgeMode::Off || ((a.gradient_step || b.gradient_step) && !p.on_gradient_steps) {
            return Ok(0.0);
        }
        let dia = self.profile.hardware.filament_diameter_mm;
        let mm3 = |v: f64| mm3_to_filament_mm(v, dia).map_err(|e| MixPassError::Config(e.to_string()));
        let same = |x: &str, y: &str| x.eq_ignore_ascii_case(y);
        if let Some(pair) = p.pair.iter().find(|q| same(&q.from, &a.label) && same(&q.to, &b.label)) {
            return match (pair.length_mm, pair.volume_mm3) {
                (Some(l), _) => Ok(l),
                (None, Some(v)) => mm3(v),
                (None, None) => unreachable!("validated: a pair has a length or a volume"),
            };
        }
        match p.mode {
            PurgeMode::Off => Ok(0.0),
            PurgeMode::Length => Ok(p.length_mm),
            PurgeMode::Volume => mm3(p.volume_mm3),
            PurgeMode::Colours => mm3(p.multiplier * flush_volume_mm3(a.predicted, b.predicted)),
            PurgeMode::Washout => {
                let w = Washout::new(p.chamber_mm3, p.dead_mm3)
                    .map_err(|e| MixPassError::Config(e.to_string()))?;
                mm3(w
                    .purge_for_tolerance_mm3(p.tolerance)
                    .map_err(|e| MixPassError::Config(e.to_string()))?)
            }
        }
    }

    /// The change of mix before an extruding move `mv`.
    fn change(&mut self, to: usize, mv: &Move, state: &State) -> Result<(), MixPassError> {
        let from = self.active;
        let label = match from {
            Some(f) => format!("{} -> {}", self.plan.mixes[f].label, self.plan.mixes[to].label),
            None => self.plan.mixes[to].label.clone(),
        };
        self.pre.extend_from_slice(format!("; gweave mix: {label}\n").as_bytes());
        self.select(to)?;
        let Some(from) = from else { return Ok(()) };
        self.acc.changes += 1;
        let purge_mm = self.purge_mm(from, to)?;
        if purge_mm > 0.0 {
            self.purge(mv, state, to, purge_mm, &label);
        } else {
            let (start, refill_mm) = self.purge_start(mv, state);
            if refill_mm > 0.0 {
                let mut block = Vec::new();
                write_refill(&mut block, &self.profile.numbers, &self.motion, &start, refill_mm);
                self.pre.extend_from_slice(&block);
                self.refilled(to, refill_mm);
            }
        }
        Ok(())
    }

    /// Where a block before `mv` starts, and the retraction in force that no line after it will
    /// undo, mm: the nozzle's beyond the slicer tool's own. PrusaSlicer retracts the tool it
    /// leaves by `retract_length_toolchange` and unretracts a tool only if that tool retracted,
    /// so the first change to a tool leaves the one nozzle retracted by the old tool's amount.
    fn purge_start(&self, mv: &Move, state: &State) -> (PurgeStart, f64) {
        let nozzle_mm = self.retractions.nozzle_mm();
        let tool_mm = self.retractions.tool_mm(self.slicer_tool);
        // Below a micrometre it is the rounding of the file's E words, not a retraction.
        let (retracted_mm, refill_mm) =
            if nozzle_mm - tool_mm > 1e-6 { (tool_mm, nozzle_mm - tool_mm) } else { (nozzle_mm, 0.0) };
        let start = PurgeStart {
            pos: purge_start_pos(&mv.from),
            absolute_xyz: state.absolute(),
            relative_e: state.relative_e(),
            feed_mm_min: self.feed_before,
            rapid_mode: self.rapid_before,
            retracted_mm,
        };
        (start, refill_mm)
    }

    /// Follows a block's prime of `refill_mm` in mix `to`: the nozzle is that much less
    /// retracted, and the filament is the mix's.
    fn refilled(&mut self, to: usize, refill_mm: f64) {
        self.retractions.refill_nozzle(refill_mm);
        self.acc.filament(to, refill_mm, None);
    }

    /// Writes a purge block of `mm` in mix `to` before the current line, from where the move
    /// starts, and counts it.
    fn purge(&mut self, mv: &Move, state: &State, to: usize, mm: f64, label: &str) {
        let (start, refill_mm) = self.purge_start(mv, state);
        let mut block = Vec::new();
        write_purge(&mut block, &self.profile.numbers, &self.motion, &start, mm, refill_mm, label);
        self.pre.extend_from_slice(&block);
        self.acc.purge(to, mm);
        if refill_mm > 0.0 {
            self.refilled(to, refill_mm);
        }
    }

    /// Follows `fed_mm` of filament fed by the slicer tool printing, on the nozzle and for the tool.
    fn feed(&mut self, fed_mm: f64) {
        self.retractions.feed(self.slicer_tool, fed_mm);
    }

    /// The purge of `[purge] initial_mm` before the first move of filament, in the first mix:
    /// whatever the chamber held before the print (the last job's mix, a colour loaded by hand)
    /// comes out at the purge spot, as the seed purged at `;LAYER:0`.
    fn initial_purge(&mut self, mv: &Move, state: &State) {
        self.initial_purge_due = false;
        let (Some(first), mm) = (self.active, self.profile.purge.initial_mm) else { return };
        let label = format!("to {} before the print", self.plan.mixes[first].label);
        self.purge(mv, state, first, mm, &label);
    }

    /// Decides what comes out for one line, into `pre` and `repl`.
    fn process(&mut self, ctx: &Ctx<'_>) -> Result<(), MixPassError> {
        let state = ctx.state;
        let print = state.structure.region == Region::Print;
        // The first filament the file moves, a start G-code's prime line included, is already
        // the first mix: the firmware's default mix (often input 0 alone) would otherwise fill
        // the chamber before layer 0.
        let moves_filament = || matches!(ctx.effect, Effect::Move(mv) if mv.e_mm() != 0.0);
        if !self.started && (print || moves_filament()) {
            self.start_print(state)?;
        }
        match ctx.effect {
            Effect::ToolChange { to, .. } => {
                // Every slicer `T<n>`, the start G-code's included: PrusaSlicer's wipe tower
                // primes each tool in turn before layer 0 (`; CP PRIMING START`, no layer yet),
                // and the tool it primes last is the one layer 0 starts with.
                if self.plan.maps_tools() {
                    self.wanted = Some(self.plan.for_tool(*to)?);
                }
                self.slicer_tool = *to;
                self.repl.push(b';');
                self.repl.extend_from_slice(ctx.line.bytes);
                self.repl.extend_from_slice(b" ; gweave mix: the mix is selected at the next extrusion\n");
                self.replaced = true;
            }
            Effect::Move(mv) => self.process_move(ctx, mv)?,
            Effect::None if is_hotend_target(ctx) => self.hotend_target(ctx),
            // The purge block primes and retracts again a firmware retraction in force too.
            Effect::FirmwareRetract { e_mm } => self.feed(*e_mm),
            _ => {}
        }
        Ok(())
    }

    /// `M104`/`M109` with a `T` word: the nozzle's when `T` is the slicer tool printing, a
    /// comment otherwise (step 6 of the module docs).
    fn hotend_target(&mut self, ctx: &Ctx<'_>) {
        let Some(t) = ctx.block.word(b'T') else { return };
        let tool = t.number().filter(|n| (0.0..f64::from(u32::MAX)).contains(n)).map(|n| n as u32);
        let line = ctx.line.bytes;
        match tool {
            Some(0) if self.slicer_tool == 0 => {}
            Some(tool) if tool == self.slicer_tool => {
                // The T word out, the rest as written: `M109 S215 T1` -> `M109 S215`.
                let (start, end) = (t.span.start as usize, t.span.end as usize);
                let before = line[..start].strip_suffix(b" ").unwrap_or(&line[..start]);
                self.repl.extend_from_slice(before);
                self.repl.extend_from_slice(&line[end..]);
                self.repl.extend_from_slice(b" ; gweave mix: the mixing hotend, for the slicer's T");
                self.repl.extend_from_slice(tool.to_string().as_bytes());
                self.replaced = true;
                self.acc.tool_temperatures += 1;
            }
            _ => {
                self.repl.extend_from_slice(&other_tool_heat(line, self.slicer_tool));
                self.replaced = true;
                self.acc.tool_temperatures += 1;
            }
        }
    }

    fn process_move(&mut self, ctx: &Ctx<'_>, mv: &Move) -> Result<(), MixPassError> {
        let state = ctx.state;
        if state.inches {
            return Err(MixPassError::Config(
                "gweave mix writes millimetres; convert the G20 (inch) file first".into(),
            ));
        }
        let print = state.structure.region == Region::Print;
        let e_mm = mv.e_mm();
        let layer = state.structure.layer.unwrap_or(0);
        if self.initial_purge_due && e_mm != 0.0 {
            self.initial_purge(mv, state);
        }
        // A schedule starts at layer 0; a tool map follows the slicer's tools wherever they
        // extrude, a tower's priming before layer 0 included (its filament is that tool's).
        if (print || self.plan.maps_tools()) && self.started && mv.is_extruding() {
            if !self.plan.maps_tools() && self.decided_layer != Some(layer) {
                self.wanted = self.plan.mix_at(layer, mv.to[Z])?;
                self.acc.learn(&self.plan);
                self.decided_layer = Some(layer);
            }
            if let Some(w) = self.wanted.filter(|w| Some(*w) != self.active) {
                self.change(w, mv, state)?;
            }
        }
        // Only a plain unretraction (no Z in the same move) is rewritten when a dropped
        // tool-change retraction is owed; the rewrite keeps E and F alone.
        let unretraction = e_mm > 0.0 && Retraction::moves_filament_only(mv) && mv.from[Z] == mv.to[Z];
        let fed_mm = if unretraction { self.unretract(ctx, mv)? } else { e_mm };
        self.feed(fed_mm);
        if let Some(a) = self.active {
            let printed = (print && mv.is_extruding()).then_some((layer, state.structure.layer_z_mm));
            self.acc.filament(a, fed_mm, printed);
        }
        if !self.replaced {
            // A move without Z motion is never too fast in Z (the seed's rule reads the Z word
            // instead, so it asks for every move): most moves skip the call.
            if let Some(zc) = self.zcap.filter(|zc| mv.from[Z] != mv.to[Z] || zc.mode == ZCapMode::Seed) {
                // A plain move comes with its words unlisted (`reads_words`): the few moves the
                // cap may rewrite, word by word, are read again whole.
                let mut listed = Block::default();
                let block = if ctx.block.words.is_empty() && ctx.block.plain.present != 0 {
                    parse_line(&ctx.line, &mut listed);
                    &listed
                } else {
                    ctx.block
                };
                if zc.rewrite(ctx.line.bytes, block, mv, &self.profile.numbers, &mut self.repl) {
                    self.replaced = true;
                    self.acc.z_capped_lines += 1;
                }
            }
        }
        Ok(())
    }

    /// An E-only forward move with tool-change retractions being dropped: the part of it that
    /// undoes the retraction in force is kept, the part that undoes a dropped tool-change
    /// retraction of this slicer tool is dropped. Returns the filament the output feeds.
    fn unretract(&mut self, ctx: &Ctx<'_>, mv: &Move) -> Result<f64, MixPassError> {
        let amount = mv.e_mm();
        let owed = self.owed_mm.get(&self.slicer_tool).copied().unwrap_or(0.0);
        if self.profile.tool_change.keep_slicer_retractions || owed <= 0.0 {
            return Ok(amount);
        }
        let keep_for_retraction = amount.min(self.retractions.nozzle_mm());
        let dropped = (amount - keep_for_retraction).min(owed);
        if dropped <= 1e-9 {
            return Ok(amount);
        }
        self.owed_mm.insert(self.slicer_tool, owed - dropped);
        self.acc.dropped_retractions += 1;
        let kept = amount - dropped;
        let fmt = self.profile.numbers;
        let mut text = b";".to_vec();
        text.extend_from_slice(ctx.line.bytes);
        text.extend_from_slice(b" ; gweave mix: slicer tool-change unretraction dropped\n");
        write_e_reset(&mut text, &fmt, mv.from[E] + dropped);
        text.push(b'\n');
        if kept > 1e-9 {
            if ctx.state.relative_e() {
                write_e_only(&mut text, &fmt, mv.rapid, Some(kept), Some(mv.feed_mm_min));
            } else {
                text.extend_from_slice(ctx.line.bytes);
            }
            text.push(b'\n');
        } else if ctx.block.names(b'F') {
            write_e_only(&mut text, &fmt, mv.rapid, None, Some(mv.feed_mm_min));
            text.push(b'\n');
        }
        self.repl = text;
        self.replaced = true;
        Ok(kept)
    }

    /// What a held retraction line becomes if dropped: a comment, the E position it reached,
    /// and the feed rate it set.
    fn dropped_retraction(&self, ctx: &Ctx<'_>, mv: &Move) -> Vec<u8> {
        let fmt = self.fmt();
        let mut text = b";".to_vec();
        text.extend_from_slice(ctx.line.bytes);
        text.extend_from_slice(b" ; gweave mix: slicer tool-change retraction dropped");
        text.extend_from_slice(self.eol.get());
        write_e_reset(&mut text, fmt, mv.to[E]);
        text.extend_from_slice(self.eol.get());
        if ctx.block.names(b'F') {
            write_e_only(&mut text, fmt, mv.rapid, None, Some(mv.feed_mm_min));
            text.extend_from_slice(self.eol.get());
        }
        text
    }

    /// Renders `pre` and the line (or its replacement) with the file's line endings.
    fn render(&mut self, ctx: &Ctx<'_>, into: &mut Vec<u8>) {
        // Writing into memory cannot fail.
        let _ = self.eol.block(into, &self.pre);
        if self.replaced {
            let _ = self.eol.text(into, &self.repl, ctx.line.eol);
        } else {
            into.extend_from_slice(ctx.line.bytes);
            into.extend_from_slice(ctx.line.eol);
        }
    }

    fn write_held(&mut self, drop: bool, out: &mut dyn Write) -> io::Result<()> {
        for h in std::mem::take(&mut self.held) {
            match h.retraction {
                Some((instead, mm)) if drop => {
                    out.write_all(&instead)?;
                    *self.owed_mm.entry(self.slicer_tool).or_insert(0.0) += mm;
                    self.retractions.withdraw(self.slicer_tool, mm);
                    self.acc.dropped_retractions += 1;
                }
                _ => out.write_all(&h.bytes)?,
            }
        }
        Ok(())
    }
}

/// Whether the line sets a hotend's temperature for a named tool: `M104`/`M109` with `T`.
fn is_hotend_target(ctx: &Ctx<'_>) -> bool {
    (ctx.block.command.is_m(104) || ctx.block.command.is_m(109)) && ctx.block.has(b'T')
}

/// The comment a temperature for a tool not printing becomes (`line` as written, `printing`
/// the slicer tool printing): kept readable, so that nothing the slicer wrote is lost.
fn other_tool_heat(line: &[u8], printing: u32) -> Vec<u8> {
    let mut out = b";".to_vec();
    out.extend_from_slice(line);
    out.extend_from_slice(
        format!(
            " ; gweave mix: for a slicer tool not printing (T{printing} prints): one nozzle, one temperature"
        )
        .as_bytes(),
    );
    out
}

/// The pass's error for the line it was given (the driver names the file and the line).
fn refused(e: MixPassError) -> PassError {
    match e {
        MixPassError::Config(message) => PassError::refuse(MixPassError::Input(message)),
        other => PassError::refuse(other),
    }
}

/// Writes `bytes` and reads on.
fn write(out: &mut dyn Write, bytes: &[u8]) -> Step {
    out.write_all(bytes)?;
    Ok(Flow::Continue)
}

impl Pass for MixPass {
    /// Plain moves' words are read only under the seed's Z cap, which looks for the Z word on
    /// every move; otherwise the pass asks only whether a move names F ([`Block::names`]) and
    /// reads again the few moves the cap rewrites.
    fn reads_words(&self) -> bool {
        self.zcap.is_some_and(|zc| zc.mode == ZCapMode::Seed)
    }

    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        self.eol.learn(ctx.line.eol);
        self.pre.clear();
        self.repl.clear();
        self.replaced = false;
        if let Some(f) = ctx.block.comment_text(ctx.line.bytes).and_then(flavour_of_comment) {
            self.flavour = Some(String::from_utf8_lossy(f).into_owned());
        }
        // The slicer tool before this line, for a retraction that a T on this line follows.
        let tool_before = self.slicer_tool;
        self.process(ctx).map_err(refused)?;
        self.feed_before = ctx.state.feed_mm_min;
        self.rapid_before = ctx.state.motion == Motion::Rapid;
        let dropping = !self.profile.tool_change.keep_slicer_retractions
            && self.plan.maps_tools()
            && ctx.state.structure.region == Region::Print;
        if !dropping && self.held.is_empty() && self.pre.is_empty() && !self.replaced {
            // The common case: the line as it was, without a copy, its ending in the same write.
            return write(out, crate::eol::with_ending(&ctx.line));
        }
        let mut bytes = Vec::with_capacity(ctx.line.bytes.len() + self.pre.len() + self.repl.len() + 2);
        self.render(ctx, &mut bytes);
        if !dropping {
            self.write_held(false, out)?;
            return write(out, &bytes);
        }
        let retraction = match ctx.effect {
            Effect::Move(mv)
                if mv.e_mm() < 0.0
                    && mv.from[X] == mv.to[X]
                    && mv.from[Y] == mv.to[Y]
                    && mv.from[Z] == mv.to[Z] =>
            {
                Some((self.dropped_retraction(ctx, mv), -mv.e_mm()))
            }
            _ => None,
        };
        if retraction.is_some() {
            self.held.push(Held { bytes, retraction });
            return Ok(Flow::Continue);
        }
        if self.held.is_empty() {
            return write(out, &bytes);
        }
        match ctx.effect {
            Effect::ToolChange { .. } => {
                // The held retractions belonged to the tool being left.
                let now = std::mem::replace(&mut self.slicer_tool, tool_before);
                self.write_held(true, out)?;
                self.slicer_tool = now;
                write(out, &bytes)
            }
            Effect::Move(mv) if mv.from[X] != mv.to[X] || mv.from[Y] != mv.to[Y] || mv.e_mm() != 0.0 => {
                self.write_held(false, out)?;
                write(out, &bytes)
            }
            _ if self.held.len() < HOLD_LINES => {
                self.held.push(Held { bytes, retraction: None });
                Ok(Flow::Continue)
            }
            _ => {
                self.write_held(false, out)?;
                write(out, &bytes)
            }
        }
    }

    fn finish(&mut self, _state: &State, out: &mut dyn Write) -> Result<(), PassError> {
        self.write_held(false, out)?;
        if !self.started {
            self.acc.warnings.push(Warning::NoMixDefined);
        }
        Ok(())
    }
}

/// Runs the pass as `run` says (input, output, strictness, progress). A profile without a
/// dialect takes the one the file's flavour implies (read from both ends first).
pub fn mix(mut profile: MixProfile, run: Run<'_>) -> Result<(MixReport, Ran), MixPassError> {
    let mut run = run.writes_e();
    let flavour = run.flavour()?.map(str::to_owned);
    let chosen_blind = profile.hardware.dialect.is_none() && flavour.is_none();
    profile.dialect_for_file(flavour.as_deref());
    let mut pass = MixPass::new(profile)?;
    let ran = run.run(&mut pass)?;
    let mut report = pass.into_report();
    // A flavour named only in the middle of the file (standard input is spooled and read at
    // both ends as a file is) shows only once the dialect is written.
    if let Some(f) = report
        .flavour
        .as_deref()
        .filter(|f| chosen_blind && Firmware::resolve(None, Some(f)).mix_commands() != report.dialect)
    {
        report.warnings.push(Warning::DialectNotTheFlavours {
            flavour: f.to_owned(),
            wanted: format!("{:?}", Firmware::resolve(None, Some(f)).mix_commands()),
            written: format!("{:?}", report.dialect),
        });
    }
    Ok((report, ran))
}

/// [`mix`] of a whole text in memory, strictly (tests, examples).
pub fn mix_bytes(profile: MixProfile, input: &[u8]) -> Result<(Vec<u8>, MixReport), MixPassError> {
    let (report, ran) = mix(profile, Run::text(input).to_memory())?;
    Ok((ran.output, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(extra: &str) -> MixProfile {
        MixProfile::from_toml_str(&format!(
            "[[schedule]]\nlayer = 0\nmix = \"Red\"\n[[schedule]]\nlayer = 1\nmix = \"Blue\"\n{extra}"
        ))
        .unwrap()
    }

    const PRINT: &str =
        ";LAYER_CHANGE\nG1 Z0.2 F100\nG1 X10 E1 F1800\n;LAYER_CHANGE\nG1 Z0.4 F100\nG1 X0 E2\n";

    #[test]
    fn crlf_files_stay_crlf() {
        let input = format!("M83\r\n{}", PRINT.replace('\n', "\r\n"));
        let (out, report) = mix_bytes(profile(""), input.as_bytes()).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(report.changes, 1);
        assert!(!text.replace("\r\n", "").contains('\n'), "a bare LF in {text:?}");
    }

    #[test]
    fn no_change_no_purge_and_direct_mixing() {
        let same = MixProfile::from_toml_str("[hardware]\ndialect = \"marlin-direct\"\n[[schedule]]\nlayer = 0\nmix = \"Red\"\n[[schedule]]\nlayer = 1\nmix = \"Red@0\"\n").unwrap();
        let (out, report) = mix_bytes(same, PRINT.as_bytes()).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("M165 A0 B0.5 C0.5 D0\n"), "{text}");
        assert!(!text.contains("\nT"), "{text}");
        // Red with no material 2 is Red: the same mix, so no change and no purge.
        assert_eq!((report.changes, report.purge.count), (0, 0));
        let (_, r) = mix_bytes(profile("[purge]\nmode = \"off\""), PRINT.as_bytes()).unwrap();
        assert_eq!((r.changes, r.purge.count), (1, 0));
    }

    #[test]
    fn purge_refills_a_retraction_made_with_its_lift() {
        // The file retracts 0.8 mm while lifting, in one move, and reaches the change of mix
        // still retracted: the purge must refill those 0.8 mm before its 25 mm count (the
        // seed's 4 mm retraction, then 4 + 0.8 + 25 back out) and leave them retracted again.
        let input = "M83\n;LAYER_CHANGE\nG1 Z0.2 F100\nG1 X10 E1 F1800\nG1 Z0.6 E-0.8 F2100\n\
                     ;LAYER_CHANGE\nG1 Z0.4 F100\nG1 X0 E2 F1800\n";
        assert_eq!(purge_e_moves(input), ["G1 E-4 F2400", "G1 E29.8 F200", "G1 E-4.8 F2400"]);
    }

    /// The first three E-only moves of the first purge block of `input` mixed with two changes.
    fn purge_e_moves(input: &str) -> Vec<String> {
        let (out, report) = mix_bytes(profile(""), input.as_bytes()).unwrap();
        assert_eq!(report.purge.count, 1);
        let text = String::from_utf8(out).unwrap();
        let e_moves: Vec<String> = text
            .lines()
            .skip_while(|l| !l.starts_with("; gweave mix: purge"))
            .filter(|l| l.starts_with("G1 E"))
            .take(3)
            .map(str::to_owned)
            .collect();
        assert_eq!(e_moves.len(), 3, "{text}");
        e_moves
    }

    #[test]
    fn purge_refills_a_firmware_retraction_in_force() {
        // As above with `G10` (1 mm by default): the firmware's retraction is in force at the
        // change too, so the purge primes 4 + 1 + 25 and retracts 4 + 1 again. Before, mix
        // ignored it (E29 / E-4) while purge-shift counted it.
        let input = "M83\n;LAYER_CHANGE\nG1 Z0.2 F100\nG1 X10 E1 F1800\nG10\n\
                     ;LAYER_CHANGE\nG1 Z0.4 F100\nG1 X0 E2 F1800\n";
        assert_eq!(purge_e_moves(input), ["G1 E-4 F2400", "G1 E30 F200", "G1 E-5 F2400"]);
    }

    /// Regression: the warning for a flavour seen only during the pass said a pipe cannot be
    /// read ahead ("give it as a file, not a pipe"), though standard input is spooled and read
    /// at both ends as a file is: only a flavour named in the middle of a file is seen late.
    #[test]
    fn dialect_warning_for_a_flavour_in_the_middle_does_not_blame_a_pipe() {
        let (head, tail) = ("; padding\n".repeat(8_000), "; tail\n".repeat(40_000));
        let late = format!("{head}; gcode_flavor = reprapfirmware\n{PRINT}{tail}");
        let (_, report) = mix_bytes(profile(""), late.as_bytes()).unwrap();
        let warnings: Vec<String> = report.warnings.iter().map(ToString::to_string).collect();
        // The palette's Blue (layer 1) is out of the filaments' gamut, and says so first.
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings[0].starts_with("Blue: out of these filaments' gamut"), "{warnings:?}");
        let w = &warnings[1];
        assert!(w.contains("(reprapfirmware)") && w.contains("--dialect") && !w.contains("pipe"), "{w}");
        // Named in the file's ends, as slicers name it, the flavour chooses the dialect.
        let (_, report) =
            mix_bytes(profile(""), format!("{PRINT}; gcode_flavor = reprapfirmware\n").as_bytes()).unwrap();
        // Only Blue's gamut warning: nothing about the dialect.
        assert!(
            matches!(&report.warnings[..], [crate::post::warning::Warning::NameOutOfGamut { .. }]),
            "{:?}",
            report.warnings
        );
        assert_eq!(report.dialect, Firmware::RepRapFirmware.mix_commands());
    }

    #[test]
    fn inch_files_and_unmapped_tools_are_refused() {
        let err = mix_bytes(profile(""), format!("G20\n{PRINT}").as_bytes()).unwrap_err();
        assert!(err.to_string().contains("G20"), "{err}");
        let mut p = MixProfile::default();
        p.add_map("T0=Red").unwrap();
        let err = mix_bytes(p, format!("{PRINT}T1\nG1 X5 E3\n").as_bytes()).unwrap_err();
        assert_eq!(err.to_string(), "<input>:7: the file selects T1, which has no mix: add map T1=<mix>");
    }

    /// Regression (mix_keeps_m104_for_a_tool_the_mixing_machine_lacks): `mix` kept the slicer's
    /// `M104 S215 T1` (`sim --machine mixing-4in`: "Invalid extruder"). A temperature for the
    /// tool printing is the one nozzle's; one for another tool (a preheat, a standby, T0's too)
    /// is a comment, so the idle tool's standby never cools the nozzle printing.
    #[test]
    fn mix_keeps_m104_for_a_tool_the_mixing_machine_lacks() {
        let mut p = MixProfile::default();
        p.add_map("T0=Red").unwrap();
        p.add_map("T1=Blue").unwrap();
        let input = "M104 S215 T0\nM104 S215 T1 ; preheat\nM109 S215 T0\n;LAYER_CHANGE\nG1 Z0.2 F100\n\
                     G1 X10 E1 F1800\nM104 T1 S210\nT1\nM109 T1 S210 ; wait\nM104 T0 S150\nG1 X0 E2\n";
        let (out, report) = mix_bytes(p, input.as_bytes()).unwrap();
        let text = String::from_utf8(out).unwrap();
        let temperatures: Vec<&str> =
            text.lines().filter(|l| l.contains("M104") || l.contains("M109")).collect();
        let other = |l: &str, t: u32| {
            format!(
                "{l} ; gweave mix: for a slicer tool not printing (T{t} prints): one nozzle, one temperature"
            )
        };
        assert_eq!(
            temperatures,
            [
                "M104 S215 T0".to_string(),
                other(";M104 S215 T1 ; preheat", 0),
                "M109 S215 T0".to_string(),
                other(";M104 T1 S210", 0),
                "M109 S210 ; wait ; gweave mix: the mixing hotend, for the slicer's T1".to_string(),
                other(";M104 T0 S150", 1),
            ]
        );
        assert_eq!(report.tool_temperatures, 4);
    }
}
