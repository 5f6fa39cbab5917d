//! Splitting one move at a fraction of its extrusion, and writing the two halves.
//!
//! ## The maths
//!
//! Firmware feeds E in proportion to the tool-path length: along a move from `P0` to `P1`
//! (every axis, E included) the machine is at `P(t) = P0 + t (P1 - P0)` when the fraction `t`
//! of the path length is done, and has fed `t * e` of the move's `e` mm of filament. So a change
//! that must come `r` mm of filament before the end of the move goes at
//!
//! ```text
//!   t = (e - r) / e,        split point  P(t) = P0 + t (P1 - P0)
//! ```
//!
//! and the move becomes `P0 -> P(t)` (fed `t e`), the change, then `P(t) -> P1` (fed `r`).
//! X, Y, Z, E and the extra axes A B C are all interpolated with the same `t`, so the point lies
//! on the original segment and the two halves feed exactly the original filament.
//!
//! An arc G2/G3 is split into two arcs around the same centre `C`: the sweep `phi` is uniform in
//! path length (`len = |phi| r`, plus a helical Z or E that also grows linearly with the angle),
//! so the split point is at angle `a0 + t phi` on the same circle, and each half is written with
//! its own `I J = C - start`. Z, E and A B C are linear in `t` as for a line.
//!
//! ## Writing the words
//!
//! - Absolute axis (G90, or E under M82): the first half gets the interpolated value; the second
//!   half keeps the original word, so on a straight move in absolute mode the second half is the
//!   original line, byte for byte.
//! - Relative axis (G91, or E under M83): the first half gets `t d` rounded, the second half the
//!   rest `d - round(t d)`, both written with at least the original's decimals, so the two words
//!   add up to the original exactly in decimal.
//! - `F` goes on both halves when the original has one; other words (`S` laser power...) are
//!   copied to both; `R` arcs are written in the `I J` form.

use crate::gcode::lexer::parse_into;
use crate::gcode::line::{Block, Value};
use crate::gcode::number::NumberFormat;
use crate::gcode::state::{axis_of, Move, Path, Position, AXES, AXIS_LETTERS, E, MM_PER_INCH, X, Y};

/// Decimals written for split positions and I/J, mm (0.01 um: far below any step).
pub(crate) const POSITION_DECIMALS: u8 = 5;
/// Decimals written for split E words, mm of filament.
pub(crate) const E_DECIMALS: u8 = 6;

/// What is needed to split a held move, captured when its line was read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Splittable {
    pub mv: Move,
    /// G91 was in force for X Y Z A B C.
    pub relative_axes: bool,
    /// E was relative (M83, or G91 on Marlin).
    pub relative_e: bool,
    pub inches: bool,
}

/// The two halves of a split move.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Halves {
    pub first: Vec<u8>,
    /// `None`: the second half is the original line unchanged.
    pub second: Option<Vec<u8>>,
    /// The split point, absolute logical mm.
    pub point: Position,
}

impl Splittable {
    /// The point at fraction `t` of the move.
    pub(super) fn point(&self, t: f64) -> Position {
        let (from, to) = (self.mv.from, self.mv.to);
        let mut p: Position = std::array::from_fn(|i| from[i] + t * (to[i] - from[i]));
        if let Path::Arc(arc) = &self.mv.path {
            let xy = arc.point(t);
            p[X] = xy[0];
            p[Y] = xy[1];
        }
        p
    }

    /// Where the machine is after `line`, a half [`split`] wrote for this move: its words read
    /// back as the firmware reads them (rounded as written), so what is inserted after the half
    /// starts from exactly the position the file has there.
    pub(super) fn end_of(&self, line: &[u8]) -> Position {
        let mut block = Block::default();
        parse_into(line, &mut block);
        let mut p = self.mv.from;
        for w in &block.words {
            let (Some(axis), Some(v)) = (axis_of(w.letter), w.number()) else { continue };
            let v = v * self.unit();
            p[axis] = if self.relative(axis) { self.mv.from[axis] + v } else { v };
        }
        p
    }

    /// Millimetres per file unit (G20 makes every axis, E included, inches).
    fn unit(&self) -> f64 {
        if self.inches {
            MM_PER_INCH
        } else {
            1.0
        }
    }

    fn relative(&self, axis: usize) -> bool {
        if axis == E {
            self.relative_e
        } else {
            self.relative_axes
        }
    }
}

/// Decimals written after the point in a word's text (`X1.250` -> 3).
fn decimals_of(word: &[u8]) -> u8 {
    match word.iter().position(|&b| b == b'.') {
        Some(dot) => word[dot + 1..].iter().take_while(|b| b.is_ascii_digit()).count().min(12) as u8,
        None => 0,
    }
}

