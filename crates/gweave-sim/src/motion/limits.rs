//! The machine's motion profile: steps per unit, speed and acceleration limits, and how corners
//! are taken (Marlin junction deviation, Klipper's square corner velocity, or at constant speed).
//!
//! The defaults describe a common RAMPS 1.4 printer running Marlin with the values of Marlin's
//! stock `Configuration.h` (`MarlinFirmware/Marlin:Marlin/Configuration.h`):
//! `DEFAULT_AXIS_STEPS_PER_UNIT { 80, 80, 4000, 500 }`, `DEFAULT_MAX_FEEDRATE { 300, 300, 5, 25 }`,
//! `DEFAULT_MAX_ACCELERATION { 3000, 3000, 100, 10000 }`, `DEFAULT_ACCELERATION`,
//! `DEFAULT_RETRACT_ACCELERATION` and `DEFAULT_TRAVEL_ACCELERATION` 3000, `JUNCTION_DEVIATION_MM`
//! 0.013. The Klipper defaults are those of `Klipper3d/klipper:docs/Config_Reference.md`
//! (`square_corner_velocity` 5, `minimum_cruise_ratio` 0.5, `instantaneous_corner_velocity` 1).
//!
//! ```toml
//! [steps]
//! e = 415.0
//! [corners]
//! mode = "klipper"
//! max_velocity_mm_s = 300.0
//! max_accel_mm_s2 = 3000.0
//! ```

use gweave::range::{self};
use gweave::settings::{CheckRanges, Table};
use gweave::{OutOfRange, Range};
use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use crate::motion::marlin_limits::Jerk;
pub(crate) use crate::motion::marlin_limits::{ExtruderLimits, MarlinCorners};

/// A value in a motion profile that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProfileError {
    /// A limit set by a G-code command (M201, M203, M204, M205) that must be a positive,
    /// finite number is not. (A profile's keys are checked against their ranges instead.)
    #[error("{name} must be positive and finite, got {value}")]
    NotPositive {
        /// The limit, e.g. `max_feed_mm_s.x` or `M204 S`.
        name: &'static str,
        /// The rejected value.
        value: f64,
    },
    /// A profile key out of its range (see [`MotionProfile::check_ranges`]).
    #[error(transparent)]
    Range(#[from] OutOfRange),
    /// Klipper's M204 needs either `S` or both `P` and `T` (it takes the smaller of the two).
    #[error("M204 needs S, or both P and T, in Klipper mode")]
    M204NeedsPAndT,
    /// A Marlin profile takes corners by junction deviation or by classic jerk, not both.
    #[error("corners: give junction_deviation_mm or jerk_mm_s, not both")]
    JerkAndJunctionDeviation,
    /// A running planner cannot switch between Marlin, Klipper and constant-speed planning.
    #[error("the corner mode (marlin, klipper or constant) cannot change while planning")]
    ModeChange,
    /// The profile text is not valid TOML for a motion profile.
    #[error("motion profile: {0}")]
    Toml(String),
}

/// Steps per unit of travel for each motor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StepsPerUnit {
    /// X steps per mm.
    pub x: f64,
    /// Y steps per mm.
    pub y: f64,
    /// Z steps per mm.
    pub z: f64,
    /// E steps per mm of filament (the single extruder, or each input when `mixing_e` is empty).
    pub e: f64,
    /// Rotary axis A steps per degree, when the machine has one (lathe printers).
    pub a_per_deg: Option<f64>,
    /// Linear axis A steps per mm, when A drives something that slides (a binder jet's feed
    /// piston). At most one of `a_per_deg` and `a_per_mm`: A either turns or slides.
    pub a_per_mm: Option<f64>,
    /// Steps per mm of each input of a mixing hotend; empty for a plain extruder.
    pub mixing_e: Vec<f64>,
}

impl StepsPerUnit {
    /// A's steps per unit: per degree on a rotary axis, per mm on a linear one. A machine that
    /// declares neither has no A motor of its own; its A moves count one step a unit, which
    /// the profile's checks keep away from every axis a machine really drives (a `[rotary]`
    /// needs `a_per_deg`, a recoat piston on A needs `a_per_mm`).
    pub fn a(&self) -> f64 {
        self.a_per_deg.or(self.a_per_mm).unwrap_or(1.0)
    }
}

