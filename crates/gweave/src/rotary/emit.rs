//! Writing rotary moves: fixed decimals, absolute or relative E, and F per feed convention.
//!
//! The firmware sees the rounded words, not the exact geometry, so every F is computed from
//! the *rounded* deltas: a helix with a fine pitch advances a few microns axially per segment,
//! and under the NIST convention F is that axial distance over the segment time. Rounding the
//! axial word from 0.0036 to 0.004 mm without recomputing F would change the surface speed by
//! 11 %; computing F from 0.004 keeps it exact. Extrusion is tracked as an exact running total
//! and each E word is the rounded total minus what was already written, so rounding never
//! accumulates, in absolute or relative mode.
//!
//! Firmware parses words into 32-bit floats (Marlin), whose resolution at 100 000 degrees is
//! 0.008 degrees: a helix of many turns would lose its angle. Once the rotary word passes
//! [`RotaryConfig::rotary_rebase_deg`] the writer declares the same physical angle with a
//! smaller number (`G92 A<angle mod 360>`), which costs no motion.

use std::io::Write;

use super::cylinder::{CylPoint, FeedConvention, MachineDelta, RotaryConfig};
use super::{Result, RotaryError};
use crate::gcode::number::{scan, NumberFormat};

/// The rotary writers' default format: fixed decimals, 3 for axes (1 micron, 0.001 degree),
/// 5 for E, and 3 for F, because a fine-pitch helix under the NIST convention has feeds of a
/// few mm/min that whole numbers would get wrong by several percent.
pub fn rotary_number_format() -> NumberFormat {
    NumberFormat {
        position_decimals: 3,
        extrusion_decimals: 5,
        feed_decimals: 3,
        trim_zeros: false,
        drop_leading_zero: false,
    }
}

/// Checks the decimal counts of the `[table]` (see `NumberFormat`'s ranges).
pub fn validate_format(table: &str, format: &NumberFormat) -> Result<()> {
    use crate::settings::{CheckRanges, Table};
    Ok(format.check_ranges(&Table::root().sub(table))?)
}

/// Appends the word `letter` carrying `value` to `line` (a value that rounds to zero is `0`).
fn write_word(format: &NumberFormat, line: &mut Vec<u8>, letter: u8, value: f64) {
    format.write_word(line, letter, value);
}

/// `value` written as the word `letter` would carry it, without the letter.
pub fn number_text(format: &NumberFormat, letter: u8, value: f64) -> String {
    let mut out = Vec::new();
    write_word(format, &mut out, letter, value);
    String::from_utf8_lossy(&out[1..]).into_owned()
}

/// The number the firmware reads from `value` written as word `letter`.
fn rounded(format: &NumberFormat, letter: u8, value: f64) -> f64 {
    let mut out = Vec::new();
    format.write(&mut out, value, format.decimals_for(letter));
    // Our own output always scans; the fallback is never taken.
    scan(&out).map_or(value, |(v, _)| v)
}

/// One move for [`MoveWriter::write_move`].
#[derive(Clone, Copy, Debug)]
pub struct MoveSpec<'a> {
    /// Write `G0` instead of `G1`.
    pub rapid: bool,
    /// Where to go (a path point: the radius is the bead centreline).
    pub to: CylPoint,
    /// Filament to push, mm.
    pub e_mm: f64,
    /// Surface speed, mm/s.
    pub speed_mm_s: f64,
    /// Comment to carry (without the `;`).
    pub comment: Option<&'a [u8]>,
}

