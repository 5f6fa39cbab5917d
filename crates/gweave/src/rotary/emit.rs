//! Writing rotary moves: fixed decimals, absolute or relative E, and F per feed convention.
//!
//! The firmware sees the rounded words, not the exact geometry, so every F is computed from
//! the *rounded* deltas: a helix with a fine pitch advances a few microns axially per segment,
//! and under the NIST convention F is that axial distance over the segment time. Rounding the
//! axial word from 0.0036 to 0.004 mm without recomputing F would change the surface speed by
//! 11 %; computing F from 0.004 keeps it exact. Extrusion is tracked as an exact running total
//! and each E word is the rounded total minus what was already written, so rounding never
//! accumulates, in absolute or relative mode.

use std::io::Write;

use serde::{Deserialize, Serialize};

use super::cylinder::{CylPoint, FeedConvention, MachineDelta, RotaryConfig};
use super::{Result, RotaryError};

/// Decimal places of emitted numbers. TOML: `decimals`, `e-decimals`, `f-decimals`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case", default)]
pub struct NumberFormat {
    /// Places of the axis words (default 3: 1 micron, 0.001 degree).
    pub decimals: u8,
    /// Places of the E word (default 5).
    pub e_decimals: u8,
    /// Places of the F word (default 3: fine pitches give feeds of a few mm/min under NIST).
    pub f_decimals: u8,
}

impl Default for NumberFormat {
    fn default() -> Self {
        Self {
            decimals: 3,
            e_decimals: 5,
            f_decimals: 3,
        }
    }
}

impl NumberFormat {
    /// Most places worth writing: an f64 holds about 15 significant digits.
    const MAX_DECIMALS: u8 = 9;

    /// Checks that no count exceeds 9 places.
    pub fn validate(&self) -> Result<()> {
        for (key, places) in [
            ("decimals", self.decimals),
            ("e-decimals", self.e_decimals),
            ("f-decimals", self.f_decimals),
        ] {
            if places > Self::MAX_DECIMALS {
                return Err(RotaryError::Config {
                    key,
                    reason: format!("at most {} places, got {places}", Self::MAX_DECIMALS),
                });
            }
        }
        Ok(())
    }
}

/// `value` with exactly `decimals` places, never `-0.000`.
pub fn format_fixed(value: f64, decimals: u8) -> String {
    let text = format!("{:.*}", usize::from(decimals), value);
    match text.strip_prefix('-') {
        Some(magnitude) if magnitude.bytes().all(|b| b == b'0' || b == b'.') => {
            magnitude.to_owned()
        }
        _ => text,
    }
}

/// The number the firmware reads from `format_fixed(value, decimals)`.
fn rounded(value: f64, decimals: u8) -> f64 {
    // Parsing our own fixed-point output cannot fail; the fallback is never taken.
    format_fixed(value, decimals).parse().unwrap_or(value)
}

/// The three axis words the firmware was last sent, already rounded.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Words {
    axial: f64,
    rotary: f64,
    radial: f64,
}

/// Streams rotary G1 moves to any writer, keeping the state the words depend on.
///
/// The radial word is the nozzle height above the mandrel surface; a path point's radius is
/// the bead centreline, so `radial = radius - R0 + nozzle_above_path_mm` (half the layer height
/// for a bead whose top the nozzle touches, 0 when the points are nozzle positions).
#[derive(Debug)]
pub struct MoveWriter<W: Write> {
    out: W,
    machine: RotaryConfig,
    format: NumberFormat,
    relative_e: bool,
    nozzle_above_path_mm: f64,
    last: Option<Words>,
    e_target_mm: f64,
    e_written_mm: f64,
    time_s: f64,
}

impl<W: Write> MoveWriter<W> {
    /// A writer that does not know where the machine is yet.
    pub fn new(
        out: W,
        machine: RotaryConfig,
        format: NumberFormat,
        relative_e: bool,
        nozzle_above_path_mm: f64,
    ) -> Self {
        Self {
            out,
            machine,
            format,
            relative_e,
            nozzle_above_path_mm,
            last: None,
            e_target_mm: 0.0,
            e_written_mm: 0.0,
            time_s: 0.0,
        }
    }

    /// Writes one verbatim line (a newline is added).
    pub fn line(&mut self, text: &str) -> Result<()> {
        writeln!(self.out, "{text}")?;
        Ok(())
    }

    fn words_of(&self, p: CylPoint) -> Words {
        let d = self.format.decimals;
        Words {
            axial: rounded(p.axial_mm, d),
            rotary: rounded(self.machine.rotary_from_deg(p.theta_deg), d),
            radial: rounded(
                p.radius_mm - self.machine.mandrel_radius_mm() + self.nozzle_above_path_mm,
                d,
            ),
        }
    }