impl Default for StepsPerUnit {
    fn default() -> Self {
        Self { x: 80.0, y: 80.0, z: 4000.0, e: 500.0, a_per_deg: None, a_per_mm: None, mixing_e: Vec::new() }
    }
}

/// One limit per axis; linear axes in mm-based units, the rotary axis A in degree-based units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisLimits {
    /// X limit.
    pub x: f64,
    /// Y limit.
    pub y: f64,
    /// Z limit.
    pub z: f64,
    /// E limit.
    pub e: f64,
    /// Rotary axis A limit (degrees).
    pub a: f64,
}

/// A per-axis table of a profile in which every key is optional, as for every other table: the
/// axes given replace those of `default` (`[motion.max_feed_mm_s]` with only `z = 12` on a
/// printer that has no rotary axis).
fn partial_limits<'de, D: serde::Deserializer<'de>>(
    d: D,
    default: AxisLimits,
) -> Result<AxisLimits, D::Error> {
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Given {
        x: Option<f64>,
        y: Option<f64>,
        z: Option<f64>,
        e: Option<f64>,
        a: Option<f64>,
    }
    let g = Given::deserialize(d)?;
    Ok(AxisLimits {
        x: g.x.unwrap_or(default.x),
        y: g.y.unwrap_or(default.y),
        z: g.z.unwrap_or(default.z),
        e: g.e.unwrap_or(default.e),
        a: g.a.unwrap_or(default.a),
    })
}

fn feed_limits<'de, D: serde::Deserializer<'de>>(d: D) -> Result<AxisLimits, D::Error> {
    partial_limits(d, MotionProfile::default().max_feed_mm_s)
}

fn accel_limits<'de, D: serde::Deserializer<'de>>(d: D) -> Result<AxisLimits, D::Error> {
    partial_limits(d, MotionProfile::default().max_accel_mm_s2)
}

impl AxisLimits {
    /// The limits in the order X Y Z E A, the order of [`crate::motion::kinematics::Pos::to_array`].
    pub fn to_array(&self) -> [f64; 5] {
        [self.x, self.y, self.z, self.e, self.a]
    }

    /// Replace the values given (an M201/M203 line: `X Y Z E A`), keep the others.
    fn update(&mut self, new: &AxisUpdate, names: [&'static str; 5]) -> Result<(), ProfileError> {
        let mut next = *self;
        let slots = [&mut next.x, &mut next.y, &mut next.z, &mut next.e, &mut next.a];
        for ((slot, value), name) in slots.into_iter().zip(new.to_array()).zip(names) {
            if let Some(v) = value {
                positive(name, v)?;
                *slot = v;
            }
        }
        *self = next;
        Ok(())
    }
}

/// Per-axis values from an M201 or M203 line, `None` where the word is absent.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AxisUpdate {
    /// X word.
    pub x: Option<f64>,
    /// Y word.
    pub y: Option<f64>,
    /// Z word.
    pub z: Option<f64>,
    /// E word.
    pub e: Option<f64>,
    /// A word.
    pub a: Option<f64>,
}

impl AxisUpdate {
    pub(crate) fn to_array(self) -> [Option<f64>; 5] {
        [self.x, self.y, self.z, self.e, self.a]
    }
}

/// The words of an M204 line, `None` where absent.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct M204 {
    /// `S`: Marlin's legacy "print and travel"; Klipper's only accel.
    pub s: Option<f64>,
    /// `P`: printing moves.
    pub p: Option<f64>,
    /// `R`: retract (extrude-only) moves.
    pub r: Option<f64>,
    /// `T`: travel moves.
    pub t: Option<f64>,
}

/// Marlin's three move accelerations (M204 P R T), mm/s².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MoveAccel {
    /// Moves that extrude while moving (M204 P).
    pub print_mm_s2: f64,
    /// Extrude-only moves: retracts and primes (M204 R).
    pub retract_mm_s2: f64,
    /// Moves without extrusion (M204 T).
    pub travel_mm_s2: f64,
}

