//! A Marlin/GRBL style planner (`gnea/grbl:grbl/planner.c`, `MarlinFirmware/Marlin:
//! Marlin/src/module/planner.cpp`).
//!
//! Each block gets a nominal speed (the requested feed, scaled down until no axis exceeds its
//! M203 maximum), an acceleration (M204 P for printing moves, R for extrude-only, T for travel,
//! scaled down until no axis exceeds its M201 maximum) and a maximum entry speed from the
//! junction with the previous block. Marlin's junction uses the direction over all axes
//! (X Y Z E A normalised together), limits the junction acceleration by each axis' maximum
//! along the change of direction, and for blocks shorter than 1 mm also caps the speed at
//! `v^2 = a * len / phi` with `phi` the turning angle, the centripetal limit of a polygonal arc.
//!
//! The buffer holds `lookahead_blocks` blocks. After each new block a reverse pass (from a stop
//! at the end of the buffer) and a forward pass (from the first block's fixed entry) set every
//! entry speed: `entry_v2 <= exit_v2 + 2 a len` backwards, `<= entry_v2_prev + 2 a len_prev`
//! forwards. When the buffer is full, the oldest block leaves with its speeds final, as in the
//! firmware where the stepper takes the oldest block while the host keeps the buffer full.

use std::collections::VecDeque;

use super::junction::HalfAngle;
use super::trapezoid::{peak_v2, Trapezoid};
use super::{BlockSink, PlannedBlock};
use crate::kinematics::{axis, Geometry, Move, MoveKind};
use crate::limits::MotionProfile;

/// Marlin treats `-u_prev . u > 0.999999` as a full reversal (stop at the junction).
const REVERSAL_NEG_COS: f64 = 0.999_999;

#[derive(Debug, Clone)]
struct Block {
    mv: Move,
    geo: Geometry,
    accel: f64,
    nominal_v2: f64,
    max_entry_v2: f64,
    /// The entry allowed by the reverse pass alone (braking for everything after it).
    reverse_v2: f64,
    entry_v2: f64,
}

/// The previous block's direction and nominal speed, kept after it leaves the buffer.
#[derive(Debug, Clone, Copy)]
struct Previous {
    unit: [f64; 5],
    nominal_v2: f64,
}

/// The Marlin planner buffer.
#[derive(Debug, Clone, Default)]
pub(crate) struct MarlinBuffer {
    blocks: VecDeque<Block>,
    /// True when the first block follows one already emitted, so its entry speed is final.
    head_entry_fixed: bool,
    prev: Option<Previous>,
}

impl MarlinBuffer {
    pub(crate) fn queued(&self) -> usize {
        self.blocks.len()
    }

    pub(crate) fn push(
        &mut self,
        mv: &Move,
        geo: Geometry,
        profile: &MotionProfile,
        junction_deviation_mm: f64,
        capacity: usize,
        sink: &mut dyn BlockSink,
    ) {
        let max_feed = profile.max_feed_mm_s.to_array();
        let max_accel = profile.max_accel_mm_s2.to_array();
        let base_accel = match geo.kind {
            MoveKind::ExtrudeOnly => profile.accel.retract_mm_s2,
            _ if geo.delta[axis::E] != 0.0 => profile.accel.print_mm_s2,
            _ => profile.accel.travel_mm_s2,
        };
        let nominal_v = axis_limited(mv.feed_mm_s, &geo.ratio, &max_feed);
        let accel = axis_limited(base_accel, &geo.ratio, &max_accel);
        let nominal_v2 = nominal_v * nominal_v;
        let norm = geo.delta.iter().map(|d| d * d).sum::<f64>().sqrt();
        let unit = geo.delta.map(|d| d / norm);
        let max_entry_v2 = match self.prev {
            Some(prev) => {
                let v2 = junction_v2(&prev.unit, &unit, accel, &max_accel, junction_deviation_mm, geo.len);
                v2.min(nominal_v2).min(prev.nominal_v2)
            }
            None => 0.0,
        };
        self.prev = Some(Previous { unit, nominal_v2 });
        self.blocks.push_back(Block {
            mv: *mv,
            geo,
            accel,
            nominal_v2,
            max_entry_v2,
            reverse_v2: -1.0,
            entry_v2: 0.0,
        });
        self.replan();
        while self.blocks.len() > capacity {
            self.emit_front(sink);
        }
    }

    /// Plan the rest of the buffer to a stop and emit it.
    pub(crate) fn flush(&mut self, sink: &mut dyn BlockSink) {
        while !self.blocks.is_empty() {
            self.emit_front(sink);
        }
        self.head_entry_fixed = false;
        self.prev = None;
    }

