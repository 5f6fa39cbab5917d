//! Seam-free helical printing on a mandrel: tubes of continuous helical layers and custom
//! helical paths (cones, variable pitch).
//!
//! # The tube (the rotary seed's method (b), done properly)
//!
//! ```text
//!         axial ->
//!   layer 1  \ \ \ \ \ \ \ \      r_1 = R0 + 1.5 h   (left-handed: X falls while A rises)
//!   layer 0  / / / / / / / /      r_0 = R0 + 0.5 h   (right-handed: X and A rise together)
//!   mandrel  ================     R0
//! ```
//!
//! - Layer `k` is a helix whose bead centreline lies on `r_k = R0 + (k + 1/2) h`; the nozzle
//!   touches the top of the bead, so its radial word is `(k + 1) h`.
//! - The helix advances one pitch `p` per turn: `p = w` (the bead width) lays turns side by
//!   side into a closed wall, `p > w` leaves an open lattice.
//! - Layers run back and forth along the mandrel. Keeping the spindle turning one way while the
//!   axial direction flips reverses the handedness of every layer (`interweave`, the default):
//!   the beads of neighbouring layers cross. Without it the spindle reverses instead and all
//!   layers share one handedness.
//! - Angular speed is recomputed per layer so the surface speed stays `v`: along the helix
//!   `ds/dtheta = sqrt(r_k^2 + (p/2pi)^2)`, so `omega_k = v / sqrt(r_k^2 + (p/2pi)^2)`
//!   (rad/s); each move's F follows from that through the feed convention.
//! - Extrusion per segment `E = w h L / A_filament`, `L` measured on the bead's surface.
//! - No travel and no seam: layer `k + 1` starts where layer `k` ended, after a radial step of
//!   one layer height.
//! - `end_turns` flat turns close each end of each layer. A helix leaves a wedge of half a turn
//!   of bead empty at each end; half a flat turn fills half of it and overlaps the next turn by
//!   the same amount, so with the default 0.5 a closed wall holds exactly the volume of the
//!   tube, `pi ((R0 + N h)^2 - R0^2) * length`.

use std::fmt;
use std::io::Write;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::cylinder::{max_chord_step_deg, pieces_for_step, surface_length_mm, CylPoint, RotaryConfig};
use super::emit::{rotary_number_format, validate_format, MoveWriter};
use super::{finite, in_range, Result, RotaryError};
use crate::gcode::number::NumberFormat;
use crate::range::{Range, FILAMENT_DIAMETER_MM, LAYER_HEIGHT_MM, POSITION_MM, SPEED_MM_S, TEMPERATURE_C};

/// Most points one path may have (a runaway guard: 5 million chords are ~150 MB of G-code).
pub const MAX_POINTS: usize = 5_000_000;

/// Largest chord sagitta: below a micrometre the chords only multiply (0.001 mm on a 1 mm
/// mandrel is already 50 chords per turn).
pub const CHORD_TOLERANCE_MM: Range<f64> = Range::new(0.001, 10.0, "mm");
/// Tube length along the mandrel.
pub const TUBE_LENGTH_MM: Range<f64> = Range::new(0.1, 10_000.0, "mm");
/// Radial layers of a tube.
pub const TUBE_LAYERS: Range<u32> = Range::new(1, 1_000, "");
/// Bead width.
pub const BEAD_WIDTH_MM: Range<f64> = Range::new(0.05, 20.0, "mm");
/// Axial advance per turn.
pub const PITCH_MM: Range<f64> = Range::new(0.05, 10_000.0, "mm");
/// Chords per turn (a triangle to a tenth of a degree).
pub const SEGMENTS_PER_TURN: Range<u32> = Range::new(3, 3_600, "");

/// Flat turns closing each end of a layer.
pub const END_TURNS: Range<f64> = Range::new(0.0, 100.0, "turns");

/// A quantity as a function of the axial position, mm -> mm.
#[derive(Clone)]
pub enum Profile {
    /// The same value everywhere.
    Constant(f64),
    /// `(axial_mm, value)` pairs in increasing axial order, linear in between and held
    /// constant beyond the ends (a cone is two pairs).
    Table(Vec<(f64, f64)>),
    /// Any function (for the Python bindings, a sampled callable).
    Custom(Arc<dyn Fn(f64) -> f64 + Send + Sync>),
}