/// Renders rotary moves, keeping the state the words depend on: the last words written (each
/// possibly unknown), the E totals, the distance modes and the rotary rebase offset.
///
/// The radial word is the nozzle height above the mandrel surface; a path point's radius is
/// the bead centreline, so `radial = radius - R0 + nozzle_above_path_mm` (half the layer height
/// for a bead whose top the nozzle touches, 0 when the points are nozzle positions).
#[derive(Debug, Clone)]
pub struct MoveWriter {
    machine: RotaryConfig,
    format: NumberFormat,
    nozzle_above_path_mm: f64,
    relative_axes: bool,
    relative_e: bool,
    /// Last axial, rotary, radial words, `None` while unknown.
    words: [Option<f64>; 3],
    /// Angle subtracted before writing the rotary word (grows with each rebase), degrees.
    rotary_offset_deg: f64,
    e_target_mm: f64,
    e_written_mm: f64,
    time_s: f64,
}

const AXIAL: usize = 0;
const ROTARY: usize = 1;
const RADIAL: usize = 2;

impl MoveWriter {
    /// A writer in absolute mode that does not know where the machine is yet.
    pub fn new(machine: RotaryConfig, format: NumberFormat, nozzle_above_path_mm: f64) -> Self {
        Self {
            machine,
            format,
            nozzle_above_path_mm,
            relative_axes: false,
            relative_e: false,
            words: [None; 3],
            rotary_offset_deg: 0.0,
            e_target_mm: 0.0,
            e_written_mm: 0.0,
            time_s: 0.0,
        }
    }

    /// Sets the distance modes the next moves are written in (G90/G91, M82/M83).
    pub fn set_modes(&mut self, relative_axes: bool, relative_e: bool) {
        self.relative_axes = relative_axes;
        self.relative_e = relative_e;
    }

    fn letters(&self) -> [u8; 3] {
        [self.machine.axial_axis, self.machine.rotary_axis, self.machine.radial_axis].map(|c| c as u8)
    }

    fn words_of(&self, p: CylPoint) -> [f64; 3] {
        let raw = [
            p.axial_mm,
            self.machine.rotary_from_deg(p.theta_deg - self.rotary_offset_deg),
            p.radius_mm - self.machine.mandrel_radius_mm() + self.nozzle_above_path_mm,
        ];
        let letters = self.letters();
        [0, 1, 2].map(|i| rounded(&self.format, letters[i], raw[i]))
    }

    fn point_of(&self, w: [f64; 3]) -> CylPoint {
        let mut p = self.machine.point_from_words(w, self.nozzle_above_path_mm);
        p.theta_deg += self.rotary_offset_deg;
        p
    }

    fn known(&self) -> Option<[f64; 3]> {
        Some([self.words[0]?, self.words[1]?, self.words[2]?])
    }

    /// Where the machine is, as the rounded words put it (`None` while any axis is unknown).
    pub fn position(&self) -> Option<CylPoint> {
        self.known().map(|w| self.point_of(w))
    }

    /// Whether the rotary word is known (it is not after a homing that may have moved it).
    pub fn rotary_known(&self) -> bool {
        self.words[ROTARY].is_some()
    }

    /// Filament extruded so far, mm (the exact total the E words follow, from the last reset).
    pub fn filament_mm(&self) -> f64 {
        self.e_target_mm
    }

    /// Time of the moves written so far, seconds, as the firmware reads their F (no
    /// acceleration).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Takes the machine to be at `p` on the chosen axes (axial, rotary, radial) without
    /// writing anything: after a homing, or at the start of a file. Unchosen axes keep their
    /// state.
    pub fn assume(&mut self, p: CylPoint, axes: [bool; 3]) {
        let w = self.words_of(p);
        for ((word, new), chosen) in self.words.iter_mut().zip(w).zip(axes) {
            if chosen {
                *word = Some(new);
            }
        }
    }

    /// Marks axes as unknown (after a homing whose effect on them is not known).
    pub fn forget(&mut self, axes: [bool; 3]) {
        for (word, chosen) in self.words.iter_mut().zip(axes) {
            if chosen {
                *word = None;
            }
        }
    }

