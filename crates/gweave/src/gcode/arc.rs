//! G2/G3 arcs: centre, sweep and length from the I/J or R form, and exact linearisation.
//!
//! An arc from P0 to P1 around centre C turns by the sweep angle `phi` (negative clockwise).
//! Its XY length is `|phi| * r`; with a helical Z (or E) change the path is a helix whose length
//! is `hypot(|phi| * r, dz)`. Linearising with chords: a chord over angle `a` deviates from the
//! circle by the sagitta `r * (1 - cos(a/2))`, so `n = ceil(|phi| / (2 acos(1 - tol/r)))` chords
//! keep every point within `tol` of the true arc.
//!
//! Firmwares differ on the arcs they refuse (`ArcRules`, from `Firmware::arcs`): a
//! refused arc does not move the machine at all, its words forgotten (the firmware answers with
//! an error and reads the next line from where the machine is).
//! - A radius too short to reach the end point (`R` under half the chord `d/2`): Marlin
//!   (`gcode/motion/G2_G3.cpp`) takes `h = 0` and turns half a circle around the chord's
//!   midpoint; RepRapFirmware (`GCodes.cpp`, `DoArcMove`) does the same up to `h^2 = -0.02 r^2`
//!   (a radius about 1 % short) and refuses past it; LinuxCNC (`interp_arc.cc`, `arc_data_r`)
//!   refuses once `d/2 - |r|` passes its length tolerance (`TOLERANCE_MM` 0.005 mm,
//!   `TOLERANCE_INCH` 0.0005 in).
//! - Klipper (`klippy/extras/gcode_arcs.py`) takes no `R` form at all, and no arc in relative
//!   coordinates (`G91`).
//! - All refuse an arc without a centre: `R` with the end point at the start, or `I` and `J` both
//!   zero or missing (Marlin's `G2/G3 bad parameters`).

use std::f64::consts::TAU;
use std::fmt;

/// How a firmware reads G2/G3 (see the module's documentation for the sources).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ArcRules {
    /// The `R` form is read.
    pub by_radius: bool,
    /// Arcs are read in relative coordinates (`G91`) too.
    pub in_relative: bool,
    /// What a radius too short to reach the end point does.
    pub short_radius: ShortRadius,
}

/// What a firmware does with an `R` shorter than half the chord.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ShortRadius {
    /// Half a circle around the chord's midpoint, however short (Marlin).
    HalfCircle,
    /// Half a circle while `h^2 = r^2 - (d/2)^2` is at least `-share * r^2`, refused past it
    /// (RepRapFirmware: 0.02).
    HalfCircleWithin { share: f64 },
    /// Refused once `d/2 - |r|` passes a length, given in the units the file is written in
    /// (LinuxCNC): millimetres, and inches under `G20`.
    RefusedPast { mm: f64, inch: f64 },
}

/// Why a firmware refuses a G2/G3 line (it then does not move).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum ArcRefusal {
    /// Neither `R` nor a non-zero `I` or `J`: no centre to turn around.
    NoCentre,
    /// An `R` arc whose end point is its start point in XY: no centre follows from a radius.
    RadiusWithoutChord,
    /// `R` shorter than half the distance to the end point, by more than the firmware allows.
    RadiusTooShort {
        /// The radius written, mm.
        radius_mm: f64,
        /// Half the distance from the start to the end point, mm.
        half_chord_mm: f64,
    },
    /// The firmware has no `R` form (Klipper).
    RadiusForm,
    /// The firmware reads arcs in absolute coordinates only (Klipper, under `G91`).
    Relative,
}

