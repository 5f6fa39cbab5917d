//! A self-contained HTML viewer: one file, no network. The page (`viewer.html`) draws the beads
//! as lit 3D tubes with WebGL 2 (one instanced quad per segment, shaded as a round bead in the
//! fragment shader), with orbit, pan, zoom, top view, a layer range, colourings with a legend,
//! travel and the file's stats. The toolpath is embedded as JSON holding base64 arrays, which the
//! page hands to the GPU as they are (no per-vertex work in JavaScript).
//!
//! Encoding, per segment (`n` segments: first the `outside` beads that can show on the part's
//! surface, then the rest of the `extruding` ones (inner walls, infill: `hidden_inside`), then
//! travel, each part in file order, so that the page draws each from one range of one buffer,
//! and only the first while the camera moves), for each file shown (two with `--compare`):
//! - `pos`: 6 x u16 little endian (start x y z, end x y z), quantised over the extents `lo..hi`:
//!   `q = round((v - lo) / (hi - lo) * 65535)`, so a 250 mm bed keeps 0.004 mm steps;
//! - `tool`, `feature` (index into `features`), `flags` (bit 0: extruding; bit 1: a move the
//!   other file of a comparison does not have): u8 each;
//! - `layer`: u32; `feed`: u16, tenths of mm/s.
//!
//! - `mix` (only when the toolpath was read with the mix colouring): u8 index into
//!   `mix_colours`, the distinct predicted colours (at most 255: channels are coarsened until
//!   they fit), with `mix_legend` the colours printed longest.
//!
//! Each column travels as base64 text in a `<script type="application/octet-stream">` element of
//! its own, which the JSON names by id: the browser's HTML tokenizer passes over such text far
//! faster than its JavaScript parser reads a string literal (on the 44 MB page of the benchmark
//! file, 2 s of the first picture's 3 were that parse), and the page decodes it natively.
//!
//! 21 bytes per segment before base64 (x 4/3): a 3.1 MB slicer file becomes a 2.8 MB page,
//! and the segment ceiling of a preview (`MAX_SEGMENTS`) bounds any file's page at
//! about 59 MB.

use std::collections::HashMap;

use serde::Serialize;

use crate::colour::Srgb8;
use crate::gcode::layers::{Feature, ALL_FEATURES};
use crate::stats::Stats;

use super::colour_by::{ColourBy, Colouring, FEATURE_COLOURS, TOOL_COLOURS, TRAVEL_COLOUR};
use super::toolpath::Toolpath;
use super::view::ViewKind;

const TEMPLATE: &str = include_str!("viewer.html");
const DATA_SLOT: &str = "/*GWEAVE_DATA*/null";
const BLOCKS_SLOT: &str = "<!--GWEAVE_BLOCKS-->";

/// The binary columns of a page, each its own element (see the module notes).
#[derive(Default)]
struct Blocks(Vec<String>);

impl Blocks {
    /// Adds a column; returns the id of its element.
    fn add(&mut self, bytes: &[u8]) -> String {
        self.0.push(base64(bytes));
        format!("c{}", self.0.len() - 1)
    }

    fn html(&self) -> String {
        let mut out = String::with_capacity(self.0.iter().map(|b| b.len() + 64).sum());
        for (i, b) in self.0.iter().enumerate() {
            out.push_str(&format!("<script type=\"application/octet-stream\" id=\"c{i}\">{b}</script>\n"));
        }
        out
    }
}

/// How the page opens (the reader can change all of it).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct HtmlOptions {
    pub title: String,
    pub colour_by: ColourBy,
    pub view: ViewKind,
    /// The layer range shown first, first and last (every layer when `None`).
    pub layers: Option<[u32; 2]>,
    pub tool_colours: Vec<Srgb8>,
}

/// One file the page shows: its toolpath, name and statistics.
pub(crate) struct HtmlFile<'a> {
    pub name: String,
    pub toolpath: &'a Toolpath,
    pub stats: Option<&'a Stats>,
    /// In a comparison, which moves the other file does not have
    /// ([`super::view::changed_moves`]): drawn in colour, the rest in grey.
    pub changed: Option<Vec<bool>>,
}

#[derive(Serialize)]
struct Payload<'a> {
    title: &'a str,
    layers: Option<[u32; 2]>,
    view: String,
    colour_by: &'static str,
    features: Vec<&'static str>,
    feature_colours: Vec<String>,
    tool_colours: Vec<String>,
    travel_colour: String,
    files: Vec<FileData<'a>>,
}