    /// Writes `G92` declaring the machine to be at `p` on the chosen axes. The mandrel angle
    /// needs no homing: declaring it is how a program fixes it.
    pub fn declare(&mut self, out: &mut dyn Write, p: CylPoint, axes: [bool; 3]) -> Result<()> {
        let w = self.words_of(p);
        let mut line = b"G92".to_vec();
        for (i, letter) in self.letters().into_iter().enumerate() {
            if axes[i] {
                line.push(b' ');
                write_word(&self.format, &mut line, letter, w[i]);
                self.words[i] = Some(w[i]);
            }
        }
        line.push(b'\n');
        out.write_all(&line)?;
        Ok(())
    }

    /// Restarts the E count at `e_mm` (what a `G92 E<e_mm>` does), writing nothing.
    pub fn set_e(&mut self, e_mm: f64) {
        self.e_target_mm = e_mm;
        self.e_written_mm = e_mm;
    }

    /// Writes `G0` moves to `p` at `feed_mm_min` in units-per-minute mode (G94), first
    /// radially, then axially; the rotary word must have been declared. For the approach from
    /// an unknown position after the start G-code; every word is written.
    pub fn approach(&mut self, out: &mut dyn Write, p: CylPoint, feed_mm_min: f64) -> Result<()> {
        let w = self.words_of(p);
        let letters = self.letters();
        for i in [RADIAL, AXIAL] {
            let mut line = b"G0 ".to_vec();
            write_word(&self.format, &mut line, letters[i], w[i]);
            line.push(b' ');
            write_word(&self.format, &mut line, b'F', feed_mm_min);
            line.push(b'\n');
            out.write_all(&line)?;
            self.words[i] = Some(w[i]);
        }
        Ok(())
    }

    /// Re-declares a large rotary word as the same angle modulo one turn (see module docs).
    fn rebase_rotary(&mut self, out: &mut dyn Write) -> Result<()> {
        let limit = self.machine.rotary_rebase_deg;
        let Some(word) = self.words[ROTARY] else {
            return Ok(());
        };
        let theta = self.machine.deg_from_rotary(word);
        if limit <= 0.0 || theta.abs() <= limit {
            return Ok(());
        }
        let position = CylPoint::new(0.0, theta + self.rotary_offset_deg, 0.0);
        self.rotary_offset_deg += 360.0 * (theta / 360.0).trunc();
        self.declare(out, position, [false, true, false])
    }

    /// Writes a `G1` to `to` pushing `e_mm` of filament at surface speed `speed_mm_s`.
    /// See [`Self::write_move`].
    pub fn move_to(&mut self, out: &mut dyn Write, to: CylPoint, e_mm: f64, speed_mm_s: f64) -> Result<()> {
        self.write_move(out, &MoveSpec { rapid: false, to, e_mm, speed_mm_s, comment: None })
    }

    /// Writes one move. Words that did not change are left out; a move whose axis words round
    /// to where the machine already is gets skipped and its E carried to the next move.
    /// Every axis must be known.
    pub fn write_move(&mut self, out: &mut dyn Write, spec: &MoveSpec<'_>) -> Result<()> {
        self.rebase_rotary(out)?;
        let last = self.known().ok_or(RotaryError::UnknownPosition)?;
        let words = self.words_of(spec.to);
        self.e_target_mm += spec.e_mm;
        if words == last {
            return Ok(());
        }
        let t_s = self.machine.move_time_s(self.point_of(last), self.point_of(words), spec.speed_mm_s);
        if let Some(turned) = self.crawl(last, words, t_s) {
            // The turn with its extrusion, then the few microns at the surface speed.
            self.finish_line(out, spec.rapid, last, turned, t_s, spec.comment)?;
            let linear_mm = (words[AXIAL] - turned[AXIAL]).hypot(words[RADIAL] - turned[RADIAL]);
            return self.finish_line(out, spec.rapid, turned, words, linear_mm / spec.speed_mm_s, None);
        }
        self.finish_line(out, spec.rapid, last, words, t_s, spec.comment)
    }