impl fmt::Display for ArcRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ArcRefusal::NoCentre => write!(f, "an arc needs R or a non-zero I or J"),
            ArcRefusal::RadiusWithoutChord => write!(f, "an R arc must end elsewhere than it starts"),
            ArcRefusal::RadiusTooShort { radius_mm, half_chord_mm } => write!(
                f,
                "R{radius_mm:.4} cannot reach an end point {:.4} mm away (half of it is {half_chord_mm:.4} mm)",
                2.0 * half_chord_mm
            ),
            ArcRefusal::RadiusForm => write!(f, "arcs are read by I and J only, not R"),
            ArcRefusal::Relative => write!(f, "arcs are read in absolute coordinates only (G90), not after G91"),
        }
    }
}

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
    pub(crate) fn from_offset(
        start: [f64; 2],
        end: [f64; 2],
        ij: [f64; 2],
        clockwise: bool,
    ) -> Result<Arc, ArcRefusal> {
        let center = [start[0] + ij[0], start[1] + ij[1]];
        let radius_mm = ij[0].hypot(ij[1]);
        if !(radius_mm.is_finite() && radius_mm > 0.0) {
            return Err(ArcRefusal::NoCentre);
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
        Ok(Arc { center, radius_mm, start_rad, sweep_rad: sweep })
    }

    /// From start and end points and a radius, as `rules` read it (`inches`: the file is in
    /// inches, for a tolerance given in the file's units); a negative radius asks for the arc
    /// longer than half a circle (RS-274 convention).
    pub(crate) fn from_radius(
        start: [f64; 2],
        end: [f64; 2],
        r: f64,
        clockwise: bool,
        (rules, inches): (ArcRules, bool),
    ) -> Result<Arc, ArcRefusal> {
        if !rules.by_radius {
            return Err(ArcRefusal::RadiusForm);
        }
        // `R0` is no radius (Marlin reads `R` only when it is not 0).
        if !(r != 0.0 && r.is_finite()) {
            return Err(ArcRefusal::NoCentre);
        }
        let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
        let chord = dx.hypot(dy);
        if !(chord > 0.0 && chord.is_finite()) {
            return Err(ArcRefusal::RadiusWithoutChord);
        }
        let half = chord / 2.0;
        // Distance from the chord's midpoint to the centre, on the side chosen by direction and
        // by the sign of R; factored as Marlin does, to round less near a half circle.
        let h2 = (r.abs() - half) * (r.abs() + half);
        let refused = match rules.short_radius {
            ShortRadius::HalfCircle => false,
            ShortRadius::HalfCircleWithin { share } => h2 < -share * r * r,
            ShortRadius::RefusedPast { mm, inch } => {
                half - r.abs() > if inches { inch * super::state::MM_PER_INCH } else { mm }
            }
        };
        if refused {
            return Err(ArcRefusal::RadiusTooShort { radius_mm: r, half_chord_mm: half });
        }
        let h = h2.max(0.0).sqrt();
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
    use crate::Firmware;

    fn marlin() -> (ArcRules, bool) {
        (Firmware::Marlin.arcs(), false)
    }

    /// Regression (an arc whose R is too short was drawn as a straight line): each firmware's
    /// reading of a radius short of half the chord, here 10 mm between the ends. Marlin turns
    /// half a circle around the midpoint however short; RepRapFirmware up to about 1 % short;
    /// LinuxCNC up to 0.005 mm (0.0005 in under G20); Klipper takes no R at all.
    #[test]
    fn a_short_radius_is_half_a_circle_or_refused_as_each_firmware_reads_it() {
        let (start, end) = ([0.0, 0.0], [10.0, 0.0]);
        let arc = |firmware: Firmware, r: f64, inches: bool| {
            Arc::from_radius(start, end, r, true, (firmware.arcs(), inches))
        };
        let half_circle = |a: Arc| {
            assert!((a.center[0] - 5.0).abs() < 1e-12 && a.center[1].abs() < 1e-12, "{a:?}");
            assert!(
                (a.radius_mm - 5.0).abs() < 1e-12 && (a.sweep_rad + std::f64::consts::PI).abs() < 1e-12,
                "{a:?}"
            );
            // Clockwise from (0, 0) to (10, 0) around (5, 0): over the top.
            assert!((a.point(0.5)[1] - 5.0).abs() < 1e-9, "{a:?}");
        };
        half_circle(arc(Firmware::Marlin, 1.0, false).unwrap());
        half_circle(arc(Firmware::Marlin, 4.99, false).unwrap());
        half_circle(arc(Firmware::RepRapFirmware, 4.96, false).unwrap());
        let short = ArcRefusal::RadiusTooShort { radius_mm: 4.9, half_chord_mm: 5.0 };
        assert_eq!(arc(Firmware::RepRapFirmware, 4.9, false), Err(short));
        half_circle(arc(Firmware::LinuxCnc, 4.996, false).unwrap());
        let short = ArcRefusal::RadiusTooShort { radius_mm: 4.994, half_chord_mm: 5.0 };
        assert_eq!(arc(Firmware::LinuxCnc, 4.994, false), Err(short));
        // 0.006 mm short is within 0.0005 in (0.0127 mm).
        half_circle(arc(Firmware::LinuxCnc, 4.994, true).unwrap());
        assert_eq!(arc(Firmware::Klipper, 5.0, false), Err(ArcRefusal::RadiusForm));
        // No centre: R with both ends the same, I and J zero.
        assert_eq!(Arc::from_radius(start, start, 5.0, true, marlin()), Err(ArcRefusal::RadiusWithoutChord));
        assert_eq!(Arc::from_radius(start, end, 0.0, true, marlin()), Err(ArcRefusal::NoCentre));
        assert_eq!(Arc::from_offset(start, end, [0.0, 0.0], true), Err(ArcRefusal::NoCentre));
    }

    #[test]
    fn quarter_circle_both_forms() {
        let a = Arc::from_offset([10.0, 0.0], [0.0, 10.0], [-10.0, 0.0], false).unwrap();
        assert!((a.sweep_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((a.xy_len_mm() - 5.0 * std::f64::consts::PI).abs() < 1e-9);
        let b = Arc::from_radius([10.0, 0.0], [0.0, 10.0], 10.0, false, marlin()).unwrap();
        assert!((b.center[0]).abs() < 1e-9 && (b.center[1]).abs() < 1e-9, "{b:?}");
        let c = Arc::from_radius([10.0, 0.0], [0.0, 10.0], -10.0, false, marlin()).unwrap();
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
