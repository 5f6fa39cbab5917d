//! The hardware profile and the job: what the mixing hotend is loaded with, how its firmware
//! speaks, how to purge, the Z feed cap, and which colour goes where. One TOML file holds it all
//! (see `examples/mix/*.toml`); every key is checked and unknown keys are rejected.
//!
//! ```toml
//! [hardware]
//! dialect = "marlin"            # marlin | marlin-direct | reprapfirmware (unset: from the file)
//! virtual_tools = 16
//! filament_diameter_mm = 1.75
//! material2_input = 3           # the input holding "material 2" (default: the last)
//! [[hardware.inputs]]
//! colour = "#00a0e0"
//! material = "PLA"
//! # ... one table per input, E0 first
//!
//! [purge]
//! mode = "length"               # off | length | volume | colours | washout
//! length_mm = 25.0
//! initial_mm = 0.0              # purge before the file's first extrusion, in the first mix
//!
//! [z_cap]
//! max_z_feed_mm_min = 200.0
//! mode = "split"                # split | slow
//!
//! [mix.Pink]                    # user colours, as in the colour palette
//! ratios = [0, 0.6, 0.1, 0.3]
//!
//! [[schedule]]                  # single-tool input: colour by layer (or z_mm)
//! layer = 0
//! mix = "Orange"
//!
//! [map]                         # multi-tool input: slicer tool -> mix
//! T1 = "PVA"
//! ```
//!
//! A mix is named by a palette name (`Orange`), a colour (`#ff8800`, solved for the loaded
//! filaments), or a material (`PVA`: 100 % of the input loaded with it; `support` is the
//! material-2 input), optionally with a proportion of material 2: `Orange@0.3`.

use std::collections::BTreeMap;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::colour::mixing::{TINT_EXPONENT, TINT_EXPONENT_MAX, TINT_EXPONENT_MIN};
use crate::colour::named_mixes::MixSpec;
use crate::colour::pigments::CMYW_FILAMENTS;
use crate::colour::shape::Shape;
use crate::colour::{MixError, MixingModel, Srgb8};
use crate::firmware::{Firmware, MixCommands};
use crate::gcode::number::NumberFormat;
use crate::post::purge_block::PurgeMotion;
use crate::range::{self, OutOfRange, Range, FILAMENT_DIAMETER_MM, LAYER_NUMBER, PURGE_MM, PURGE_MM3};
use crate::settings::{CheckRanges, Table};

use super::MixPassError;

use super::job::split_eq;
pub use super::job::{At, GradientSpace, GradientSpec, MixBase, MixRef, ScheduleEntry};

impl FromStr for MixCommands {
    type Err = MixPassError;
    /// The profile's names (`marlin`, `marlin-direct`, `reprapfirmware`; `reprap` still
    /// accepted), as its TOML reads them.
    fn from_str(s: &str) -> Result<Self, MixPassError> {
        use serde::de::{value::Error, IntoDeserializer};
        MixCommands::deserialize(s.into_deserializer())
            .map_err(|e: Error| MixPassError::Config(format!("dialect: {e}")))
    }
}

/// One filament input of the hotend.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Input {
    /// The filament's colour (sRGB), for the mixing model.
    pub colour: Srgb8,
    /// The filament's material, for reports (default PLA).
    #[serde(default = "default_material")]
    pub material: String,
    /// For purge waste in grams, g/cm^3 (PLA about 1.24, PVA about 1.23).
    #[serde(default = "default_density")]
    pub density_g_cm3: f64,
    /// How strongly it tints a mix (the scattering scale of the pigment model, see
    /// `crate::colour::mixing`); unset, from its colour. `gweave mix --fit` measures it.
    #[serde(default)]
    pub strength: Option<f64>,
    /// Its spectral shape (seven bump weights at 400, 450, .. 700 nm, see
    /// `crate::colour::shape`); unset, none. `gweave mix --fit` measures it.
    #[serde(default)]
    pub shape: Option<Shape>,
    /// How its share weighs in a mix, `share^tint_exponent` (see `crate::colour::mixing`,
    /// step 3); unset, 1.7. `gweave mix --fit` measures it.
    #[serde(default)]
    pub tint_exponent: Option<f64>,
}

fn default_material() -> String {
    "PLA".into()
}
fn default_density() -> f64 {
    1.24
}

