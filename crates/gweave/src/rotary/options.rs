//! The options of `gweave rotary wrap` / `rotary tube` and `gweave.rotary_wrap()` /
//! `rotary_tube()`, declared once ([`crate::options`]): the machine's, which both share
//! ([`MachineOptions`]), and each job's own; and how they lay over the TOML settings.
//!
//! Reading takes two steps, as a file's errors name the file and an option's do not:
//! [`WrapConfig::read`] (or [`TubeParams::read`]) turns the optional TOML text into settings,
//! then `apply` lays the other options over them and validates the result.
//!
//! ```
//! use gweave::rotary::options::{MachineOptions, WrapOptions};
//! use gweave::rotary::wrap::WrapConfig;
//! let machine = MachineOptions { mandrel_diameter: Some(30.0), ..MachineOptions::default() };
//! let mut config = WrapConfig::read(Some("chord_tolerance_mm = 0.05\n"), &machine).unwrap();
//! config.apply(&WrapOptions { machine, seam_rotation: Some(7.5), ..WrapOptions::default() }).unwrap();
//! assert_eq!((config.machine.mandrel_diameter_mm, config.unwrap.seam_rotation_per_layer_deg), (30.0, 7.5));
//! assert_eq!(config.chord_tolerance_mm, 0.05, "a file's value stays unless an option replaces it");
//! ```

use std::path::PathBuf;

use super::cylinder::{FeedConvention, RotaryConfig, RotaryUnit, MANDREL_DIAMETER_MM};
use super::helix::{
    TubeParams, BEAD_WIDTH_MM, CHORD_TOLERANCE_MM, PITCH_MM, SEGMENTS_PER_TURN, TUBE_LAYERS, TUBE_LENGTH_MM,
};
use super::wrap::WrapConfig;
use super::{Result, RotaryError};
use crate::options::Shape;
use crate::range::{ANGLE_DEG, FILAMENT_DIAMETER_MM, LAYER_HEIGHT_MM, SPEED_MM_S, TEMPERATURE_C};

crate::word_option!(FeedConvention);
crate::word_option!(RotaryUnit);

crate::job_options! {
    /// The machine, which `rotary wrap` and `rotary tube` share: a value given replaces the
    /// settings file's.
    pub struct MachineOptions for "rotary" {
        /// Mandrel diameter, mm [default: the config file's `[machine] mandrel_diameter_mm`;
        /// one of them is required].
        mandrel_diameter: Option<f64> = Shape::new("MM").range(MANDREL_DIAMETER_MM),
        /// How the firmware reads F on rotary moves: `nist` (F is the linear X, Z speed;
        /// rotary-only moves in deg/min: LinuxCNC, Marlin's default), `combined` (F =
        /// sqrt(dX^2 + dZ^2 + dA^2)/T: Marlin ARTICULATED_ROBOT_ARM, RRF `M584 S0`) or
        /// `inverse-time` (G93: F = 1/T, T in minutes); `--feed` is an older name [default:
        /// nist].
        feed_convention: Option<FeedConvention> = Shape::new("FEED").aliases(&["feed"]),
        /// Unit of the rotary word: `deg` (`degrees`: a true rotary axis such as A) or `mm`
        /// (of circumference at the mandrel surface: a rotary axis set up as Y) [default: deg].
        rotary_unit: Option<RotaryUnit> = Shape::new("UNIT"),
        /// Axis letters: axial, rotary, radial [default: X,A,Z].
        axes: Option<[char; 3]> = Shape::new("X,A,Z"),
        /// Configuration file (TOML; see examples/rotary/).
        config: Option<PathBuf> = Shape::new("TOML").short('c'),
    }
}

crate::job_options! {
    /// What a wrap is given besides its file: the machine, then how the flat part is wrapped.
    pub struct WrapOptions for "rotary wrap" {
        ..machine: MachineOptions,
        /// Keep flat arc lengths (the Diabase wizard: A = Y*180/(pi*(R + z - z1)), E unchanged).
        keep_arc_length: Option<bool> = Shape::new(""),
        /// Turn every layer this much further than the one below, degrees, so seams do not
        /// stack [default: 0].
        seam_rotation: Option<f64> = Shape::new("DEG").range(ANGLE_DEG),
        /// Wind each layer as one turn of a helix rising one layer height per turn, joined to
        /// the next layer without a step: no weld line (the rotary seed's helical unwrapping).
        helical: bool = Shape::new("").conflicts(&["keep_arc_length", "seam_rotation"]),
        /// Wrap a part wider than the circumference over itself instead of refusing it.
        allow_overlap: bool = Shape::new(""),
        /// Largest chord sagitta on the cylinder, mm (0: one move per flat move) [default:
        /// 0.01].
        chord_tol: Option<f64> = Shape::new("MM").range(CHORD_TOLERANCE_MM.or_zero()),
    }
}

