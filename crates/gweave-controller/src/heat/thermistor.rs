//! Thermistors: from an ADC reading to degrees Celsius.
//!
//! An NTC thermistor sits between the ADC input and ground with a pull-up resistor `R_p` to the
//! 5 V reference, so the 10-bit ADC reads `adc = 1023 R / (R + R_p)`. Its resistance falls as
//! it heats, by the beta model `R(T) = R25 exp(B (1/T - 1/T25))` (T in kelvin, T25 = 298.15 K;
//! Wikipedia, "Thermistor", B parameter equation). Marlin's thermistor type 1 is the EPCOS
//! 100 kΩ with B = 4092 on a 4.7 kΩ pull-up (`MarlinFirmware/Marlin:Marlin/src/module/
//! thermistor/thermistor_1.h`, which tabulates the same part); the table below is computed
//! from that model every 5 °C (the test `type_1_is_the_beta_model` recomputes it), so the
//! firmware and the virtual printer's sensor model agree.
//!
//! Reading a table: binary search for the two entries around the reading, linear
//! interpolation between them, and the end entries outside the table. What the ends mean for
//! safety: an **open** sensor reads full scale, below the table's coldest entry, so 0 °C and
//! MINTEMP; a **short** reads near 0, the hottest entry, 300 °C and MAXTEMP.

/// `(adc, celsius)` pairs, by rising adc (falling temperature): EPCOS 100 kΩ, B 4092, 4.7 kΩ
/// pull-up, 10-bit ADC. 244 bytes.
pub const TYPE_1: [(u16, i16); 61] = [
    (29, 300),
    (31, 295),
    (33, 290),
    (35, 285),
    (37, 280),
    (40, 275),
    (43, 270),
    (46, 265),
    (49, 260),
    (52, 255),
    (56, 250),
    (60, 245),
    (65, 240),
    (70, 235),
    (75, 230),
    (81, 225),
    (88, 220),
    (95, 215),
    (102, 210),
    (111, 205),
    (120, 200),
    (130, 195),
    (141, 190),
    (153, 185),
    (167, 180),
    (181, 175),
    (197, 170),
    (214, 165),
    (233, 160),
    (254, 155),
    (276, 150),
    (300, 145),
    (325, 140),
    (353, 135),
    (382, 130),
    (413, 125),
    (446, 120),
    (480, 115),
    (515, 110),
    (551, 105),
    (587, 100),
    (624, 95),
    (661, 90),
    (697, 85),
    (732, 80),
    (765, 75),
    (797, 70),
    (826, 65),
    (853, 60),
    (878, 55),
    (901, 50),
    (920, 45),
    (938, 40),
    (953, 35),
    (966, 30),
    (977, 25),
    (986, 20),
    (994, 15),
    (1000, 10),
    (1005, 5),
    (1009, 0),
];

/// The table of a Marlin thermistor type, if this core has it.
pub fn table(kind: u8) -> Option<&'static [(u16, i16)]> {
    match kind {
        1 => Some(&TYPE_1),
        _ => None,
    }
}

/// The temperature of a reading, °C: binary search and linear interpolation, clamped to the
/// table's ends.
pub fn celsius(table: &[(u16, i16)], adc: u16) -> f32 {
    let (Some(&first), Some(&last)) = (table.first(), table.last()) else { return 0.0 };
    if adc <= first.0 {
        return f32::from(first.1);
    }
    if adc >= last.0 {
        return f32::from(last.1);
    }
    // The first entry above the reading: `lo` ends at it.
    let (mut lo, mut hi) = (0, table.len() - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if table[mid].0 <= adc {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let ((a0, t0), (a1, t1)) = (table[lo], table[hi]);
    let fraction = f32::from(adc - a0) / f32::from(a1 - a0);
    f32::from(t0) + fraction * f32::from(t1 - t0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn beta_adc(t_c: f64) -> f64 {
        let r = 100_000.0 * (4092.0 * (1.0 / (t_c + 273.15) - 1.0 / 298.15)).exp();
        1023.0 * r / (r + 4700.0)
    }

    #[test]
    fn type_1_is_the_beta_model() {
        for &(adc, t) in &TYPE_1 {
            assert_eq!(f64::from(adc), beta_adc(f64::from(t)).round(), "{t} °C");
        }
    }

    /// The beta model's temperature of a reading.
    fn beta_celsius(adc: u16) -> f64 {
        let r = 4700.0 * f64::from(adc) / (1023.0 - f64::from(adc));
        1.0 / (1.0 / 298.15 + (r / 100_000.0).ln() / 4092.0) - 273.15
    }

    #[test]
    fn readings_interpolate_within_a_degree_of_the_model() {
        for adc in TYPE_1[0].0..=TYPE_1[TYPE_1.len() - 1].0 {
            let (want, got) = (beta_celsius(adc), f64::from(celsius(&TYPE_1, adc)));
            // The entries' adc values are rounded, and one count is 2.5 °C near 300 °C.
            assert!((got - want).abs() < 1.0, "adc {adc}: {got} °C, the model says {want}");
        }
    }

    #[test]
    fn an_open_or_shorted_sensor_reads_the_table_ends() {
        assert_eq!(celsius(&TYPE_1, 1023), 0.0);
        assert_eq!(celsius(&TYPE_1, 0), 300.0);
        assert_eq!(celsius(&TYPE_1, 102), 210.0);
        assert_eq!(celsius(&TYPE_1, 98), 212.857_14);
    }
}