impl fmt::Debug for Profile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Constant(v) => f.debug_tuple("Constant").field(v).finish(),
            Self::Table(t) => f.debug_tuple("Table").field(t).finish(),
            Self::Custom(_) => f.write_str("Custom(..)"),
        }
    }
}

impl Profile {
    /// The raw value at `axial_mm` (not checked; see `checked`).
    pub fn at(&self, axial_mm: f64) -> f64 {
        match self {
            Self::Constant(v) => *v,
            Self::Custom(f) => f(axial_mm),
            Self::Table(table) => {
                let i = table.partition_point(|&(x, _)| x <= axial_mm);
                match (i.checked_sub(1).map(|j| table[j]), table.get(i)) {
                    (Some((x0, v0)), Some(&(x1, v1))) => v0 + (v1 - v0) * (axial_mm - x0) / (x1 - x0),
                    (Some((_, v)), None) | (None, Some(&(_, v))) => v,
                    (None, None) => f64::NAN,
                }
            }
        }
    }

    /// The value at `axial_mm`, which must be finite and positive.
    fn checked(&self, what: &'static str, axial_mm: f64) -> Result<f64> {
        let value = self.at(axial_mm);
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(RotaryError::Profile { what, axial_mm, value })
        }
    }

    /// A table must be non-empty with strictly increasing, finite axial positions.
    fn validate(&self, key: &'static str) -> Result<()> {
        let Self::Table(table) = self else {
            return Ok(());
        };
        let increasing = table.windows(2).all(|w| w[0].0 < w[1].0);
        if table.is_empty() || !increasing || table.iter().any(|(x, _)| !x.is_finite()) {
            return Err(RotaryError::Config {
                key,
                reason: "a table needs finite, strictly increasing axial positions".into(),
            });
        }
        Ok(())
    }
}

/// The sense of a helix: right-handed when the axial position and the angle grow together.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Handedness {
    /// The angle grows while moving towards +axial.
    Right,
    /// The angle falls while moving towards +axial.
    Left,
}

/// One helical bead from `start_axial_mm` to `end_axial_mm` (either direction), its
/// centreline at `radius_mm(axial)`, advancing `pitch_mm(axial)` per turn, optionally with
/// flat turns (no axial motion) before and after.
#[derive(Clone, Debug)]
pub struct HelicalPath {
    /// Where the helix starts along the mandrel, mm.
    pub start_axial_mm: f64,
    /// Where it ends, mm (smaller than the start to go backwards).
    pub end_axial_mm: f64,
    /// The mandrel angle at the start, degrees.
    pub start_theta_deg: f64,
    /// Sense of the helix; with the axial direction it fixes the spindle direction.
    pub handedness: Handedness,
    /// Axial advance per turn, mm, as a function of the axial position.
    pub pitch_mm: Profile,
    /// Bead centreline radius, mm, as a function of the axial position.
    pub radius_mm: Profile,
    /// Flat turning at the start before the helix advances, degrees.
    pub lead_in_deg: f64,
    /// Flat turning at the end, degrees.
    pub lead_out_deg: f64,
}

impl HelicalPath {
    /// A right-handed path starting at angle 0 with no flat turns.
    pub fn new(start_axial_mm: f64, end_axial_mm: f64, radius_mm: Profile, pitch_mm: Profile) -> Self {
        Self {
            start_axial_mm,
            end_axial_mm,
            start_theta_deg: 0.0,
            handedness: Handedness::Right,
            pitch_mm,
            radius_mm,
            lead_in_deg: 0.0,
            lead_out_deg: 0.0,
        }
    }

    /// +1 if the path runs towards +axial (or stays put), -1 if it runs back.
    fn axial_dir(&self) -> f64 {
        if self.end_axial_mm >= self.start_axial_mm {
            1.0
        } else {
            -1.0
        }
    }

    /// +1 if the angle grows along this path, -1 if it falls.
    pub fn spin(&self) -> f64 {
        let axial = self.axial_dir();
        match self.handedness {
            Handedness::Right => axial,
            Handedness::Left => -axial,
        }
    }

