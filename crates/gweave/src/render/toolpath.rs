//! The segments a file draws, collected in one streaming pass with the core machine state.
//!
//! Every move becomes one or more straight [`Segment`]s in absolute millimetres: lines as they
//! are, G2/G3 arcs split into chords within [`ToolpathOptions::arc_tol_mm`] of the true arc (see
//! [`crate::gcode::arc`] for the chord count). Each segment carries what a preview colours by:
//! the tool, the feature type the slicer marked, the feed rate, the layer and whether it extrudes.
//!
//! Inkjet raster output (`gweave raster`): each fire command `M700 P<head> S<bits>` (or the
//! profile's `M578`) is a set of drops, where [`PrintheadProfile::drops_mm`] puts them with the
//! carriage where it is; each drop becomes an extruding segment one nozzle pitch long along X,
//! centred on it, with the head as its tool. Neighbouring drops then close up into the area
//! they wet, as the binder does in the powder.
//!
//! Rotary programs ([`ToolpathOptions::rotary`]): each move's machine words are read back as
//! the nozzle's points on the cylinder and the segment is the chord between them, in 3D with the
//! mandrel along X; its speed is the surface speed the firmware runs at. Layers are the slicer's
//! comments when a wrapped file has them, else the bead radii ranked from the mandrel out
//! (`cylinder`).
//!
//! Huge files: memory is bounded by keeping only the layers asked for, and by decimation. With
//! `min_len_mm > 0`, consecutive chained moves that agree on every attribute are merged until the
//! merged piece is at least that long. The merged piece is the chord from the first start to the
//! last end, so no drawn point is further than `min_len_mm` from the true path; choose it below
//! the size of a pixel and the picture does not change. A 230 MB file has ~8 M moves, 36 bytes
//! each kept: merging to 0.2 mm typically keeps a fifth of them. Denser files (gyroid infill)
//! keep more, so pictures also set [`ToolpathOptions::max_segments`]: when the toolpath reaches
//! it, the merge length doubles and the segments kept so far are merged again, as often as
//! needed. Memory then has a ceiling whatever the file's size, and the picture loses only detail
//! finer than the final merge length (the pass's `options.min_len_mm` at the end). Moves that
//! never chain (travel and extrusion taking turns) cannot merge: then every second segment of
//! each kind is dropped instead, as often as needed ([`ToolpathPass::thinning`]), so the ceiling
//! holds for any file.

use std::io::Write;
use std::ops::RangeInclusive;
use std::path::Path;

use crate::gcode::layers::{Feature, Region, Structure};
use crate::gcode::state::{Effect, Move, Path as MovePath, E, X, Y, Z};
use crate::gen::printhead::PrintheadProfile;
use crate::pass::{Ctx, Flow, Pass, Step};
use crate::rotary::cylinder::CylPoint;
use crate::rotary::preview::{RotaryMove, RotaryReading};
use crate::run::Run;

use super::mix_colour::{MixColours, MixTracker};
use cylinder::{CylinderLayers, PROVISIONAL};

mod cylinder;

/// One straight piece of tool path, mm and mm/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Where the move starts, mm.
    pub start: [f32; 3],
    /// Where it ends, mm.
    pub end: [f32; 3],
    /// The tool that moved.
    pub tool: u16,
    /// The feature printed.
    pub feature: Feature,
    /// Feed rate, mm/s.
    pub feed_mm_s: f32,
    /// 0-based layer (0 for moves before the first layer marker).
    pub layer: u32,
    /// Deposits material (not travel or retraction).
    pub extruding: bool,
    /// Predicted printed colour (sRGB), when the toolpath was read with
    /// [`ToolpathOptions::mix`]; black otherwise.
    pub mix_rgb: [u8; 3],
}

impl Segment {
    /// XYZ length, mm.
    pub fn len_mm(&self) -> f32 {
        let d = [self.end[0] - self.start[0], self.end[1] - self.start[1], self.end[2] - self.start[2]];
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    }

    /// Same attributes: may be merged or drawn in one run.
    fn same_kind(&self, o: &Segment) -> bool {
        self.tool == o.tool
            && self.feature == o.feature
            && self.feed_mm_s == o.feed_mm_s
            && self.layer == o.layer
            && self.extruding == o.extruding
            && self.mix_rgb == o.mix_rgb
    }
}

