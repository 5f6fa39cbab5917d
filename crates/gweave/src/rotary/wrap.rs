//! `wrap`: a part sliced flat, printed onto the mandrel (the rotary seed's method (a), docs/seeds.md).
//!
//! The flat file's X runs along the mandrel, its Y around it (its Y length should be the
//! circumference `pi * D`), its Z away from it. Each motion line is rewritten:
//!
//! 1. G2/G3 arcs are cut into chords in the flat plane first (the core
//!    [`crate::gcode::arc::Arc`] geometry), since
//!    an arc in (x, y) is no arc on the cylinder;
//! 2. every piece is mapped with [`UnwrapConfig::map`] and cut again into chords whose
//!    sagitta on the cylinder stays within `chord_tolerance_mm` (0 = no cutting);
//! 3. positive E grows by the stretch of the surface, [`UnwrapConfig::e_scale`] (retractions and
//!    wipes are filament moves, not beads, and keep their length);
//! 4. the flat F is the surface speed to keep; the F written is converted per the machine's
//!    feed convention from the rounded words ([`super::emit`]).
//!
//! The output starts with two comment lines naming the machine
//! ([`RotaryConfig::header_lines`]), so that `gweave preview` draws it on its cylinder. Every
//! other line is copied byte for byte, except `G92` with axis words (re-declared in
//! machine words). Before the first move the mandrel angle is declared with `G92 <rotary>`;
//! with the inverse-time convention `G93` precedes it and `G94` ends the file. Homing that may
//! move the rotary axis (`G28` with Y, or with no axis) makes the angle unknown, and it is
//! declared again before the next move. Machine-setup M-codes that name axes (`M92`, `M203`...)
//! are said for the rotary machine: Y renamed to the rotary axis (its value converted to
//! degrees where the rotary word is in degrees), X and Z to the axial and radial axes
//! (the `setup` module).
//!
//! Before writing, the file is read once for the `y` span of its extrusions
//! (`rotary::helical`): a part wider than the circumference is refused unless
//! `allow_overlap`, and the helical mapping starts its turn at the part's smallest `y`.
//!
//! The seam rotation counts layers from the slicer's layer comments (the core
//! [`crate::gcode::layers`] structure); a file without them is one layer.
//!
//! Before and after, on a mandrel of 60 mm circumference (Y15 = a quarter turn), NIST feed,
//! chords off: at r = R0 + 0.2 the 18.03 mm flat move is 18.29 mm on the surface, so E grows
//! by 1.45 % and, at the same 20 mm/s, F is the axial speed 10 mm / 0.914 s.
//!
//! ```
//! use gweave::rotary::{cylinder::RotaryConfig, wrap::{wrap_bytes, WrapConfig}};
//! let mut config = WrapConfig::new(RotaryConfig::new(60.0 / std::f64::consts::PI));
//! config.chord_tolerance_mm = 0.0;
//! let before = "G1 Z0.2 F600\nG1 X10 Y15 E1.0 F1200 ; first\nM106 S255\n";
//! let after = "; gweave rotary wrap: mandrel 19.098593171027442 mm\n\
//!              ; axes: axial X, rotary A (Degrees), radial Z (0 = on the mandrel); feed Nist\n\
//!              G92 A0.000\nG1 Z0.200 F600.000\n\
//!              G1 X10.000 A90.000 E1.01455 F656.097 ; first\nM106 S255\n";
//! assert_eq!(String::from_utf8(wrap_bytes(config, before.as_bytes()).unwrap()).unwrap(), after);
//! ```

use std::io::Write;

use serde::{Deserialize, Serialize};

use super::cylinder::{chord_pieces, CylPoint, RotaryConfig, UnwrapConfig};
use super::emit::{rotary_number_format, validate_format, MoveSpec, MoveWriter};
use super::helical::{check_width, part_extent, PartExtent, Ramp};
use super::helix::CHORD_TOLERANCE_MM;
use super::setup::rewrite_setup;
use super::{in_range, Result, RotaryError};
use crate::eol::Eol;
use crate::gcode::number::NumberFormat;
use crate::gcode::state::{Effect, Move, Path, State, E, X, Y, Z};
use crate::pass::{keep, Ctx, Flow, Pass, PassError, Step};
use crate::run::{Ran, Run};