/// The mixing hotend and its firmware.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Hardware {
    /// Input 0 first. Default: the mixing post-processor seed's cyan, magenta, yellow and white PLA.
    pub inputs: Vec<Input>,
    /// How the firmware is told the mix; unset, the file's flavour decides
    /// ([`MixProfile::dialect_for_file`]), and Marlin when the file does not say.
    pub dialect: Option<MixCommands>,
    /// Virtual tools the firmware stores (Marlin MIXING_VIRTUAL_TOOLS, default 16).
    pub virtual_tools: usize,
    /// Filament diameter, mm.
    pub filament_diameter_mm: f64,
    /// The input holding "material 2" (default: the last input).
    pub material2_input: Option<usize>,
    /// Decimals of the ratios written (they always sum to exactly 1).
    pub ratio_decimals: u32,
    /// RepRapFirmware: the heater of the mixing tools (`M563 ... H<h>`).
    pub rrf_heater: u32,
}

impl Default for Hardware {
    fn default() -> Self {
        let names = ["PLA"; 4];
        Hardware {
            inputs: CMYW_FILAMENTS
                .iter()
                .zip(names)
                .map(|(&colour, m)| Input {
                    colour,
                    material: m.into(),
                    density_g_cm3: default_density(),
                    strength: None,
                    shape: None,
                    tint_exponent: None,
                })
                .collect(),
            dialect: None,
            virtual_tools: crate::colour::dialect::MARLIN_VIRTUAL_TOOLS,
            filament_diameter_mm: 1.75,
            material2_input: None,
            ratio_decimals: 4,
            rrf_heater: 1,
        }
    }
}

impl Hardware {
    /// The dialect written: the profile's, or Marlin's if it is still unset.
    pub fn dialect(&self) -> MixCommands {
        self.dialect.unwrap_or_default()
    }

    /// The pigment model for the loaded filaments (their colours, strengths, shapes and tinting
    /// exponents): the one model
    /// that the mix pass, `--predict`, previews and swatches use.
    pub fn mixing_model(&self) -> Result<MixingModel, MixError> {
        let colours: Vec<Srgb8> = self.inputs.iter().map(|i| i.colour).collect();
        let strengths: Vec<f64> = self
            .inputs
            .iter()
            .map(|i| i.strength.unwrap_or_else(|| MixingModel::default_strength(i.colour)))
            .collect();
        let shapes: Vec<Shape> = self.inputs.iter().map(|i| i.shape.unwrap_or_default()).collect();
        let tints: Vec<f64> = self.inputs.iter().map(|i| i.tint_exponent.unwrap_or(TINT_EXPONENT)).collect();
        MixingModel::with_shapes(&colours, &strengths, &shapes)?.with_new_tint_exponents(&tints)
    }

    /// The input that holds material 2.
    pub fn material2_index(&self) -> usize {
        self.material2_input.unwrap_or(self.inputs.len().saturating_sub(1))
    }
}

/// The card's geometry and printing (`[card]` in the profile).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CardConfig {
    /// Side of a square swatch, mm.
    pub patch_mm: f64,
    /// Space between swatches, mm.
    pub gap_mm: f64,
    /// Swatches per row.
    pub columns: u32,
    /// Layers of each swatch.
    pub layers: u32,
    /// Layer height, mm.
    pub layer_mm: f64,
    /// Extrusion width and line spacing, mm.
    pub line_mm: f64,
    /// Front left corner of swatch 1, mm (away from the purge spot at X10 Y10).
    pub x_mm: f64,
    /// Y of the front left corner of swatch 1, mm.
    pub y_mm: f64,
    /// Hotend temperature, °C.
    pub hotend_c: f64,
    /// Bed temperature, °C.
    pub bed_c: f64,
    /// Feed while printing, mm/min.
    pub print_feed_mm_min: f64,
    /// Feed of travels, mm/min.
    pub travel_feed_mm_min: f64,
}

impl Default for CardConfig {
    fn default() -> Self {
        CardConfig {
            patch_mm: 15.0,
            gap_mm: 5.0,
            columns: 6,
            layers: 5,
            layer_mm: 0.2,
            line_mm: 0.45,
            x_mm: 40.0,
            y_mm: 40.0,
            hotend_c: 210.0,
            bed_c: 60.0,
            print_feed_mm_min: 1800.0,
            travel_feed_mm_min: 6000.0,
        }
    }
}

