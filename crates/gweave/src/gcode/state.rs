//! The modal machine state: what a printer would know after executing every line so far.
//!
//! Positions are kept in millimetres in the file's own (logical) coordinates, with G20 inches,
//! G91 relative moves and M83 relative extrusion resolved here once, so that every pass above
//! sees absolute millimetres. `G92` changes the logical origin; the cumulative filament fed per
//! tool is tracked separately from the E coordinate so that resets do not lose it.

use super::arc::{Arc, ArcRefusal};
use super::layers::{Markers, Structure};
use super::line::{Block, Command, PlainMove, Value, Word};
use crate::firmware::Firmware;

pub use super::axes::{axis_of, Position, A, AXES, AXIS_LETTERS, B, C, E, X, Y, Z};
pub use super::effect::{Effect, Motion, Move, Path};
pub use super::limits::MAX_TOOLS;

/// The axis a word moves: as [`axis_of`], but the extrusion word ([`Firmware::
/// extrusion_letter`]) is E, and `E` is no axis where another letter extrudes.
#[inline]
fn axis_of_word(letter: u8, extrusion_letter: u8) -> Option<usize> {
    if letter == extrusion_letter {
        return Some(E);
    }
    axis_of(letter).filter(|&i| i != E)
}

/// Millimetres in an inch (G20 files), exactly.
pub(crate) const MM_PER_INCH: f64 = 25.4;

/// Temperatures and fan the file has asked for.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Thermal {
    /// Target per hotend, °C (grown on demand).
    pub hotend_c: Vec<f64>,
    /// Bed target, °C.
    pub bed_c: f64,
    /// Any hotend temperature has been set (for the cold-extrusion lint).
    pub hotend_set: bool,
    /// Part fan, 0..=1.
    pub fan: f64,
}

/// Options fixed for a whole file.
#[derive(Debug, Clone, PartialEq)]
pub struct StateOptions {
    /// How the file's lines are read (the extrusion word, what G90/G91 do to E, ...).
    pub firmware: Firmware,
    /// Length of a `G10` firmware retraction when the file does not set it with `M207`, mm.
    pub fw_retract_mm: f64,
    /// Explicit markers for the print proper.
    pub markers: Markers,
}

impl Default for StateOptions {
    fn default() -> Self {
        StateOptions { firmware: Firmware::Marlin, fw_retract_mm: 1.0, markers: Markers::default() }
    }
}

impl StateOptions {
    /// These options for a file sliced for `flavour` (its `gcode_flavor`, see
    /// [`crate::gcode::flavour`]) on a machine whose firmware is `configured` (a profile's key,
    /// a flag, Python's `firmware=`), by the one rule, [`Firmware::resolve`]: the configured
    /// firmware wins, else the one the flavour names, else Marlin. These options' own
    /// `firmware` is replaced.
    pub fn resolved(self, configured: Option<Firmware>, flavour: Option<&str>) -> Self {
        StateOptions { firmware: Firmware::resolve(configured, flavour), ..self }
    }
}

/// The modal state. Feed it every line with [`State::apply`].
#[derive(Debug, Clone)]
pub struct State {
    /// Logical position, mm, indexed by axis ([`X`], [`E`]...).
    pub pos: Position,
    /// G90 (true) or G91.
    absolute: bool,
    /// M82 (true) or M83.
    absolute_e: bool,
    /// Bit i: axis i moves relative to the current position, from the two above and the
    /// firmware's rule for E ([`State::set_modes`]); kept so a move does not work it out again.
    relative_axes: u8,
    /// G20 in force.
    pub inches: bool,
    /// Feed rate in force, mm/min.
    pub feed_mm_min: f64,
    /// The motion mode that axis words without a command continue.
    pub motion: Motion,
    /// The active tool.
    pub tool: u32,
    /// Filament fed per tool since the start, mm (never reset by G92).
    pub filament_mm: Vec<f64>,
    /// A G10 retraction is in force.
    pub fw_retracted: bool,
    /// Length of a `G10` retraction (`M207 S`), mm.
    pub fw_retract_mm: f64,
    /// Temperatures and fan asked for.
    pub thermal: Thermal,
    /// Layer, feature and region of the line.
    pub structure: Structure,
    /// Fixed at creation: [`State::options`].
    options: StateOptions,
    /// For each word letter (a byte), where its word goes on a motion line (from the options).
    slots: [u8; 256],
    /// The lexer's words by letter ([`PlainMove`]) mean what they say: E extrudes.
    reads_plain_moves: bool,
    /// What the last line did.
    pub effect: Effect,
}

