//! The maths of a rotary machine: coordinates, feed-rate conventions, the unwrap mapping and
//! chord subdivision, all as pure functions over a validated [`RotaryConfig`].
//!
//! # Coordinates
//!
//! A point on the machine is a [`CylPoint`] `(axial_mm, theta_deg, radius_mm)`; in Cartesian
//! terms ([`to_cartesian`]) it is `(axial, r cos(theta), r sin(theta))`, the mandrel axis being
//! the first coordinate. The G-code words are:
//!
//! ```text
//!   axial  word = axial_mm
//!   rotary word = theta_deg                    (unit `degrees`)
//!               = theta_deg / 360 * pi * D     (unit `mm`: arc length at the mandrel surface,
//!                                               for printers whose rotary axis is a linear Y)
//!   radial word = radius_mm - D/2              (0 = nozzle touching the mandrel surface)
//! ```
//!
//! # Feed rate: the trap of rotary printing
//!
//! A segment at mean radius `r` that moves `dX` along the axis, `dr` radially and turns by
//! `dTheta` follows a helix (the firmware interpolates X, A and Z linearly). Its length on the
//! surface is `L = sqrt(dX^2 + dr^2 + (r*dTheta_rad)^2)` (exact for `dr = 0`; for a radial ramp
//! the mean radius is a second-order approximation). To move at surface speed `v` it needs
//! `T = L / v`, lengthened if the rotary axis would exceed its speed cap. What F must then be
//! written depends on how the firmware reads F (LinuxCNC's feed-rate rules for rotary axes, Marlin's `ARTICULATED_ROBOT_ARM`,
//! RepRapFirmware's `M584 ... S0`, `G93` inverse time):
//!
//! ```text
//!   nist         LinuxCNC / NIST RS274NGC, Marlin's default: if a linear axis (axial or
//!                radial) moves, F is the linear speed hypot(dX, dZ)/T and the rotary axis
//!                just follows; a rotary-only move has F in rotary units (deg) per minute.
//!   combined     Marlin ARTICULATED_ROBOT_ARM, RRF `M584 ... S0`, and any printer whose
//!                rotary axis is a linear Y: F = sqrt(dX^2 + dZ^2 + dA^2)/T, dA in its unit.
//!   inverse-time G93: F = 1/T with T in minutes, on every move.
//! ```
//!
//! A move of the extruder alone has F = |dE|/T in every convention but inverse time.
//!
//! # Unwrap: a flat part onto the cylinder
//!
//! A part sliced flat with its Y length equal to the circumference `C = 2*pi*R0` maps as
//! `theta_deg = 360*y/C`, `r = R0 + z` (the rotary seed's method (a)). A flat step `(dx, dy)` becomes
//! `(dx, dy*r/R0)` on the surface at radius `r`, so the extrusion scales by
//! `hypot(dx, dy*r/R0) / hypot(dx, dy)`. The Diabase rotary wizard keeps the arc length instead,
//! `A = Y*180/(pi*(R0 + z - z1))`, and leaves E as it is; the surface speed is then the flat
//! speed, so with the combined convention and a rotary axis in mm the F words come out
//! (nearly) unchanged too.
//!
//! # Chords
//!
//! A straight chord between two points of a helix at radius `r`, `dTheta` apart, passes inside
//! the cylinder by its sagitta `s = r*(1 - cos(dTheta/2))` at its midpoint (the axial coordinate
//! is linear in both, so the helix sagitta equals the circle's). Splitting a segment into pieces
//! of at most `2*acos(1 - tol/r)` keeps `s <= tol`. The firmware itself interpolates the
//! rotary axis, so a long rotary move already follows the true helix; the chords bound the
//! error of anything that draws moves as straight 3D lines (previews, a Cartesian simulator)
//! and keep the radius linear in time on radial ramps.

use std::f64::consts::PI;

use crate::range::Range;
use serde::{Deserialize, Serialize};

use super::{in_range, Result, RotaryError};

/// How the firmware reads the rotary word.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RotaryUnit {
    /// Degrees of mandrel rotation (a true rotary axis such as `A`); `deg` as the CLI has
    /// always spelled it.
    #[default]
    #[serde(alias = "deg")]
    Degrees,
    /// Millimetres of circumference at the mandrel surface (a rotary axis configured as `Y`).
    Mm,
}

/// How the firmware reads F on moves that involve the rotary axis (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FeedConvention {
    /// F is the linear (axial + radial) speed; rotary-only moves in rotary units per minute.
    #[default]
    Nist,
    /// F is the Euclidean speed over all axes, the rotary one in its own unit.
    Combined,
    /// G93: F is 1/T with T in minutes.
    InverseTime,
}

