//! A rotary program's feed convention: what F means on a move that turns the rotary axis.
//!
//! The firmware models here read F as Marlin does: the speed along X, Y and Z, or along A
//! (deg/min) when no XYZ motor takes `MIN_STEPS_PER_SEGMENT` steps (Klipper's model: when there
//! is no XYZ travel at all). A rotary program says in its header how its F words were written
//! (`; axes: axial X, rotary A (Degrees), radial Z (0 = on the mandrel); feed Nist`, see
//! `gweave::rotary::cylinder::RotaryConfig::header_lines`): NIST (LinuxCNC's reading, and
//! `gweave rotary`'s default) measures F over the axial and radial travel and rotary-only moves
//! in rotary units per minute; `combined` over all three. A helix segment of a NIST tube
//! advances 0.04 mm along X (3 steps at 80 steps/mm) while the mandrel turns 5°: Marlin's rule
//! measures it along A at the axial feed, and a 3-minute tube took 5 h 23 min
//! (`gweave_sim_reads_the_feed_convention_the_rotary_file_declares`). So the time of a move is
//! the one its declared convention gives (`RotaryConfig::time_from_feed`, the inverse of what
//! the writer computed), and its F is rewritten so that the model's own rule takes that time.
//! The estimator's parse side does the rewriting, right after the modal state made the move,
//! so that `gweave estimate` and the virtual printer (whose motion core it is) read a rotary
//! program alike: `gweave estimate` did not, and took 90 h 44 min over an 8-minute tube
//! (`gweave_estimate_reads_the_rotary_feed_convention_as_gweave_sim_does`).
//!
//! Inverse time: between a `G93` and a `G94` each move takes `1 / F` minutes, whatever the
//! header declares (`rotary --feed-convention inverse-time` writes `G93` at the start and `G94`
//! at the end; the gweave firmware's rotary image reads it the same way). A file that declares
//! inverse time but moves outside `G93` keeps the model's reading there.

use gweave::gcode::axes::{A, E, X, Y, Z};
use gweave::gcode::effect::{Move, Path};
use gweave::rotary::cylinder::{FeedConvention, MachineDelta, RotaryConfig, RotaryUnit};

use crate::motion::limits::StepsPerUnit;

/// Marlin's `MIN_STEPS_PER_SEGMENT`: below it on every XYZ motor, a move is measured along A
/// (or E).
const MIN_STEPS_PER_SEGMENT: f64 = 6.0;

/// The convention a rotary program declared, and where its axes are in a position.
#[derive(Debug, Clone)]
pub(super) struct DeclaredFeed {
    machine: RotaryConfig,
    /// Between `G93` and `G94`: F is one over the move's minutes.
    pub(super) inverse_time: bool,
    /// Position indices of the axial, rotary and radial words.
    axes: [usize; 3],
}

impl DeclaredFeed {
    /// The declared convention of `machine`, if the simulator can honour it: the rotary axis A
    /// in degrees (the simulator's only rotary axis).
    pub(super) fn new(machine: RotaryConfig) -> Option<DeclaredFeed> {
        let index = |letter: char| match letter {
            'X' => Some(X),
            'Y' => Some(Y),
            'Z' => Some(Z),
            'A' => Some(A),
            _ => None,
        };
        let axes = [index(machine.axial_axis)?, index(machine.rotary_axis)?, index(machine.radial_axis)?];
        let honoured = machine.rotary_unit == RotaryUnit::Degrees && axes[1] == A;
        honoured.then_some(DeclaredFeed { machine, inverse_time: false, axes })
    }

    /// Rewrites the F of `m` to [`Self::model_feed_mm_min`]'s, if it has one. Cold: only a
    /// rotary program's moves come here.
    #[cold]
    #[inline(never)]
    pub(super) fn rewrite_feed(&self, m: &mut Move, steps: &StepsPerUnit, marlin: bool) {
        if let Some(feed) = self.model_feed_mm_min(m, steps, marlin) {
            m.feed_mm_min = feed;
        }
    }

    /// The F (mm/min) that makes the model take the time the declared convention gives a
    /// straight move, or `None` to keep the move's own (an arc, a move of nothing).
    pub(super) fn model_feed_mm_min(&self, m: &Move, steps: &StepsPerUnit, marlin: bool) -> Option<f64> {
        if !matches!(m.path, Path::Line) {
            return None;
        }
        let d = |i: usize| m.to[i] - m.from[i];
        let delta = MachineDelta {
            axial_mm: d(self.axes[0]),
            rotary: d(self.axes[1]),
            radial_mm: d(self.axes[2]),
            e_mm: d(E),
        };
        let t_s = if self.inverse_time {
            (m.feed_mm_min > 0.0).then(|| 60.0 / m.feed_mm_min)?
        } else if self.machine.feed_convention == FeedConvention::InverseTime {
            return None;
        } else {
            self.machine.time_from_feed(&delta, m.feed_mm_min)?
        };
        let len = model_len(m, steps, marlin);
        (len > 0.0).then(|| 60.0 * len / t_s)
    }
}

