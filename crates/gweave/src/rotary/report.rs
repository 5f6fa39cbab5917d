//! What the two rotary jobs report (serialisable, the `--json` documents of `gweave rotary wrap`
//! and `gweave rotary tube`): per layer of a wrap the radius, the angles the beads sweep and
//! where the weld line (flat y = 0) lies; per layer of a tube the radius, handedness, turns,
//! spindle speed and where the layer starts and ends (the next one starts there: there is no
//! seam). The jobs themselves, which write, read back and draw, are [`crate::wrap_file`] and
//! [`crate::tube_file`].
//!
//! The commands' flags and Python's keywords reach the settings as the options declared in
//! [`super::options`]; the settings of custom helical paths (`gweave.write_helical_paths`)
//! come as one JSON document merged over a TOML file ([`merged_settings`]).

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::Serialize;

use super::cylinder::{FeedConvention, RotaryConfig, RotaryUnit};
use super::helix::Handedness;
use super::preview::LayerSummary;
use super::{Result, RotaryError};

/// The machine a program was written for.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MachineReport {
    /// Mandrel diameter, mm.
    pub mandrel_diameter_mm: f64,
    /// Its circumference `pi * D`, mm.
    pub circumference_mm: f64,
    /// Axis letters: axial, rotary, radial.
    pub axes: String,
    /// Unit of the rotary word.
    pub rotary_unit: RotaryUnit,
    /// How F is written.
    pub feed_convention: FeedConvention,
}

impl MachineReport {
    /// The figures of a machine.
    pub fn of(m: &RotaryConfig) -> Self {
        Self {
            mandrel_diameter_mm: m.mandrel_diameter_mm,
            circumference_mm: m.circumference_mm(),
            axes: [m.axial_axis, m.rotary_axis, m.radial_axis].iter().collect(),
            rotary_unit: m.rotary_unit,
            feed_convention: m.feed_convention,
        }
    }
}

/// One layer of a wrapped part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WrapLayer {
    /// What the layer's beads do (the radius is the nozzle's, `R0 + z`).
    #[serde(flatten)]
    pub layer: LayerSummary,
    /// Angle the beads sweep, `theta max - theta min`, degrees. A part that wraps once and
    /// closes sweeps `360 - 360 * w / C` for a bead width `w`.
    pub span_deg: f64,
    /// Where the flat y = 0 (the weld line) lies on this layer, degrees in `[0, 360)`.
    pub seam_deg: f64,
}

/// What `rotary wrap` did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WrapReport {
    /// The flat file.
    pub input: PathBuf,
    /// The written file (`None` for standard output, which is not read back).
    pub output: Option<PathBuf>,
    /// The machine.
    pub machine: MachineReport,
    /// The Diabase mapping was used.
    pub keep_arc_length: bool,
    /// Each layer was wound as one turn of a helix (no weld line).
    pub helical: bool,
    /// Seam angle of layer 0, degrees.
    pub seam_offset_deg: f64,
    /// Seam turn per layer, degrees.
    pub seam_rotation_per_layer_deg: f64,
    /// Chord tolerance on the cylinder, mm.
    pub chord_tolerance_mm: f64,
    /// Per layer, read back.
    pub layers: Vec<WrapLayer>,
    /// Filament of the beads, mm (unretractions not counted).
    pub filament_mm: f64,
    /// Time of every move as the firmware reads F, seconds (no acceleration).
    pub time_s: f64,
}

/// One layer of a tube.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeLayer {
    /// 0-based index.
    pub index: u32,
    /// Bead centreline radius, mm.
    pub radius_mm: f64,
    /// Sense of the helix.
    pub handedness: Handedness,
    /// Turns of the mandrel, end turns included.
    pub turns: f64,
    /// Spindle speed at the print speed, deg/s.
    pub angular_speed_deg_s: f64,
    /// Axial position at the start and the end, mm.
    pub axial_mm: [f64; 2],
    /// Angle at the start and the end (the next layer starts there: no seam), degrees.
    pub theta_deg: [f64; 2],
}