struct Writer {
    format: NumberFormat,
}

impl Writer {
    /// Numbers in the file's own style: without the leading zero (`E.4`) if the slicer wrote so.
    fn new(raw: &[u8], block: &Block) -> Self {
        let drop_leading_zero = block.words.iter().any(|w| {
            let text = w.span.of(raw);
            matches!(text.get(1..3), Some([b'.', _]) | Some([b'-', b'.']))
        });
        Writer { format: NumberFormat { drop_leading_zero, ..NumberFormat::default() } }
    }

    fn word(&self, out: &mut Vec<u8>, letter: u8, value: f64, decimals: u8) {
        out.push(b' ');
        out.push(letter);
        self.format.write(out, value, decimals);
    }
}

/// Splits the move written on `raw` at fraction `t` (0 < t < 1) of its path.
pub(crate) fn split(raw: &[u8], s: &Splittable, t: f64) -> Halves {
    let mut block = Block::default();
    parse_into(raw, &mut block);
    let point = s.point(t);
    let w = Writer::new(raw, &block);
    let arc = match &s.mv.path {
        Path::Arc(a) => Some(*a),
        Path::Line => None,
    };
    let command: &[u8] = match &arc {
        Some(a) if a.sweep_rad < 0.0 => b"G2",
        Some(_) => b"G3",
        None if s.mv.rapid => b"G0",
        None => b"G1",
    };
    // Per axis: (first-half value, second-half value) in file units, for the axes written.
    let mut first = command.to_vec();
    let mut second = command.to_vec();
    let mut second_edits: Vec<(usize, Vec<u8>)> = Vec::new();
    let written =
        |axis: usize| block.words.iter().any(|w| axis_of(w.letter) == Some(axis) && w.number().is_some());
    for axis in 0..AXES {
        let letter = AXIS_LETTERS[axis];
        let on_arc_plane = arc.is_some() && (axis == X || axis == Y);
        if !written(axis) && !on_arc_plane {
            continue;
        }
        let unit = s.unit();
        let original = block.word(letter).filter(|w| w.number().is_some());
        let base = if axis == E { E_DECIMALS } else { POSITION_DECIMALS };
        let decimals = original.map_or(base, |w| decimals_of(w.span.of(raw)).max(base));
        if s.relative(axis) {
            let delta = (s.mv.to[axis] - s.mv.from[axis]) / unit;
            let scale = 10f64.powi(i32::from(decimals));
            let head = (t * delta * scale).round() / scale;
            let rest = delta - head;
            w.word(&mut first, letter, head, decimals);
            w.word(&mut second, letter, rest, decimals);
            let mut text = vec![letter];
            w.format.write(&mut text, rest, decimals);
            if let Some(o) = original {
                second_edits.push((o.span.start as usize, text));
            }
        } else {
            w.word(&mut first, letter, point[axis] / unit, decimals);
            match original {
                Some(o) => {
                    second.push(b' ');
                    second.extend_from_slice(o.span.of(raw));
                }
                None => w.word(&mut second, letter, s.mv.to[axis] / unit, decimals),
            }
        }
    }
    if let Some(a) = &arc {
        let unit = s.unit();
        let from = [s.mv.from[X], s.mv.from[Y]];
        for (line, start) in [(&mut first, from), (&mut second, [point[X], point[Y]])] {
            w.word(line, b'I', (a.center[0] - start[0]) / unit, POSITION_DECIMALS);
            w.word(line, b'J', (a.center[1] - start[1]) / unit, POSITION_DECIMALS);
        }
    }
    for word in &block.words {
        let keep = match word.letter {
            b'I' | b'J' | b'K' | b'R' if arc.is_some() => false,
            l => axis_of(l).is_none() || !matches!(word.value, Value::Number(_)),
        };
        if keep {
            for line in [&mut first, &mut second] {
                line.push(b' ');
                line.extend_from_slice(word.span.of(raw));
            }
        }
    }
    let second = if arc.is_some() {
        if let Some(c) = block.comment {
            second.extend_from_slice(b" ;");
            second.extend_from_slice(c.of(raw));
        }
        Some(second)
    } else if second_edits.is_empty() {
        None
    } else {
        Some(replace_words(raw, &block, &second_edits))
    };
    Halves { first, second, point }
}