/// On a motion line a word fills a slot: an axis of the target (`X`..`C`, `0..AXES`), the feed
/// rate, or none.
const FEED_SLOT: usize = AXES;
const NO_SLOT: u8 = u8::MAX;
/// Slot bits of the axes other than E, which G91 makes relative.
const XYZ_ABC_BITS: u8 = (1 << AXES) - 1 - (1 << E);

impl Default for State {
    fn default() -> Self {
        State::new(StateOptions::default())
    }
}

impl State {
    /// A state at the origin, absolute, with `options` for the whole file.
    pub fn new(options: StateOptions) -> Self {
        State {
            pos: [0.0; AXES],
            absolute: true,
            absolute_e: true,
            relative_axes: 0,
            inches: false,
            feed_mm_min: 0.0,
            motion: Motion::Linear,
            tool: 0,
            filament_mm: vec![0.0],
            fw_retracted: false,
            fw_retract_mm: options.fw_retract_mm,
            thermal: Thermal::default(),
            structure: Structure::with_markers(options.markers.clone()),
            slots: std::array::from_fn(|i| {
                let letter = i as u8;
                match axis_of_word(letter, options.firmware.extrusion_letter()) {
                    Some(axis) => axis as u8,
                    None if letter == b'F' => FEED_SLOT as u8,
                    None => NO_SLOT,
                }
            }),
            reads_plain_moves: options.firmware.extrusion_letter() == b'E',
            options,
            effect: Effect::None,
        }
    }

    /// Whether plain moves must come with their words listed ([`Block::words`]): they are
    /// read from [`Block::plain`] only where E is the extrusion word.
    pub fn reads_words(&self) -> bool {
        !self.reads_plain_moves
    }

    /// The options the state was made with.
    pub fn options(&self) -> &StateOptions {
        &self.options
    }

    /// G90 (true) or G91 in force.
    pub fn absolute(&self) -> bool {
        self.absolute
    }

    /// E moves relative to the current position on this line.
    #[inline]
    pub fn relative_e(&self) -> bool {
        self.relative_axes >> E & 1 != 0
    }

    /// Sets G90/G91 and M82/M83, and which axes they make relative: G91 every axis but E; E
    /// as the firmware says ([`Firmware::relative_e`]).
    fn set_modes(&mut self, absolute: bool, absolute_e: bool) {
        (self.absolute, self.absolute_e) = (absolute, absolute_e);
        let relative_e = self.options.firmware.relative_e(absolute, absolute_e);
        self.relative_axes = if absolute { 0 } else { XYZ_ABC_BITS } | u8::from(relative_e) << E;
    }

    #[inline]
    fn to_mm(&self, v: f64) -> f64 {
        if self.inches {
            v * MM_PER_INCH
        } else {
            v
        }
    }

    /// Executes one parsed line (`raw` is its text, for comments) and says what it did. The
    /// effect is also kept in [`State::effect`] until the next line.
    #[inline(always)]
    pub fn apply(&mut self, raw: &[u8], block: &Block) -> &Effect {
        // The effect is written in place: a `Move` is large, and copying it per line shows.
        self.effect = Effect::None;
        self.structure.layer_started = false;
        if let Some(c) = block.comment {
            self.structure.observe_comment(c.of(raw));
        }
        if block.block_delete {
            return &self.effect;
        }
        self.structure.observe_command(|| !block.is_empty() && block.comment.is_none());
        if let Some(plain) = self.plain_move(block) {
            // Most lines of a print: a plain G0/G1, its words sorted by letter by the lexer.
            self.motion = if plain.rapid { Motion::Rapid } else { Motion::Linear };
            self.motion_words(block);
        } else {
            self.command(block);
        }
        if let Effect::Move(m) = &self.effect {
            if m.is_extruding() {
                self.structure.observe_extrusion(m.to[Z]);
            }
        }
        self.feed(self.effect.filament_mm());
        &self.effect
    }