    /// Under the NIST convention the F of a move that turns and moves a linear axis is the linear
    /// speed alone: a turn that drifts a micron axially (a flat part's edge almost along the
    /// wrap) would need F below any feed a firmware takes (`F0.679`: the virtual printer
    /// refuses it, Marlin raises it to its minimum and rushes the turn). Such a move is written
    /// as the turn alone, which ends at the words this returns, then the linear rest.
    fn crawl(&self, last: [f64; 3], words: [f64; 3], t_s: f64) -> Option<[f64; 3]> {
        let linear_mm = (words[AXIAL] - last[AXIAL]).hypot(words[RADIAL] - last[RADIAL]);
        let crawls = self.machine.feed_convention == FeedConvention::Nist
            && words[ROTARY] != last[ROTARY]
            && linear_mm > 0.0
            && 60.0 * linear_mm / t_s < crate::range::FEED_MM_MIN.min;
        crawls.then_some([last[AXIAL], words[ROTARY], last[RADIAL]])
    }

    /// Writes an extruder-only move of `e_mm` at `speed_mm_s` of filament (a retraction).
    pub fn extrude_only(
        &mut self,
        out: &mut dyn Write,
        e_mm: f64,
        speed_mm_s: f64,
        comment: Option<&[u8]>,
    ) -> Result<()> {
        let last = self.known().ok_or(RotaryError::UnknownPosition)?;
        self.e_target_mm += e_mm;
        let t_s = e_mm.abs() / speed_mm_s;
        self.finish_line(out, false, last, last, t_s, comment)
    }

    fn finish_line(
        &mut self,
        out: &mut dyn Write,
        rapid: bool,
        last: [f64; 3],
        words: [f64; 3],
        t_s: f64,
        comment: Option<&[u8]>,
    ) -> Result<()> {
        let e_total = rounded(&self.format, b'E', self.e_target_mm);
        let delta = MachineDelta {
            axial_mm: words[AXIAL] - last[AXIAL],
            rotary: words[ROTARY] - last[ROTARY],
            radial_mm: words[RADIAL] - last[RADIAL],
            e_mm: e_total - self.e_written_mm,
        };
        if words == last && delta.e_mm == 0.0 {
            return Ok(());
        }
        let feed = self.machine.feed_for(&delta, t_s).ok_or(RotaryError::Config {
            key: "speed",
            reason: format!("no feed rate for a move of {t_s} s"),
        })?;
        let mut line = if rapid { b"G0".to_vec() } else { b"G1".to_vec() };
        for (i, letter) in self.letters().into_iter().enumerate() {
            if words[i] != last[i] {
                line.push(b' ');
                let value = if self.relative_axes { words[i] - last[i] } else { words[i] };
                write_word(&self.format, &mut line, letter, value);
            }
        }
        if delta.e_mm != 0.0 {
            line.push(b' ');
            let e_word = if self.relative_e { delta.e_mm } else { e_total };
            write_word(&self.format, &mut line, b'E', e_word);
        }
        line.push(b' ');
        write_word(&self.format, &mut line, b'F', feed);
        if let Some(text) = comment {
            line.extend_from_slice(b" ;");
            line.extend_from_slice(text);
        }
        line.push(b'\n');
        out.write_all(&line)?;
        self.e_written_mm = e_total;
        self.words = words.map(Some);
        self.time_s += self.machine.time_from_feed(&delta, rounded(&self.format, b'F', feed)).unwrap_or(t_s);
        Ok(())
    }

    /// `G93` when the convention is inverse time (written before the first timed move).
    pub fn enter_feed_mode(&self, out: &mut dyn Write) -> Result<()> {
        if self.machine.feed_convention == FeedConvention::InverseTime {
            out.write_all(b"G93 ; inverse-time feed: F = 1/T, T in minutes\n")?;
        }
        Ok(())
    }

