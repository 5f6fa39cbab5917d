//! The purge sequence a mixing hotend needs after a change of mix, as the mixing
//! post-processor seed (`docs/seeds.md`) did it: retract, lift, travel to the purge spot, extrude, retract, wipe, come back, lower,
//! unretract, restore the extruder position.
//!
//! E bookkeeping. Let `r` be the block's own retraction and `d` the retraction the slicer already
//! has in force (an E-only retract not yet undone). At the spot the block primes `r + d` and
//! purges `p`, then retracts `r + d` again, and after lowering undoes only its own `r`:
//!
//! ```text
//!   -r  (retract)   +(r + d + p) (prime, purge)   -(r + d) (retract)   +r (unretract)
//!   net: p of filament at the spot; retraction in force afterwards: d, as before
//! ```
//!
//! `d` is only what the slicer will undo itself. A retraction in force that nothing after the
//! block undoes, `f` ([`PurgeJob::refill_mm`]: on one mixing nozzle, the old slicer tool's
//! tool-change retraction, which the new tool never unretracts), is primed with the purge and
//! not retracted again: `+(r + d + f + p)` at the spot, net `f + p`, and the next extrusion
//! starts from the nozzle the slicer meant.
//!
//! In absolute extrusion (M82) the block starts with `G92 E0`, so its numbers are small and
//! exact; in relative extrusion (M83, or G91 on Marlin) it writes increments. Either way it ends
//! with `G92 E<e>`, the position the file had before the block, so the next line of the file
//! extrudes exactly what the slicer meant. XYZ follow the file's own G90/G91. The feed rate and
//! the G0/G1 motion mode are restored at the end, since the next line may rely on them.
//!
//! ```text
//! ; gweave mix: purge Orange -> Pink, 25 mm
//! G92 E0
//! G1 E-4 F2400
//! G0 Z15.3 F200
//! G0 X10 Y10 F1320
//! G1 E25 F200
//! G1 E21 F2400
//! G0 X15 F1320
//! G0 X120.5 Y80 F1320
//! G0 Z0.3 F200
//! G1 E25 F2400
//! G92 E12.3456
//! G1 F1800
//! ; gweave mix: end purge
//! ```
//!
//! The same block serves `gweave purge-shift`'s fallbacks: `block` is exactly this (a blob at
//! the spot), `tower` replaces the blob by a compact zigzag at the current Z ([`PurgePattern`]),
//! a layer of a small purge tower next to the part.

use serde::{Deserialize, Serialize};

use crate::gcode::number::NumberFormat;
use crate::gcode::retraction::{write_e_only, write_e_reset};
use crate::gcode::state::{E, X, Y, Z};
use crate::range::{self, OutOfRange};
use crate::settings::{CheckRanges, Table};

/// Where and how to purge: the one purge-settings type, read from `gweave mix`'s `[purge]` table
/// (flattened into [`PurgeConfig`](crate::post::mix::profile::PurgeConfig)) and `gweave
/// purge-shift`'s `[block]` table, checked once by its [`CheckRanges`]. The default is the seed's:
/// retract 4 mm, lift 15 mm, purge at X10 Y10, wipe 5 mm along +X.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PurgeMotion {
    /// Retraction before the travel to the purge spot, mm.
    pub retract_mm: f64,
    /// Z lift before the travel, mm.
    pub lift_mm: f64,
    /// X of the purge spot, mm.
    pub x_mm: f64,
    /// Y of the purge spot, mm.
    pub y_mm: f64,
    /// Wipe along +X after the purge, mm.
    pub wipe_mm: f64,
    /// Feed of the travel to the spot and back, mm/min.
    pub travel_feed_mm_min: f64,
    /// Feed of the purge's extrusion, mm/min.
    pub extrude_feed_mm_min: f64,
    /// Feed of the retraction and unretraction, mm/min.
    pub retract_feed_mm_min: f64,
    /// Feed of the Z lift and lower, mm/min. Unset, each command puts its own: `mix` the travel
    /// feed under its Z cap, `purge-shift` [`PurgeMotion::SEED_Z_FEED_MM_MIN`].
    pub z_feed_mm_min: Option<f64>,
    /// Feed of the way back from the purge spot, mm/min (default: `travel_feed_mm_min`).
    pub return_feed_mm_min: Option<f64>,
    /// Feed of the lower back onto the print, mm/min (default: `z_feed_mm_min`).
    pub lower_feed_mm_min: Option<f64>,
    /// Feed of the last unretraction, mm/min (default: `retract_feed_mm_min`).
    pub unretract_feed_mm_min: Option<f64>,
}

