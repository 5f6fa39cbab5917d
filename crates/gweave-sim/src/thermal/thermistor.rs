//! Thermistor: the NTC beta model of the physical sensor and the firmware's
//! `(adc, celsius)` lookup table.
//!
//! # The sensor circuit
//!
//! An NTC thermistor sits between the ADC input and ground, with a pull-up
//! resistor `R_p` to the ADC reference. The ADC therefore reads the divider
//! fraction
//!
//! ```text
//!   adc / adc_full = R(T) / (R(T) + R_p)
//! ```
//!
//! and the thermistor follows the beta model (Steinhart-Hart with only the
//! first-order term, see the Wikipedia article "Thermistor", section
//! "B or beta parameter equation"):
//!
//! ```text
//!   R(T) = R25 * exp(B * (1/T - 1/T25))      T in kelvin, T25 = 298.15 K
//!   1/T  = 1/T25 + ln(R/R25) / B
//! ```
//!
//! Marlin's thermistor type 1 is a 100 kOhm NTC with B = 4092 on a 4.7 kOhm
//! pull-up, read by a 10-bit ADC whose samples are summed `OVERSAMPLENR = 16`
//! times, so the raw value spans `0..=1023*16`
//! (`Marlin/src/module/thermistor/thermistor_1.h`). We do not copy that table:
//! [`BetaThermistor::table`] generates one from the model.
//!
//! # The firmware side
//!
//! The firmware converts a raw reading with a table of `(adc, celsius)` pairs
//! sorted by adc: binary search for the bracketing pair, linear interpolation
//! between them, and clamping to the first/last entry outside the table (the
//! seed document 002 does the same with a linear scan).
//!
//! Sensor faults follow from the circuit: an **open** thermistor leaves only
//! the pull-up, so the ADC reads full scale (the table clamps to its coldest
//! entry and MINTEMP fires); a **shorted** one pulls the input to ground, the
//! ADC reads ~0 (the table clamps to its hottest entry and MAXTEMP fires).

use gweave::settings::{CheckRanges, Table};
use gweave::{OutOfRange, Range};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::motion::rounding::round_i64;

/// 0 degrees Celsius in kelvin.
const KELVIN_OFFSET: f64 = 273.15;
/// Reference temperature of `r25_ohm`, in Celsius.
const T25_C: f64 = 25.0;

/// Resistances of NTC thermistors and pull-ups on printer boards (1 kOhm to 10 MOhm).
const RESISTANCE_OHM: Range = Range::new(1.0, 10_000_000.0, "Ω");
/// Beta coefficients of NTC thermistors (about 3000 to 5000 K).
const BETA_K: Range = Range::new(100.0, 20_000.0, "K");
/// Up to a 16-bit ADC.
const ADC_MAX: Range = Range::new(1.0, 65_535.0, "");
/// `OVERSAMPLENR`; with a 16-bit ADC the sum still fits 32 bits.
const OVERSAMPLE: Range = Range::new(1.0, 1_024.0, "");

impl CheckRanges for BetaThermistor {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("r25_ohm", self.r25_ohm, RESISTANCE_OHM)?;
        t.check("beta_k", self.beta_k, BETA_K)?;
        t.check("pullup_ohm", self.pullup_ohm, RESISTANCE_OHM)?;
        t.count("adc_max", self.adc_max, ADC_MAX)?;
        t.count("oversample", self.oversample, OVERSAMPLE)
    }
}

/// Errors building a thermistor model or table.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ThermistorError {
    #[error(transparent)]
    Range(#[from] OutOfRange),
    #[error("thermistor table needs at least two entries, got {0}")]
    TooShort(usize),
    #[error("thermistor table adc values must strictly increase (entry {index})")]
    AdcNotIncreasing { index: usize },
    #[error("thermistor table temperatures must be strictly monotonic (entry {index})")]
    TempNotMonotonic { index: usize },
    #[error("table range {t_min_c}..{t_max_c} C with step {step_c} C is empty or invalid")]
    BadRange { t_min_c: f64, t_max_c: f64, step_c: f64 },
    /// A thermistor table file that cannot be read (see [`crate::thermal::thermistor_csv`]).
    #[error("line {line}: {message}")]
    Csv { line: usize, message: String },
}

/// A physical NTC thermistor on a pull-up divider read by an oversampling ADC.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BetaThermistor {
    /// Resistance at 25 C, ohm.
    pub r25_ohm: f64,
    /// Beta coefficient, kelvin.
    pub beta_k: f64,
    /// Pull-up resistor to the ADC reference, ohm.
    pub pullup_ohm: f64,
    /// Full-scale value of one ADC sample (1023 for 10 bits).
    pub adc_max: u32,
    /// Number of samples summed per reading (Marlin's `OVERSAMPLENR`).
    pub oversample: u32,
}

