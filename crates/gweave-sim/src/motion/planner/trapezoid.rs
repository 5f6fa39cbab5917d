//! The trapezoidal speed profile of one block.
//!
//! ```text
//!  speed
//!    |        cruise_v
//!    |     +-------------+
//!    |    /               \
//!    |   /                 \  exit_v
//!    |  /                   +
//!    | + entry_v
//!    +--------------------------> time
//!      |accel_t| cruise_t |decel_t|
//! ```
//!
//! With constant acceleration `a`, squared speed changes linearly with distance
//! (`v1^2 = v0^2 + 2 a d`), so the planners work in squared speeds (`_v2`, (mm/s)^2) and the
//! distances follow directly: `accel_d = (cruise_v2 - entry_v2) / 2a`,
//! `decel_d = (cruise_v2 - exit_v2) / 2a`, the rest cruises. Each phase's time is its distance
//! over its mean speed. When the block is too short to reach the requested speed, the peak is
//! where the acceleration and deceleration parabolas meet:
//! `peak_v2 = (entry_v2 + exit_v2) / 2 + a * len` (the "triangle" case).

/// The speeds and phase times of one planned block.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Trapezoid {
    /// Speed at the start of the block, mm/s.
    pub entry_v_mm_s: f64,
    /// Highest speed, held while cruising, mm/s.
    pub cruise_v_mm_s: f64,
    /// Speed at the end of the block, mm/s.
    pub exit_v_mm_s: f64,
    /// Time spent accelerating, s.
    pub accel_t_s: f64,
    /// Time spent at cruise speed, s.
    pub cruise_t_s: f64,
    /// Time spent decelerating, s.
    pub decel_t_s: f64,
}

impl Trapezoid {
    /// The profile of a block of length `len` with acceleration `accel` between the squared
    /// speeds given. `cruise_v2` must be reachable: `cruise_v2 <= peak_v2(...)`, and at least
    /// the entry and exit speeds. Tiny negative cruise distances from rounding count as zero.
    pub fn from_v2(len: f64, accel: f64, entry_v2: f64, cruise_v2: f64, exit_v2: f64) -> Self {
        let half_inv_accel = 0.5 / accel;
        let accel_d = (cruise_v2 - entry_v2) * half_inv_accel;
        let decel_d = (cruise_v2 - exit_v2) * half_inv_accel;
        let cruise_d = (len - accel_d - decel_d).max(0.0);
        let entry_v = entry_v2.sqrt();
        let cruise_v = cruise_v2.sqrt();
        let exit_v = exit_v2.sqrt();
        Self {
            entry_v_mm_s: entry_v,
            cruise_v_mm_s: cruise_v,
            exit_v_mm_s: exit_v,
            accel_t_s: phase_time(accel_d, entry_v + cruise_v),
            cruise_t_s: phase_time(cruise_d, 2.0 * cruise_v),
            decel_t_s: phase_time(decel_d, exit_v + cruise_v),
        }
    }

    /// Total time of the block, s.
    pub fn duration_s(&self) -> f64 {
        self.accel_t_s + self.cruise_t_s + self.decel_t_s
    }
}

/// Time to cover `d` at the mean of two speeds whose sum is `v_sum`; a phase of no length takes
/// no time even when both speeds are zero.
fn phase_time(d: f64, v_sum: f64) -> f64 {
    if d > 0.0 {
        d / (0.5 * v_sum)
    } else {
        0.0
    }
}

/// The highest squared speed a block can reach when it must enter at `entry_v2` and leave at
/// `exit_v2`: where `v^2 = entry_v2 + 2 a x` meets `v^2 = exit_v2 + 2 a (len - x)`.
#[cfg(test)]
fn peak_v2(len: f64, accel: f64, entry_v2: f64, exit_v2: f64) -> f64 {
    0.5 * (entry_v2 + exit_v2) + accel * len
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12 * b.abs().max(1.0)
    }

    #[test]
    fn accelerate_cruise_decelerate() {
        // 100 mm at 50 mm/s, a = 1000: accelerating 0 -> 50 takes 0.05 s over 1.25 mm,
        // decelerating the same; 97.5 mm cruise at 50 mm/s = 1.95 s.
        let t = Trapezoid::from_v2(100.0, 1000.0, 0.0, 2500.0, 0.0);
        assert!(close(t.accel_t_s, 0.05) && close(t.decel_t_s, 0.05), "{t:?}");
        assert!(close(t.cruise_t_s, 1.95), "{t:?}");
        assert!(close(t.duration_s(), 2.05));
    }

    #[test]
    fn triangle_when_too_short_to_reach_cruise() {
        // 2 mm, a = 1000, from and to rest: peak v^2 = 1000 * 2 = 2000, v = 44.72 mm/s,
        // each half 1 mm in v/a = 0.04472 s.
        let p = peak_v2(2.0, 1000.0, 0.0, 0.0);
        assert_eq!(p, 2000.0);
        let t = Trapezoid::from_v2(2.0, 1000.0, 0.0, p.min(2500.0), 0.0);
        let half = 2000f64.sqrt() / 1000.0;
        assert!(close(t.accel_t_s, half) && close(t.decel_t_s, half), "{t:?}");
        assert_eq!(t.cruise_t_s, 0.0);
    }

    #[test]
    fn entry_and_exit_speeds() {
        // Enter at 10, cruise 30, leave at 20 over 10 mm with a = 500:
        // accel_d = (900-100)/1000 = 0.8 mm in 0.8/20 = 0.04 s,
        // decel_d = (900-400)/1000 = 0.5 mm in 0.5/25 = 0.02 s, cruise 8.7/30 = 0.29 s.
        let t = Trapezoid::from_v2(10.0, 500.0, 100.0, 900.0, 400.0);
        assert!(close(t.accel_t_s, 0.04) && close(t.decel_t_s, 0.02) && close(t.cruise_t_s, 0.29), "{t:?}");
        assert_eq!((t.entry_v_mm_s, t.cruise_v_mm_s, t.exit_v_mm_s), (10.0, 30.0, 20.0));
    }
}