    fn point_of(&self, w: Words) -> CylPoint {
        CylPoint::new(
            w.axial,
            self.machine.deg_from_rotary(w.rotary),
            w.radial + self.machine.mandrel_radius_mm() - self.nozzle_above_path_mm,
        )
    }

    /// Where the machine is, as the rounded words put it (`None` before the first move).
    pub fn position(&self) -> Option<CylPoint> {
        self.last.map(|w| self.point_of(w))
    }

    /// Filament extruded so far, mm (the exact total the E words follow).
    pub fn filament_mm(&self) -> f64 {
        self.e_target_mm
    }

    /// Time of the moves written with [`Self::move_to`], seconds, as the firmware reads F
    /// (no acceleration).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Writes `G92 <rotary><angle> E0`: the mandrel's current angle is declared to be that of
    /// `p` (a rotary axis needs no homing: its starting angle is irrelevant) and E restarts.
    pub fn declare_rotary_and_e(&mut self, p: CylPoint) -> Result<()> {
        let rotary = self.words_of(p).rotary;
        writeln!(
            self.out,
            "G92 {}{} E0",
            self.machine.rotary_axis,
            format_fixed(rotary, self.format.decimals)
        )?;
        self.e_target_mm = 0.0;
        self.e_written_mm = 0.0;
        if let Some(last) = self.last.as_mut() {
            last.rotary = rotary;
        }
        Ok(())
    }

    /// Writes `G0` moves to `p` at `feed_mm_min` in units-per-minute mode (G94), first
    /// radially, then axially, the rotary axis being declared rather than moved. For the
    /// approach from an unknown position after the start G-code; every word is written.
    pub fn approach(&mut self, p: CylPoint, feed_mm_min: f64) -> Result<()> {
        let w = self.words_of(p);
        let d = self.format.decimals;
        let feed = format_fixed(feed_mm_min, self.format.f_decimals);
        writeln!(
            self.out,
            "G0 {}{} F{feed}",
            self.machine.radial_axis,
            format_fixed(w.radial, d)
        )?;
        writeln!(
            self.out,
            "G0 {}{} F{feed}",
            self.machine.axial_axis,
            format_fixed(w.axial, d)
        )?;
        self.last = Some(Words {
            rotary: self.last.map_or(w.rotary, |l| l.rotary),
            ..w
        });
        Ok(())
    }

    /// Writes one `G1` to `to`, extruding `e_mm` of filament, at surface speed `speed_mm_s`.
    /// Words that did not change are left out; a move whose axis words round to where the
    /// machine already is gets skipped and its E carried to the next move.
    pub fn move_to(&mut self, to: CylPoint, e_mm: f64, speed_mm_s: f64) -> Result<()> {
        let last = self.last.ok_or(RotaryError::UnknownPosition)?;
        let words = self.words_of(to);
        self.e_target_mm += e_mm;
        let e_total = rounded(self.e_target_mm, self.format.e_decimals);
        let e_word = if self.relative_e {
            rounded(e_total - self.e_written_mm, self.format.e_decimals)
        } else {
            e_total
        };
        let delta = MachineDelta {
            axial_mm: words.axial - last.axial,
            rotary: words.rotary - last.rotary,
            radial_mm: words.radial - last.radial,
            e_mm: e_total - self.e_written_mm,
        };
        if words == last {
            return Ok(());
        }
        let t_s = self
            .machine
            .move_time_s(self.point_of(last), self.point_of(words), speed_mm_s);
        let Some(feed) = self.machine.feed_for(&delta, t_s) else {
            return Err(RotaryError::Config {
                key: "speed",
                reason: format!("no feed rate for a move at {speed_mm_s} mm/s"),
            });
        };
        let mut text = String::from("G1");
        let d = self.format.decimals;
        for (letter, old, new) in [
            (self.machine.axial_axis, last.axial, words.axial),
            (self.machine.rotary_axis, last.rotary, words.rotary),
            (self.machine.radial_axis, last.radial, words.radial),
        ] {
            if old != new {
                text.push_str(&format!(" {letter}{}", format_fixed(new, d)));
            }
        }
        if delta.e_mm != 0.0 {
            text.push_str(&format!(
                " E{}",
                format_fixed(e_word, self.format.e_decimals)
            ));
        }
        text.push_str(&format!(" F{}", format_fixed(feed, self.format.f_decimals)));
        writeln!(self.out, "{text}")?;
        self.e_written_mm = e_total;
        self.last = Some(words);
        self.time_s += self
            .machine
            .time_from_feed(&delta, rounded(feed, self.format.f_decimals))
            .unwrap_or(t_s);
        Ok(())
    }

    /// `G93` when the convention is inverse time (written before the first timed move).
    pub fn enter_feed_mode(&mut self) -> Result<()> {
        if self.machine.feed_convention == FeedConvention::InverseTime {
            self.line("G93 ; inverse-time feed: F = 1/T, T in minutes")?;
        }
        Ok(())
    }