    /// [`State::apply`] for a plain move read without a [`Block`] (a reader of its own, such
    /// as `estimate`'s: [`read_plain_move`](super::lexer::read_plain_move)): the same state
    /// after it, to the bit, except [`State::effect`], which is left [`Effect::None`] (the
    /// caller has the move: [`State::pos`] before and after). Returns whether it moved. Only
    /// where plain moves are read by letter ([`State::reads_words`] is `false`), and for a
    /// `plain` with at least one word; any other line goes through [`State::apply`].
    #[inline(always)]
    pub fn apply_plain(&mut self, plain: &PlainMove) -> bool {
        debug_assert!(self.reads_plain_moves && plain.present != 0);
        self.effect = Effect::None;
        self.structure.layer_started = false;
        // A command without a comment: a bare one.
        self.structure.observe_command(|| true);
        self.motion = if plain.rapid { Motion::Rapid } else { Motion::Linear };
        let scale = if self.inches { MM_PER_INCH } else { 1.0 };
        // Changed in place: no move is copied out of the position here (see `motion_words`).
        let (x, y, e) = (self.pos[X], self.pos[Y], self.pos[E]);
        let (moved, feed) = plain_targets(plain, scale, self.relative_axes, &mut self.pos);
        if let Some(feed) = feed {
            self.feed_mm_min = feed;
        }
        if moved {
            // What [`Move::is_extruding`] and [`Move::e_mm`] say of a straight move.
            let to = &self.pos;
            let e_mm = to[E] - e;
            if e_mm > 0.0 && (to[X] != x || to[Y] != y) {
                self.structure.observe_extrusion(to[Z]);
            }
            self.feed(e_mm);
        }
        moved
    }

    /// `fed_mm` of filament fed (negative: retracted) by the active tool.
    #[inline(always)]
    fn feed(&mut self, fed_mm: f64) {
        if fed_mm != 0.0 {
            if let Some(fed) = self.filament_mm.get_mut(self.tool as usize) {
                *fed += fed_mm;
            }
        }
    }

