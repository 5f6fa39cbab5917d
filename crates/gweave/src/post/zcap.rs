//! A Z feed-rate cap. Firmware runs a move at the feed rate F along its XYZ path, so the Z axis
//! moves at `F * |dz| / L` with `L = sqrt(dx^2 + dy^2 + dz^2)`; that component is what is
//! capped. Two remedies when it is over the cap:
//!
//! - **split** a travel that moves XY and Z: Z alone first at the cap, then XY at the
//!   original F (which is also the feed rate in force afterwards, as the slicer expects);
//! - **slow** everything else (Z-only moves, moves that extrude or retract while moving Z, arcs):
//!   F becomes `cap * L / |dz|` (rounded down), then a `G1 F<original>` line restores the feed
//!   rate the next lines rely on.
//!
//! The mixing post-processor seed's printer stalled its Z axis above F200 (mm/min). Its script
//! split *every* line with a Z word and an F above 200, whatever Z did: its example
//! `G0 F9000 X128.2 Y96.8 Z0.4` became `G0 F200 Z0.400` then `G0 F9000 X128.200 Y96.800`. This
//! cap does not reproduce that by default: in the seed's file that move comes from far away, so
//! Z runs at `9000 * 0.2 / L`, about 97 mm/min there, under the cap, and the line stays as it is
//! (splitting it costs a stop for nothing). The same line after a short move is split
//! (`the_seeds_example_splits` below). [`ZCapMode::Seed`] applies the seed's own rule.
//!
//! Lines with `N` line numbers or checksums are left alone (rewriting would break the checksum).

use crate::gcode::line::{Block, Command};
use crate::gcode::number::NumberFormat;
use crate::gcode::retraction::write_exact_feed;
use crate::gcode::state::{Move, Path, E, X, Y, Z};

pub use super::mix::profile::ZCapMode;

/// The cap and what to do above it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZCap {
    /// Largest Z speed, mm/min.
    pub max_z_feed_mm_min: f64,
    /// What to do with a move above it.
    pub mode: ZCapMode,
}

/// The speed of the Z axis during a move, mm/min.
pub fn z_feed_mm_min(mv: &Move) -> f64 {
    let dz = (mv.to[Z] - mv.from[Z]).abs();
    if dz == 0.0 {
        return 0.0;
    }
    mv.feed_mm_min * dz / mv.len_mm()
}

impl ZCap {
    /// Whether the move is too fast in Z (with a margin for the rounding of F).
    pub fn exceeded(&self, mv: &Move) -> bool {
        z_feed_mm_min(mv) > self.max_z_feed_mm_min * (1.0 + 1e-9)
    }

    /// Writes the line's replacement (`\n`-terminated lines) into `out` and returns `true`, or
    /// returns `false` when the line can stay as it is.
    pub fn rewrite(
        &self,
        raw: &[u8],
        block: &Block,
        mv: &Move,
        fmt: &NumberFormat,
        out: &mut Vec<u8>,
    ) -> bool {
        let over = match self.mode {
            // The seed's rule looks at the words, not at the motion.
            ZCapMode::Seed => block.has(b'Z') && mv.feed_mm_min > self.max_z_feed_mm_min * (1.0 + 1e-9),
            _ => self.exceeded(mv),
        };
        if !over || block.line_number.is_some() || block.checksum.is_some() {
            return false;
        }
        let command: &[u8] = match block.command {
            Command::None => {
                if mv.rapid {
                    b"G0"
                } else {
                    b"G1"
                }
            }
            _ => block.command_span.of(raw),
        };
        let moves_xy = mv.to[X] != mv.from[X] || mv.to[Y] != mv.from[Y];
        let splittable = self.mode != ZCapMode::Slow
            && moves_xy
            && mv.to[E] == mv.from[E]
            && matches!(mv.path, Path::Line)
            && block.has(b'Z');
        let words = |skip: &[u8], out: &mut Vec<u8>| {
            out.extend_from_slice(command);
            for w in block.words.iter().filter(|w| !skip.contains(&w.letter)) {
                out.push(b' ');
                out.extend_from_slice(w.span.of(raw));
            }
        };
        let comment = |out: &mut Vec<u8>| {
            if let Some(c) = block.comment {
                out.extend_from_slice(b" ;");
                out.extend_from_slice(c.of(raw));
            }
            out.push(b'\n');
        };
        if splittable {
            // Z alone at the cap, then the rest at the original feed rate.
            out.extend_from_slice(command);
            if let Some(z) = block.word(b'Z') {
                out.push(b' ');
                out.extend_from_slice(z.span.of(raw));
            }
            out.push(b' ');
            fmt.write_word(out, b'F', floor_to(self.max_z_feed_mm_min, fmt.feed_decimals));
            out.push(b'\n');
            words(b"ZF", out);
            out.push(b' ');
            match block.word(b'F') {
                Some(f) => out.extend_from_slice(f.span.of(raw)),
                None => write_exact_feed(out, fmt, mv.feed_mm_min),
            }
            comment(out);
        } else {
            // A Z word that does not move Z (the seed's rule only) runs at the cap.
            let dz = (mv.to[Z] - mv.from[Z]).abs();
            let stretch = if dz > 0.0 { mv.len_mm() / dz } else { 1.0 };
            let slow = floor_to(self.max_z_feed_mm_min * stretch, fmt.feed_decimals);
            words(b"F", out);
            out.push(b' ');
            fmt.write_word(out, b'F', slow);
            comment(out);
            out.extend_from_slice(if mv.rapid { b"G0 " } else { b"G1 " });
            write_exact_feed(out, fmt, mv.feed_mm_min);
            out.push(b'\n');
        }
        true
    }
}

