//! The machine profile of the virtual printer: one TOML file that says what the printer is.
//!
//! It composes the motion profile ([`MotionProfile`]: steps per unit, including each mixing
//! input's in `steps.mixing_e` and the rotary axis' in `steps.a_per_deg`; feed and acceleration
//! limits; Marlin or Klipper corners), the heaters ([`ThermalConfig`], with the minimum
//! extrusion temperature `thermal.extrude_min_c`), the build volume and endstops, homing, an
//! optional mixing hotend, rotary axis and inkjet printhead, and faults to inject. What the
//! board's firmware was built with (Marlin's `Configuration.h` and `Configuration_adv.h`
//! options: `EEPROM_SETTINGS`, `SDSUPPORT`, ...) is its `[firmware]` table
//! ([`MachineProfile::firmware`]); [`m503`] reads a
//! profile back from a real board's `M503` report.
//!
//! Every key has a default; together they describe a common RAMPS 1.4 printer running Marlin's
//! stock `Configuration.h` (`MarlinFirmware/Marlin:Marlin/Configuration.h`): a 200 x 200 x 200 mm
//! volume (`X_BED_SIZE`, `Y_BED_SIZE`, `Z_MAX_POS`), endstops at the minimum of every axis
//! (`X_HOME_DIR -1`...), homing at 50/50/4 mm/s (`HOMING_FEEDRATE_MM_M`) with a bump of
//! 5/5/2 mm re-approached at 1/2, 1/2, 1/4 of that speed (`HOMING_BUMP_MM`,
//! `HOMING_BUMP_DIVISOR`), X then Y then Z. Unknown keys are errors (a typo must not pass
//! silently as a default).
//!
//! ```
//! use gweave_sim::MachineProfile;
//!
//! let p = MachineProfile::from_toml_str("name = \"mini\"\n[bed]\nx_mm = 180.0\n").unwrap();
//! assert_eq!((p.bed.x_mm, p.bed.y_mm), (180.0, 200.0));
//! assert!(MachineProfile::from_toml_str("[bed]\nx_nm = 1.0\n").is_err());
//! ```

pub(crate) mod build_options;
pub mod builtin;
pub(crate) mod m503;

use std::fmt;
use std::str::FromStr;

use gweave::gen::printhead::{PrintheadError, PrintheadProfile};
use gweave::gen::raster_job::HeadSource;
use gweave::range::{self};
use gweave::settings::{CheckRanges, Table};
use gweave::{OutOfRange, Range};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::motion::limits::MotionProfile;
use crate::profile::build_options::{BuildOptions, BuildOptionsError};
use crate::thermal::heater::{HeaterFault, HeaterId};
use crate::thermal::thermistor::SensorFault;
use crate::thermal::thermistor_csv::table_from_csv;
use crate::thermal::ThermalConfig;