    /// The line's words by letter, if it is a plain move read that way ([`PlainMove`]) and they
    /// mean what they say here (E extrudes).
    #[inline(always)]
    fn plain_move<'b>(&self, block: &'b Block) -> Option<&'b PlainMove> {
        (block.plain.present != 0 && self.reads_plain_moves).then_some(&block.plain)
    }

    /// Every line but a plain move: out of line, so that [`State::apply`] stays small enough
    /// to be inlined into the loops that call it. The codes matched here and in the two below
    /// are declared in [`MODAL_CODES`](super::codes::MODAL_CODES); a test keeps them equal.
    #[inline(never)]
    fn command(&mut self, block: &Block) {
        match block.command {
            Command::Code { letter: b'G', number: number @ 0..=3, sub: None } => {
                self.motion = match number {
                    0 => Motion::Rapid,
                    1 => Motion::Linear,
                    2 => Motion::ArcCw,
                    _ => Motion::ArcCcw,
                };
                self.motion_words(block)
            }
            Command::Code { letter: b'G', number, sub: None } => self.g_code(number, block),
            Command::Code { letter: b'M', number, sub: None } => self.m_code(number, block),
            Command::Code { letter: b'T', number, sub: None } if number < MAX_TOOLS => {
                let from = self.tool;
                self.tool = number;
                self.grow_tool(number);
                self.effect = Effect::ToolChange { from, to: number };
            }
            // No command and no word (a comment, a blank line): nothing to read. First, so
            // that such a line, a good part of a slicer's file, reads no more of its block
            // than its words (with the junk test first, reading the findings too, `check` of
            // bench/data's file took 0.94 s instead of 0.81, the same instructions).
            Command::None if block.words.is_empty() => {}
            // Junk where the command belongs: nothing of the line is read.
            Command::None if block.starts_unreadable() => {}
            Command::None if block.words.iter().any(|w| axis_of(w.letter).is_some()) => {
                self.motion_words(block)
            }
            Command::None => {
                if let Some(f) = block.get(b'F') {
                    self.feed_mm_min = self.to_mm(f);
                }
            }
            _ => {}
        }
    }

    fn grow_tool(&mut self, tool: u32) {
        let n = tool as usize + 1;
        if self.filament_mm.len() < n {
            self.filament_mm.resize(n, 0.0);
        }
    }

    fn g_code(&mut self, number: u32, block: &Block) {
        match number {
            4 => {
                let t_s = block.get(b'S').unwrap_or(0.0) + block.get(b'P').unwrap_or(0.0) / 1000.0;
                self.effect = Effect::Dwell { t_s };
            }
            10 if self.g10_is_not_a_retraction(block) => self.rrf_tool_temperature(block),
            10 => self.firmware_retract(true),
            11 => self.firmware_retract(false),
            20 => self.inches = true,
            21 => self.inches = false,
            28 => {
                let mut axes = 0u8;
                for (i, letter) in AXIS_LETTERS.iter().enumerate().take(3) {
                    if block.has(*letter) {
                        axes |= 1 << i;
                    }
                }
                if axes == 0 {
                    axes = 0b111;
                }
                for i in 0..3 {
                    if axes & (1 << i) != 0 {
                        self.pos[i] = 0.0;
                    }
                }
                self.effect = Effect::Home { axes };
            }
            // Marlin's G90/G91 set the extrusion mode too.
            90 | 91 => {
                let absolute = number == 90;
                self.set_modes(
                    absolute,
                    self.options.firmware.absolute_e_after_g90_g91(absolute, self.absolute_e),
                );
            }
            92 => {
                for w in &block.words {
                    if let (Some(i), Some(v)) =
                        (axis_of_word(w.letter, self.options.firmware.extrusion_letter()), w.number())
                    {
                        self.pos[i] = self.to_mm(v);
                    }
                }
                self.effect = Effect::SetPosition;
            }
            _ => {}
        }
    }

    fn m_code(&mut self, number: u32, block: &Block) {
        match number {
            82 | 83 => self.set_modes(self.absolute, number == 82),
            // The temperature is S (R: Marlin's wait in both directions); PrusaSlicer's mach3 and
            // machinekit flavours write it as P, LinuxCNC's word for an M-code's parameter.
            104 | 109 => {
                if let Some(s) = block.get(b'S').or_else(|| block.get(b'R')).or_else(|| block.get(b'P')) {
                    self.set_hotend(block.get(b'T'), s);
                }
            }
            140 | 190 => {
                if let Some(s) = block.get(b'S').or_else(|| block.get(b'R')).or_else(|| block.get(b'P')) {
                    self.thermal.bed_c = s;
                }
            }
            106 => {
                let speed = block
                    .get(b'S')
                    .or_else(|| block.get(b'P').filter(|_| self.options.firmware.values_in_p()));
                let full = crate::range::PWM.max;
                self.thermal.fan = (speed.unwrap_or(full) / full).clamp(0.0, 1.0);
            }
            107 => self.thermal.fan = 0.0,
            207 => {
                if let Some(s) = block.get(b'S') {
                    self.fw_retract_mm = self.to_mm(s);
                }
            }
            // RepRapFirmware 3.3+: `M568 P<tool> S<active> R<standby>`, as `G10 P S` before.
            568 => self.rrf_tool_temperature(block),
            _ => {}
        }
    }

    /// Whether this `G10` is RepRapFirmware's tool temperature, `G10 P<tool> S<active>
    /// [R<standby>]` (PrusaSlicer's way of heating for that flavour, then `M116` waits; `S`
    /// alone in a RepRapFirmware file), or with `L` offsets or a coordinate system: none moves
    /// filament. Otherwise it is a firmware retraction, Marlin's `G10 S1` (the longer one
    /// before a tool swap on machines with several extruders) included. The virtual printer
    /// asks the same question.
    pub fn g10_is_not_a_retraction(&self, block: &Block) -> bool {
        block.has(b'P')
            || block.has(b'L')
            || (self.options.firmware.g10_s_is_a_temperature() && block.has(b'S'))
    }

    /// A RepRapFirmware tool temperature: the active one (`S`) of tool `P` (default: the current).
    fn rrf_tool_temperature(&mut self, block: &Block) {
        if let Some(s) = block.get(b'S') {
            self.set_hotend(block.get(b'P'), s);
        }
    }

    /// The hotend target of `tool` (the current tool when the command names none), °C.
    fn set_hotend(&mut self, tool: Option<f64>, celsius: f64) {
        let tool = tool.map_or(self.tool as usize, |t| t.max(0.0) as usize);
        if tool < MAX_TOOLS as usize {
            if self.thermal.hotend_c.len() <= tool {
                self.thermal.hotend_c.resize(tool + 1, 0.0);
            }
            self.thermal.hotend_c[tool] = celsius;
            self.thermal.hotend_set = true;
        }
    }

    fn firmware_retract(&mut self, retract: bool) {
        if self.fw_retracted != retract {
            self.fw_retracted = retract;
            let e_mm = if retract { -self.fw_retract_mm } else { self.fw_retract_mm };
            self.effect = Effect::FirmwareRetract { e_mm };
        }
    }

    /// Resolves the axis words of a motion line to an absolute target and the move to it.
    #[inline(always)]
    fn motion_words(&mut self, block: &Block) {
        // Multiplying by 1 is exact, so one multiply serves both units without a branch.
        let scale = if self.inches { MM_PER_INCH } else { 1.0 };
        let from = self.pos;
        // The target is worked out in a copy and stored whole, once, to the position and the
        // move: copying `self.pos` into the move after writing its axes one by one read it back
        // in 16-byte pieces from two 8-byte stores still in flight, which the CPU cannot forward
        // (the load waits for every older store to reach the cache, some of them to lines the
        // planning core holds: in some runs of `estimate` perf put 85 % of the interpreting
        // thread's samples on that load; docs/performance.md, twentieth session).
        let mut to = from;
        let (mut moved, feed) = match self.plain_move(block) {
            Some(plain) => plain_targets(plain, scale, self.relative_axes, &mut to),
            None => targets(&block.words, &self.slots, scale, self.relative_axes, &mut to),
        };
        self.pos = to;
        let feed_before = self.feed_mm_min;
        if let Some(feed) = feed {
            self.feed_mm_min = feed;
        }
        let arc = match self.motion {
            Motion::ArcCw | Motion::ArcCcw => match self.arc(block, &from) {
                Ok(arc) => Some(arc),
                Err(refusal) => return self.refuse_arc(refusal, from, feed_before),
            },
            _ => None,
        };
        moved |= arc.is_some();
        if !moved {
            return;
        }
        self.effect = Effect::Move(Move {
            from,
            to,
            path: Path::Line,
            rapid: self.motion == Motion::Rapid,
            feed_mm_min: self.feed_mm_min,
        });
        // Set apart: a `Path` holds a whole arc, and copying it on every straight move shows.
        if let (Some(arc), Effect::Move(m)) = (arc, &mut self.effect) {
            m.path = Path::Arc(arc);
        }
    }

    /// The arc of a G2/G3 from `from` to the current position, from its R or I/J words, as the
    /// firmware reads them ([`Firmware::arcs`]); why it refuses them otherwise.
    #[inline(never)]
    fn arc(&self, block: &Block, from: &Position) -> Result<Arc, ArcRefusal> {
        let rules = self.options.firmware.arcs();
        if !rules.in_relative && self.relative_axes >> X & 1 != 0 {
            return Err(ArcRefusal::Relative);
        }
        let cw = self.motion == Motion::ArcCw;
        let start = [from[X], from[Y]];
        let end = [self.pos[X], self.pos[Y]];
        match block.get(b'R') {
            Some(r) => Arc::from_radius(start, end, self.to_mm(r), cw, (rules, self.inches)),
            None => {
                let ij =
                    [self.to_mm(block.get(b'I').unwrap_or(0.0)), self.to_mm(block.get(b'J').unwrap_or(0.0))];
                Arc::from_offset(start, end, ij, cw)
            }
        }
    }

    /// A G2/G3 the firmware refuses: the machine stays at `from`, and the feed rate is
    /// `feed_before` again where the firmware takes the line's F only with its move
    /// (Klipper and RepRapFirmware check the arc first; Marlin reads F with the target).
    #[cold]
    fn refuse_arc(&mut self, refusal: ArcRefusal, from: Position, feed_before: f64) {
        self.pos = from;
        if matches!(self.options.firmware, Firmware::Klipper | Firmware::RepRapFirmware) {
            self.feed_mm_min = feed_before;
        }
        self.effect = Effect::ArcRefused(refusal);
    }
}

