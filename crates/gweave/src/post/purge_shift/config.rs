//! Settings of the purge-shift pass: how much to purge for each change, and the rules for where
//! a change may go. Read from TOML (unknown keys rejected) or built in code; validated once in
//! [`PurgeShiftConfig::validate`], so the pass itself never meets a bad number.
//!
//! ```toml
//! purge_mm = 2.5                 # filament, mm (or purge_mm3 = 6.0)
//! filament_diameter_mm = 1.75
//! cross_layers = false           # may a change move back into the previous layer?
//! allow_features = ["inner_wall", "infill", "solid_infill"]   # default: all but outer_wall
//! markers = ["begin", "end"]     # explicit print-proper markers (comment text)
//! fallback = "partial"           # too little room: accept the shortfall ("block", "tower")
//! colours = ["#ff0000", "#0000ff"]   # per tool: purge from the colours (OrcaSlicer's rule)
//! [[pair]]                       # a per-pair amount wins over everything else
//! from = 0
//! to = 1
//! purge_mm = 4.0
//! [washout]                      # the mixing chamber, for the report and the tolerance source
//! chamber_mm3 = 4.0
//! dead_mm3 = 1.0
//! tolerance = 0.05               # if set and no purge_mm/purge_mm3: purge = V ln(1/eps) + Vd
//! [block]                        # fallback "block": gweave mix's purge block (the mixing seed's defaults)
//! retract_mm = 4.0
//! lift_mm = 15.0
//! x_mm = 10.0
//! y_mm = 10.0
//! [tower]                        # fallback "tower": a zigzag next to the part at the layer's Z
//! x_mm = 150.0                   # its corner; default: gap_mm beside the print's extent so far
//! y_mm = 20.0
//! ```

use serde::{Deserialize, Serialize};

use crate::colour::purge::{filament_mm_to_mm3, flush_volume_mm3, mm3_to_filament_mm, Washout};
use crate::colour::Srgb8;
use crate::gcode::layers::{Feature, Markers, ALL_FEATURES};
use crate::gcode::limits::MAX_TOOLS;
use crate::options::Said;
use crate::post::purge_block::PurgeMotion;
use crate::range::{self, OutOfRange, Range, FILAMENT_DIAMETER_MM, PURGE_MM, PURGE_MM3};
use crate::settings::{CheckRanges, Table};

/// Why a purge-shift configuration was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// A number outside its range.
    #[error(transparent)]
    Range(#[from] OutOfRange),
    /// No purge amount anywhere ([`ConfigError::said`] names the options that give one).
    #[error("{}", no_purge())]
    NoPurge,
    /// Both `purge_mm` and `purge_mm3`.
    #[error("give either purge_mm or purge_mm3, not both")]
    BothPurges,
    /// A pair with no amount or both.
    #[error("pair {from}->{to} needs exactly one of purge_mm and purge_mm3")]
    Pair {
        /// The tool before the change.
        from: u32,
        /// The tool after it.
        to: u32,
    },
    /// A feature name gweave does not know.
    #[error("unknown feature {0:?} (known: {known})", known = feature_names())]
    Feature(String),
    /// A fallback other than `partial`, `block` or `tower`.
    #[error("unknown fallback {0:?} (known: partial, block, tower)")]
    Fallback(String),
    /// Only one of the tower's `x_mm` and `y_mm`.
    #[error("tower: give both x_mm and y_mm, or neither (placed beside the print)")]
    Tower,
    /// A marker with empty text.
    #[error("markers need non-empty begin and end text")]
    Markers,
    /// Invalid washout settings.
    #[error("washout: {0}")]
    Washout(String),
    /// The configuration's TOML cannot be read.
    #[error("TOML: {0}")]
    Toml(String),
}

fn feature_names() -> String {
    ALL_FEATURES.iter().map(Feature::name).collect::<Vec<_>>().join(", ")
}