/// A machine profile that cannot be used.
#[derive(Debug, PartialEq, Error)]
pub enum MachineProfileError {
    /// The text is not a valid machine profile (syntax, unknown key, wrong type).
    #[error("machine profile: {0}")]
    Toml(String),
    /// A value out of its range (it names the table and the key).
    #[error(transparent)]
    Range(#[from] OutOfRange),
    /// The printhead is not usable (no head, a nozzle map that is no permutation).
    #[error("machine profile: [inkjet.printhead] {0}")]
    Printhead(PrintheadError),
    /// `homing.order` is not some of `XYZ`, each at most once.
    #[error("machine profile: [homing] order = {0:?}: give some of XYZ, each at most once")]
    HomingOrder(String),
    /// Several tools feed one nozzle (`single_nozzle_tools`), so the machine has one hotend
    /// and no mixing inputs.
    #[error("machine profile: single_nozzle_tools = {tools} feeds one nozzle: give one [[thermal.hotends]] entry (not {hotends}) and no mixing_inputs")]
    SingleNozzle {
        /// `single_nozzle_tools`.
        tools: usize,
        /// `[[thermal.hotends]]` entries.
        hotends: usize,
    },
    /// A rotary axis needs its steps per degree (`motion.steps.a_per_deg`).
    #[error("machine profile: [rotary] needs motion.steps.a_per_deg")]
    RotaryWithoutSteps,
    /// Axis A either turns (`a_per_deg`) or slides (`a_per_mm`), not both.
    #[error("machine profile: motion.steps has both a_per_deg and a_per_mm: axis A either turns or slides, give one")]
    AxisATurnsOrSlides,
    /// A recoat piston on A slides: its steps are per mm (without them every layer's piston
    /// move counted one step a millimetre).
    #[error("machine profile: [inkjet.printhead.recoat] moves a piston on A: give motion.steps.a_per_mm (the piston's steps per mm)")]
    PistonWithoutSteps,
    /// `mixing_inputs` and `motion.steps.mixing_e` disagree.
    #[error("machine profile: mixing_inputs = {inputs} but motion.steps.mixing_e has {steps} entries")]
    MixingSteps {
        /// `mixing_inputs`.
        inputs: usize,
        /// Entries of `motion.steps.mixing_e`.
        steps: usize,
    },
    /// A `[firmware]` value out of range.
    #[error("machine profile: {0}")]
    BuildOptions(#[from] BuildOptionsError),
    /// The thermistor table file named by `[thermal] thermistor_table` cannot be read.
    #[error("machine profile: [thermal] thermistor_table {}: {message}", path.display())]
    #[allow(missing_docs)] // the file and why
    ThermistorTable { path: std::path::PathBuf, message: String },
    /// A fault specification such as `hotend-cartridge-off@120s` that cannot be read.
    #[error("fault `{0}`: expected HEATER-FAULT@SECONDS, e.g. hotend-cartridge-off@120s, bed-thermistor-open@30s, hotend1-thermistor-shorted@5s")]
    Fault(String),
    /// A fault for a heater the machine does not have (it would never happen, and the run
    /// would look as if the firmware had survived it).
    #[error("fault `{fault}`: this machine has no such heater (its heaters: {heaters})")]
    #[allow(missing_docs)] // the fault as given, and the heaters the machine has
    FaultHeater { fault: String, heaters: String },
    /// A raster job was given a machine without a printhead (its name).
    #[error("machine `{0}` has no inkjet printhead (no [inkjet] table): give an inkjet machine (`gweave machine list`: binder-jet, inkjet-c6602) or a printhead profile")]
    NoPrinthead(String),
}

/// The build volume: the soft limits moves are checked against, mm. The bed surface is Z = 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Bed {
    /// Smallest X the nozzle can reach (`X_MIN_POS`), mm.
    pub x_min_mm: f64,
    /// Smallest Y (`Y_MIN_POS`), mm.
    pub y_min_mm: f64,
    /// X travel from `x_min_mm` (`X_BED_SIZE`), mm.
    pub x_mm: f64,
    /// Y travel from `y_min_mm` (`Y_BED_SIZE`), mm.
    pub y_mm: f64,
    /// Highest Z (`Z_MAX_POS`), mm.
    pub z_mm: f64,
}

/// A machine with a few inputs more than the largest mixing hotends (6 inputs).
const MIXING_INPUTS: Range = Range::new(0.0, 16.0, "inputs");
/// Marlin's `EXTRUDERS` goes to 8 (a Prusa MMU2S has 5 filaments).
const SINGLE_NOZZLE_TOOLS: Range = Range::new(0.0, 8.0, "tools");
/// The slow second touch of homing runs at `feed / divisor` (Marlin ships 2 to 10).
const BUMP_DIVISOR: Range = Range::new(1.0, 100.0, "");
/// The inkjet canvas: 20 000 pitches per side (5.3 m at 96 dpi) is more than any bed.
const CANVAS_PX: Range = Range::new(1.0, 20_000.0, "px");

impl CheckRanges for MachineProfile {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        self.motion.check_ranges(&t.sub("motion"))?;
        self.thermal.check_ranges(&t.sub("thermal"))?;
        let bed = t.sub("bed");
        let b = &self.bed;
        bed.check("x_min_mm", b.x_min_mm, range::POSITION_MM)?;
        bed.check("y_min_mm", b.y_min_mm, range::POSITION_MM)?;
        bed.check("x_mm", b.x_mm, range::SIZE_MM)?;
        bed.check("y_mm", b.y_mm, range::SIZE_MM)?;
        bed.check("z_mm", b.z_mm, range::SIZE_MM)?;
        let homing = t.sub("homing");
        homing.each("feed_mm_s", &self.homing.feed_mm_s, range::SPEED_MM_S)?;
        homing.each("bump_mm", &self.homing.bump_mm, range::LEN_MM)?;
        homing.each("bump_divisor", &self.homing.bump_divisor, BUMP_DIVISOR)?;
        t.count("mixing_inputs", self.mixing_inputs as u64, MIXING_INPUTS)?;
        t.count("single_nozzle_tools", self.single_nozzle_tools as u64, SINGLE_NOZZLE_TOOLS)?;
        if let Some(r) = &self.rotary {
            t.sub("rotary").check("cylinder_radius_mm", r.cylinder_radius_mm, range::SIZE_MM)?;
        }
        if let Some(ink) = &self.inkjet {
            let inkjet = t.sub("inkjet");
            ink.printhead.check_ranges(&inkjet.sub("printhead"))?;
            inkjet.check("origin_x_mm", ink.origin_x_mm, range::POSITION_MM)?;
            inkjet.check("origin_y_mm", ink.origin_y_mm, range::POSITION_MM)?;
            // The canvas is allocated at this size, so a computed size is held to the range too.
            let [width, height] = ink.canvas_px(&self.bed);
            let key = |name: &str, given: Option<usize>| match given {
                Some(_) => name.to_owned(),
                None => format!("{name} (unset: the bed in nozzle pitches)"),
            };
            inkjet.check(&key("width_px", ink.width_px), width as f64, CANVAS_PX)?;
            inkjet.check(&key("height_px", ink.height_px), height as f64, CANVAS_PX)?;
        }
        Ok(())
    }
}

