//! Klipper's checks of each move's extrusion (`Klipper3d/klipper:klippy/kinematics/extruder.py`,
//! `check_move`), which stop the print with an error where Marlin would go on:
//!
//! - an extrude-only or retraction move (no X or Y, or E backwards) longer than
//!   `max_extrude_only_distance` (50 mm by default): "Extrude only move too long";
//! - a printing move whose filament, spread over its length, makes a wider bead than
//!   `max_extrude_cross_section` (by default 4 x `nozzle_diameter`², 0.64 mm² for a 0.4 mm
//!   nozzle): "Move exceeds maximum extrusion". The filament fed per millimetre of path times
//!   the filament's area is the bead's cross-section; a normal line of 0.45 x 0.2 mm is
//!   0.09 mm². What passes it is a blob: a purge line pushed over a few millimetres, the ramming
//!   of a wipe tower, a layer height typed in metres. A move that feeds less than
//!   `nozzle_diameter` x the ratio (a tiny dab) is let through, as Klipper lets it.
//!
//! The nozzle and filament are the printer's `[extruder]` section's; a file sliced for the
//! printer states them in its slicer settings (PrusaSlicer's `nozzle_diameter` and
//! `filament_diameter`, Cura's `machine_nozzle_size` and `material_diameter`), which
//! [`KlipperExtruder::from_settings`] reads.

use std::f64::consts::PI;

use serde::Serialize;

use crate::check::round3;
use crate::gcode::diag::Finding;
use crate::gcode::effect::Move;
use crate::Firmware;

/// A Klipper printer's `[extruder]` limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KlipperExtruder {
    /// `nozzle_diameter`, mm.
    pub nozzle_diameter_mm: f64,
    /// `filament_diameter`, mm.
    pub filament_diameter_mm: f64,
    /// `max_extrude_cross_section`, mm²; 0: Klipper's default, 4 x `nozzle_diameter`².
    pub max_extrude_cross_section_mm2: f64,
    /// `max_extrude_only_distance`, mm (50 by default; 0: no limit).
    pub max_extrude_only_distance_mm: f64,
}

impl Default for KlipperExtruder {
    fn default() -> Self {
        KlipperExtruder {
            nozzle_diameter_mm: 0.4,
            filament_diameter_mm: 1.75,
            max_extrude_cross_section_mm2: 0.0,
            max_extrude_only_distance_mm: 50.0,
        }
    }
}

/// The slicer settings that name the nozzle and the filament: PrusaSlicer's (and Slic3r's,
/// SuperSlicer's, OrcaSlicer's) and Cura's.
const SETTING_KEYS: [&str; 4] =
    ["nozzle_diameter", "filament_diameter", "machine_nozzle_size", "material_diameter"];

/// A nozzle or filament diameter a file may state, mm: anything else is not taken.
const DIAMETER_MM: std::ops::RangeInclusive<f64> = 0.05..=5.0;

impl KlipperExtruder {
    /// These limits with the nozzle and filament the slicer settings in `ends` (a file's ends,
    /// [`crate::gcode::ends::read_ends`], as text) state, each where it does (the first
    /// extruder's of a list such as `0.4,0.4`).
    pub fn from_settings(self, ends: &str) -> KlipperExtruder {
        let settings = crate::gcode::ends::settings(ends, &SETTING_KEYS);
        let diameter = |keys: [&str; 2]| {
            keys.iter()
                .filter_map(|k| settings.get(k))
                .filter_map(|v| v.split(',').next()?.trim().parse::<f64>().ok())
                .find(|d| DIAMETER_MM.contains(d))
        };
        KlipperExtruder {
            nozzle_diameter_mm: diameter(["nozzle_diameter", "machine_nozzle_size"])
                .unwrap_or(self.nozzle_diameter_mm),
            filament_diameter_mm: diameter(["filament_diameter", "material_diameter"])
                .unwrap_or(self.filament_diameter_mm),
            ..self
        }
    }

    /// The widest bead allowed, mm².
    pub fn max_cross_section_mm2(&self) -> f64 {
        match self.max_extrude_cross_section_mm2 {
            0.0 => 4.0 * self.nozzle_diameter_mm * self.nozzle_diameter_mm,
            set => set,
        }
    }

