//! Heater: a lumped thermal plant (one heater block or bed) on the simulated
//! clock, with injectable faults.
//!
//! # The plant
//!
//! The block is one thermal mass at temperature `T` (a "lumped capacitance"
//! model, valid while the block conducts heat much faster than it loses it,
//! i.e. a small Biot number; see any heat-transfer text, e.g. Incropera,
//! *Fundamentals of Heat and Mass Transfer*, ch. 5.1):
//!
//! ```text
//!   C dT/dt = u P  -  (h + f h_fan) (T - T_amb)
//! ```
//!
//! with heat capacity `C` (J/K), heater power `P` (W) switched with duty
//! `u` in 0..=1, loss conductance to ambient `h` (W/K) and, for a hotend, an
//! extra conductance `h_fan` scaled by the part-cooling fan fraction `f`.
//! For inputs held constant over a step `dt` the equation has the exact
//! solution
//!
//! ```text
//!   k     = h + f h_fan                    (W/K)
//!   T_inf = T_amb + u P / k                (where T settles)
//!   T(dt) = T_inf + (T(0) - T_inf) exp(-k dt / C)
//! ```
//!
//! which [`Heater::step`] extends to the lags below, so any `dt` is exact.
//!
//! # The two lags
//!
//! Heat made in the cartridge core reaches the block only after warming the
//! core itself, and the thermistor pressed into the block lags the block.
//! Both are modelled as first-order low-passes, `tau dy/dt = x - y`:
//!
//! * `heater_lag_s`: the heat flow into the block follows `u P`;
//! * `sensor_lag_s`: the sensor temperature follows `T`.
//!
//! The three stages in series still have an exact solution for power held
//! over a step (a sum of the three stages' exponentials, see `cascade`), so a
//! step of any length, or the same time cut into any number of steps, gives
//! the same temperatures.
//!
//! With the block's own time constant `C/k` this makes a third-order plant
//! whose phase reaches -180 degrees at a finite frequency, so a relay
//! (bang-bang) loop oscillates with the finite period M303 measures: for
//! `C/k` much longer than the lags, the phase condition
//! `atan(w tau_h) + atan(w tau_s) = 90 deg` gives `w = 1/sqrt(tau_h tau_s)`,
//! a period `Tu ~ 2 pi sqrt(tau_h tau_s)`.
//!
//! # Faults
//!
//! A disconnected cartridge delivers no power whatever the duty; an open or
//! shorted thermistor replaces the sensor reading with the ADC rail (see
//! [`crate::thermal::thermistor::SensorFault`]). The block's physics continues.

use std::fmt;

use gweave::settings::{CheckRanges, Table};
use gweave::{OutOfRange, Range};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::thermal::thermistor::{BetaThermistor, SensorFault};

use cascade::Decay;
use memo::Memo;

mod cascade;
mod memo;

/// Which heater: a hotend by index, or the bed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeaterId {
    /// Hotend `n` (`T<n>`, Marlin `Heater_ID: n`).
    Hotend(u8),
    /// The heated bed (`B`, Marlin `Heater_ID: bed`).
    Bed,
}

impl fmt::Display for HeaterId {
    /// The form Marlin prints after `Heater_ID: `.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HeaterId::Hotend(n) => write!(f, "{n}"),
            HeaterId::Bed => f.write_str("bed"),
        }
    }
}

/// Errors in a heater configuration.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HeaterError {
    #[error(transparent)]
    Range(#[from] OutOfRange),
}