/// The rotary machine: mandrel and axes. Unknown TOML keys are errors.
///
/// ```toml
/// mandrel_diameter_mm = 50.0   # required
/// axial_axis = "X"             # default X
/// rotary_axis = "A"            # default A (use "Y" with rotary_unit = "mm")
/// radial_axis = "Z"            # default Z
/// rotary_unit = "degrees"      # or "mm" (circumference at the mandrel surface)
/// feed_convention = "nist"     # or "combined", "inverse-time"
/// max_rotary_deg_s = 360.0     # optional cap on the rotary speed, deg/s
/// rotary_rebase_deg = 36000.0  # re-declare the angle mod 360 beyond this (0 = never)
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotaryConfig {
    /// Diameter of the mandrel (the print surface of the first layer), mm.
    pub mandrel_diameter_mm: f64,
    /// Letter of the axis along the mandrel.
    #[serde(default = "default_axial")]
    pub axial_axis: char,
    /// Letter of the axis that turns the mandrel.
    #[serde(default = "default_rotary")]
    pub rotary_axis: char,
    /// Letter of the axis that moves the nozzle away from the mandrel.
    #[serde(default = "default_radial")]
    pub radial_axis: char,
    /// Unit of the rotary word.
    #[serde(default)]
    pub rotary_unit: RotaryUnit,
    /// How F is read on moves with a rotary component.
    #[serde(default)]
    pub feed_convention: FeedConvention,
    /// Optional cap on the rotary speed, deg/s: moves that would turn faster are slowed down.
    #[serde(default)]
    pub max_rotary_deg_s: Option<f64>,
    /// Beyond this many degrees the rotary word is re-declared modulo one turn with `G92`, so
    /// that 32-bit float firmware keeps its angular resolution (0 = never). Default 36000:
    /// a float resolves 0.004 degrees there.
    #[serde(default = "default_rebase")]
    pub rotary_rebase_deg: f64,
}

fn default_rebase() -> f64 {
    36_000.0
}

fn default_axial() -> char {
    'X'
}
fn default_rotary() -> char {
    'A'
}
fn default_radial() -> char {
    'Z'
}

/// Mandrel diameters a lathe-type printer has (a 1 mm wire to a 1 m drum).
pub const MANDREL_DIAMETER_MM: Range<f64> = Range::new(1.0, 1000.0, "mm");

/// Axis letters a firmware accepts for motion (E is the extruder, so it is excluded).
const AXIS_LETTERS: &str = "XYZABCUVW";

impl RotaryConfig {
    /// A machine with the given mandrel diameter and every other setting at its default.
    pub fn new(mandrel_diameter_mm: f64) -> Self {
        Self {
            mandrel_diameter_mm,
            axial_axis: default_axial(),
            rotary_axis: default_rotary(),
            radial_axis: default_radial(),
            rotary_unit: RotaryUnit::default(),
            feed_convention: FeedConvention::default(),
            max_rotary_deg_s: None,
            rotary_rebase_deg: default_rebase(),
        }
    }

