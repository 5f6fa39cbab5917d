//! Control: the algorithms that turn a measured temperature into heater
//! power, swappable behind one trait that takes the time as an argument.
//!
//! # Power units
//!
//! A controller returns the power Marlin reports after `@:` in M105: a
//! soft-PWM amount in `0..=`[`POWER_MAX`] (127), i.e. the duty cycle is
//! `power / 127`. Marlin's PID computes its output on a `0..=PID_MAX` (255)
//! scale and halves it for the soft PWM; [`Pid`] does the same so gains
//! tuned on Marlin (and by M303, [`crate::thermal::autotune`]) carry over unchanged.
//!
//! # Bang-bang (seed document 002, section 5)
//!
//! Full power while the reading is below the target, off once it is above,
//! evaluated only every 500 ms while idle and every 250 ms while moving;
//! between evaluations the last decision holds. An optional hysteresis band
//! `h` switches on below `target - h` and off above `target + h`.
//!
//! # PID
//!
//! On the error `e = target - measured` (Marlin's
//! `M301` semantics):
//!
//! ```text
//!   out = Kp e  +  I  -  Kd d(measured)/dt         clamped to 0..=255
//!   I  += Ki e dt                                   clamped to 0..=255 (anti-windup)
//! ```
//!
//! * `Kp` in output counts per kelvin; `Ki` in counts per (kelvin second)
//!   and `Kd` in counts seconds per kelvin: the per-second ("unscaled")
//!   values M301 and M303 print, independent of the sample period;
//! * the derivative acts on the measurement (no kick when the target
//!   changes) and is low-pass filtered with time constant
//!   `derivative_filter_s`, as Marlin smooths it with `PID_K1 = 0.95` per
//!   sample;
//! * outside Marlin's `PID_FUNCTIONAL_RANGE` (10 C) the output is simply
//!   full (too cold) or off (too hot) and the integral is reset.

use std::fmt;

use gweave::settings::{CheckRanges, Table};
use gweave::{OutOfRange, Range};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Largest power a controller returns (Marlin's soft-PWM range, `@:127`).
pub(crate) const POWER_MAX: u8 = 127;

/// Full scale of the PID output before halving (Marlin `PID_MAX`).
pub(crate) const PID_MAX: f64 = 255.0;

/// Duty cycle (0..=1) for a power value.
pub(crate) fn duty(power: u8) -> f64 {
    f64::from(power.min(POWER_MAX)) / f64::from(POWER_MAX)
}

/// Errors in a controller configuration.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ControlError {
    #[error(transparent)]
    Range(#[from] OutOfRange),
}

/// A switching band or PID functional range, C.
const BAND_C: Range = Range::new(0.0, 100.0, "°C");
/// How often bang-bang decides (must advance the clock).
const EVAL_PERIOD_S: Range = Range::new(0.001, 60.0, "s");
/// PID gains in counts (of 255) per kelvin (per second, times seconds); tuned beds reach a
/// few thousand.
pub(crate) const GAIN: Range = Range::new(0.0, 100_000.0, "");
const FILTER_S: Range = Range::new(0.0, 600.0, "s");

impl CheckRanges for ControlConfig {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        match self {
            ControlConfig::BangBang(c) => {
                t.check("hysteresis_c", c.hysteresis_c, BAND_C)?;
                t.check("idle_period_s", c.idle_period_s, EVAL_PERIOD_S)?;
                t.check("moving_period_s", c.moving_period_s, EVAL_PERIOD_S)
            }
            ControlConfig::Pid(c) => {
                c.gains.check_ranges(&t.sub("gains"))?;
                t.check_opt("functional_range_c", c.functional_range_c, BAND_C)?;
                t.check("derivative_filter_s", c.derivative_filter_s, FILTER_S)
            }
        }
    }
}

impl CheckRanges for PidGains {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("kp", self.kp, GAIN)?;
        t.check("ki", self.ki, GAIN)?;
        t.check("kd", self.kd, GAIN)
    }
}

/// A heater control algorithm. Every call carries the simulated time; no
/// implementation reads a clock.
///
/// With a target of 0, `update` returns 0 and keeps nothing that the next update reads but
/// what that update writes again (the PID's last sample): the thermal loop passes over such
/// updates while every heater rests (`thermal/rest.rs`), and runs the last one in full.
pub trait Control: fmt::Debug + Send {
    /// Decide the heater power (`0..=POWER_MAX`) at `now_s` from the
    /// measured temperature and the target. A target of 0 means off.
    fn update(&mut self, now_s: f64, measured_c: f64, target_c: f64) -> u8;

    /// Forget all history (the heater was halted or re-targeted from cold).
    fn reset(&mut self) {}