    /// The reverse and forward passes over the buffer. The reverse pass stops at the first
    /// block whose reverse limit did not change (nothing before it can change either, GRBL's
    /// "planned" pointer idea), and the forward pass starts there.
    fn replan(&mut self) {
        let fixed = usize::from(self.head_entry_fixed);
        let n = self.blocks.len();
        let mut first_changed = fixed;
        let mut exit_v2 = 0.0;
        for i in (fixed..n).rev() {
            let b = &mut self.blocks[i];
            let reverse_v2 = b.max_entry_v2.min(exit_v2 + 2.0 * b.accel * b.geo.len);
            if reverse_v2 == b.reverse_v2 {
                first_changed = i;
                break;
            }
            b.reverse_v2 = reverse_v2;
            exit_v2 = reverse_v2;
        }
        let mut reach_v2 = match first_changed.checked_sub(1).and_then(|i| self.blocks.get(i)) {
            Some(prev) => prev.entry_v2 + 2.0 * prev.accel * prev.geo.len,
            None => f64::INFINITY,
        };
        for b in self.blocks.iter_mut().skip(first_changed) {
            b.entry_v2 = b.reverse_v2.min(reach_v2);
            reach_v2 = b.entry_v2 + 2.0 * b.accel * b.geo.len;
        }
    }

    fn emit_front(&mut self, sink: &mut dyn BlockSink) {
        let Some(b) = self.blocks.pop_front() else {
            return;
        };
        let exit_v2 = self.blocks.front().map_or(0.0, |next| next.entry_v2);
        let cruise_v2 = b.nominal_v2.min(peak_v2(b.geo.len, b.accel, b.entry_v2, exit_v2));
        let trapezoid = Trapezoid::from_v2(b.geo.len, b.accel, b.entry_v2, cruise_v2, exit_v2);
        sink.block(&PlannedBlock::new(&b.mv, &b.geo, b.accel, trapezoid));
        self.head_entry_fixed = !self.blocks.is_empty();
    }
}

/// Scale `value` (a speed or an acceleration along the path) down until no axis, moving at
/// `ratio[i] * value`, exceeds its own limit.
fn axis_limited(value: f64, ratio: &[f64; 5], limit: &[f64; 5]) -> f64 {
    ratio.iter().zip(limit).filter(|(r, _)| **r != 0.0).fold(value, |v, (r, l)| v.min(l / r.abs()))
}

/// Marlin's junction speed limit between unit directions `prev` and `next`.
fn junction_v2(
    prev: &[f64; 5],
    next: &[f64; 5],
    accel: f64,
    max_accel: &[f64; 5],
    deviation_mm: f64,
    len: f64,
) -> f64 {
    let dot: f64 = prev.iter().zip(next).map(|(a, b)| a * b).sum();
    let neg_cos = -dot;
    if neg_cos > REVERSAL_NEG_COS {
        return 0.0;
    }
    let neg_cos = neg_cos.max(-REVERSAL_NEG_COS);
    // The acceleration available along the change of direction, per-axis limited.
    let change = std::array::from_fn::<f64, 5, _>(|i| next[i] - prev[i]);
    let change_len = change.iter().map(|c| c * c).sum::<f64>().sqrt();
    let junction_accel = if change_len > 0.0 {
        axis_limited(accel, &change.map(|c| c / change_len), max_accel)
    } else {
        accel
    };
    let half = HalfAngle::from_neg_cos(neg_cos);
    let mut v2 = half.deviation_v2(junction_accel, deviation_mm).unwrap_or(f64::INFINITY);
    if len < 1.0 {
        // Short segments approximate arcs: turning by phi over len is a circle of radius
        // len / phi, whose centripetal limit is v^2 = a len / phi.
        let phi = dot.clamp(-1.0, 1.0).acos();
        v2 = v2.min(len * junction_accel / phi);
    }
    v2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Pos;
    use proptest::prelude::*;

    proptest! {
        /// The early-stopping replan gives the same entry speeds as replanning everything.
        #[test]
        fn early_stop_equals_full_replan(
            steps in proptest::collection::vec((-5.0..5.0f64, -5.0..5.0f64, 5.0..200.0f64), 1..200),
            capacity in 2usize..40,
        ) {
            let profile = MotionProfile::default();
            let mut buffer = MarlinBuffer::default();
            let mut sink = |_: &PlannedBlock| {};
            let mut at = Pos::default();
            for (dx, dy, feed) in steps {
                let to = Pos::xyze(at.x_mm + dx, at.y_mm + dy, 0.0, at.e_mm + 0.1);
                let mv = Move { start: at, end: to, feed_mm_s: feed, tag: 0 };
                buffer.push(&mv, mv.geometry().unwrap(), &profile, 0.013, capacity, &mut sink);
                let mut full = buffer.clone();
                let fixed = usize::from(full.head_entry_fixed);
                full.blocks.iter_mut().skip(fixed).for_each(|b| b.reverse_v2 = -1.0);
                full.replan();
                for (a, b) in buffer.blocks.iter().zip(&full.blocks) {
                    prop_assert_eq!(a.entry_v2, b.entry_v2);
                }
                at = to;
            }
        }
    }
}