    /// Reads and validates a TOML document holding exactly these keys.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let config: Self = toml::from_str(text)?;
        config.validate()?;
        Ok(config)
    }

    /// Checks ranges and that the three axis letters are distinct motion axes.
    pub fn validate(&self) -> Result<()> {
        use crate::range::Range;
        in_range("machine", "mandrel_diameter_mm", self.mandrel_diameter_mm, MANDREL_DIAMETER_MM)?;
        if let Some(cap) = self.max_rotary_deg_s {
            in_range("machine", "max_rotary_deg_s", cap, Range::new(0.001, 100_000.0, "°/s"))?;
        }
        // Where A is brought back near 0 (G92); far beyond 1e8 degrees the 3 decimals of A
        // run out of digits.
        in_range("machine", "rotary_rebase_deg", self.rotary_rebase_deg, Range::new(0.0, 1e8, "°"))?;
        let axes = [
            ("axial_axis", self.axial_axis),
            ("rotary_axis", self.rotary_axis),
            ("radial_axis", self.radial_axis),
        ];
        for (i, (key, letter)) in axes.iter().enumerate() {
            if !AXIS_LETTERS.contains(*letter) {
                return Err(RotaryError::Config {
                    key,
                    reason: format!("`{letter}` is not one of the axis letters {AXIS_LETTERS}"),
                });
            }
            if axes[..i].iter().any(|(_, other)| other == letter) {
                return Err(RotaryError::Config {
                    key,
                    reason: format!("axis `{letter}` is already used by another role"),
                });
            }
        }
        Ok(())
    }

    /// Mandrel radius `R0`, mm.
    pub fn mandrel_radius_mm(&self) -> f64 {
        self.mandrel_diameter_mm / 2.0
    }

    /// Mandrel circumference `C = pi * D`, mm: the Y length of a flat part that wraps once.
    pub fn circumference_mm(&self) -> f64 {
        PI * self.mandrel_diameter_mm
    }

    /// The rotary word for an angle.
    pub fn rotary_from_deg(&self, theta_deg: f64) -> f64 {
        match self.rotary_unit {
            RotaryUnit::Degrees => theta_deg,
            RotaryUnit::Mm => theta_deg / 360.0 * self.circumference_mm(),
        }
    }

    /// The angle of a rotary word.
    pub fn deg_from_rotary(&self, rotary: f64) -> f64 {
        match self.rotary_unit {
            RotaryUnit::Degrees => rotary,
            RotaryUnit::Mm => rotary / self.circumference_mm() * 360.0,
        }
    }

    /// Time a move between two points takes at surface speed `speed_mm_s`, seconds, after the
    /// rotary speed cap. Zero for a move that goes nowhere.
    pub fn move_time_s(&self, from: CylPoint, to: CylPoint, speed_mm_s: f64) -> f64 {
        let t_s = surface_length_mm(from, to) / speed_mm_s;
        match self.max_rotary_deg_s {
            Some(cap) => t_s.max((to.theta_deg - from.theta_deg).abs() / cap),
            None => t_s,
        }
    }

    /// The distance F is measured over under a per-minute convention (0 if nothing counts).
    fn feed_distance(&self, d: &MachineDelta) -> f64 {
        let moved = match self.feed_convention {
            FeedConvention::Nist => {
                let linear = d.axial_mm.hypot(d.radial_mm);
                if linear > 0.0 {
                    linear
                } else {
                    d.rotary.abs()
                }
            }
            FeedConvention::Combined => (d.axial_mm.powi(2) + d.radial_mm.powi(2) + d.rotary.powi(2)).sqrt(),
            FeedConvention::InverseTime => 1.0,
        };
        if moved > 0.0 {
            moved
        } else {
            d.e_mm.abs()
        }
    }

    /// The path point of machine words `[axial, rotary, radial]`, the path running
    /// `nozzle_above_path_mm` below the nozzle (half the layer height for helix beads, 0 for
    /// wrapped files): `radius = R0 + radial - nozzle_above_path_mm`.
    pub fn point_from_words(&self, words: [f64; 3], nozzle_above_path_mm: f64) -> CylPoint {
        CylPoint::new(
            words[0],
            self.deg_from_rotary(words[1]),
            self.mandrel_radius_mm() + words[2] - nozzle_above_path_mm,
        )
    }

    /// The surface speed, mm/s, at which the firmware runs a move between two sets of machine
    /// words with this F: the path's surface length over [`Self::time_from_feed`]. What a
    /// virtual printer checks against the speed asked for. `None` for a move of nothing.
    pub fn surface_speed_mm_s(
        &self,
        from: [f64; 3],
        to: [f64; 3],
        feed: f64,
        nozzle_above_path_mm: f64,
    ) -> Option<f64> {
        let delta = MachineDelta {
            axial_mm: to[0] - from[0],
            rotary: to[1] - from[1],
            radial_mm: to[2] - from[2],
            e_mm: 0.0,
        };
        let t_s = self.time_from_feed(&delta, feed)?;
        let len = surface_length_mm(
            self.point_from_words(from, nozzle_above_path_mm),
            self.point_from_words(to, nozzle_above_path_mm),
        );
        Some(len / t_s)
    }

    /// The F word that makes the firmware take `t_s` seconds over `delta`.
    /// `None` if the time is not positive or nothing moves under this convention.
    pub fn feed_for(&self, delta: &MachineDelta, t_s: f64) -> Option<f64> {
        let distance = self.feed_distance(delta);
        (t_s > 0.0 && t_s.is_finite() && distance > 0.0).then(|| 60.0 * distance / t_s)
    }

    /// The time, seconds, the firmware takes over `delta` when given `feed` (the inverse of
    /// [`Self::feed_for`]: what a virtual printer computes). `None` for a non-positive feed or a
    /// move of nothing.
    pub fn time_from_feed(&self, delta: &MachineDelta, feed: f64) -> Option<f64> {
        let distance = self.feed_distance(delta);
        (feed > 0.0 && feed.is_finite() && distance > 0.0).then(|| 60.0 * distance / feed)
    }
}