impl CheckRanges for PurgeMotion {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("retract_mm", self.retract_mm, range::LEN_MM)?;
        t.check("lift_mm", self.lift_mm, range::LEN_MM)?;
        t.check("x_mm", self.x_mm, range::POSITION_MM)?;
        t.check("y_mm", self.y_mm, range::POSITION_MM)?;
        t.check("wipe_mm", self.wipe_mm, range::LEN_MM)?;
        t.check("travel_feed_mm_min", self.travel_feed_mm_min, range::FEED_MM_MIN)?;
        t.check("extrude_feed_mm_min", self.extrude_feed_mm_min, range::FEED_MM_MIN)?;
        t.check("retract_feed_mm_min", self.retract_feed_mm_min, range::FEED_MM_MIN)?;
        t.check_opt("z_feed_mm_min", self.z_feed_mm_min, range::FEED_MM_MIN)?;
        t.check_opt("return_feed_mm_min", self.return_feed_mm_min, range::FEED_MM_MIN)?;
        t.check_opt("lower_feed_mm_min", self.lower_feed_mm_min, range::FEED_MM_MIN)?;
        t.check_opt("unretract_feed_mm_min", self.unretract_feed_mm_min, range::FEED_MM_MIN)
    }
}

impl PurgeMotion {
    /// The seed's Z feed, mm/min.
    pub const SEED_Z_FEED_MM_MIN: f64 = 200.0;

    /// The seed's purge: 4 mm retraction, 15 mm lift, at X10 Y10, 5 mm wipe; the Z feed is left
    /// to the command.
    pub const SEED: PurgeMotion = PurgeMotion {
        retract_mm: 4.0,
        lift_mm: 15.0,
        x_mm: 10.0,
        y_mm: 10.0,
        wipe_mm: 5.0,
        travel_feed_mm_min: 1320.0,
        extrude_feed_mm_min: 200.0,
        retract_feed_mm_min: 2400.0,
        z_feed_mm_min: None,
        return_feed_mm_min: None,
        lower_feed_mm_min: None,
        unretract_feed_mm_min: None,
    };

    /// The mixing post-processor seed's own feeds: everything at F200 once it has set it
    /// (retract, lift, purge, retract, the way back), the travel out at F1320, then the lower
    /// and the unretraction at F150; no wipe. Lengths and the spot are kept from `self`.
    pub fn with_seed_feeds(self) -> PurgeMotion {
        PurgeMotion {
            wipe_mm: 0.0,
            travel_feed_mm_min: 1320.0,
            extrude_feed_mm_min: 200.0,
            retract_feed_mm_min: 200.0,
            z_feed_mm_min: Some(Self::SEED_Z_FEED_MM_MIN),
            return_feed_mm_min: Some(200.0),
            lower_feed_mm_min: Some(150.0),
            unretract_feed_mm_min: Some(150.0),
            ..self
        }
    }

    /// The feed of the Z lift and lower: the one set, else the travel feed.
    fn z_feed(&self) -> f64 {
        self.z_feed_mm_min.unwrap_or(self.travel_feed_mm_min)
    }
}

impl Default for PurgeMotion {
    fn default() -> Self {
        PurgeMotion::SEED
    }
}

/// What the nozzle does at the purge spot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PurgePattern {
    /// Extrude in place, a blob (the seed's purge, what `gweave mix` writes).
    Blob,
    /// A compact zigzag from the spot at the current Z: `rows` rows of `row_mm`, alternately
    /// along +X and -X, `pitch_mm` apart along +Y. E is fed in proportion to the path length,
    /// rows and steps alike: the flow of a printed line whose width is the pitch.
    Zigzag {
        /// Number of rows.
        rows: u32,
        /// Length of a row, mm.
        row_mm: f64,
        /// Distance between rows along +Y, mm.
        pitch_mm: f64,
    },
}