/// A purge amount for one tool pair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairPurge {
    pub from: u32,
    pub to: u32,
    #[serde(default)]
    pub purge_mm: Option<f64>,
    #[serde(default)]
    pub purge_mm3: Option<f64>,
}

/// The mixing chamber as a washout system ([`Washout`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WashoutConfig {
    pub chamber_mm3: f64,
    #[serde(default)]
    pub dead_mm3: f64,
    /// Old-colour fraction that counts as clean; also the purge source when no amount is given.
    #[serde(default)]
    pub tolerance: Option<f64>,
}

/// What to do when there is too little room before a change for the whole purge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Fallback {
    /// Move the change as far as the rules allow and report the shortfall.
    #[default]
    Partial,
    /// Also purge the shortfall in a purge block after the change, as `gweave mix` does.
    Block,
    /// Also purge the shortfall as a zigzag on a small tower next to the part.
    Tower,
}

impl Fallback {
    /// The fallback's name in configurations and reports.
    pub fn name(&self) -> &'static str {
        match self {
            Fallback::Partial => "partial",
            Fallback::Block => "block",
            Fallback::Tower => "tower",
        }
    }
}

/// Where and how the `tower` fallback purges. The zigzag is a square-ish patch of lines
/// `line_width_mm` apart whose volume is the shortfall: path length
/// `L = shortfall * A_filament / (line_width * layer_height)`, side `sqrt(L * line_width)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TowerConfig {
    /// The tower's corner (smallest X and Y), mm; unset: `gap_mm` to the right of the print's
    /// XY extent known so far (to the left when the bed ends there).
    pub x_mm: Option<f64>,
    /// The tower's corner along Y, mm (set with `x_mm`).
    pub y_mm: Option<f64>,
    /// Distance from the print's extent, mm.
    pub gap_mm: f64,
    /// The bed the tower stays on, X and Y from 0, mm (the default machine profile's).
    pub bed_mm: [f64; 2],
    /// Line pitch of the zigzag, mm.
    pub line_width_mm: f64,
    /// Layer height the zigzag's flow is computed for, mm.
    pub layer_height_mm: f64,
    /// Z lift for the travels, mm (0: travel at the layer's Z, as the slicer's own travels do).
    pub lift_mm: f64,
    /// Feed of the travels, mm/min.
    pub travel_feed_mm_min: f64,
    /// Feed of the zigzag's extrusion, mm/min.
    pub extrude_feed_mm_min: f64,
    /// Feed of the retraction around the travels when the file's own is not known yet.
    pub retract_feed_mm_min: f64,
}

impl Default for TowerConfig {
    fn default() -> Self {
        TowerConfig {
            x_mm: None,
            y_mm: None,
            gap_mm: 5.0,
            bed_mm: [200.0, 200.0],
            line_width_mm: 0.5,
            layer_height_mm: 0.2,
            lift_mm: 0.0,
            travel_feed_mm_min: 6000.0,
            extrude_feed_mm_min: 1200.0,
            retract_feed_mm_min: 2400.0,
        }
    }
}

/// All settings of the pass. `Default` is the purge-shift seed's (`docs/seeds.md`): 2.5 mm of 1.75 mm filament, no crossing
/// of layers, every feature but the outer wall, no explicit markers, partial fallback.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PurgeShiftConfig {
    /// Filament to purge at each change, mm.
    pub purge_mm: Option<f64>,
    /// Plastic to purge at each change, mm^3 (converted with `filament_diameter_mm`).
    pub purge_mm3: Option<f64>,
    /// Filament diameter, mm.
    pub filament_diameter_mm: f64,
    /// Amounts for given tool pairs, over the global one.
    pub pair: Vec<PairPurge>,
    /// Colour of each tool (`#RRGGBB`), for purge volumes derived from colours.
    pub colours: Vec<String>,
    /// The washout model, purging until the old colour is below a tolerance.
    pub washout: Option<WashoutConfig>,
    /// A change may move back past a layer start.
    pub cross_layers: bool,
    /// Feature names a change may move through (see [`Feature::name`]).
    pub allow_features: Vec<String>,
    /// `[begin, end]` comment texts that delimit the print proper.
    pub markers: Option<[String; 2]>,
    /// What to do with the purge a change cannot move: `partial`, `block` or `tower`.
    pub fallback: String,
    /// The `block` fallback's purge block (as in `gweave mix`'s `[purge]`).
    pub block: PurgeMotion,
    /// The `tower` fallback.
    pub tower: TowerConfig,
    /// Hard cap on held lines, whatever the purge: past it the oldest line is written out and the
    /// walk back stops there (a bound for pathological files with huge runs of non-extrusion).
    pub max_window_lines: usize,
}