/// Settings of the wrap pass. In TOML, top-level keys first, then the tables:
///
/// ```toml
/// chord_tolerance_mm = 0.01   # sagitta on the cylinder; 0 = do not cut long moves
/// arc_tolerance_mm = 0.01     # sagitta of G2/G3 chords in the flat
/// [machine]                   # a RotaryConfig
/// mandrel_diameter_mm = 50.0
/// [unwrap]                    # an UnwrapConfig, optional
/// seam_rotation_per_layer_deg = 5.0
/// [numbers]                   # the core NumberFormat, optional (default: fixed 3/5/3)
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WrapConfig {
    /// Largest chord sagitta on the cylinder, mm (0 = one chord per flat move).
    #[serde(default = "default_tolerance")]
    pub chord_tolerance_mm: f64,
    /// Largest chord sagitta when linearising G2/G3 in the flat, mm.
    #[serde(default = "default_tolerance")]
    pub arc_tolerance_mm: f64,
    /// The machine.
    pub machine: RotaryConfig,
    /// The mapping.
    #[serde(default)]
    pub unwrap: UnwrapConfig,
    /// Decimal places of rewritten words.
    #[serde(default = "rotary_number_format")]
    pub numbers: NumberFormat,
    /// Wrap a part wider than the circumference over itself instead of refusing it.
    #[serde(default)]
    pub allow_overlap: bool,
    /// Travel the short way round: a travel that would turn the mandrel more than half a turn
    /// turns the other way, and the angle is declared back onto the mapping with `G92`.
    #[serde(default = "default_short_travel")]
    pub short_travel: bool,
}

fn default_short_travel() -> bool {
    true
}

/// Most chords one flat move becomes (a move of many turns round a thin mandrel); past it the
/// move is refused rather than written as gigabytes.
pub const MAX_CHORDS_PER_MOVE: usize = 1_000_000;

fn default_tolerance() -> f64 {
    0.01
}

impl WrapConfig {
    /// Wrapping onto `machine` with every other setting at its default.
    pub fn new(machine: RotaryConfig) -> Self {
        Self {
            chord_tolerance_mm: default_tolerance(),
            arc_tolerance_mm: default_tolerance(),
            machine,
            unwrap: UnwrapConfig::default(),
            numbers: rotary_number_format(),
            allow_overlap: false,
            short_travel: true,
        }
    }

    /// Reads and validates a TOML document.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let config: Self = toml::from_str(text)?;
        config.validate()?;
        Ok(config)
    }

    /// Checks every range.
    pub fn validate(&self) -> Result<()> {
        // 0 is one chord per flat move.
        in_range("", "chord_tolerance_mm", self.chord_tolerance_mm, CHORD_TOLERANCE_MM.or_zero())?;
        in_range("", "arc_tolerance_mm", self.arc_tolerance_mm, CHORD_TOLERANCE_MM)?;
        self.machine.validate()?;
        self.unwrap.validate()?;
        validate_format("numbers", &self.numbers)
    }
}

/// The wrap pass; see the module docs. A line it cannot wrap is refused with a [`RotaryError`],
/// to which the driver adds the file and the line ([`crate::Error::Pass`]).
#[derive(Debug)]
pub struct Wrap {
    config: WrapConfig,
    writer: MoveWriter,
    started: bool,
    /// A line has given an `F` word: a move at feed 0 is then one at `F0`, not one before any
    /// feed rate.
    feed_given: bool,
    /// The header naming the machine ([`RotaryConfig::header_lines`]) is out.
    headed: bool,
    /// The file's line endings, for the lines the wrap writes.
    eol: Eol,
    /// The last line read had no ending (the file's last line, unterminated).
    unterminated: bool,
    buffer: Vec<u8>,
    /// The helical ramp of the current layer (helical mapping only).
    ramp: Option<Ramp>,
}

