//! Reading a rotary program back as the machine executes it.
//!
//! [`RotaryReading`] turns a move's machine words back into cylinder points
//! ([`RotaryConfig::point_from_words`], the nozzle's position: radius `R0 + radial`) and times it
//! as the firmware reads F under the machine's feed convention ([`RotaryConfig::time_from_feed`],
//! no acceleration). Two passes read with it: the toolpath pass draws the program on its cylinder
//! (`crate::render::toolpath`, the preview of `gweave preview` and of `rotary --preview`), and
//! [`ProgramPass`] adds up what the program does for the rotary reports: filament, time and per
//! layer the radius, the angles and axial positions swept. Both number the layers alike: the
//! slicer's layer comments when a wrapped file has them, else the rank of the nozzle radius among
//! the radii beads were laid at, from the mandrel out.
//!
//! ```
//! use gweave::Run;
//! use gweave::rotary::{cylinder::RotaryConfig, helix::TubeParams, preview};
//! let mut tube = TubeParams::new(RotaryConfig::new(10.0));
//! (tube.length_mm, tube.layers, tube.pitch_mm) = (4.0, 2, Some(2.0));
//! let mut gcode = Vec::new();
//! tube.write_gcode(&mut gcode).unwrap();
//! let mut pass = preview::ProgramPass::new(preview::RotaryReading::new(&tube.machine).unwrap());
//! Run::text(&gcode).scan(&mut pass).unwrap();
//! let program = pass.finish();
//! assert_eq!(program.layers.len(), 2);
//! // Layer 1's nozzle rides one layer height above layer 0's.
//! assert!((program.layers[1].radius_mm - program.layers[0].radius_mm - 0.2).abs() < 1e-9);
//! ```

use std::collections::HashMap;
use std::io::Write;

use serde::Serialize;

use super::cylinder::{surface_length_mm, CylPoint, MachineDelta, RotaryConfig};
use super::{Result, RotaryError};
use crate::gcode::state::{axis_of, Effect, Move, Position, E};
use crate::pass::{Ctx, Flow, Pass, Step};

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

/// What a program does as the machine runs it ([`ProgramPass`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    /// Per-layer figures, by layer index.
    pub layers: Vec<LayerSummary>,
    /// Filament pushed by extruding moves, mm.
    pub filament_mm: f64,
    /// Time of every move as the firmware reads its F, seconds (no acceleration).
    pub time_s: f64,
    /// Extruding moves that go somewhere (beads).
    pub beads: usize,
}