/// Physical parameters of one heater. Deserialized with unknown keys
/// rejected; see [`HeaterConfig::hotend_40w`] and [`HeaterConfig::bed_200w`]
/// for the documented defaults.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeaterConfig {
    /// Electrical power of the heater at full duty, W.
    pub power_w: f64,
    /// Heat capacity of the block (or bed) including the heater, J/K.
    pub heat_capacity_j_k: f64,
    /// Loss conductance to ambient, W/K (convection plus radiation,
    /// linearised).
    pub loss_w_k: f64,
    /// Extra loss conductance with the part-cooling fan at 100 %, W/K.
    #[serde(default)]
    pub fan_loss_w_k: f64,
    /// Ambient (and initial) temperature, C.
    #[serde(default = "default_ambient_c")]
    pub ambient_c: f64,
    /// Lag of the heat flow behind the electrical power (first-order time
    /// constant of the cartridge core or heater pad), s; 0 for none.
    #[serde(default)]
    pub heater_lag_s: f64,
    /// Thermistor lag behind the block (first-order time constant), s;
    /// 0 for none.
    #[serde(default)]
    pub sensor_lag_s: f64,
}

fn default_ambient_c() -> f64 {
    25.0
}

/// A heater as a profile writes it: every key optional (docs/machine.md), the missing ones
/// taken from the default heater of its kind, so `[[thermal.hotends]]` with only `power_w = 50`
/// is a 50 W version of the default block rather than an error for the five keys not given.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HeaterKeys {
    power_w: Option<f64>,
    heat_capacity_j_k: Option<f64>,
    loss_w_k: Option<f64>,
    fan_loss_w_k: Option<f64>,
    ambient_c: Option<f64>,
    heater_lag_s: Option<f64>,
    sensor_lag_s: Option<f64>,
}

impl HeaterKeys {
    fn over(self, d: HeaterConfig) -> HeaterConfig {
        HeaterConfig {
            power_w: self.power_w.unwrap_or(d.power_w),
            heat_capacity_j_k: self.heat_capacity_j_k.unwrap_or(d.heat_capacity_j_k),
            loss_w_k: self.loss_w_k.unwrap_or(d.loss_w_k),
            fan_loss_w_k: self.fan_loss_w_k.unwrap_or(d.fan_loss_w_k),
            ambient_c: self.ambient_c.unwrap_or(d.ambient_c),
            heater_lag_s: self.heater_lag_s.unwrap_or(d.heater_lag_s),
            sensor_lag_s: self.sensor_lag_s.unwrap_or(d.sensor_lag_s),
        }
    }
}

/// `[[thermal.hotends]]`, each key missing taken from [`HeaterConfig::hotend_40w`].
pub(crate) fn hotends_with_defaults<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Vec<HeaterConfig>, D::Error> {
    let keys = Vec::<HeaterKeys>::deserialize(d)?;
    Ok(keys.into_iter().map(|k| k.over(HeaterConfig::hotend_40w())).collect())
}

/// `[thermal.bed]`, each key missing taken from [`HeaterConfig::bed_200w`].
pub(crate) fn bed_with_defaults<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Option<HeaterConfig>, D::Error> {
    Ok(Some(HeaterKeys::deserialize(d)?.over(HeaterConfig::bed_200w())))
}