impl Wrap {
    /// A pass for a validated configuration, given the `y` span of the part's extrusions
    /// (`helical::file_extent`): a part wider than the circumference is refused
    /// unless `allow_overlap`. The machine starts where the core state does, at flat (0, 0, 0),
    /// with the mandrel angle not yet declared.
    pub fn new(config: WrapConfig, extent: Option<PartExtent>) -> Result<Self> {
        config.validate()?;
        check_width(&config.machine, extent, config.allow_overlap)?;
        let mut writer = MoveWriter::new(config.machine.clone(), config.numbers, 0.0);
        let origin = config.unwrap.map(&config.machine, [0.0; 3], 0)?;
        writer.assume(origin, [true, false, true]);
        let ramp = config.unwrap.helical.then(|| Ramp::new(extent.map_or(0.0, |e| e.y_min_mm)));
        Ok(Self {
            config,
            writer,
            started: false,
            feed_given: false,
            headed: false,
            eol: Eol::default(),
            unterminated: false,
            buffer: Vec::new(),
            ramp,
        })
    }

    fn map(&self, flat: [f64; 3], layer: u32) -> Result<CylPoint> {
        let [x, y, mut z] = flat;
        if let Some(ramp) = &self.ramp {
            z -= ramp.drop_mm(y, self.config.machine.circumference_mm());
        }
        self.config.unwrap.map(&self.config.machine, [x, y, z], layer)
    }

    /// For a travel to flat `to` that would turn the mandrel more than half a turn: where it
    /// ends when it turns the other way, whole turns off the mapped angle (`None` when the
    /// mapped way is already the short one, or the angle is not known).
    fn short_way(&self, to: [f64; 3], layer: u32) -> Result<Option<CylPoint>> {
        let Some(here) = self.writer.position() else { return Ok(None) };
        let mut there = self.map(to, layer)?;
        // Half a turn either way is as short: keep the mapped one.
        if (here.theta_deg - there.theta_deg).abs() <= 180.0 {
            return Ok(None);
        }
        let turns = ((here.theta_deg - there.theta_deg) / 360.0).round();
        there.theta_deg += 360.0 * turns;
        Ok(Some(there))
    }

    /// Rewrites one line into `self.buffer`, or returns `false` to keep it as it is.
    fn rewrite(&mut self, ctx: &Ctx<'_>) -> Result<bool> {
        let state = ctx.state;
        self.writer.set_modes(!state.absolute(), state.relative_e());
        let layer = state.structure.layer.unwrap_or(0);
        if let Some(ramp) = &mut self.ramp {
            ramp.observe(&state.structure);
        }
        match ctx.effect {
            Effect::Move(mv) => self.rewrite_move(ctx, mv, layer),
            Effect::Home { axes } => {
                let p = self.map(flat(&state.pos), layer)?;
                let homed = |i: usize| axes & (1 << i) != 0;
                self.writer.assume(p, [homed(X), false, homed(Z)]);
                if homed(Y) {
                    self.writer.forget([false, true, false]);
                }
                Ok(false)
            }
            Effect::SetPosition => {
                if ctx.block.has(b'E') {
                    self.writer.set_e(state.pos[E]);
                }
                let axes = [X, Y, Z].map(|i| ctx.block.get(b"XYZ"[i]).is_some());
                if axes == [false; 3] {
                    return Ok(false);
                }
                // Y sets the angle; the flat Z also moves it under keep_arc_length.
                let machine_axes = [axes[0], axes[1] || axes[2], axes[2]];
                let p = self.map(flat(&state.pos), layer)?;
                self.writer.declare(&mut self.buffer, p, machine_axes)?;
                if ctx.block.has(b'E') {
                    // Keep the E reset on the same line's meaning: append it as written.
                    self.buffer.pop();
                    let e_word = ctx.block.word(b'E').map(|w| w.span.of(ctx.line.bytes));
                    self.buffer.push(b' ');
                    self.buffer.extend_from_slice(e_word.unwrap_or(b"E0"));
                    self.buffer.push(b'\n');
                }
                Ok(true)
            }
            _ => match rewrite_setup(&self.config.machine, &self.config.numbers, ctx.line.bytes, ctx.block) {
                Some(line) => {
                    self.buffer.extend_from_slice(&line);
                    self.buffer.push(b'\n');
                    Ok(true)
                }
                None => Ok(false),
            },
        }
    }