crate::job_options! {
    /// What a tube is given: the machine, then the tube's shape and how it prints.
    pub struct TubeOptions for "rotary tube" {
        ..machine: MachineOptions,
        /// Tube length along the mandrel, mm [default: 50].
        length: Option<f64> = Shape::new("MM").range(TUBE_LENGTH_MM),
        /// Number of layers (`--layers` is an older name) [default: 4].
        layer_count: Option<u32> = Shape::new("N").whole(TUBE_LAYERS).aliases(&["layers"]),
        /// Layer height (radial step), mm [default: 0.2].
        layer_height: Option<f64> = Shape::new("MM").range(LAYER_HEIGHT_MM),
        /// Bead width, mm [default: 0.4].
        bead_width: Option<f64> = Shape::new("MM").range(BEAD_WIDTH_MM),
        /// Axial advance per turn, mm [default: the bead width, a closed wall].
        pitch: Option<f64> = Shape::new("MM").range(PITCH_MM),
        /// Reverse the helix every layer (interweaving); off (`--no-interweave`), every layer
        /// keeps one handedness and the spindle reverses instead [default: on].
        interweave: Option<bool> = Shape::new("").negated(),
        /// At least this many chords per turn [default: as many as the chord tolerance needs].
        segments_per_turn: Option<u32> = Shape::new("N").whole(SEGMENTS_PER_TURN),
        /// Largest chord sagitta, mm [default: 0.01].
        chord_tol: Option<f64> = Shape::new("MM").range(CHORD_TOLERANCE_MM),
        /// Surface speed while printing, mm/s [default: 20].
        speed: Option<f64> = Shape::new("MM_S").range(SPEED_MM_S),
        /// Nozzle temperature, degrees C [default: 190].
        temp: Option<f64> = Shape::new("C").range(TEMPERATURE_C),
        /// Filament diameter, mm [default: 1.75].
        filament_diameter: Option<f64> = Shape::new("MM").range(FILAMENT_DIAMETER_MM),
    }
}

impl MachineOptions {
    /// Settings from an optional TOML document (`parse` validates it). The mandrel diameter, if
    /// given, is laid into the `[machine]` table before it is read, so that a file without one
    /// (the table requires it) can be completed by the flag; without a document it is the
    /// whole machine (`new`), and without either it is an error.
    fn read<T>(
        &self,
        toml: Option<&str>,
        parse: impl FnOnce(&str) -> Result<T>,
        new: impl FnOnce(RotaryConfig) -> T,
    ) -> Result<T> {
        let Some(text) = toml else {
            return match self.mandrel_diameter {
                Some(d) => Ok(new(RotaryConfig::new(d))),
                None => Err(RotaryError::NoMandrel),
            };
        };
        let Some(d) = self.mandrel_diameter else {
            return parse(text);
        };
        let mut table: toml::Table = text.parse()?;
        let machine = table.entry("machine").or_insert_with(|| toml::Table::new().into());
        if let Some(machine) = machine.as_table_mut() {
            machine.insert("mandrel_diameter_mm".into(), d.into());
        }
        parse(&table.to_string())
    }

    /// Lays the options over a machine.
    pub fn apply(&self, machine: &mut RotaryConfig) {
        if let Some(d) = self.mandrel_diameter {
            machine.mandrel_diameter_mm = d;
        }
        if let Some(feed) = self.feed_convention {
            machine.feed_convention = feed;
        }
        if let Some(unit) = self.rotary_unit {
            machine.rotary_unit = unit;
        }
        if let Some([a, r, z]) = self.axes {
            (machine.axial_axis, machine.rotary_axis, machine.radial_axis) = (a, r, z);
        }
    }
}

/// `slot = value` when a value is given.
fn set<T>(slot: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *slot = v;
    }
}

impl WrapConfig {
    /// The settings of the TOML document `toml` (None: the defaults), with `machine`'s mandrel
    /// diameter completing or replacing the file's (see [`MachineOptions`]).
    pub fn read(toml: Option<&str>, machine: &MachineOptions) -> Result<Self> {
        machine.read(toml, Self::from_toml_str, Self::new)
    }

    /// Lays `o` over the settings, then validates the result.
    pub fn apply(&mut self, o: &WrapOptions) -> Result<()> {
        o.machine.apply(&mut self.machine);
        set(&mut self.unwrap.keep_arc_length, o.keep_arc_length);
        set(&mut self.unwrap.seam_rotation_per_layer_deg, o.seam_rotation);
        self.unwrap.helical |= o.helical;
        self.allow_overlap |= o.allow_overlap;
        set(&mut self.chord_tolerance_mm, o.chord_tol);
        self.validate()
    }
}