/// Klipper's `[printer]` and `[extruder]` motion limits (`Klipper3d/klipper:klippy/toolhead.py`,
/// `kinematics/cartesian.py`, `kinematics/extruder.py`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KlipperLimits {
    /// `max_velocity` of the toolhead.
    pub max_velocity_mm_s: f64,
    /// `max_accel` of the toolhead; M204 and `SET_VELOCITY_LIMIT ACCEL` change it.
    pub max_accel_mm_s2: f64,
    /// `minimum_cruise_ratio`: the share of each move that should cruise, in `[0, 1)`.
    pub minimum_cruise_ratio: f64,
    /// `square_corner_velocity`: the speed through a 90 degree corner.
    pub square_corner_velocity_mm_s: f64,
    /// `max_z_velocity`; `None` means `max_velocity` as configured at start.
    pub max_z_velocity_mm_s: Option<f64>,
    /// `max_z_accel`; `None` means `max_accel` as configured at start.
    pub max_z_accel_mm_s2: Option<f64>,
    /// `max_extrude_only_velocity` of the extruder; `None` leaves extrude-only moves unbounded.
    /// (Klipper's own default derives it from the nozzle and filament diameters; give it here.)
    pub max_extrude_only_velocity_mm_s: Option<f64>,
    /// `max_extrude_only_accel`; `None` leaves extrude-only moves unbounded.
    pub max_extrude_only_accel_mm_s2: Option<f64>,
    /// The extruder's `instantaneous_corner_velocity`: the largest instant change of E speed.
    pub instantaneous_corner_velocity_mm_s: f64,
}

impl Default for KlipperLimits {
    fn default() -> Self {
        Self {
            max_velocity_mm_s: 300.0,
            max_accel_mm_s2: 3000.0,
            minimum_cruise_ratio: 0.5,
            square_corner_velocity_mm_s: 5.0,
            max_z_velocity_mm_s: None,
            max_z_accel_mm_s2: None,
            max_extrude_only_velocity_mm_s: None,
            max_extrude_only_accel_mm_s2: None,
            instantaneous_corner_velocity_mm_s: 1.0,
        }
    }
}

/// `minimum_cruise_ratio`: a share of each move, below 1 (a move must be able to accelerate).
const CRUISE_RATIO: Range = Range::new(0.0, 0.99, "");
/// A corner speed (square corner or instantaneous E change); 0 stops at every corner.
const CORNER_SPEED_MM_S: Range = Range::new(0.0, 1_000.0, "mm/s");
/// Marlin's junction deviation (`JUNCTION_DEVIATION_MM`, typically 0.005 to 0.3).
pub(crate) const JUNCTION_DEVIATION_MM: Range = Range::new(0.000_1, 10.0, "mm");
/// Marlin's planner buffer (`BLOCK_BUFFER_SIZE`, 8 to 64 on real boards); its ring keeps one
/// slot free, so 2 slots hold one block.
const LOOKAHEAD_BLOCKS: Range = Range::new(2.0, 1_024.0, "blocks");
/// Marlin's minimum segment time (`DEFAULT_MINSEGMENTTIME`, M205 B), up to a second.
pub(crate) const MIN_SEGMENT_TIME_US: Range = Range::new(0.0, 1_000_000.0, "µs");
/// Classic jerk (`CLASSIC_JERK`, M205 X Y Z E): an instant change of speed, 0 for none.
pub(crate) const JERK_MM_S: Range = Range::new(0.0, 1_000.0, "mm/s");
/// Extruders with their own limits (see [`crate::motion::marlin_limits::MAX_EXTRUDERS`]).
const EXTRUDERS: Range = Range::new(0.0, crate::motion::marlin_limits::MAX_EXTRUDERS as f64, "extruders");
/// The rotary axis' speed and acceleration, degree based.
pub(crate) const SPEED_DEG_S: Range = Range::new(0.001, 100_000.0, "°/s");
pub(crate) const ACCEL_DEG_S2: Range = Range::new(0.001, 10_000_000.0, "°/s²");