impl Default for PurgeShiftConfig {
    fn default() -> Self {
        PurgeShiftConfig {
            purge_mm: None,
            purge_mm3: None,
            filament_diameter_mm: 1.75,
            pair: Vec::new(),
            colours: Vec::new(),
            washout: None,
            cross_layers: false,
            allow_features: ALL_FEATURES
                .iter()
                .filter(|f| **f != Feature::OuterWall)
                .map(|f| f.name().to_string())
                .collect(),
            markers: None,
            fallback: "partial".into(),
            block: PurgeMotion::default(),
            tower: TowerConfig::default(),
            max_window_lines: 200_000,
        }
    }
}

/// A set of features (the ones a change may move through): one bit per [`Feature`], so the
/// test each extruding move makes is a shift and a mask, not a tree search.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct FeatureSet(u32);

impl FeatureSet {
    fn bit(f: Feature) -> u32 {
        1 << f as u32
    }

    pub(crate) fn insert(&mut self, f: Feature) {
        self.0 |= Self::bit(f);
    }

    #[inline]
    pub(crate) fn contains(self, f: Feature) -> bool {
        self.0 & Self::bit(f) != 0
    }
}

impl FromIterator<Feature> for FeatureSet {
    fn from_iter<I: IntoIterator<Item = Feature>>(features: I) -> Self {
        let mut set = FeatureSet::default();
        features.into_iter().for_each(|f| set.insert(f));
        set
    }
}

/// The validated settings the pass runs with: all amounts in mm of filament.
#[derive(Debug, Clone)]
pub struct Rules {
    pub(crate) default_mm: Option<f64>,
    pub(crate) pairs: Vec<(u32, u32, f64)>,
    pub(crate) colours: Vec<Srgb8>,
    pub(crate) washout: Option<Washout>,
    pub(crate) tolerance: f64,
    pub(crate) area_mm2: f64,
    pub(crate) diameter_mm: f64,
    pub(crate) cross_layers: bool,
    pub(crate) allowed: FeatureSet,
    pub(crate) markers: Markers,
    pub(crate) fallback: Fallback,
    pub(crate) block: PurgeMotion,
    pub(crate) tower: TowerConfig,
    pub(crate) max_window_lines: usize,
    /// The largest purge any change can ask for: the window never needs more extrusion.
    pub(crate) max_purge_mm: f64,
}

const WASHOUT_MM3: Range = Range::new(0.0, 10_000.0, "mm³");
const TOLERANCE: Range = Range::new(0.000_001, 1.0, "");
/// A tower's line width and layer height.
const LINE_MM: Range = Range::new(0.01, 10.0, "mm");
/// Tool pairs given their own purge: every ordered pair of 100 tools.
const PAIRS: Range = Range::new(0.0, 10_000.0, "pairs");
/// Tool colours: one per tool a machine may have ([`MAX_TOOLS`]).
const TOOLS: Range = Range::new(0.0, MAX_TOOLS as f64, "tools");
/// Feature names: each feature once, with room for the names of other slicers.
const FEATURES: Range = Range::new(0.0, 1_000.0, "names");
/// Lines held while looking for a place to purge.
const WINDOW_LINES: Range = Range::new(1.0, 10_000_000.0, "lines");