impl Default for BetaThermistor {
    /// Marlin thermistor type 1: 100 kOhm, B 4092, 4.7 kOhm pull-up, 10-bit
    /// ADC, oversampling 16.
    fn default() -> Self {
        Self { r25_ohm: 100_000.0, beta_k: 4092.0, pullup_ohm: 4_700.0, adc_max: 1023, oversample: 16 }
    }
}

impl BetaThermistor {
    /// Check every parameter against its range (see [`CheckRanges`]).
    pub fn validate(&self) -> Result<(), ThermistorError> {
        Ok(self.check_ranges(&Table::root())?)
    }

    /// Largest raw reading: `adc_max * oversample` (16368 for Marlin).
    pub fn raw_max(&self) -> u32 {
        self.adc_max * self.oversample
    }

    /// Thermistor resistance at `celsius`, from the beta equation.
    pub fn resistance_ohm(&self, celsius: f64) -> f64 {
        let t_k = celsius + KELVIN_OFFSET;
        let t25_k = T25_C + KELVIN_OFFSET;
        self.r25_ohm * (self.beta_k * (1.0 / t_k - 1.0 / t25_k)).exp()
    }

    /// Raw oversampled reading for a sensor at `celsius`, rounded.
    ///
    /// The sum of `oversample` samples is modelled as resolving a fraction of
    /// one count (ADC noise dithers the samples), so the result is
    /// `round(raw_max * R / (R + R_p))`.
    pub fn adc_at(&self, celsius: f64) -> u32 {
        let r = self.resistance_ohm(celsius);
        let frac = r / (r + self.pullup_ohm);
        // `frac` is within [0, 1], so the product fits the raw range.
        round_i64(frac * f64::from(self.raw_max())).clamp(0, i64::from(self.raw_max())) as u32
    }

    /// Exact model temperature for a raw reading (inverse of [`adc_at`]
    /// before rounding). Returns `None` at the rails, where the divider
    /// equation has no finite solution (open or shorted sensor).
    ///
    /// [`adc_at`]: BetaThermistor::adc_at
    pub fn celsius_at(&self, adc: u32) -> Option<f64> {
        if adc == 0 || adc >= self.raw_max() {
            return None;
        }
        let frac = f64::from(adc) / f64::from(self.raw_max());
        let r = self.pullup_ohm * frac / (1.0 - frac);
        let inv_t = 1.0 / (T25_C + KELVIN_OFFSET) + (r / self.r25_ohm).ln() / self.beta_k;
        Some(1.0 / inv_t - KELVIN_OFFSET)
    }

    /// Generate a firmware table from the model: one entry per `step_c`
    /// from `t_min_c` to `t_max_c` (inclusive), sorted by adc. Temperatures
    /// whose rounded adc collides with a neighbour's are dropped, so adc
    /// strictly increases.
    pub fn table(&self, t_min_c: f64, t_max_c: f64, step_c: f64) -> Result<ThermistorTable, ThermistorError> {
        self.validate()?;
        let bad_range = ThermistorError::BadRange { t_min_c, t_max_c, step_c };
        if !(t_min_c.is_finite() && t_max_c.is_finite() && step_c.is_finite())
            || step_c <= 0.0
            || t_max_c <= t_min_c
            || t_min_c <= -KELVIN_OFFSET
        {
            return Err(bad_range);
        }
        let count = ((t_max_c - t_min_c) / step_c).floor() as usize + 1;
        // Hottest first: NTC adc rises as the temperature falls.
        let mut entries: Vec<(u32, f64)> = Vec::with_capacity(count);
        for i in (0..count).rev() {
            let celsius = t_min_c + step_c * i as f64;
            let adc = self.adc_at(celsius);
            if entries.last().is_some_and(|&(last, _)| last >= adc) {
                continue;
            }
            entries.push((adc, celsius));
        }
        ThermistorTable::new(entries)
    }
}

/// Which way a thermistor has failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorFault {
    /// Broken wire: only the pull-up remains, the ADC reads full scale.
    Open,
    /// Short circuit: the input is at ground, the ADC reads zero.
    Shorted,
}

impl SensorFault {
    /// The raw reading a faulty sensor produces.
    pub fn adc(self, raw_max: u32) -> u32 {
        match self {
            SensorFault::Open => raw_max,
            SensorFault::Shorted => 0,
        }
    }
}

/// A firmware lookup table of `(raw adc, celsius)` pairs, strictly
/// increasing in adc and strictly monotonic in temperature (decreasing for an
/// NTC, increasing for a PTC).
#[derive(Debug, Clone, PartialEq)]
pub struct ThermistorTable {
    entries: Vec<(u32, f64)>,
}