impl CheckRanges for KlipperLimits {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("max_velocity_mm_s", self.max_velocity_mm_s, range::SPEED_MM_S)?;
        t.check("max_accel_mm_s2", self.max_accel_mm_s2, range::ACCEL_MM_S2)?;
        t.check("minimum_cruise_ratio", self.minimum_cruise_ratio, CRUISE_RATIO)?;
        t.check("square_corner_velocity_mm_s", self.square_corner_velocity_mm_s, CORNER_SPEED_MM_S)?;
        t.check(
            "instantaneous_corner_velocity_mm_s",
            self.instantaneous_corner_velocity_mm_s,
            CORNER_SPEED_MM_S,
        )?;
        t.check_opt("max_z_velocity_mm_s", self.max_z_velocity_mm_s, range::SPEED_MM_S)?;
        t.check_opt("max_z_accel_mm_s2", self.max_z_accel_mm_s2, range::ACCEL_MM_S2)?;
        t.check_opt(
            "max_extrude_only_velocity_mm_s",
            self.max_extrude_only_velocity_mm_s,
            range::SPEED_MM_S,
        )?;
        t.check_opt("max_extrude_only_accel_mm_s2", self.max_extrude_only_accel_mm_s2, range::ACCEL_MM_S2)
    }
}

impl KlipperLimits {
    /// Klipper's `SET_VELOCITY_LIMIT`: change the values given, keep the others.
    pub fn set_velocity_limit(
        &mut self,
        velocity_mm_s: Option<f64>,
        accel_mm_s2: Option<f64>,
        square_corner_velocity_mm_s: Option<f64>,
        minimum_cruise_ratio: Option<f64>,
    ) -> Result<(), ProfileError> {
        let mut next = *self;
        next.max_velocity_mm_s = velocity_mm_s.unwrap_or(next.max_velocity_mm_s);
        next.max_accel_mm_s2 = accel_mm_s2.unwrap_or(next.max_accel_mm_s2);
        next.square_corner_velocity_mm_s =
            square_corner_velocity_mm_s.unwrap_or(next.square_corner_velocity_mm_s);
        next.minimum_cruise_ratio = minimum_cruise_ratio.unwrap_or(next.minimum_cruise_ratio);
        // The profile's ranges bound the command too; the message names the profile key.
        next.check_ranges(&Table::root().sub("motion.corners"))?;
        *self = next;
        Ok(())
    }

    /// The junction deviation Klipper derives from the square corner velocity:
    /// `d = scv^2 (sqrt(2) - 1) / max_accel` (`Klipper3d/klipper:klippy/toolhead.py`), chosen so
    /// that the junction-deviation formula gives exactly `scv` at a 90 degree corner.
    pub fn junction_deviation_mm(&self) -> f64 {
        self.square_corner_velocity_mm_s.powi(2) * (std::f64::consts::SQRT_2 - 1.0) / self.max_accel_mm_s2
    }

    /// The "pseudo acceleration" behind `minimum_cruise_ratio`: lookahead plans the peak speed
    /// of a run of moves as if only `max_accel * (1 - ratio)` were available, so that at least
    /// `ratio` of the distance is left to cruise.
    pub fn mcr_pseudo_accel_mm_s2(&self) -> f64 {
        self.max_accel_mm_s2 * (1.0 - self.minimum_cruise_ratio)
    }
}

/// How the planner limits the speed through a corner, and whose planner it imitates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "snake_case", deny_unknown_fields)]
pub enum CornerMode {
    /// Marlin: per-axis feed and accel limits, M204 P/R/T, and corners by junction deviation
    /// or, with `jerk_mm_s`, by classic jerk (a Marlin build has one or the other).
    Marlin {
        /// `JUNCTION_DEVIATION_MM` (M205 J); `None` with `jerk_mm_s` (giving both is an error),
        /// 0.013 when neither is given.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        junction_deviation_mm: Option<f64>,
        /// `CLASSIC_JERK`: the largest instant speed change of each axis (`DEFAULT_XJERK` ...,
        /// M205 X Y Z E).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        jerk_mm_s: Option<Jerk>,
        /// The planner buffer (`BLOCK_BUFFER_SIZE`, 16); like Marlin's ring buffer it holds one
        /// block less, and a block leaves with its speeds final when it is full, as in the
        /// firmware while the host streams.
        #[serde(default = "default_lookahead_blocks")]
        lookahead_blocks: usize,
        /// `DEFAULT_MINSEGMENTTIME` (M205 B), µs: while the buffer is low (2 to
        /// `lookahead_blocks / 2 - 1` blocks queued) a shorter block is slowed down towards it.
        #[serde(default = "default_min_segment_time_us")]
        min_segment_time_us: f64,
    },
    /// Klipper: square corner velocity, minimum cruise ratio and the toolhead limits.
    Klipper(KlipperLimits),
    /// No acceleration: every move runs at its commanded feed from its first step to its last,
    /// corners included, as the controller seed's firmware steps (`planner/constant.rs`). The
    /// feed, acceleration and corner limits are kept (M503 prints them) but not applied. (A
    /// variant with no fields, so that serde refuses a key given with it, as a unit variant
    /// would not.)
    Constant {},
}