    fn rewrite_move(&mut self, ctx: &Ctx<'_>, mv: &Move, layer: u32) -> Result<bool> {
        if ctx.state.inches {
            return Err(RotaryError::Config {
                key: "G20",
                reason: "wrap writes millimetres; convert the file to G21 first".into(),
            });
        }
        let (from, to) = (flat(&mv.from), flat(&mv.to));
        let e_mm = mv.e_mm();
        let moves_axes = from != to || matches!(mv.path, Path::Arc(_));
        if !moves_axes && e_mm == 0.0 {
            return Ok(false);
        }
        let speed_mm_s = mv.feed_mm_min / 60.0;
        if speed_mm_s.is_nan() || speed_mm_s <= 0.0 {
            let reason = if self.feed_given {
                format!(
                    "a move at F{}: set a feed rate above 0 before it",
                    crate::range::short(mv.feed_mm_min)
                )
            } else {
                "a move before any feed rate was set".into()
            };
            return Err(RotaryError::Config { key: "F", reason });
        }
        if !self.started {
            self.writer.enter_feed_mode(&mut self.buffer)?;
            self.started = true;
        }
        if !self.writer.rotary_known() {
            let p = self.map(from, layer)?;
            self.writer.declare(&mut self.buffer, p, [false, true, false])?;
        }
        let comment = ctx.block.comment_text(ctx.line.bytes);
        if !moves_axes {
            self.writer.extrude_only(&mut self.buffer, e_mm, speed_mm_s, comment)?;
            return Ok(true);
        }
        // A travel goes the short way round in one machine move (it lays no bead, so it need
        // not follow the flat path), then the angle is declared back onto the mapping: the
        // mandrel is physically where the mapped angle is, whole turns away.
        let short = if e_mm <= 0.0 && self.config.short_travel { self.short_way(to, layer)? } else { None };
        if let Some(there) = short {
            let spec = MoveSpec { rapid: mv.rapid, to: there, e_mm, speed_mm_s, comment };
            self.writer.write_move(&mut self.buffer, &spec)?;
            let mapped = self.map(to, layer)?;
            self.writer.declare(&mut self.buffer, mapped, [false, true, false])?;
            return Ok(true);
        }
        self.write_pieces(mv, layer, e_mm, speed_mm_s, comment)?;
        Ok(true)
    }

    /// The move's pieces: arcs in chords, chords on the cylinder within the tolerance.
    fn write_pieces(
        &mut self,
        mv: &Move,
        layer: u32,
        e_mm: f64,
        speed_mm_s: f64,
        mut comment: Option<&[u8]>,
    ) -> Result<()> {
        let from = flat(&mv.from);
        let pieces = flat_pieces(mv, self.config.arc_tolerance_mm)?;
        let share = 1.0 / pieces.len() as f64;
        let mut prev = from;
        // Chords written for this move so far: an arc of kilometres round a thin mandrel is
        // thousands of turns per piece, and the pieces add up.
        let mut chords = 0usize;
        for next in pieces {
            let (a, b) = (self.map(prev, layer)?, self.map(next, layer)?);
            let cuts = if self.config.chord_tolerance_mm > 0.0 {
                let radius = a.radius_mm.max(b.radius_mm);
                chord_pieces(radius, b.theta_deg - a.theta_deg, self.config.chord_tolerance_mm)
            } else {
                1
            };
            chords = chords.saturating_add(cuts);
            if chords > MAX_CHORDS_PER_MOVE {
                return Err(RotaryError::TooManyChords { limit: MAX_CHORDS_PER_MOVE });
            }
            for j in 1..=cuts {
                let t0 = (j - 1) as f64 / cuts as f64;
                let t1 = j as f64 / cuts as f64;
                let (q0, q1) = (lerp3(prev, next, t0), lerp3(prev, next, t1));
                let mut e_piece = e_mm * share / cuts as f64;
                if e_piece > 0.0 {
                    let machine = &self.config.machine;
                    e_piece *= self.config.unwrap.e_scale(machine, q0, q1);
                    if let Some(ramp) = &self.ramp {
                        e_piece *= ramp.e_factor(q0[1], q1[1], machine.circumference_mm());
                    }
                }
                let spec = MoveSpec {
                    rapid: mv.rapid,
                    to: self.map(q1, layer)?,
                    e_mm: e_piece,
                    speed_mm_s,
                    comment: comment.take(),
                };
                self.writer.write_move(&mut self.buffer, &spec)?;
            }
            prev = next;
        }
        Ok(())
    }
}

