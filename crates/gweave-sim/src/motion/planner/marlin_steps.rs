//! A Marlin block's speed profile in steps, and its time.
//!
//! Marlin's stepper does not follow the planner's speeds in mm/s but a trapezoid in steps of
//! the block's busiest motor (`Marlin/src/module/planner.cpp`,
//! `Planner::calculate_trapezoid_for_block`): whole step rates (steps/s) and whole step counts
//! at which to stop accelerating and start braking. The rounding is small per block but always
//! the same way (rates are rounded up, the acceleration phase too), so over a file of many short
//! blocks it comes to more than 0.01 %:
//!
//! ```text
//!  rate (steps/s)
//!    |        cruise_rate
//!    |     +-------------+          initial_rate = ceil(nominal_rate * entry_v / nominal_v)
//!    |    /               \         final_rate   = ceil(nominal_rate * exit_v / nominal_v)
//!    |   /                 +        both at least MINIMAL_STEP_RATE (120 steps/s)
//!    |  +                      
//!    +--|------|-------------|---> steps
//!       0  accelerate_until  decelerate_after  step_event_count
//! ```
//!
//! `accelerate_until = ceil((nominal^2 - initial^2) / 2a)`, the braking distance is
//! `floor((nominal^2 - final^2) / 2a)`; when they overlap the block has no cruise, the
//! acceleration ends at `ceil` of the intersection of the two parabolas and the peak rate is
//! what that many steps of acceleration reach. Each phase then takes its steps over the mean
//! of its end rates (the constant-acceleration time), which is how Marlin's own host-side
//! estimate (the `marlin-calc` tool of the PrintTimeGenius plugin) times a block.

use super::{Greater, Lesser};
use crate::motion::rounding::{ceil, floor, trunc};

/// `MINIMAL_STEP_RATE`: the stepper timer cannot run slower, steps/s.
pub(crate) const MINIMAL_STEP_RATE: f64 = 120.0;

/// The step trapezoid of one block and its phase times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StepProfile {
    /// Rates at the start, at the top and at the end, steps/s.
    pub initial_rate: f64,
    pub cruise_rate: f64,
    pub final_rate: f64,
    /// Time accelerating, cruising and braking, s.
    pub accel_t_s: f64,
    pub cruise_t_s: f64,
    pub decel_t_s: f64,
}

