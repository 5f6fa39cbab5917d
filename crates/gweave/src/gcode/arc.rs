//! G2/G3 arcs: centre, sweep and length from the I/J or R form, and exact linearisation.
//!
//! An arc from P0 to P1 around centre C turns by the sweep angle `phi` (negative clockwise).
//! Its XY length is `|phi| * r`; with a helical Z (or E) change the path is a helix whose length
//! is `hypot(|phi| * r, dz)`. Linearising with chords: a chord over angle `a` deviates from the
//! circle by the sagitta `r * (1 - cos(a/2))`, so `n = ceil(|phi| / (2 acos(1 - tol/r)))` chords
//! keep every point within `tol` of the true arc.

use std::f64::consts::TAU;

/// An arc in the XY plane (G17), resolved to absolute millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    /// Centre in the XY plane, absolute mm.
    pub center: [f64; 2],
    /// Radius, mm.
    pub radius_mm: f64,
    /// Angle of the start point around the centre, radians.
    pub start_rad: f64,
    /// Signed sweep: positive counter-clockwise (G3), negative clockwise (G2).
    pub sweep_rad: f64,
}

impl Arc {
    /// From start and end points and the I/J centre offset (relative to the start).
    /// Equal start and end points make a full circle, as in Marlin and RepRapFirmware.
    pub(crate) fn from_offset(start: [f64; 2], end: [f64; 2], ij: [f64; 2], clockwise: bool) -> Option<Arc> {
        let center = [start[0] + ij[0], start[1] + ij[1]];
        let radius_mm = ij[0].hypot(ij[1]);
        if !(radius_mm.is_finite() && radius_mm > 0.0) {
            return None;
        }
        let start_rad = (start[1] - center[1]).atan2(start[0] - center[0]);
        let end_rad = (end[1] - center[1]).atan2(end[0] - center[0]);
        let mut sweep = end_rad - start_rad;
        let full = (start[0] - end[0]).abs() < 1e-9 && (start[1] - end[1]).abs() < 1e-9;
        if clockwise {
            if sweep >= 0.0 {
                sweep -= TAU;
            }
            if full {
                sweep = -TAU;
            }
        } else {
            if sweep <= 0.0 {
                sweep += TAU;
            }
            if full {
                sweep = TAU;
            }
        }
        Some(Arc { center, radius_mm, start_rad, sweep_rad: sweep })
    }

    /// From start and end points and a radius; a negative radius asks for the arc longer than half
    /// a circle (RS-274 convention).
    pub(crate) fn from_radius(start: [f64; 2], end: [f64; 2], r: f64, clockwise: bool) -> Option<Arc> {
        let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
        let chord = dx.hypot(dy);
        if chord.is_nan() || chord <= 0.0 || r.is_nan() || r.abs() * 2.0 < chord - 1e-9 {
            return None;
        }
        // Distance from the chord's midpoint to the centre, on the side chosen by direction and
        // by the sign of R.
        let h = (r * r - chord * chord / 4.0).max(0.0).sqrt();
        let mut side = if clockwise { 1.0 } else { -1.0 };
        if r < 0.0 {
            side = -side;
        }
        let mid = [start[0] + dx / 2.0, start[1] + dy / 2.0];
        let center = [mid[0] + side * h * dy / chord, mid[1] - side * h * dx / chord];
        Arc::from_offset(start, end, [center[0] - start[0], center[1] - start[1]], clockwise)
    }

    /// XY length of the arc, mm.
    pub fn xy_len_mm(&self) -> f64 {
        self.sweep_rad.abs() * self.radius_mm
    }

    /// The point at fraction `t` (0..=1) of the sweep.
    pub fn point(&self, t: f64) -> [f64; 2] {
        let a = self.start_rad + self.sweep_rad * t;
        [self.center[0] + self.radius_mm * a.cos(), self.center[1] + self.radius_mm * a.sin()]
    }

