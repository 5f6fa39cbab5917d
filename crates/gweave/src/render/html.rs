//! A self-contained HTML viewer: one file, no network. The page (`viewer.html`, a canvas 2D
//! viewer with a layer slider, pan, zoom, rotate, legend and stats) is built into the library;
//! the toolpath is embedded in it as JSON holding base64 arrays.
//!
//! Encoding, per segment (`n` segments):
//! - `pos`: 6 x u16 little endian (start x y z, end x y z), quantised over the extents `lo..hi`:
//!   `q = round((v - lo) / (hi - lo) * 65535)`, so a 250 mm bed keeps 0.004 mm steps;
//! - `tool`, `feature` (index into `features`), `flags` (bit 0: extruding): u8 each;
//! - `layer`: u32; `feed`: u16, tenths of mm/s.
//!
//! - `mix` (only when the toolpath was read with the mix colouring): u8 index into
//!   `mix_colours`, the distinct predicted colours (at most 255: channels are coarsened until
//!   they fit), with `mix_legend` the colours printed longest.
//!
//! 15 bytes per segment before base64 (x 4/3): a 3 MB slicer file becomes about 2.5 MB of HTML.

use std::collections::HashMap;

use serde::Serialize;

use crate::colour::Srgb8;
use crate::gcode::layers::ALL_FEATURES;
use crate::stats::Stats;

use super::colour_by::{ColourBy, Colouring, FEATURE_COLOURS, TOOL_COLOURS, TRAVEL_COLOUR};
use super::toolpath::Toolpath;
use super::view::ViewKind;

const TEMPLATE: &str = include_str!("viewer.html");
const DATA_SLOT: &str = "/*GWEAVE_DATA*/null";

/// How the page opens (the reader can change all of it).
#[derive(Debug, Clone, PartialEq)]
pub struct HtmlOptions {
    pub title: String,
    pub colour_by: ColourBy,
    pub view: ViewKind,
    /// Layer shown first (the last layer when `None`).
    pub layer: Option<u32>,
    pub tool_colours: Vec<Srgb8>,
}

#[derive(Serialize)]
struct Payload<'a> {
    title: &'a str,
    n: usize,
    lo: [f32; 3],
    hi: [f32; 3],
    layer_z: &'a [f32],
    layer: Option<u32>,
    view: String,
    colour_by: &'static str,
    features: Vec<&'static str>,
    feature_colours: Vec<String>,
    tool_colours: Vec<String>,
    travel_colour: String,
    stats: Option<&'a Stats>,
    pos: String,
    tool: String,
    feature: String,
    flags: String,
    layer_of: String,
    feed: String,
    mix: Option<String>,
    mix_colours: Vec<String>,
    mix_legend: Vec<String>,
}

/// The page for a toolpath, with the file's stats when given.
pub fn write_html(tp: &Toolpath, stats: Option<&Stats>, options: &HtmlOptions) -> String {
    let (lo, hi) = tp.bounds().unwrap_or(([0.0; 3], [1.0; 3]));
    // Travel may leave the extruded extents: quantise over everything drawn.
    let (mut lo, mut hi) = (lo, hi);
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
    for s in &tp.segments {
        for p in [s.start, s.end] {
            for i in 0..3 {
                pos.extend_from_slice(&quantise(p[i], lo[i], hi[i]).to_le_bytes());
            }
        }
        tool.push(s.tool.min(255) as u8);
        feature.push(s.feature as u8);
        flags.push(u8::from(s.extruding));
        layer_of.extend_from_slice(&s.layer.to_le_bytes());
        feed.extend_from_slice(&((s.feed_mm_s * 10.0).round().clamp(0.0, 65535.0) as u16).to_le_bytes());
    }
    let tools = (tp.tools as usize).max(options.tool_colours.len());
    let tool_colours = (0..tools)
        .map(|t| {
            options.tool_colours.get(t).copied().unwrap_or(TOOL_COLOURS[t % TOOL_COLOURS.len()]).to_hex()
        })
        .collect();
    let (mix, mix_colours, mix_legend) = if options.colour_by == ColourBy::Mix {
        let (index, colours) = mix_palette(tp);
        let legend = Colouring::new(ColourBy::Mix, Vec::new(), &[tp]).legend(&[tp]);
        (Some(base64(&index)), colours, legend.iter().map(|e| e.colour.to_hex()).collect())
    } else {
        (None, Vec::new(), Vec::new())
    };
    let payload = Payload {
        title: &options.title,
        n,
        lo,
        hi,
        layer_z: &tp.layer_z_mm,
        layer: options.layer,
        view: options.view.to_string(),
        colour_by: options.colour_by.name(),
        features: ALL_FEATURES.iter().map(|f| f.name()).collect(),
        feature_colours: FEATURE_COLOURS.iter().map(|c| c.to_hex()).collect(),
        tool_colours,
        travel_colour: TRAVEL_COLOUR.to_hex(),
        stats,
        pos: base64(&pos),
        tool: base64(&tool),
        feature: base64(&feature),
        flags: base64(&flags),
        layer_of: base64(&layer_of),
        feed: base64(&feed),
        mix,
        mix_colours,
        mix_legend,
    };
    // Serialising plain numbers and strings cannot fail; `</` is escaped so that no text in the
    // data (a file name, a stats string) can close the script element.
    let json = serde_json::to_string(&payload).unwrap_or_else(|_| "null".into()).replace("</", "<\\/");
    TEMPLATE
        .replacen("<title>gweave preview</title>", &format!("<title>{}</title>", escape(&options.title)), 1)
        .replacen(DATA_SLOT, &json, 1)
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
pub fn base64(bytes: &[u8]) -> String {
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
        let tp =
            Toolpath { segments: vec![s], layer_z_mm: vec![0.2], tools: 2, on_cylinder: false, heads: false };
        let options = HtmlOptions {
            title: "a</script>b".into(),
            colour_by: ColourBy::Tool,
            view: ViewKind::Top,
            layer: None,
            tool_colours: vec![],
        };
        let html = write_html(&tp, None, &options);
        assert!(!html.contains(DATA_SLOT));
        assert!(!html.contains("http://") && !html.contains("https://"), "no network");
        assert_eq!(html.matches("</script>").count(), 1, "the title cannot end the script");
        // Start (0, 0, 0.2) is the low corner, end the high one: 0 and 65535 (ff ff) on each axis.
        let pos = base64(&[0, 0, 0, 0, 0, 0, 255, 255, 255, 255, 0, 0]);
        assert!(html.contains(&format!("\"pos\":\"{pos}\"")), "z span is 0: quantised to 0");
        assert!(html.contains("\"feed\":\"+gA=\""), "250 tenths of mm/s");
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
            on_cylinder: false,
            heads: false,
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
            layer: None,
            tool_colours: vec![],
        };
        let html = write_html(&few, None, &options);
        assert!(html.contains("\"mix_colours\":[\"#000007\",\"#010007\",\"#020007\"]"));
    }
}