/// What to collect.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolpathOptions {
    /// Only these layers (all when `None`).
    pub layers: Option<RangeInclusive<u32>>,
    /// Keep travel moves (non-extruding) too.
    pub travel: bool,
    /// Leave out the start G-code (purge lines before the first layer).
    pub print_only: bool,
    /// Merge chained moves shorter than this, mm (0: keep every move).
    pub min_len_mm: f32,
    /// Keep at most this many segments: past it the merge length doubles (see the module notes).
    pub max_segments: Option<usize>,
    /// Largest distance of an arc's chords from the arc, mm.
    pub arc_tol_mm: f64,
    /// Predict each move's printed colour with this mixing hardware ([`Segment::mix_rgb`]).
    pub mix: Option<MixColours>,
    /// The inkjet head whose fire commands (`M700`/`M578 P<head> S<bits>`, binder-jet raster
    /// output) are drawn as dots (see the module notes).
    pub printhead: PrintheadProfile,
    /// Read the file as a rotary program on this machine (see the module notes).
    pub rotary: Option<RotaryReading>,
}

impl Default for ToolpathOptions {
    fn default() -> Self {
        ToolpathOptions {
            layers: None,
            travel: true,
            print_only: true,
            min_len_mm: 0.0,
            max_segments: None,
            arc_tol_mm: 0.02,
            mix: None,
            printhead: PrintheadProfile::default(),
            rotary: None,
        }
    }
}

impl ToolpathOptions {
    /// A decimation length for a file of `bytes`: none below 32 MB, 0.2 mm above (well under a
    /// pixel of a 1200 px picture of a 250 mm bed, 0.21 mm/px).
    pub fn min_len_for_file_size(bytes: u64) -> f32 {
        if bytes > 32 << 20 {
            0.2
        } else {
            0.0
        }
    }
}

/// Everything collected from one file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Toolpath {
    /// The moves, in file order.
    pub segments: Vec<Segment>,
    /// Z of each layer as the slicer states it, mm (index = layer; layers not kept included).
    pub layer_z_mm: Vec<f32>,
    /// Number of tools the file selected (highest `T` + 1, at least 1).
    pub tools: u16,
    /// A rotary program: the segments lie on cylinders about the X axis (see
    /// [`ToolpathOptions::rotary`]).
    pub on_cylinder: bool,
    /// A name for each predicted mix colour ([`Segment::mix_rgb`]) the file printed: the name
    /// `gweave mix` gave the mix, else the palette's name of its ratios, else the ratios
    /// (`0.25:0.25:0.5:0`). For legends.
    pub mix_names: std::collections::BTreeMap<[u8; 3], String>,
    /// Read with the mix colouring, the file has mixing commands (M163-M165, M567).
    pub mixing: bool,
    /// Binder-jet raster output: the tools are the inkjet heads that fired.
    pub heads: bool,
}

impl Toolpath {
    /// Reads a file.
    pub fn from_file(path: &Path, options: ToolpathOptions) -> crate::Result<Toolpath> {
        let mut pass = ToolpathPass::new(options);
        Run::file(path).scan(&mut pass)?;
        Ok(pass.finish_toolpath())
    }

    /// Number of layers the file has (kept or not).
    pub fn layer_count(&self) -> u32 {
        self.layer_z_mm.len() as u32
    }

    /// Bounding box of the extruding segments (all segments if none extrude), or `None` if empty.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let mut it = self.segments.iter().filter(|s| s.extruding).peekable();
        let any_extruding = it.peek().is_some();
        let all: Box<dyn Iterator<Item = &Segment>> =
            if any_extruding { Box::new(it) } else { Box::new(self.segments.iter()) };
        let mut b: Option<([f32; 3], [f32; 3])> = None;
        for s in all {
            for p in [s.start, s.end] {
                let (lo, hi) = b.get_or_insert((p, p));
                for i in 0..3 {
                    lo[i] = lo[i].min(p[i]);
                    hi[i] = hi[i].max(p[i]);
                }
            }
        }
        b
    }
}