impl Default for CornerMode {
    fn default() -> Self {
        Self::Marlin {
            junction_deviation_mm: Some(MARLIN_JUNCTION_DEVIATION_MM),
            jerk_mm_s: None,
            lookahead_blocks: default_lookahead_blocks(),
            min_segment_time_us: default_min_segment_time_us(),
        }
    }
}

/// Marlin's stock `JUNCTION_DEVIATION_MM`.
pub(crate) const MARLIN_JUNCTION_DEVIATION_MM: f64 = 0.013;

fn default_lookahead_blocks() -> usize {
    16
}

fn default_min_segment_time_us() -> f64 {
    20_000.0
}

/// Everything the planner and the steppers need to know about the machine's motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionProfile {
    /// Steps per unit of each motor.
    pub steps: StepsPerUnit,
    /// Marlin's per-axis maximum feed rate (M203), mm/s (A: deg/s). In Klipper mode only A uses it.
    #[serde(deserialize_with = "feed_limits")]
    pub max_feed_mm_s: AxisLimits,
    /// Marlin's per-axis maximum acceleration (M201), mm/s² (A: deg/s²). In Klipper mode only A.
    #[serde(deserialize_with = "accel_limits")]
    pub max_accel_mm_s2: AxisLimits,
    /// Marlin's move accelerations (M204 P R T). Klipper uses `corners.max_accel_mm_s2` instead.
    pub accel: MoveAccel,
    /// Corner handling and, in Klipper mode, the toolhead limits.
    pub corners: CornerMode,
    /// Extruders with their own E limits (Marlin's `DISTINCT_E_FACTORS`, set by M92, M201 and
    /// M203 with `T`), by tool number; a tool not listed, or a value not given, takes the
    /// shared E values above. Marlin mode only.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extruders: Vec<ExtruderLimits>,
}

impl Default for MotionProfile {
    fn default() -> Self {
        Self {
            steps: StepsPerUnit::default(),
            max_feed_mm_s: AxisLimits { x: 300.0, y: 300.0, z: 5.0, e: 25.0, a: 360.0 },
            max_accel_mm_s2: AxisLimits { x: 3000.0, y: 3000.0, z: 100.0, e: 10000.0, a: 3600.0 },
            accel: MoveAccel { print_mm_s2: 3000.0, retract_mm_s2: 3000.0, travel_mm_s2: 3000.0 },
            corners: CornerMode::default(),
            extruders: Vec::new(),
        }
    }
}

const FEED_NAMES: [&str; 5] =
    ["max_feed_mm_s.x", "max_feed_mm_s.y", "max_feed_mm_s.z", "max_feed_mm_s.e", "max_feed_mm_s.a"];
const ACCEL_NAMES: [&str; 5] =
    ["max_accel_mm_s2.x", "max_accel_mm_s2.y", "max_accel_mm_s2.z", "max_accel_mm_s2.e", "max_accel_mm_s2.a"];

impl MotionProfile {
    /// A Klipper machine with these toolhead limits and Marlin's default step rates.
    pub fn klipper(limits: KlipperLimits) -> Self {
        Self { corners: CornerMode::Klipper(limits), ..Self::default() }
    }

    /// Read a profile from TOML text and check it.
    pub fn from_toml_str(text: &str) -> Result<Self, ProfileError> {
        let profile: Self =
            toml::from_str(text).map_err(|e| ProfileError::Toml(gweave::settings::toml_message(&e)))?;
        profile.validate()?;
        Ok(profile)
    }

    /// Check every value against its range (see [`CheckRanges`]), as a standalone file.
    pub fn validate(&self) -> Result<(), ProfileError> {
        self.check_ranges(&Table::root())?;
        if let CornerMode::Marlin { junction_deviation_mm: Some(_), jerk_mm_s: Some(_), .. } = self.corners {
            // A firmware is built with one corner rule or the other.
            return Err(ProfileError::JerkAndJunctionDeviation);
        }
        Ok(())
    }

