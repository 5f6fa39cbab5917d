//! From segments in millimetres to strokes in pixels: the top view of a layer or a layer range,
//! the isometric view of the whole print, and the before/after comparison of two files.
//!
//! Top view: `x_px = W/2 + (x - cx) * s`, `y_px = H/2 - (y - cy) * s` (Y up, as on the bed),
//! with the scale `s` fitting the extruded extents into the picture with a margin.
//!
//! Isometric view: the print is turned 45 degrees about Z and tilted so that the eye looks down
//! at `atan(1/sqrt 2) = 35.26` degrees, the angle at which X, Y and Z are foreshortened alike:
//! `u = (x - y) / sqrt 2`, `w = (x + y) / sqrt 2`, `v = w sin(e) + z cos(e)`. Strokes are drawn
//! from low to high Z (painter's algorithm): for an eye above every layer, a horizontal layer can
//! only hide the layers below it, so this order is exact for planar layers. Walls are shaded by
//! their direction so that the shape reads.
//!
//! Rotary programs ([`Toolpath::on_cylinder`]): the layers are cylinders about X, nested. A line
//! of sight meets them in one order: it enters each cylinder on the half that faces the eye,
//! outermost first, and leaves on the half turned away, innermost first (the chord through an
//! inner cylinder lies inside the chord through an outer one). So the strokes are drawn half
//! turned away first, outer radii before inner, then the half facing the eye, inner radii before
//! outer, and at one radius in file order: painter's algorithm with an order that is exact for
//! every pixel, where ordering by depth alone let a lower layer's short strokes show through the
//! long chords above them. Beads are shaded by how much the cylinder's normal
//! `(0, y, z) / r` faces the eye (35 % ambient, 65 % diffuse).
//!
//! Comparison: a move is unchanged when the other file has a move with the same end points (to
//! 0.01 mm), tool, feed rate (to 0.1 mm/s) and extruding flag; moves are counted as a multiset,
//! so a move repeated in one file and not the other is a change. The two files are drawn side by
//! side in one projection; unchanged moves grey, changed moves in their colours and wider.

use std::collections::HashMap;
use std::fmt;
use std::ops::RangeInclusive;
use std::str::FromStr;

use crate::colour::Srgb8;

use super::colour_by::{ColourBy, Colouring, LegendEntry};
use super::legend::{self, Rect};
use super::toolpath::{Segment, Toolpath};

/// Which way the print is looked at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ViewKind {
    /// From above, Y up.
    #[default]
    Top,
    /// Isometric, from the front left and above.
    Iso,
}

impl FromStr for ViewKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "top" => Ok(ViewKind::Top),
            "iso" => Ok(ViewKind::Iso),
            _ => Err(format!("unknown view {s:?} (top or iso)")),
        }
    }
}

impl fmt::Display for ViewKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ViewKind::Top => "top",
            ViewKind::Iso => "iso",
        })
    }
}

/// What to draw and how.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewOptions {
    /// The projection: from above or isometric.
    pub kind: ViewKind,
    /// Layers drawn (all when `None`).
    pub layers: Option<RangeInclusive<u32>>,
    /// Picture width, pixels.
    pub width_px: u32,
    /// Picture height, pixels.
    pub height_px: u32,
    /// The attribute that picks a segment's colour.
    pub colour_by: ColourBy,
    /// Per-tool colours for the tool and mix colourings (see [`super::colour_by`]).
    pub tool_colours: Vec<Srgb8>,
    /// Draw travel moves (thin, translucent).
    pub travel: bool,
    /// Extrusion width drawn, mm.
    pub line_width_mm: f32,
}

impl Default for ViewOptions {
    fn default() -> Self {
        ViewOptions {
            kind: ViewKind::Top,
            layers: None,
            width_px: 1200,
            height_px: 900,
            colour_by: ColourBy::Tool,
            tool_colours: Vec::new(),
            travel: false,
            line_width_mm: 0.45,
        }
    }
}

