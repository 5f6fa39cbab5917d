//! The planned toolhead speed over the time of a run, in bounded memory, for the speed chart.
//!
//! Time is cut into buckets of equal width. Each bucket keeps the distance travelled in it and
//! the highest speed reached in it, from the planner's trapezoids: in the acceleration and
//! deceleration phases the speed is linear in time, so the distance over any interval
//! `[ta, tb]` of a phase is `(v(ta) + v(tb)) / 2 * (tb - ta)` and the highest speed is at one
//! of its ends. The mean speed of a bucket is its distance over its width (standing still,
//! heating, counts as 0). When a run outgrows `MAX_BUCKETS`, neighbouring buckets are merged
//! in pairs and the width doubles, so a 46-hour print costs the same memory as a minute.
//!
//! Only moves with XYZ travel count; extrude-only and rotary-only moves take time at speed 0.

use crate::motion::kinematics::MoveKind;
use crate::motion::planner::PlannedBlock;

/// Most buckets kept; the chart is at most this many pixels wide anyway.
const MAX_BUCKETS: usize = 2048;
/// Width of a bucket at the start, s.
const FIRST_BUCKET_S: f64 = 0.05;

/// One slice of time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Bucket {
    /// Distance travelled in it, mm.
    pub distance_mm: f64,
    /// Highest planned speed in it, mm/s.
    pub max_mm_s: f64,
}

/// See the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedTrace {
    bucket_s: f64,
    buckets: Vec<Bucket>,
    end_s: f64,
}

impl Default for SpeedTrace {
    fn default() -> Self {
        SpeedTrace { bucket_s: FIRST_BUCKET_S, buckets: Vec::new(), end_s: 0.0 }
    }
}

impl SpeedTrace {
    /// Width of each bucket, s.
    pub fn bucket_s(&self) -> f64 {
        self.bucket_s
    }

    pub fn buckets(&self) -> &[Bucket] {
        &self.buckets
    }

    /// End of the last block recorded, s.
    pub fn end_s(&self) -> f64 {
        self.end_s
    }

    /// Mean speed of bucket `i`, mm/s.
    pub fn mean_mm_s(&self, i: usize) -> f64 {
        self.buckets.get(i).map_or(0.0, |b| b.distance_mm / self.bucket_s)
    }

    /// A block that starts at `t0_s`.
    pub fn add(&mut self, t0_s: f64, block: &PlannedBlock) {
        let tz = &block.trapezoid;
        self.end_s = self.end_s.max(t0_s + block.duration_s());
        if block.kind != MoveKind::Kinematic {
            return;
        }
        let phases = [
            (tz.accel_t_s, tz.entry_v_mm_s, tz.cruise_v_mm_s),
            (tz.cruise_t_s, tz.cruise_v_mm_s, tz.cruise_v_mm_s),
            (tz.decel_t_s, tz.cruise_v_mm_s, tz.exit_v_mm_s),
        ];
        let mut t = t0_s;
        for (dt, v0, v1) in phases {
            if dt > 0.0 && dt.is_finite() {
                self.phase(t, dt, v0, v1);
                t += dt;
            }
        }
    }

    /// A phase of `dt` s from `t` with the speed going linearly from `v0` to `v1`.
    fn phase(&mut self, t: f64, dt: f64, v0: f64, v1: f64) {
        let end = t + dt;
        while (end / self.bucket_s).ceil() as usize > MAX_BUCKETS {
            self.coarsen();
        }
        let v_at = |x: f64| v0 + (v1 - v0) * ((x - t) / dt);
        let mut a = t;
        while a < end {
            let mut i = (a / self.bucket_s).floor() as usize;
            // `a` on a boundary may divide to a hair below it: that bucket is already done.
            if (i + 1) as f64 * self.bucket_s <= a {
                i += 1;
            }
            let b = ((i + 1) as f64 * self.bucket_s).min(end);
            if self.buckets.len() <= i {
                self.buckets.resize(i + 1, Bucket::default());
            }
            let (va, vb) = (v_at(a), v_at(b));
            let bucket = &mut self.buckets[i];
            bucket.distance_mm += (va + vb) / 2.0 * (b - a);
            bucket.max_mm_s = bucket.max_mm_s.max(va).max(vb);
            a = if b > a { b } else { end };
        }
    }

    /// Merges neighbouring buckets in pairs: twice the width.
    fn coarsen(&mut self) {
        let merged = self
            .buckets
            .chunks(2)
            .map(|pair| Bucket {
                distance_mm: pair.iter().map(|b| b.distance_mm).sum(),
                max_mm_s: pair.iter().map(|b| b.max_mm_s).fold(0.0, f64::max),
            })
            .collect();
        self.buckets = merged;
        self.bucket_s *= 2.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::kinematics::Pos;
    use crate::motion::planner::Trapezoid;

    fn block(len: f64, accel: f64, cruise: f64, kind: MoveKind) -> PlannedBlock {
        PlannedBlock {
            tag: 0,
            start: Pos::default(),
            end: Pos::default(),
            len,
            accel_mm_s2: accel,
            kind,
            trapezoid: Trapezoid::from_v2(len, accel, 0.0, cruise * cruise, 0.0),
        }
    }

    #[test]
    fn distance_and_peak_are_kept_per_bucket() {
        let mut trace = SpeedTrace::default();
        // 100 mm at 50 mm/s with 500 mm/s^2: 0.1 s up (2.5 mm), 1.9 s cruise, 0.1 s down.
        let b = block(100.0, 500.0, 50.0, MoveKind::Kinematic);
        trace.add(1.0, &b);
        assert!((trace.end_s() - 3.1).abs() < 1e-9);
        let total: f64 = trace.buckets().iter().map(|b| b.distance_mm).sum();
        assert!((total - 100.0).abs() < 1e-9, "{total}");
        // Idle before the move, cruising in the middle of it.
        assert_eq!(trace.mean_mm_s(10), 0.0);
        let mid = (2.0 / trace.bucket_s()) as usize;
        assert!((trace.mean_mm_s(mid) - 50.0).abs() < 1e-9);
        assert_eq!(trace.buckets()[mid].max_mm_s, 50.0);
        // Extrude-only moves take time at speed 0.
        let extrude = block(5.0, 500.0, 30.0, MoveKind::ExtrudeOnly);
        trace.add(3.1, &extrude);
        let total_after: f64 = trace.buckets().iter().map(|b| b.distance_mm).sum();
        assert_eq!(total_after, total);
        assert_eq!(trace.end_s(), 3.1 + extrude.duration_s());
    }

    #[test]
    fn long_runs_coarsen_without_losing_distance() {
        let mut trace = SpeedTrace::default();
        let b = block(100.0, 1000.0, 100.0, MoveKind::Kinematic);
        let mut t = 0.0;
        for _ in 0..5000 {
            trace.add(t, &b);
            t += b.duration_s();
        }
        assert!(trace.buckets().len() <= MAX_BUCKETS);
        // The first bucket width doubled until the run fits in MAX_BUCKETS.
        let mut want_s = FIRST_BUCKET_S;
        while (t / want_s).ceil() as usize > MAX_BUCKETS {
            want_s *= 2.0;
        }
        assert!(want_s > FIRST_BUCKET_S);
        assert_eq!(trace.bucket_s(), want_s);
        let total: f64 = trace.buckets().iter().map(|b| b.distance_mm).sum();
        assert!((total - 500_000.0).abs() < 1e-6, "{total}");
        assert!(trace.buckets().iter().all(|b| b.max_mm_s <= 100.0 + 1e-9));
    }
}