/// One purge: how much, how, and the names in its comment lines
/// (`; gweave <by>: purge <label>, <purge_mm> mm` ... `; gweave <by>: end purge`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PurgeJob<'a> {
    /// Filament to purge, mm.
    pub purge_mm: f64,
    /// Where the filament goes.
    pub pattern: PurgePattern,
    /// The command that writes it (`mix`, `purge-shift`).
    pub by: &'a str,
    /// The mix or tool purged into, for the comments.
    pub label: &'a str,
    /// Retraction in force beyond [`PurgeStart::retracted_mm`] that nothing after the block
    /// undoes, mm: on one nozzle, the tool-change retraction of a slicer tool the next tool
    /// never unretracts (it has its own nozzle to the slicer). The block primes it with the
    /// purge and leaves it unretracted, so the next extrusion starts from a full nozzle.
    pub refill_mm: f64,
}

/// The machine where the block starts, in the file's logical millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PurgeStart {
    /// X, Y, Z, E.
    pub pos: [f64; 4],
    /// G90 in force.
    pub absolute_xyz: bool,
    /// E relative (M83, or G91 on Marlin).
    pub relative_e: bool,
    /// The feed rate in force, restored at the end, mm/min.
    pub feed_mm_min: f64,
    /// G0 was the modal motion (restored with it).
    pub rapid_mode: bool,
    /// Retraction the slicer has in force and will undo itself, mm.
    pub retracted_mm: f64,
}

/// Writes G-code lines (`\n`-terminated) for one purge block.
struct Emitter<'a> {
    out: &'a mut Vec<u8>,
    fmt: &'a NumberFormat,
    start: PurgeStart,
    /// XYZ now.
    xyz: [f64; 3],
    /// E now, counted from the block's `G92 E0` (absolute) or its start (relative).
    e: f64,
}

impl Emitter<'_> {
    fn line(&mut self, text: &str) {
        self.out.extend_from_slice(text.as_bytes());
        self.out.push(b'\n');
    }

    /// A move to `xyz` (None: unchanged) extruding `de`, at `feed`.
    fn go(&mut self, rapid: bool, xyz: [Option<f64>; 3], de: f64, feed: f64) {
        self.out.extend_from_slice(if rapid { b"G0" } else { b"G1" });
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = xyz[i] {
                let word = if self.start.absolute_xyz { v } else { v - self.xyz[i] };
                self.out.push(b' ');
                self.fmt.write_word(self.out, letter, word);
                self.xyz[i] = v;
            }
        }
        if de != 0.0 {
            self.e += de;
            let word = if self.start.relative_e { de } else { self.e };
            self.out.push(b' ');
            self.fmt.write_word(self.out, b'E', word);
        }
        self.out.push(b' ');
        self.fmt.write_word(self.out, b'F', feed);
        self.out.push(b'\n');
    }

    /// Ends a block: the file's E position `e0` and, if the file set one, its feed rate and
    /// motion mode, which the next line may rely on.
    fn restore(&mut self, e0: f64) {
        let mut tail = Vec::new();
        write_e_reset(&mut tail, self.fmt, e0);
        self.line(&String::from_utf8_lossy(&tail));
        if self.start.feed_mm_min > 0.0 {
            let mut feed = Vec::new();
            write_e_only(&mut feed, self.fmt, self.start.rapid_mode, None, Some(self.start.feed_mm_min));
            self.line(&String::from_utf8_lossy(&feed));
        }
    }

    /// Extrudes `purge_mm` along the zigzag of [`PurgePattern::Zigzag`] from the current point.
    /// Each segment feeds the difference of the cumulative feed rounded to the written decimals,
    /// so in relative E the written words add up to the rounded purge exactly.
    fn zigzag(&mut self, m: &PurgeMotion, purge_mm: f64, rows: u32, row_mm: f64, pitch_mm: f64) {
        let path_mm = rows as f64 * row_mm + (rows - 1) as f64 * pitch_mm;
        let scale = 10f64.powi(self.fmt.extrusion_decimals as i32);
        let fed_at = |len_mm: f64| (purge_mm * len_mm / path_mm * scale).round() / scale;
        let [x0, y0, _] = self.xyz;
        let (mut done_mm, mut fed_mm) = (0.0, 0.0);
        for row in 0..rows {
            let y = y0 + row as f64 * pitch_mm;
            if row > 0 {
                done_mm += pitch_mm;
                let de = fed_at(done_mm) - fed_mm;
                fed_mm += de;
                self.go(false, [None, Some(y), None], de, m.extrude_feed_mm_min);
            }
            done_mm += row_mm;
            let de = if row + 1 == rows { fed_at(path_mm) - fed_mm } else { fed_at(done_mm) - fed_mm };
            fed_mm += de;
            let x = if row % 2 == 0 { x0 + row_mm } else { x0 };
            self.go(false, [Some(x), None, None], de, m.extrude_feed_mm_min);
        }
    }
}