/// The pass that collects a [`Toolpath`].
#[derive(Debug)]
pub(crate) struct ToolpathPass {
    options: ToolpathOptions,
    out: Toolpath,
    /// A merged piece still growing (decimation).
    pending: Option<Segment>,
    mix: Option<MixTracker>,
    cylinder: CylinderLayers,
    /// How many segments of each kind stand for one kept (1: none dropped), once merging could
    /// not keep the toolpath under [`ToolpathOptions::max_segments`].
    thinning: u64,
    /// Segments of each kind (travel, extruding) offered since thinning began.
    thinning_seen: [u64; 2],
    /// The layer whose Z the drops of a fire command gave (see [`Self::fire`]).
    fired_layer: Option<u32>,
}

impl ToolpathPass {
    /// A pass collecting the toolpath with `options`.
    pub(crate) fn new(options: ToolpathOptions) -> Self {
        let mix = options.mix.clone().map(MixTracker::new);
        let out = Toolpath { tools: 1, ..Toolpath::default() };
        ToolpathPass {
            options,
            out,
            pending: None,
            mix,
            cylinder: CylinderLayers::default(),
            thinning: 1,
            thinning_seen: [0; 2],
            fired_layer: None,
        }
    }

    /// The collected toolpath.
    pub(crate) fn finish_toolpath(mut self) -> Toolpath {
        self.flush();
        if self.options.rotary.is_some() {
            self.out.layer_z_mm = self.cylinder.finish(&mut self.out.segments, self.options.layers.as_ref());
            self.out.on_cylinder = true;
        }
        if let Some(mix) = self.mix.take() {
            self.out.mixing = mix.mixing;
            self.out.mix_names = mix.into_names();
        }
        self.out
    }

    fn flush(&mut self) {
        if let Some(p) = self.pending.take() {
            self.keep(p);
        }
    }

    fn keep(&mut self, s: Segment) {
        if self.thinned_out(&s) {
            return;
        }
        self.out.segments.push(s);
        if self.options.max_segments.is_some_and(|max| self.out.segments.len() >= max) {
            self.coarsen();
        }
    }

    /// Doubles the merge length and merges the segments kept so far again, with the rule of
    /// [`Self::push`], until at most three quarters of the ceiling are used. When merging cannot
    /// make the room even at an unbounded length (too few segments chain onto one of their kind,
    /// as when travel and extrusion take turns), every second segment of each kind is dropped
    /// instead, from now on too ([`ToolpathPass::thinning`]). Each round halves, or merges with a
    /// doubled length (and an infinite length merges every chain), so the loop ends whatever the
    /// file holds.
    fn coarsen(&mut self) {
        let max = self.options.max_segments.unwrap_or(usize::MAX).max(4);
        let target = max / 4 * 3;
        while self.out.segments.len() > target {
            let segments = &self.out.segments;
            // Merging at any length removes one segment per chained pair, and no more.
            let chained =
                segments.windows(2).filter(|w| w[0].same_kind(&w[1]) && w[0].end == w[1].start).count();
            if segments.len() - chained > target {
                self.thin();
            } else {
                // 0.05 mm: the first step when the file was read without merging.
                self.merge_again((self.options.min_len_mm * 2.0).max(0.05));
            }
        }
    }

    /// Merges the segments kept so far again with merge length `min_len`.
    fn merge_again(&mut self, min_len: f32) {
        self.options.min_len_mm = min_len;
        let segments = &mut self.out.segments;
        let mut kept = 0;
        for i in 0..segments.len() {
            let s = segments[i];
            if kept > 0 {
                let p = &mut segments[kept - 1];
                if p.same_kind(&s) && p.end == s.start && p.len_mm() < min_len {
                    p.end = s.end;
                    continue;
                }
            }
            segments[kept] = s;
            kept += 1;
        }
        segments.truncate(kept);
    }

    /// Doubles the thinning: keeps every second segment of each kind (extruding or not, so that
    /// alternating travel and extrusion keep both) of those kept so far, and of those to come.
    fn thin(&mut self) {
        self.thinning *= 2;
        let mut seen = [0u64; 2];
        self.out.segments.retain(|s| {
            let n = &mut seen[usize::from(s.extruding)];
            *n += 1;
            *n % 2 == 1
        });
    }