/// What `rotary tube` did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeReport {
    /// The written file (`None` for standard output).
    pub output: Option<PathBuf>,
    /// The machine.
    pub machine: MachineReport,
    /// Tube length, mm.
    pub length_mm: f64,
    /// Layer height, mm.
    pub layer_height_mm: f64,
    /// Bead width, mm.
    pub bead_width_mm: f64,
    /// Axial advance per turn, mm.
    pub pitch_mm: f64,
    /// Handedness reverses every layer.
    pub interweave: bool,
    /// Per layer.
    pub layers: Vec<TubeLayer>,
    /// Filament pushed, mm.
    pub filament_mm: f64,
    /// Its volume, mm^3.
    pub extruded_mm3: f64,
    /// Volume of the closed tube wall `pi ((R0 + N h)^2 - R0^2) L`, mm^3.
    pub wall_volume_mm3: f64,
    /// Time as the firmware reads F, seconds (no acceleration).
    pub print_time_s: f64,
    /// Extruding moves read back from the written file (`None` for standard output).
    pub executed_beads: Option<usize>,
}

/// Settings of type `T` from an optional TOML file with `overrides` (a JSON object, the same
/// keys and tables) merged over it key by key; unknown keys are errors as in the file itself.
///
/// ```
/// use gweave::rotary::{helix::TubeParams, report::merged_settings};
/// let t: TubeParams = merged_settings(None, r#"{"layers": 2, "machine": {"mandrel_diameter_mm": 20}}"#).unwrap();
/// assert_eq!((t.layers, t.machine.mandrel_diameter_mm), (2, 20.0));
/// ```
pub fn merged_settings<T: DeserializeOwned>(toml_file: Option<&Path>, overrides: &str) -> Result<T> {
    let mut base = match toml_file {
        Some(path) => {
            let text = crate::settings::read_text(path)?;
            let table: toml::Table = toml::from_str(&text)?;
            serde_json::to_value(table).map_err(json_error)?
        }
        None => serde_json::Value::Object(serde_json::Map::new()),
    };
    let over: serde_json::Value = serde_json::from_str(overrides).map_err(json_error)?;
    merge(&mut base, over);
    serde_json::from_value(base).map_err(json_error)
}

fn json_error(e: serde_json::Error) -> RotaryError {
    RotaryError::Config { key: "settings", reason: e.to_string() }
}

/// Merges `over` into `base`: objects key by key (recursively), anything else replaces; a
/// null in `over` leaves `base` as it is.
fn merge(base: &mut serde_json::Value, over: serde_json::Value) {
    use serde_json::Value;
    match (base, over) {
        (_, Value::Null) => {}
        (Value::Object(b), Value::Object(o)) => {
            for (key, value) in o.into_iter().filter(|(_, v)| !v.is_null()) {
                match b.get_mut(&key) {
                    Some(slot) => merge(slot, value),
                    None => {
                        let mut fresh = Value::Object(serde_json::Map::new());
                        merge(&mut fresh, value);
                        // A table of nulls only adds an empty table (its defaults).
                        b.insert(key, fresh);
                    }
                }
            }
        }
        (b, o) => *b = o,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotary::helix::TubeParams;

    #[test]
    fn merge_overrides_key_by_key_and_rejects_unknown_keys() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("tube.toml");
        std::fs::write(
            &file,
            "length_mm = 30\n[machine]\nmandrel_diameter_mm = 20\n[print]\nbead_width_mm = 0.5\n",
        )
        .unwrap();
        let t: TubeParams = merged_settings(
            Some(&file),
            r#"{"layers": 2, "print": {"layer_height_mm": 0.3}, "pitch_mm": null}"#,
        )
        .unwrap();
        assert_eq!((t.length_mm, t.layers, t.pitch_mm, t.interweave), (30.0, 2, None, true));
        // Nulls everywhere, nested too, leave every default in place.
        let d: TubeParams =
            merged_settings(None, r#"{"machine": {"mandrel_diameter_mm": 8, "rotary_unit": null}, "print": {"bead_width_mm": null}}"#)
                .unwrap();
        assert_eq!(d, TubeParams::new(RotaryConfig::new(8.0)));
        assert_eq!((t.print.bead_width_mm, t.print.layer_height_mm), (0.5, 0.3));
        let err = merged_settings::<TubeParams>(Some(&file), r#"{"print": {"speed": 3}}"#).unwrap_err();
        assert!(err.to_string().contains("unknown field `speed`"), "{err}");
    }
}
