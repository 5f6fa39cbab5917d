//! Reading a rotary program back as the machine executes it, and drawing it.
//!
//! [`read_back`] runs machine G-code (any rotary program: a wrapped part, a tube, custom paths)
//! through the core parser and state, turns every move's machine words back into cylinder
//! points ([`RotaryConfig::point_from_words`], the nozzle's position: radius `R0 + radial`) and
//! keeps the extruding ones as [`Bead`]s, each with its layer. It also adds up what the
//! firmware will do: filament, and time as the firmware reads F under the machine's feed
//! convention ([`RotaryConfig::time_from_feed`], no acceleration).
//!
//! [`render`] draws the beads in 3D: each point at `(x, r cos(theta), r sin(theta))`, seen by a
//! [`Camera`], one colour per layer, shaded by how much the cylinder's normal
//! `(0, cos(theta), sin(theta))` faces the eye, the z-buffer hiding what is behind.
//!
//! ```
//! use gweave::rotary::{cylinder::RotaryConfig, helix::TubeParams, preview};
//! let mut tube = TubeParams::new(RotaryConfig::new(10.0));
//! (tube.length_mm, tube.layers, tube.pitch_mm) = (4.0, 2, Some(2.0));
//! let mut gcode = Vec::new();
//! tube.write_gcode(&mut gcode).unwrap();
//! let program = preview::read_back(&tube.machine, gcode.as_slice()).unwrap();
//! assert_eq!(program.layers.len(), 2);
//! // Layer 1's nozzle rides one layer height above layer 0's.
//! assert!((program.layers[1].radius_mm - program.layers[0].radius_mm - 0.2).abs() < 1e-9);
//! let image = preview::render(&program.beads, &preview::PreviewOptions::default());
//! assert_eq!(image.width(), 800);
//! ```

use std::io::{self, Read, Write};

use serde::Serialize;

use super::cylinder::{surface_length_mm, CylPoint, MachineDelta, RotaryConfig};
use super::{Result, RotaryError};
use crate::gcode::layers::Feature;
use crate::gcode::state::{axis_of, Effect, Move, Position, StateOptions, E};
use crate::pass::{drive_reader, Ctx, Flow, Pass, Quiet, Step, Strictness};
use crate::render::camera::Camera;
use crate::render::canvas::Canvas;

/// One extruding move, at the nozzle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bead {
    /// Where the move starts.
    pub from: CylPoint,
    /// Where it ends.
    pub to: CylPoint,
    /// Filament pushed, mm.
    pub e_mm: f64,
    /// Surface speed the firmware runs it at (its F under the machine's feed convention), mm/s.
    pub speed_mm_s: f64,
    /// The feature type the slicer marked (a wrapped slicer file keeps its comments).
    pub feature: Feature,
    /// 0-based layer: the slicer's layer comments if the file has them, else the rank of the
    /// nozzle radius among the radii beads were laid at.
    pub layer: u32,
}

/// What one layer of a program does.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LayerSummary {
    /// 0-based layer index.
    pub index: u32,
    /// Nozzle radius of the layer's first bead, mm.
    pub radius_mm: f64,
    /// Smallest and largest mandrel angle reached by its beads, degrees.
    pub theta_range_deg: [f64; 2],
    /// Smallest and largest axial position of its beads, mm.
    pub axial_range_mm: [f64; 2],
    /// Filament of the layer, mm.
    pub filament_mm: f64,
    /// Number of beads (G1 moves that extrude).
    pub beads: usize,
}

/// A program as the machine runs it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    /// Every extruding move, in order.
    pub beads: Vec<Bead>,
    /// Per-layer figures, by layer index.
    pub layers: Vec<LayerSummary>,
    /// Filament pushed by extruding moves, mm.
    pub filament_mm: f64,
    /// Time of every move as the firmware reads its F, seconds (no acceleration).
    pub time_s: f64,
}

/// How a rotary machine's words read back: which of the core's axes carry the axial, rotary
/// and radial words, and the machine that turns them into nozzle points and times. Shared by
/// [`read_back`] and the preview's toolpath pass ([`crate::render::toolpath`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RotaryReading {
    machine: RotaryConfig,
    axes: [usize; 3],
}