    /// `G94` back to units per minute when the convention was inverse time.
    pub fn leave_feed_mode(&mut self) -> Result<()> {
        if self.machine.feed_convention == FeedConvention::InverseTime {
            self.line("G94")?;
        }
        Ok(())
    }

    /// Flushes and returns the underlying writer.
    pub fn into_inner(mut self) -> Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn writer(relative_e: bool) -> MoveWriter<Vec<u8>> {
        let mut w = MoveWriter::new(
            Vec::new(),
            RotaryConfig::new(20.0),
            NumberFormat::default(),
            relative_e,
            0.1,
        );
        w.approach(CylPoint::new(1.0, 0.0, 10.1), 3000.0).unwrap();
        w
    }

    fn text(w: MoveWriter<Vec<u8>>) -> String {
        String::from_utf8(w.into_inner().unwrap()).unwrap()
    }

    #[test]
    fn fixed_format_has_no_negative_zero() {
        assert_eq!(format_fixed(-0.0001, 3), "0.000");
        assert_eq!(format_fixed(-0.0006, 3), "-0.001");
        assert_eq!(format_fixed(12.5, 2), "12.50");
        assert_eq!(format_fixed(3.0, 0), "3");
    }

    #[test]
    fn format_limits() {
        let bad = NumberFormat {
            decimals: 12,
            ..Default::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(RotaryError::Config {
                key: "decimals",
                ..
            })
        ));
        assert!(NumberFormat::default().validate().is_ok());
    }

    #[test]
    fn approach_and_move_words() {
        let mut w = writer(false);
        // Bead centre at 10.1 with the nozzle 0.1 above it: radial word 0.2.
        assert_eq!(w.position(), Some(CylPoint::new(1.0, 0.0, 10.1)));
        w.move_to(CylPoint::new(1.0, 90.0, 10.1), 0.5, 10.0)
            .unwrap();
        // Rotary-only under NIST: 90 deg over 15.865 mm at 10 mm/s = 1.5865 s -> 3403.8 deg/min.
        let expected_feed = 90.0 * 60.0 / (10.1 * std::f64::consts::FRAC_PI_2 / 10.0);
        let out = text(w);
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[0], "G0 Z0.200 F3000.000");
        assert_eq!(lines[1], "G0 X1.000 F3000.000");
        assert_eq!(
            lines[2],
            format!("G1 A90.000 E0.50000 F{}", format_fixed(expected_feed, 3))
        );
    }

    #[test]
    fn feed_from_rounded_axial_step() {
        let mut w = writer(false);
        // 0.0036 mm axial rounds to 0.004: F must be 0.004 mm over the segment time.
        let to = CylPoint::new(1.0036, 5.0, 10.1);
        w.move_to(to, 0.01, 20.0).unwrap();
        let from_q = CylPoint::new(1.0, 0.0, 10.1);
        let to_q = CylPoint::new(1.004, 5.0, 10.1);
        let t_s = super::super::cylinder::surface_length_mm(from_q, to_q) / 20.0;
        let out = text(w);
        let last = out.lines().last().unwrap();
        assert_eq!(
            last,
            format!(
                "G1 X1.004 A5.000 E0.01000 F{}",
                format_fixed(0.004 * 60.0 / t_s, 3)
            )
        );
    }

    #[test]
    fn relative_e_does_not_drift() {
        let mut w = writer(true);
        for i in 1..=1000 {
            let p = CylPoint::new(1.0, f64::from(i), 10.1);
            w.move_to(p, 0.000_013, 10.0).unwrap();
        }
        let total: f64 = text(w)
            .lines()
            .filter_map(|l| l.split(' ').find_map(|word| word.strip_prefix('E')))
            .map(|e| e.parse::<f64>().unwrap())
            .sum();
        // 1000 * 0.000013 = 0.013 exactly, although each word rounds to 0.00001.
        assert!((total - 0.013).abs() < 1e-9, "{total}");
    }

    #[test]
    fn unknown_position_is_an_error() {
        let mut w = MoveWriter::new(
            Vec::new(),
            RotaryConfig::new(20.0),
            NumberFormat::default(),
            false,
            0.0,
        );
        let err = w.move_to(CylPoint::new(0.0, 1.0, 10.0), 0.0, 10.0);
        assert!(matches!(err, Err(RotaryError::UnknownPosition)));
    }

    #[test]
    fn nothing_moves_nothing_written() {
        let mut w = writer(false);
        w.move_to(CylPoint::new(1.0, 0.0001, 10.1), 0.25, 10.0)
            .unwrap();
        w.move_to(CylPoint::new(1.0, 1.0, 10.1), 0.25, 10.0)
            .unwrap();
        let out = text(w);
        assert_eq!(out.lines().count(), 3);
        // The E of the skipped move is carried: 0.5 in all.
        assert!(out.lines().last().unwrap().contains(" E0.50000 "), "{out}");
    }
}