    /// Whether the machine is moving (bang-bang evaluates faster then).
    fn set_moving(&mut self, _moving: bool) {}

    /// The PID gains, if this controller is a PID (M301 query).
    fn pid_gains(&self) -> Option<PidGains> {
        None
    }

    /// Replace the PID gains (M301 set); returns false if not a PID.
    fn set_pid_gains(&mut self, _gains: PidGains) -> bool {
        false
    }
}

/// Configuration of a controller, deserialized as
/// `{ kind = "bang_bang", ... }` or `{ kind = "pid", ... }`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ControlConfig {
    BangBang(BangBangConfig),
    Pid(PidConfig),
}

impl ControlConfig {
    /// Validate and build the controller.
    pub fn build(&self) -> Result<Box<dyn Control>, ControlError> {
        Ok(match self {
            ControlConfig::BangBang(c) => Box::new(BangBang::new(*c)?),
            ControlConfig::Pid(c) => Box::new(Pid::new(*c)?),
        })
    }
}

/// Bang-bang settings; the defaults are the seed's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BangBangConfig {
    /// Half-width of the switching band, C (0: on at or below target).
    pub hysteresis_c: f64,
    /// Evaluation period while idle, s (seed: 500 ms).
    pub idle_period_s: f64,
    /// Evaluation period while moving, s (seed: 250 ms).
    pub moving_period_s: f64,
}

impl Default for BangBangConfig {
    fn default() -> Self {
        Self { hysteresis_c: 0.0, idle_period_s: 0.5, moving_period_s: 0.25 }
    }
}

/// The seed's bang-bang controller.
#[derive(Debug, Clone)]
pub(crate) struct BangBang {
    cfg: BangBangConfig,
    moving: bool,
    on: bool,
    next_eval_s: Option<f64>,
}

impl BangBang {
    pub(crate) fn new(cfg: BangBangConfig) -> Result<Self, ControlError> {
        ControlConfig::BangBang(cfg).check_ranges(&Table::root())?;
        Ok(Self { cfg, moving: false, on: false, next_eval_s: None })
    }
}

impl Control for BangBang {
    fn update(&mut self, now_s: f64, measured_c: f64, target_c: f64) -> u8 {
        if target_c <= 0.0 {
            self.on = false;
            self.next_eval_s = None;
            return 0;
        }
        if self.next_eval_s.is_none_or(|t| now_s >= t) {
            let h = self.cfg.hysteresis_c;
            if measured_c > target_c + h {
                self.on = false;
            } else if measured_c <= target_c - h {
                self.on = true;
            }
            let period = if self.moving { self.cfg.moving_period_s } else { self.cfg.idle_period_s };
            self.next_eval_s = Some(now_s + period);
        }
        if self.on {
            POWER_MAX
        } else {
            0
        }
    }

    fn reset(&mut self) {
        self.on = false;
        self.next_eval_s = None;
    }

    fn set_moving(&mut self, moving: bool) {
        self.moving = moving;
    }
}

/// PID gains in Marlin's per-second units (what `M301 P I D` takes).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PidGains {
    /// Proportional gain, output counts (of 255) per kelvin.
    pub kp: f64,
    /// Integral gain, counts per kelvin per second.
    pub ki: f64,
    /// Derivative gain, counts seconds per kelvin.
    pub kd: f64,
}

impl PidGains {
    /// Marlin's shipped hotend defaults (`DEFAULT_Kp 22.2`, `Ki 1.08`,
    /// `Kd 114`), for reference; tune the real plant with M303.
    pub const MARLIN_HOTEND: PidGains = PidGains { kp: 22.2, ki: 1.08, kd: 114.0 };

    /// Gains found by M303 (this crate's autotune, 5 cycles at 210 C) on the
    /// default plant [`crate::thermal::heater::HeaterConfig::hotend_40w`].
    pub const DEFAULT_HOTEND_40W: PidGains = PidGains { kp: 37.17, ki: 4.74, kd: 72.95 };

    /// The M301/M503-style report line, e.g.
    /// `echo:  M301 P22.20 I1.08 D114.00` (`M304` for the bed).
    pub fn report_line(&self, bed: bool) -> String {
        let code = if bed { "M304" } else { "M301" };
        format!("echo:  {code} P{:.2} I{:.2} D{:.2}", self.kp, self.ki, self.kd)
    }

    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.check_ranges(&Table::root())?)
    }
}