impl CheckRanges for CardConfig {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("patch_mm", self.patch_mm, range::Range::new(3.0, 100.0, "mm"))?;
        t.check("gap_mm", self.gap_mm, range::Range::new(1.0, 100.0, "mm"))?;
        t.count("columns", u64::from(self.columns), range::Range::new(1.0, 100.0, ""))?;
        t.count("layers", u64::from(self.layers), range::Range::new(1.0, 100.0, ""))?;
        t.check("layer_mm", self.layer_mm, range::LAYER_HEIGHT_MM)?;
        t.check("line_mm", self.line_mm, range::Range::new(0.1, 3.0, "mm"))?;
        t.check("x_mm", self.x_mm, range::POSITION_MM)?;
        t.check("y_mm", self.y_mm, range::POSITION_MM)?;
        t.check("hotend_c", self.hotend_c, range::Range::new(0.0, 500.0, "°C"))?;
        t.check("bed_c", self.bed_c, range::Range::new(0.0, 150.0, "°C"))?;
        t.check("print_feed_mm_min", self.print_feed_mm_min, range::FEED_MM_MIN)?;
        t.check("travel_feed_mm_min", self.travel_feed_mm_min, range::FEED_MM_MIN)
    }
}

/// How the purge length is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum PurgeMode {
    /// No purge.
    Off,
    /// `length_mm` of filament.
    #[default]
    Length,
    /// `volume_mm3` of plastic.
    Volume,
    /// OrcaSlicer's formula from the two predicted colours, times `multiplier`.
    Colours,
    /// The washout model: `dead_mm3 + chamber_mm3 * ln(1 / tolerance)`.
    Washout,
}

/// A purge amount for one change of colour, overriding the mode.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairPurge {
    /// The mix before the change (a name or colour as in the schedule).
    pub from: String,
    /// The mix after the change.
    pub to: String,
    /// Purge this much filament, mm.
    pub length_mm: Option<f64>,
    /// Purge this much plastic, mm^3.
    pub volume_mm3: Option<f64>,
}

/// The purge at each change of mix. Defaults are the mixing post-processor seed's (`docs/seeds.md`): retract 4 mm, lift 15 mm, go to
/// X10 Y10, extrude 25 mm. Its `Deserialize` reads mix's own keys with this derive and the
/// motion's from the same table (`purge_table.rs`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields, default)]
pub struct PurgeConfig {
    /// How the purge amount is found.
    pub mode: PurgeMode,
    /// Filament purged in `length` mode, mm.
    pub length_mm: f64,
    /// Purged in the first mix before the file first moves filament (0: none): the chamber may
    /// hold anything from the last print or a hand-loaded colour.
    pub initial_mm: f64,
    /// Plastic purged in `volume` mode, mm^3.
    pub volume_mm3: f64,
    /// Scales OrcaSlicer's volume (`colours` mode).
    pub multiplier: f64,
    /// Volume of the mixing chamber (`washout` mode), mm^3.
    pub chamber_mm3: f64,
    /// Volume between the chamber and the nozzle tip that purges at once (`washout` mode), mm^3.
    pub dead_mm3: f64,
    /// Old-colour fraction left after the purge (`washout` mode).
    pub tolerance: f64,
    /// Where and how the block moves: `retract_mm`, `lift_mm`, `x_mm`, `y_mm`, `wipe_mm` and the
    /// feeds, keys of this same table (the Z feed unset: the travel feed under the Z cap).
    #[serde(skip)]
    pub motion: PurgeMotion,
    /// Purge at every step of a gradient too (normally the blend is the point).
    pub on_gradient_steps: bool,
    /// Amounts for given changes of mix, over `mode`.
    pub pair: Vec<PairPurge>,
    /// `seed`: the mixing seed's purge feeds (`PurgeMotion::with_seed_feeds`) over the feed
    /// and wipe keys.
    pub style: PurgeStyle,
}

/// Whose feeds the purge block moves with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum PurgeStyle {
    /// The profile's feeds (retract and unretract fast, so that the nozzle does not ooze
    /// meanwhile; a wipe after the purge).
    #[default]
    Gweave,
    /// The seed's: F200 throughout, F150 to lower and unretract, no wipe.
    Seed,
}