/// `raw` with the words starting at the given offsets replaced by new text.
fn replace_words(raw: &[u8], block: &Block, edits: &[(usize, Vec<u8>)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(raw.len() + 8);
    let mut at = 0;
    let mut words: Vec<_> =
        block.words.iter().filter(|w| edits.iter().any(|e| e.0 == w.span.start as usize)).collect();
    words.sort_by_key(|w| w.span.start);
    for w in words {
        let (start, end) = (w.span.start as usize, w.span.end as usize);
        out.extend_from_slice(&raw[at..start]);
        if let Some((_, text)) = edits.iter().find(|e| e.0 == start) {
            out.extend_from_slice(text);
        }
        at = end;
    }
    out.extend_from_slice(&raw[at..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::state::{Effect, State};

    /// Runs `prelude` then `line`, returns the move and its split at `t`.
    fn split_after(prelude: &str, line: &str, t: f64) -> (Splittable, Halves) {
        let mut state = State::default();
        let mut block = Block::default();
        for l in prelude.lines() {
            parse_into(l.as_bytes(), &mut block);
            state.apply(l.as_bytes(), &block);
        }
        let (relative_axes, relative_e, inches) = (!state.absolute(), state.relative_e(), state.inches);
        parse_into(line.as_bytes(), &mut block);
        let Effect::Move(mv) = *state.apply(line.as_bytes(), &block) else { panic!("not a move: {line}") };
        let s = Splittable { mv, relative_axes, relative_e, inches };
        let h = split(line.as_bytes(), &s, t);
        (s, h)
    }

    fn text(b: &[u8]) -> &str {
        std::str::from_utf8(b).unwrap()
    }

    #[test]
    fn absolute_line_keeps_the_original_as_second_half() {
        let (_, h) = split_after("G90\nM82\nG1 X0 Y0 E1", "G1 X10 Y20 E3.0 F1200 ; wall", 0.25);
        assert_eq!(text(&h.first), "G1 X2.5 Y5 E1.5 F1200");
        assert_eq!(h.second, None);
        assert_eq!(h.point[X], 2.5);
    }

    #[test]
    fn relative_e_is_shared_exactly() {
        let (_, h) = split_after("G90\nM83\nG1 X0 Y0", "G1 X3 Y4 E.33333", 1.0 / 3.0);
        assert_eq!(text(&h.first), "G1 X1 Y1.33333 E.11111");
        assert_eq!(text(h.second.as_deref().unwrap()), "G1 X3 Y4 E.22222");
    }

    #[test]
    fn relative_axes_under_g91() {
        let (_, h) = split_after("G91\nG1 X5 Y5", "G1 X10 E2", 0.5);
        assert_eq!(text(&h.first), "G1 X5 E1");
        assert_eq!(text(h.second.as_deref().unwrap()), "G1 X5 E1");
        assert_eq!(h.point[X], 10.0);
    }

    #[test]
    fn arc_is_split_around_the_same_centre() {
        // Quarter circle of radius 10 around the origin, from (10,0) to (0,10).
        let (s, h) = split_after("G90\nM82\nG1 X10 Y0 E0", "G3 X0 Y10 I-10 J0 E2 ; arc", 0.5);
        let c = std::f64::consts::FRAC_1_SQRT_2 * 10.0;
        assert!((h.point[X] - c).abs() < 1e-12 && (h.point[Y] - c).abs() < 1e-12);
        assert_eq!(text(&h.first), "G3 X7.07107 Y7.07107 E1 I-10 J0");
        assert_eq!(text(h.second.as_deref().unwrap()), "G3 X0 Y10 E2 I-7.07107 J-7.07107 ; arc");
        assert!(s.point(1.0)[X].abs() < 1e-12);
    }

    #[test]
    fn r_arcs_become_ij() {
        let (_, h) = split_after("G90\nM83\nG1 X10 Y0", "G2 X0 Y-10 R10 E1", 0.5);
        assert_eq!(text(&h.first), "G2 X7.07107 Y-7.07107 E0.5 I-10 J0");
        assert_eq!(text(h.second.as_deref().unwrap()), "G2 X0 Y-10 E0.5 I-7.07107 J7.07107");
    }

    #[test]
    fn z_and_extra_axes_are_interpolated() {
        let (_, h) = split_after("G90\nM82\nG1 X0 Y0 Z1 A0 E0", "G1 X4 Z2 A90 E4", 0.75);
        assert_eq!(text(&h.first), "G1 X3 Z1.75 E3 A67.5");
        assert_eq!(h.second, None);
    }

    #[test]
    fn inches_are_written_in_inches() {
        let (_, h) = split_after("G20\nG90\nM83\nG1 X0 Y0", "G1 X1 E0.1", 0.5);
        assert_eq!(text(&h.first), "G1 X0.5 E0.05");
        assert!((h.point[X] - 12.7).abs() < 1e-12);
    }
}