impl Default for Bed {
    fn default() -> Self {
        Self { x_min_mm: 0.0, y_min_mm: 0.0, x_mm: 200.0, y_mm: 200.0, z_mm: 200.0 }
    }
}

impl Bed {
    /// `[min, max]` of X, Y and Z, mm.
    pub fn ranges(&self) -> [(f64, f64); 3] {
        [
            (self.x_min_mm, self.x_min_mm + self.x_mm),
            (self.y_min_mm, self.y_min_mm + self.y_mm),
            (0.0, self.z_mm),
        ]
    }

    /// The volume `gweave check --machine` holds moves to: this one.
    pub fn to_check(self) -> Result<gweave::Bed, gweave::BedError> {
        let [x, y, z] = self.ranges();
        gweave::Bed::new([x.0, y.0], [x.1, y.1], Some(z.1))
    }
}

/// Which end of an axis its endstop is at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EndstopSide {
    /// At the axis minimum (`*_HOME_DIR -1`, M119 `x_min`).
    Min,
    /// At the axis maximum (`*_HOME_DIR 1`, M119 `x_max`).
    Max,
}

/// The endstop of each linear axis; homing drives towards it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Endstops {
    /// X endstop.
    pub x: EndstopSide,
    /// Y endstop.
    pub y: EndstopSide,
    /// Z endstop.
    pub z: EndstopSide,
}

impl Default for Endstops {
    fn default() -> Self {
        Self { x: EndstopSide::Min, y: EndstopSide::Min, z: EndstopSide::Min }
    }
}

impl Endstops {
    /// The sides in the order X Y Z.
    pub fn to_array(self) -> [EndstopSide; 3] {
        [self.x, self.y, self.z]
    }
}

/// How `G28` homes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Homing {
    /// The axes in the order they home, a permutation of some of `XYZ` (Marlin: X, Y, then Z).
    pub order: String,
    /// Speed towards the endstop per axis X Y Z (`HOMING_FEEDRATE_MM_M` / 60), mm/s.
    pub feed_mm_s: [f64; 3],
    /// Back-off after the first touch, before the slow second touch (`HOMING_BUMP_MM`), mm.
    pub bump_mm: [f64; 3],
    /// The second touch runs at `feed / divisor` (`HOMING_BUMP_DIVISOR`).
    pub bump_divisor: [f64; 3],
}

impl Default for Homing {
    fn default() -> Self {
        Self {
            order: "XYZ".to_owned(),
            feed_mm_s: [50.0, 50.0, 4.0],
            bump_mm: [5.0, 5.0, 2.0],
            bump_divisor: [2.0, 2.0, 4.0],
        }
    }
}

impl Homing {
    /// The axis indices (0 = X) in homing order.
    pub fn axes(&self) -> Vec<usize> {
        self.order
            .bytes()
            .filter_map(|c| match c.to_ascii_uppercase() {
                b'X' => Some(0),
                b'Y' => Some(1),
                b'Z' => Some(2),
                _ => None,
            })
            .collect()
    }
}

/// A rotary (lathe) axis A. Its steps per degree are `motion.steps.a_per_deg`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Rotary {
    /// Radius of the bare cylinder the part is printed on (for reports), mm.
    pub cylinder_radius_mm: f64,
    /// The axis turns without end (no out-of-range warnings for A).
    pub continuous: bool,
    /// What F means on a `G94` move that turns A to the machine's firmware, when it is gweave's
    /// controller core (`[firmware] kind = "gweave"`, the firmware's `[rotary] feed`): `nist`
    /// or `combined`. The Marlin and Klipper models read the convention a rotary program's
    /// header declares instead.
    pub feed: RotaryFeed,
}

/// The gweave firmware's reading of F on a move that turns A (`gweave_controller::rotary`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RotaryFeed {
    /// Along X, Y and Z when any of them moves, else in degrees per minute.
    Nist,
    /// Along `sqrt(dX² + dY² + dZ² + dA²)`.
    Combined,
}

impl Default for Rotary {
    fn default() -> Self {
        Self { cylinder_radius_mm: 10.0, continuous: true, feed: RotaryFeed::Nist }
    }
}