impl RotaryConfig {
    /// The comment lines a rotary program starts with (`what` says which command wrote it):
    /// they name the machine, so that a reader (`gweave preview`) can draw the program on its
    /// cylinder; [`Self::from_header`] reads them back.
    pub fn header_lines(&self, what: &str) -> [String; 2] {
        [
            format!("; gweave rotary {what}: mandrel {} mm", self.mandrel_diameter_mm),
            format!(
                "; axes: axial {}, rotary {} ({:?}), radial {} (0 = on the mandrel); feed {:?}",
                self.axial_axis, self.rotary_axis, self.rotary_unit, self.radial_axis, self.feed_convention
            ),
        ]
    }

    /// How far into a file its header is looked for, bytes (after the run's own header line
    /// and the slicer's first comments).
    pub const HEADER_BYTES: u64 = 4096;

    /// The machine named by the header at the start of `input` (its first
    /// [`Self::HEADER_BYTES`]), and `input` again from its first byte: a file is read once, as
    /// it comes (standard input, a decompressed or decoded stream), the head kept for the reader.
    pub fn from_stream_head<R: std::io::Read>(
        mut input: R,
    ) -> std::io::Result<(Option<RotaryConfig>, impl std::io::Read)> {
        use std::io::Read;
        let mut head = Vec::new();
        input.by_ref().take(Self::HEADER_BYTES).read_to_end(&mut head)?;
        let rotary = Self::from_header(&String::from_utf8_lossy(&head));
        Ok((rotary, std::io::Cursor::new(head).chain(input)))
    }

    /// The machine named by the header of the file at `path` ([`Self::from_stream_head`]), for
    /// a reader that sets its reading up before it reads (a preview's toolpath options); `None`
    /// if it cannot be read or has no such header.
    pub fn from_file_header(path: &std::path::Path) -> Option<RotaryConfig> {
        Self::from_stream_head(crate::gcode::container::open(path).ok()?).ok()?.0
    }

    /// The machine named by a program's header ([`Self::header_lines`]) in `text`, the start
    /// of a file; `None` if it has no such header (or a malformed one).
    pub fn from_header(text: &str) -> Option<RotaryConfig> {
        let mut lines = text.lines().map(str::trim);
        let first = lines.find(|l| l.starts_with("; gweave rotary "))?;
        let diameter: f64 = first.split_once(": mandrel ")?.1.split_whitespace().next()?.parse().ok()?;
        let axes = lines.take(4).find_map(|l| l.strip_prefix("; axes: axial "))?;
        // `X, rotary A (Degrees), radial Z (0 = on the mandrel); feed Nist`
        let (axial, rest) = axes.split_once(", rotary ")?;
        let (rotary, rest) = rest.split_once(" (")?;
        let (unit, rest) = rest.split_once("), radial ")?;
        let (radial, rest) = rest.split_once(" (")?;
        let feed = rest.rsplit_once("; feed ")?.1.trim();
        let letter = |s: &str| -> Option<char> {
            let mut c = s.chars();
            c.next().filter(|_| c.next().is_none())
        };
        let mut machine = RotaryConfig::new(diameter);
        machine.axial_axis = letter(axial)?;
        machine.rotary_axis = letter(rotary)?;
        machine.radial_axis = letter(radial)?;
        machine.rotary_unit =
            [RotaryUnit::Degrees, RotaryUnit::Mm].into_iter().find(|u| format!("{u:?}") == unit)?;
        machine.feed_convention =
            [FeedConvention::Nist, FeedConvention::Combined, FeedConvention::InverseTime]
                .into_iter()
                .find(|f| format!("{f:?}") == feed)?;
        machine.validate().ok().map(|()| machine)
    }
}

/// A point in cylindrical coordinates: along the mandrel, angle, distance from the axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CylPoint {
    /// Position along the mandrel axis, mm.
    pub axial_mm: f64,
    /// Mandrel angle, degrees, unbounded (several turns accumulate).
    pub theta_deg: f64,
    /// Distance from the mandrel axis, mm.
    pub radius_mm: f64,
}

impl CylPoint {
    /// Bundles the three coordinates.
    pub fn new(axial_mm: f64, theta_deg: f64, radius_mm: f64) -> Self {
        Self { axial_mm, theta_deg, radius_mm }
    }

    /// This point in Cartesian coordinates, see [`to_cartesian`].
    pub fn to_cartesian(self) -> [f64; 3] {
        to_cartesian(self.axial_mm, self.theta_deg, self.radius_mm)
    }
}

