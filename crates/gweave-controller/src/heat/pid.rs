//! PID control of one heater.
//!
//! A heater block is a mass that the cartridge heats and the air cools. Switching the heater
//! fully on below the target and off above it (bang-bang) overshoots, because the heat already
//! in the cartridge keeps flowing after the switch. A PID controller sets the power from three
//! terms of the error `e = target - temperature`:
//! - proportional, `Kp e`: power in proportion to how far the temperature is;
//! - integral, `Ki ∫e dt`: the power that holds the target against the losses (at the target
//!   the proportional term is zero, so something else must supply it);
//! - derivative, `-Kd dT/dt`: brakes while the temperature rises fast, before the overshoot.
//!   It is taken on the temperature, not the error, so a new target gives no kick, and
//!   smoothed (Marlin's `PID_K1` = 0.95) because one ADC count of noise over 0.1 s is a large
//!   slope.
//!
//! As Marlin (`Marlin/src/module/temperature.cpp`, `PID_FUNCTIONAL_RANGE`), far from the target
//! (more than 10 °C) the heater is simply full on or off and the integral is cleared, so it does
//! not wind up during the long heat-up; the integral is also held within what the output can
//! use (0-255), for the same reason.

use crate::settings::Pid;

/// Beyond this error (°C) the heater is full on or off and the PID waits.
pub const FUNCTIONAL_RANGE_C: f32 = 10.0;

/// Smoothing of the temperature's slope: each update keeps this much of the old slope.
const SLOPE_SMOOTHING: f32 = 0.95;

/// The state of one PID loop.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PidState {
    integral_c_s: f32,
    slope_c_s: f32,
    last_c: Option<f32>,
}

impl PidState {
    /// The heater's duty (0-255) for `temp_c` against `target_c` after `dt_s` seconds.
    pub fn update(&mut self, gains: &Pid, target_c: f32, temp_c: f32, dt_s: f32) -> u8 {
        if let Some(last) = self.last_c {
            if dt_s > 0.0 {
                let slope = (temp_c - last) / dt_s;
                self.slope_c_s = SLOPE_SMOOTHING * self.slope_c_s + (1.0 - SLOPE_SMOOTHING) * slope;
            }
        }
        self.last_c = Some(temp_c);
        let error = target_c - temp_c;
        if target_c <= 0.0 || error < -FUNCTIONAL_RANGE_C {
            self.integral_c_s = 0.0;
            return 0;
        }
        if error > FUNCTIONAL_RANGE_C {
            self.integral_c_s = 0.0;
            return 255;
        }
        self.integral_c_s += error * dt_s;
        if gains.ki > 0.0 {
            self.integral_c_s = self.integral_c_s.clamp(0.0, 255.0 / gains.ki);
        }
        let power = gains.kp * error + gains.ki * self.integral_c_s - gains.kd * self.slope_c_s;
        power.clamp(0.0, 255.0) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::Settings;

    /// A hotend as a first-order plant: 40 W at full duty into 10 J/K, losing 0.1 W/K to 20 °C
    /// air (so 400 °C at full power, a time constant of 100 s), the thermistor reading
    /// 1 s late. Returns (the highest temperature, the lowest and highest in the last minute).
    fn heat_to(target_c: f32, seconds: u32) -> (f32, f32, f32) {
        let gains = Settings::DEFAULT.hotend_pid;
        let mut pid = PidState::default();
        let dt_s = 0.1;
        let (mut temp, mut sensed) = (20.0f32, 20.0f32);
        let (mut peak, mut low, mut high) = (0.0f32, f32::MAX, 0.0f32);
        for i in 0..seconds * 10 {
            let duty = pid.update(&gains, target_c, sensed, dt_s);
            let watts = 40.0 * f32::from(duty) / 255.0 - 0.1 * (temp - 20.0);
            temp += watts / 10.0 * dt_s;
            sensed += (temp - sensed) * dt_s; // 1 s lag
            peak = peak.max(sensed);
            if i >= (seconds - 60) * 10 {
                low = low.min(sensed);
                high = high.max(sensed);
            }
        }
        (peak, low, high)
    }

    #[test]
    fn pid_reaches_210_with_little_overshoot_and_holds_it() {
        let (peak, low, high) = heat_to(210.0, 600);
        assert!(peak < 213.0, "overshoot to {peak}");
        assert!(low > 209.0 && high < 211.0, "held within {low}..{high}");
    }

    #[test]
    fn far_below_the_target_the_heater_is_full_on_and_far_above_off() {
        let gains = Settings::DEFAULT.hotend_pid;
        let mut pid = PidState::default();
        assert_eq!(pid.update(&gains, 210.0, 20.0, 0.1), 255);
        assert_eq!(pid.update(&gains, 210.0, 230.0, 0.1), 0);
        assert_eq!(pid.update(&gains, 0.0, 20.0, 0.1), 0);
    }
}