    fn validate(&self) -> Result<()> {
        finite("start_axial_mm", self.start_axial_mm)?;
        finite("end_axial_mm", self.end_axial_mm)?;
        finite("start_theta_deg", self.start_theta_deg)?;
        for (key, deg) in [("lead_in_deg", self.lead_in_deg), ("lead_out_deg", self.lead_out_deg)] {
            if !(deg.is_finite() && deg >= 0.0) {
                return Err(RotaryError::Config {
                    key,
                    reason: format!("must be a finite angle >= 0, got {deg}"),
                });
            }
        }
        self.pitch_mm.validate("pitch_mm")?;
        self.radius_mm.validate("radius_mm")
    }

    /// The points of the path, each chord within `resolution` of the true helix.
    ///
    /// Steps are taken in angle: the largest whose chord sagitta at the local radius (the
    /// larger of the step's two ends, for cones) is within tolerance, and the axial advance of
    /// a step uses the pitch at its midpoint.
    pub fn points(&self, resolution: Resolution) -> Result<Vec<CylPoint>> {
        self.validate()?;
        resolution.validate()?;
        let dir = self.axial_dir();
        let spin = self.spin();
        self.check_size(resolution)?;
        let mut x = self.start_axial_mm;
        let mut points = vec![CylPoint::new(x, self.start_theta_deg, self.radius_mm.checked("radius", x)?)];
        self.turn_in_place(&mut points, self.lead_in_deg * spin, resolution)?;
        let mut theta = points.last().map_or(self.start_theta_deg, |p| p.theta_deg);
        loop {
            let remaining = (self.end_axial_mm - x).abs();
            if remaining <= 0.0 {
                break;
            }
            let r = self.radius_mm.checked("radius", x)?;
            let mut step = resolution.step_deg(r);
            let ahead = x + dir * (self.pitch_mm.checked("pitch", x)? * step / 360.0).min(remaining);
            step = step.min(resolution.step_deg(self.radius_mm.checked("radius", ahead)?));
            let mid = x + dir * (self.pitch_mm.checked("pitch", x)? * step / 720.0).min(remaining);
            let pitch = self.pitch_mm.checked("pitch", mid)?;
            let advance = pitch * step / 360.0;
            if advance >= remaining {
                step *= remaining / advance;
                x = self.end_axial_mm;
            } else {
                x += dir * advance;
            }
            theta += spin * step;
            push(&mut points, CylPoint::new(x, theta, self.radius_mm.checked("radius", x)?))?;
        }
        self.turn_in_place(&mut points, self.lead_out_deg * spin, resolution)?;
        Ok(points)
    }

    /// Refuses early a path whose estimate from its start (pitch, radius) exceeds
    /// [`MAX_POINTS`]; variable profiles are also guarded point by point.
    fn check_size(&self, resolution: Resolution) -> Result<()> {
        if self.estimated_points(resolution)? > MAX_POINTS as f64 {
            return Err(RotaryError::TooManyPoints { limit: MAX_POINTS });
        }
        Ok(())
    }

    /// Points of the path estimated from its start (pitch, radius).
    fn estimated_points(&self, resolution: Resolution) -> Result<f64> {
        let x = self.start_axial_mm;
        let step = resolution.step_deg(self.radius_mm.checked("radius", x)?);
        let turns_deg = (self.end_axial_mm - x).abs() / self.pitch_mm.checked("pitch", x)? * 360.0
            + self.lead_in_deg
            + self.lead_out_deg;
        Ok(turns_deg / step)
    }

    /// Appends a flat turn of `d_theta_deg` at the last point's axial position.
    fn turn_in_place(
        &self,
        points: &mut Vec<CylPoint>,
        d_theta_deg: f64,
        resolution: Resolution,
    ) -> Result<()> {
        let Some(&start) = points.last() else {
            return Ok(());
        };
        if d_theta_deg == 0.0 {
            return Ok(());
        }
        let pieces = pieces_for_step(d_theta_deg, resolution.step_deg(start.radius_mm));
        for i in 1..=pieces {
            let theta = start.theta_deg + d_theta_deg * i as f64 / pieces as f64;
            push(points, CylPoint::new(start.axial_mm, theta, start.radius_mm))?;
        }
        Ok(())
    }

    /// A complete program printing these paths in order, see [`write_paths`].
    pub fn write_gcode<W: Write>(
        &self,
        machine: &RotaryConfig,
        print: &PrintSettings,
        out: W,
    ) -> Result<ProgramSummary> {
        write_paths(machine, print, std::slice::from_ref(self), out)
    }
}