impl PurgeConfig {
    /// A purge of `mm` of filament at each change, 0 for none (`--purge-mm`, `purge_mm=`).
    pub fn set_length_mm(&mut self, mm: f64) {
        self.length_mm = mm;
        self.mode = if mm > 0.0 { PurgeMode::Length } else { PurgeMode::Off };
    }

    /// The purge block's moves: the Z feed is the one set, else the travel feed, at most
    /// `z_cap_mm_min` (0: no cap).
    pub fn motion(&self, z_cap_mm_min: f64) -> PurgeMotion {
        let z_mm_min = self.motion.z_feed_mm_min.unwrap_or(self.motion.travel_feed_mm_min);
        let z_mm_min = if z_cap_mm_min > 0.0 { z_cap_mm_min.min(z_mm_min) } else { z_mm_min };
        let motion = PurgeMotion { z_feed_mm_min: Some(z_mm_min), ..self.motion };
        match self.style {
            PurgeStyle::Gweave => motion,
            PurgeStyle::Seed => motion.with_seed_feeds(),
        }
    }
}

impl Default for PurgeConfig {
    fn default() -> Self {
        PurgeConfig {
            mode: PurgeMode::Length,
            length_mm: 25.0,
            initial_mm: 0.0,
            volume_mm3: 90.0,
            multiplier: 1.0,
            chamber_mm3: 40.0,
            dead_mm3: 10.0,
            tolerance: 0.02,
            motion: PurgeMotion::SEED,
            on_gradient_steps: false,
            pair: Vec::new(),
            style: PurgeStyle::Gweave,
        }
    }
}

/// What to do with a move whose Z speed is over the cap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ZCapMode {
    /// Z alone at the cap first, then XY at the original feed rate (as the seed did).
    #[default]
    Split,
    /// Slow the whole move until its Z component is at the cap.
    Slow,
    /// The mixing post-processor seed's rule: every move with a Z word and F above the cap is
    /// split as `split` does, however little Z moves (see [`crate::post::zcap`]).
    Seed,
}

/// The Z feed-rate cap. The mixing post-processor seed's printer could not move Z faster than F200 (mm/min).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ZCapConfig {
    /// Largest Z speed, mm/min (0: no cap).
    pub max_z_feed_mm_min: f64,
    /// What to do with a move whose Z runs faster than the cap.
    pub mode: ZCapMode,
}

impl Default for ZCapConfig {
    fn default() -> Self {
        ZCapConfig { max_z_feed_mm_min: 200.0, mode: ZCapMode::Split }
    }
}

/// What the slicer's own tool-change retractions become.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ToolChangeConfig {
    /// Keep the retraction before a slicer `T<n>` and the unretraction after it. A mixing hotend
    /// has one melt zone, so a multi-material unload (10 mm and more) only wastes time.
    pub keep_slicer_retractions: bool,
}

impl Default for ToolChangeConfig {
    fn default() -> Self {
        ToolChangeConfig { keep_slicer_retractions: true }
    }
}

/// Everything `gweave mix` needs.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct MixProfile {
    /// The mixing hotend and its firmware (`[hardware]`).
    pub hardware: Hardware,
    /// The purge at each change of mix (`[purge]`).
    pub purge: PurgeConfig,
    /// The Z feed cap (`[z_cap]`).
    pub z_cap: ZCapConfig,
    /// What slicer tool-change retractions become (`[tool_change]`).
    pub tool_change: ToolChangeConfig,
    /// Format of the numbers in new lines.
    pub numbers: NumberFormat,
    /// User colours by name (`[mix.Pink] ratios = [...]` or `colour = "#..."`).
    pub mix: BTreeMap<String, MixSpec>,
    /// Mixes from given layers or heights on (`[[schedule]]`).
    pub schedule: Vec<ScheduleEntry>,
    /// Blends over layer or Z ranges (`[[gradient]]`).
    pub gradient: Vec<GradientSpec>,
    /// Slicer tool (`T1`) to mix.
    pub map: BTreeMap<String, MixRef>,
    /// The calibration card (`gweave mix --calibration-card`).
    pub card: CardConfig,
}

impl MixProfile {
    /// Reads and validates a profile.
    pub fn from_toml_str(text: &str) -> Result<Self, MixPassError> {
        let profile: MixProfile =
            toml::from_str(text).map_err(|e| MixPassError::Config(crate::settings::toml_message(&e)))?;
        profile.validate()?;
        Ok(profile)
    }