impl HeaterConfig {
    /// A typical 40 W cartridge in an aluminium block (E3D V6 class).
    ///
    /// * `heat_capacity_j_k = 12`: ~10 g of aluminium (0.9 J/(g K)) plus the
    ///   cartridge and nozzle;
    /// * `loss_w_k = 0.1`: ~18.5 W hold 210 C in still air, so full power
    ///   settles near 425 C and a cold start reaches 200 C in about 70 s;
    /// * `fan_loss_w_k = 0.05`: the part fan at 100 % costs ~9 W at 210 C;
    /// * `heater_lag_s = 2`: the cartridge core, ~2 J/K (a 6 x 20 mm
    ///   cartridge of ~3.5 g) behind ~1 W/K of contact to the bore, so
    ///   `tau = C/G ~ 2 s`; `sensor_lag_s = 3`: the thermistor bead in its
    ///   bore. Together 5 s, close to the single lag Marlin's MPC measures
    ///   on this class of hotend (`MPC_SENSOR_RESPONSIVENESS 0.22`/s, i.e.
    ///   4.5 s, Marlin `Configuration.h`). Relay period
    ///   `2 pi sqrt(2 * 3) ~ 15 s` (M303 finds 15.7 s), the low end of M303
    ///   logs from real hotends (18 s on an Artillery Volcano block,
    ///   MarlinFirmware/Configurations#641).
    /// * Cold start to 200 C at full power: about 74 s.
    ///
    /// The lags decide how far the reading keeps falling after the heater
    /// switches back on while the block cools (a lower target, then a
    /// higher one): with the fan on, the block loses ~2 C/s at 200 C with
    /// no heat, the sensor reads `sensor_lag_s * rate` above the block and
    /// the block sinks for about `heater_lag_s` more. An earlier 5 s core
    /// lag made that dip 6 C and tripped Marlin's 20 s heating watch on a
    /// real Cura dual-nozzle file (Marlin issue #5232 describes the same
    /// false alarm on sluggish real hotends).
    pub fn hotend_40w() -> Self {
        Self {
            power_w: 40.0,
            heat_capacity_j_k: 12.0,
            loss_w_k: 0.1,
            fan_loss_w_k: 0.05,
            ambient_c: default_ambient_c(),
            heater_lag_s: 2.0,
            sensor_lag_s: 3.0,
        }
    }

    /// A 200 W heated bed (220 x 220 mm aluminium plate with its sheet).
    ///
    /// * `heat_capacity_j_k = 600`: ~0.45 kg of aluminium plus the sheet;
    /// * `loss_w_k = 1.5`: ~52 W hold 60 C, full power settles near 158 C;
    ///   60 C is reached in about two minutes, 100 C in about five and a half;
    /// * `heater_lag_s = 2`, `sensor_lag_s = 3`: heater pad and a thermistor
    ///   glued under the plate; relay period ~15 s.
    pub fn bed_200w() -> Self {
        Self {
            power_w: 200.0,
            heat_capacity_j_k: 600.0,
            loss_w_k: 1.5,
            fan_loss_w_k: 0.0,
            ambient_c: default_ambient_c(),
            heater_lag_s: 2.0,
            sensor_lag_s: 3.0,
        }
    }

    /// Check every value against its range (see [`CheckRanges`]).
    pub fn validate(&self) -> Result<(), HeaterError> {
        Ok(self.check_ranges(&Table::root())?)
    }
}

/// From a cartridge of a few watts to a large mains bed.
const POWER_W: Range = Range::new(0.1, 5_000.0, "W");
/// From a tiny nozzle block (~1 J/K) to a heavy cast bed.
const HEAT_CAPACITY_J_K: Range = Range::new(0.01, 1_000_000.0, "J/K");
const LOSS_W_K: Range = Range::new(0.000_1, 1_000.0, "W/K");
const FAN_LOSS_W_K: Range = Range::new(0.0, 1_000.0, "W/K");
/// A room a printer works in.
const AMBIENT_C: Range = Range::new(-50.0, 100.0, "°C");
const LAG_S: Range = Range::new(0.0, 600.0, "s");

impl CheckRanges for HeaterConfig {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("power_w", self.power_w, POWER_W)?;
        t.check("heat_capacity_j_k", self.heat_capacity_j_k, HEAT_CAPACITY_J_K)?;
        t.check("loss_w_k", self.loss_w_k, LOSS_W_K)?;
        t.check("fan_loss_w_k", self.fan_loss_w_k, FAN_LOSS_W_K)?;
        t.check("ambient_c", self.ambient_c, AMBIENT_C)?;
        t.check("heater_lag_s", self.heater_lag_s, LAG_S)?;
        t.check("sensor_lag_s", self.sensor_lag_s, LAG_S)
    }
}

/// A fault injected into a heater.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeaterFault {
    /// The cartridge wire is off: no power reaches the block.
    CartridgeDisconnected,
    /// The thermistor is open or shorted.
    Sensor(SensorFault),
}