/// One move as the machine runs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotaryMove {
    /// Where the nozzle starts.
    pub from: CylPoint,
    /// Where the nozzle ends.
    pub to: CylPoint,
    /// Filament pushed, mm.
    pub e_mm: f64,
    /// Time the firmware takes at the move's F under the machine's feed convention, s (0 for a
    /// move of nothing or without a feed).
    pub t_s: f64,
    /// Whether any of the three machine words changed.
    pub moved: bool,
}

impl RotaryMove {
    /// An extruding move that goes somewhere: a bead.
    pub fn is_bead(&self) -> bool {
        self.e_mm > 0.0 && self.moved
    }

    /// Surface speed, mm/s (0 when the move takes no time).
    pub fn speed_mm_s(&self) -> f64 {
        if self.t_s > 0.0 {
            surface_length_mm(self.from, self.to) / self.t_s
        } else {
            0.0
        }
    }
}

impl RotaryReading {
    /// The reading of `machine`, whose axis letters must be ones the core tracks (X, Y, Z, A,
    /// B, C).
    pub fn new(machine: &RotaryConfig) -> Result<Self> {
        machine.validate()?;
        let letters = [
            ("axial_axis", machine.axial_axis),
            ("rotary_axis", machine.rotary_axis),
            ("radial_axis", machine.radial_axis),
        ];
        let mut axes = [0; 3];
        for (slot, (key, letter)) in axes.iter_mut().zip(letters) {
            *slot = axis_of(letter as u8).ok_or_else(|| RotaryError::Config {
                key,
                reason: format!("`{letter}` cannot be read back (only X, Y, Z, A, B, C)"),
            })?;
        }
        Ok(Self { machine: machine.clone(), axes })
    }

    /// How the file at `path` reads: on `machine` when given, else on the machine its header
    /// names ([`RotaryConfig::from_file_header`]); `None` for a flat file.
    pub fn for_file(path: &std::path::Path, machine: Option<&RotaryConfig>) -> Result<Option<Self>> {
        match machine.cloned().or_else(|| RotaryConfig::from_file_header(path)) {
            Some(m) => Self::new(&m).map(Some),
            None => Ok(None),
        }
    }

    /// `mv` as the machine runs it.
    pub fn read(&self, mv: &Move) -> RotaryMove {
        let words = |pos: &Position| self.axes.map(|i| pos[i]);
        let (a, b) = (words(&mv.from), words(&mv.to));
        let e_mm = mv.to[E] - mv.from[E];
        let delta = MachineDelta { axial_mm: b[0] - a[0], rotary: b[1] - a[1], radial_mm: b[2] - a[2], e_mm };
        RotaryMove {
            from: self.machine.point_from_words(a, 0.0),
            to: self.machine.point_from_words(b, 0.0),
            e_mm,
            t_s: self.machine.time_from_feed(&delta, mv.feed_mm_min).unwrap_or(0.0),
            moved: a != b,
        }
    }
}

/// The pass behind [`read_back`].
struct Reader {
    reading: RotaryReading,
    beads: Vec<(Bead, Option<u32>)>,
    time_s: f64,
}

impl Pass for Reader {
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        let Effect::Move(mv) = ctx.effect else {
            return Ok(Flow::Continue);
        };
        let m = self.reading.read(mv);
        self.time_s += m.t_s;
        if m.is_bead() {
            let feature = ctx.state.structure.feature;
            let bead =
                Bead { from: m.from, to: m.to, e_mm: m.e_mm, speed_mm_s: m.speed_mm_s(), feature, layer: 0 };
            self.beads.push((bead, ctx.state.structure.commented_layer()));
        }
        Ok(Flow::Continue)
    }
}