    /// Settles the dialect for a file sliced for `flavour` (see [`flavour_in`]) when the profile
    /// leaves it unset.
    ///
    /// [`flavour_in`]: crate::gcode::flavour::flavour_in
    pub fn dialect_for_file(&mut self, flavour: Option<&str>) {
        let hw = &mut self.hardware;
        hw.dialect = Some(hw.dialect.unwrap_or_else(|| Firmware::resolve(None, flavour).mix_commands()));
    }

    /// Adds `--map T1=PVA`.
    pub fn add_map(&mut self, s: &str) -> Result<(), MixPassError> {
        let (tool, mix) = split_eq(s)?;
        parse_tool(tool)?;
        self.map.insert(tool.to_ascii_uppercase(), mix.parse()?);
        Ok(())
    }

    /// The slicer tool map with tool numbers.
    pub fn tool_map(&self) -> Result<BTreeMap<u32, MixRef>, MixPassError> {
        self.map.iter().map(|(k, v)| Ok((parse_tool(k)?, v.clone()))).collect()
    }

    /// Checks every range and the combination of settings.
    pub fn validate(&self) -> Result<(), MixPassError> {
        let cfg = |m: String| Err(MixPassError::Config(m));
        let hw = &self.hardware;
        if hw.inputs.is_empty() {
            return cfg("hardware.inputs: at least one input".into());
        }
        if let Some(max) = hw.dialect().max_inputs().filter(|&max| hw.inputs.len() > max) {
            return cfg(format!("marlin-direct (M165) has letters for {max} inputs at most"));
        }
        if hw.virtual_tools == 0 && hw.dialect().uses_tools() {
            return cfg("hardware.virtual_tools must be at least 1".into());
        }
        if hw.material2_index() >= hw.inputs.len() {
            return cfg(format!("hardware.material2_input {} does not exist", hw.material2_index()));
        }
        self.check_ranges(&Table::root())?;
        for pair in &self.purge.pair {
            if pair.length_mm.is_some() == pair.volume_mm3.is_some() {
                return cfg(format!("purge pair {} -> {}: give length_mm or volume_mm3", pair.from, pair.to));
            }
        }
        let scheduled = !(self.schedule.is_empty() && self.gradient.is_empty());
        if !self.map.is_empty() && scheduled {
            return cfg("use either a layer/Z schedule (with gradients) or a tool map, not both".into());
        }
        for s in &self.schedule {
            s.at()?;
        }
        for g in &self.gradient {
            g.range()?;
        }
        self.tool_map()?;
        Ok(())
    }
}

const INPUTS: Range = Range::new(1.0, 16.0, "inputs");
/// Pigment strengths: the default runs from 0.01 (black) to 1.01 (white); carbon black and
/// fitted values go above, nothing mixes at 0.
const STRENGTH: Range = Range::new(0.001, 100.0, "");
/// Spectral shape weights: `gweave mix --fit` keeps them within ±3 (see `colour::fit`).
const SHAPE: Range = Range::new(-3.0, 3.0, "");
/// Tinting exponents: the range `gweave mix --fit` keeps them in (see `colour::mixing`).
const TINT_EXPONENT_RANGE: Range = Range::new(TINT_EXPONENT_MIN, TINT_EXPONENT_MAX, "");
/// Filament densities, from foams to metal-filled filaments.
const DENSITY_G_CM3: Range = Range::new(0.1, 25.0, "g/cm³");
const VIRTUAL_TOOLS: Range = Range::new(0.0, 1_000.0, "tools");
const RATIO_DECIMALS: Range = Range::new(0.0, crate::colour::dialect::Decimals::MAX as f64, "");
/// RepRapFirmware heater numbers.
const RRF_HEATER: Range = Range::new(0.0, 255.0, "");
const CHAMBER_MM3: Range = Range::new(0.001, 10_000.0, "mm³");
const MULTIPLIER: Range = Range::new(0.001, 100.0, "");
/// The washout tolerance: the share of the old colour left, below 1.
const TOLERANCE: Range = Range::new(0.000_001, 0.999, "");
/// 0 turns the Z feed cap off.
const Z_CAP_MM_MIN: Range = Range::new(0.0, 600_000.0, "mm/min");
const EVERY_LAYERS: Range = Range::new(1.0, 1_000_000.0, "layers");
/// Named mixes, gradients, purge pairs and tool mappings of one profile: more than any job
/// paints with (a virtual tool per mix is at most 1 000), few enough that every one is
/// resolved (a colour solved for the loaded filaments) in a few seconds.
const ENTRIES: Range = Range::new(0.0, 4_096.0, "entries");
/// Schedule entries: one per layer at most ([`range::MAX_LAYERS`]).
const SCHEDULE_ENTRIES: Range = Range::new(0.0, range::MAX_LAYERS as f64, "entries");