/// How a rotary machine's words read back: which of the core's axes carry the axial, rotary
/// and radial words, and the machine that turns them into nozzle points and times.
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

    /// The diameter of the mandrel the program is read on, mm.
    pub fn mandrel_diameter_mm(&self) -> f64 {
        self.machine.mandrel_diameter_mm
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

/// What a program does, added up as it streams by (see the module docs): per-layer figures,
/// filament, time and beads, in one pass that keeps no bead. The layers are numbered as the
/// toolpath pass numbers them for the preview (`crate::render::toolpath`), so that one read of
/// a file can feed both.
#[derive(Clone, Debug)]
pub struct ProgramPass {
    reading: RotaryReading,
    /// Layers by bead radius (whole microns), for a file without layer comments.
    by_radius: HashMap<i64, LayerSummary>,
    /// Layers by the slicer's comments, once a bead had one: beads without a comment (a purge
    /// line before the first layer) go to layer 0.
    commented: Vec<LayerSummary>,
    /// The beads before the first commented one, as one layer: layer 0 if a comment follows.
    uncommented: LayerSummary,
    filament_mm: f64,
    time_s: f64,
    beads: usize,
}

impl ProgramPass {
    /// Adds up a program read on `reading`'s machine.
    pub fn new(reading: RotaryReading) -> Self {
        Self {
            reading,
            by_radius: HashMap::new(),
            commented: Vec::new(),
            uncommented: LayerSummary::empty(0),
            filament_mm: 0.0,
            time_s: 0.0,
            beads: 0,
        }
    }

    /// What the program does, once the whole file went by.
    pub fn finish(self) -> Program {
        let layers = if self.commented.is_empty() {
            let mut layers: Vec<LayerSummary> = self.by_radius.into_values().collect();
            layers.sort_unstable_by_key(|l| micron(l.radius_mm));
            for (rank, layer) in layers.iter_mut().enumerate() {
                // Ranks fit a u32 for any program that fits in memory.
                layer.index = rank as u32;
            }
            layers
        } else {
            // Layers without beads (a slicer layer of travel only) are dropped and the rest keep
            // their index.
            self.commented.into_iter().filter(|l| l.beads > 0).collect()
        };
        Program { layers, filament_mm: self.filament_mm, time_s: self.time_s, beads: self.beads }
    }

    fn bead(&mut self, m: &RotaryMove, commented: Option<u32>) {
        self.filament_mm += m.e_mm;
        self.beads += 1;
        let layer = match commented {
            Some(k) => {
                if self.commented.is_empty() {
                    self.commented.push(std::mem::replace(&mut self.uncommented, LayerSummary::empty(0)));
                }
                let k = k as usize;
                while self.commented.len() <= k {
                    self.commented.push(LayerSummary::empty(self.commented.len() as u32));
                }
                &mut self.commented[k]
            }
            None if !self.commented.is_empty() => &mut self.commented[0],
            None => {
                self.uncommented.add(m);
                let um = micron(m.from.radius_mm);
                self.by_radius.entry(um).or_insert_with(|| LayerSummary::empty(0))
            }
        };
        layer.add(m);
    }
}

impl Pass for ProgramPass {
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        let Effect::Move(mv) = ctx.effect else {
            return Ok(Flow::Continue);
        };
        let m = self.reading.read(mv);
        self.time_s += m.t_s;
        if m.is_bead() {
            self.bead(&m, ctx.state.structure.commented_layer());
        }
        Ok(Flow::Continue)
    }
}

/// A radius in whole microns, to group beads by the radial word (written to 1 micron).
pub(crate) fn micron(mm: f64) -> i64 {
    (mm * 1000.0).round() as i64
}

impl LayerSummary {
    /// Layer `index` before its first bead.
    fn empty(index: u32) -> Self {
        Self {
            index,
            radius_mm: f64::NAN,
            theta_range_deg: [f64::INFINITY, f64::NEG_INFINITY],
            axial_range_mm: [f64::INFINITY, f64::NEG_INFINITY],
            filament_mm: 0.0,
            beads: 0,
        }
    }

    /// Adds bead `m`.
    fn add(&mut self, m: &RotaryMove) {
        if self.beads == 0 {
            self.radius_mm = m.from.radius_mm;
        }
        for p in [m.from, m.to] {
            widen(&mut self.theta_range_deg, p.theta_deg);
            widen(&mut self.axial_range_mm, p.axial_mm);
        }
        self.filament_mm += m.e_mm;
        self.beads += 1;
    }
}