impl ThermistorTable {
    /// Validate and wrap a table.
    pub fn new(entries: Vec<(u32, f64)>) -> Result<Self, ThermistorError> {
        if entries.len() < 2 {
            return Err(ThermistorError::TooShort(entries.len()));
        }
        let falling = entries[1].1 < entries[0].1;
        for (index, pair) in entries.windows(2).enumerate() {
            let ((a0, t0), (a1, t1)) = (pair[0], pair[1]);
            if a1 <= a0 {
                return Err(ThermistorError::AdcNotIncreasing { index: index + 1 });
            }
            let ok = if falling { t1 < t0 } else { t1 > t0 };
            if !ok || !t1.is_finite() || !t0.is_finite() {
                return Err(ThermistorError::TempNotMonotonic { index: index + 1 });
            }
        }
        Ok(Self { entries })
    }

    /// The `(adc, celsius)` pairs, ascending by adc.
    pub fn entries(&self) -> &[(u32, f64)] {
        &self.entries
    }

    /// Temperature for a raw reading: binary search for the bracketing pair,
    /// then linear interpolation; readings outside the table clamp to the
    /// end entries.
    pub fn celsius(&self, adc: u32) -> f64 {
        self.interpolate(adc, self.bracket(adc))
    }

    /// [`Self::celsius`] for a reading near the last one: `hint` is the bracket the last
    /// reading fell in, and is updated. A heater's reading moves by a fraction of a table step
    /// between two samples, so the bracket is usually checked, not searched for.
    pub fn celsius_near(&self, adc: u32, hint: &mut usize) -> f64 {
        let e = &self.entries;
        let h = *hint;
        let fits = h < e.len() && e[h].0 >= adc && (h == 0 || e[h - 1].0 < adc);
        if !fits {
            *hint = self.bracket(adc);
        }
        self.interpolate(adc, *hint)
    }

    /// Index of the first entry whose adc is >= the reading.
    fn bracket(&self, adc: u32) -> usize {
        self.entries.partition_point(|&(a, _)| a < adc)
    }

    /// The reading between entries `hi - 1` and `hi`, clamped to the ends.
    fn interpolate(&self, adc: u32, hi: usize) -> f64 {
        let e = &self.entries;
        if hi == 0 {
            return e[0].1;
        }
        if hi == e.len() {
            return e[e.len() - 1].1;
        }
        let (a0, t0) = e[hi - 1];
        let (a1, t1) = e[hi];
        t0 + (t1 - t0) * f64::from(adc - a0) / f64::from(a1 - a0)
    }

