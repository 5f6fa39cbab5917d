//! What a line did to the machine: the move it commanded (a line or an arc, in absolute
//! logical millimetres) or another effect (a tool change, a firmware retraction, a dwell).

use super::arc::{Arc, ArcRefusal};
use super::axes::{Position, E, X, Y, Z};

/// The motion mode that axis words on a line without a command continue.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Motion {
    /// `G0`: a rapid move.
    Rapid,
    /// `G1`: a linear move at the feed rate.
    #[default]
    Linear,
    /// `G2`: a clockwise arc.
    ArcCw,
    /// `G3`: a counter-clockwise arc.
    ArcCcw,
}

/// The geometry of one move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Path {
    /// A straight line.
    Line,
    /// An arc (`G2`/`G3`).
    Arc(Arc),
}

/// A move the line commanded, in absolute logical millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// Where the move starts.
    pub from: Position,
    /// Where the move ends.
    pub to: Position,
    /// The path between them.
    pub path: Path,
    /// `G0`: a rapid (slicers use it for travel).
    pub rapid: bool,
    /// The feed rate, mm/min.
    pub feed_mm_min: f64,
}

impl Move {
    /// Filament fed by this move, mm (negative for a retraction).
    #[inline]
    pub fn e_mm(&self) -> f64 {
        self.to[E] - self.from[E]
    }

    /// The lowest and highest value the move reaches in X, Y and Z, `[lo, hi]` each: its end,
    /// or in X and Y an arc's box ([`Arc::bounds`]), which reaches past its end points (a full
    /// circle ends where it starts). What a bed check holds against the bed.
    pub fn reach(&self) -> [[f64; 2]; 3] {
        let end = |axis: usize| [self.to[axis], self.to[axis]];
        match &self.path {
            Path::Line => [end(X), end(Y), end(Z)],
            Path::Arc(arc) => {
                let [min, max] = arc.bounds();
                [[min[0], max[0]], [min[1], max[1]], end(Z)]
            }
        }
    }

    /// XY length, following the arc for G2/G3.
    pub fn xy_len_mm(&self) -> f64 {
        match &self.path {
            Path::Line => {
                let (dx, dy) = (self.to[X] - self.from[X], self.to[Y] - self.from[Y]);
                (dx * dx + dy * dy).sqrt()
            }
            Path::Arc(arc) => arc.xy_len_mm(),
        }
    }

    /// Tool-path length in XYZ, mm (a helix for an arc with Z change).
    pub fn len_mm(&self) -> f64 {
        // sqrt of squares rather than hypot: no overflow is possible at printer scales, and it
        // is several times faster on the hot path.
        let dz = self.to[Z] - self.from[Z];
        let xy2 = match &self.path {
            Path::Line => {
                let (dx, dy) = (self.to[X] - self.from[X], self.to[Y] - self.from[Y]);
                dx * dx + dy * dy
            }
            Path::Arc(arc) => arc.xy_len_mm().powi(2),
        };
        (xy2 + dz * dz).sqrt()
    }

    /// Deposits material while moving in XY: a printing move, not travel or retraction.
    #[inline]
    pub fn is_extruding(&self) -> bool {
        self.e_mm() > 0.0
            && (self.to[X] != self.from[X] || self.to[Y] != self.from[Y] || matches!(self.path, Path::Arc(_)))
    }
}

/// What a line did to the machine.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Effect {
    /// Nothing that moves or changes modes we track.
    #[default]
    None,
    /// A move (`G0`-`G3`).
    Move(Move),
    /// `G28`: the axes homed (bit i = axis i).
    Home {
        /// Bit i: axis i homed.
        axes: u8,
    },
    /// `G92`: the logical position was set.
    SetPosition,
    /// `T<n>`.
    ToolChange {
        /// The tool before the change.
        from: u32,
        /// The tool after it.
        to: u32,
    },
    /// `G10` firmware retraction or `G11` recover: filament moved, mm (negative = retract).
    FirmwareRetract {
        /// Filament moved, mm (negative = retract).
        e_mm: f64,
    },
    /// `G4` dwell.
    Dwell {
        /// Dwell time, s.
        t_s: f64,
    },
    /// A `G2`/`G3` the firmware refuses: the machine does not move.
    ArcRefused(ArcRefusal),
}

impl Effect {
    /// Filament this line fed, mm (negative for a retraction): a move's E or a firmware retract.
    #[inline]
    pub fn filament_mm(&self) -> f64 {
        match self {
            Effect::Move(m) => m.e_mm(),
            Effect::FirmwareRetract { e_mm } => *e_mm,
            _ => 0.0,
        }
    }
}