/// Appends `gweave mix`'s purge block for `purge_mm` of filament, priming `refill_mm` with it
/// ([`PurgeJob::refill_mm`]), to `out`; `label` names the change.
pub(crate) fn write_purge(
    out: &mut Vec<u8>,
    fmt: &NumberFormat,
    m: &PurgeMotion,
    start: &PurgeStart,
    purge_mm: f64,
    refill_mm: f64,
    label: &str,
) {
    let job = PurgeJob { purge_mm, pattern: PurgePattern::Blob, by: "mix", label, refill_mm };
    write_purge_job(out, fmt, m, start, &job);
}

/// Appends a purge block to `out`, with the pattern and comment names of `job`.
pub(crate) fn write_purge_job(
    out: &mut Vec<u8>,
    fmt: &NumberFormat,
    m: &PurgeMotion,
    start: &PurgeStart,
    job: &PurgeJob,
) {
    let [x, y, z, e0] = start.pos;
    let purge_mm = job.purge_mm;
    let mut w = Emitter { out, fmt, start: *start, xyz: [x, y, z], e: 0.0 };
    let mut head = Vec::new();
    fmt.write(&mut head, purge_mm, 2);
    w.line(&format!("; gweave {}: purge {}, {} mm", job.by, job.label, String::from_utf8_lossy(&head)));
    if !start.relative_e {
        w.line("G92 E0");
    }
    let (r, d, refill) = (m.retract_mm, start.retracted_mm.max(0.0), job.refill_mm.max(0.0));
    if r > 0.0 {
        w.go(false, [None; 3], -r, m.retract_feed_mm_min);
    }
    if m.lift_mm > 0.0 {
        w.go(true, [None, None, Some(z + m.lift_mm)], 0.0, m.z_feed());
    }
    w.go(true, [Some(m.x_mm), Some(m.y_mm), None], 0.0, m.travel_feed_mm_min);
    match job.pattern {
        PurgePattern::Blob => w.go(false, [None; 3], r + d + refill + purge_mm, m.extrude_feed_mm_min),
        PurgePattern::Zigzag { rows, row_mm, pitch_mm } => {
            if r + d + refill > 0.0 {
                w.go(false, [None; 3], r + d + refill, m.retract_feed_mm_min);
            }
            w.zigzag(m, purge_mm, rows.max(1), row_mm, pitch_mm);
        }
    }
    if r + d > 0.0 {
        w.go(false, [None; 3], -(r + d), m.retract_feed_mm_min);
    }
    if m.wipe_mm > 0.0 {
        w.go(true, [Some(m.x_mm + m.wipe_mm), None, None], 0.0, m.travel_feed_mm_min);
    }
    w.go(true, [Some(x), Some(y), None], 0.0, m.return_feed_mm_min.unwrap_or(m.travel_feed_mm_min));
    if m.lift_mm > 0.0 {
        w.go(true, [None, None, Some(z)], 0.0, m.lower_feed_mm_min.unwrap_or(m.z_feed()));
    }
    if r > 0.0 {
        w.go(false, [None; 3], r, m.unretract_feed_mm_min.unwrap_or(m.retract_feed_mm_min));
    }
    w.restore(e0);
    w.line(&format!("; gweave {}: end purge", job.by));
}

/// Appends the prime of `refill_mm` that a change of mix without a purge block still owes
/// ([`PurgeJob::refill_mm`]): an E-only move where the nozzle stands, at the unretraction feed,
/// then the file's E position and feed rate restored.
pub(crate) fn write_refill(
    out: &mut Vec<u8>,
    fmt: &NumberFormat,
    m: &PurgeMotion,
    start: &PurgeStart,
    refill_mm: f64,
) {
    let [x, y, z, e0] = start.pos;
    let mut w = Emitter { out, fmt, start: *start, xyz: [x, y, z], e: 0.0 };
    let mut head = Vec::new();
    fmt.write(&mut head, refill_mm, 2);
    w.line(&format!(
        "; gweave mix: refill {} mm another slicer tool left retracted",
        String::from_utf8_lossy(&head)
    ));
    if !start.relative_e {
        w.line("G92 E0");
    }
    w.go(false, [None; 3], refill_mm, m.unretract_feed_mm_min.unwrap_or(m.retract_feed_mm_min));
    w.restore(e0);
    w.line("; gweave mix: end refill");
}