/// One line to draw, in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    /// Start, pixels from the top left corner.
    pub from: [f32; 2],
    /// End, pixels from the top left corner.
    pub to: [f32; 2],
    /// sRGB colour.
    pub colour: [u8; 3],
    /// Line width, pixels.
    pub width_px: f32,
    /// Opacity, 0 to 1.
    pub alpha: f32,
}

/// A part of the picture with its own projection (the whole picture, or one side of a
/// comparison) and a title (empty for a single view).
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Left edge of the panel, pixels.
    pub x_px: u32,
    /// Width of the panel, pixels.
    pub width_px: u32,
    /// The panel's title (empty for a single view).
    pub title: String,
    /// In a comparison, the moves of this side (in the layers drawn) the other file does not have.
    pub changed_moves: Option<usize>,
    /// Where a point in mm lands in the picture.
    pub projection: Projection,
}

/// Everything a PNG or SVG writer needs: strokes in drawing order, legend, titles.
#[derive(Debug, Clone, PartialEq)]
pub struct Drawing {
    /// Picture width, pixels.
    pub width_px: u32,
    /// Picture height, pixels.
    pub height_px: u32,
    /// sRGB colour behind everything.
    pub background: [u8; 3],
    /// The lines, in drawing order.
    pub strokes: Vec<Stroke>,
    /// What each colour stands for.
    pub legend: Vec<LegendEntry>,
    /// The views side by side (one, or two for a comparison).
    pub panels: Vec<Panel>,
    /// The layers drawn, as the file numbers them (`None`: no layer of the file is in range).
    pub layers_drawn: Option<RangeInclusive<u32>>,
}

impl Drawing {
    /// Nothing to draw: the picture is the background only.
    pub fn is_blank(&self) -> bool {
        self.strokes.is_empty()
    }
}

/// The picture's background (sRGB, a warm off-white).
pub const BACKGROUND: [u8; 3] = [0xf7, 0xf7, 0xf5];
/// Unchanged moves in a comparison.
pub const UNCHANGED: [u8; 3] = [0xc4, 0xc4, 0xc4];
const ISO_ELEVATION_RAD: f32 = 0.615_479_7; // atan(1 / sqrt 2)
const MARGIN: f32 = 0.06;

/// Millimetres to pixels for one view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    kind: ViewKind,
    scale_px_mm: f32,
    /// Centre of the fitted extents in view coordinates (u, v).
    centre: [f32; 2],
    /// Pixel centre of the panel.
    origin_px: [f32; 2],
}

impl Projection {
    /// Fits the extents `lo..hi` into a panel `width x height` px whose left edge is at `x_px`.
    pub fn fit(kind: ViewKind, lo: [f32; 3], hi: [f32; 3], x_px: u32, width: u32, height: u32) -> Projection {
        Projection::fit_into(kind, lo, hi, [x_px, 0, width, height])
    }

    /// Fits the extents `lo..hi` into the rectangle `[left, top, width, height]` px.
    pub fn fit_into(kind: ViewKind, lo: [f32; 3], hi: [f32; 3], rect: Rect) -> Projection {
        let [x_px, y_px, width, height] = rect;
        let (umin, umax) = view_extents(kind, lo, hi);
        let span = [(umax[0] - umin[0]).max(1.0), (umax[1] - umin[1]).max(1.0)];
        let usable = 1.0 - 2.0 * MARGIN;
        let scale_px_mm = (width as f32 * usable / span[0]).min(height as f32 * usable / span[1]);
        Projection {
            kind,
            scale_px_mm,
            centre: [(umin[0] + umax[0]) / 2.0, (umin[1] + umax[1]) / 2.0],
            origin_px: [x_px as f32 + width as f32 / 2.0, y_px as f32 + height as f32 / 2.0],
        }
    }