/// The length the firmware model measures F over: XYZ, else A, else E. Marlin's planner takes
/// XYZ only when an XYZ motor takes at least `MIN_STEPS_PER_SEGMENT` steps; Klipper's whenever
/// there is XYZ travel.
fn model_len(m: &Move, steps: &StepsPerUnit, marlin: bool) -> f64 {
    let steps_of =
        |i: usize, per_unit: f64| ((m.to[i] * per_unit).round() - (m.from[i] * per_unit).round()).abs();
    let xyz = m.len_mm();
    let xyz_counts = if marlin {
        [(X, steps.x), (Y, steps.y), (Z, steps.z)]
            .iter()
            .any(|&(i, s)| steps_of(i, s) >= MIN_STEPS_PER_SEGMENT)
    } else {
        xyz > 0.0
    };
    let da = m.to[A] - m.from[A];
    if xyz_counts {
        xyz
    } else if da != 0.0 {
        da.abs()
    } else {
        m.e_mm().abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn helix_step(feed_mm_min: f64) -> Move {
        let mut from = [0.0; gweave::gcode::axes::AXES];
        let mut to = from;
        from[X] = 0.200;
        to[X] = 0.242;
        to[A] = 5.1;
        from[E] = 1.0;
        to[E] = 1.03;
        Move { from, to, path: Path::Line, rapid: false, feed_mm_min }
    }

    #[test]
    fn a_nist_helix_step_takes_its_axial_time() {
        // 0.042 mm of X at F56 is 45 ms; on Marlin's rule (3 X steps: measured along A) the F
        // that gives 45 ms is 5.1 degrees in 45 ms.
        let declared = DeclaredFeed::new(RotaryConfig::new(20.0)).unwrap();
        let steps = StepsPerUnit { x: 80.0, ..StepsPerUnit::default() };
        let f = declared.model_feed_mm_min(&helix_step(56.0), &steps, true).unwrap();
        let t_s = 0.042 / (56.0 / 60.0);
        assert!((f - 60.0 * 5.1 / t_s).abs() < 1e-6, "F{f}");
        // Klipper's rule measures the XYZ travel: F stays the axial feed.
        let f = declared.model_feed_mm_min(&helix_step(56.0), &steps, false).unwrap();
        assert!((f - 56.0).abs() < 1e-9, "F{f}");
    }

    #[test]
    fn a_combined_feed_is_over_every_axis() {
        let mut machine = RotaryConfig::new(20.0);
        machine.feed_convention = FeedConvention::Combined;
        let declared = DeclaredFeed::new(machine).unwrap();
        let steps = StepsPerUnit { x: 80.0, ..StepsPerUnit::default() };
        let f = declared.model_feed_mm_min(&helix_step(6800.0), &steps, true).unwrap();
        let t_s = 60.0 * (0.042f64.powi(2) + 5.1f64.powi(2)).sqrt() / 6800.0;
        assert!((f - 60.0 * 5.1 / t_s).abs() < 1e-6, "F{f}");
    }

    #[test]
    fn between_g93_and_g94_a_move_takes_one_over_f_minutes() {
        // G93 F600: 0.1 s; measured along A by Marlin's rule (3 X steps), 5.1 degrees in it.
        let mut machine = RotaryConfig::new(20.0);
        machine.feed_convention = FeedConvention::InverseTime;
        let mut declared = DeclaredFeed::new(machine).unwrap();
        let steps = StepsPerUnit { x: 80.0, ..StepsPerUnit::default() };
        assert_eq!(declared.model_feed_mm_min(&helix_step(600.0), &steps, true), None, "G94: the model's");
        declared.inverse_time = true;
        let f = declared.model_feed_mm_min(&helix_step(600.0), &steps, true).unwrap();
        assert!((f - 60.0 * 5.1 / 0.1).abs() < 1e-6, "F{f}");
    }

    #[test]
    fn a_rotary_axis_in_mm_is_left_to_the_model() {
        let mut machine = RotaryConfig::new(20.0);
        machine.rotary_axis = 'Y';
        machine.rotary_unit = RotaryUnit::Mm;
        assert!(DeclaredFeed::new(machine).is_none());
    }
}