/// One simulated heater: block temperature, lagged sensor temperature and
/// the injected faults.
#[derive(Debug, Clone, PartialEq)]
pub struct Heater {
    cfg: HeaterConfig,
    block_c: f64,
    sensor_c: f64,
    heat_flow_w: f64,
    fan_fraction: f64,
    cartridge_disconnected: bool,
    sensor_fault: Option<SensorFault>,
    last_power_w: f64,
    /// The step response kept for the next step, and the steps the plant is known still under.
    memo: Memo,
}

/// The plant's exact response over one step of `t_s` with loss conductance `k_w_k`: measured
/// from where the chain settles for the held power, the fraction of each stage's distance left
/// at the end, and what each stage passes on to the next (see `cascade`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Response {
    t_s: f64,
    k_w_k: f64,
    flow: f64,
    block: f64,
    block_from_flow: f64,
    sensor: f64,
    sensor_from_block: f64,
    sensor_from_flow: f64,
}

impl Response {
    fn new(cfg: &HeaterConfig, k_w_k: f64, t_s: f64) -> Self {
        let block = Decay::new(k_w_k / cfg.heat_capacity_j_k, t_s);
        let lagged = |tau_s: f64| (tau_s > 0.0).then(|| Decay::new(1.0 / tau_s, t_s));
        let heater = lagged(cfg.heater_lag_s);
        let sensor = lagged(cfg.sensor_lag_s);
        // A watt of heat-flow shortfall pulls the block toward ambient at b/k kelvin per second.
        let pull = block.rate / k_w_k;
        let mut r = Self {
            t_s,
            k_w_k,
            flow: 0.0,
            block: block.factor,
            block_from_flow: 0.0,
            sensor: 0.0,
            sensor_from_block: 0.0,
            sensor_from_flow: 0.0,
        };
        if let Some(h) = heater {
            r.flow = h.factor;
            r.block_from_flow = -pull * cascade::divided2(h, block, t_s);
        }
        if let Some(s) = sensor {
            r.sensor = s.factor;
            r.sensor_from_block = -s.rate * cascade::divided2(block, s, t_s);
            if let Some(h) = heater {
                r.sensor_from_flow = s.rate * pull * cascade::divided3(h, block, s, t_s);
            }
        }
        r
    }
}

impl Heater {
    /// A heater at ambient temperature.
    pub fn new(cfg: HeaterConfig) -> Result<Self, HeaterError> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            block_c: cfg.ambient_c,
            sensor_c: cfg.ambient_c,
            heat_flow_w: 0.0,
            fan_fraction: 0.0,
            cartridge_disconnected: false,
            sensor_fault: None,
            last_power_w: 0.0,
            memo: Memo::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &HeaterConfig {
        &self.cfg
    }

    /// True block temperature, C.
    pub fn block_c(&self) -> f64 {
        self.block_c
    }

    /// Temperature at the thermistor (the block seen through the lag), C.
    pub fn sensor_c(&self) -> f64 {
        self.sensor_c
    }

    /// Electrical power drawn during the last step, W.
    pub fn last_power_w(&self) -> f64 {
        self.last_power_w
    }

    /// Heat flowing into the block (the lagged electrical power), W.
    pub fn heat_flow_w(&self) -> f64 {
        self.heat_flow_w
    }

    /// Set both block and sensor temperature (for a warm start); the heat
    /// flow restarts from zero (the heater was off).
    pub fn set_temperature(&mut self, celsius: f64) {
        self.block_c = celsius;
        self.sensor_c = celsius;
        self.heat_flow_w = 0.0;
        self.memo.moved();
    }

    /// Part-cooling fan fraction, clamped to 0..=1.
    pub fn set_fan(&mut self, fraction: f64) {
        self.fan_fraction = if fraction.is_nan() { 0.0 } else { fraction.clamp(0.0, 1.0) };
    }