    /// M201: per-axis maximum acceleration (mm/s², A in deg/s²). Klipper ignores M201.
    pub fn set_max_accel(&mut self, m201: &AxisUpdate) -> Result<(), ProfileError> {
        self.max_accel_mm_s2.update(m201, ACCEL_NAMES)
    }

    /// M203: per-axis maximum feed rate (mm/s, A in deg/s). Klipper ignores M203.
    pub fn set_max_feed(&mut self, m203: &AxisUpdate) -> Result<(), ProfileError> {
        self.max_feed_mm_s.update(m203, FEED_NAMES)
    }

    /// M204. Marlin: `S` sets print and travel, `P` print, `R` retract, `T` travel.
    /// Klipper (`Klipper3d/klipper:klippy/toolhead.py`): `S` sets `max_accel`, otherwise both `P`
    /// and `T` must be present and the smaller one is used; `R` is ignored.
    pub fn set_accel(&mut self, m204: &M204) -> Result<(), ProfileError> {
        for (name, v) in [("M204 S", m204.s), ("M204 P", m204.p), ("M204 R", m204.r), ("M204 T", m204.t)] {
            if let Some(v) = v {
                positive(name, v)?;
            }
        }
        match &mut self.corners {
            CornerMode::Klipper(k) => {
                let accel = match (m204.s, m204.p, m204.t) {
                    (Some(s), _, _) => s,
                    (None, Some(p), Some(t)) => p.min(t),
                    _ => return Err(ProfileError::M204NeedsPAndT),
                };
                k.max_accel_mm_s2 = accel;
            }
            // Constant mode keeps Marlin's M204 values (M503 reports them) without using them.
            CornerMode::Marlin { .. } | CornerMode::Constant {} => {
                let a = &mut self.accel;
                if let Some(s) = m204.s {
                    a.print_mm_s2 = s;
                    a.travel_mm_s2 = s;
                }
                a.print_mm_s2 = m204.p.unwrap_or(a.print_mm_s2);
                a.retract_mm_s2 = m204.r.unwrap_or(a.retract_mm_s2);
                a.travel_mm_s2 = m204.t.unwrap_or(a.travel_mm_s2);
            }
        }
        Ok(())
    }

    /// M205 J: Marlin's junction deviation in mm. A Marlin build has junction deviation or
    /// classic jerk, so this changes nothing in a jerk profile, nor in Klipper mode (Klipper
    /// ignores M205).
    pub fn set_junction_deviation(&mut self, j_mm: f64) -> Result<(), ProfileError> {
        positive("M205 J", j_mm)?;
        if let CornerMode::Marlin { junction_deviation_mm, jerk_mm_s: None, .. } = &mut self.corners {
            *junction_deviation_mm = Some(j_mm);
        }
        Ok(())
    }
}