#[derive(Serialize)]
struct FileData<'a> {
    name: &'a str,
    n: usize,
    /// The first `extruding` segments extrude, the rest travel; of those, the first `outside`
    /// can show on the part's surface.
    extruding: usize,
    outside: usize,
    /// Quantisation extents of `pos` (everything drawn, travel included), mm.
    lo: [f32; 3],
    hi: [f32; 3],
    /// Extents of what is printed (the panel's x, y, z), mm.
    printed_lo: [f32; 3],
    printed_hi: [f32; 3],
    /// Z of each layer; on a cylinder, the radius of each layer, mm.
    layer_z: &'a [f32],
    on_cylinder: bool,
    /// On a cylinder: the radii the beads lie between, mm.
    radius_mm: Option<[f32; 2]>,
    stats: Option<&'a Stats>,
    pos: String,
    tool: String,
    feature: String,
    flags: String,
    layer_of: String,
    feed: String,
    mix: Option<String>,
    mix_colours: Vec<String>,
    /// The colours printed longest, each with its mix's name.
    mix_legend: Vec<[String; 2]>,
}

/// The page for one toolpath, or two compared side by side (see [`HtmlFile::changed`]), with
/// each file's stats when given.
pub(crate) fn write_html(files: &[HtmlFile<'_>], options: &HtmlOptions) -> String {
    let toolpaths: Vec<&Toolpath> = files.iter().map(|f| f.toolpath).collect();
    let tools =
        toolpaths.iter().map(|tp| tp.tools as usize).max().unwrap_or(1).max(options.tool_colours.len());
    let tool_colours = (0..tools)
        .map(|t| {
            options.tool_colours.get(t).copied().unwrap_or(TOOL_COLOURS[t % TOOL_COLOURS.len()]).to_hex()
        })
        .collect();
    let mut blocks = Blocks::default();
    let payload = Payload {
        title: &options.title,
        layers: options.layers,
        view: options.view.to_string(),
        colour_by: options.colour_by.name(),
        features: ALL_FEATURES.iter().map(|f| f.name()).collect(),
        feature_colours: FEATURE_COLOURS.iter().map(|c| c.to_hex()).collect(),
        tool_colours,
        travel_colour: TRAVEL_COLOUR.to_hex(),
        files: files.iter().map(|f| file_data(f, &mut blocks)).collect(),
    };
    // Serialising plain numbers and strings cannot fail; `</` is escaped so that no text in the
    // data (a file name, a stats string) can close the script element.
    let json = serde_json::to_string(&payload).unwrap_or_else(|_| "null".into()).replace("</", "<\\/");
    TEMPLATE
        .replacen("<title>gweave preview</title>", &format!("<title>{}</title>", escape(&options.title)), 1)
        .replacen(DATA_SLOT, &json, 1)
        .replacen(BLOCKS_SLOT, &blocks.html(), 1)
}

/// The columns of one file (see the module notes).
fn file_data<'a>(f: &'a HtmlFile<'a>, blocks: &mut Blocks) -> FileData<'a> {
    let tp = f.toolpath;
    let (printed_lo, printed_hi) = tp.bounds().unwrap_or(([0.0; 3], [1.0; 3]));
    // Travel may leave the extruded extents: quantise over everything drawn.
    let (mut lo, mut hi) = (printed_lo, printed_hi);
    for s in &tp.segments {
        for p in [s.start, s.end] {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
    }
    let n = tp.segments.len();
    let mut pos = Vec::with_capacity(n * 12);
    let (mut tool, mut feature, mut flags) =
        (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut layer_of, mut feed) = (Vec::with_capacity(n * 4), Vec::with_capacity(n * 2));
    let class = |i: &usize| {
        let s = &tp.segments[*i];
        match (s.extruding, hidden_inside(s.feature)) {
            (true, false) => 0,
            (true, true) => 1,
            (false, _) => 2,
        }
    };
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(class);
    for &i in &order {
        let s = &tp.segments[i];
        for p in [s.start, s.end] {
            for i in 0..3 {
                pos.extend_from_slice(&quantise(p[i], lo[i], hi[i]).to_le_bytes());
            }
        }
        tool.push(s.tool.min(255) as u8);
        feature.push(s.feature as u8);
        let is_changed = f.changed.as_ref().is_some_and(|c| c[i]);
        flags.push(u8::from(s.extruding) | u8::from(is_changed) << 1);
        layer_of.extend_from_slice(&s.layer.to_le_bytes());
        feed.extend_from_slice(&((s.feed_mm_s * 10.0).round().clamp(0.0, 65535.0) as u16).to_le_bytes());
    }
    // Whatever colouring the page opens on, a file with mixing commands can be shown by mix,
    // its legend naming each mix as `gweave mix` named it.
    let (mix, mix_colours, mix_legend) = if tp.mixing {
        let (index, colours) = mix_palette(tp);
        let legend = Colouring::new(ColourBy::Mix, Vec::new(), &[tp]).legend(&[tp]);
        let index: Vec<u8> = order.iter().map(|&i| index[i]).collect();
        let legend = legend.iter().map(|e| [e.colour.to_hex(), e.label.clone()]).collect();
        (Some(blocks.add(&index)), colours, legend)
    } else {
        (None, Vec::new(), Vec::new())
    };
    // The mandrel lies along X: a point's radius is its distance from that axis.
    let radius_mm = tp.on_cylinder.then(|| {
        let r = |p: [f32; 3]| p[1].hypot(p[2]);
        let radii = tp.segments.iter().filter(|s| s.extruding).flat_map(|s| [r(s.start), r(s.end)]);
        radii.fold([f32::INFINITY, 0.0], |[lo, hi], r| [lo.min(r), hi.max(r)])
    });
    FileData {
        name: &f.name,
        n,
        extruding: order.iter().filter(|i| class(i) < 2).count(),
        outside: order.iter().filter(|i| class(i) == 0).count(),
        radius_mm,
        lo,
        hi,
        printed_lo,
        printed_hi,
        layer_z: &tp.layer_z_mm,
        on_cylinder: tp.on_cylinder,
        stats: f.stats,
        pos: blocks.add(&pos),
        tool: blocks.add(&tool),
        feature: blocks.add(&feature),
        flags: blocks.add(&flags),
        layer_of: blocks.add(&layer_of),
        feed: blocks.add(&feed),
        mix,
        mix_colours,
        mix_legend,
    }
}

/// Features the part's surface covers: the page leaves them out while the camera moves.
fn hidden_inside(f: Feature) -> bool {
    matches!(
        f,
        Feature::InnerWall | Feature::Infill | Feature::SolidInfill | Feature::Bridge | Feature::GapFill
    )
}

/// Each segment's index into a palette of its predicted mix colours, and the palette: at most
/// 255 colours, the low bits of each channel dropped until they fit (a gradient then shows in
/// steps of 2, 4, ... levels).
fn mix_palette(tp: &Toolpath) -> (Vec<u8>, Vec<String>) {
    for shift in 0..8 {
        let coarse = |c: [u8; 3]| c.map(|v| (v >> shift) << shift);
        let mut index: HashMap<[u8; 3], u8> = HashMap::new();
        let mut colours = Vec::new();
        let fits = tp.segments.iter().all(|s| {
            let c = coarse(s.mix_rgb);
            if index.contains_key(&c) {
                return true;
            }
            if colours.len() == 255 {
                return false;
            }
            index.insert(c, colours.len() as u8);
            colours.push(Srgb8::new(c[0], c[1], c[2]).to_hex());
            true
        });
        if fits {
            return (tp.segments.iter().map(|s| index[&coarse(s.mix_rgb)]).collect(), colours);
        }
    }
    // Channels of one bit give 8 colours: the loop has returned by now.
    (vec![0; tp.segments.len()], vec![Srgb8::new(0, 0, 0).to_hex()])
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

fn quantise(v: f32, lo: f32, hi: f32) -> u16 {
    if hi > lo {
        ((v - lo) / (hi - lo) * 65535.0).round().clamp(0.0, 65535.0) as u16
    } else {
        0
    }
}

/// Standard base64 (RFC 4648, with padding).
pub(crate) fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let v = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[(v >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::layers::Feature;
    use crate::render::toolpath::Segment;

    fn file(tp: &Toolpath) -> HtmlFile<'_> {
        HtmlFile { name: "t.gcode".into(), toolpath: tp, stats: None, changed: None }
    }

    #[test]
    fn base64_matches_rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, encoded) in cases {
            assert_eq!(base64(plain.as_bytes()), encoded);
        }
    }

    #[test]
    fn page_is_self_contained_and_carries_the_data() {
        let s = Segment {
            start: [0.0, 0.0, 0.2],
            end: [10.0, 20.0, 0.2],
            tool: 1,
            feature: Feature::OuterWall,
            feed_mm_s: 25.0,
            layer: 0,
            extruding: true,
            mix_rgb: [0; 3],
        };
        let tp = Toolpath { segments: vec![s], layer_z_mm: vec![0.2], tools: 2, ..Toolpath::default() };
        let options = HtmlOptions {
            title: "a</script>b".into(),
            colour_by: ColourBy::Tool,
            view: ViewKind::Top,
            layers: None,
            tool_colours: vec![],
        };
        let html = write_html(&[file(&tp)], &options);
        assert!(!html.contains(DATA_SLOT));
        assert!(!html.contains("http://") && !html.contains("https://"), "no network");
        assert_eq!(html.matches("</script>").count(), 2 + 6, "the title cannot end a script");
        // Start (0, 0, 0.2) is the low corner, end the high one: 0 and 65535 (ff ff) on each axis.
        let pos = base64(&[0, 0, 0, 0, 0, 0, 255, 255, 255, 255, 0, 0]);
        assert!(html.contains("\"pos\":\"c0\""), "columns named by id");
        assert!(html.contains(&format!("id=\"c0\">{pos}</script>")), "z span is 0: quantised to 0");
        assert!(html.contains("\"feed\":\"c5\"") && html.contains("id=\"c5\">+gA=<"), "250 tenths of mm/s");
    }

    #[test]
    fn surface_beads_come_first_and_compared_moves_are_flagged() {
        let seg = |feature, extruding, x: f32| Segment {
            start: [x, 0.0, 0.2],
            end: [x + 1.0, 0.0, 0.2],
            tool: 0,
            feature,
            feed_mm_s: 20.0,
            layer: 0,
            extruding,
            mix_rgb: [0; 3],
        };
        let segments = vec![
            seg(Feature::Unknown, false, 0.0),
            seg(Feature::Infill, true, 1.0),
            seg(Feature::OuterWall, true, 2.0),
        ];
        let tp = Toolpath { segments, layer_z_mm: vec![0.2], tools: 1, ..Toolpath::default() };
        let options = HtmlOptions {
            title: "c".into(),
            colour_by: ColourBy::Tool,
            view: ViewKind::Iso,
            layers: None,
            tool_colours: vec![],
        };
        let f = HtmlFile { changed: Some(vec![true, false, true]), ..file(&tp) };
        let html = write_html(&[f], &options);
        assert!(html.contains("\"extruding\":2,\"outside\":1"));
        // Outer wall (changed), infill, travel (changed): bit 0 extruding, bit 1 changed.
        assert!(html.contains(&format!("id=\"c3\">{}<", base64(&[3, 1, 2]))));
    }

    #[test]
    fn mix_colours_travel_as_a_palette_of_at_most_255() {
        let seg = |i: u32| Segment {
            start: [i as f32, 0.0, 0.2],
            end: [i as f32 + 1.0, 0.0, 0.2],
            tool: 0,
            feature: Feature::Infill,
            feed_mm_s: 20.0,
            layer: 0,
            extruding: true,
            mix_rgb: [(i % 256) as u8, (i / 256) as u8 * 100, 7],
        };
        let few = Toolpath {
            segments: (0..3).map(seg).collect(),
            layer_z_mm: vec![0.2],
            tools: 1,
            mixing: true,
            ..Toolpath::default()
        };
        let (index, colours) = mix_palette(&few);
        assert_eq!(index, [0, 1, 2]);
        assert_eq!(colours, ["#000007", "#010007", "#020007"], "exact while they fit");
        let many = Toolpath { segments: (0..300).map(seg).collect(), ..few.clone() };
        let (index, colours) = mix_palette(&many);
        assert_eq!(colours.len(), 150);
        // 300 colours do not fit: one low bit dropped per channel, 150 remain; (5, 0, 7) maps
        // to (4, 0, 6).
        assert_eq!(colours[index[5] as usize], "#040006");
        let options = HtmlOptions {
            title: "m".into(),
            colour_by: ColourBy::Mix,
            view: ViewKind::Top,
            layers: None,
            tool_colours: vec![],
        };
        let html = write_html(&[file(&few)], &options);
        assert!(html.contains("\"mix_colours\":[\"#000007\",\"#010007\",\"#020007\"]"));
    }
}