/// X, Y, Z and E of a core position.
pub(crate) fn purge_start_pos(pos: &crate::gcode::state::Position) -> [f64; 4] {
    [pos[X], pos[Y], pos[Z], pos[E]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::lexer::parse_into;
    use crate::gcode::line::Block;
    use crate::gcode::state::{Effect, State};

    /// The seed's purge with the seed's Z feed, as `purge-shift` resolves it.
    const SEED: PurgeMotion =
        PurgeMotion { z_feed_mm_min: Some(PurgeMotion::SEED_Z_FEED_MM_MIN), ..PurgeMotion::SEED };

    /// Runs `prefix`, then the block from the resulting state; returns the text, the state after,
    /// and the filament the block fed.
    fn run(prefix: &str, retracted_mm: f64) -> (String, State, f64) {
        let mut state = State::default();
        let mut block = Block::default();
        for l in prefix.lines() {
            parse_into(l.as_bytes(), &mut block);
            state.apply(l.as_bytes(), &block);
        }
        let start = PurgeStart {
            pos: purge_start_pos(&state.pos),
            absolute_xyz: state.absolute(),
            relative_e: state.relative_e(),
            feed_mm_min: state.feed_mm_min,
            rapid_mode: false,
            retracted_mm,
        };
        let mut out = Vec::new();
        write_purge(&mut out, &NumberFormat::default(), &SEED, &start, 25.0, 0.0, "A -> B");
        let text = String::from_utf8(out).unwrap();
        let before = state.filament_mm[0];
        let mut max_z_feed: f64 = 0.0;
        for l in text.lines() {
            parse_into(l.as_bytes(), &mut block);
            if let Effect::Move(m) = state.apply(l.as_bytes(), &block) {
                if m.to[Z] != m.from[Z] {
                    max_z_feed = max_z_feed.max(m.feed_mm_min);
                }
            }
        }
        assert_eq!(max_z_feed, 200.0);
        let fed = state.filament_mm[0] - before;
        (text, state, fed)
    }

    #[test]
    fn absolute_extrusion_returns_to_the_same_state() {
        let (text, s, fed) = run("M82\nG1 X120.5 Y80 Z0.3 E12.3456 F1800", 0.0);
        assert_eq!(
            text,
            "; gweave mix: purge A -> B, 25 mm\nG92 E0\nG1 E-4 F2400\nG0 Z15.3 F200\nG0 X10 Y10 F1320\n\
             G1 E25 F200\nG1 E21 F2400\nG0 X15 F1320\nG0 X120.5 Y80 F1320\nG0 Z0.3 F200\nG1 E25 F2400\n\
             G92 E12.3456\nG1 F1800\n; gweave mix: end purge\n"
        );
        assert_eq!([s.pos[X], s.pos[Y], s.pos[Z], s.pos[E]], [120.5, 80.0, 0.3, 12.3456]);
        assert!((fed - 25.0).abs() < 1e-9);
        assert_eq!(s.feed_mm_min, 1800.0);
    }

    #[test]
    fn relative_extrusion_and_a_slicer_retraction() {
        let (text, s, fed) = run("M83\nG1 X20 Y30 Z1 E0.5 F1500\nG1 E-2", 2.0);
        assert!(text.contains("\nG1 E-4 F2400\n"), "{text}");
        assert!(text.contains("\nG1 E31 F200\n"), "{text}");
        assert!(text.contains("\nG1 E-6 F2400\n"), "{text}");
        // Back where it was: same XYZ, same logical E, the slicer's 2 mm still retracted.
        assert_eq!([s.pos[X], s.pos[Y], s.pos[Z]], [20.0, 30.0, 1.0]);
        assert!((s.pos[E] - -1.5).abs() < 1e-9);
        assert!((fed - 25.0).abs() < 1e-9);
    }

    #[test]
    fn relative_axes_follow_g91() {
        let (text, s, _) = run("G1 X20 Y30 Z1 F1500\nG91", 0.0);
        assert!(text.contains("\nG0 Z15 F200\nG0 X-10 Y-20 F1320\n"), "{text}");
        assert_eq!([s.pos[X], s.pos[Y], s.pos[Z]], [20.0, 30.0, 1.0]);
    }

    #[test]
    fn seed_feeds_are_the_mixing_seeds_purge() {
        // The mixing seed's block: G0 F200, retract 4, lift 15, G0 F1320 to X10 Y10, F200,
        // extrude 25, retract 4, back (still F200), G0 F150, lower 15, unretract 4.
        let start = PurgeStart {
            pos: [50.0, 60.0, 0.4, 0.0],
            absolute_xyz: true,
            relative_e: true,
            feed_mm_min: 1800.0,
            rapid_mode: false,
            retracted_mm: 0.0,
        };
        let m = SEED.with_seed_feeds();
        let mut out = Vec::new();
        write_purge(&mut out, &NumberFormat::default(), &m, &start, 25.0, 0.0, "A -> B");
        let text = String::from_utf8(out).unwrap();
        let feeds: Vec<&str> =
            text.lines().filter_map(|l| l.split_whitespace().find(|w| w.starts_with('F'))).collect();
        assert_eq!(
            feeds,
            ["F200", "F200", "F1320", "F200", "F200", "F200", "F150", "F150", "F1800"],
            "{text}"
        );
        assert!(!text.contains("X15"), "no wipe: {text}");
    }

    #[test]
    fn zigzag_feeds_the_purge_exactly_and_comes_back() {
        for prefix in
            ["M82\nG1 X120.5 Y80 Z0.3 E12.3456 F1800", "M83\nG1 X120.5 Y80 Z0.3 E0.5 F1800\nG1 E-0.8"]
        {
            let mut state = State::default();
            let mut block = Block::default();
            for l in prefix.lines() {
                parse_into(l.as_bytes(), &mut block);
                state.apply(l.as_bytes(), &block);
            }
            let pos = purge_start_pos(&state.pos);
            let retracted_mm = if state.relative_e() { 0.8 } else { 0.0 };
            let start = PurgeStart {
                pos,
                absolute_xyz: true,
                relative_e: state.relative_e(),
                feed_mm_min: 1800.0,
                rapid_mode: false,
                retracted_mm,
            };
            let m =
                PurgeMotion { retract_mm: 0.8, lift_mm: 0.0, x_mm: 130.0, y_mm: 70.0, wipe_mm: 0.0, ..SEED };
            let fmt = NumberFormat { extrusion_decimals: 6, position_decimals: 5, ..NumberFormat::default() };
            let pattern = PurgePattern::Zigzag { rows: 7, row_mm: 3.1, pitch_mm: 0.5 };
            let job =
                PurgeJob { purge_mm: 1.2345678, pattern, by: "purge-shift", label: "T0->T1", refill_mm: 0.0 };
            let mut out = Vec::new();
            write_purge_job(&mut out, &fmt, &m, &start, &job);
            let text = String::from_utf8(out).unwrap();
            assert!(text.starts_with("; gweave purge-shift: purge T0->T1, 1.23 mm\n"), "{text}");
            assert!(text.ends_with("; gweave purge-shift: end purge\n"), "{text}");
            let before = state.filament_mm[0];
            let (mut printed, mut rows) = (0.0, 0);
            for l in text.lines() {
                parse_into(l.as_bytes(), &mut block);
                if let Effect::Move(mv) = state.apply(l.as_bytes(), &block) {
                    if mv.is_extruding() {
                        printed += mv.e_mm();
                        rows += usize::from(mv.to[Y] == mv.from[Y]);
                        // The zigzag stays in its footprint, at the layer's Z.
                        assert!((130.0..=133.1).contains(&mv.to[X]) && (70.0..=73.0).contains(&mv.to[Y]));
                        assert_eq!(mv.to[Z], 0.3);
                    }
                }
            }
            assert_eq!(rows, 7);
            assert!((printed - 1.234568).abs() < 1e-9, "{printed}");
            assert!((state.filament_mm[0] - before - 1.234568).abs() < 1e-9);
            assert_eq!([state.pos[X], state.pos[Y], state.pos[Z]], [pos[0], pos[1], pos[2]], "{text}");
            assert!((state.pos[E] - pos[3]).abs() < 1e-12, "{text}");
        }
    }
}