/// PID settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PidConfig {
    pub gains: PidGains,
    /// Beyond this error the output is full on/off and the integral is
    /// reset (Marlin `PID_FUNCTIONAL_RANGE`, 10 C); `None` disables it.
    #[serde(default = "default_functional_range_c")]
    pub functional_range_c: Option<f64>,
    /// Time constant of the low-pass on the derivative term, s.
    #[serde(default = "default_derivative_filter_s")]
    pub derivative_filter_s: f64,
}

fn default_functional_range_c() -> Option<f64> {
    Some(10.0)
}

fn default_derivative_filter_s() -> f64 {
    // PID_K1 = 0.95 per sample at Marlin's ~0.1 s sample period gives a
    // time constant of 0.1 * 0.95 / 0.05 ~ 2 s.
    2.0
}

impl PidConfig {
    /// A PID with the given gains and Marlin's defaults otherwise.
    pub fn with_gains(gains: PidGains) -> Self {
        Self {
            gains,
            functional_range_c: default_functional_range_c(),
            derivative_filter_s: default_derivative_filter_s(),
        }
    }
}

/// Marlin-style PID (module docs).
#[derive(Debug, Clone)]
pub(crate) struct Pid {
    cfg: PidConfig,
    integral: f64,
    derivative: f64,
    last: Option<(f64, f64)>,
}

impl Pid {
    pub(crate) fn new(cfg: PidConfig) -> Result<Self, ControlError> {
        ControlConfig::Pid(cfg).check_ranges(&Table::root())?;
        Ok(Self { cfg, integral: 0.0, derivative: 0.0, last: None })
    }

    /// The output on the 0..=255 scale (before halving), for inspection.
    fn output(&mut self, now_s: f64, measured_c: f64, target_c: f64) -> f64 {
        let prev = self.last.replace((now_s, measured_c));
        let error = target_c - measured_c;
        if target_c <= 0.0 {
            self.reset();
            return 0.0;
        }
        if let Some(range) = self.cfg.functional_range_c {
            if error > range || error < -range {
                self.integral = 0.0;
                self.derivative = 0.0;
                return if error > 0.0 { PID_MAX } else { 0.0 };
            }
        }
        let g = self.cfg.gains;
        if let Some((t0, m0)) = prev {
            let dt = now_s - t0;
            if dt > 0.0 {
                self.integral = (self.integral + g.ki * error * dt).clamp(0.0, PID_MAX);
                let raw = (measured_c - m0) / dt;
                let alpha = dt / (self.cfg.derivative_filter_s + dt);
                self.derivative += alpha * (raw - self.derivative);
            }
        }
        (g.kp * error + self.integral - g.kd * self.derivative).clamp(0.0, PID_MAX)
    }
}

impl Control for Pid {
    fn update(&mut self, now_s: f64, measured_c: f64, target_c: f64) -> u8 {
        // Whole counts (rounded, so float dust like 29.999 stays 30), then
        // halved like Marlin's soft PWM: 255 -> 127.
        (self.output(now_s, measured_c, target_c).round() as u8) >> 1
    }

    fn reset(&mut self) {
        self.integral = 0.0;
        self.derivative = 0.0;
    }

    fn pid_gains(&self) -> Option<PidGains> {
        Some(self.cfg.gains)
    }