    /// The pixels the extents `lo..hi` cover, widened by `pad_px` on every side.
    pub fn covered(&self, lo: [f32; 3], hi: [f32; 3], pad_px: f32) -> Rect {
        let (umin, umax) = view_extents(self.kind, lo, hi);
        let a = self.project_view([umin[0], umax[1]]);
        let b = self.project_view([umax[0], umin[1]]);
        let (x0, y0) = ((a[0] - pad_px).floor().max(0.0), (a[1] - pad_px).floor().max(0.0));
        let (x1, y1) = ((b[0] + pad_px).ceil().max(x0), (b[1] + pad_px).ceil().max(y0));
        [x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32]
    }

    /// A point in mm to pixels.
    pub fn project(&self, p: [f32; 3]) -> [f32; 2] {
        self.project_view(view_coords(self.kind, p))
    }

    /// A point of the view plane (u, v), mm, to pixels.
    fn project_view(&self, uv: [f32; 2]) -> [f32; 2] {
        [
            self.origin_px[0] + (uv[0] - self.centre[0]) * self.scale_px_mm,
            self.origin_px[1] - (uv[1] - self.centre[1]) * self.scale_px_mm,
        ]
    }

    /// Pixels per mm.
    pub fn scale_px_mm(&self) -> f32 {
        self.scale_px_mm
    }
}

/// The smallest and largest view-plane coordinates of the box `lo..hi`'s corners.
fn view_extents(kind: ViewKind, lo: [f32; 3], hi: [f32; 3]) -> ([f32; 2], [f32; 2]) {
    let mut umin = [f32::INFINITY; 2];
    let mut umax = [f32::NEG_INFINITY; 2];
    for i in 0..8 {
        let p = [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ];
        let uv = view_coords(kind, p);
        for k in 0..2 {
            umin[k] = umin[k].min(uv[k]);
            umax[k] = umax[k].max(uv[k]);
        }
    }
    (umin, umax)
}

/// View-plane coordinates (u right, v up), mm.
fn view_coords(kind: ViewKind, p: [f32; 3]) -> [f32; 2] {
    match kind {
        ViewKind::Top => [p[0], p[1]],
        ViewKind::Iso => {
            let (u, w) = iso_turn(p);
            [u, w * ISO_ELEVATION_RAD.sin() + p[2] * ISO_ELEVATION_RAD.cos()]
        }
    }
}

/// Turned 45 degrees about Z: (right, into the picture).
fn iso_turn(p: [f32; 3]) -> (f32, f32) {
    let r = std::f32::consts::FRAC_1_SQRT_2;
    ((p[0] - p[1]) * r, (p[0] + p[1]) * r)
}

/// Light from the front left, in the XY plane.
const LIGHT_XY: [f32; 2] = [-0.8, -0.6];

/// Shading for the isometric view: an extruded line is a wall whose face is normal to the
/// segment in XY; faces turned to the light are lighter (Lambert's cosine law, with the sign
/// dropped because the side the face looks to depends on the print direction).
fn shade(s: &Segment, c: [u8; 3]) -> [u8; 3] {
    let (dx, dy) = (s.end[0] - s.start[0], s.end[1] - s.start[1]);
    let len = (dx * dx + dy * dy).sqrt();
    let lambert = if len > 0.0 { ((dy * LIGHT_XY[0] - dx * LIGHT_XY[1]) / len).abs() } else { 1.0 };
    c.map(|v| (v as f32 * (0.6 + 0.4 * lambert)) as u8)
}

/// Unit vector from the scene to the eye.
fn toward_eye(kind: ViewKind) -> [f32; 3] {
    match kind {
        ViewKind::Top => [0.0, 0.0, 1.0],
        ViewKind::Iso => {
            let (sin_e, cos_e) = ISO_ELEVATION_RAD.sin_cos();
            let r = std::f32::consts::FRAC_1_SQRT_2;
            [-cos_e * r, -cos_e * r, sin_e]
        }
    }
}