    /// Thinning for a segment about to be kept: only every `thinning`-th of its kind is.
    fn thinned_out(&mut self, s: &Segment) -> bool {
        if self.thinning == 1 {
            return false;
        }
        let n = &mut self.thinning_seen[usize::from(s.extruding)];
        *n += 1;
        *n % self.thinning != 1
    }

    fn push(&mut self, s: Segment) {
        if self.options.min_len_mm <= 0.0 {
            self.keep(s);
            return;
        }
        match &mut self.pending {
            Some(p) if p.same_kind(&s) && p.end == s.start && p.len_mm() < self.options.min_len_mm => {
                p.end = s.end;
            }
            _ => {
                self.flush();
                self.pending = Some(s);
            }
        }
    }

    fn add_move(&mut self, m: &Move, template: Segment) {
        let point = |p: [f64; 2], z: f64| [p[0] as f32, p[1] as f32, z as f32];
        match &m.path {
            MovePath::Line => self.push(Segment {
                start: point([m.from[X], m.from[Y]], m.from[Z]),
                end: point([m.to[X], m.to[Y]], m.to[Z]),
                ..template
            }),
            MovePath::Arc(arc) => {
                let n = arc.segments(self.options.arc_tol_mm);
                let mut prev = point([m.from[X], m.from[Y]], m.from[Z]);
                for i in 1..=n {
                    let t = i as f64 / n as f64;
                    // The end point exactly, not as computed from the angle.
                    let xy = if i == n { [m.to[X], m.to[Y]] } else { arc.point(t) };
                    let next = point(xy, m.from[Z] + (m.to[Z] - m.from[Z]) * t);
                    self.push(Segment { start: prev, end: next, ..template });
                    prev = next;
                }
            }
        }
    }
}

impl ToolpathPass {
    /// A move of a rotary program: the chord between the nozzle's points on the cylinder (a
    /// bead is a short helix). Nothing is left out as start G-code: a wrapped purge line is
    /// printed on the mandrel too.
    fn cylinder_move(&mut self, m: &RotaryMove, st: &Structure, tool: u16, mix_rgb: [u8; 3]) {
        let extruding = m.is_bead();
        if !m.moved || (!extruding && !self.options.travel) {
            return;
        }
        let layer = self.cylinder.layer(st.commented_layer(), m);
        let ranked = layer & PROVISIONAL == 0;
        if ranked && self.options.layers.as_ref().is_some_and(|r| !r.contains(&layer)) {
            return;
        }
        let point = |p: CylPoint| p.to_cartesian().map(|v| v as f32);
        let (start, end, feed_mm_s) = (point(m.from), point(m.to), m.speed_mm_s() as f32);
        self.push(Segment { start, end, tool, feature: st.feature, feed_mm_s, layer, extruding, mix_rgb });
    }

    /// A fire command of an inkjet head: its drops as dots.
    fn fire(&mut self, ctx: &Ctx<'_>) {
        let st = &ctx.state.structure;
        let layer = st.layer.unwrap_or(0);
        let skipped = self.options.print_only && st.region == Region::Start;
        if skipped || self.options.layers.as_ref().is_some_and(|r| !r.contains(&layer)) {
            return;
        }
        let word = |l: u8| ctx.block.word(l).and_then(|w| w.number());
        // The firmware reads S only with P (`sjkelly/Marlin` branch hpc6602, `Marlin_main.cpp`).
        let (Some(head), Some(bits)) = (word(b'P'), word(b'S')) else { return };
        if !(head >= 0.0 && bits >= 0.0 && head < 64.0 && bits < u64::MAX as f64) {
            return;
        }
        let head = head as usize;
        let pos = &ctx.state.pos;
        let half = (self.options.printhead.pitch_mm() / 2.0) as f32;
        let z = pos[Z] as f32;
        // A raster layer states no Z in a comment and never extrudes, so the core's layer Z
        // (stated, or taken at the first extrusion) stays unknown: the drops are the layer's
        // deposit, and their Z is the layer's.
        if let Some(layer_z) = self.out.layer_z_mm.get_mut(layer as usize) {
            *layer_z = z;
            self.fired_layer = Some(layer);
        }
        for [x, y] in self.options.printhead.drops_mm(head, bits as u64, [pos[X], pos[Y]]) {
            let (x, y) = (x as f32, y as f32);
            self.out.tools = self.out.tools.max(head as u16 + 1);
            self.out.heads = true;
            self.push(Segment {
                start: [x - half, y, z],
                end: [x + half, y, z],
                tool: head as u16,
                feature: Feature::Unknown,
                feed_mm_s: 0.0,
                layer,
                extruding: true,
                mix_rgb: [0; 3],
            });
        }
    }
}