/// Cartesian position `[axial, r cos(theta), r sin(theta)]` of a cylindrical point, mm.
pub fn to_cartesian(axial_mm: f64, theta_deg: f64, radius_mm: f64) -> [f64; 3] {
    let (sin, cos) = theta_deg.to_radians().sin_cos();
    [axial_mm, radius_mm * cos, radius_mm * sin]
}

/// A move in machine words: the differences of the words the firmware sees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MachineDelta {
    /// Change of the axial word, mm.
    pub axial_mm: f64,
    /// Change of the rotary word, in the configured rotary unit.
    pub rotary: f64,
    /// Change of the radial word, mm.
    pub radial_mm: f64,
    /// Filament moved, mm.
    pub e_mm: f64,
}

/// Length of the machine's path between two points on the surface it sweeps, mm:
/// `sqrt(dX^2 + dr^2 + (r_mean*dTheta_rad)^2)` (exact at constant radius).
pub fn surface_length_mm(from: CylPoint, to: CylPoint) -> f64 {
    let r_mean = 0.5 * (from.radius_mm + to.radius_mm);
    let arc = r_mean * (to.theta_deg - from.theta_deg).to_radians();
    let dx = to.axial_mm - from.axial_mm;
    let dr = to.radius_mm - from.radius_mm;
    (dx * dx + dr * dr + arc * arc).sqrt()
}

/// Sagitta of the chord spanning `d_theta_deg` on a circle of radius `radius_mm`:
/// `r*(1 - cos(dTheta/2))`, mm.
pub fn sagitta_mm(radius_mm: f64, d_theta_deg: f64) -> f64 {
    radius_mm * (1.0 - (0.5 * d_theta_deg.to_radians()).cos())
}

/// The largest angle, degrees, whose chord stays within `tolerance_mm` of a circle of radius
/// `radius_mm`: `2*acos(1 - tol/r)`, at most 180 degrees (a longer chord says nothing useful).
pub fn max_chord_step_deg(radius_mm: f64, tolerance_mm: f64) -> f64 {
    if tolerance_mm >= radius_mm {
        return 180.0;
    }
    (2.0 * (1.0 - tolerance_mm / radius_mm).acos()).to_degrees().min(180.0)
}

/// How many equal pieces a turn of `d_theta_deg` at radius `radius_mm` needs so that each
/// chord's sagitta is at most `tolerance_mm` (at least 1).
pub fn chord_pieces(radius_mm: f64, d_theta_deg: f64, tolerance_mm: f64) -> usize {
    pieces_for_step(d_theta_deg, max_chord_step_deg(radius_mm, tolerance_mm))
}

/// How many equal pieces of at most `step_deg` a turn of `d_theta_deg` needs (at least 1).
pub fn pieces_for_step(d_theta_deg: f64, step_deg: f64) -> usize {
    // The ratio is finite and non-negative for validated inputs; float-to-int casts saturate.
    ((d_theta_deg.abs() / step_deg).ceil() as usize).max(1)
}

/// How a flat part is wrapped onto the mandrel. TOML keys all optional.
///
/// ```toml
/// keep_arc_length = false             # true: Diabase's A = Y*180/(pi*(R0 + z - z1)), E kept
/// arc_length_z1_mm = 0.0              # z1 of that formula (the first layer's Z in Diabase)
/// seam_offset_deg = 0.0               # where y = 0 lands on the mandrel
/// seam_rotation_per_layer_deg = 0.0   # turn each layer further, to stagger the weld line
/// helical = false                     # true: each layer one turn of a helix, no weld line
/// ```
///
/// The seam rotation turns whole layers: it staggers the weld line of parts that go all the way
/// round (sleeves) and twists any other part.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UnwrapConfig {
    /// Keep flat arc lengths (Diabase) instead of wrapping Y onto one circumference.
    pub keep_arc_length: bool,
    /// Reference height z1 of the arc-length formula, mm.
    pub arc_length_z1_mm: f64,
    /// Angle of the seam (flat y = 0), degrees.
    pub seam_offset_deg: f64,
    /// Extra rotation of every layer relative to the previous one, degrees.
    pub seam_rotation_per_layer_deg: f64,
    /// Helical unwrapping (`rotary::helical`): the radius rises one layer height per turn.
    pub helical: bool,
}