    /// What Klipper stops the print at in `m`, which feeds `e` mm of filament (0 for none).
    pub fn refusal(&self, e: f64, m: &Move) -> Option<Finding> {
        if e == 0.0 {
            return None;
        }
        let xy_len = m.xy_len_mm();
        if xy_len == 0.0 || e < 0.0 {
            let max_mm = self.max_extrude_only_distance_mm;
            return (max_mm > 0.0 && e.abs() > max_mm).then(|| Finding::LongExtrusion {
                firmware: Firmware::Klipper,
                e_mm: round3(e),
                max_mm: max_mm as f32,
            });
        }
        let filament_mm2 = PI / 4.0 * self.filament_diameter_mm * self.filament_diameter_mm;
        let max_mm2 = self.max_cross_section_mm2();
        let max_ratio = max_mm2 / filament_mm2;
        // E per millimetre of the move's path (X, Y and Z: Klipper's `move_d`).
        let ratio = e / m.len_mm();
        if ratio <= max_ratio || e <= self.nozzle_diameter_mm * max_ratio {
            return None;
        }
        Some(Finding::OverExtrusion { area_mm2: round3(ratio * filament_mm2), max_mm2: max_mm2 as f32 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::axes::{Position, E, X, Y};
    use crate::gcode::effect::Path;

    fn line(dx: f64, dy: f64, de: f64) -> Move {
        let from = Position::default();
        let mut to = from;
        to[X] += dx;
        to[Y] += dy;
        to[E] += de;
        Move { from, to, path: Path::Line, rapid: false, feed_mm_min: 1200.0 }
    }

    #[test]
    fn a_bead_wider_than_four_nozzle_squares_stops_the_print() {
        let k = KlipperExtruder::default();
        // 0.64 mm² over a 2.405 mm² filament: 0.266 mm of filament per mm of path at most.
        let check = |dx: f64, de: f64| k.refusal(de, &line(dx, 0.0, de)).map(|f| f.to_string());
        assert_eq!(check(10.0, 0.4), None, "a normal line: 0.096 mm²");
        assert_eq!(check(10.0, 2.6), None, "0.625 mm²: within");
        let blob = check(2.0, 3.0).expect("a blob");
        assert!(blob.contains("3.608 mm²") && blob.contains("0.640 mm²"), "{blob}");
        // A tiny dab passes whatever its ratio: at most 0.4 x 0.266 = 0.106 mm of filament.
        assert_eq!(check(0.1, 0.1), None);
        // Extrude-only and retraction moves are held to max_extrude_only_distance instead.
        assert_eq!(check(0.0, 40.0), None);
        assert!(check(0.0, 60.0).unwrap().contains("Extrude only move too long"));
        assert!(check(5.0, -51.0).unwrap().contains("Extrude only move too long"));
    }

    #[test]
    fn the_slicers_nozzle_and_filament_are_taken_from_the_file() {
        let prusa = "; filament_diameter = 2.85,2.85\n; nozzle_diameter = 0.6,0.4\n";
        let k = KlipperExtruder::default().from_settings(prusa);
        assert_eq!((k.nozzle_diameter_mm, k.filament_diameter_mm), (0.6, 2.85));
        assert!((k.max_cross_section_mm2() - 1.44).abs() < 1e-12);
        let cura = ";SETTING_3 {\"global_quality\": \"[general]\\\\nmachine_nozzle_size = 0.25\\\\nmaterial_diameter = 1.75\\\\n\"}\n";
        let k = KlipperExtruder::default().from_settings(cura);
        assert_eq!((k.nozzle_diameter_mm, k.filament_diameter_mm), (0.25, 1.75));
        // Nothing stated, or nonsense: the limits given stay.
        let k = KlipperExtruder::default().from_settings("; nozzle_diameter = 40\n");
        assert_eq!(k, KlipperExtruder::default());
        // A cross-section set in printer.cfg wins over the default.
        let set = KlipperExtruder { max_extrude_cross_section_mm2: 5.0, ..KlipperExtruder::default() };
        assert_eq!(set.max_cross_section_mm2(), 5.0);
    }
}