    /// The smallest axis-aligned box `[min, max]` holding the arc: its end points, and each
    /// point where it crosses the circle's right, top, left or bottom, if the sweep reaches it.
    pub fn bounds(&self) -> [[f64; 2]; 2] {
        let (a, b) = (self.point(0.0), self.point(1.0));
        let mut min = [a[0].min(b[0]), a[1].min(b[1])];
        let mut max = [a[0].max(b[0]), a[1].max(b[1])];
        let (from, to) = if self.sweep_rad >= 0.0 {
            (self.start_rad, self.start_rad + self.sweep_rad)
        } else {
            (self.start_rad + self.sweep_rad, self.start_rad)
        };
        let [cx, cy] = self.center;
        let r = self.radius_mm;
        for (k, [x, y]) in [[cx + r, cy], [cx, cy + r], [cx - r, cy], [cx, cy - r]].into_iter().enumerate() {
            // The first angle at or after `from` that points this way.
            let angle = k as f64 * TAU / 4.0;
            if angle + TAU * ((from - angle) / TAU).ceil() <= to {
                min = [min[0].min(x), min[1].min(y)];
                max = [max[0].max(x), max[1].max(y)];
            }
        }
        [min, max]
    }

    /// Number of chords that keep the path within `tol_mm` of the arc.
    pub fn segments(&self, tol_mm: f64) -> usize {
        let tol = tol_mm.clamp(1e-9, self.radius_mm);
        let max_angle = 2.0 * (1.0 - tol / self.radius_mm).acos();
        ((self.sweep_rad.abs() / max_angle).ceil() as usize).max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_circle_both_forms() {
        let a = Arc::from_offset([10.0, 0.0], [0.0, 10.0], [-10.0, 0.0], false).unwrap();
        assert!((a.sweep_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((a.xy_len_mm() - 5.0 * std::f64::consts::PI).abs() < 1e-9);
        let b = Arc::from_radius([10.0, 0.0], [0.0, 10.0], 10.0, false).unwrap();
        assert!((b.center[0]).abs() < 1e-9 && (b.center[1]).abs() < 1e-9, "{b:?}");
        let c = Arc::from_radius([10.0, 0.0], [0.0, 10.0], -10.0, false).unwrap();
        assert!((c.sweep_rad - 1.5 * std::f64::consts::PI).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn clockwise_full_circle() {
        let a = Arc::from_offset([5.0, 0.0], [5.0, 0.0], [-5.0, 0.0], true).unwrap();
        assert!((a.sweep_rad + TAU).abs() < 1e-12);
        let p = a.point(0.25);
        assert!((p[0]).abs() < 1e-9 && (p[1] + 5.0).abs() < 1e-9, "{p:?}");
    }

    #[test]
    fn bounds_reach_the_bulge() {
        let close = |a: [[f64; 2]; 2], b: [[f64; 2]; 2]| {
            a.iter().flatten().zip(b.iter().flatten()).all(|(x, y)| (x - y).abs() < 1e-9)
        };
        // A quarter from the right to the top: its end points are its extremes.
        let a = Arc::from_offset([10.0, 0.0], [0.0, 10.0], [-10.0, 0.0], false).unwrap();
        assert!(close(a.bounds(), [[0.0, 0.0], [10.0, 10.0]]), "{:?}", a.bounds());
        // Half a circle over the top, counter-clockwise, and the other half clockwise.
        let a = Arc::from_offset([10.0, 0.0], [-10.0, 0.0], [-10.0, 0.0], false).unwrap();
        assert!(close(a.bounds(), [[-10.0, 0.0], [10.0, 10.0]]), "{:?}", a.bounds());
        let a = Arc::from_offset([10.0, 0.0], [-10.0, 0.0], [-10.0, 0.0], true).unwrap();
        assert!(close(a.bounds(), [[-10.0, -10.0], [10.0, 0.0]]), "{:?}", a.bounds());
        // A full circle around (5, 5), and a short arc that crosses the left point only.
        let a = Arc::from_offset([5.0, 0.0], [5.0, 0.0], [0.0, 5.0], true).unwrap();
        assert!(close(a.bounds(), [[0.0, 0.0], [10.0, 10.0]]), "{:?}", a.bounds());
        let (s, c) = (0.1f64.sin(), 0.1f64.cos());
        let a = Arc::from_offset([-c, s], [-c, -s], [c, -s], false).unwrap();
        assert!(close(a.bounds(), [[-1.0, -s], [-c, s]]), "{:?}", a.bounds());
    }

    #[test]
    fn segments_respect_tolerance() {
        let a = Arc::from_offset([10.0, 0.0], [-10.0, 0.0], [-10.0, 0.0], false).unwrap();
        let n = a.segments(0.01);
        let half = a.sweep_rad.abs() / n as f64 / 2.0;
        assert!(10.0 * (1.0 - half.cos()) <= 0.01);
        let fewer = a.sweep_rad.abs() / (n - 1) as f64 / 2.0;
        assert!(10.0 * (1.0 - fewer.cos()) > 0.01);
    }
}