impl TubeParams {
    /// The tube of the TOML document `toml` (None: the defaults), with `machine`'s mandrel
    /// diameter completing or replacing the file's (see [`MachineOptions`]).
    pub fn read(toml: Option<&str>, machine: &MachineOptions) -> Result<Self> {
        machine.read(toml, Self::from_toml_str, Self::new)
    }

    /// Lays `o` over the tube, then validates the result.
    pub fn apply(&mut self, o: &TubeOptions) -> Result<()> {
        o.machine.apply(&mut self.machine);
        set(&mut self.length_mm, o.length);
        set(&mut self.layers, o.layer_count);
        if o.pitch.is_some() {
            self.pitch_mm = o.pitch;
        }
        set(&mut self.interweave, o.interweave);
        let p = &mut self.print;
        set(&mut p.layer_height_mm, o.layer_height);
        set(&mut p.bead_width_mm, o.bead_width);
        set(&mut p.chord_tolerance_mm, o.chord_tol);
        set(&mut p.print_speed_mm_s, o.speed);
        set(&mut p.nozzle_temp_c, o.temp);
        set(&mut p.filament_diameter_mm, o.filament_diameter);
        if o.segments_per_turn.is_some() {
            p.segments_per_turn = o.segments_per_turn;
        }
        self.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mandrel(d: f64) -> MachineOptions {
        MachineOptions { mandrel_diameter: Some(d), ..MachineOptions::default() }
    }

    #[test]
    fn the_mandrel_comes_from_the_flag_or_the_file_and_one_is_needed() {
        let file = "[machine]\nmandrel_diameter_mm = 16\nfeed_convention = \"combined\"\n";
        let from_file = TubeParams::read(Some(file), &MachineOptions::default()).unwrap();
        assert_eq!(from_file.machine.mandrel_diameter_mm, 16.0);
        // The flag replaces the file's diameter and keeps the rest of its machine.
        let both = TubeParams::read(Some(file), &mandrel(20.0)).unwrap();
        assert_eq!(both.machine.mandrel_diameter_mm, 20.0);
        assert_eq!(both.machine.feed_convention, FeedConvention::Combined);
        // A file without the table's required diameter, completed by the flag.
        let completed = WrapConfig::read(Some("chord_tolerance_mm = 0.05\n"), &mandrel(30.0)).unwrap();
        assert_eq!((completed.machine.mandrel_diameter_mm, completed.chord_tolerance_mm), (30.0, 0.05));
        assert_eq!(WrapConfig::read(None, &mandrel(30.0)).unwrap(), WrapConfig::new(RotaryConfig::new(30.0)));
        let none = WrapConfig::read(None, &MachineOptions::default()).unwrap_err();
        assert_eq!(
            none.to_string(),
            "no mandrel diameter: give one (1 to 1000 mm), or a config file with [machine] mandrel_diameter_mm"
        );
        assert!(matches!(WrapConfig::read(Some("x = 1\n"), &mandrel(30.0)), Err(RotaryError::Toml(_))));
    }

    #[test]
    fn flags_replace_the_files_values_and_the_result_is_validated() {
        let mut t =
            TubeParams::read(Some("layers = 5\n[print]\nbead_width_mm = 0.5\n"), &mandrel(20.0)).unwrap();
        let o = TubeOptions {
            machine: MachineOptions {
                rotary_unit: Some(RotaryUnit::Mm),
                axes: Some(['X', 'Y', 'Z']),
                ..MachineOptions::default()
            },
            layer_count: Some(2),
            pitch: Some(4.0),
            interweave: Some(false),
            segments_per_turn: Some(90),
            speed: Some(15.0),
            ..TubeOptions::default()
        };
        t.apply(&o).unwrap();
        assert_eq!((t.layers, t.pitch_mm, t.interweave), (2, Some(4.0), false));
        assert_eq!(
            (t.print.bead_width_mm, t.print.print_speed_mm_s, t.print.segments_per_turn),
            (0.5, 15.0, Some(90))
        );
        assert_eq!((t.machine.rotary_unit, t.machine.rotary_axis), (RotaryUnit::Mm, 'Y'));
        let narrow = TubeOptions { pitch: Some(0.1), ..TubeOptions::default() };
        let e = t.apply(&narrow).unwrap_err();
        assert!(e.to_string().contains("pitch_mm"), "{e}");

        let mut w = WrapConfig::read(Some("[unwrap]\nkeep_arc_length = true\n"), &mandrel(30.0)).unwrap();
        let off = WrapOptions { keep_arc_length: Some(false), helical: true, ..WrapOptions::default() };
        w.apply(&off).unwrap();
        assert!(!w.unwrap.keep_arc_length && w.unwrap.helical);
        // `false` for a switch leaves the file's value: it is a flag not given.
        w.apply(&WrapOptions::default()).unwrap();
        assert!(w.unwrap.helical);
    }
}