impl Pass for ToolpathPass {
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        let st = &ctx.state.structure;
        if let Some(layer) = st.layer {
            let n = layer as usize + 1;
            if self.out.layer_z_mm.len() < n {
                self.out.layer_z_mm.resize(n, st.layer_z_mm as f32);
            }
            // The slicer may state Z after the marker (`;Z:`) or at the first extrusion; a
            // raster layer's Z is its drops' (`fire`).
            if self.fired_layer != Some(layer) {
                self.out.layer_z_mm[layer as usize] = st.layer_z_mm as f32;
            }
        }
        if let Some(mix) = &mut self.mix {
            mix.line(ctx.line.bytes, ctx.block, ctx.state.tool);
        }
        if ctx.block.command.is_m(self.options.printhead.fire_code()) {
            self.fire(ctx);
        }
        match ctx.effect {
            Effect::ToolChange { to, .. } => {
                self.out.tools = self.out.tools.max((*to).min(u16::MAX as u32 - 1) as u16 + 1);
            }
            Effect::Move(m) => {
                // Every extrusion of the print washes the mixing chamber, drawn or not (the start
                // G-code's primes are taken to load the first colour, see `mix_colour`).
                let mix_rgb = match &mut self.mix {
                    Some(mix) if m.to[E] > m.from[E] && st.region != Region::Start => {
                        let c = mix.extrude(m.to[E] - m.from[E]);
                        [c.r, c.g, c.b]
                    }
                    _ => [0; 3],
                };
                let tool = ctx.state.tool.min(u16::MAX as u32) as u16;
                if let Some(m) = self.options.rotary.as_ref().map(|r| r.read(m)) {
                    self.cylinder_move(&m, st, tool, mix_rgb);
                    return Ok(Flow::Continue);
                }
                // Only the start G-code (purge lines) is left out: the end G-code's parking is
                // travel, drawn only on request, and any extrusion there is really printed.
                if self.options.print_only && st.region == Region::Start {
                    return Ok(Flow::Continue);
                }
                let layer = st.layer.unwrap_or(0);
                if let Some(r) = &self.options.layers {
                    if !r.contains(&layer) {
                        return Ok(Flow::Continue);
                    }
                }
                let extruding = m.is_extruding();
                if !extruding && !self.options.travel {
                    return Ok(Flow::Continue);
                }
                if m.to[X] == m.from[X] && m.to[Y] == m.from[Y] && m.to[Z] == m.from[Z] {
                    return Ok(Flow::Continue);
                }
                let template = Segment {
                    start: [0.0; 3],
                    end: [0.0; 3],
                    tool,
                    feature: st.feature,
                    feed_mm_s: (m.feed_mm_min / 60.0) as f32,
                    layer,
                    extruding,
                    mix_rgb,
                };
                self.add_move(m, template);
            }
            _ => {}
        }
        Ok(Flow::Continue)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pass::{drive_reader, Reading};
    use std::io;

    fn read(text: &str, pass: &mut ToolpathPass) {
        drive_reader(text.as_bytes(), Reading::new(Path::new("t.gcode")), pass, &mut io::sink()).unwrap();
    }

    pub(crate) fn collect(text: &str, options: ToolpathOptions) -> Toolpath {
        let mut pass = ToolpathPass::new(options);
        read(text, &mut pass);
        pass.finish_toolpath()
    }

    const SQUARE: &str = ";LAYER:0\n;TYPE:WALL-OUTER\nG1 X0 Y0 Z0.2 F600\nG1 X10 E1\nG1 Y10 E2\n\
                          T1\n;TYPE:FILL\nG0 X5 F6000\nG1 X0 E3 F1200\n;LAYER:1\nG1 Z0.4\nG1 X10 E4\n";