/// An inkjet printhead fired by `M700`/`M578`, and the bed area its drops are recorded on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Inkjet {
    /// The printhead (nozzles, pitch, nozzle map, heads).
    pub printhead: PrintheadProfile,
    /// Bed position of the canvas' pixel (0, 0) corner, mm. The raster generator's origin.
    pub origin_x_mm: f64,
    /// See `origin_x_mm`.
    pub origin_y_mm: f64,
    /// Canvas width in nozzle pitches; `None`: to the end of the bed.
    pub width_px: Option<usize>,
    /// Canvas height in nozzle pitches; `None`: to the end of the bed.
    pub height_px: Option<usize>,
}

impl Inkjet {
    /// The canvas size in nozzle pitches: `width_px` and `height_px`, or from the origin to the
    /// end of the bed.
    pub fn canvas_px(&self, bed: &Bed) -> [usize; 2] {
        let pitch = self.printhead.pitch_mm();
        let [(_, x_max), (_, y_max), _] = bed.ranges();
        // A saturating cast: a NaN or huge size becomes 0 or usize::MAX, both out of range.
        let fit = |from: f64, to: f64| ((to - from) / pitch).ceil().max(1.0) as usize;
        [
            self.width_px.unwrap_or_else(|| fit(self.origin_x_mm, x_max)),
            self.height_px.unwrap_or_else(|| fit(self.origin_y_mm, y_max)),
        ]
    }
}

impl Default for Inkjet {
    fn default() -> Self {
        Self {
            printhead: PrintheadProfile::default(),
            origin_x_mm: 0.0,
            origin_y_mm: 0.0,
            width_px: None,
            height_px: None,
        }
    }
}

/// A fault to inject into a heater at a simulated time: `hotend-cartridge-off@120s`,
/// `hotend1-thermistor-open@30s`, `bed-thermistor-shorted@10s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct FaultSpec {
    /// Which heater.
    pub heater: HeaterId,
    /// What breaks.
    pub fault: HeaterFault,
    /// When, simulated seconds from power-on.
    pub at_s: f64,
}

impl FromStr for FaultSpec {
    type Err = MachineProfileError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || MachineProfileError::Fault(s.to_owned());
        let (what, at) = s.split_once('@').ok_or_else(bad)?;
        let at_s: f64 = at.trim_end_matches('s').parse().map_err(|_| bad())?;
        if !(at_s.is_finite() && at_s >= 0.0) {
            return Err(bad());
        }
        let (heater, fault) = what.split_once('-').ok_or_else(bad)?;
        let heater = match heater {
            "bed" => HeaterId::Bed,
            "hotend" => HeaterId::Hotend(0),
            h => HeaterId::Hotend(h.strip_prefix("hotend").and_then(|n| n.parse().ok()).ok_or_else(bad)?),
        };
        let fault = match fault {
            "cartridge-off" => HeaterFault::CartridgeDisconnected,
            "thermistor-open" => HeaterFault::Sensor(SensorFault::Open),
            "thermistor-shorted" => HeaterFault::Sensor(SensorFault::Shorted),
            _ => return Err(bad()),
        };
        Ok(Self { heater, fault, at_s })
    }
}

impl fmt::Display for FaultSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&fault_heater(self.heater))?;
        let fault = match self.fault {
            HeaterFault::CartridgeDisconnected => "cartridge-off",
            HeaterFault::Sensor(SensorFault::Open) => "thermistor-open",
            HeaterFault::Sensor(SensorFault::Shorted) => "thermistor-shorted",
        };
        write!(f, "-{fault}@{}s", self.at_s)
    }
}

/// A heater as a fault names it: `hotend`, `hotend1`, `bed`.
fn fault_heater(heater: HeaterId) -> String {
    match heater {
        HeaterId::Bed => "bed".to_owned(),
        HeaterId::Hotend(0) => "hotend".to_owned(),
        HeaterId::Hotend(n) => format!("hotend{n}"),
    }
}

impl TryFrom<String> for FaultSpec {
    type Error = MachineProfileError;

    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

impl From<FaultSpec> for String {
    fn from(f: FaultSpec) -> String {
        f.to_string()
    }
}

/// Everything the virtual printer needs to know about the machine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MachineProfile {
    /// A name for reports and `M115`.
    pub name: String,
    /// Steps, limits, corners.
    pub motion: MotionProfile,
    /// Heaters, their control and protection, and `extrude_min_c`.
    pub thermal: ThermalConfig,
    /// The build volume.
    pub bed: Bed,
    /// The endstops.
    pub endstops: Endstops,
    /// `G28`.
    pub homing: Homing,
    /// Inputs of a mixing hotend (0: a plain extruder per hotend). Each input's steps/mm are in
    /// `motion.steps.mixing_e` (left empty, every input gets `motion.steps.e`).
    pub mixing_inputs: usize,
    /// Tools that feed one nozzle (0: one tool per hotend). A single-extruder multi-material
    /// printer (a Prusa MMU2S, Marlin's `SINGLENOZZLE` with `EXTRUDERS` filaments) changes
    /// filament, not nozzle: `T0` to `T<n-1>` all print through the one hotend, at its
    /// temperature, and each tool's filament is counted on its own.
    pub single_nozzle_tools: usize,
    /// A rotary axis A.
    pub rotary: Option<Rotary>,
    /// An inkjet printhead.
    pub inkjet: Option<Inkjet>,
    /// Faults to inject, e.g. `["hotend-cartridge-off@120s"]`.
    pub faults: Vec<FaultSpec>,
    /// What the firmware was built with ([`BuildOptions`]), the `[firmware]` table.
    pub firmware: BuildOptions,
}