/// Reads a rotary program (see the module docs). The machine's axis letters must be ones the
/// core tracks (X, Y, Z, A, B, C).
pub fn read_back(machine: &RotaryConfig, input: impl Read) -> Result<Program> {
    let mut reader = Reader { reading: RotaryReading::new(machine)?, beads: Vec::new(), time_s: 0.0 };
    drive_reader(
        input,
        std::path::Path::new("<rotary program>"),
        StateOptions::default(),
        // A program gweave wrote holds a malformed line only where a lenient wrap copied one
        // through (a strict one refuses it first): it is read past here too.
        Strictness::Lenient,
        &mut Quiet,
        &mut reader,
        &mut io::sink(),
    )?;
    let commented = reader.beads.iter().any(|(_, layer)| layer.is_some());
    let mut radii: Vec<i64> = reader.beads.iter().map(|(b, _)| micron(b.from.radius_mm)).collect();
    radii.sort_unstable();
    radii.dedup();
    let beads: Vec<Bead> = reader
        .beads
        .into_iter()
        .map(|(mut bead, layer)| {
            bead.layer = match (commented, layer) {
                (true, layer) => layer.unwrap_or(0),
                // `radii` holds this radius, so the search finds it; its rank fits a u32 for
                // any program that fits in memory.
                (false, _) => radii.binary_search(&micron(bead.from.radius_mm)).unwrap_or(0) as u32,
            };
            bead
        })
        .collect();
    Ok(Program {
        layers: summarize(&beads),
        filament_mm: beads.iter().map(|b| b.e_mm).sum(),
        time_s: reader.time_s,
        beads,
    })
}

/// A radius in whole microns, to group beads by the radial word (written to 1 micron).
pub(crate) fn micron(mm: f64) -> i64 {
    (mm * 1000.0).round() as i64
}

fn summarize(beads: &[Bead]) -> Vec<LayerSummary> {
    let mut layers: Vec<LayerSummary> = Vec::new();
    for bead in beads {
        let k = bead.layer as usize;
        while layers.len() <= k {
            layers.push(LayerSummary {
                index: layers.len() as u32,
                radius_mm: f64::NAN,
                theta_range_deg: [f64::INFINITY, f64::NEG_INFINITY],
                axial_range_mm: [f64::INFINITY, f64::NEG_INFINITY],
                filament_mm: 0.0,
                beads: 0,
            });
        }
        let layer = &mut layers[k];
        if layer.beads == 0 {
            layer.radius_mm = bead.from.radius_mm;
        }
        for p in [bead.from, bead.to] {
            widen(&mut layer.theta_range_deg, p.theta_deg);
            widen(&mut layer.axial_range_mm, p.axial_mm);
        }
        layer.filament_mm += bead.e_mm;
        layer.beads += 1;
    }
    // Layers without beads (a slicer layer of travel only) are dropped and the rest keep their
    // index.
    layers.retain(|l| l.beads > 0);
    layers
}

fn widen(range: &mut [f64; 2], v: f64) {
    range[0] = range[0].min(v);
    range[1] = range[1].max(v);
}

/// How a preview looks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviewOptions {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Thinnest line, pixels.
    pub line_px: u32,
    /// Bead width, mm: lines are drawn this wide at the image's scale (0 = `line_px` only).
    pub bead_width_mm: f64,
    /// The view (its fit is recomputed to the beads).
    pub camera: Camera,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        Self { width_px: 800, height_px: 600, line_px: 1, bead_width_mm: 0.4, camera: Camera::isometric() }
    }
}

/// Layer colours, cycled: distinct hues that stay apart when shaded.
const PALETTE: [[u8; 3]; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [23, 190, 207],
];

/// The colour of layer `layer` on a surface whose normal makes cosine `facing` with the eye:
/// 35 % ambient plus 65 % diffuse.
pub fn layer_colour(layer: u32, facing: f64) -> [u8; 3] {
    let base = PALETTE[layer as usize % PALETTE.len()];
    let light = 0.35 + 0.65 * facing.clamp(0.0, 1.0);
    base.map(|c| (f64::from(c) * light).round() as u8)
}