fn push(points: &mut Vec<CylPoint>, p: CylPoint) -> Result<()> {
    if points.len() >= MAX_POINTS {
        return Err(RotaryError::TooManyPoints { limit: MAX_POINTS });
    }
    points.push(p);
    Ok(())
}

/// How finely a helix is cut into straight G1 chords.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resolution {
    /// Largest distance of a chord's midpoint from the true helix, mm.
    pub chord_tolerance_mm: f64,
    /// If set, also at least this many chords per turn.
    pub segments_per_turn: Option<u32>,
}

impl Resolution {
    fn validate(&self) -> Result<()> {
        CHORD_TOLERANCE_MM.check("chord_tolerance_mm", self.chord_tolerance_mm)?;
        if let Some(n) = self.segments_per_turn {
            SEGMENTS_PER_TURN.check("segments_per_turn", n)?;
        }
        Ok(())
    }

    /// The largest step at radius `radius_mm`, degrees.
    pub fn step_deg(&self, radius_mm: f64) -> f64 {
        let by_chord = max_chord_step_deg(radius_mm, self.chord_tolerance_mm);
        match self.segments_per_turn {
            Some(n) => by_chord.min(360.0 / f64::from(n)),
            None => by_chord,
        }
    }
}

/// The bead, the material and how to write the program. TOML keys are all optional; the defaults are the rotary seed's setup (`docs/seeds.md`) (`G28 X Z`, `M109 S190`, `G90`, `G21`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PrintSettings {
    /// Bead height = radial step between layers, mm (default 0.2).
    pub layer_height_mm: f64,
    /// Bead width, mm (default 0.4).
    pub bead_width_mm: f64,
    /// Filament diameter, mm (default 1.75).
    pub filament_diameter_mm: f64,
    /// Speed of the nozzle over the bead's surface while printing, mm/s (default 20).
    pub print_speed_mm_s: f64,
    /// Speed of non-extruding moves, mm/s (default 50).
    pub travel_speed_mm_s: f64,
    /// Nozzle temperature, degrees C (default 190).
    pub nozzle_temp_c: f64,
    /// Heated mandrel temperature, degrees C (default none: no M190/M140).
    pub mandrel_temp_c: Option<f64>,
    /// Relative E (M83) instead of absolute (M82, the default).
    pub relative_e: bool,
    /// Largest chord sagitta, mm (default 0.01).
    pub chord_tolerance_mm: f64,
    /// Optional minimum number of chords per turn.
    pub segments_per_turn: Option<u32>,
    /// Lines written before printing; default `G28 X Z`, heat-up, `G90`, `G21`.
    pub start_gcode: Option<Vec<String>>,
    /// Lines written after printing; default heaters off, lift 5 mm, motors off.
    pub end_gcode: Option<Vec<String>>,
    /// Decimal places (`[print.numbers]`).
    pub numbers: NumberFormat,
}

impl Default for PrintSettings {
    fn default() -> Self {
        Self {
            layer_height_mm: 0.2,
            bead_width_mm: 0.4,
            filament_diameter_mm: 1.75,
            print_speed_mm_s: 20.0,
            travel_speed_mm_s: 50.0,
            nozzle_temp_c: 190.0,
            mandrel_temp_c: None,
            relative_e: false,
            chord_tolerance_mm: 0.01,
            segments_per_turn: None,
            start_gcode: None,
            end_gcode: None,
            numbers: rotary_number_format(),
        }
    }
}

impl PrintSettings {
    /// Checks every range.
    pub fn validate(&self) -> Result<()> {
        in_range("print", "layer_height_mm", self.layer_height_mm, LAYER_HEIGHT_MM)?;
        in_range("print", "bead_width_mm", self.bead_width_mm, BEAD_WIDTH_MM)?;
        in_range("print", "filament_diameter_mm", self.filament_diameter_mm, FILAMENT_DIAMETER_MM)?;
        in_range("print", "print_speed_mm_s", self.print_speed_mm_s, SPEED_MM_S)?;
        in_range("print", "travel_speed_mm_s", self.travel_speed_mm_s, SPEED_MM_S)?;
        in_range("print", "nozzle_temp_c", self.nozzle_temp_c, TEMPERATURE_C)?;
        if let Some(t) = self.mandrel_temp_c {
            in_range("print", "mandrel_temp_c", t, TEMPERATURE_C)?;
        }
        in_range("print", "chord_tolerance_mm", self.chord_tolerance_mm, CHORD_TOLERANCE_MM)?;
        if let Some(n) = self.segments_per_turn {
            in_range("print", "segments_per_turn", n, SEGMENTS_PER_TURN)?;
        }
        validate_format("print.numbers", &self.numbers)
    }

