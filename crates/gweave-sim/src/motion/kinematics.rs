//! Cartesian kinematics: positions, requested moves, and the geometry the planner works on.
//!
//! A move's length is the Euclidean XYZ distance. A move without XYZ travel is measured along
//! its rotary axis A (degrees, the feed is then in deg/s) or, without A travel either, along E
//! (an extrude-only move: retract, unretract, prime). This is Klipper's rule for extrude-only
//! moves (`Klipper3d/klipper:klippy/toolhead.py`, moves shorter than 1e-9 mm count as
//! extrude-only) and Marlin's for rotary axes (`Marlin/src/module/planner.cpp`, `millimeters`).

use thiserror::Error;

/// Below this XYZ distance a move is not a kinematic move (Klipper's threshold, mm).
pub(crate) const MIN_KINEMATIC_LEN_MM: f64 = 1e-9;

/// A machine position: X Y Z E in mm, the rotary axis A in degrees.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pos {
    /// X, mm.
    pub x_mm: f64,
    /// Y, mm.
    pub y_mm: f64,
    /// Z, mm.
    pub z_mm: f64,
    /// E (filament), mm.
    pub e_mm: f64,
    /// Rotary axis A, degrees.
    pub a_deg: f64,
}

impl Pos {
    /// A position from X Y Z E, with A at 0.
    pub fn xyze(x_mm: f64, y_mm: f64, z_mm: f64, e_mm: f64) -> Self {
        Self { x_mm, y_mm, z_mm, e_mm, a_deg: 0.0 }
    }

    /// The coordinates in the order X Y Z E A.
    pub fn to_array(self) -> [f64; 5] {
        [self.x_mm, self.y_mm, self.z_mm, self.e_mm, self.a_deg]
    }

    /// The position of coordinates in the order X Y Z E A.
    pub(crate) fn from_array([x_mm, y_mm, z_mm, e_mm, a_deg]: [f64; 5]) -> Self {
        Self { x_mm, y_mm, z_mm, e_mm, a_deg }
    }
}

/// Index of each axis in [`Pos::to_array`] and [`Geometry::delta`].
pub(crate) mod axis {
    /// X.
    pub(crate) const X: usize = 0;
    /// Y.
    pub(crate) const Y: usize = 1;
    /// Z.
    pub(crate) const Z: usize = 2;
    /// E.
    pub(crate) const E: usize = 3;
    /// A (rotary).
    pub(crate) const A: usize = 4;
}

/// One requested straight move, as the G-code asked for it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// Where the move starts.
    pub start: Pos,
    /// Where the move ends.
    pub end: Pos,
    /// The requested speed along the move (F / 60), mm/s (deg/s for A-only moves).
    pub feed_mm_s: f64,
    /// A caller's label carried to the planned block, e.g. layer and feature for attribution.
    pub tag: u64,
}

/// A move that cannot be planned.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum MoveError {
    /// A coordinate is NaN or infinite (or the distance between two is past the largest
    /// number).
    #[error("move has a non-finite coordinate")]
    NonFinitePosition,
    /// The feed rate is zero, negative or not finite.
    #[error("feed rate must be positive and finite, got {0} mm/s")]
    BadFeed(f64),
}

/// What a move drives, which decides its length and its limits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveKind {
    /// XYZ travel (E and A ride along).
    Kinematic,
    /// No XYZ travel; measured along A.
    RotaryOnly,
    /// Neither XYZ nor A travel; measured along E.
    ExtrudeOnly,
}

/// The geometry of a move: per-axis deltas, the length the speeds refer to, and the ratio of
/// each axis' travel to that length (the axis speed is `ratio * speed`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// End minus start, X Y Z E A.
    pub delta: [f64; 5],
    /// The length the feed rate and accelerations refer to, mm (deg for A-only moves).
    pub len: f64,
    /// `delta / len` per axis (0 for a zero-length move).
    pub ratio: [f64; 5],
    /// What the move drives.
    pub kind: MoveKind,
}

impl Geometry {
    /// The geometry of a move from `start` to `end`.
    pub fn between(start: Pos, end: Pos) -> Self {
        Self::of_delta(deltas(start, end))
    }

    /// The geometry of a move by `delta` (end minus start, X Y Z E A).
    #[inline]
    fn of_delta(delta: [f64; 5]) -> Self {
        let (len, kind) = extent(&delta);
        Self::with_extent(delta, len, kind)
    }

    /// [`Geometry::of_delta`] with the move's [`extent`] known already.
    #[inline]
    pub(crate) fn with_extent(delta: [f64; 5], len: f64, kind: MoveKind) -> Self {
        let mut delta = delta;
        if kind != MoveKind::Kinematic {
            // Sub-nanometre XYZ wobble of a non-kinematic move is dropped, as Klipper does.
            delta[..3].fill(0.0);
        }
        let inv = if len > 0.0 { 1.0 / len } else { 0.0 };
        let ratio = delta.map(|d| d * inv);
        Self { delta, len, ratio, kind }
    }
}