impl CheckRanges for PurgeShiftConfig {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check_opt("purge_mm", self.purge_mm, PURGE_MM)?;
        t.check_opt("purge_mm3", self.purge_mm3, PURGE_MM3)?;
        t.check("filament_diameter_mm", self.filament_diameter_mm, FILAMENT_DIAMETER_MM)?;
        // Counts first: every tool change looks its pair up among them.
        t.count("pair (count)", self.pair.len() as u64, PAIRS)?;
        t.count("colours (count)", self.colours.len() as u64, TOOLS)?;
        t.count("allow_features (count)", self.allow_features.len() as u64, FEATURES)?;
        for (i, p) in self.pair.iter().enumerate() {
            let pair = t.sub("pair").item(i);
            pair.check_opt("purge_mm", p.purge_mm, PURGE_MM)?;
            pair.check_opt("purge_mm3", p.purge_mm3, PURGE_MM3)?;
        }
        if let Some(w) = &self.washout {
            let washout = t.sub("washout");
            washout.check("chamber_mm3", w.chamber_mm3, WASHOUT_MM3)?;
            washout.check("dead_mm3", w.dead_mm3, WASHOUT_MM3)?;
            washout.check_opt("tolerance", w.tolerance, TOLERANCE)?;
        }
        self.block.check_ranges(&t.sub("block"))?;
        let tower = t.sub("tower");
        let tw = &self.tower;
        tower.check_opt("x_mm", tw.x_mm, range::POSITION_MM)?;
        tower.check_opt("y_mm", tw.y_mm, range::POSITION_MM)?;
        tower.check("gap_mm", tw.gap_mm, range::LEN_MM)?;
        tower.each("bed_mm", &tw.bed_mm, range::SIZE_MM)?;
        tower.check("line_width_mm", tw.line_width_mm, LINE_MM)?;
        tower.check("layer_height_mm", tw.layer_height_mm, LINE_MM)?;
        tower.check("lift_mm", tw.lift_mm, range::LEN_MM)?;
        tower.check("travel_feed_mm_min", tw.travel_feed_mm_min, range::FEED_MM_MIN)?;
        tower.check("extrude_feed_mm_min", tw.extrude_feed_mm_min, range::FEED_MM_MIN)?;
        tower.check("retract_feed_mm_min", tw.retract_feed_mm_min, range::FEED_MM_MIN)?;
        t.count("max_window_lines", self.max_window_lines as u64, WINDOW_LINES)
    }
}

impl PurgeShiftConfig {
    /// Parses TOML and validates it.
    pub fn from_toml(text: &str) -> Result<Rules, ConfigError> {
        let config: Self =
            toml::from_str(text).map_err(|e| ConfigError::Toml(crate::settings::toml_message(&e)))?;
        config.validate()
    }

    /// Parses TOML into the raw settings (for merging with command-line flags).
    pub fn parse_toml(text: &str) -> Result<Self, ConfigError> {
        let config: Self =
            toml::from_str(text).map_err(|e| ConfigError::Toml(crate::settings::toml_message(&e)))?;
        // The file's own values, so that their errors name the file (flags are checked again
        // by `validate`).
        config.check_ranges(&Table::root())?;
        Ok(config)
    }