    fn set_pid_gains(&mut self, gains: PidGains) -> bool {
        if gains.validate().is_err() {
            return false;
        }
        self.cfg.gains = gains;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bang_bang_switches_on_seed_periods() {
        let mut bb = BangBang::new(BangBangConfig::default()).unwrap();
        assert_eq!(bb.update(0.0, 20.0, 60.0), POWER_MAX);
        // Above target at 0.3 s, but the next idle check is at 0.5 s.
        assert_eq!(bb.update(0.3, 61.0, 60.0), POWER_MAX);
        assert_eq!(bb.update(0.5, 61.0, 60.0), 0);
        // While moving the period is 250 ms.
        bb.set_moving(true);
        assert_eq!(bb.update(0.8, 59.0, 60.0), 0);
        assert_eq!(bb.update(1.0, 59.0, 60.0), POWER_MAX);
        assert_eq!(bb.update(1.25, 61.0, 60.0), 0);
        // Equal to target counts as "not above": on (seed: off only if greater).
        assert_eq!(bb.update(1.5, 60.0, 60.0), POWER_MAX);
        // Target 0 is off at once.
        assert_eq!(bb.update(1.6, 20.0, 0.0), 0);
    }

    #[test]
    fn bang_bang_hysteresis_holds_inside_band() {
        let mut bb =
            BangBang::new(BangBangConfig { hysteresis_c: 2.0, ..BangBangConfig::default() }).unwrap();
        assert_eq!(bb.update(0.0, 57.0, 60.0), POWER_MAX);
        assert_eq!(bb.update(0.5, 61.5, 60.0), POWER_MAX);
        assert_eq!(bb.update(1.0, 62.5, 60.0), 0);
        assert_eq!(bb.update(1.5, 58.5, 60.0), 0);
        assert_eq!(bb.update(2.0, 57.5, 60.0), POWER_MAX);
    }

    fn pid(gains: PidGains) -> Pid {
        Pid::new(PidConfig {
            functional_range_c: None,
            derivative_filter_s: 0.0,
            ..PidConfig::with_gains(gains)
        })
        .unwrap()
    }

    #[test]
    fn pid_terms_in_per_second_units() {
        // P only: 10 counts/K * 5 K = 50 of 255 -> power 25.
        let mut p = pid(PidGains { kp: 10.0, ki: 0.0, kd: 0.0 });
        assert_eq!(p.update(0.0, 205.0, 210.0), 25);
        // I only: 2 counts/(K s) * 5 K * 3 s = 30 of 255 -> 15, whatever the
        // sample period.
        for steps in [3usize, 30] {
            let mut i = pid(PidGains { kp: 0.0, ki: 2.0, kd: 0.0 });
            let dt = 3.0 / steps as f64;
            let mut power = i.update(0.0, 205.0, 210.0);
            for k in 1..=steps {
                power = i.update(k as f64 * dt, 205.0, 210.0);
            }
            assert_eq!(power, 15, "steps {steps}");
        }
        // D only, on the measurement: rising 2 K/s with Kd 20 counts s/K
        // subtracts 40 counts; with P 100 counts -> (100 - 40)/2 = 30.
        let mut d = pid(PidGains { kp: 10.0, ki: 0.0, kd: 20.0 });
        d.update(0.0, 198.0, 210.0);
        assert_eq!(d.update(1.0, 200.0, 210.0), 30);
    }

    #[test]
    fn pid_integral_windup_is_clamped() {
        let mut i = pid(PidGains { kp: 0.0, ki: 10.0, kd: 0.0 });
        // A long time far below target would integrate to 10*50*1000.
        i.update(0.0, 160.0, 210.0);
        assert_eq!(i.update(1000.0, 160.0, 210.0), POWER_MAX);
        // Once above target the clamped integral (255) unwinds at
        // 10 * 5 = 50 counts/s: after 3 s it is 105 -> power 52. Without
        // the clamp it would still be saturated.
        assert_eq!(i.update(1003.0, 215.0, 210.0), 52);
    }

    #[test]
    fn pid_functional_range_is_full_on_or_off() {
        let mut p = Pid::new(PidConfig::with_gains(PidGains::MARLIN_HOTEND)).unwrap();
        assert_eq!(p.update(0.0, 100.0, 210.0), POWER_MAX);
        assert_eq!(p.update(0.1, 230.0, 210.0), 0);
        assert_eq!(p.update(0.2, 25.0, 0.0), 0);
    }

    #[test]
    fn m301_set_and_report() {
        let mut c = ControlConfig::Pid(PidConfig::with_gains(PidGains::MARLIN_HOTEND)).build().unwrap();
        assert_eq!(c.pid_gains().unwrap().report_line(false), "echo:  M301 P22.20 I1.08 D114.00");
        let new = PidGains { kp: 19.54, ki: 1.63, kd: 58.61 };
        assert!(c.set_pid_gains(new));
        assert_eq!(c.pid_gains(), Some(new));
        assert!(!c.set_pid_gains(PidGains { kp: -1.0, ..new }));
        let mut bb = ControlConfig::BangBang(BangBangConfig::default()).build().unwrap();
        assert_eq!(bb.pid_gains(), None);
        assert!(!bb.set_pid_gains(new));
    }

    #[test]
    fn config_parses_and_rejects_unknown_keys() {
        let c: ControlConfig = toml::from_str("kind = \"bang_bang\"\nhysteresis_c = 1.5\n").unwrap();
        assert_eq!(
            c,
            ControlConfig::BangBang(BangBangConfig { hysteresis_c: 1.5, ..BangBangConfig::default() })
        );
        let p: ControlConfig =
            toml::from_str("kind = \"pid\"\ngains = { kp = 1.0, ki = 0.1, kd = 5.0 }\n").unwrap();
        assert!(matches!(p, ControlConfig::Pid(c) if c.functional_range_c == Some(10.0)));
        assert!(toml::from_str::<ControlConfig>("kind = \"bang_bang\"\nperiod = 1.0\n").is_err());
        let bad = ControlConfig::BangBang(BangBangConfig { idle_period_s: 0.0, ..BangBangConfig::default() });
        assert!(bad.build().is_err());
    }
}