/// Draws beads in 3D (see the module docs) on a white image.
pub fn render(beads: &[Bead], options: &PreviewOptions) -> Canvas {
    let points = beads.iter().flat_map(|b| [b.from.to_cartesian(), b.to.to_cartesian()]);
    let camera = options.camera.fitted(points, options.width_px, options.height_px, 12.0);
    let mut canvas = Canvas::new(options.width_px, options.height_px, [255, 255, 255]);
    // A bead spans its width at any angle; the float-to-int cast saturates on wild values.
    let bead_px = (options.bead_width_mm * camera.scale_px_mm()).round() as u32;
    let width_px = options.line_px.max(bead_px);
    for bead in beads {
        let mid_deg = 0.5 * (bead.from.theta_deg + bead.to.theta_deg);
        let (sin, cos) = mid_deg.to_radians().sin_cos();
        let colour = layer_colour(bead.layer, camera.facing([0.0, cos, sin]));
        let (a, b) = (camera.project(bead.from.to_cartesian()), camera.project(bead.to.to_cartesian()));
        canvas.line(a, b, colour, width_px);
    }
    canvas
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_words_back_into_layers_time_and_filament() {
        let machine = RotaryConfig::new(20.0);
        // Two layers by radius (no layer comments); F is the axial speed (NIST): 10 mm at
        // 600 mm/min is 1 s, the rotary-only move 90 deg at 900 deg/min 6 s.
        let text = "G92 A0\nG1 Z0.2 F600\nG1 X10 A90 E1 F600\nG1 A180 E1.5 F900\n\
                    G1 Z0.4\nG1 X0 A360 E2.5 F600\n";
        let p = read_back(&machine, text.as_bytes()).unwrap();
        assert_eq!(p.beads.len(), 3, "{:?}", p.beads);
        assert_eq!(p.beads.iter().map(|b| b.layer).collect::<Vec<_>>(), [0, 0, 1]);
        assert_eq!(p.beads[0].to, CylPoint::new(10.0, 90.0, 10.2));
        // 1 s for the first bead: its surface length per second.
        let surface = surface_length_mm(p.beads[0].from, p.beads[0].to);
        assert!((p.beads[0].speed_mm_s - surface).abs() < 1e-9, "{}", p.beads[0].speed_mm_s);
        assert!((p.filament_mm - 2.5).abs() < 1e-12);
        // Z0.2 at F600 (0.02 s) + 1 s + 6 s + Z0.4 at the modal F900 (0.0133 s) + 1 s.
        assert!((p.time_s - (8.02 + 0.2 / 15.0)).abs() < 1e-9, "{}", p.time_s);
        assert_eq!(p.layers.len(), 2);
        assert_eq!(p.layers[0].theta_range_deg, [0.0, 180.0]);
        assert_eq!(p.layers[1].axial_range_mm, [0.0, 10.0]);
        assert!((p.layers[1].radius_mm - 10.4).abs() < 1e-12);
        assert!((p.layers[0].filament_mm - 1.5).abs() < 1e-12);
    }

    #[test]
    fn slicer_layer_comments_win_and_unreadable_axes_are_errors() {
        let machine = RotaryConfig::new(20.0);
        let text = ";LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\nG1 X5 E1\nG1 Z0.6\nG1 X0 E2\n";
        let p = read_back(&machine, text.as_bytes()).unwrap();
        // One commented layer even though the radius changed inside it.
        assert_eq!(p.layers.len(), 1);
        assert_eq!(p.layers[0].beads, 2);
        let mut odd = machine.clone();
        odd.rotary_axis = 'U';
        let err = read_back(&odd, text.as_bytes()).unwrap_err();
        assert!(matches!(err, RotaryError::Config { key: "rotary_axis", .. }), "{err}");
    }

    #[test]
    fn preview_colours_layers_and_hides_the_back() {
        let machine = RotaryConfig::new(20.0);
        // One flat turn at r = 10.2, seen from the top: the front (theta = 90, facing the
        // eye) and the back (theta = 270) land on the same pixels; the front hides the back.
        let mut text = String::from("G92 A0\nG1 Z0.2 F600\n");
        for i in 1..=72 {
            text.push_str(&format!("G1 A{} E{i} F600\n", i * 5));
        }
        let p = read_back(&machine, text.as_bytes()).unwrap();
        let options = PreviewOptions {
            width_px: 100,
            height_px: 100,
            line_px: 1,
            bead_width_mm: 0.0,
            camera: Camera::top(),
        };
        let image = render(&p.beads, &options);
        let lit = layer_colour(0, 1.0);
        assert_eq!(lit, PALETTE[0]);
        // The top of the ring projects onto the image's middle row; its nearest part is lit.
        let row: Vec<[u8; 3]> = (0..100).filter_map(|x| image.pixel(x, 50)).collect();
        assert!(row.contains(&lit), "{row:?}");
        assert!(!row.contains(&layer_colour(0, -1.0)), "{row:?}");
        assert_eq!(layer_colour(9, -1.0), [89, 44, 5]);
    }
}