    /// Checks every value and converts volumes to filament length.
    pub fn validate(&self) -> Result<Rules, ConfigError> {
        self.check_ranges(&Table::root())?;
        let diameter_mm = self.filament_diameter_mm;
        let to_mm = |v: f64| mm3_to_filament_mm(v, diameter_mm).unwrap_or(f64::NAN);
        let area_mm2 = filament_mm_to_mm3(1.0, diameter_mm).unwrap_or(f64::NAN);
        let washout = match &self.washout {
            Some(w) => Some(
                Washout::new(w.chamber_mm3, w.dead_mm3).map_err(|e| ConfigError::Washout(e.to_string()))?,
            ),
            None => None,
        };
        let tolerance = self.washout.and_then(|w| w.tolerance);
        let default_mm = match (self.purge_mm, self.purge_mm3, tolerance, washout) {
            (Some(_), Some(_), ..) => return Err(ConfigError::BothPurges),
            (Some(mm), None, ..) => Some(mm),
            (None, Some(v), ..) => Some(to_mm(v)),
            (None, None, Some(eps), Some(w)) => {
                Some(to_mm(w.purge_for_tolerance_mm3(eps).map_err(|e| ConfigError::Washout(e.to_string()))?))
            }
            _ => None,
        };
        // A purge however given (a volume through a thin filament, a washout tolerance) is held
        // to the same length as one given in mm: the tower or block a fallback builds grows
        // with it.
        let as_filament = "purge as filament mm (from purge_mm3 or the washout)";
        if let Some(mm) = default_mm {
            PURGE_MM.check(as_filament, mm)?;
        }
        let mut pairs = Vec::new();
        for p in &self.pair {
            let mm = match (p.purge_mm, p.purge_mm3) {
                (Some(mm), None) => mm,
                (None, Some(v)) => to_mm(v),
                _ => return Err(ConfigError::Pair { from: p.from, to: p.to }),
            };
            pairs.push((p.from, p.to, PURGE_MM.check(as_filament, mm)?));
        }
        let colours = self
            .colours
            .iter()
            .map(|c| c.parse::<Srgb8>().map_err(|e| ConfigError::Toml(e.to_string())))
            .collect::<Result<Vec<_>, _>>()?;
        if default_mm.is_none() && pairs.is_empty() && colours.is_empty() {
            return Err(ConfigError::NoPurge);
        }
        let mut allowed = FeatureSet::default();
        for name in &self.allow_features {
            allowed.insert(Feature::parse(name).ok_or_else(|| ConfigError::Feature(name.clone()))?);
        }
        let markers = match &self.markers {
            None => Markers::default(),
            Some([b, e]) if !b.trim().is_empty() && !e.trim().is_empty() => {
                Markers { begin: Some(b.trim().as_bytes().to_vec()), end: Some(e.trim().as_bytes().to_vec()) }
            }
            Some(_) => return Err(ConfigError::Markers),
        };
        let fallback = match self.fallback.as_str() {
            "partial" => Fallback::Partial,
            "block" => Fallback::Block,
            "tower" => Fallback::Tower,
            other => return Err(ConfigError::Fallback(other.to_string())),
        };
        let t = &self.tower;
        if t.x_mm.is_some() != t.y_mm.is_some() {
            return Err(ConfigError::Tower);
        }
        let mut rules = Rules {
            default_mm,
            pairs,
            colours,
            washout,
            tolerance: tolerance.unwrap_or(0.05),
            area_mm2,
            diameter_mm,
            cross_layers: self.cross_layers,
            allowed,
            markers,
            fallback,
            // The block lifts at the seed's Z feed unless `[block]` names one.
            block: PurgeMotion {
                z_feed_mm_min: Some(self.block.z_feed_mm_min.unwrap_or(PurgeMotion::SEED_Z_FEED_MM_MIN)),
                ..self.block
            },
            tower: self.tower,
            max_window_lines: self.max_window_lines.max(16),
            max_purge_mm: 0.0,
        };
        rules.max_purge_mm = rules.all_amounts_mm().fold(0.0, f64::max);
        Ok(rules)
    }
}

/// What [`ConfigError::NoPurge`] says, naming the options as each front end spells them.
fn no_purge() -> Said {
    Said::new("no purge amount: give ")
        .option("purge_mm")
        .text(" or ")
        .option("purge_mm3")
        .text(", or in the config purge_mm, purge_mm3, colours, pairs or a washout tolerance")
}