impl Default for MachineProfile {
    fn default() -> Self {
        Self {
            name: "RAMPS 1.4 Marlin (default)".to_owned(),
            motion: MotionProfile::default(),
            thermal: ThermalConfig::default(),
            bed: Bed::default(),
            endstops: Endstops::default(),
            homing: Homing::default(),
            mixing_inputs: 0,
            single_nozzle_tools: 0,
            rotary: None,
            inkjet: None,
            faults: Vec::new(),
            firmware: BuildOptions::default(),
        }
    }
}

impl MachineProfile {
    /// `check` against this machine (`gweave check --machine`, Python's `check(machine=)`): its
    /// `[bed]` travel, as `sim` holds moves to it, and the longest extrusion its firmware takes
    /// (`[firmware] extrude_max_mm`), over `options`.
    pub fn check_options(
        &self,
        options: gweave::CheckOptions,
    ) -> Result<gweave::CheckOptions, gweave::BedError> {
        Ok(gweave::CheckOptions {
            bed: Some(self.bed.to_check()?),
            marlin_extrude_max_mm: f64::from(self.firmware.extrude_max_mm),
            ..options
        })
    }

    /// The printhead and canvas origin a raster job writes for on this machine (`gweave raster
    /// --machine`): its drops land on the canvas and its recoats are the ones this profile's
    /// virtual printer checks.
    pub fn raster_head(&self) -> Result<HeadSource, MachineProfileError> {
        let inkjet =
            self.inkjet.as_ref().ok_or_else(|| MachineProfileError::NoPrinthead(self.name.clone()))?;
        Ok(HeadSource::Machine {
            printhead: Box::new(inkjet.printhead.clone()),
            origin_mm: (inkjet.origin_x_mm, inkjet.origin_y_mm),
        })
    }

    /// Whether tool `tool` exists: a tool per hotend, several on one nozzle
    /// ([`Self::single_nozzle_tools`]); a mixing hotend's virtual tools are checked apart.
    pub fn has_tool(&self, tool: u32) -> bool {
        let tools = match self.single_nozzle_tools {
            0 => self.thermal.hotends.len().max(1),
            n => n,
        };
        (tool as usize) < tools
    }

    /// The hotend tool `tool` prints through: its own on a multi-hotend machine, the only one
    /// on a mixing hotend or a single nozzle fed by several tools.
    pub fn hotend_of_tool(&self, tool: usize) -> u8 {
        if self.mixing_inputs > 0 || self.single_nozzle_tools > 0 {
            0
        } else {
            tool.min(usize::from(u8::MAX)) as u8
        }
    }

    /// Read a profile from TOML text, fill derived defaults and check it.
    /// Files it names (`[thermal] thermistor_table`) are read from the current folder.
    pub fn from_toml_str(text: &str) -> Result<Self, MachineProfileError> {
        Self::from_toml_in(text, std::path::Path::new(""))
    }

    /// Read a profile file; the files it names are read from its folder.
    pub fn from_file(path: &std::path::Path) -> Result<Self, MachineProfileError> {
        let text = gweave::settings::read_text(path)
            .map_err(|e| MachineProfileError::Toml(format!("{}: {e}", path.display())))?;
        Self::from_toml_in(&text, path.parent().unwrap_or(std::path::Path::new("")))
    }

    /// [`Self::from_toml_str`] with the files it names read from `folder`.
    pub fn from_toml_in(text: &str, folder: &std::path::Path) -> Result<Self, MachineProfileError> {
        Self::from_toml_reading(text, |name| {
            let path = folder.join(name);
            let text = gweave::settings::read_text(&path).map_err(|e| e.to_string());
            (path, text)
        })
    }

    /// [`Self::from_toml_str`] with the files it names given by `read` (the name the profile
    /// uses in, the path to show and the text or why there is none out): from a folder, or
    /// from the program for a [`builtin`] profile.
    pub fn from_toml_reading(
        text: &str,
        read: impl Fn(&std::path::Path) -> (std::path::PathBuf, Result<String, String>),
    ) -> Result<Self, MachineProfileError> {
        let mut p: Self = toml::from_str(text)
            .map_err(|e| MachineProfileError::Toml(gweave::settings::toml_message(&e)))?;
        // The circuit the table's values are read through is checked first.
        p.normalize()?;
        if let Some(name) = &p.thermal.thermistor_table {
            let (path, text) = read(name);
            let table =
                text.and_then(|text| table_from_csv(&text, &p.thermal.thermistor).map_err(|e| e.to_string()));
            match table {
                Ok(t) => p.thermal.thermistor_table_entries = Some(t),
                Err(message) => return Err(MachineProfileError::ThermistorTable { path, message }),
            }
        }
        Ok(p)
    }