impl UnwrapConfig {
    /// Checks every number against its range.
    pub fn validate(&self) -> Result<()> {
        use crate::range;
        in_range("unwrap", "arc_length_z1_mm", self.arc_length_z1_mm, range::POSITION_MM)?;
        in_range("unwrap", "seam_offset_deg", self.seam_offset_deg, range::ANGLE_DEG)?;
        in_range(
            "unwrap",
            "seam_rotation_per_layer_deg",
            self.seam_rotation_per_layer_deg,
            range::ANGLE_DEG,
        )?;
        // A helical layer has no seam to stagger, and its turn is one circumference of flat Y.
        let reason = if !self.helical {
            None
        } else if self.keep_arc_length {
            Some("the helical mapping wraps flat Y onto the circumference; it cannot keep arc lengths")
        } else if self.seam_rotation_per_layer_deg != 0.0 {
            Some("a helical layer has no seam to stagger; turning a layer would break the join to the next")
        } else {
            None
        };
        match reason {
            Some(r) => Err(RotaryError::Config { key: "helical", reason: r.into() }),
            None => Ok(()),
        }
    }

    /// Angle of the seam (flat y = 0) on layer `layer` (0-based), degrees.
    pub fn seam_deg(&self, layer: u32) -> f64 {
        self.seam_offset_deg + f64::from(layer) * self.seam_rotation_per_layer_deg
    }

    /// Maps a flat point `[x, y, z]` of layer `layer` onto the mandrel. The radius is the
    /// nozzle's, `R0 + z`; it is an error if that is not above the axis.
    pub fn map(&self, machine: &RotaryConfig, flat: [f64; 3], layer: u32) -> Result<CylPoint> {
        let [x, y, z] = flat;
        let r0 = machine.mandrel_radius_mm();
        let radius_mm = r0 + z;
        let theta_deg = if self.keep_arc_length {
            // Diabase: the arc at radius R0 + z - z1 has the flat length y.
            let arc_radius = r0 + z - self.arc_length_z1_mm;
            if arc_radius <= 0.0 {
                return Err(RotaryError::BelowAxis { radius_mm: arc_radius });
            }
            y * 180.0 / (PI * arc_radius)
        } else {
            360.0 * y / machine.circumference_mm()
        };
        if radius_mm <= 0.0 {
            return Err(RotaryError::BelowAxis { radius_mm });
        }
        Ok(CylPoint::new(x, theta_deg + self.seam_deg(layer), radius_mm))
    }

    /// Factor by which the extrusion of the flat segment `from -> to` grows on the cylinder:
    /// surface length `|(dx, dy*r/R0, dz)|` over flat length `|(dx, dy, dz)|` with `r = R0 + z`
    /// at the segment's mean z. 1 for a segment of zero length and with `keep_arc_length`.
    pub fn e_scale(&self, machine: &RotaryConfig, from: [f64; 3], to: [f64; 3]) -> f64 {
        let [dx, dy, dz] = [to[0] - from[0], to[1] - from[1], to[2] - from[2]];
        let flat = (dx * dx + dy * dy + dz * dz).sqrt();
        if self.keep_arc_length || flat == 0.0 {
            return 1.0;
        }
        let r0 = machine.mandrel_radius_mm();
        let stretch = (r0 + 0.5 * (from[2] + to[2])) / r0;
        let around = dy * stretch;
        (dx * dx + around * around + dz * dz).sqrt() / flat
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, eps: f64) -> bool {
        (a - b).abs() <= eps
    }

    #[test]
    fn toml_defaults_and_unknown_keys() {
        let config = RotaryConfig::from_toml_str("mandrel_diameter_mm = 40.0").unwrap();
        assert_eq!(config, RotaryConfig::new(40.0));
        assert_eq!((config.axial_axis, config.rotary_axis, config.radial_axis), ('X', 'A', 'Z'));
        let err = RotaryConfig::from_toml_str("mandrel_diameter_mm = 40.0\nspeed = 3").unwrap_err();
        assert!(err.to_string().contains("unknown field `speed`"), "{err}");
        let err = RotaryConfig::from_toml_str("axial_axis = \"X\"").unwrap_err();
        assert!(err.to_string().contains("mandrel_diameter_mm"), "{err}");
    }

