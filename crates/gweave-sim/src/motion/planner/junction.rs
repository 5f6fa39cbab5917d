//! Speed limits at the junction of two moves.
//!
//! Junction deviation (Sonny Jeon, "Improving Grbl: Cornering Algorithm",
//! onehossshay.wordpress.com 2011-09-24; `gnea/grbl:grbl/planner.c`): place a circle of radius `R`
//! tangent to both moves such that its closest point lies `d` (the junction deviation) from the
//! corner. With `theta` the angle at the corner between the two segments (180 degrees straight
//! on, 90 for a square corner, 0 for a full reversal),
//! `R = d sin(theta/2) / (1 - sin(theta/2))`, and the centripetal acceleration `v^2 / R` must not
//! exceed `a`, so
//!
//! ```text
//!   v^2 = a * d * sin(theta/2) / (1 - sin(theta/2))
//! ```
//!
//! The half-angle functions come from the dot product of the unit directions without any trig:
//! with `c = -u_prev . u_next = cos(theta)` (the incoming direction reversed against the outgoing
//! one), `sin(theta/2) = sqrt((1 - c) / 2)` and `cos(theta/2) = sqrt((1 + c) / 2)`.
//!
//! Klipper (`Klipper3d/klipper:klippy/toolhead.py`, `Move.calc_junction`) adds that the circle may
//! touch each move no further than its midpoint: `v^2 <= a * (len / 2) * tan(theta/2)`, written as
//! `delta_v2 * tan(theta/2) / 4` with `delta_v2 = 2 a len`. Its extruder
//! (`kinematics/extruder.py`) allows an instant change of E speed of at most
//! `instantaneous_corner_velocity`: with `r` the E mm per mm of path, `v <= icv / |r1 - r0|`.

/// The sine and cosine of half the corner angle `theta` (180 degrees = straight on).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct HalfAngle {
    /// `sin(theta/2)`: 1 straight on, 0 for a full reversal.
    pub sin: f64,
    /// `cos(theta/2)`: 0 straight on, 1 for a full reversal.
    pub cos: f64,
}

impl HalfAngle {
    /// From `c`, the negated dot product of the previous and the next unit direction.
    pub(super) fn from_neg_cos(c: f64) -> Self {
        Self { sin: (0.5 * (1.0 - c)).max(0.0).sqrt(), cos: (0.5 * (1.0 + c)).max(0.0).sqrt() }
    }

    /// The junction-deviation limit `a d sin/(1 - sin)`; `None` straight on (`sin = 1`,
    /// `cos = 0`), where the circle's radius is infinite and nothing limits the speed.
    pub(super) fn deviation_v2(&self, accel: f64, deviation_mm: f64) -> Option<f64> {
        let one_minus_sin = 1.0 - self.sin;
        (one_minus_sin > 0.0 && self.cos > 0.0).then(|| self.sin / one_minus_sin * deviation_mm * accel)
    }

    /// Klipper's mid-move contact limit for a move with `delta_v2 = 2 a len`.
    pub(super) fn centripetal_v2(&self, delta_v2: f64) -> f64 {
        delta_v2 * 0.25 * self.sin / self.cos
    }
}

/// Klipper's extruder junction limit: the squared path speed at which the step in E speed,
/// `v * |ratio_next - ratio_prev|`, equals `instantaneous_corner_velocity`; `None` when the
/// ratio does not change.
pub(super) fn extruder_v2(icv_mm_s: f64, ratio_prev: f64, ratio_next: f64) -> Option<f64> {
    let diff = ratio_next - ratio_prev;
    (diff != 0.0).then(|| (icv_mm_s / diff.abs()).powi(2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_corner_of_klipper_gives_scv() {
        // Klipper picks d = scv^2 (sqrt 2 - 1) / a so a 90 degree corner yields scv exactly.
        let h = HalfAngle::from_neg_cos(0.0);
        let a = 3000.0;
        let d = 25.0 * (2f64.sqrt() - 1.0) / a;
        assert!((h.deviation_v2(a, d).unwrap() - 25.0).abs() < 1e-9);
    }

    #[test]
    fn marlin_square_corner_hand_computed() {
        // sin 45 = 0.70711: v^2 = 3000 * 0.013 * 0.70711 / 0.29289 = 94.155, v = 9.703 mm/s.
        let v = HalfAngle::from_neg_cos(0.0).deviation_v2(3000.0, 0.013).unwrap().sqrt();
        assert!((v - 9.7033).abs() < 1e-4, "{v}");
    }

    #[test]
    fn straight_is_unlimited_and_reversal_stops() {
        assert_eq!(HalfAngle::from_neg_cos(-1.0).deviation_v2(3000.0, 0.013), None);
        assert_eq!(HalfAngle::from_neg_cos(1.0).deviation_v2(3000.0, 0.013), Some(0.0));
    }

    #[test]
    fn extruder_limit() {
        assert_eq!(extruder_v2(1.0, 0.05, 0.05), None);
        assert!((extruder_v2(1.0, 0.0, 0.04).unwrap() - 625.0).abs() < 1e-9);
    }
}