impl CheckRanges for MotionProfile {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        let steps = t.sub("steps");
        let s = &self.steps;
        for (key, v) in [("x", s.x), ("y", s.y), ("z", s.z), ("e", s.e)] {
            steps.check(key, v, range::STEPS_PER_UNIT)?;
        }
        steps.check_opt("a_per_deg", s.a_per_deg, range::STEPS_PER_UNIT)?;
        steps.check_opt("a_per_mm", s.a_per_mm, range::STEPS_PER_UNIT)?;
        steps.each("mixing_e", &s.mixing_e, range::STEPS_PER_UNIT)?;
        let linear_and_a = |table: Table, limits: &AxisLimits, linear: Range, a: Range| {
            let l = limits;
            [("x", l.x), ("y", l.y), ("z", l.z), ("e", l.e)]
                .into_iter()
                .try_for_each(|(key, v)| table.check(key, v, linear))?;
            table.check("a", l.a, a)
        };
        linear_and_a(t.sub("max_feed_mm_s"), &self.max_feed_mm_s, range::SPEED_MM_S, SPEED_DEG_S)?;
        linear_and_a(t.sub("max_accel_mm_s2"), &self.max_accel_mm_s2, range::ACCEL_MM_S2, ACCEL_DEG_S2)?;
        let accel = t.sub("accel");
        accel.check("print_mm_s2", self.accel.print_mm_s2, range::ACCEL_MM_S2)?;
        accel.check("retract_mm_s2", self.accel.retract_mm_s2, range::ACCEL_MM_S2)?;
        accel.check("travel_mm_s2", self.accel.travel_mm_s2, range::ACCEL_MM_S2)?;
        t.count("extruders (count)", self.extruders.len() as u64, EXTRUDERS)?;
        for (i, extruder) in self.extruders.iter().enumerate() {
            extruder.check_ranges(&t.sub("extruders").item(i))?;
        }
        let corners = t.sub("corners");
        match &self.corners {
            CornerMode::Marlin {
                junction_deviation_mm,
                jerk_mm_s,
                lookahead_blocks,
                min_segment_time_us,
            } => {
                corners.check_opt("junction_deviation_mm", *junction_deviation_mm, JUNCTION_DEVIATION_MM)?;
                if let Some(jerk) = jerk_mm_s {
                    jerk.check_ranges(&corners.sub("jerk_mm_s"))?;
                }
                corners.count("lookahead_blocks", *lookahead_blocks as u64, LOOKAHEAD_BLOCKS)?;
                corners.check("min_segment_time_us", *min_segment_time_us, MIN_SEGMENT_TIME_US)
            }
            CornerMode::Klipper(k) => k.check_ranges(&corners),
            CornerMode::Constant {} => Ok(()),
        }
    }
}

/// A value of a G-code command (M201, M203, M204, M205) that changes a limit at run time.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<(), ProfileError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ProfileError::NotPositive { name, value })
    }
}

pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<(), ProfileError> {
    if value == 0.0 {
        Ok(())
    } else {
        positive(name, value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (a new user's trial): a per-axis table with only the keys a user changes was
    /// refused with `missing field 'y'`, then `'a'` (a rotary axis the printer does not have).
    #[test]
    fn a_per_axis_table_takes_only_the_axes_given() {
        let p = MotionProfile::from_toml_str("[max_feed_mm_s]\nz = 12.0\n[max_accel_mm_s2]\nx = 9000.0\n")
            .unwrap();
        let d = MotionProfile::default();
        assert_eq!(p.max_feed_mm_s, AxisLimits { z: 12.0, ..d.max_feed_mm_s });
        assert_eq!(p.max_accel_mm_s2, AxisLimits { x: 9000.0, ..d.max_accel_mm_s2 });
        let e = MotionProfile::from_toml_str("[max_feed_mm_s]\nx = 0.0\n").unwrap_err();
        assert_eq!(e.to_string(), "[max_feed_mm_s] x = 0 is out of range: 0.01 to 1000 mm/s");
    }

    #[test]
    fn default_profile_is_marlin_ramps() {
        let p = MotionProfile::default();
        assert_eq!(p.validate(), Ok(()));
        assert_eq!(p.steps.z, 4000.0);
        assert_eq!(p.max_feed_mm_s.z, 5.0);
        assert_eq!(p.corners.marlin_corners(), Some(MarlinCorners::JunctionDeviation(0.013)));
    }

    #[test]
    fn toml_klipper_profile_round_trips_and_rejects_unknown_keys() {
        let text = "[steps]\ne = 415.0\n[corners]\nmode = \"klipper\"\nmax_velocity_mm_s = 250.0\n\
                    max_extrude_only_velocity_mm_s = 80.0\n";
        let p = MotionProfile::from_toml_str(text).unwrap();
        assert_eq!(p.steps.e, 415.0);
        let CornerMode::Klipper(k) = p.corners else { panic!("not klipper: {:?}", p.corners) };
        assert_eq!(k.max_velocity_mm_s, 250.0);
        assert_eq!(k.max_accel_mm_s2, 3000.0);
        assert_eq!(k.max_extrude_only_velocity_mm_s, Some(80.0));
        let again = MotionProfile::from_toml_str(&toml::to_string(&p).unwrap()).unwrap();
        assert_eq!(again, p);
        let typo = MotionProfile::from_toml_str("[steps]\nxx = 1.0\n");
        assert!(matches!(&typo, Err(ProfileError::Toml(m)) if m.contains("xx")), "{typo:?}");
        let typo = MotionProfile::from_toml_str("[corners]\nmode = \"klipper\"\nmax_velocty = 1.0\n");
        assert!(matches!(typo, Err(ProfileError::Toml(_))), "{typo:?}");
    }

    #[test]
    fn toml_constant_profile_has_no_corner_keys_and_cannot_change_mode() {
        let p = MotionProfile::from_toml_str("[corners]\nmode = \"constant\"\n").unwrap();
        assert_eq!(p.corners, CornerMode::Constant {});
        assert_eq!(p.corners.marlin_corners(), None);
        assert_eq!(MotionProfile::from_toml_str(&toml::to_string(&p).unwrap()).unwrap(), p);
        let extra =
            MotionProfile::from_toml_str("[corners]\nmode = \"constant\"\njunction_deviation_mm = 0.01\n");
        assert!(
            matches!(&extra, Err(ProfileError::Toml(m)) if m.contains("junction_deviation_mm")),
            "{extra:?}"
        );
        let change = crate::motion::planner::Planner::check_change(&p, &MotionProfile::default());
        assert_eq!(change, Err(ProfileError::ModeChange));
    }

    #[test]
    fn klipper_junction_deviation_matches_square_corner_formula() {
        let k = KlipperLimits::default();
        // 25 * 0.41421356 / 3000
        assert!((k.junction_deviation_mm() - 0.003_451_779_7).abs() < 1e-9);
        assert_eq!(k.mcr_pseudo_accel_mm_s2(), 1500.0);
    }

    #[test]
    fn m204_marlin_and_klipper_rules() {
        let mut m = MotionProfile::default();
        m.set_accel(&M204 { s: Some(1000.0), r: Some(500.0), ..M204::default() }).unwrap();
        assert_eq!(m.accel, MoveAccel { print_mm_s2: 1000.0, retract_mm_s2: 500.0, travel_mm_s2: 1000.0 });
        m.set_accel(&M204 { p: Some(800.0), ..M204::default() }).unwrap();
        assert_eq!(m.accel.print_mm_s2, 800.0);
        assert_eq!(m.accel.travel_mm_s2, 1000.0);

        let mut k = MotionProfile::klipper(KlipperLimits::default());
        k.set_accel(&M204 { p: Some(1200.0), t: Some(900.0), ..M204::default() }).unwrap();
        assert!(matches!(k.corners, CornerMode::Klipper(l) if l.max_accel_mm_s2 == 900.0));
        assert_eq!(k.set_accel(&M204 { p: Some(1.0), ..M204::default() }), Err(ProfileError::M204NeedsPAndT));
        let bad = k.set_accel(&M204 { s: Some(-3.0), ..M204::default() });
        assert_eq!(bad, Err(ProfileError::NotPositive { name: "M204 S", value: -3.0 }));
    }

    #[test]
    fn m201_m203_m205_update_only_given_axes_and_reject_bad_values() {
        let mut m = MotionProfile::default();
        m.set_max_feed(&AxisUpdate { z: Some(12.0), ..AxisUpdate::default() }).unwrap();
        assert_eq!(m.max_feed_mm_s.to_array(), [300.0, 300.0, 12.0, 25.0, 360.0]);
        let err = m.set_max_accel(&AxisUpdate { x: Some(500.0), y: Some(f64::NAN), ..AxisUpdate::default() });
        assert!(matches!(err, Err(ProfileError::NotPositive { name: "max_accel_mm_s2.y", .. })));
        assert_eq!(m.max_accel_mm_s2.x, 3000.0, "a rejected line changes nothing");
        m.set_junction_deviation(0.02).unwrap();
        assert!(
            matches!(m.corners, CornerMode::Marlin { junction_deviation_mm: Some(jd), .. } if jd == 0.02)
        );
    }

    #[test]
    fn set_velocity_limit_validates() {
        let mut k = KlipperLimits::default();
        k.set_velocity_limit(None, Some(5000.0), Some(8.0), None).unwrap();
        assert_eq!((k.max_accel_mm_s2, k.square_corner_velocity_mm_s), (5000.0, 8.0));
        let err = k.set_velocity_limit(None, None, None, Some(1.0)).unwrap_err().to_string();
        assert_eq!(err, "[motion.corners] minimum_cruise_ratio = 1 is out of range: 0 to 0.99");
        assert_eq!(k.minimum_cruise_ratio, 0.5);
    }
}