impl ConfigError {
    /// The refusal as a sentence that names options by identity, for a front end to spell
    /// ([`Said::spelled`]); `None` when it names none.
    pub fn said(&self) -> Option<Said> {
        matches!(self, ConfigError::NoPurge).then(no_purge)
    }
}

impl Rules {
    /// The purge-shift seed's setting: a fixed purge of `purge_mm` of filament, other rules default.
    pub fn fixed(purge_mm: f64) -> Result<Rules, ConfigError> {
        PurgeShiftConfig { purge_mm: Some(purge_mm), ..PurgeShiftConfig::default() }.validate()
    }

    fn colour_mm(&self, from: u32, to: u32) -> Option<f64> {
        let a = self.colours.get(from as usize)?;
        let b = self.colours.get(to as usize)?;
        Some(flush_volume_mm3(*a, *b) / self.area_mm2)
    }

    fn all_amounts_mm(&self) -> impl Iterator<Item = f64> + '_ {
        let n = self.colours.len() as u32;
        let colour = (0..n).flat_map(move |a| (0..n).filter_map(move |b| self.colour_mm(a, b)));
        self.default_mm.into_iter().chain(self.pairs.iter().map(|p| p.2)).chain(colour)
    }

    /// The purge for a change from tool `from` to tool `to`, mm of filament: a pair entry, else
    /// the colours, else the global amount, else the largest amount configured (the caller warns).
    pub fn purge_mm(&self, from: u32, to: u32) -> (f64, bool) {
        if let Some(p) = self.pairs.iter().find(|p| p.0 == from && p.1 == to) {
            return (p.2, true);
        }
        if let Some(mm) = self.colour_mm(from, to) {
            return (mm, true);
        }
        match self.default_mm {
            Some(mm) => (mm, true),
            None => (self.max_purge_mm, false),
        }
    }

    /// The comments that delimit the print proper.
    pub fn markers(&self) -> &Markers {
        &self.markers
    }

    /// What to do with the purge a change cannot move.
    pub fn fallback(&self) -> Fallback {
        self.fallback
    }

    /// Filament diameter, mm.
    pub fn filament_diameter_mm(&self) -> f64 {
        self.diameter_mm
    }

    pub(crate) fn mm3(&self, mm: f64) -> f64 {
        mm * self.area_mm2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (issue 25): 10 000 mm3 through a 0.5 mm filament is 50 930 mm of purge, and
    /// passed because only the volume was checked.
    #[test]
    fn a_purge_given_as_volume_is_held_to_the_length_limit() {
        let e = PurgeShiftConfig::parse_toml("purge_mm3 = 10000.0\nfilament_diameter_mm = 0.5\n")
            .and_then(|c| c.validate())
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "purge as filament mm (from purge_mm3 or the washout) = 50929.6 is out of range: 0 to 1000 mm"
        );
    }

    #[test]
    fn defaults_and_sources() {
        let r = Rules::fixed(2.5).unwrap();
        assert_eq!(r.purge_mm(0, 1), (2.5, true));
        assert!(!r.allowed.contains(Feature::OuterWall));
        assert!(r.allowed.contains(Feature::Infill));
        let r = PurgeShiftConfig::from_toml(
            "purge_mm3 = 24.0525\nfilament_diameter_mm = 1.75\n[[pair]]\nfrom = 0\nto = 1\npurge_mm = 4.0\n",
        )
        .unwrap();
        assert!((r.purge_mm(1, 0).0 - 10.0).abs() < 1e-3, "{:?}", r.purge_mm(1, 0));
        assert_eq!(r.purge_mm(0, 1), (4.0, true));
        assert!((r.max_purge_mm - 10.0).abs() < 1e-3);
        // White to black is 80 mm^3 = 33.26 mm of 1.75 mm filament.
        let r = PurgeShiftConfig::from_toml("colours = [\"#ffffff\", \"#000000\"]\n").unwrap();
        assert!((r.purge_mm(0, 1).0 - 80.0 / (std::f64::consts::PI * 1.75 * 1.75 / 4.0)).abs() < 1e-9);
        assert!(!r.purge_mm(0, 5).1);
        // Black to white (560 mm^3) is the largest amount.
        assert!((r.max_purge_mm - 560.0 / r.area_mm2).abs() < 1e-9);
    }

    #[test]
    fn washout_tolerance_is_a_source() {
        let r =
            PurgeShiftConfig::from_toml("[washout]\nchamber_mm3 = 10.0\ndead_mm3 = 2.0\ntolerance = 0.01\n")
                .unwrap();
        let want_mm3 = 2.0 + 10.0 * 100f64.ln();
        assert!((r.purge_mm(0, 1).0 * r.area_mm2 - want_mm3).abs() < 1e-9);
    }

    #[test]
    fn flags_override_the_file() {
        let mut c = PurgeShiftConfig::parse_toml("purge_mm3 = 10.0\ncross_layers = true\n").unwrap();
        c.apply(&super::super::PurgeShiftOptions {
            purge_mm: Some(3.0),
            allow_features: Some(vec![" infill".into()]),
            ..Default::default()
        });
        let r = c.validate().unwrap();
        assert_eq!(r.purge_mm(0, 1), (3.0, true));
        assert!(r.cross_layers);
        assert_eq!(r.allowed, [Feature::Infill].into_iter().collect());
    }

    #[test]
    fn refusals() {
        let err = |t: &str| PurgeShiftConfig::from_toml(t).unwrap_err();
        assert_eq!(err(""), ConfigError::NoPurge);
        let msg = |text: &str| err(text).to_string();
        assert_eq!(msg("purge_mm = -1.0"), "purge_mm = -1 is out of range: 0 to 1000 mm");
        assert_eq!(msg("purge_mm = 1e308"), "purge_mm = 1e308 is out of range: 0 to 1000 mm");
        assert_eq!(err("purge_mm = 1.0\npurge_mm3 = 2.0"), ConfigError::BothPurges);
        assert_eq!(err("purge_mm = 1.0\nfallback = \"wipe\""), ConfigError::Fallback("wipe".into()));
        assert_eq!(err("purge_mm = 1.0\n[tower]\nx_mm = 5.0"), ConfigError::Tower);
        assert_eq!(
            msg("purge_mm = 1.0\n[block]\nlift_mm = -1.0"),
            "[block] lift_mm = -1 is out of range: 0 to 10000 mm"
        );
        assert_eq!(
            msg("purge_mm = 1.0\n[block]\nx_mm = inf"),
            "[block] x_mm = inf is out of range: -10000 to 10000 mm"
        );
        assert_eq!(
            msg("purge_mm = 1.0\n[tower]\nx_mm = 5.0\ny_mm = nan"),
            "[tower] y_mm = nan is out of range: -10000 to 10000 mm"
        );
        let e = PurgeShiftConfig::parse_toml("[washout]\nchamber_mm3 = 40.0\nvolume = 3\n").unwrap_err();
        assert!(e.to_string().contains("unknown field `volume`"), "{e}");
        let e = PurgeShiftConfig::parse_toml("[[pair]]\nfrom = 0\nto = 1\npurge_mm = nan\n").unwrap_err();
        assert_eq!(e.to_string(), "[pair[0]] purge_mm = nan is out of range: 0 to 1000 mm");
        assert!(matches!(err("purge_mm = 1.0\nallow_features = [\"walls\"]"), ConfigError::Feature(_)));
        assert!(matches!(err("purge_mm = 1.0\nbogus = 1"), ConfigError::Toml(_)));
        assert_eq!(err("purge_mm = 1.0\nmarkers = [\"\", \"end\"]"), ConfigError::Markers);
    }
}
