//! A firmware thermistor table from a CSV file, as the controller seed declares its own: pairs
//! of a sensor value and a temperature, read by linear interpolation between the two pairs that
//! bracket a reading (the seed scans its 31 pairs linearly, Marlin searches its table; the
//! result is the same).
//!
//! ```text
//! # comment lines and blank lines are skipped
//! adc,celsius              # or: resistance_ohm,celsius
//! 23,300
//! 25,295
//! ...
//! ```
//!
//! `adc` is one ADC sample (0 to the profile's `adc_max`, the 0..1023 of the seed's
//! `analogRead`); the firmware's oversampled reading is that times `oversample`.
//! `resistance_ohm` is the thermistor's resistance, turned into the reading through the
//! profile's pull-up divider, `raw = raw_max * R / (R + R_pullup)`. Rows may come in any order;
//! the readings must differ and the temperatures be monotonic in them (an NTC or a PTC).
//!
//! The virtual sensor stays the `[thermal.thermistor]` beta model: the table is how the
//! firmware reads it, so a table that does not describe that sensor reads wrong temperatures,
//! as it would on a real board.

use gweave::Range;

use crate::thermal::thermistor::{BetaThermistor, ThermistorError, ThermistorTable};

/// Temperatures a table may list, °C.
const TABLE_C: Range = Range::new(-273.0, 1_000.0, "°C");
/// Thermistor resistances, Ω.
const TABLE_OHM: Range = Range::new(0.001, 1e9, "Ω");
/// More rows than any firmware table has.
const MAX_ROWS: usize = 10_000;

/// The first column's quantity.
#[derive(Clone, Copy, PartialEq)]
enum Column {
    Adc,
    Resistance,
}

/// Reads a table in the format above; `circuit` gives the ADC and the pull-up.
pub(crate) fn table_from_csv(
    text: &str,
    circuit: &BetaThermistor,
) -> Result<ThermistorTable, ThermistorError> {
    let bad = |line: usize, message: String| ThermistorError::Csv { line, message };
    let mut column = None;
    let mut rows: Vec<(u32, f64)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let text = raw.split('#').next().unwrap_or("").trim();
        if text.is_empty() {
            continue;
        }
        let fields: Vec<&str> = text.split(',').map(str::trim).collect();
        let [first, second] = fields[..] else {
            return Err(bad(line, format!("expected two comma-separated values, got `{text}`")));
        };
        let Some(kind) = column else {
            column = Some(match (first, second) {
                ("adc", "celsius") => Column::Adc,
                ("resistance_ohm", "celsius") => Column::Resistance,
                _ => {
                    return Err(bad(
                        line,
                        format!("the header must be `adc,celsius` or `resistance_ohm,celsius`, got `{text}`"),
                    ))
                }
            });
            continue;
        };
        let number = |s: &str| s.parse::<f64>().map_err(|_| bad(line, format!("`{s}` is not a number")));
        let (value, celsius) = (number(first)?, number(second)?);
        TABLE_C.check("celsius", celsius).map_err(|e| bad(line, e.to_string()))?;
        let raw_max = f64::from(circuit.raw_max());
        let reading = match kind {
            Column::Adc => {
                Range::new(0.0, f64::from(circuit.adc_max), "")
                    .check("adc", value)
                    .map_err(|e| bad(line, e.to_string()))?;
                value * f64::from(circuit.oversample)
            }
            Column::Resistance => {
                TABLE_OHM.check("resistance_ohm", value).map_err(|e| bad(line, e.to_string()))?;
                raw_max * value / (value + circuit.pullup_ohm)
            }
        };
        if rows.len() == MAX_ROWS {
            return Err(bad(line, format!("more than {MAX_ROWS} rows")));
        }
        // Within 0..=raw_max, checked above.
        rows.push((reading.round() as u32, celsius));
    }
    if column.is_none() {
        return Err(bad(0, "no header `adc,celsius` or `resistance_ohm,celsius`".into()));
    }
    rows.sort_by_key(|&(adc, _)| adc);
    ThermistorTable::new(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adc_rows_interpolate_linearly_as_the_seed_does() {
        let circuit = BetaThermistor::default();
        // Unsorted, with comments; 10-bit values scaled by Marlin's oversampling of 16.
        let t = table_from_csv("# seed layout\nadc,celsius\n100, 200\n50,250 # hot\n\n200,150\n", &circuit)
            .unwrap();
        assert_eq!(t.entries(), &[(800, 250.0), (1600, 200.0), (3200, 150.0)]);
        // Halfway between 100 and 200 (raw 1600 and 3200): halfway between 200 and 150 °C.
        assert_eq!(t.celsius(2400), 175.0);
        assert_eq!(t.celsius(100), 250.0, "clamped past the hottest row");
    }

    #[test]
    fn resistance_rows_go_through_the_divider() {
        let circuit = BetaThermistor::default();
        // 4.7 kΩ against the 4.7 kΩ pull-up: half scale, 16368 / 2.
        let t = table_from_csv("resistance_ohm,celsius\n4700,180\n100000,25\n", &circuit).unwrap();
        assert_eq!(t.entries()[0], (8184, 180.0));
    }

    #[test]
    fn errors_name_the_line() {
        let c = BetaThermistor::default();
        let err = |text: &str| table_from_csv(text, &c).unwrap_err().to_string();
        assert!(err("volts,celsius\n").contains("line 1: the header must be"), "{}", err("volts,celsius\n"));
        assert!(err("adc,celsius\n1,x\n").contains("line 2: `x` is not a number"));
        assert!(
            err("adc,celsius\n2000,20\n").contains("line 2") && err("adc,celsius\n2000,20\n").contains("adc")
        );
        assert!(err("adc,celsius\n1,20,3\n").contains("two comma-separated values"));
        assert!(err("adc,celsius\n10,20\n10,30\n").contains("must strictly increase"));
        assert!(err("# nothing\n").contains("no header"));
    }
}