/// Writes the numeric axis words of a motion line into `to` (absolute, or added where bit i of
/// `relative` is set), in millimetres. Returns whether any axis word was written, and the F word.
/// A letter given twice counts once, by its last word, as firmware reads a line (Marlin keeps
/// one value per letter) and as [`Block::get`] answers: `G91` then `G1 X1 X2` moves 2 mm, not 3.
#[inline(always)]
fn targets(
    words: &[Word],
    slots: &[u8; 256],
    scale: f64,
    relative: u8,
    to: &mut Position,
) -> (bool, Option<f64>) {
    let (mut moved, mut feed) = (false, None);
    // Bit i: slot i has had its last word (words are read from the end).
    let mut seen = 0u8;
    for w in words.iter().rev() {
        let slot = slots[usize::from(w.letter)];
        if slot == NO_SLOT || seen >> slot & 1 != 0 {
            continue;
        }
        seen |= 1 << slot;
        let Value::Number(v) = w.value else { continue };
        let v = v * scale;
        match usize::from(slot) {
            FEED_SLOT => feed = Some(v),
            i => {
                to[i] = if relative >> i & 1 != 0 { to[i] + v } else { v };
                moved = true;
            }
        }
    }
    (moved, feed)
}

/// [`targets`] for a plain move, from its words by letter: X Y Z E are the first four axes, in
/// the same order, and F comes last. No loop over the words: each axis is one test of a bit.
#[inline(always)]
fn plain_targets(plain: &PlainMove, scale: f64, relative: u8, to: &mut Position) -> (bool, Option<f64>) {
    for (i, (to, value)) in to[X..=E].iter_mut().zip(plain.values).enumerate() {
        if plain.present >> i & 1 != 0 {
            let v = value * scale;
            *to = if relative >> i & 1 != 0 { *to + v } else { v };
        }
    }
    let feed = plain.present >> 4 & 1 != 0;
    (plain.present & 0b1111 != 0, feed.then(|| plain.values[4] * scale))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::lexer::parse_into;

    fn run(state: &mut State, text: &str) -> Vec<Effect> {
        let mut block = Block::default();
        text.lines()
            .map(|l| {
                parse_into(l.as_bytes(), &mut block);
                *state.apply(l.as_bytes(), &block)
            })
            .collect()
    }

    /// A breaking session found `!!! Z5` counted as malformed yet run as a modal move to Z5 by
    /// every reader (`stats --lenient`, `estimate`, `sim`, `serve`): junk where the command
    /// belongs is no command, as Marlin and Klipper answer. Junk after a command is read past,
    /// the command kept, as firmware reads it.
    #[test]
    fn a_line_that_starts_with_junk_moves_nothing() {
        let mut s = State::default();
        let effects = run(&mut s, "G1 X10 F600\n!!! Z5\n  $junk Y30 F9\n#x X100\nX1..2 Y20\nG1 !! X30");
        assert!(effects[1..4].iter().all(|e| *e == Effect::None), "{effects:?}");
        assert_eq!(s.feed_mm_min, 600.0);
        // Words alone still continue the motion; the malformed word is left out.
        assert!(matches!(effects[4], Effect::Move(m) if m.to[Y] == 20.0 && m.to[X] == 10.0));
        assert!(matches!(effects[5], Effect::Move(m) if m.to[X] == 30.0));
        assert_eq!([s.pos[X], s.pos[Y], s.pos[Z]], [30.0, 20.0, 0.0]);
    }

    #[test]
    fn relative_and_absolute_extrusion_agree() {
        let mut abs = State::default();
        run(&mut abs, "G90\nM82\nG92 E0\nG1 X10 E1\nG1 X20 E2.5\nG1 E1.5\nG92 E0\nG1 X30 E1");
        let mut rel = State::default();
        run(&mut rel, "G90\nM83\nG1 X10 E1\nG1 X20 E1.5\nG1 E-1\nG1 X30 E1");
        assert_eq!(abs.filament_mm[0], 2.5);
        assert_eq!(rel.filament_mm[0], 2.5);
        assert_eq!(abs.pos[X], 30.0);
        assert_eq!(rel.pos[E], 2.5);
    }

    #[test]
    fn reprapfirmware_g10_with_words_sets_a_tool_temperature_not_a_retraction() {
        let mut s = State::new(StateOptions::default().resolved(None, Some("reprapfirmware")));
        let effects = run(&mut s, "T1\nG10 P0 S215 R170\nG10 S190\nM116\nG1 X10 E1 F600");
        assert_eq!(s.thermal.hotend_c, vec![215.0, 190.0]);
        assert!(s.thermal.hotend_set);
        assert!(!s.fw_retracted);
        assert_eq!(effects[1], Effect::None);
        assert_eq!(s.filament_mm[1], 1.0);
    }

    /// PrusaSlicer's mach3/machinekit flavours extrude with `A` (absolute under G90, as they
    /// write it), set it with `G92 A`, heat with `M104 P`, and write no `E`.
    #[test]
    fn a_as_the_extrusion_word() {
        let options = StateOptions::default().resolved(None, Some("mach3"));
        let mut s = State::new(options);
        run(&mut s, "M104 P200\nG90\nG1 X10 A1 F600\nG1 A-1\nG1 A1\nG92 A0\nG1 X20 A2\nG1 E5");
        assert_eq!(s.thermal.hotend_c, vec![200.0]);
        assert_eq!(s.filament_mm[0], 3.0);
        assert_eq!((s.pos[E], s.pos[A], s.pos[X]), (2.0, 0.0, 20.0));
        // A file that names no flavour on a machine configured for none reads as Marlin's, E.
        assert_eq!(StateOptions::default().resolved(None, None).firmware.extrusion_letter(), b'E');
    }

    /// `M106 P` is the fan speed in the LinuxCNC flavours (PrusaSlicer writes `M106 P237.15`),
    /// and Marlin's fan index elsewhere, where a missing `S` means full speed.
    #[test]
    fn fan_speed_word_follows_the_flavour() {
        let mut s = State::new(StateOptions::default().resolved(None, Some("mach3")));
        run(&mut s, "M106 P191.25");
        assert_eq!(s.thermal.fan, 0.75);
        let mut s = State::new(StateOptions::default().resolved(None, Some("marlin2")));
        run(&mut s, "M106 P1");
        assert_eq!(s.thermal.fan, 1.0);
        run(&mut s, "M106 P0 S127.5");
        assert_eq!(s.thermal.fan, 0.5);
    }

    #[test]
    fn reprapfirmware_m568_sets_a_tool_temperature() {
        let mut s = State::default();
        run(&mut s, "M568 P1 S205 R180\nT0\nM568 S199");
        assert_eq!(s.thermal.hotend_c, vec![199.0, 205.0]);
        assert!(s.thermal.hotend_set);
    }

    #[test]
    fn marlin_g90_resets_extrusion_mode_klipper_does_not() {
        let mut marlin = State::default();
        run(&mut marlin, "M83\nG90\nG1 E1\nG1 E1");
        assert_eq!(marlin.filament_mm[0], 1.0);
        let mut klipper = State::new(StateOptions { firmware: Firmware::Klipper, ..Default::default() });
        run(&mut klipper, "M83\nG90\nG1 E1\nG1 E1");
        assert_eq!(klipper.filament_mm[0], 2.0);
    }

    /// Under M82, G91 makes E relative in Marlin and Klipper but not in RepRapFirmware; the
    /// file's flavour picks the rule.
    /// `G10 S1` is Marlin's swap retraction, not a 1 °C tool temperature; `G10 P S` is
    /// RepRapFirmware's tool temperature, and so is `G10 S` alone in a RepRapFirmware file.
    #[test]
    fn g10_retracts_or_sets_a_tool_temperature() {
        let mut s = State::default();
        run(&mut s, "M104 S200\nG1 X10 E1 F600");
        let effects = run(&mut s, "G10 S1\nG11");
        assert_eq!(effects, [Effect::FirmwareRetract { e_mm: -1.0 }, Effect::FirmwareRetract { e_mm: 1.0 }]);
        run(&mut s, "G10 P1 S215\nG10 L2 P1 X5");
        assert_eq!((s.thermal.hotend_c.as_slice(), s.pos[X]), (&[200.0, 215.0][..], 10.0));
        let mut rrf = State::new(StateOptions::default().resolved(None, Some("reprapfirmware")));
        run(&mut rrf, "G10 S190");
        assert_eq!(rrf.thermal.hotend_c, vec![190.0]);
    }

    #[test]
    fn g91_and_extrusion_by_flavour() {
        let text = "M82\nG1 E1\nG91\nG1 E1\nG1 E1";
        for (flavour, firmware, filament_mm) in [
            (Some("marlin2"), Firmware::Marlin, 3.0),
            (None, Firmware::Marlin, 3.0),
            (Some("klipper"), Firmware::Klipper, 3.0),
            (Some("reprapfirmware"), Firmware::RepRapFirmware, 1.0),
        ] {
            let options = StateOptions::default().resolved(None, flavour);
            assert_eq!(options.firmware, firmware, "{flavour:?}");
            let mut s = State::new(options);
            run(&mut s, text);
            assert_eq!(s.filament_mm[0], filament_mm, "{flavour:?}");
        }
        // The configured firmware wins over the flavour the file names: a file sliced with
        // Klipper's flavour, printed on a machine configured for RepRapFirmware, reads as RRF.
        let options = StateOptions::default().resolved(Some(Firmware::RepRapFirmware), Some("klipper"));
        assert_eq!(options.firmware, Firmware::RepRapFirmware);
        let mut s = State::new(options);
        run(&mut s, text);
        assert_eq!(s.filament_mm[0], 1.0);
        // RepRapFirmware: M83 alone makes E relative, whatever G90 says.
        let mut rrf = State::new(StateOptions::default().resolved(None, Some("reprapfirmware")));
        run(&mut rrf, "M83\nG90\nG1 E1\nG1 E1");
        assert_eq!(rrf.filament_mm[0], 2.0);
    }

    #[test]
    fn g91_moves_and_inches() {
        let mut s = State::default();
        run(&mut s, "G21\nG1 X10 Y10\nG91\nG1 X-2 Z0.2\nG90\nG20\nG1 X1");
        assert_eq!(s.pos[X], 25.4);
        assert_eq!(s.pos[Y], 10.0);
        assert!((s.pos[Z] - 0.2).abs() < 1e-12);
        // A letter given twice counts once, by its last word (as firmware reads it), on the
        // fast path (plain moves) and on the general one (a comment sends the line there).
        run(&mut s, "G21\nG91\nG1 X1 X2\nG1 Y1 Y2 ; c\nG1 Y1 Y");
        assert_eq!(s.pos[X], 25.4 + 2.0);
        assert_eq!(s.pos[Y], 12.0);
    }

    #[test]
    fn arcs_tools_and_firmware_retraction() {
        let mut s = State::default();
        let fx = run(&mut s, "G1 X10 Y0 F600\nG3 X0 Y10 I-10 J0 E1\nT1\nM207 S2\nG10\nG10\nG11\nX5");
        match fx[1] {
            Effect::Move(m) => assert!((m.xy_len_mm() - 5.0 * std::f64::consts::PI).abs() < 1e-9),
            e => panic!("{e:?}"),
        }
        assert_eq!(fx[2], Effect::ToolChange { from: 0, to: 1 });
        assert_eq!(fx[4], Effect::FirmwareRetract { e_mm: -2.0 });
        assert_eq!(fx[5], Effect::None);
        assert_eq!(fx[6], Effect::FirmwareRetract { e_mm: 2.0 });
        assert_eq!(s.filament_mm, vec![1.0, 0.0]);
        // A bare axis word continues the modal G3; with no centre given every firmware refuses
        // it (Marlin: `G2/G3 bad parameters`) and the machine stays where it was.
        assert_eq!(fx[7], Effect::ArcRefused(ArcRefusal::NoCentre));
        assert_eq!((s.pos[X], s.pos[Y]), (0.0, 10.0));
    }

    /// Regression (a G2/G3 a firmware refuses moved in a straight line): the machine stays,
    /// whatever the line's words; the next move starts where it stayed; its F is kept by Marlin
    /// (read with the target) and not by Klipper (which checks the arc first); Klipper refuses
    /// R arcs and arcs after G91.
    #[test]
    fn a_refused_arc_does_not_move_the_machine() {
        let read = |firmware: Firmware, text: &str| {
            let mut s = State::new(StateOptions { firmware, ..StateOptions::default() });
            let fx = run(&mut s, text);
            (s, fx)
        };
        let (s, fx) = read(Firmware::Marlin, "G1 X10 Y10 F600\nG2 X20 Y10 E5 F1200\nG1 Y20");
        assert_eq!(fx[1], Effect::ArcRefused(ArcRefusal::NoCentre));
        match fx[2] {
            Effect::Move(m) => assert_eq!((m.from[X], m.from[Y], m.from[E]), (10.0, 10.0, 0.0)),
            e => panic!("{e:?}"),
        }
        assert_eq!((s.pos[X], s.pos[Y], s.filament_mm[0]), (10.0, 20.0, 0.0));
        assert_eq!(s.feed_mm_min, 1200.0);
        let (s, fx) = read(Firmware::Klipper, "G1 X10 Y10 F600\nG2 X20 Y10 R5 F1200");
        assert_eq!(fx[1], Effect::ArcRefused(ArcRefusal::RadiusForm));
        assert_eq!((s.pos[X], s.feed_mm_min), (10.0, 600.0));
        let (_, fx) = read(Firmware::Klipper, "G91\nG2 X10 I5");
        assert_eq!(fx[1], Effect::ArcRefused(ArcRefusal::Relative));
        // Marlin draws both, the R one as half a circle over a 10 mm chord with R1.
        let (s, fx) = read(Firmware::Marlin, "G91\nG2 X10 I5\nG90\nG2 X20 Y0 R1");
        assert!(matches!(fx[1], Effect::Move(_)) && matches!(fx[3], Effect::Move(_)), "{fx:?}");
        assert_eq!(s.pos[X], 20.0);
    }

    proptest::proptest! {
        /// A plain move read from its words by letter (the lexer's fast path) does what the
        /// same line read word by word does, whatever the modes before it (G90/G91, M82/M83,
        /// G20/G21, firmware) and however its words repeat.
        #[test]
        fn plain_moves_by_letter_match_the_words(
            modes in proptest::collection::vec("(G90|G91|M82|M83|G20|G21|G92 X1 E2)", 0..4),
            line in "G[01]( [XYZEF]-?[0-9]{1,3}\\.[0-9]{1,3}){0,6}",
            firmware in 0usize..4,
        ) {
            let firmware = Firmware::ALL[firmware];
            let mut by_letter = State::new(StateOptions { firmware, ..StateOptions::default() });
            run(&mut by_letter, &format!("G1 X3 Y4 Z5 E6 F100\n{}", modes.join("\n")));
            let mut by_word = by_letter.clone();
            let mut block = Block::default();
            parse_into(line.as_bytes(), &mut block);
            proptest::prop_assert!(block.plain.present != 0 || block.words.is_empty(), "{}", line);
            let fast = *by_letter.apply(line.as_bytes(), &block);
            block.plain = PlainMove::default();
            let slow = *by_word.apply(line.as_bytes(), &block);
            proptest::prop_assert_eq!(fast, slow);
            proptest::prop_assert_eq!(by_letter.pos.map(f64::to_bits), by_word.pos.map(f64::to_bits));
            proptest::prop_assert_eq!(by_letter.feed_mm_min, by_word.feed_mm_min);
            proptest::prop_assert_eq!(&by_letter.filament_mm, &by_word.filament_mm);
        }
    }
}