    /// The chord resolution these settings ask for.
    pub fn resolution(&self) -> Resolution {
        Resolution { chord_tolerance_mm: self.chord_tolerance_mm, segments_per_turn: self.segments_per_turn }
    }

    /// Filament for a bead of length `len_mm`: `w h L / (pi d^2 / 4)`, mm.
    pub fn filament_for_mm(&self, len_mm: f64) -> f64 {
        let area_mm2 = std::f64::consts::PI * self.filament_diameter_mm.powi(2) / 4.0;
        self.bead_width_mm * self.layer_height_mm * len_mm / area_mm2
    }

    fn start_lines(&self) -> Vec<String> {
        if let Some(lines) = &self.start_gcode {
            return lines.clone();
        }
        let mut lines = vec!["G28 X Z ; home axial and radial; the mandrel angle needs no homing".into()];
        if let Some(t) = self.mandrel_temp_c {
            lines.push(format!("M190 S{t:.0}"));
        }
        lines.push(format!("M109 S{:.0}", self.nozzle_temp_c));
        lines.extend(["G90".into(), "G21".into()]);
        lines
    }

    fn end_lines(&self, radial_axis: char) -> Vec<String> {
        if let Some(lines) = &self.end_gcode {
            return lines.clone();
        }
        let mut lines = vec!["M104 S0".to_owned()];
        if self.mandrel_temp_c.is_some() {
            lines.push("M140 S0".into());
        }
        lines.extend([
            "G91".into(),
            format!("G1 {radial_axis}5 F600 ; lift off the part"),
            "G90".into(),
            "M84".into(),
        ]);
        lines
    }
}

/// What a written program does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProgramSummary {
    /// Filament pushed, mm.
    pub filament_mm: f64,
    /// Time of the G1 moves as the firmware reads their F, seconds (no acceleration).
    pub print_time_s: f64,
}

/// Writes a program around paths: start G-code, the approach to the first point, then each
/// path; between paths a non-extruding move at travel speed (for a tube, the radial step).
fn write_program<W: Write>(
    machine: &RotaryConfig,
    print: &PrintSettings,
    header: &[String],
    mut next_path: impl FnMut(Option<CylPoint>) -> Option<Result<(String, Vec<CylPoint>)>>,
    mut out: W,
) -> Result<ProgramSummary> {
    machine.validate()?;
    print.validate()?;
    let out: &mut dyn Write = &mut out;
    let mut writer = MoveWriter::new(machine.clone(), print.numbers, print.layer_height_mm / 2.0);
    writer.set_modes(false, print.relative_e);
    for line in header.iter().chain(&print.start_lines()) {
        writeln!(out, "{line}")?;
    }
    writeln!(out, "{}", if print.relative_e { "M83" } else { "M82" })?;
    let mut end = None;
    while let Some(path) = next_path(end) {
        let (label, points) = path?;
        let Some((&first, rest)) = points.split_first() else {
            continue;
        };
        if writer.position().is_none() {
            writer.declare(out, first, [false, true, false])?;
            writeln!(out, "G92 E0")?;
            writer.set_e(0.0);
            writer.approach(out, first, print.travel_speed_mm_s * 60.0)?;
            writer.enter_feed_mode(out)?;
        }
        writeln!(out, "; {label}")?;
        writer.move_to(out, first, 0.0, print.travel_speed_mm_s)?;
        let mut prev = first;
        for &p in rest {
            let e_mm = print.filament_for_mm(surface_length_mm(prev, p));
            writer.move_to(out, p, e_mm, print.print_speed_mm_s)?;
            prev = p;
        }
        end = Some(prev);
    }
    writer.leave_feed_mode(out)?;
    for line in print.end_lines(machine.radial_axis) {
        writeln!(out, "{line}")?;
    }
    out.flush()?;
    Ok(ProgramSummary { filament_mm: writer.filament_mm(), print_time_s: writer.time_s() })
}