    /// Inject a fault. A sensor fault replaces any earlier sensor fault.
    pub fn inject(&mut self, fault: HeaterFault) {
        match fault {
            HeaterFault::CartridgeDisconnected => self.cartridge_disconnected = true,
            HeaterFault::Sensor(s) => self.sensor_fault = Some(s),
        }
    }

    /// Remove every injected fault.
    pub fn clear_faults(&mut self) {
        self.cartridge_disconnected = false;
        self.sensor_fault = None;
    }

    /// The active sensor fault, if any.
    pub fn sensor_fault(&self) -> Option<SensorFault> {
        self.sensor_fault
    }

    /// Advance the plant by `dt_s` with heater duty `duty` (0..=1, clamped),
    /// using the exact solution for constant inputs (module docs).
    pub fn step(&mut self, duty: f64, dt_s: f64) {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return;
        }
        let duty = if duty.is_nan() { 0.0 } else { duty.clamp(0.0, 1.0) };
        // The response is worked out once and reused by the steps of about the same length
        // (`memo`'s notes).
        let r = self.memo.response(&self.cfg, dt_s, self.loss_w_k());
        if duty == 0.0 {
            let before = self.state_bits();
            self.advance(0.0, &r);
            if self.state_bits() == before {
                self.memo.still(self.memo.kept());
                return;
            }
        } else {
            // Only a heater off comes to rest: a step with power is not looked at (a print's
            // firmware loop costs what it did).
            self.advance(duty, &r);
        }
        self.memo.moved();
    }

    /// A step of `dt_s` with the heater off, if it leaves the plant as it is, to the bit
    /// (`memo`'s notes): known for the steps it was found still under since it last moved, tried
    /// on a copy for another; only the step response kept then moves, as the step would move it.
    /// False, with the plant as it was, if the step would move it (a plant that moved at its last
    /// step has not settled: false at once). Keeping the response of a step the caller then runs
    /// changes nothing: the step keeps the same one.
    pub(crate) fn rest(&mut self, dt_s: f64) -> bool {
        let k_w_k = self.loss_w_k();
        let key = self.memo.key_for(dt_s, k_w_k);
        if !self.memo.is_still(key) {
            if !self.memo.knows_still() {
                return false;
            }
            let mut copy = self.clone();
            copy.advance(0.0, &Response::new(&self.cfg, key.k_w_k, key.t_s));
            if copy.state_bits() != self.state_bits() {
                return false;
            }
            self.memo.still(key);
        }
        self.memo.keep(dt_s, k_w_k);
        true
    }

    /// The loss conductance with the fan as it is, W/K.
    fn loss_w_k(&self) -> f64 {
        self.cfg.loss_w_k + self.fan_fraction * self.cfg.fan_loss_w_k
    }

    /// What a step changes, to the bit.
    fn state_bits(&self) -> [u64; 4] {
        [self.heat_flow_w, self.block_c, self.sensor_c, self.last_power_w].map(f64::to_bits)
    }

    /// The step of response `r` with `duty` held.
    fn advance(&mut self, duty: f64, r: &Response) {
        let power_w = if self.cartridge_disconnected { 0.0 } else { duty * self.cfg.power_w };
        // Everything is measured from where the chain settles with this power held.
        let settle_c = self.cfg.ambient_c + power_w / r.k_w_k;
        let flow0_w = if self.cfg.heater_lag_s > 0.0 { self.heat_flow_w - power_w } else { 0.0 };
        let block0_c = self.block_c - settle_c;
        let sensor0_c = self.sensor_c - settle_c;
        self.heat_flow_w = power_w + flow0_w * r.flow;
        self.block_c = settle_c + block0_c * r.block + flow0_w * r.block_from_flow;
        self.sensor_c = if self.cfg.sensor_lag_s > 0.0 {
            settle_c + sensor0_c * r.sensor + block0_c * r.sensor_from_block + flow0_w * r.sensor_from_flow
        } else {
            self.block_c
        };
        self.last_power_w = power_w;
    }

    /// The raw ADC reading the firmware sees through `thermistor`: the
    /// model's value at the sensor temperature, or the rail for a faulty
    /// sensor.
    pub fn read_adc(&self, thermistor: &BetaThermistor) -> u32 {
        match self.sensor_fault {
            Some(fault) => fault.adc(thermistor.raw_max()),
            None => thermistor.adc_at(self.sensor_c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hotend() -> Heater {
        Heater::new(HeaterConfig::hotend_40w()).unwrap()
    }

    /// The default hotend without either lag: a pure first-order block.
    fn no_lag() -> HeaterConfig {
        HeaterConfig { heater_lag_s: 0.0, sensor_lag_s: 0.0, ..HeaterConfig::hotend_40w() }
    }

    /// Seconds of full power until the sensor reaches `target_c`.
    fn time_to(heater: &mut Heater, target_c: f64, dt_s: f64) -> f64 {
        let mut t_s = 0.0;
        while heater.sensor_c() < target_c && t_s < 3600.0 {
            heater.step(1.0, dt_s);
            t_s += dt_s;
        }
        t_s
    }

    #[test]
    fn step_matches_closed_form() {
        let mut h = Heater::new(no_lag()).unwrap();
        h.step(1.0, 60.0);
        // T_inf = 25 + 40/0.1 = 425; tau = 12/0.1 = 120 s.
        let expected = 425.0 - 400.0 * (-0.5f64).exp();
        assert!((h.block_c() - expected).abs() < 1e-9);
        // Many small steps give the same answer (exactness in dt).
        let mut h2 = Heater::new(no_lag()).unwrap();
        for _ in 0..600 {
            h2.step(1.0, 0.1);
        }
        assert!((h2.block_c() - expected).abs() < 1e-9);
    }

    /// The plant with both lags, integrated by fourth-order Runge-Kutta in steps of 1 ms.
    fn runge_kutta(cfg: &HeaterConfig, duty: f64, fan: f64, start: [f64; 3], t_s: f64) -> [f64; 3] {
        let k = cfg.loss_w_k + fan * cfg.fan_loss_w_k;
        let p = duty * cfg.power_w;
        let f = |y: [f64; 3]| {
            [
                (p - y[0]) / cfg.heater_lag_s,
                (y[0] - k * (y[1] - cfg.ambient_c)) / cfg.heat_capacity_j_k,
                (y[1] - y[2]) / cfg.sensor_lag_s,
            ]
        };
        let add = |y: [f64; 3], d: [f64; 3], h: f64| [y[0] + h * d[0], y[1] + h * d[1], y[2] + h * d[2]];
        let h = 1e-3;
        let mut y = start;
        for _ in 0..(t_s / h).round() as usize {
            let k1 = f(y);
            let k2 = f(add(y, k1, h / 2.0));
            let k3 = f(add(y, k2, h / 2.0));
            let k4 = f(add(y, k3, h));
            y = std::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        }
        y
    }

    #[test]
    fn lagged_step_matches_numerical_integration() {
        let equal_lags = HeaterConfig { heater_lag_s: 2.5, sensor_lag_s: 2.5, ..HeaterConfig::hotend_40w() };
        for cfg in [HeaterConfig::hotend_40w(), HeaterConfig::bed_200w(), equal_lags] {
            for (duty, fan) in [(1.0, 0.0), (0.3, 1.0), (0.0, 0.5)] {
                let mut h = Heater::new(cfg).unwrap();
                h.set_fan(fan);
                // A state off every equilibrium: flow, block and sensor all different.
                h.heat_flow_w = 0.6 * cfg.power_w;
                h.block_c = 180.0;
                h.sensor_c = 150.0;
                let want = runge_kutta(&cfg, duty, fan, [h.heat_flow_w, 180.0, 150.0], 7.0);
                h.step(duty, 7.0);
                let got = [h.heat_flow_w(), h.block_c(), h.sensor_c()];
                for (g, w) in got.iter().zip(want) {
                    assert!((g - w).abs() < 1e-8, "{cfg:?} duty {duty} fan {fan}: {got:?} vs {want:?}");
                }
            }
        }
    }

    #[test]
    fn the_cached_response_is_not_state() {
        let (mut a, mut b) = (hotend(), hotend());
        a.step(0.0, 0.1);
        b.step(0.0, 0.25);
        // Both still at ambient with no power; only what they cached differs.
        assert_eq!(a, b);
        b.step(1.0, 0.1);
        assert_ne!(a, b);
    }

    /// At a clock of ten days the periods between the firmware's sample instants differ by more
    /// than the 1e-9 within which a step reuses the kept response, so steps at rest keep
    /// changing it; a rest (the loop passed over) keeps the one each step would, and the first
    /// step with power after it gives the same temperatures.
    #[test]
    fn a_rest_keeps_the_step_response_a_step_would() {
        let periods: Vec<f64> =
            (8_640_001u64..8_650_000).map(|k| k as f64 * 0.1 - (k - 1) as f64 * 0.1).collect();
        let (mut stepped, mut rested) = (hotend(), hotend());
        stepped.step(0.0, periods[0]);
        rested.step(0.0, periods[0]);
        let mut changes = 0;
        for &h_s in &periods {
            let kept = stepped.memo.kept();
            stepped.step(0.0, h_s);
            changes += usize::from(stepped.memo.kept() != kept);
            assert!(rested.rest(h_s));
            assert_eq!(rested.memo.kept(), stepped.memo.kept());
        }
        assert!(changes > 1000, "{changes}");
        stepped.step(1.0, periods[1]);
        rested.step(1.0, periods[1]);
        assert_eq!(rested.state_bits(), stepped.state_bits());
        assert!(rested.block_c() > 25.0);
    }

    /// Off and cooling, a plant comes to rest within rounding of ambient, not at it, and stays
    /// there to the bit under the steps it came to rest with (a long step takes it on to
    /// ambient); a step that moves it forgets that it was still.
    #[test]
    fn a_cooled_plant_stays_still_above_ambient() {
        let mut h = hotend();
        h.set_temperature(200.0);
        assert!(!h.rest(0.1), "it moved at its last change");
        let mut steps = 0;
        while !h.rest(0.1) {
            h.step(0.0, 0.1);
            steps += 1;
            assert!(steps < 200_000, "not still after {steps} steps: {} C", h.block_c());
        }
        assert!(h.block_c() > 25.0 && h.block_c() - 25.0 < 1e-11, "{}", h.block_c());
        h.step(0.0, 0.1);
        assert!(h.rest(0.1) && !h.rest(1000.0));
        h.step(0.5, 0.1);
        assert!(!h.rest(0.1));
    }

    #[test]
    fn split_steps_give_the_same_temperatures() {
        let mut whole = hotend();
        let mut split = hotend();
        whole.step(0.8, 10.0);
        for dt in [0.013, 2.5, 0.1, 4.387, 3.0] {
            split.step(0.8, dt);
        }
        assert!((whole.block_c() - split.block_c()).abs() < 1e-10);
        assert!((whole.sensor_c() - split.sensor_c()).abs() < 1e-10);
        assert!((whole.heat_flow_w() - split.heat_flow_w()).abs() < 1e-10);
    }

    #[test]
    fn hotend_reaches_200_in_plausible_time() {
        let mut h = hotend();
        let t_s = time_to(&mut h, 200.0, 0.1);
        // -120 ln(1 - 175/400) = 69.0 s, plus ~2 s + 3 s of lags.
        assert!((73.0..75.0).contains(&t_s), "{t_s}");
    }

    #[test]
    fn bed_reaches_60_in_about_two_minutes() {
        let mut b = Heater::new(HeaterConfig::bed_200w()).unwrap();
        let t_s = time_to(&mut b, 60.0, 0.5);
        // -400 ln(1 - 35/133.3) = 122 s, plus ~2 s + 3 s of lags.
        assert!((125.0..130.0).contains(&t_s), "{t_s}");
    }

    #[test]
    fn holds_at_equilibrium_duty() {
        let mut h = Heater::new(no_lag()).unwrap();
        h.set_temperature(210.0);
        // 0.1 W/K * 185 K = 18.5 W = duty 0.4625.
        for _ in 0..1000 {
            h.step(18.5 / 40.0, 0.1);
        }
        assert!((h.block_c() - 210.0).abs() < 1e-9);
    }

    #[test]
    fn fan_cools_the_block() {
        let mut h = Heater::new(no_lag()).unwrap();
        h.set_temperature(210.0);
        h.set_fan(1.0);
        for _ in 0..10_000 {
            h.step(18.5 / 40.0, 0.1);
        }
        // Settles at 25 + 18.5 / 0.15 = 148.3 C.
        assert!((h.block_c() - (25.0 + 18.5 / 0.15)).abs() < 1e-3);
    }

    #[test]
    fn heat_flow_lags_power() {
        let mut h = hotend();
        h.step(1.0, 2.0);
        // One time constant (2 s): 40 W * (1 - 1/e) = 25.3 W.
        assert!((h.heat_flow_w() - 40.0 * (1.0 - (-1.0f64).exp())).abs() < 1e-9);
        assert_eq!(h.last_power_w(), 40.0);
    }

    #[test]
    fn sensor_lags_block() {
        let mut h = hotend();
        h.step(1.0, 1.0);
        assert!(h.sensor_c() < h.block_c());
        assert!(h.sensor_c() > 25.0);
    }

    #[test]
    fn disconnected_cartridge_delivers_nothing() {
        let mut h = hotend();
        h.inject(HeaterFault::CartridgeDisconnected);
        h.step(1.0, 30.0);
        assert_eq!(h.block_c(), 25.0);
        assert_eq!(h.last_power_w(), 0.0);
        h.clear_faults();
        h.step(1.0, 1.0);
        assert_eq!(h.last_power_w(), 40.0);
    }

    #[test]
    fn sensor_faults_read_rails() {
        let th = BetaThermistor::default();
        let mut h = hotend();
        assert_eq!(h.read_adc(&th), th.adc_at(25.0));
        h.inject(HeaterFault::Sensor(SensorFault::Open));
        assert_eq!(h.read_adc(&th), 16368);
        h.inject(HeaterFault::Sensor(SensorFault::Shorted));
        assert_eq!(h.read_adc(&th), 0);
    }

    #[test]
    fn config_rejects_unknown_keys_and_bad_values() {
        let toml_ok = "power_w = 40.0\nheat_capacity_j_k = 12.0\nloss_w_k = 0.1\n";
        let cfg: HeaterConfig = toml::from_str(toml_ok).unwrap();
        assert_eq!(cfg.ambient_c, 25.0);
        assert_eq!(cfg.sensor_lag_s, 0.0);
        let unknown = format!("{toml_ok}watts = 3\n");
        assert!(toml::from_str::<HeaterConfig>(&unknown).is_err());
        let bad = HeaterConfig { loss_w_k: 0.0, ..HeaterConfig::hotend_40w() };
        assert_eq!(
            Heater::new(bad).unwrap_err().to_string(),
            "loss_w_k = 0 is out of range: 0.0001 to 1000 W/K"
        );
    }

    #[test]
    fn heater_id_prints_like_marlin() {
        assert_eq!(HeaterId::Hotend(0).to_string(), "0");
        assert_eq!(HeaterId::Bed.to_string(), "bed");
    }
}