/// The length a move's speeds refer to and what it drives, from its `delta` (end minus start, X Y
/// Z E A): the XYZ length, else the A travel, else the E travel. All a planner that works in
/// its own units (Marlin's steps) needs of a move's geometry, without the division and the
/// ratios of [`Geometry`].
#[inline]
pub(crate) fn extent(delta: &[f64; 5]) -> (f64, MoveKind) {
    let xyz = (delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2]).sqrt();
    if xyz >= MIN_KINEMATIC_LEN_MM {
        (xyz, MoveKind::Kinematic)
    } else if delta[axis::A] != 0.0 {
        (delta[axis::A].abs(), MoveKind::RotaryOnly)
    } else {
        (delta[axis::E].abs(), MoveKind::ExtrudeOnly)
    }
}

impl Move {
    /// Check the move's numbers and compute its geometry.
    #[inline]
    pub fn geometry(&self) -> Result<Geometry, MoveError> {
        self.checked_delta().map(Geometry::of_delta)
    }

    /// The move's `delta` (end minus start, X Y Z E A), once its numbers are checked.
    #[inline]
    pub(crate) fn checked_delta(&self) -> Result<[f64; 5], MoveError> {
        // A difference is finite exactly when both ends are (inf - inf is NaN): one test per
        // axis instead of two. And `d * 0` is zero for a finite `d`, NaN otherwise, so the sum
        // of those is zero exactly when every axis is finite: a multiply and an add per axis
        // (`is_finite` on each is some eight integer instructions, a sixth of the Marlin
        // planner's own bookkeeping per move).
        let delta = deltas(self.start, self.end);
        if delta.iter().fold(0.0, |sum, d| sum + d * 0.0) != 0.0 {
            return Err(MoveError::NonFinitePosition);
        }
        // NaN fails both comparisons.
        if !(self.feed_mm_s > 0.0 && self.feed_mm_s < f64::INFINITY) {
            return Err(MoveError::BadFeed(self.feed_mm_s));
        }
        Ok(delta)
    }
}

/// End minus start, X Y Z E A.
#[inline]
pub(crate) fn deltas(start: Pos, end: Pos) -> [f64; 5] {
    let (s, e) = (start.to_array(), end.to_array());
    std::array::from_fn(|i| e[i] - s[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinematic_length_ignores_e_and_a() {
        let g = Geometry::between(
            Pos::xyze(0.0, 0.0, 0.0, 0.0),
            Pos { a_deg: 9.0, ..Pos::xyze(3.0, 4.0, 0.0, 1.0) },
        );
        assert_eq!(g.kind, MoveKind::Kinematic);
        assert_eq!(g.len, 5.0);
        let want = [0.6, 0.8, 0.0, 0.2, 1.8];
        assert!(g.ratio.iter().zip(want).all(|(r, w)| (r - w).abs() < 1e-15), "{:?}", g.ratio);
    }

    #[test]
    fn extrude_only_and_rotary_only_lengths() {
        let g = Geometry::between(Pos::xyze(1.0, 1.0, 1.0, 5.0), Pos::xyze(1.0, 1.0, 1.0 + 1e-12, 3.0));
        assert_eq!(g.kind, MoveKind::ExtrudeOnly);
        assert_eq!((g.len, g.delta[2], g.ratio[3]), (2.0, 0.0, -1.0));
        let g = Geometry::between(Pos::default(), Pos { a_deg: -90.0, e_mm: 2.0, ..Pos::default() });
        assert_eq!(g.kind, MoveKind::RotaryOnly);
        assert_eq!((g.len, g.ratio[4], g.ratio[3]), (90.0, -1.0, 2.0 / 90.0));
    }

    #[test]
    fn bad_moves_are_errors() {
        let m =
            Move { start: Pos::default(), end: Pos::xyze(f64::NAN, 0.0, 0.0, 0.0), feed_mm_s: 1.0, tag: 0 };
        assert_eq!(m.geometry(), Err(MoveError::NonFinitePosition));
        // Infinite at both ends, at one end, and finite ends too far apart to measure.
        for (from, to) in [(f64::INFINITY, f64::INFINITY), (f64::NEG_INFINITY, 1.0), (-f64::MAX, f64::MAX)] {
            let m = Move {
                start: Pos { a_deg: from, ..Pos::default() },
                end: Pos { a_deg: to, ..Pos::default() },
                ..m
            };
            assert_eq!(m.geometry(), Err(MoveError::NonFinitePosition), "{from} -> {to}");
        }
        let m = Move { end: Pos::xyze(1.0, 0.0, 0.0, 0.0), feed_mm_s: 0.0, ..m };
        assert_eq!(m.geometry(), Err(MoveError::BadFeed(0.0)));
    }
}