/// A complete program printing `paths` in order with one bead (see [`PrintSettings`]).
pub fn write_paths<W: Write>(
    machine: &RotaryConfig,
    print: &PrintSettings,
    paths: &[HelicalPath],
    out: W,
) -> Result<ProgramSummary> {
    let [machine_line, axes_line] = machine.header_lines("paths");
    let header = [format!("{machine_line}, {} helical path(s)", paths.len()), axes_line];
    let mut iter = paths.iter().enumerate();
    let next = |_: Option<CylPoint>| {
        iter.next().map(|(i, path)| Ok((format!("path {i}"), path.points(print.resolution())?)))
    };
    write_program(machine, print, &header, next, out)
}

/// A tube of continuous helical layers (see the module docs). In TOML,
/// `[machine]` is a [`RotaryConfig`] and `[print]` a [`PrintSettings`].
///
/// ```toml
/// length_mm = 50.0         # default 50
/// layers = 4               # default 4
/// pitch_mm = 0.4           # default: the bead width (closed wall)
/// interweave = true        # default true
/// end_turns = 0.5          # flat turns closing each end of a layer, default 0.5
/// axial_start_mm = 0.0     # where the tube starts on the mandrel, default 0
/// [machine]
/// mandrel_diameter_mm = 20.0
/// [print]
/// layer_height_mm = 0.2
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TubeParams {
    /// The machine.
    pub machine: RotaryConfig,
    /// Length of the tube along the mandrel, mm.
    #[serde(default = "default_length")]
    pub length_mm: f64,
    /// Number of layers.
    #[serde(default = "default_layers")]
    pub layers: u32,
    /// Axial advance per turn, mm; `None` = the bead width.
    #[serde(default)]
    pub pitch_mm: Option<f64>,
    /// Reverse the handedness every layer.
    #[serde(default = "default_interweave")]
    pub interweave: bool,
    /// Flat turns at each end of each layer.
    #[serde(default = "default_end_turns")]
    pub end_turns: f64,
    /// Axial position of the tube's start, mm.
    #[serde(default)]
    pub axial_start_mm: f64,
    /// Bead, speeds, temperatures, output.
    #[serde(default)]
    pub print: PrintSettings,
}

fn default_length() -> f64 {
    50.0
}
fn default_layers() -> u32 {
    4
}
fn default_interweave() -> bool {
    true
}
fn default_end_turns() -> f64 {
    0.5
}

impl TubeParams {
    /// A tube on `machine` with every other parameter at its default.
    pub fn new(machine: RotaryConfig) -> Self {
        Self {
            machine,
            length_mm: default_length(),
            layers: default_layers(),
            pitch_mm: None,
            interweave: default_interweave(),
            end_turns: default_end_turns(),
            axial_start_mm: 0.0,
            print: PrintSettings::default(),
        }
    }

