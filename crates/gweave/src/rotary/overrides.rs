//! Settings given as flags (`gweave rotary wrap --mandrel-diameter 30 --seam-rotation 7.5`) or
//! Python keywords (`gweave.rotary_wrap(..., mandrel_diameter=30, seam_rotation=7.5)`), laid
//! over the TOML settings: the CLI and Python share these types, so the two cannot read the
//! same option differently.
//!
//! Reading takes two steps, as a file's errors name the file and a flag's do not:
//! [`WrapConfig::read`] (or [`TubeParams::read`]) turns the optional TOML text into settings,
//! then `apply` lays the other flags over them and validates the result.
//!
//! ```
//! use gweave::rotary::overrides::{MachineOverrides, WrapOverrides};
//! use gweave::rotary::wrap::WrapConfig;
//! let machine = MachineOverrides { mandrel_diameter_mm: Some(30.0), ..MachineOverrides::default() };
//! let mut config = WrapConfig::read(Some("chord_tolerance_mm = 0.05\n"), &machine).unwrap();
//! config.apply(&WrapOverrides { machine, seam_rotation_deg: Some(7.5), ..WrapOverrides::default() }).unwrap();
//! assert_eq!((config.machine.mandrel_diameter_mm, config.unwrap.seam_rotation_per_layer_deg), (30.0, 7.5));
//! assert_eq!(config.chord_tolerance_mm, 0.05, "a file's value stays unless a flag replaces it");
//! ```

use super::cylinder::{FeedConvention, RotaryConfig, RotaryUnit};
use super::helix::TubeParams;
use super::wrap::WrapConfig;
use super::{Result, RotaryError};

/// The machine's flags, which `rotary wrap` and `rotary tube` share. A value replaces the
/// file's.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MachineOverrides {
    /// Mandrel diameter, mm (`--mandrel-diameter`): required, here or in the file's `[machine]`.
    pub mandrel_diameter_mm: Option<f64>,
    /// How the firmware reads F on rotary moves (`--feed-convention`).
    pub feed_convention: Option<FeedConvention>,
    /// The unit of the rotary word (`--rotary-unit`).
    pub rotary_unit: Option<RotaryUnit>,
    /// Axis letters: axial, rotary, radial (`--axes X,A,Z`).
    pub axes: Option<[char; 3]>,
}

/// What the command line or Python lays over a wrap's settings.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WrapOverrides {
    /// The machine.
    pub machine: MachineOverrides,
    /// Keep flat arc lengths (`--keep-arc-length`); `Some(false)` turns a file's `true` off.
    pub keep_arc_length: Option<bool>,
    /// Each layer one turn of a helix (`--helical`); `false` leaves the file's value.
    pub helical: bool,
    /// Wrap a part wider than the circumference over itself (`--allow-overlap`); `false`
    /// leaves the file's value.
    pub allow_overlap: bool,
    /// Seam turn per layer, degrees (`--seam-rotation`).
    pub seam_rotation_deg: Option<f64>,
    /// Largest chord sagitta, mm (`--chord-tol`).
    pub chord_tolerance_mm: Option<f64>,
}

/// What the command line or Python lays over a tube's settings.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TubeOverrides {
    /// The machine.
    pub machine: MachineOverrides,
    /// Tube length, mm (`--length`).
    pub length_mm: Option<f64>,
    /// Number of layers (`--layer-count`).
    pub layers: Option<u32>,
    /// Layer height, mm (`--layer-height`).
    pub layer_height_mm: Option<f64>,
    /// Bead width, mm (`--bead-width`).
    pub bead_width_mm: Option<f64>,
    /// Axial advance per turn, mm (`--pitch`).
    pub pitch_mm: Option<f64>,
    /// Reverse the helix every layer; `Some(false)` is `--no-interweave`.
    pub interweave: Option<bool>,
    /// At least this many chords per turn (`--segments-per-turn`).
    pub segments_per_turn: Option<u32>,
    /// Largest chord sagitta, mm (`--chord-tol`).
    pub chord_tolerance_mm: Option<f64>,
    /// Surface speed while printing, mm/s (`--speed`).
    pub print_speed_mm_s: Option<f64>,
    /// Nozzle temperature, °C (`--temp`).
    pub nozzle_temp_c: Option<f64>,
    /// Filament diameter, mm (`--filament-diameter`).
    pub filament_diameter_mm: Option<f64>,
}