/// Shading of a bead on a cylinder about X, seen from `eye` (see the module notes).
fn shade_cylinder(s: &Segment, eye: [f32; 3], c: [u8; 3]) -> [u8; 3] {
    let (y, z) = ((s.start[1] + s.end[1]) / 2.0, (s.start[2] + s.end[2]) / 2.0);
    let r = y.hypot(z);
    let facing = if r > 0.0 { ((y * eye[1] + z * eye[2]) / r).max(0.0) } else { 1.0 };
    c.map(|v| (v as f32 * (0.35 + 0.65 * facing)).round() as u8)
}

/// Radii on a cylinder are below this, mm (a 1000 mm mandrel and its layers): the drawing order
/// puts the half facing the eye after it.
const FRONT_HALF: f32 = 2048.0;

/// Where a stroke on a cylinder about X comes in the drawing order (see the module notes): the
/// half turned away from `eye` at `-r` (outer radii first), the half facing it at
/// `FRONT_HALF + r` (inner radii first). The radius is whole microns (what the radial word is
/// written to), so that the strokes of one layer tie and keep their file order: on one half of
/// one cylinder a line of sight meets one stroke, and strokes overlap only by their width, as on
/// a flat layer. The f32 steps near `2 * FRONT_HALF` are 0.24 microns.
fn cylinder_order(s: &Segment, eye: [f32; 3]) -> f32 {
    let mid = [1, 2].map(|k| (s.start[k] + s.end[k]) / 2.0);
    // The ends lie on the cylinder (a chord's middle sags inside it).
    let r = (s.start[1].hypot(s.start[2]) + s.end[1].hypot(s.end[2])) / 2.0;
    let r = (r * 1000.0).round() / 1000.0;
    if mid[0] * eye[1] + mid[1] * eye[2] >= 0.0 {
        FRONT_HALF + r
    } else {
        -r
    }
}

fn in_layers(options: &ViewOptions, s: &Segment) -> bool {
    options.layers.as_ref().is_none_or(|r| r.contains(&s.layer)) && (s.extruding || options.travel)
}