    #[test]
    fn collects_attributes_per_move() {
        let tp = collect(SQUARE, ToolpathOptions { print_only: false, ..Default::default() });
        let ext: Vec<_> = tp.segments.iter().filter(|s| s.extruding).collect();
        assert_eq!(ext.len(), 4);
        assert_eq!((ext[0].start, ext[0].end), ([0.0, 0.0, 0.2], [10.0, 0.0, 0.2]));
        assert_eq!((ext[0].tool, ext[0].feature, ext[0].feed_mm_s), (0, Feature::OuterWall, 10.0));
        assert_eq!((ext[2].tool, ext[2].feature, ext[2].feed_mm_s), (1, Feature::Infill, 20.0));
        assert_eq!((ext[3].layer, ext[3].end), (1, [10.0, 10.0, 0.4]));
        assert_eq!(tp.tools, 2);
        assert_eq!(tp.layer_count(), 2);
        let travel: Vec<_> = tp.segments.iter().filter(|s| !s.extruding).collect();
        assert_eq!(travel.len(), 3, "{travel:?}"); // to the start, G0 X5, Z up
    }

    #[test]
    fn keeps_only_the_layers_asked_for() {
        let options =
            ToolpathOptions { layers: Some(1..=1), travel: false, print_only: false, ..Default::default() };
        let tp = collect(SQUARE, options);
        assert_eq!(tp.segments.len(), 1);
        assert_eq!(tp.segments[0].layer, 1);
        assert_eq!(tp.layer_count(), 2);
    }

    #[test]
    fn arcs_become_chords_on_the_circle() {
        let tp = collect(
            "G1 X10 Y0 Z1 F600\nG3 X-10 Y0 I-10 J0 E5\n",
            ToolpathOptions { print_only: false, ..Default::default() },
        );
        let chords: Vec<_> = tp.segments.iter().filter(|s| s.extruding).collect();
        assert!(chords.len() > 10, "{}", chords.len());
        assert_eq!(chords.last().unwrap().end, [-10.0, 0.0, 1.0]);
        for c in &chords {
            let r = (c.end[0].powi(2) + c.end[1].powi(2)).sqrt();
            assert!((r - 10.0).abs() < 1e-4, "{c:?}");
            assert!(c.end[1] >= -1e-4, "G3 from +X to -X goes through +Y: {c:?}");
        }
    }

    #[test]
    fn decimation_merges_short_chained_moves_within_tolerance() {
        let mut text = String::from("G1 X0 Y0 Z0.2 F600\n");
        for i in 1..=100 {
            text.push_str(&format!("G1 X{:.2} Y{:.3} E{i}\n", i as f64 * 0.05, (i % 2) as f64 * 0.01));
        }
        let all = collect(&text, ToolpathOptions { print_only: false, travel: false, ..Default::default() });
        let merged = collect(
            &text,
            ToolpathOptions { print_only: false, travel: false, min_len_mm: 0.5, ..Default::default() },
        );
        assert_eq!(all.segments.len(), 100);
        assert_eq!(merged.segments.len(), 10, "5 mm in pieces of 0.5 mm");
        assert_eq!(merged.segments[0].start, [0.0, 0.0, 0.2]);
        assert_eq!(merged.segments.last().unwrap().end, all.segments.last().unwrap().end);
    }

    #[test]
    fn a_segment_ceiling_coarsens_the_merge_and_keeps_the_ends() {
        // A zigzag of 2000 moves of 0.05 mm: far more than a ceiling of 100 segments.
        let mut text = String::from("G1 X0 Y0 Z0.2 F600\n");
        for i in 1..=2000 {
            text.push_str(&format!("G1 X{:.2} Y{:.3} E{i}\n", i as f64 * 0.05, (i % 2) as f64 * 0.01));
        }
        let options = ToolpathOptions {
            print_only: false,
            travel: false,
            max_segments: Some(100),
            ..Default::default()
        };
        let mut pass = ToolpathPass::new(options);
        read(&text, &mut pass);
        let min_len = pass.options.min_len_mm;
        let tp = pass.finish_toolpath();
        assert!(tp.segments.len() <= 100, "{}", tp.segments.len());
        // 100 mm in at most 100 pieces needs pieces of 1 mm or more: 0.05 doubled five times.
        assert_eq!(min_len, 1.6);
        assert_eq!(tp.segments[0].start, [0.0, 0.0, 0.2]);
        assert_eq!(tp.segments.last().unwrap().end, [100.0, 0.0, 0.2]);
        // Still one chained path: each piece starts where the last ended.
        assert!(tp.segments.windows(2).all(|w| w[0].end == w[1].start));
    }