/// `v` rounded down to `decimals` places, so a written cap is never above the cap.
fn floor_to(v: f64, decimals: u8) -> f64 {
    let scale = 10f64.powi(i32::from(decimals));
    (v * scale * (1.0 + 1e-12)).floor() / scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::lexer::parse_into;
    use crate::gcode::state::{Effect, State};

    /// Feeds `prefix`, then caps `line`; returns the replacement (or the line) and checks by
    /// re-running it that every move keeps its end point and no Z speed exceeds the cap.
    fn cap(mode: ZCapMode, prefix: &str, line: &str) -> String {
        let zc = ZCap { max_z_feed_mm_min: 200.0, mode };
        let mut state = State::default();
        let mut block = Block::default();
        for l in prefix.lines() {
            parse_into(l.as_bytes(), &mut block);
            state.apply(l.as_bytes(), &block);
        }
        let mut after = state.clone();
        parse_into(line.as_bytes(), &mut block);
        let Effect::Move(mv) = *state.apply(line.as_bytes(), &block) else { panic!("not a move") };
        let mut out = Vec::new();
        if !zc.rewrite(line.as_bytes(), &block, &mv, &NumberFormat::default(), &mut out) {
            return line.to_owned();
        }
        let text = String::from_utf8(out).unwrap();
        for l in text.lines() {
            parse_into(l.as_bytes(), &mut block);
            if let Effect::Move(m) = after.apply(l.as_bytes(), &block) {
                assert!(z_feed_mm_min(m) <= 200.0 + 1e-9, "{l}: {}", z_feed_mm_min(m));
            }
        }
        assert_eq!(after.pos, state.pos);
        assert_eq!(after.feed_mm_min, state.feed_mm_min);
        text
    }

    #[test]
    fn the_seeds_example_splits() {
        // From nearby (0.5 mm away in XY) Z would run at 9000 * 0.2 / 0.54 = 3330 mm/min.
        let out = cap(ZCapMode::Split, "G0 X128 Y96.3 Z0.2 F200", "G0 F9000 X128.200 Y96.800 Z0.400 ; next");
        assert_eq!(out, "G0 Z0.400 F200\nG0 X128.200 Y96.800 F9000 ; next\n");
        // Without its own F the XY part states the feed rate in force.
        let out = cap(ZCapMode::Split, "G1 F3000", "G1 X10 Z2");
        assert_eq!(out, "G1 Z2 F200\nG1 X10 F3000\n");
        // From far away the same move is slow enough in Z: 9000 * 0.2 / 159.3 = 11.3 mm/min.
        let far = "G0 F9000 X128.200 Y96.800 Z0.400";
        assert_eq!(cap(ZCapMode::Split, "G0 X0 Y0 Z0.2", far), far);
        // The seed's rule splits it anyway, as the seed's script did.
        assert_eq!(cap(ZCapMode::Seed, "G0 X0 Y0 Z0.2", far), "G0 Z0.400 F200\nG0 X128.200 Y96.800 F9000\n");
        // ... and a Z word that does not move Z runs at the cap.
        assert_eq!(cap(ZCapMode::Seed, "G0 X0 Y0 Z0.4", "G0 Z0.4 F9000"), "G0 Z0.4 F200\nG0 F9000\n");
        assert_eq!(cap(ZCapMode::Seed, "G0 X0 Y0 Z0.2", "G0 X1 F9000"), "G0 X1 F9000", "no Z word");
    }

    #[test]
    fn z_only_and_extruding_moves_slow_down() {
        assert_eq!(cap(ZCapMode::Split, "G1 F7800", "G1 Z.6"), "G1 Z.6 F200\nG1 F7800\n");
        // A spiral-vase move: dz = 0.02 over 10 mm; at F1800 Z runs at 3.6 mm/min: untouched.
        assert_eq!(cap(ZCapMode::Split, "G1 F1800", "G1 X10 Z0.02 E0.5"), "G1 X10 Z0.02 E0.5");
        // Retract while hopping: slowed so that Z runs at 200 mm/min.
        let out = cap(ZCapMode::Split, "G1 X3 Y4 F2400", "G1 X0 Y0 Z5 E-1");
        assert_eq!(out, "G1 X0 Y0 Z5 E-1 F282\nG1 F2400\n");
        let out = cap(ZCapMode::Slow, "G1 F9000", "G0 X3 Y4 Z1");
        assert_eq!(out, "G0 X3 Y4 Z1 F1019\nG0 F9000\n");
    }
}