/// The flat XYZ of a core position.
fn flat(pos: &crate::gcode::state::Position) -> [f64; 3] {
    [pos[X], pos[Y], pos[Z]]
}

fn lerp3(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t)
}

/// The flat end points of a move's pieces: the end itself for a line, chords within
/// `tolerance_mm` for an arc (Z rising linearly along it, a helix).
fn flat_pieces(mv: &Move, tolerance_mm: f64) -> Result<Vec<[f64; 3]>> {
    let to = flat(&mv.to);
    let Path::Arc(arc) = mv.path else {
        return Ok(vec![to]);
    };
    let n = arc.segments(tolerance_mm);
    if n > MAX_CHORDS_PER_MOVE {
        return Err(RotaryError::TooManyChords { limit: MAX_CHORDS_PER_MOVE });
    }
    let mut points: Vec<[f64; 3]> = (1..n)
        .map(|i| {
            let t = i as f64 / n as f64;
            let [x, y] = arc.point(t);
            [x, y, mv.from[Z] + (mv.to[Z] - mv.from[Z]) * t]
        })
        .collect();
    points.push(to);
    Ok(points)
}

impl Pass for Wrap {
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        self.eol.learn(ctx.line.eol);
        self.unterminated = ctx.line.eol.is_empty();
        if !self.headed {
            self.headed = true;
            let header = self.config.machine.header_lines("wrap").join("\n");
            self.eol.block(out, header.as_bytes())?;
        }
        self.buffer.clear();
        self.feed_given |= ctx.block.has(b'F');
        if !self.rewrite(ctx).map_err(PassError::refuse)? {
            return keep(ctx, out);
        }
        // The writer ends lines with `\n`: the file's own ending instead (none after the last
        // line of a file that has none).
        self.eol.text(out, &self.buffer, ctx.line.eol)?;
        Ok(Flow::Continue)
    }

    fn finish(&mut self, _state: &State, out: &mut dyn Write) -> Result<(), PassError> {
        if !self.started {
            return Ok(());
        }
        self.buffer.clear();
        self.writer.leave_feed_mode(&mut self.buffer).map_err(PassError::refuse)?;
        if self.buffer.is_empty() {
            return Ok(());
        }
        // In the file's line ending; after a last line without one, the closing line becomes
        // the last line and goes without.
        if self.unterminated {
            out.write_all(self.eol.get())?;
            self.eol.text(out, &self.buffer, b"")?;
        } else {
            self.eol.block(out, &self.buffer)?;
        }
        Ok(())
    }
}

/// Wraps as `run` says (input, output, strictness, progress): the file is read once for the
/// part's width first (`rotary::helical`), then wrapped. The wrap writes the rotary axis as
/// `A`: a file that extrudes with `A` (PrusaSlicer's mach3 and machinekit flavours) is refused.
pub fn wrap(config: WrapConfig, run: Run<'_>) -> Result<Ran> {
    let mut run = run.writes_e();
    let extent = part_extent(&mut run)?;
    let mut pass = Wrap::new(config, extent)?;
    Ok(run.run(&mut pass)?)
}

/// [`wrap`] of a whole text in memory, strictly (tests, examples).
pub fn wrap_bytes(config: WrapConfig, input: &[u8]) -> Result<Vec<u8>> {
    Ok(wrap(config, Run::text(input).to_memory())?.output)
}