    /// `G94` back to units per minute when the convention was inverse time.
    pub fn leave_feed_mode(&self, out: &mut dyn Write) -> Result<()> {
        if self.machine.feed_convention == FeedConvention::InverseTime {
            out.write_all(b"G94\n")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn writer() -> (MoveWriter, Vec<u8>) {
        let mut w = MoveWriter::new(RotaryConfig::new(20.0), rotary_number_format(), 0.1);
        let mut out = Vec::new();
        let start = CylPoint::new(1.0, 0.0, 10.1);
        w.declare(&mut out, start, [false, true, false]).unwrap();
        w.approach(&mut out, start, 3000.0).unwrap();
        (w, out)
    }

    fn lines(out: &[u8]) -> Vec<String> {
        String::from_utf8(out.to_vec()).unwrap().lines().map(str::to_owned).collect()
    }

    #[test]
    fn format_limits_and_text() {
        let mut bad = rotary_number_format();
        bad.position_decimals = 12;
        let err = validate_format("numbers", &bad).unwrap_err().to_string();
        assert_eq!(err, "[numbers] position_decimals = 12 is out of range: 0 to 9 decimals");
        let f = rotary_number_format();
        assert_eq!(number_text(&f, b'X', -0.0001), "0.000");
        assert_eq!(number_text(&f, b'E', 1.0), "1.00000");
    }

    #[test]
    fn approach_and_move_words() {
        let (mut w, mut out) = writer();
        // Bead centre at 10.1 with the nozzle 0.1 above it: radial word 0.2.
        assert_eq!(w.position(), Some(CylPoint::new(1.0, 0.0, 10.1)));
        w.move_to(&mut out, CylPoint::new(1.0, 90.0, 10.1), 0.5, 10.0).unwrap();
        // Rotary-only under NIST: 90 deg over 15.865 mm at 10 mm/s = 1.5865 s -> 3403.8 deg/min.
        let feed = 90.0 * 60.0 / (10.1 * std::f64::consts::FRAC_PI_2 / 10.0);
        let f = rotary_number_format();
        assert_eq!(
            lines(&out),
            [
                "G92 A0.000".to_owned(),
                "G0 Z0.200 F3000.000".into(),
                "G0 X1.000 F3000.000".into(),
                format!("G1 A90.000 E0.50000 F{}", number_text(&f, b'F', feed)),
            ]
        );
    }

    #[test]
    fn feed_from_rounded_axial_step() {
        let (mut w, mut out) = writer();
        // 0.0036 mm axial rounds to 0.004: F must be 0.004 mm over the segment time.
        let to = CylPoint::new(1.0036, 5.0, 10.1);
        w.move_to(&mut out, to, 0.01, 20.0).unwrap();
        let from_q = CylPoint::new(1.0, 0.0, 10.1);
        let to_q = CylPoint::new(1.004, 5.0, 10.1);
        let t_s = super::super::cylinder::surface_length_mm(from_q, to_q) / 20.0;
        let f = rotary_number_format();
        assert_eq!(
            lines(&out).last().unwrap(),
            &format!("G1 X1.004 A5.000 E0.01000 F{}", number_text(&f, b'F', 0.004 * 60.0 / t_s))
        );
    }

    /// Regression: wrapping a PrusaSlicer pyramid wrote `G1 X101.364 A376.758 E6.76525 F0.679`
    /// (X one micron on, a long turn): under NIST F is the axial speed alone, below the 1 mm/min
    /// any firmware takes, and `gweave sim --machine rotary` refused the file. The turn is
    /// written alone, then the micron at the surface speed: every F at least 1 mm/min, the
    /// end where it was and the extrusion on the turn.
    #[test]
    fn a_turn_that_drifts_a_micron_is_not_written_at_a_crawl() {
        let (mut w, mut out) = writer();
        w.move_to(&mut out, CylPoint::new(1.001, 90.0, 10.1), 0.5, 10.0).unwrap();
        let lines = lines(&out);
        let feed = 90.0 * 60.0 / (10.1 * std::f64::consts::FRAC_PI_2 / 10.0);
        let f = rotary_number_format();
        assert_eq!(
            lines[3..],
            [format!("G1 A90.000 E0.50000 F{}", number_text(&f, b'F', feed)), "G1 X1.001 F600.000".into()]
        );
        assert_eq!(w.position(), Some(CylPoint::new(1.001, 90.0, 10.1)));
    }

    #[test]
    fn relative_e_does_not_drift() {
        let (mut w, mut out) = writer();
        w.set_modes(false, true);
        for i in 1..=1000 {
            let p = CylPoint::new(1.0, f64::from(i), 10.1);
            w.move_to(&mut out, p, 0.000_013, 10.0).unwrap();
        }
        let total: f64 = lines(&out)
            .iter()
            .filter_map(|l| l.split(' ').find_map(|word| word.strip_prefix('E')))
            .map(|e| e.parse::<f64>().unwrap())
            .sum();
        // 1000 * 0.000013 = 0.013 exactly, although each word rounds to 0.00001.
        assert!((total - 0.013).abs() < 1e-9, "{total}");
    }

    #[test]
    fn relative_axes_write_deltas() {
        let (mut w, mut out) = writer();
        w.set_modes(true, true);
        w.move_to(&mut out, CylPoint::new(3.0, 0.0, 10.6), 0.0, 10.0).unwrap();
        assert_eq!(lines(&out)[3], "G1 X2.000 Z0.500 F600.000");
    }

    #[test]
    fn extruder_only_moves() {
        let (mut w, mut out) = writer();
        w.extrude_only(&mut out, -0.8, 35.0, Some(b" retract")).unwrap();
        assert_eq!(lines(&out)[3], "G1 E-0.80000 F2100.000 ; retract");
    }

    #[test]
    fn unknown_position_is_an_error() {
        let mut w = MoveWriter::new(RotaryConfig::new(20.0), rotary_number_format(), 0.0);
        let err = w.move_to(&mut Vec::new(), CylPoint::new(0.0, 1.0, 10.0), 0.0, 10.0);
        assert!(matches!(err, Err(RotaryError::UnknownPosition)));
        w.assume(CylPoint::new(0.0, 0.0, 10.0), [true, true, true]);
        w.forget([false, true, false]);
        assert!(!w.rotary_known() && w.position().is_none());
    }

    #[test]
    fn nothing_moves_nothing_written() {
        let (mut w, mut out) = writer();
        w.move_to(&mut out, CylPoint::new(1.0, 0.0001, 10.1), 0.25, 10.0).unwrap();
        w.move_to(&mut out, CylPoint::new(1.0, 1.0, 10.1), 0.25, 10.0).unwrap();
        let lines = lines(&out);
        assert_eq!(lines.len(), 4);
        // The E of the skipped move is carried: 0.5 in all.
        assert!(lines[3].contains(" E0.50000 "), "{lines:?}");
    }

    #[test]
    fn large_angles_are_rebased() {
        let mut machine = RotaryConfig::new(20.0);
        machine.rotary_rebase_deg = 720.0;
        let mut w = MoveWriter::new(machine, rotary_number_format(), 0.0);
        let mut out = Vec::new();
        w.assume(CylPoint::new(0.0, 0.0, 10.0), [true, true, true]);
        for i in 1..=20 {
            let p = CylPoint::new(0.0, f64::from(i) * 100.0, 10.0);
            w.move_to(&mut out, p, 0.0, 10.0).unwrap();
        }
        let lines = lines(&out);
        // 800 deg is declared as 80, and so on: the words stay below 720 + one move.
        assert!(lines.contains(&"G92 A80.000".to_owned()), "{lines:?}");
        assert_eq!(lines.last().unwrap(), "G1 A560.000 F3437.747");
        assert!((w.position().unwrap().theta_deg - 2000.0).abs() < 1e-9);
    }
}