    #[test]
    fn toml_full_and_validation() {
        let config = RotaryConfig::from_toml_str(
            "mandrel_diameter_mm = 30\nrotary_axis = \"Y\"\nrotary_unit = \"mm\"\n\
             feed_convention = \"inverse-time\"\nmax_rotary_deg_s = 90",
        )
        .unwrap();
        assert_eq!(config.rotary_unit, RotaryUnit::Mm);
        assert_eq!(config.feed_convention, FeedConvention::InverseTime);
        assert_eq!(config.max_rotary_deg_s, Some(90.0));
        let same = RotaryConfig::from_toml_str("mandrel_diameter_mm = 30\nrotary_axis = \"X\"");
        assert!(matches!(same, Err(RotaryError::Config { key: "rotary_axis", .. })));
        let bad = RotaryConfig::from_toml_str("mandrel_diameter_mm = 30\nradial_axis = \"E\"");
        assert!(matches!(bad, Err(RotaryError::Config { key: "radial_axis", .. })));
        assert!(RotaryConfig::new(-1.0).validate().is_err());
        assert!(RotaryConfig::new(f64::NAN).validate().is_err());
    }

    #[test]
    fn rotary_units_round_trip() {
        let mut config = RotaryConfig::new(20.0);
        assert_eq!(config.rotary_from_deg(90.0), 90.0);
        config.rotary_unit = RotaryUnit::Mm;
        // A quarter turn of a 20 mm mandrel is a quarter of 62.83 mm.
        assert!(close(config.rotary_from_deg(90.0), 15.707_963, 1e-6));
        assert!(close(config.deg_from_rotary(15.707_963_267_9), 90.0, 1e-9));
    }

    #[test]
    fn feed_per_convention() {
        // 10 mm axial and a quarter turn at r = 10: L = hypot(10, 15.708) = 18.621 mm.
        let from = CylPoint::new(0.0, 0.0, 10.0);
        let to = CylPoint::new(10.0, 90.0, 10.0);
        let length = surface_length_mm(from, to);
        assert!(close(length, 18.620_90, 1e-4));
        let mut config = RotaryConfig::new(20.0);
        let t_s = config.move_time_s(from, to, 10.0);
        assert!(close(t_s, 1.862_09, 1e-5));
        let delta = MachineDelta { axial_mm: 10.0, rotary: 90.0, ..Default::default() };
        // NIST: 10 mm of X in 1.862 s.
        assert!(close(config.feed_for(&delta, t_s).unwrap(), 322.22, 0.01));
        config.feed_convention = FeedConvention::Combined;
        // hypot(10, 90) = 90.554 "mm" in 1.862 s.
        assert!(close(config.feed_for(&delta, t_s).unwrap(), 2917.8, 0.1));
        config.feed_convention = FeedConvention::InverseTime;
        assert!(close(config.feed_for(&delta, t_s).unwrap(), 32.222, 0.001));
        for convention in [FeedConvention::Nist, FeedConvention::Combined, FeedConvention::InverseTime] {
            config.feed_convention = convention;
            let feed = config.feed_for(&delta, t_s).unwrap();
            assert!(close(config.time_from_feed(&delta, feed).unwrap(), t_s, 1e-9));
        }
    }

    #[test]
    fn nist_rotary_only_and_extruder_only() {
        let config = RotaryConfig::new(20.0);
        let spin = MachineDelta { rotary: 180.0, ..Default::default() };
        // Half a turn in 3 s: 60 deg/s = 3600 deg/min.
        assert!(close(config.feed_for(&spin, 3.0).unwrap(), 3600.0, 1e-9));
        let retract = MachineDelta { e_mm: -2.0, ..Default::default() };
        assert!(close(config.feed_for(&retract, 0.05).unwrap(), 2400.0, 1e-9));
        assert_eq!(config.feed_for(&MachineDelta::default(), 1.0), None);
        assert_eq!(config.feed_for(&spin, 0.0), None);
    }

    #[test]
    fn rotary_cap_slows_the_move() {
        let mut config = RotaryConfig::new(20.0);
        config.max_rotary_deg_s = Some(30.0);
        let from = CylPoint::new(0.0, 0.0, 10.0);
        let to = CylPoint::new(0.0, 90.0, 10.0);
        // 15.7 mm at 100 mm/s would be 0.157 s, but 90 deg at 30 deg/s takes 3 s.
        assert!(close(config.move_time_s(from, to, 100.0), 3.0, 1e-12));
        assert!(close(config.move_time_s(from, to, 1.0), 15.707_963, 1e-6));
    }

    #[test]
    fn chords() {
        assert!(close(sagitta_mm(10.0, 180.0), 10.0, 1e-12));
        let step = max_chord_step_deg(10.0, 0.01);
        assert!(close(sagitta_mm(10.0, step), 0.01, 1e-12));
        assert_eq!(chord_pieces(10.0, 360.0, 0.01), (360.0 / step).ceil() as usize);
        assert_eq!(chord_pieces(10.0, 0.0, 0.01), 1);
        assert_eq!(max_chord_step_deg(1.0, 5.0), 180.0);
    }

