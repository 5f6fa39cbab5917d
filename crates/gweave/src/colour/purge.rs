//! How much to purge between two colours.
//!
//! Two estimates:
//! - **From the colours** (`flush_volume_mm3`): the empirical rule OrcaSlicer and
//!   BambuStudio use for their purge matrix (`src/libslic3r/FlushVolCalc.cpp`),
//!   re-derived here from its published form. Colours in `[0, 1]`; HSV chroma
//!   points `z = s v e^{i h}`; hue/saturation distance `hs = 230 min(1.2, |z1 - z2|)`;
//!   luminance `L = 0.3 R + 0.59 G + 0.11 B`; going lighter needs much more than
//!   going darker: `lumi = 560 dL^0.7` if the new colour is lighter, else `80 |dL|`.
//!   The two add like two sides of a triangle with a 120 degree angle:
//!   `V = sqrt(hs^2 + lumi^2 + hs lumi)` mm^3, and never less than 60 mm^3.
//! - **From the hotend** (`Washout`): our own model (no public implementation).
//!   A perfectly stirred mixing chamber of volume `V` washed with new material
//!   keeps the old-colour fraction `c` with `dc/dVp = -c / V`, so
//!   `c(Vp) = exp(-Vp / V)` and the purge for a tolerance `eps` is `V ln(1/eps)`.
//!   A laminar path between chamber and nozzle (volume `Vd`, "dead volume")
//!   only delays this: it flushes as a plug, adding `Vd` before any washout.
//!   Measured transitions on a 4-in-1 hotend are about 90-100 mm^3, melt zones
//!   80-110 mm^3 (published transition measurements of 4-in-1 mixing hotends).

use std::f64::consts::PI;

use super::srgb::Srgb8;

/// OrcaSlicer's floor for a colour change, mm^3.
pub(crate) const MIN_FLUSH_MM3: f64 = 60.0;

/// Why purge settings are refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PurgeError {
    /// A quantity that must be positive is not.
    #[error("{what} must be a positive number, got {value}")]
    NotPositive {
        /// The setting's name, for the message.
        what: &'static str,
        /// The value as given.
        value: f64,
    },
    /// A quantity that must not be negative is.
    #[error("{what} must be a non-negative number, got {value}")]
    Negative {
        /// The setting's name, for the message.
        what: &'static str,
        /// The value as given.
        value: f64,
    },
    /// A tolerance outside (0, 1].
    #[error("tolerance must be within (0, 1], got {0}")]
    Tolerance(f64),
}

fn positive(what: &'static str, value: f64) -> Result<f64, PurgeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(PurgeError::NotPositive { what, value })
    }
}

fn non_negative(what: &'static str, value: f64) -> Result<f64, PurgeError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(PurgeError::Negative { what, value })
    }
}

/// HSV of a colour with channels in `[0, 1]`: hue in radians, saturation, value.
fn hsv(c: Srgb8) -> (f64, f64, f64) {
    let [r, g, b] = [c.r, c.g, c.b].map(|v| f64::from(v) / 255.0);
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let chroma = max - min;
    let sector = if chroma == 0.0 {
        0.0
    } else if max == r {
        ((g - b) / chroma).rem_euclid(6.0)
    } else if max == g {
        (b - r) / chroma + 2.0
    } else {
        (r - g) / chroma + 4.0
    };
    let s = if max == 0.0 { 0.0 } else { chroma / max };
    (sector * PI / 3.0, s, max)
}

fn luminance(c: Srgb8) -> f64 {
    (0.3 * f64::from(c.r) + 0.59 * f64::from(c.g) + 0.11 * f64::from(c.b)) / 255.0
}

/// Purge volume in mm^3 to change from colour `from` to colour `to` (see module docs).
pub(crate) fn flush_volume_mm3(from: Srgb8, to: Srgb8) -> f64 {
    let (h1, s1, v1) = hsv(from);
    let (h2, s2, v2) = hsv(to);
    let (x1, y1) = (s1 * v1 * h1.cos(), s1 * v1 * h1.sin());
    let (x2, y2) = (s2 * v2 * h2.cos(), s2 * v2 * h2.sin());
    let hs = 230.0 * (x1 - x2).hypot(y1 - y2).min(1.2);
    let dl = luminance(to) - luminance(from);
    let lumi = if dl >= 0.0 { 560.0 * dl.powf(0.7) } else { -80.0 * dl };
    (hs * hs + lumi * lumi + hs * lumi).sqrt().max(MIN_FLUSH_MM3)
}

/// A mixing chamber as a washout system (see module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Washout {
    chamber_mm3: f64,
    dead_mm3: f64,
}

impl Washout {
    /// Stirred chamber of `chamber_mm3` (> 0) plus plug-flow `dead_mm3` (>= 0).
    pub fn new(chamber_mm3: f64, dead_mm3: f64) -> Result<Self, PurgeError> {
        Ok(Self {
            chamber_mm3: positive("chamber volume", chamber_mm3)?,
            dead_mm3: non_negative("dead volume", dead_mm3)?,
        })
    }

    /// Fraction of the old colour still coming out after purging `purge_mm3`
    /// (1 while the dead volume is flushing; negative purges count as none).
    pub fn residual_fraction(&self, purge_mm3: f64) -> f64 {
        let washed = (purge_mm3 - self.dead_mm3).max(0.0);
        (-washed / self.chamber_mm3).exp()
    }