/// Extents of what will be drawn from these toolpaths.
fn extents<'a>(
    options: &ViewOptions,
    toolpaths: impl Iterator<Item = &'a Toolpath>,
) -> Option<([f32; 3], [f32; 3])> {
    let mut b: Option<([f32; 3], [f32; 3])> = None;
    for s in toolpaths.flat_map(|t| &t.segments).filter(|s| s.extruding && in_layers(options, s)) {
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

/// Whether each segment of `a` also appears in `b` (see the module notes), in `a`'s order.
pub fn changed_moves(a: &Toolpath, b: &Toolpath) -> Vec<bool> {
    type Key = ([i32; 6], u16, i32, bool);
    let key = |s: &Segment| -> Key {
        let q = |v: f32| (v * 100.0).round() as i32;
        (
            [q(s.start[0]), q(s.start[1]), q(s.start[2]), q(s.end[0]), q(s.end[1]), q(s.end[2])],
            s.tool,
            (s.feed_mm_s * 10.0).round() as i32,
            s.extruding,
        )
    };
    let mut in_b: HashMap<Key, u32> = HashMap::with_capacity(b.segments.len());
    for s in &b.segments {
        *in_b.entry(key(s)).or_default() += 1;
    }
    a.segments
        .iter()
        .map(|s| match in_b.get_mut(&key(s)) {
            Some(n) if *n > 0 => {
                *n -= 1;
                false
            }
            _ => true,
        })
        .collect()
}

/// Draws one toolpath.
pub fn draw(tp: &Toolpath, options: &ViewOptions) -> Drawing {
    let colouring = Colouring::new(options.colour_by, options.tool_colours.clone(), &[tp]);
    let mut d = empty(options, tp.layer_count());
    let Some((lo, hi)) = extents(options, std::iter::once(tp)) else {
        return d;
    };
    d.legend = colouring.legend(&[tp]);
    let panel = [0, 0, options.width_px, options.height_px];
    let proj =
        Projection::fit_into(options.kind, lo, hi, clear_of_legend(options.kind, lo, hi, panel, &d.legend));
    d.strokes = strokes(tp, None, options, &proj, &colouring);
    d.panels.push(Panel {
        x_px: 0,
        width_px: options.width_px,
        title: String::new(),
        changed_moves: None,
        projection: proj,
    });
    d
}

/// Draws `before` and `after` side by side, highlighting the moves that differ.
pub fn draw_compare(before: &Toolpath, after: &Toolpath, options: &ViewOptions) -> Drawing {
    let colouring = Colouring::new(options.colour_by, options.tool_colours.clone(), &[before, after]);
    let mut d = empty(options, before.layer_count().max(after.layer_count()));
    let Some((lo, hi)) = extents(options, [before, after].into_iter()) else {
        return d;
    };
    d.legend = colouring.legend(&[before, after]);
    let half = options.width_px / 2;
    // Both sides in one scale: the left one kept clear of the legend, the right one alike.
    let [dx, y, w, h] = clear_of_legend(options.kind, lo, hi, [0, 0, half, options.height_px], &d.legend);
    let sides = [(before, after, 0, "before"), (after, before, half, "after")];
    for (this, other, x_px, name) in sides {
        let proj = Projection::fit_into(options.kind, lo, hi, [x_px + dx, y, w, h]);
        let changed = changed_moves(this, other);
        let n = this.segments.iter().zip(&changed).filter(|(s, c)| **c && in_layers(options, s)).count();
        d.strokes.extend(strokes(this, Some(&changed), options, &proj, &colouring));
        d.panels.push(Panel {
            x_px,
            width_px: half,
            title: format!("{name} - {n} moves changed"),
            changed_moves: Some(n),
            projection: proj,
        });
    }
    d
}

/// Widest half stroke, px (strokes are at most 12 px wide, see [`strokes`]).
const HALF_STROKE_PX: f32 = 6.0;

/// Where in `panel` to fit the extents `lo..hi` so that the legend's box hides none of them
/// ([`legend::clear_of`]).
fn clear_of_legend(kind: ViewKind, lo: [f32; 3], hi: [f32; 3], panel: Rect, legend: &[LegendEntry]) -> Rect {
    let drawn = Projection::fit_into(kind, lo, hi, panel).covered(lo, hi, HALF_STROKE_PX);
    let scale = |r: Rect| Projection::fit_into(kind, lo, hi, r).scale_px_mm();
    legend::clear_of(panel, drawn, legend::legend_box(legend), |a, b| scale(a) >= scale(b))
}

/// A drawing with nothing on it yet, of a file with `layers` layers.
fn empty(options: &ViewOptions, layers: u32) -> Drawing {
    Drawing {
        layers_drawn: layers_drawn(options, layers),
        width_px: options.width_px,
        height_px: options.height_px,
        background: BACKGROUND,
        strokes: Vec::new(),
        legend: Vec::new(),
        panels: Vec::new(),
    }
}

/// The layers `options` asks for that a file with `layers` layers has.
pub(crate) fn layers_drawn(options: &ViewOptions, layers: u32) -> Option<RangeInclusive<u32>> {
    let last = layers.checked_sub(1)?;
    let (first, end) = match &options.layers {
        Some(asked) => (*asked.start(), (*asked.end()).min(last)),
        None => (0, last),
    };
    (first <= end).then_some(first..=end)
}

/// The strokes of one toolpath in drawing order; with `changed`, unchanged moves are grey.
fn strokes(
    tp: &Toolpath,
    changed: Option<&[bool]>,
    options: &ViewOptions,
    proj: &Projection,
    colouring: &Colouring,
) -> Vec<Stroke> {
    // At least 2 px in the isometric view, where layers 0.1 to 0.3 mm apart are a pixel or less
    // apart: the walls then close up, and the rasteriser can skip what they hide.
    let min_px = if options.kind == ViewKind::Iso { 2.0 } else { 1.0 };
    let width_px = (options.line_width_mm * proj.scale_px_mm()).clamp(min_px, 12.0);
    let eye = toward_eye(options.kind);
    // The drawing order is found on (key, segment) pairs, 8 bytes each, and the strokes are made
    // in that order: sorting the strokes themselves (32 bytes each, and the sort's scratch)
    // held a picture's 2 M strokes twice beside the toolpath, 50 MB more at the peak.
    // Segment indices fit a u32: a picture keeps at most `MAX_SEGMENTS`.
    let mut order: Vec<(f32, u32)> = Vec::new();
    for (i, s) in tp.segments.iter().enumerate() {
        // A stopped run (Python's Ctrl-C) projects no further: the drawing is thrown away.
        if i.is_multiple_of(crate::interrupt::CHECK_EVERY) && crate::interrupt::stopped() {
            return Vec::new();
        }
        if !in_layers(options, s) {
            continue;
        }
        // Drawing order: height for flat layers; on a cylinder see the module notes.
        let key = if tp.on_cylinder { cylinder_order(s, eye) } else { (s.start[2] + s.end[2]) / 2.0 };
        order.push((key, i as u32));
    }
    if options.kind == ViewKind::Iso || tp.on_cylinder {
        // Low to high (far to near); stable, so equal keys keep file order.
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let stroke = |&(_, i): &(f32, u32)| {
        let s = &tp.segments[i as usize];
        let is_changed = changed.map(|c| c[i as usize]);
        let mut colour = match is_changed {
            Some(false) => UNCHANGED,
            _ => colouring.colour(s),
        };
        if tp.on_cylinder && s.extruding && is_changed != Some(false) {
            colour = shade_cylinder(s, eye, colour);
        } else if options.kind == ViewKind::Iso && s.extruding {
            colour = shade(s, colour);
        }
        let (w, alpha) = match (s.extruding, is_changed) {
            (false, _) => (1.0, 0.35),
            (true, Some(true)) => (width_px.max(2.0) * 1.6, 1.0),
            (true, _) => (width_px, 1.0),
        };
        Stroke { from: proj.project(s.start), to: proj.project(s.end), colour, width_px: w, alpha }
    };
    if changed.is_some() {
        let mut strokes: Vec<Stroke> = order.iter().map(stroke).collect();
        drop(order);
        // Changed moves on top of the grey ones.
        strokes.sort_by_key(|st| st.colour != UNCHANGED);
        return with_rims(strokes.into_iter());
    }
    with_rims(order.iter().map(stroke))
}

/// A colour closer than this to the background (CIEDE2000) hardly shows on it: white filament,
/// a calibration card's white swatch (#f5f5ee on #f7f7f5 is 1.9). 6 is about three times the
/// difference an eye just tells apart side by side.
const FAINT_DE00: f64 = 6.0;
/// A faint colour's rim: the colour at this fraction of its value (#f5f5ee becomes #acaca7).
const RIM_SHADE: f32 = 0.7;
/// How much wider than the stroke its rim is, px (one pixel each side).
const RIM_PX: f32 = 2.0;

/// The strokes, each run of extruded strokes in faint colours (see [`FAINT_DE00`]) preceded
/// by a rim: its strokes again, [`RIM_PX`] wider in a darker shade. Painted first, the rims
/// show only round the outside of the run (a white swatch gets a grey edge, its inside stays
/// white).
fn with_rims(strokes: impl Iterator<Item = Stroke>) -> Vec<Stroke> {
    use crate::colour::{Ciede2000, Lab};
    let background = Lab::from(Srgb8::new(BACKGROUND[0], BACKGROUND[1], BACKGROUND[2]));
    // Colours come in runs: the last one's answer is kept.
    let mut last: Option<([u8; 3], bool)> = None;
    let mut faint = |c: [u8; 3]| match last {
        Some((l, f)) if l == c => f,
        _ => {
            let f = Lab::from(Srgb8::new(c[0], c[1], c[2])).difference(background) < FAINT_DE00;
            last = Some((c, f));
            f
        }
    };
    let mut out = Vec::new();
    let mut run: Vec<Stroke> = Vec::new();
    let flush = |out: &mut Vec<Stroke>, run: &mut Vec<Stroke>| {
        out.extend(run.iter().map(|s| Stroke {
            colour: s.colour.map(|v| (f32::from(v) * RIM_SHADE).round() as u8),
            width_px: s.width_px + RIM_PX,
            ..*s
        }));
        out.append(run);
    };
    for s in strokes {
        let rimmed = s.alpha == 1.0 && faint(s.colour);
        // One run for every faint colour in a row: a swatch whose first lines are still
        // tinted by the colour before (the chamber's washout) gets one rim round it, not one
        // across it at each change of tint.
        if !rimmed && !run.is_empty() {
            flush(&mut out, &mut run);
        }
        if rimmed {
            run.push(s);
        } else {
            out.push(s);
        }
    }
    flush(&mut out, &mut run);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::layers::Feature;

    fn seg(start: [f32; 3], end: [f32; 3], tool: u16, layer: u32) -> Segment {
        Segment {
            start,
            end,
            tool,
            feature: Feature::Infill,
            feed_mm_s: 30.0,
            layer,
            extruding: true,
            mix_rgb: [0; 3],
        }
    }

    fn square() -> Toolpath {
        let s = vec![
            seg([0.0, 0.0, 0.2], [10.0, 0.0, 0.2], 0, 0),
            seg([10.0, 0.0, 0.2], [10.0, 10.0, 0.2], 0, 0),
            seg([10.0, 10.0, 0.4], [0.0, 10.0, 0.4], 1, 1),
        ];
        Toolpath { segments: s, layer_z_mm: vec![0.2, 0.4], tools: 2, ..Toolpath::default() }
    }

    #[test]
    fn top_view_fits_and_keeps_y_up() {
        // Wide enough that the legend (T0, T1) in the top left corner is clear of the square.
        let options = ViewOptions { width_px: 400, height_px: 100, ..Default::default() };
        let d = draw(&square(), &options);
        assert_eq!(d.strokes.len(), 3);
        // 10 mm fits 100 px * 0.88 = 88 px; the square is centred.
        let p = d.strokes[0].from;
        assert!((p[0] - 156.0).abs() < 1e-3 && (p[1] - 94.0).abs() < 1e-3, "{p:?}");
        // At 200 px wide the centred square would run under the legend: it moves right of it,
        // in the same scale (the strip right of the box is still 100 px high).
        let d = draw(&square(), &ViewOptions { width_px: 200, ..options });
        let legend = legend::legend_box(&d.legend).unwrap();
        let p = d.strokes[0].from;
        assert!(
            p[0] - 6.0 >= (legend[0] + legend[2]) as f32 && (p[1] - 94.0).abs() < 1e-3,
            "{p:?} {legend:?}"
        );
        assert!(d.strokes[1].to[1] < d.strokes[1].from[1], "Y up on the bed is up in the picture");
    }

    #[test]
    fn layer_selection_and_empty_layers() {
        let options = ViewOptions { layers: Some(1..=1), ..Default::default() };
        assert_eq!(draw(&square(), &options).strokes.len(), 1);
        let beyond = ViewOptions { layers: Some(7..=9), ..Default::default() };
        let d = draw(&square(), &beyond);
        assert!(d.is_blank() && d.legend.is_empty());
    }

    #[test]
    fn iso_view_draws_low_to_high_and_shades_by_direction() {
        let mut tp = square();
        tp.segments.swap(0, 2); // the top layer first in the file
        let options = ViewOptions { kind: ViewKind::Iso, ..Default::default() };
        let d = draw(&tp, &options);
        assert_eq!(d.strokes.len(), 3);
        let proj = Projection::fit(ViewKind::Iso, [0.0, 0.0, 0.2], [10.0, 10.0, 0.4], 0, 1200, 900);
        assert_eq!(d.strokes[2].from, proj.project([10.0, 10.0, 0.4]), "the highest drawn last");
        // Layer 0 keeps file order: the Y edge, then the X edge. A line along Y is a face
        // looking along X: cos = 0.8 to the light; along X it looks along Y: cos = 0.6.
        let c = super::super::colour_by::TOOL_COLOURS[0];
        assert_eq!(d.strokes[0].colour, [c.r, c.g, c.b].map(|v| (v as f32 * (0.6 + 0.4 * 0.8)) as u8));
        assert_eq!(d.strokes[1].colour, [c.r, c.g, c.b].map(|v| (v as f32 * (0.6 + 0.4 * 0.6)) as u8));
    }

    /// Regression: strokes on a cylinder were drawn by the depth of their middle, so a long
    /// chord of an outer layer, whose middle sags away from the eye, was drawn under a short
    /// stroke of the layer inside it, and lower layers showed through the tube's surface.
    #[test]
    fn cylinder_strokes_follow_the_line_of_sight() {
        // Seen from the top (eye +Z): the half z > 0 faces the eye. On each half a short
        // stroke on r = 10 at the top of the arc, and a long chord on r = 10.2 over 60 degrees,
        // whose middle is 1.4 mm further down.
        let (s60, c60) = (60f32.to_radians().sin(), 60f32.to_radians().cos());
        // The halves at different X, so that their strokes can be told apart.
        let ring = |sign: f32| {
            let (r, big, x) = (10.0, 10.2, 1.5 - 1.5 * sign);
            [
                seg([x, -0.1, sign * r], [x + 1.0, 0.1, sign * r], 0, 0),
                seg([x, big * c60, sign * big * s60], [x + 1.0, -big * c60, sign * big * s60], 1, 1),
            ]
        };
        let mut segments = ring(1.0).to_vec();
        segments.extend(ring(-1.0));
        let tp = Toolpath {
            segments,
            layer_z_mm: vec![10.0, 10.2],
            tools: 2,
            on_cylinder: true,
            ..Toolpath::default()
        };
        let d = draw(&tp, &ViewOptions::default());
        let order: Vec<(f32, u16)> = d
            .strokes
            .iter()
            .map(|st| {
                let s =
                    tp.segments.iter().find(|s| d.panels[0].projection.project(s.start) == st.from).unwrap();
                (s.start[2].signum(), s.tool)
            })
            .collect();
        // The back half outer (tool 1) then inner (tool 0), the front half inner then outer.
        assert_eq!(order, [(-1.0, 1), (-1.0, 0), (1.0, 0), (1.0, 1)]);
    }

    #[test]
    fn compare_finds_the_moved_segment() {
        let a = square();
        let mut b = square();
        b.segments[1].end[0] += 1.0;
        assert_eq!(changed_moves(&a, &b), [false, true, false]);
        assert_eq!(changed_moves(&b, &a), [false, true, false]);
        let mut dup = square();
        dup.segments.push(dup.segments[0]);
        assert_eq!(changed_moves(&dup, &a), [false, false, false, true], "multiset");
        let d = draw_compare(&a, &b, &ViewOptions::default());
        assert_eq!(d.panels.len(), 2);
        assert_eq!(d.panels[1].title, "after - 1 moves changed");
        let grey = d.strokes.iter().filter(|s| s.colour == UNCHANGED).count();
        assert_eq!(grey, 4);
    }
}