    #[test]
    fn cartesian() {
        let [x, y, z] = to_cartesian(3.0, 90.0, 2.0);
        assert!(close(x, 3.0, 0.0) && close(y, 0.0, 1e-12) && close(z, 2.0, 1e-12));
    }

    #[test]
    fn unwrap_maps_and_scales() {
        let machine = RotaryConfig::new(20.0);
        let unwrap = UnwrapConfig::default();
        let c = machine.circumference_mm();
        let p = unwrap.map(&machine, [5.0, c / 4.0, 0.4], 0).unwrap();
        assert_eq!(p.axial_mm, 5.0);
        assert!(close(p.theta_deg, 90.0, 1e-12) && close(p.radius_mm, 10.4, 1e-12));
        // Pure Y move at z = 0.4 on R0 = 10: surface grows by 10.4/10.
        let s = unwrap.e_scale(&machine, [0.0, 0.0, 0.4], [0.0, 3.0, 0.4]);
        assert!(close(s, 1.04, 1e-12));
        // Pure X move: unchanged. Diagonal: hypot(3, 4*1.04)/5.
        assert_eq!(unwrap.e_scale(&machine, [0.0, 0.0, 0.4], [3.0, 0.0, 0.4]), 1.0);
        let s = unwrap.e_scale(&machine, [0.0, 0.0, 0.4], [3.0, 4.0, 0.4]);
        assert!(close(s, (9.0f64 + 4.16 * 4.16).sqrt() / 5.0, 1e-12));
        assert_eq!(unwrap.e_scale(&machine, [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]), 1.0);
        // The scale matches the surface length of the mapped points.
        let (a, b) = ([1.0, 2.0, 0.4], [4.0, 9.0, 0.4]);
        let flat = (9.0f64 + 49.0).sqrt();
        let mapped =
            surface_length_mm(unwrap.map(&machine, a, 0).unwrap(), unwrap.map(&machine, b, 0).unwrap());
        assert!(close(unwrap.e_scale(&machine, a, b) * flat, mapped, 1e-9));
    }

    #[test]
    fn keep_arc_length_is_diabase() {
        let machine = RotaryConfig::new(20.0);
        let unwrap = UnwrapConfig { keep_arc_length: true, arc_length_z1_mm: 0.2, ..Default::default() };
        // A = Y*180/(pi*(R + z - z1)) with R = 10, z = 1.2, z1 = 0.2: Y = 11 -> 180/pi * 1.
        let p = unwrap.map(&machine, [0.0, 11.0, 1.2], 0).unwrap();
        assert!(close(p.theta_deg, 180.0 / PI, 1e-12));
        assert_eq!(unwrap.e_scale(&machine, [0.0, 0.0, 1.2], [0.0, 11.0, 1.2]), 1.0);
        let low = unwrap.map(&machine, [0.0, 1.0, -10.0], 0);
        assert!(matches!(low, Err(RotaryError::BelowAxis { .. })));
    }

    #[test]
    fn seam_rotates_per_layer() {
        let machine = RotaryConfig::new(20.0);
        let unwrap =
            UnwrapConfig { seam_offset_deg: 10.0, seam_rotation_per_layer_deg: 7.5, ..Default::default() };
        assert_eq!(unwrap.seam_deg(4), 40.0);
        let p = unwrap.map(&machine, [0.0, 0.0, 0.2], 4).unwrap();
        assert_eq!(p.theta_deg, 40.0);
    }

    #[test]
    fn header_lines_read_back_into_the_machine() {
        let mut m = RotaryConfig::new(30.0);
        m.rotary_axis = 'Y';
        m.rotary_unit = RotaryUnit::Mm;
        m.feed_convention = FeedConvention::InverseTime;
        let text = format!("G28\n{}\n{}\nG1 X1\n", m.header_lines("wrap")[0], m.header_lines("wrap")[1]);
        assert_eq!(RotaryConfig::from_header(&text), Some(m.clone()));
        assert_eq!(
            m.header_lines("tube")[1],
            "; axes: axial X, rotary Y (Mm), radial Z (0 = on the mandrel); feed InverseTime"
        );
        assert_eq!(RotaryConfig::from_header("; generated by PrusaSlicer\nG1 X1\n"), None);
        assert_eq!(RotaryConfig::from_header("; gweave rotary tube: mandrel -3 mm\n; axes: axial X, rotary A (Degrees), radial Z (0 = on the mandrel); feed Nist"), None, "invalid machine");
    }
}