    /// Purge needed until at most `tolerance` (0 < tolerance <= 1) of the old colour remains.
    pub fn purge_for_tolerance_mm3(&self, tolerance: f64) -> Result<f64, PurgeError> {
        if !(tolerance > 0.0 && tolerance <= 1.0) {
            return Err(PurgeError::Tolerance(tolerance));
        }
        Ok(self.dead_mm3 + self.chamber_mm3 * (1.0 / tolerance).ln())
    }
}

fn filament_area_mm2(diameter_mm: f64) -> Result<f64, PurgeError> {
    let d = positive("filament diameter", diameter_mm)?;
    Ok(PI * d * d / 4.0)
}

/// Length of filament of `diameter_mm` holding `volume_mm3`.
pub(crate) fn mm3_to_filament_mm(volume_mm3: f64, diameter_mm: f64) -> Result<f64, PurgeError> {
    Ok(volume_mm3 / filament_area_mm2(diameter_mm)?)
}

/// Volume of `length_mm` of filament of `diameter_mm`.
pub(crate) fn filament_mm_to_mm3(length_mm: f64, diameter_mm: f64) -> Result<f64, PurgeError> {
    Ok(length_mm * filament_area_mm2(diameter_mm)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BLACK: Srgb8 = Srgb8::new(0, 0, 0);
    const WHITE: Srgb8 = Srgb8::new(255, 255, 255);

    fn close(got: f64, want: f64, tol: f64) {
        assert!((got - want).abs() < tol, "{got} != {want}");
    }

    #[test]
    fn flush_volumes() {
        // Same colour: the floor.
        assert_eq!(flush_volume_mm3(WHITE, WHITE), MIN_FLUSH_MM3);
        // Black to white: no chroma change, dL = 1 lighter -> 560.
        close(flush_volume_mm3(BLACK, WHITE), 560.0, 1e-9);
        // White to black: darker is cheap, 80 -> above the floor.
        close(flush_volume_mm3(WHITE, BLACK), 80.0, 1e-9);
        // Red to blue: chroma distance sqrt(3) capped at 1.2 -> hs 276;
        // luminance 0.3 -> 0.11 is darker -> 15.2; sqrt(276^2 + 15.2^2 + 276*15.2).
        let red_blue = flush_volume_mm3(Srgb8::new(255, 0, 0), Srgb8::new(0, 0, 255));
        close(red_blue, 80_602.24f64.sqrt(), 1e-6);
        // Yellow to green: 60 degrees apart -> |z1 - z2| = 1 -> hs 230;
        // luminance 0.89 -> 0.59, darker by 0.3 -> 24.
        let y_g = flush_volume_mm3(Srgb8::new(255, 255, 0), Srgb8::new(0, 255, 0));
        close(y_g, (230.0f64 * 230.0 + 24.0 * 24.0 + 230.0 * 24.0).sqrt(), 1e-6);
    }

    #[test]
    fn hsv_of_primaries() {
        let (h, s, v) = hsv(Srgb8::new(0, 0, 255));
        close(h, 4.0 * PI / 3.0, 1e-12);
        assert_eq!((s, v), (1.0, 1.0));
        let (h, s, v) = hsv(Srgb8::new(255, 0, 128));
        close(h.to_degrees(), 360.0 - 30.1176, 1e-3);
        assert_eq!((s, v), (1.0, 1.0));
        assert_eq!(hsv(BLACK), (0.0, 0.0, 0.0));
    }

    #[test]
    fn washout() {
        let w = Washout::new(100.0, 0.0).unwrap();
        close(w.residual_fraction(100.0), (-1.0f64).exp(), 1e-12);
        assert_eq!(w.residual_fraction(0.0), 1.0);
        close(w.purge_for_tolerance_mm3(0.01).unwrap(), 100.0 * 100f64.ln(), 1e-9);
        // The purge for a tolerance leaves exactly that tolerance.
        let laminar = Washout::new(30.0, 20.0).unwrap();
        let p = laminar.purge_for_tolerance_mm3(0.05).unwrap();
        close(p, 20.0 + 30.0 * 20f64.ln(), 1e-9);
        close(laminar.residual_fraction(p), 0.05, 1e-12);
        assert_eq!(laminar.residual_fraction(15.0), 1.0);
        assert_eq!(laminar.purge_for_tolerance_mm3(1.0), Ok(20.0));
    }

    #[test]
    fn washout_rejects_bad_numbers() {
        assert!(Washout::new(0.0, 0.0).is_err());
        assert!(Washout::new(f64::NAN, 0.0).is_err());
        assert!(Washout::new(10.0, -1.0).is_err());
        let w = Washout::new(10.0, 0.0).unwrap();
        assert_eq!(w.purge_for_tolerance_mm3(0.0), Err(PurgeError::Tolerance(0.0)));
        assert!(w.purge_for_tolerance_mm3(f64::NAN).is_err());
        assert!(w.purge_for_tolerance_mm3(1.5).is_err());
    }

    #[test]
    fn filament_conversions() {
        // 1.75 mm filament: 2.405 mm^2, so the mixing seed's 25 mm purge is 60.1 mm^3.
        close(filament_mm_to_mm3(25.0, 1.75).unwrap(), 60.132, 1e-3);
        close(mm3_to_filament_mm(100.0, 1.75).unwrap(), 41.575, 1e-3);
        close(mm3_to_filament_mm(100.0, 2.85).unwrap(), 15.676, 1e-3);
        assert!(mm3_to_filament_mm(100.0, 0.0).is_err());
        assert!(filament_mm_to_mm3(1.0, -1.75).is_err());
    }
}