    /// Fill `motion.steps.mixing_e` for a mixing hotend that left it empty, then validate.
    pub fn normalize(&mut self) -> Result<(), MachineProfileError> {
        // The count is checked before it sizes anything: `mixing_inputs = 4294967296` would
        // otherwise ask for 34 GB here, before `validate` could refuse it.
        Table::root().count("mixing_inputs", self.mixing_inputs as u64, MIXING_INPUTS)?;
        let steps = &mut self.motion.steps;
        if self.mixing_inputs > 0 && steps.mixing_e.is_empty() {
            steps.mixing_e = vec![steps.e; self.mixing_inputs];
        }
        self.validate()
    }

    /// Check every value: each key against its range (the motion, heaters and printhead
    /// included, so `sim`, `estimate` and `serve` refuse the same profile with the same
    /// message), then the keys that must agree with each other.
    pub fn validate(&self) -> Result<(), MachineProfileError> {
        self.check_ranges(&Table::root())?;
        self.firmware.validate()?;
        let h = &self.homing;
        let axes = h.axes();
        let unique = (0..3).all(|a| axes.iter().filter(|&&x| x == a).count() <= 1);
        if !(unique && axes.len() == h.order.len()) {
            return Err(MachineProfileError::HomingOrder(h.order.clone()));
        }
        let mixing = self.motion.steps.mixing_e.len();
        if mixing != self.mixing_inputs {
            return Err(MachineProfileError::MixingSteps { inputs: self.mixing_inputs, steps: mixing });
        }
        let hotends = self.thermal.hotends.len();
        for f in &self.faults {
            let present = match f.heater {
                HeaterId::Bed => self.thermal.bed.is_some(),
                HeaterId::Hotend(n) => (n as usize) < hotends,
            };
            if !present {
                let hotend_ids = (0..hotends).map(|n| HeaterId::Hotend(n as u8));
                let ids = hotend_ids.chain(self.thermal.bed.as_ref().map(|_| HeaterId::Bed));
                let heaters: Vec<String> = ids.map(fault_heater).collect();
                let heaters = if heaters.is_empty() { "none".to_owned() } else { heaters.join(", ") };
                return Err(MachineProfileError::FaultHeater { fault: f.to_string(), heaters });
            }
        }
        if self.single_nozzle_tools > 0 && (hotends != 1 || self.mixing_inputs > 0) {
            return Err(MachineProfileError::SingleNozzle { tools: self.single_nozzle_tools, hotends });
        }
        let steps = &self.motion.steps;
        if steps.a_per_deg.is_some() && steps.a_per_mm.is_some() {
            return Err(MachineProfileError::AxisATurnsOrSlides);
        }
        if self.rotary.is_some() && steps.a_per_deg.is_none() {
            return Err(MachineProfileError::RotaryWithoutSteps);
        }
        let recoat = self.inkjet.as_ref().and_then(|ink| ink.printhead.recoat.as_ref());
        let piston_on_a = recoat.is_some_and(|r| r.feed_piston_axis == 'A' || r.build_piston_axis == 'A');
        if piston_on_a && steps.a_per_mm.is_none() {
            return Err(MachineProfileError::PistonWithoutSteps);
        }
        if let Some(ink) = &self.inkjet {
            ink.printhead.validate().map_err(MachineProfileError::Printhead)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {

    /// A breaking session found `--fault hotend1-cartridge-off@5s` on a one-hotend machine run
    /// to its end without a fault and without a word: the user believed it injected.
    #[test]
    fn a_fault_for_a_heater_the_machine_lacks_is_refused() {
        let e = MachineProfile::from_toml_str("faults = [\"hotend1-cartridge-off@5s\"]\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "fault `hotend1-cartridge-off@5s`: this machine has no such heater (its heaters: hotend, bed)"
        );
        let mut no_bed = MachineProfile::default();
        no_bed.thermal.bed = None;
        no_bed.faults = vec!["bed-thermistor-open@1s".parse().unwrap()];
        let e = no_bed.validate().unwrap_err().to_string();
        assert!(e.ends_with("(its heaters: hotend)"), "{e}");
        let two = "faults = [\"hotend1-thermistor-open@1s\", \"bed-thermistor-open@1s\"]\n[[thermal.hotends]]\n[[thermal.hotends]]\n";
        assert_eq!(MachineProfile::from_toml_str(two).unwrap().faults.len(), 2);
    }

    /// docs/machine.md says every key is optional, but a `[[thermal.hotends]]` entry failed
    /// with "missing field `heat_capacity_j_k`" until all six were given.
    #[test]
    fn a_hotend_entry_takes_the_default_blocks_missing_keys() {
        let p = MachineProfile::from_toml_str(
            "[[thermal.hotends]]\n[[thermal.hotends]]\npower_w = 30.0\n[thermal.bed]\npower_w = 300.0\n",
        )
        .unwrap();
        let block = HeaterConfig::hotend_40w();
        assert_eq!(p.thermal.hotends, [block, HeaterConfig { power_w: 30.0, ..block }]);
        assert_eq!(p.thermal.bed, Some(HeaterConfig { power_w: 300.0, ..HeaterConfig::bed_200w() }));
        let typo = MachineProfile::from_toml_str("[[thermal.hotends]]\npower = 30.0\n").unwrap_err();
        assert!(typo.to_string().contains("unknown field `power`"), "{typo}");
    }
    use super::*;
    use crate::motion::limits::CornerMode;
    use crate::thermal::heater::HeaterConfig;

    #[test]
    fn default_is_ramps_marlin() {
        let p = MachineProfile::default();
        assert_eq!(p.validate(), Ok(()));
        assert_eq!(p.bed.ranges(), [(0.0, 200.0), (0.0, 200.0), (0.0, 200.0)]);
        assert_eq!(p.homing.axes(), vec![0, 1, 2]);
        assert_eq!(p.thermal.extrude_min_c, Some(170.0));
        assert!(matches!(p.motion.corners, CornerMode::Marlin { .. }));
        // The defaults survive a TOML round trip.
        let text = toml::to_string(&p).unwrap();
        assert_eq!(MachineProfile::from_toml_str(&text).unwrap(), p);
    }

    /// Issue 39 point 5: several tools on one nozzle (a Prusa MMU2S) all print through
    /// hotend 0; a profile that gives them several hotends or a mixing hotend is refused.
    #[test]
    fn single_nozzle_tools_share_the_one_hotend() {
        let p = MachineProfile::from_toml_str("single_nozzle_tools = 5\n").unwrap();
        let tools: Vec<(bool, u8)> = (0..6).map(|t| (p.has_tool(t), p.hotend_of_tool(t as usize))).collect();
        assert_eq!(tools, [(true, 0), (true, 0), (true, 0), (true, 0), (true, 0), (false, 0)]);
        let two = MachineProfile::from_toml_str("[[thermal.hotends]]\n[[thermal.hotends]]\n").unwrap();
        assert_eq!((two.has_tool(1), two.hotend_of_tool(1), two.has_tool(2)), (true, 1, false));
        let e = MachineProfile::from_toml_str(
            "single_nozzle_tools = 2\n[[thermal.hotends]]\n[[thermal.hotends]]\n",
        );
        assert_eq!(
            e.unwrap_err().to_string(),
            "machine profile: single_nozzle_tools = 2 feeds one nozzle: give one [[thermal.hotends]] entry (not 2) and no mixing_inputs"
        );
        let e = MachineProfile::from_toml_str("single_nozzle_tools = 9\n").unwrap_err().to_string();
        assert_eq!(e, "single_nozzle_tools = 9 is out of range: 0 to 8 tools");
    }

    #[test]
    fn mixing_inputs_fill_steps_and_must_agree() {
        let p = MachineProfile::from_toml_str("mixing_inputs = 4\n").unwrap();
        assert_eq!(p.motion.steps.mixing_e, vec![500.0; 4]);
        let err = MachineProfile::from_toml_str(
            "mixing_inputs = 2\n[motion.steps]\nmixing_e = [500.0, 500.0, 500.0]\n",
        );
        assert_eq!(err, Err(MachineProfileError::MixingSteps { inputs: 2, steps: 3 }));
    }

    #[test]
    fn rotary_needs_steps_and_bad_values_are_named() {
        assert_eq!(MachineProfile::from_toml_str("[rotary]\n"), Err(MachineProfileError::RotaryWithoutSteps));
        let err = MachineProfile::from_toml_str("[homing]\nfeed_mm_s = [50.0, 0.0, 4.0]\n").unwrap_err();
        assert_eq!(err.to_string(), "[homing] feed_mm_s[1] = 0 is out of range: 0.01 to 1000 mm/s");
        let err = MachineProfile::from_toml_str("[homing]\norder = \"XXZ\"\n");
        assert_eq!(err, Err(MachineProfileError::HomingOrder("XXZ".into())));
    }

    /// The example profile with one key's value replaced.
    fn ramps_with(key: &str, value: &str) -> Result<MachineProfile, MachineProfileError> {
        let text = include_str!("../../../../examples/machines/marlin-ramps.toml");
        let line = text.lines().find(|l| l.starts_with(&format!("{key} ="))).expect(key);
        MachineProfile::from_toml_str(&text.replace(line, &format!("{key} = {value}")))
    }

    #[test]
    fn every_numeric_key_has_a_range_nan_inf_huge_and_negative_are_refused() {
        let cases = [
            ("x_min_mm", "1e308", "[bed] x_min_mm = 1e308 is out of range: -10000 to 10000 mm"),
            ("sample_period_s", "1e308", "[thermal] sample_period_s = 1e308 is out of range: 0.001 to 10 s"),
            ("extrude_min_c", "nan", "[thermal] extrude_min_c = nan is out of range: 0 to 500 °C"),
            ("extrude_min_c", "-1", "[thermal] extrude_min_c = -1 is out of range: 0 to 500 °C"),
            ("power_w", "inf", "[thermal.hotends[0]] power_w = inf is out of range: 0.1 to 5000 W"),
            (
                "junction_deviation_mm",
                "-1",
                "[motion.corners] junction_deviation_mm = -1 is out of range: 0.0001 to 10 mm",
            ),
            ("e", "1e308", "[motion.steps] e = 1e308 is out of range: 0.001 to 1000000 steps/unit"),
            ("mixing_inputs", "99", "mixing_inputs = 99 is out of range: 0 to 16 inputs"),
        ];
        for (key, value, message) in cases {
            let err = ramps_with(key, value).unwrap_err();
            assert_eq!(err.to_string(), message, "{key} = {value}");
        }
        let text = "[[thermal.hotends]]\npower_w = 40.0\nheat_capacity_j_k = 12.0\nloss_w_k = 0.1\n\
                    [thermal.hotend_protection]\nrunaway_period_s = 40.0\nrunaway_hysteresis_c = 4.0\n\
                    watch_period_s = 20.0\nwatch_increase_c = 2.0\nmin_temp_c = 5.0\nmax_temp_c = 1e308\n";
        let err = MachineProfile::from_toml_str(text).unwrap_err().to_string();
        assert_eq!(err, "[thermal.hotend_protection] max_temp_c = 1e308 is out of range: 0 to 500 °C");
    }

    /// Regression: an inkjet canvas of 1e308 mm (or a bed at 10 000 dpi) aborted `sim` on its
    /// allocation; the canvas size, given or computed, is bounded.
    #[test]
    fn inkjet_canvas_size_is_bounded_given_or_computed() {
        let text = include_str!("../../../../examples/machines/inkjet-c6602.toml");
        let p = MachineProfile::from_toml_str(text).unwrap();
        let mut wide = p.clone();
        wide.inkjet.as_mut().unwrap().width_px = Some(1_000_000);
        let err = wide.validate().unwrap_err().to_string();
        assert_eq!(err, "[inkjet] width_px = 1000000 is out of range: 1 to 20000 px");
        let mut fine = p;
        let ink = fine.inkjet.as_mut().unwrap();
        (ink.width_px, ink.height_px, ink.printhead.dpi) = (None, None, 10_000.0);
        fine.bed.x_mm = 5_000.0;
        let err = fine.validate().unwrap_err().to_string();
        assert_eq!(
            err,
            "[inkjet] width_px (unset: the bed in nozzle pitches) = 1960630 is out of range: 1 to 20000 px"
        );
    }

    #[test]
    fn unknown_key_in_marlin_corners_is_refused() {
        let err = ramps_with("lookahead_blocks", "16\njunction_deviaton_mm = 0.02").unwrap_err().to_string();
        assert!(err.contains("unknown field `junction_deviaton_mm`"), "{err}");
        let err = MachineProfile::from_toml_str("[thermal.hotend_control]\nkind = \"bang_bang\"\nhyst = 1\n");
        assert!(err.unwrap_err().to_string().contains("unknown field `hyst`"));
    }

    #[test]
    fn fault_specs_parse_and_print() {
        let f: FaultSpec = "hotend-cartridge-off@120s".parse().unwrap();
        assert_eq!(
            f,
            FaultSpec { heater: HeaterId::Hotend(0), fault: HeaterFault::CartridgeDisconnected, at_s: 120.0 }
        );
        let f: FaultSpec = "hotend1-thermistor-shorted@2.5".parse().unwrap();
        assert_eq!(
            (f.heater, f.fault, f.at_s),
            (HeaterId::Hotend(1), HeaterFault::Sensor(SensorFault::Shorted), 2.5)
        );
        assert_eq!(f.to_string(), "hotend1-thermistor-shorted@2.5s");
        assert!("bed-melted@3s".parse::<FaultSpec>().is_err());
        assert!("bed-thermistor-open".parse::<FaultSpec>().is_err());
        let p = MachineProfile::from_toml_str("faults = [\"bed-thermistor-open@30s\"]\n").unwrap();
        assert_eq!(p.faults[0].heater, HeaterId::Bed);
    }
}