impl MachineOverrides {
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
            return match self.mandrel_diameter_mm {
                Some(d) => Ok(new(RotaryConfig::new(d))),
                None => Err(RotaryError::NoMandrel),
            };
        };
        let Some(d) = self.mandrel_diameter_mm else {
            return parse(text);
        };
        let mut table: toml::Table = text.parse()?;
        let machine = table.entry("machine").or_insert_with(|| toml::Table::new().into());
        if let Some(machine) = machine.as_table_mut() {
            machine.insert("mandrel_diameter_mm".into(), d.into());
        }
        parse(&table.to_string())
    }

    /// Lays the flags over a machine.
    fn apply(&self, machine: &mut RotaryConfig) {
        if let Some(d) = self.mandrel_diameter_mm {
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
    /// diameter completing or replacing the file's (see [`MachineOverrides`]).
    pub fn read(toml: Option<&str>, machine: &MachineOverrides) -> Result<Self> {
        machine.read(toml, Self::from_toml_str, Self::new)
    }

    /// Lays `o` over the settings, then validates the result.
    pub fn apply(&mut self, o: &WrapOverrides) -> Result<()> {
        o.machine.apply(&mut self.machine);
        set(&mut self.unwrap.keep_arc_length, o.keep_arc_length);
        set(&mut self.unwrap.seam_rotation_per_layer_deg, o.seam_rotation_deg);
        self.unwrap.helical |= o.helical;
        self.allow_overlap |= o.allow_overlap;
        set(&mut self.chord_tolerance_mm, o.chord_tolerance_mm);
        self.validate()
    }
}

impl TubeParams {
    /// The tube of the TOML document `toml` (None: the defaults), with `machine`'s mandrel
    /// diameter completing or replacing the file's (see [`MachineOverrides`]).
    pub fn read(toml: Option<&str>, machine: &MachineOverrides) -> Result<Self> {
        machine.read(toml, Self::from_toml_str, Self::new)
    }

    /// Lays `o` over the tube, then validates the result.
    pub fn apply(&mut self, o: &TubeOverrides) -> Result<()> {
        o.machine.apply(&mut self.machine);
        set(&mut self.length_mm, o.length_mm);
        set(&mut self.layers, o.layers);
        if o.pitch_mm.is_some() {
            self.pitch_mm = o.pitch_mm;
        }
        set(&mut self.interweave, o.interweave);
        let p = &mut self.print;
        set(&mut p.layer_height_mm, o.layer_height_mm);
        set(&mut p.bead_width_mm, o.bead_width_mm);
        set(&mut p.chord_tolerance_mm, o.chord_tolerance_mm);
        set(&mut p.print_speed_mm_s, o.print_speed_mm_s);
        set(&mut p.nozzle_temp_c, o.nozzle_temp_c);
        set(&mut p.filament_diameter_mm, o.filament_diameter_mm);
        if o.segments_per_turn.is_some() {
            p.segments_per_turn = o.segments_per_turn;
        }
        self.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mandrel(d: f64) -> MachineOverrides {
        MachineOverrides { mandrel_diameter_mm: Some(d), ..MachineOverrides::default() }
    }

    #[test]
    fn the_mandrel_comes_from_the_flag_or_the_file_and_one_is_needed() {
        let file = "[machine]\nmandrel_diameter_mm = 16\nfeed_convention = \"combined\"\n";
        let from_file = TubeParams::read(Some(file), &MachineOverrides::default()).unwrap();
        assert_eq!(from_file.machine.mandrel_diameter_mm, 16.0);
        // The flag replaces the file's diameter and keeps the rest of its machine.
        let both = TubeParams::read(Some(file), &mandrel(20.0)).unwrap();
        assert_eq!(both.machine.mandrel_diameter_mm, 20.0);
        assert_eq!(both.machine.feed_convention, FeedConvention::Combined);
        // A file without the table's required diameter, completed by the flag.
        let completed = WrapConfig::read(Some("chord_tolerance_mm = 0.05\n"), &mandrel(30.0)).unwrap();
        assert_eq!((completed.machine.mandrel_diameter_mm, completed.chord_tolerance_mm), (30.0, 0.05));
        assert_eq!(WrapConfig::read(None, &mandrel(30.0)).unwrap(), WrapConfig::new(RotaryConfig::new(30.0)));
        let none = WrapConfig::read(None, &MachineOverrides::default()).unwrap_err();
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
        let o = TubeOverrides {
            machine: MachineOverrides {
                rotary_unit: Some(RotaryUnit::Mm),
                axes: Some(['X', 'Y', 'Z']),
                ..MachineOverrides::default()
            },
            layers: Some(2),
            pitch_mm: Some(4.0),
            interweave: Some(false),
            segments_per_turn: Some(90),
            print_speed_mm_s: Some(15.0),
            ..TubeOverrides::default()
        };
        t.apply(&o).unwrap();
        assert_eq!((t.layers, t.pitch_mm, t.interweave), (2, Some(4.0), false));
        assert_eq!(
            (t.print.bead_width_mm, t.print.print_speed_mm_s, t.print.segments_per_turn),
            (0.5, 15.0, Some(90))
        );
        assert_eq!((t.machine.rotary_unit, t.machine.rotary_axis), (RotaryUnit::Mm, 'Y'));
        let narrow = TubeOverrides { pitch_mm: Some(0.1), ..TubeOverrides::default() };
        let e = t.apply(&narrow).unwrap_err();
        assert!(e.to_string().contains("pitch_mm"), "{e}");

        let mut w = WrapConfig::read(Some("[unwrap]\nkeep_arc_length = true\n"), &mandrel(30.0)).unwrap();
        let off = WrapOverrides { keep_arc_length: Some(false), helical: true, ..WrapOverrides::default() };
        w.apply(&off).unwrap();
        assert!(!w.unwrap.keep_arc_length && w.unwrap.helical);
        // `false` for a switch leaves the file's value: it is a flag not given.
        w.apply(&WrapOverrides::default()).unwrap();
        assert!(w.unwrap.helical);
    }
}