impl CheckRanges for MixProfile {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        // The counts first: they size what the checks below walk.
        t.count("mix (count)", self.mix.len() as u64, ENTRIES)?;
        t.count("schedule (count)", self.schedule.len() as u64, SCHEDULE_ENTRIES)?;
        t.count("gradient (count)", self.gradient.len() as u64, ENTRIES)?;
        t.count("map (count)", self.map.len() as u64, ENTRIES)?;
        t.sub("purge").count("pair (count)", self.purge.pair.len() as u64, ENTRIES)?;
        let hw = &self.hardware;
        let hardware = t.sub("hardware");
        hardware.count("inputs (count)", hw.inputs.len() as u64, INPUTS)?;
        for (i, input) in hw.inputs.iter().enumerate() {
            let item = hardware.sub("inputs").item(i);
            item.check("density_g_cm3", input.density_g_cm3, DENSITY_G_CM3)?;
            item.check_opt("strength", input.strength, STRENGTH)?;
            for (k, &a) in input.shape.iter().flatten().enumerate() {
                item.check(&format!("shape[{k}]"), a, SHAPE)?;
            }
            item.check_opt("tint_exponent", input.tint_exponent, TINT_EXPONENT_RANGE)?;
        }
        hardware.count("virtual_tools", hw.virtual_tools as u64, VIRTUAL_TOOLS)?;
        hardware.check("filament_diameter_mm", hw.filament_diameter_mm, FILAMENT_DIAMETER_MM)?;
        hardware.count("ratio_decimals", hw.ratio_decimals, RATIO_DECIMALS)?;
        hardware.count("rrf_heater", hw.rrf_heater, RRF_HEATER)?;
        let p = &self.purge;
        let purge = t.sub("purge");
        purge.check("length_mm", p.length_mm, PURGE_MM)?;
        purge.check("initial_mm", p.initial_mm, PURGE_MM)?;
        purge.check("volume_mm3", p.volume_mm3, PURGE_MM3)?;
        purge.check("multiplier", p.multiplier, MULTIPLIER)?;
        purge.check("chamber_mm3", p.chamber_mm3, CHAMBER_MM3)?;
        purge.check("dead_mm3", p.dead_mm3, PURGE_MM3)?;
        purge.check("tolerance", p.tolerance, TOLERANCE)?;
        p.motion.check_ranges(&purge)?;
        for (i, pair) in p.pair.iter().enumerate() {
            let table = purge.sub("pair").item(i);
            table.check_opt("length_mm", pair.length_mm, PURGE_MM)?;
            table.check_opt("volume_mm3", pair.volume_mm3, PURGE_MM3)?;
        }
        t.sub("z_cap").check("max_z_feed_mm_min", self.z_cap.max_z_feed_mm_min, Z_CAP_MM_MIN)?;
        self.numbers.check_ranges(&t.sub("numbers"))?;
        self.card.check_ranges(&t.sub("card"))?;
        for (i, s) in self.schedule.iter().enumerate() {
            let table = t.sub("schedule").item(i);
            table.check_opt("layer", s.layer, LAYER_NUMBER)?;
            table.check_opt("z_mm", s.z_mm, range::LEN_MM)?;
        }
        for (i, g) in self.gradient.iter().enumerate() {
            let table = t.sub("gradient").item(i);
            table.check_opt("from_layer", g.from_layer, LAYER_NUMBER)?;
            table.check_opt("to_layer", g.to_layer, LAYER_NUMBER)?;
            table.check_opt("from_z_mm", g.from_z_mm, range::LEN_MM)?;
            table.check_opt("to_z_mm", g.to_z_mm, range::LEN_MM)?;
            table.count("every_layers", g.every_layers, EVERY_LAYERS)?;
            table.check("z_step_mm", g.z_step_mm, range::SIZE_MM)?;
        }
        Ok(())
    }
}