    /// Inverse lookup: the (rounded) raw reading the table maps to
    /// `celsius`, clamped to the table's adc range.
    pub fn adc(&self, celsius: f64) -> u32 {
        let e = &self.entries;
        let falling = e[1].1 < e[0].1;
        // Position of `celsius` along the table in adc order.
        let hi = e.partition_point(|&(_, t)| if falling { t > celsius } else { t < celsius });
        if hi == 0 {
            return e[0].0;
        }
        if hi == e.len() {
            return e[e.len() - 1].0;
        }
        let (a0, t0) = e[hi - 1];
        let (a1, t1) = e[hi];
        let frac = (celsius - t0) / (t1 - t0);
        (f64::from(a0) + frac * f64::from(a1 - a0)).round() as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn marlin_1_table() -> ThermistorTable {
        BetaThermistor::default().table(-20.0, 400.0, 5.0).unwrap()
    }

    #[test]
    fn model_matches_hand_computed_divider() {
        let th = BetaThermistor::default();
        // At 25 C R = R25, so the fraction is 100k / 104.7k.
        assert!((th.resistance_ohm(25.0) - 100_000.0).abs() < 1e-6);
        let expected = (100_000.0 / 104_700.0 * 16368.0_f64).round() as u32;
        assert_eq!(th.adc_at(25.0), expected);
        assert_eq!(expected, 15633);
        // R(210 C) = 1e5 * exp(4092 * (1/483.15 - 1/298.15)) = 522.4 ohm.
        let r210 = th.resistance_ohm(210.0);
        assert!((r210 - 522.4).abs() < 0.5, "{r210}");
    }

    #[test]
    fn table_is_strictly_monotonic_and_spans_range() {
        let t = marlin_1_table();
        let e = t.entries();
        assert!(e.windows(2).all(|w| w[0].0 < w[1].0 && w[0].1 > w[1].1));
        assert_eq!(e.first().unwrap().1, 400.0);
        assert_eq!(e.last().unwrap().1, -20.0);
        // 85 temperatures from -20 to 400 in 5 C steps, none collide.
        assert_eq!(e.len(), 85);
    }

    #[test]
    fn interpolates_linearly_between_entries() {
        let t = ThermistorTable::new(vec![(100, 300.0), (200, 250.0), (400, 150.0)]).unwrap();
        assert_eq!(t.celsius(100), 300.0);
        assert_eq!(t.celsius(150), 275.0);
        assert_eq!(t.celsius(300), 200.0);
        assert_eq!(t.celsius(350), 175.0);
        // Clamped outside the table.
        assert_eq!(t.celsius(0), 300.0);
        assert_eq!(t.celsius(10_000), 150.0);
        assert_eq!(t.adc(275.0), 150);
        assert_eq!(t.adc(500.0), 100);
        assert_eq!(t.adc(-5.0), 400);
    }

    #[test]
    fn ptc_table_interpolates_too() {
        let t = ThermistorTable::new(vec![(100, 0.0), (300, 100.0)]).unwrap();
        assert_eq!(t.celsius(200), 50.0);
        assert_eq!(t.adc(25.0), 150);
    }

    #[test]
    fn rejects_bad_tables() {
        assert_eq!(ThermistorTable::new(vec![(1, 2.0)]), Err(ThermistorError::TooShort(1)));
        assert_eq!(
            ThermistorTable::new(vec![(1, 2.0), (1, 1.0)]),
            Err(ThermistorError::AdcNotIncreasing { index: 1 })
        );
        assert_eq!(
            ThermistorTable::new(vec![(1, 3.0), (2, 2.0), (3, 2.5)]),
            Err(ThermistorError::TempNotMonotonic { index: 2 })
        );
        assert!(BetaThermistor::default().table(10.0, 5.0, 1.0).is_err());
        let bad = BetaThermistor { beta_k: -1.0, ..BetaThermistor::default() };
        let err = bad.table(0.0, 100.0, 5.0).unwrap_err().to_string();
        assert_eq!(err, "beta_k = -1 is out of range: 100 to 20000 K");
    }

    #[test]
    fn faults_clamp_to_table_ends() {
        let th = BetaThermistor::default();
        let t = marlin_1_table();
        assert_eq!(t.celsius(SensorFault::Open.adc(th.raw_max())), -20.0);
        assert_eq!(t.celsius(SensorFault::Shorted.adc(th.raw_max())), 400.0);
        assert_eq!(th.celsius_at(0), None);
        assert_eq!(th.celsius_at(th.raw_max()), None);
    }

    proptest! {
        /// The generated table reads the modelled sensor back within 0.2 C
        /// up to 300 C (5 C steps, linear interpolation). At 300 C one raw
        /// count is ~0.17 C (slope `raw B / T^2` ~ 5.9 counts/C).
        #[test]
        fn table_reads_model_back(celsius in 0.0f64..300.0) {
            let th = BetaThermistor::default();
            let t = marlin_1_table();
            let read = t.celsius(th.adc_at(celsius));
            prop_assert!((read - celsius).abs() < 0.2, "{celsius} read as {read}");
        }

        /// Above 300 C the divider flattens (~2.9 counts/C at 350 C, ~1.9 at
        /// 380 C), so rounding of the reading and of the table's own adc
        /// values costs up to one count; allow 0.15 C plus one count.
        #[test]
        fn table_reads_model_back_hot(celsius in 300.0f64..400.0) {
            let th = BetaThermistor::default();
            let t = marlin_1_table();
            let read = t.celsius(th.adc_at(celsius));
            let counts_per_c = th.adc_at(celsius - 0.5) - th.adc_at(celsius + 0.5);
            let tol = 0.15 + 1.0 / f64::from(counts_per_c.max(1));
            prop_assert!((read - celsius).abs() < tol, "{celsius} read as {read}, tol {tol}");
        }

        /// Starting from any bracket gives the reading a full search gives.
        #[test]
        fn a_hint_never_changes_the_reading(adc in 0u32..16_400, hint in 0usize..200) {
            let t = marlin_1_table();
            let mut h = hint;
            prop_assert_eq!(t.celsius_near(adc, &mut h), t.celsius(adc));
            let mut again = h;
            prop_assert_eq!(t.celsius_near(adc, &mut again), t.celsius(adc));
            prop_assert_eq!(again, h);
        }

        /// Forward and inverse lookups agree to one count.
        #[test]
        fn inverse_round_trips(celsius in -20.0f64..400.0) {
            let t = marlin_1_table();
            let adc = t.adc(celsius);
            let back = t.adc(t.celsius(adc));
            prop_assert!(back.abs_diff(adc) <= 1);
        }

        /// The exact model inverse undoes the model.
        #[test]
        fn model_inverse(celsius in 0.0f64..300.0) {
            let th = BetaThermistor::default();
            let back = th.celsius_at(th.adc_at(celsius)).unwrap();
            prop_assert!((back - celsius).abs() < 0.5);
        }
    }
}