fn widen(range: &mut [f64; 2], v: f64) {
    range[0] = range[0].min(v);
    range[1] = range[1].max(v);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::state::{Path as MovePath, A, AXES, X, Z};

    fn read_back(machine: &RotaryConfig, text: &str) -> Result<Program> {
        let mut pass = ProgramPass::new(RotaryReading::new(machine)?);
        crate::run::Run::text(text.as_bytes()).scan(&mut pass)?;
        Ok(pass.finish())
    }

    #[test]
    fn reads_words_back_into_layers_time_and_filament() {
        let machine = RotaryConfig::new(20.0);
        // Two layers by radius (no layer comments); F is the axial speed (NIST): 10 mm at
        // 600 mm/min is 1 s, the rotary-only move 90 deg at 900 deg/min 6 s.
        let text = "G92 A0\nG1 Z0.2 F600\nG1 X10 A90 E1 F600\nG1 A180 E1.5 F900\n\
                    G1 Z0.4\nG1 X0 A360 E2.5 F600\n";
        let p = read_back(&machine, text).unwrap();
        assert_eq!(p.beads, 3);
        assert!((p.filament_mm - 2.5).abs() < 1e-12);
        // Z0.2 at F600 (0.02 s) + 1 s + 6 s + Z0.4 at the modal F900 (0.0133 s) + 1 s.
        assert!((p.time_s - (8.02 + 0.2 / 15.0)).abs() < 1e-9, "{}", p.time_s);
        assert_eq!(p.layers.len(), 2);
        assert_eq!(p.layers.iter().map(|l| (l.index, l.beads)).collect::<Vec<_>>(), [(0, 2), (1, 1)]);
        assert_eq!(p.layers[0].theta_range_deg, [0.0, 180.0]);
        assert_eq!(p.layers[0].axial_range_mm, [0.0, 10.0]);
        assert_eq!(p.layers[1].axial_range_mm, [0.0, 10.0]);
        assert!((p.layers[1].radius_mm - 10.4).abs() < 1e-12);
        assert!((p.layers[0].filament_mm - 1.5).abs() < 1e-12);
    }

    #[test]
    fn a_move_reads_back_as_its_nozzle_points_and_surface_speed() {
        let reading = RotaryReading::new(&RotaryConfig::new(20.0)).unwrap();
        let mut pass = ProgramPass::new(reading.clone());
        let text = "G92 A0\nG1 Z0.2 F600\nG1 X10 A90 E1 F600\n";
        crate::run::Run::text(text.as_bytes()).scan(&mut pass).unwrap();
        let layer = pass.finish().layers[0];
        assert_eq!((layer.theta_range_deg, layer.axial_range_mm), ([0.0, 90.0], [0.0, 10.0]));
        let mut from = [0.0; AXES];
        from[Z] = 0.2;
        let mut to = from;
        (to[X], to[A], to[E]) = (10.0, 90.0, 1.0);
        let mv = Move { from, to, path: MovePath::Line, rapid: false, feed_mm_min: 600.0 };
        let m = reading.read(&mv);
        assert!(m.is_bead());
        assert_eq!(m.to, CylPoint::new(10.0, 90.0, 10.2));
        // 1 s for the move: its surface length per second.
        assert!((m.t_s - 1.0).abs() < 1e-12, "{}", m.t_s);
        assert!((m.speed_mm_s() - surface_length_mm(m.from, m.to)).abs() < 1e-9);
    }

    #[test]
    fn slicer_layer_comments_win_and_unreadable_axes_are_errors() {
        let machine = RotaryConfig::new(20.0);
        // A purge bead before the first comment goes to layer 0, which it opens.
        let text = "G1 Z0.3 F600\nG1 X-5 E0.5\n;LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\nG1 X5 E1\n\
                    G1 Z0.6\nG1 X0 E2\n;LAYER_CHANGE\n;LAYER_CHANGE\nG1 X3 E3\n";
        let p = read_back(&machine, text).unwrap();
        // Commented layers even though the radius changed inside one; the empty one is dropped.
        assert_eq!(p.layers.iter().map(|l| (l.index, l.beads)).collect::<Vec<_>>(), [(0, 3), (2, 1)]);
        assert!((p.layers[0].radius_mm - 10.3).abs() < 1e-12, "{}", p.layers[0].radius_mm);
        assert_eq!(p.layers[0].axial_range_mm, [-5.0, 5.0]);
        assert!((p.layers[0].filament_mm - 2.0).abs() < 1e-12);
        let mut odd = machine.clone();
        odd.rotary_axis = 'U';
        let err = read_back(&odd, text).unwrap_err();
        assert!(matches!(err, RotaryError::Config { key: "rotary_axis", .. }), "{err}");
    }
}