impl StepProfile {
    /// The profile of a block of `steps` steps with nominal rate `nominal_rate` (a whole
    /// number of steps/s) and acceleration `accel` (whole steps/s²), entered and left at
    /// `entry_factor` and `exit_factor` times its nominal speed. As in Marlin, the rates and
    /// distances are worked out in single precision before they are rounded to whole numbers
    /// (a factor of exactly 1/3 times 2400 steps/s is 800 in `float`, 801 rounded up in
    /// `double`).
    pub(crate) fn new(
        steps: f64,
        nominal_rate: f64,
        accel: f64,
        entry_factor: f32,
        exit_factor: f32,
    ) -> Self {
        let (steps32, nominal32, accel32) = (steps as f32, nominal_rate as f32, accel as f32);
        let initial_rate = ceil(f64::from(nominal32 * entry_factor)).greater(MINIMAL_STEP_RATE);
        let final_rate = ceil(f64::from(nominal32 * exit_factor)).greater(MINIMAL_STEP_RATE);
        let (initial32, final32) = (initial_rate as f32, final_rate as f32);
        let distance = |from: f32, to: f32| f64::from((to * to - from * from) / (accel32 * 2.0));
        // Marlin stores the step counts in unsigned integers. A negative acceleration distance
        // (a rate floor above a nominal rate under 120 steps/s) is taken as none. A negative
        // braking distance (a block left faster than its nominal speed, which classic jerk
        // allows, see `marlin.rs`) wraps around and, through the same wrap in the cruise
        // count, means no braking: the block cruises to its end.
        let mut accelerate = ceil(distance(initial32, nominal32)).greater(0.0);
        let decelerate = floor(distance(final32, nominal32));
        let mut plateau = steps - accelerate - decelerate;
        let cruise_rate = if plateau < 0.0 {
            let meet =
                (accel32 * 2.0 * steps32 - initial32 * initial32 + final32 * final32) / (accel32 * 4.0);
            accelerate = ceil(f64::from(meet)).clamp(0.0, steps);
            plateau = 0.0;
            // The peak rate is kept as a whole number (truncated), as Marlin stores it.
            trunc(f64::from((initial32 * initial32 + 2.0 * accel32 * accelerate as f32).sqrt()))
        } else {
            nominal_rate
        };
        let accel_steps = accelerate;
        let cruise_steps = (accelerate + plateau).lesser(steps) - accel_steps;
        let decel_steps = (steps - cruise_steps - accel_steps).greater(0.0);
        Self {
            initial_rate,
            cruise_rate,
            final_rate,
            accel_t_s: accel_steps * 2.0 / (cruise_rate + initial_rate),
            cruise_t_s: cruise_steps / cruise_rate,
            decel_t_s: decel_steps * 2.0 / (final_rate + cruise_rate),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_round_up_and_phases_take_whole_steps() {
        // 8000 steps (100 mm at 80 steps/mm) at 4000 steps/s (50 mm/s), a = 240000 steps/s²
        // (3000 mm/s²), from and to the 0.05 mm/s floor (4 steps/s, raised to 120):
        // accelerate ceil((4000² - 120²) / 480000) = ceil(33.303) = 34 steps in
        // 34 * 2 / 4120 s, brake floor(33.303) = 33 steps in 33 * 2 / 4120 s, cruise 7933 steps.
        let p = StepProfile::new(8000.0, 4000.0, 240_000.0, 0.05 / 50.0, 0.05 / 50.0);
        assert_eq!((p.initial_rate, p.cruise_rate, p.final_rate), (120.0, 4000.0, 120.0));
        assert!((p.accel_t_s - 68.0 / 4120.0).abs() < 1e-15, "{p:?}");
        assert!((p.decel_t_s - 66.0 / 4120.0).abs() < 1e-15, "{p:?}");
        assert!((p.cruise_t_s - 7933.0 / 4000.0).abs() < 1e-15, "{p:?}");
    }

    #[test]
    fn short_block_peaks_where_the_parabolas_meet() {
        // 240 steps at a = 240000 from and to 120 steps/s: they meet at ceil(120) = 120 steps;
        // the peak is trunc(sqrt(120² + 480000 * 120)) = 7590 steps/s.
        let p = StepProfile::new(240.0, 16_000.0, 240_000.0, 0.0, 0.0);
        assert_eq!(p.cruise_rate, 7590.0);
        assert_eq!(p.cruise_t_s, 0.0);
        assert!((p.accel_t_s - 240.0 / 7710.0).abs() < 1e-15 && (p.decel_t_s - 240.0 / 7710.0).abs() < 1e-15);
    }

    #[test]
    fn block_left_above_its_nominal_rate_cruises_to_the_end() {
        // 80 Z steps at 2000 steps/s, a = 40000, entered at 0.06 (121 steps/s), left at 2.83
        // times nominal (5657 steps/s): accelerate ceil((2000² - 121²) / 80000) = 50 steps,
        // then cruise 30 steps at 2000, no braking.
        let p = StepProfile::new(80.0, 2000.0, 40_000.0, 0.0602, 2.8284);
        assert_eq!((p.initial_rate, p.cruise_rate, p.final_rate), (121.0, 2000.0, 5657.0));
        assert_eq!(p.decel_t_s, 0.0);
        assert!((p.accel_t_s - 100.0 / 2121.0).abs() < 1e-15 && (p.cruise_t_s - 30.0 / 2000.0).abs() < 1e-15);
    }
}