/// `T1` -> 1.
fn parse_tool(s: &str) -> Result<u32, MixPassError> {
    s.strip_prefix(['T', 't'])
        .and_then(|n| n.parse().ok())
        .ok_or_else(|| MixPassError::Config(format!("{s:?} is not a slicer tool like T1")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dialect_names_are_the_profiles() {
        let names = ["marlin", "marlin-direct", "reprapfirmware", "reprap"]
            .map(|n| n.parse::<MixCommands>().unwrap());
        let rrf = MixCommands::RepRapFirmware;
        assert_eq!(names, [MixCommands::Marlin, MixCommands::MarlinDirect, rrf, rrf]);
        let err = "rrf".parse::<MixCommands>().unwrap_err().to_string();
        assert!(err.contains("unknown variant `rrf`"), "{err}");
    }

    #[test]
    fn flags_parse() {
        let e = ScheduleEntry::parse_layer("10=Pink").unwrap();
        assert_eq!((e.at().unwrap(), e.mix.label()), (At::Layer(10), "Pink".into()));
        assert_eq!(ScheduleEntry::parse_z("2.5=Blue").unwrap().at().unwrap(), At::Z(2.5));
        let g = GradientSpec::parse("0-50/2=Cyan..Magenta", GradientSpace::Mix).unwrap();
        assert_eq!((g.from_layer, g.to_layer, g.every_layers), (Some(0), Some(50), 2));
        let g = GradientSpec::parse("z1-5=Cyan..#ff0000", GradientSpace::Perceived).unwrap();
        assert_eq!((g.from_z_mm, g.to_z_mm), (Some(1.0), Some(5.0)));
        assert!(GradientSpec::parse("5-1=Cyan..Magenta", GradientSpace::Mix).is_err());
        let mut p = MixProfile::default();
        p.add_map("T1=PVA").unwrap();
        assert_eq!(p.tool_map().unwrap()[&1].label(), "PVA");
        assert!(p.add_map("X1=PVA").is_err());
    }

    #[test]
    fn defaults_are_the_seeds() {
        let p = MixProfile::from_toml_str("").unwrap();
        let m = &p.purge.motion;
        assert_eq!((m.retract_mm, m.lift_mm, p.purge.length_mm), (4.0, 15.0, 25.0));
        assert_eq!((m.x_mm, m.y_mm), (10.0, 10.0));
        assert_eq!(p.z_cap.max_z_feed_mm_min, 200.0);
        assert_eq!((p.hardware.virtual_tools, p.hardware.inputs.len()), (16, 4));
    }

    #[test]
    fn purge_z_feed_is_the_travel_feed_under_the_cap_unless_set() {
        let z =
            |text: &str, cap: f64| MixProfile::from_toml_str(text).unwrap().purge.motion(cap).z_feed_mm_min;
        assert_eq!(z("", 200.0), Some(200.0));
        assert_eq!(z("", 0.0), Some(1320.0));
        assert_eq!(z("[purge]\nz_feed_mm_min = 100", 200.0), Some(100.0));
        assert_eq!(z("[purge]\nz_feed_mm_min = 900", 200.0), Some(200.0));
        assert_eq!(z("[purge]\nstyle = \"seed\"", 0.0), Some(PurgeMotion::SEED_Z_FEED_MM_MIN));
    }

    #[test]
    fn rejects_bad_profiles() {
        assert!(MixProfile::from_toml_str("[purge]\nlenght_mm = 3").is_err());
        assert!(MixProfile::from_toml_str("[purge]\nretract_mm = -1").is_err());
        assert!(MixProfile::from_toml_str("[[schedule]]\nlayer = 1\nz_mm = 2\nmix = \"Red\"").is_err());
        let both = "[[schedule]]\nlayer = 0\nmix = \"Red\"\n[map]\nT1 = \"Blue\"";
        assert!(MixProfile::from_toml_str(both).is_err());
    }

    #[test]
    fn every_numeric_key_has_a_range() {
        let msg = |text: &str| MixProfile::from_toml_str(text).unwrap_err().to_string();
        assert_eq!(
            msg("[purge]\nlength_mm = 1e308"),
            "[purge] length_mm = 1e308 is out of range: 0 to 1000 mm"
        );
        assert_eq!(msg("[purge]\nretract_mm = -1"), "[purge] retract_mm = -1 is out of range: 0 to 10000 mm");
        assert_eq!(msg("[purge]\nx_mm = nan"), "[purge] x_mm = nan is out of range: -10000 to 10000 mm");
        assert_eq!(
            msg("[hardware]\nfilament_diameter_mm = inf"),
            "[hardware] filament_diameter_mm = inf is out of range: 0.5 to 5 mm"
        );
        assert_eq!(
            msg("[[gradient]]\nfrom_z_mm = 0\nto_z_mm = 1e308\nstart = \"Red\"\nend = \"Blue\""),
            "[gradient[0]] to_z_mm = 1e308 is out of range: 0 to 10000 mm"
        );
        assert_eq!(
            msg("[numbers]\nposition_decimals = 200"),
            "[numbers] position_decimals = 200 is out of range: 0 to 9 decimals"
        );
        assert!(msg("[z_cap]\nmax_z_feed = 1").contains("unknown field `max_z_feed`"));
        assert!(
            msg("[[hardware.inputs]]\ncolour = \"#ffffff\"\ndensity = 1").contains("unknown field `density`")
        );
    }
    /// Every key `[purge]` reads, in the order unknown-key errors list them: its own, then the
    /// purge motion's (the keys of purge-shift's `[block]`).
    const PURGE_KEYS: &str = "`mode`, `length_mm`, `initial_mm`, `volume_mm3`, `multiplier`, `chamber_mm3`, \
        `dead_mm3`, `tolerance`, `on_gradient_steps`, `pair`, `style`, `retract_mm`, `lift_mm`, `x_mm`, `y_mm`, \
        `wipe_mm`, `travel_feed_mm_min`, `extrude_feed_mm_min`, `retract_feed_mm_min`, `z_feed_mm_min`, \
        `return_feed_mm_min`, `lower_feed_mm_min`, `unretract_feed_mm_min`";

    #[test]
    fn unknown_key_in_purge_is_reported_at_its_own_line_with_the_expected_keys() {
        let err = MixProfile::from_toml_str(
            "[hardware]
virtual_tools = 4

[purge]
mode = \"length\"\nlenght_mm = 3\n",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("TOML parse error at line 6, column 1\n"), "{err}");
        assert!(err.contains("6 | lenght_mm = 3\n"), "{err}");
        assert!(
            err.ends_with(&format!("unknown field `lenght_mm`, expected one of {PURGE_KEYS}\n")),
            "{err}"
        );
    }

    #[test]
    fn wrong_type_in_purge_is_reported_at_its_own_value() {
        let msg = |text: &str| MixProfile::from_toml_str(text).unwrap_err().to_string();
        // A key of the purge motion, and one of mix's own.
        let err = msg("[purge]\nmode = \"length\"\nretract_mm = \"4\"\n");
        assert!(err.contains("TOML parse error at line 3, column 14\n"), "{err}");
        assert!(err.ends_with("invalid type: string \"4\", expected f64\n"), "{err}");
        let err = msg("[purge]\nlength_mm = 25\non_gradient_steps = 1\n");
        assert!(err.contains("TOML parse error at line 3, column 21\n"), "{err}");
        assert!(err.ends_with("invalid type: integer `1`, expected a boolean\n"), "{err}");
        let err = msg("[purge]\nz_feed_mm_min = true\n");
        assert!(err.contains("TOML parse error at line 2, column 17\n"), "{err}");
        assert!(err.ends_with("invalid type: boolean `true`, expected f64\n"), "{err}");
    }

    #[test]
    fn purge_keys_read_as_before() {
        let p = MixProfile::from_toml_str(
            "[purge]\nmode = \"volume\"\nvolume_mm3 = 50\nretract_mm = 2\nz_feed_mm_min = 300.5\n\
             style = \"seed\"\nunretract_feed_mm_min = 900\n[[purge.pair]]\nfrom = \"A\"\nto = \"B\"\nlength_mm = 3\n",
        )
        .unwrap();
        let want = PurgeMotion {
            retract_mm: 2.0,
            z_feed_mm_min: Some(300.5),
            unretract_feed_mm_min: Some(900.0),
            ..PurgeMotion::SEED
        };
        assert_eq!(p.purge.motion, want);
        assert_eq!(
            (p.purge.mode, p.purge.volume_mm3, p.purge.style),
            (PurgeMode::Volume, 50.0, PurgeStyle::Seed)
        );
        assert_eq!(p.purge.pair.len(), 1);
        assert_eq!(p.purge.length_mm, 25.0, "a key not given keeps its default");
    }
}
