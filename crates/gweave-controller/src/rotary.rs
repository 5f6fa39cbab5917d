//! The rotary axis `A` of a lathe-type printer: a mandrel turned by a stepper, in degrees.
//!
//! # The motor
//!
//! A steps the motor of RAMPS's E1 socket ([`A_MOTOR`]), the one a mixing hotend's second
//! input uses: a machine has one or the other ([`Rotary::fitted`] is false on a mixing
//! hotend). Its steps per degree are `200 full steps × microsteps × gear ratio / 360` (8.889 for
//! a 1/16-stepped motor turning the mandrel directly). A mandrel has no endstop and no end:
//! `G28` leaves it alone, its angle is whatever the program names (`G92 A0`), and it may turn
//! without limit (a tube of 4 layers turns 200 times).
//!
//! # What F means on a move that turns A
//!
//! A degree is not a millimetre, so a feed rate over a move that turns the mandrel needs a rule.
//! G-code has two (LinuxCNC's documentation, "Feed Rate" with rotary axes, after NIST RS274NGC
//! 3.0, section 2.1.2.5):
//!
//! - `G94` (the default), units per minute. Which length F is measured over is the machine's
//!   convention, set at build time ([`RotaryFeed`]): **NIST**, F along X, Y and Z when any of
//!   them moves (the mandrel follows in the same time), in degrees per minute when A alone
//!   moves; or **combined**, F along `sqrt(dX² + dY² + dZ² + dA²)`, degrees counted as
//!   millimetres (Marlin's `ARTICULATED_ROBOT_ARM`, RepRapFirmware's `M584 ... S0`).
//! - `G93`, inverse time: F is one over the move's duration in minutes (`F60` takes one
//!   second), whatever the axes: a move of length `L` (by the convention above) runs at
//!   `L × F / 60` per second. `G94` goes back to units per minute.
//!
//! `gweave rotary wrap` and `rotary tube` write F by the `--feed-convention` they are given
//! (`nist` by default, `combined`, or `inverse-time` with `G93`): set [`Rotary::feed`] to the
//! one the files use, and every move takes the time the writer computed. A host strips the
//! comment that declares it, so the firmware cannot read it from the file.
//!
//! The planner then works in that length: its speed, acceleration and junction speeds are
//! along it, and each motor's own limit holds (A's in degrees per second, and per second
//! squared): a helix chord of 0.04 mm of X and 5° of A under NIST is a path of 0.04 mm, with
//! A's speed `5 / 0.04` times the path's.

use crate::E;

/// The motor the rotary axis steps: RAMPS's E1 socket (D36 STEP, D34 DIR, D30 ENABLE).
pub const A_MOTOR: usize = E + 1;

/// The length a `G94` feed rate is measured over on a move that turns A (see the module's
/// text).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RotaryFeed {
    /// XYZ when any of them moves, else A in degrees, else E (LinuxCNC, NIST RS274NGC).
    Nist,
    /// `sqrt(dX² + dY² + dZ² + dA²)`, degrees as millimetres, else E.
    Combined,
}

/// The rotary axis' build-time settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rotary {
    /// Steps per degree of the mandrel; 0: no rotary axis (an `A` word is refused).
    pub steps_per_deg: f32,
    /// Highest speed of the mandrel, degrees per second.
    pub max_feed_deg_s: f32,
    /// Highest acceleration of the mandrel, degrees per second squared.
    pub max_accel_deg_s2: f32,
    /// What F means on a move that turns it.
    pub feed: RotaryFeed,
}

impl Rotary {
    /// No rotary axis.
    pub const NONE: Rotary = Rotary {
        steps_per_deg: 0.0,
        max_feed_deg_s: 360.0,
        max_accel_deg_s2: 3600.0,
        feed: RotaryFeed::Nist,
    };

    /// Whether the machine has the axis: a build with the feature `rotary` (without it this is
    /// a constant `false` and the axis' code compiles to nothing), steps per degree set, and no
    /// mixing hotend on its motor.
    pub fn fitted(&self, mixing_inputs: u8) -> bool {
        cfg!(feature = "rotary") && self.steps_per_deg > 0.0 && mixing_inputs == 0
    }

    /// The length F is measured over for a move of `xyz_mm2` (the squared XYZ distance),
    /// `a_deg` and `e_mm`: mm, or degrees for a move of A alone under NIST.
    pub fn path_len(&self, xyz_mm2: f32, a_deg: f32, e_mm: f32) -> f32 {
        let a2 = a_deg * a_deg;
        match self.feed {
            RotaryFeed::Nist if xyz_mm2 > 0.0 => crate::math::sqrt(xyz_mm2),
            RotaryFeed::Nist if a2 > 0.0 => a_deg.abs(),
            RotaryFeed::Combined if xyz_mm2 + a2 > 0.0 => crate::math::sqrt(xyz_mm2 + a2),
            _ => e_mm.abs(),
        }
    }
}

/// A move's feed rate as the planner takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feed {
    /// `G94`: units of the path's length ([`Rotary::path_len`]) per second.
    PerSecond(f32),
    /// `G93`: the move takes `1 / moves_per_s` seconds (F / 60).
    InverseTime {
        /// One over the move's duration, 1/s.
        moves_per_s: f32,
    },
}

impl Feed {
    /// The speed along a path of `len`, per second.
    pub fn speed(self, len: f32) -> f32 {
        match self {
            Feed::PerSecond(v) => v,
            Feed::InverseTime { moves_per_s } => len * moves_per_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotary(feed: RotaryFeed) -> Rotary {
        Rotary { steps_per_deg: 8.888_889, feed, ..Rotary::NONE }
    }

    #[test]
    fn nist_measures_xyz_then_a_then_e() {
        let r = rotary(RotaryFeed::Nist);
        assert_eq!(r.path_len(0.04 * 0.04, 5.0, 0.03), 0.04);
        assert_eq!(r.path_len(0.0, -5.0, 0.03), 5.0);
        assert_eq!(r.path_len(0.0, 0.0, -0.8), 0.8);
    }

    #[test]
    fn combined_counts_degrees_as_millimetres() {
        let r = rotary(RotaryFeed::Combined);
        assert_eq!(r.path_len(9.0, 4.0, 1.0), 5.0);
        assert_eq!(r.path_len(0.0, 0.0, -0.8), 0.8);
    }

    #[test]
    fn inverse_time_runs_the_move_in_one_over_f_minutes() {
        // G93 F120: half a second, whatever the length.
        let f = Feed::InverseTime { moves_per_s: 120.0 / 60.0 };
        assert_eq!(f.speed(5.0), 10.0);
        assert_eq!(Feed::PerSecond(20.0).speed(5.0), 20.0);
    }

    #[test]
    fn a_mixing_hotend_takes_the_rotary_motor() {
        assert!(rotary(RotaryFeed::Nist).fitted(0));
        assert!(!rotary(RotaryFeed::Nist).fitted(2));
        assert!(!Rotary::NONE.fitted(0));
    }
}