    /// Regression: alternating travel and extrusion never chain, so the merge could not reduce
    /// anything and `coarsen` doubled the merge length for ever (a 39 MB file hung `preview`).
    #[test]
    fn coarsen_terminates_when_nothing_can_merge() {
        let mut text = String::from("G1 X0 Y0 Z0.2 F600\n");
        for i in 1..=5000 {
            text.push_str(&format!("G0 X{} Y{}\nG1 X{}.5 E{i}\n", i % 97, i % 89, i % 97));
        }
        let options = ToolpathOptions {
            print_only: false,
            travel: true,
            max_segments: Some(100),
            ..Default::default()
        };
        let mut pass = ToolpathPass::new(options);
        read(&text, &mut pass);
        let (min_len, thinning) = (pass.options.min_len_mm, pass.thinning);
        let tp = pass.finish_toolpath();
        assert!(tp.segments.len() <= 100, "{}", tp.segments.len());
        // 10 000 segments in at most 100: halved (per kind) until they fit, both kinds kept.
        assert_eq!(thinning, 128);
        let extruding = tp.segments.iter().filter(|s| s.extruding).count();
        assert!(extruding > 30 && tp.segments.len() - extruding > 30, "{extruding} of {}", tp.segments.len());
        assert!(min_len < 1.0, "the merge length stays meaningful: {min_len}");
    }

    #[test]
    fn print_only_drops_start_gcode() {
        let text = ";FLAVOR:Marlin\nG1 X0 Y0 Z0.3 F600\nG1 X100 E5\n;LAYER:0\nG1 X10 Y10 Z0.2\nG1 X20 E6\n";
        let tp = collect(text, ToolpathOptions::default());
        let ext: Vec<_> = tp.segments.iter().filter(|s| s.extruding).collect();
        assert_eq!(ext.len(), 1);
        assert_eq!(ext[0].end, [20.0, 10.0, 0.2]);
    }

    #[test]
    fn inkjet_fires_become_dots_at_the_nozzles() {
        // C6602 default: 12 nozzles at 96 dpi; S5 fires rows 0 and 2.
        let text = ";LAYER:0\nG1 Z0.1\nG1 X10 Y20 F3000\nM400\nM700 P0 S5\nM700 S1\nM700 P1 S1\n";
        let tp = collect(text, ToolpathOptions::default());
        let pitch = 25.4f32 / 96.0;
        assert_eq!(tp.segments.iter().filter(|s| s.extruding).count(), 2, "no P: no fire; no head 1");
        let dots: Vec<_> = tp.segments.iter().filter(|s| s.extruding).collect();
        for (d, row) in dots.iter().zip([0.0, 2.0]) {
            assert_eq!(d.start, [10.0 - pitch / 2.0, 20.0 + row * pitch, 0.1]);
            assert_eq!(d.end, [10.0 + pitch / 2.0, 20.0 + row * pitch, 0.1]);
            assert_eq!((d.tool, d.layer), (0, 0));
        }
    }

    /// Regression (issue 23): raster layers state no Z in a comment and never extrude, and
    /// every layer's Z was 0.0 (`z 0.00 mm` in the viewer, `toolpath()["layer_z"]` all 0).
    #[test]
    fn raster_layers_take_the_z_of_their_drops() {
        let mut text = String::new();
        for layer in 0..3 {
            let z = 0.1 * (layer + 1) as f64;
            text.push_str(&format!(
                ";LAYER:{layer}\nG1 Z{z:.1}\nG1 X10 Y20 F3000\nM400\nM700 P0 S1\nG1 X0\n"
            ));
        }
        let tp = collect(&text, ToolpathOptions::default());
        assert_eq!(tp.layer_z_mm, [0.1, 0.2, 0.3]);
    }
}
