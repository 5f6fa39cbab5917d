//! Passing over the firmware loops while every heater rests.
//!
//! The heaters are simulated as the firmware runs them, one loop a sample period (0.1 s): a day
//! of dwell is 864 000 loops, a quarter of a second of CPU. A loop reads each sensor, checks
//! the protection, runs the control and records the series. When every heater rests, that is
//! no autotune, and each heater has no power, no target, no armed protection (or the machine
//! is halted) and a plant that its last step left as it was, to the bit (`heater/memo.rs`: a
//! plant off long enough stops moving, at ambient or within rounding of it), a loop reads the
//! same temperature, faults on nothing new, controls to 0 and leaves every state as it found
//! it, the controllers' stamp of their last sample aside. So the loops to come change nothing
//! but what the clock itself moves:
//!
//! - the clock and the count of loops;
//! - the series, which records at its due times;
//! - the step response each plant keeps, which later steps reuse (`heater/memo.rs`): it
//!   follows the periods between the loops' instants, which differ in their last bits;
//!
//! and [`Thermal::rest`] carries out just these, loop by loop, with each plant checked still
//! under each period it meets (it is, or the rest ends there). The step's last loop runs in full,
//! to stamp the controllers. A day at rest then costs a few milliseconds, and every temperature,
//! record and fault is what the loops run in full give (`thermal.rs`'s tests compare them).

use super::Thermal;

impl Thermal {
    /// Whether every heater rests but for its plant, which [`Thermal::rest`] checks loop by
    /// loop (module notes). Called after a loop run in full.
    pub(super) fn at_rest(&self) -> bool {
        let halted = self.halted.is_some();
        self.autotune.is_none()
            && self
                .channels
                .iter()
                .all(|c| c.power == 0 && (halted || (c.target_c == 0.0 && c.protection.idle())))
    }

    /// Passes over the loops of the step ending at `end_s`, at most `budget - 1` of them, while
    /// every plant stays still; the loop after them (the step's last, or its budget's) runs in
    /// full. Returns how many were passed over. (Kept out of `step`'s loop, which a print runs
    /// at every sample.)
    #[inline(never)]
    pub(super) fn rest(&mut self, end_s: f64, budget: u32) -> u32 {
        let period_s = self.sample_period_s;
        let mut passed = 0;
        while passed + 1 < budget && (self.samples_taken + 1) as f64 * period_s <= end_s + 1e-9 {
            // What `step` does for this loop: the clock to the loop's instant, the plants
            // integrated up to it (`settle_plants`), and the record if one is due.
            let now_s = self.now_s.max(self.samples_taken as f64 * period_s);
            let h_s = now_s - self.plant_s;
            if h_s > 1e-12 && !self.channels.iter_mut().all(|c| c.plant.rest(h_s)) {
                break;
            }
            self.now_s = now_s;
            self.plant_s = now_s;
            if self.series.due(now_s) {
                self.record();
            }
            self.samples_taken += 1;
            passed += 1;
        }
        passed
    }
}