    /// Reads and validates a TOML document.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let params: Self = toml::from_str(text)?;
        params.validate()?;
        Ok(params)
    }

    /// Checks every range: the tube must be longer than a bead and the pitch at least a bead.
    pub fn validate(&self) -> Result<()> {
        self.machine.validate()?;
        self.print.validate()?;
        in_range("", "axial_start_mm", self.axial_start_mm, POSITION_MM)?;
        in_range("", "length_mm", self.length_mm, TUBE_LENGTH_MM)?;
        in_range("", "layers", self.layers, TUBE_LAYERS)?;
        in_range("", "end_turns", self.end_turns, END_TURNS)?;
        if let Some(p) = self.pitch_mm {
            in_range("", "pitch_mm", p, PITCH_MM)?;
        }
        if !(self.length_mm.is_finite() && self.length_mm > self.print.bead_width_mm) {
            return Err(RotaryError::Config {
                key: "length_mm",
                reason: format!("must exceed the bead width, got {}", self.length_mm),
            });
        }
        let pitch = self.pitch();
        if !(pitch.is_finite() && pitch >= self.print.bead_width_mm) {
            return Err(RotaryError::Config {
                key: "pitch_mm",
                reason: format!("must be at least the bead width (beads would overlap), got {pitch}"),
            });
        }
        // The whole program, estimated from its outermost layer (the most chords per turn),
        // before a byte is written: each path's own guard alone would let a billion layers by.
        let outer = self.layer_path(self.layers - 1, 0.0);
        if f64::from(self.layers) * outer.estimated_points(self.print.resolution())? > MAX_POINTS as f64 {
            return Err(RotaryError::TooManyPoints { limit: MAX_POINTS });
        }
        Ok(())
    }

    /// The pitch in use, mm.
    pub fn pitch(&self) -> f64 {
        self.pitch_mm.unwrap_or(self.print.bead_width_mm)
    }

    /// Bead centreline radius of layer `k`: `R0 + (k + 1/2) h`, mm.
    pub fn layer_radius_mm(&self, k: u32) -> f64 {
        self.machine.mandrel_radius_mm() + (f64::from(k) + 0.5) * self.print.layer_height_mm
    }

    /// Angular speed on layer `k` at the print speed: `v / sqrt(r_k^2 + (p/2pi)^2)`, deg/s.
    pub fn angular_speed_deg_s(&self, k: u32) -> f64 {
        let lead_mm_rad = self.pitch() / std::f64::consts::TAU;
        (self.print.print_speed_mm_s / self.layer_radius_mm(k).hypot(lead_mm_rad)).to_degrees()
    }

    /// Volume of the tube wall, `pi ((R0 + N h)^2 - R0^2) * length`, mm^3.
    pub fn wall_volume_mm3(&self) -> f64 {
        let r0 = self.machine.mandrel_radius_mm();
        let r1 = r0 + f64::from(self.layers) * self.print.layer_height_mm;
        std::f64::consts::PI * (r1 * r1 - r0 * r0) * self.length_mm
    }

    /// The helix of layer `k`, starting at angle `start_theta_deg` (where layer `k - 1` ended).
    pub fn layer_path(&self, k: u32, start_theta_deg: f64) -> HelicalPath {
        let half_bead = self.print.bead_width_mm / 2.0;
        let low = self.axial_start_mm + half_bead;
        let high = self.axial_start_mm + self.length_mm - half_bead;
        let forward = k & 1 == 0; // even layers run towards +axial
        let (start, end) = if forward { (low, high) } else { (high, low) };
        let handedness = if self.interweave && !forward { Handedness::Left } else { Handedness::Right };
        HelicalPath {
            start_axial_mm: start,
            end_axial_mm: end,
            start_theta_deg,
            handedness,
            pitch_mm: Profile::Constant(self.pitch()),
            radius_mm: Profile::Constant(self.layer_radius_mm(k)),
            lead_in_deg: 360.0 * self.end_turns,
            lead_out_deg: 360.0 * self.end_turns,
        }
    }

    /// The points of every layer, each layer starting at the angle where the previous ended.
    pub fn layer_points(&self) -> Result<Vec<Vec<CylPoint>>> {
        self.validate()?;
        let mut layers = Vec::new();
        let mut theta = 0.0;
        for k in 0..self.layers {
            let points = self.layer_path(k, theta).points(self.print.resolution())?;
            theta = points.last().map_or(theta, |p| p.theta_deg);
            layers.push(points);
        }
        Ok(layers)
    }

    /// Streams the whole program to `out`, one layer in memory at a time.
    pub fn write_gcode<W: Write>(&self, out: W) -> Result<ProgramSummary> {
        self.validate()?;
        let m = &self.machine;
        let p = &self.print;
        let [machine_line, axes_line] = m.header_lines("tube");
        let header = [
            format!(
                "{machine_line}, length {} mm, {} layers of {} x {} mm, pitch {} mm, interweave {}",
                self.length_mm,
                self.layers,
                p.bead_width_mm,
                p.layer_height_mm,
                self.pitch(),
                self.interweave
            ),
            axes_line,
        ];
        let mut k = 0;
        let next = |end: Option<CylPoint>| {
            if k == self.layers {
                return None;
            }
            let theta = end.map_or(0.0, |p| p.theta_deg);
            let label = format!(
                "layer {k} radius {:.3} mm, {:.3} deg/s",
                self.layer_radius_mm(k),
                self.angular_speed_deg_s(k)
            );
            let points = self.layer_path(k, theta).points(p.resolution());
            k += 1;
            Some(points.map(|pts| (label, pts)))
        };
        write_program(m, p, &header, next, out)
    }
}
