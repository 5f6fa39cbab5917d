//! What colour each segment is drawn in: by tool, feature type, speed, layer, or the colour a
//! mixing hotend is predicted to print.
//!
//! Speed and layer use a ramp from blue (slow, low) to red (fast, high), interpolated in CIELAB
//! so that equal steps look equally different, precomputed into a 256-entry table so that the
//! per-segment cost is one lookup.
//!
//! The mix colouring draws each segment in its [`Segment::mix_rgb`], the colour the mixing model
//! and the chamber's washout predict for it (`mix_colour`): read the toolpath with
//! [`super::ToolpathOptions::mix`] set.

use std::collections::HashMap;
use std::fmt;
use std::str::FromStr;

use palette::Mix as _;

use crate::colour::{Lab, Srgb8};
use crate::gcode::layers::{Feature, ALL_FEATURES};

use super::toolpath::{Segment, Toolpath};

/// The attribute that picks a segment's colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColourBy {
    /// Each tool its colour.
    #[default]
    Tool,
    /// Each feature (wall, infill, support...) its colour.
    Feature,
    /// Feed rate, slow to fast on a colour ramp.
    Speed,
    /// Layer, bottom to top on a colour ramp.
    Layer,
    /// Predicted printed colour of each move ([`Segment::mix_rgb`]).
    Mix,
}

impl ColourBy {
    /// Every colouring, in the order `--colour-by` lists them.
    pub const ALL: [ColourBy; 5] =
        [ColourBy::Tool, ColourBy::Feature, ColourBy::Speed, ColourBy::Layer, ColourBy::Mix];

    /// The colouring's name for `--colour-by`.
    pub fn name(self) -> &'static str {
        match self {
            ColourBy::Tool => "tool",
            ColourBy::Feature => "feature",
            ColourBy::Speed => "speed",
            ColourBy::Layer => "layer",
            ColourBy::Mix => "mix",
        }
    }
}

impl fmt::Display for ColourBy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ColourBy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        ColourBy::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| format!("unknown colour-by {s:?} (tool, feature, speed, layer or mix)"))
    }
}

/// Distinct tool colours, chosen to stay apart for common colour-vision deficiencies
/// (orange, blue, bluish green, reddish purple, yellow, sky blue, vermilion, grey).
pub const TOOL_COLOURS: [Srgb8; 8] = [
    Srgb8::new(0xe6, 0x9f, 0x00),
    Srgb8::new(0x00, 0x72, 0xb2),
    Srgb8::new(0x00, 0x9e, 0x73),
    Srgb8::new(0xcc, 0x79, 0xa7),
    Srgb8::new(0xf0, 0xe4, 0x42),
    Srgb8::new(0x56, 0xb4, 0xe9),
    Srgb8::new(0xd5, 0x5e, 0x00),
    Srgb8::new(0x80, 0x80, 0x80),
];

/// The colour of each feature type, indexed like [`ALL_FEATURES`] (close to the colours slicer
/// previews use, so that people recognise them).
pub const FEATURE_COLOURS: [Srgb8; 15] = [
    Srgb8::new(0x9e, 0x9e, 0x9e), // unknown
    Srgb8::new(0xff, 0x7d, 0x38), // outer wall
    Srgb8::new(0xff, 0xe6, 0x4d), // inner wall
    Srgb8::new(0x00, 0x00, 0xff), // overhang wall
    Srgb8::new(0xb0, 0x30, 0x29), // infill
    Srgb8::new(0x96, 0x54, 0xcc), // solid infill
    Srgb8::new(0xf0, 0x40, 0x40), // top surface
    Srgb8::new(0x4d, 0x80, 0xba), // bridge
    Srgb8::new(0x00, 0xff, 0x00), // support
    Srgb8::new(0x00, 0x80, 0x00), // support interface
    Srgb8::new(0x00, 0x87, 0x87), // skirt
    Srgb8::new(0xb3, 0xe3, 0xab), // wipe tower
    Srgb8::new(0xff, 0x8c, 0x69), // ironing
    Srgb8::new(0xff, 0xff, 0xff), // gap fill
    Srgb8::new(0x5e, 0xd1, 0x94), // custom
];

/// Colours listed in the legend of the mix colouring.
const MIX_LEGEND_ENTRIES: usize = 6;
/// Colours closer than this on every channel share a legend entry.
const MIX_LEGEND_NEAR: u8 = 12;

/// Travel moves, when drawn.
pub const TRAVEL_COLOUR: Srgb8 = Srgb8::new(0x40, 0x60, 0xa0);

/// Stops of the speed and layer ramp, low to high.
const RAMP_STOPS: [Srgb8; 5] = [
    Srgb8::new(0x2b, 0x3a, 0xb8),
    Srgb8::new(0x1f, 0x9e, 0xd6),
    Srgb8::new(0x3c, 0xc0, 0x4a),
    Srgb8::new(0xf2, 0xc9, 0x1b),
    Srgb8::new(0xd6, 0x27, 0x28),
];

/// A ramp precomputed at 256 steps.
fn ramp_table() -> Vec<[u8; 3]> {
    let labs: Vec<Lab> = RAMP_STOPS.iter().map(|&c| Lab::from(c)).collect();
    let spans = (labs.len() - 1) as f64;
    (0..256)
        .map(|i| {
            let x = i as f64 / 255.0 * spans;
            let k = (x.floor() as usize).min(labs.len() - 2);
            let c = Srgb8::from(labs[k].mix(labs[k + 1], x - k as f64));
            [c.r, c.g, c.b]
        })
        .collect()
}

/// One entry of a legend.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LegendEntry {
    /// What the colour stands for: a tool, a feature, a speed or layer band, a mix.
    pub label: String,
    /// The colour drawn.
    pub colour: Srgb8,
}

/// A colouring fitted to one toolpath.
#[derive(Debug, Clone)]
pub struct Colouring {
    /// The attribute the colours stand for.
    pub by: ColourBy,
    /// Per-tool colours (tool colouring); missing tools fall back to [`TOOL_COLOURS`].
    pub tool_colours: Vec<Srgb8>,
    /// Extruding feed-rate range, mm/s.
    speed_mm_s: (f32, f32),
    /// Layer range drawn.
    layers: (u32, u32),
    ramp: Vec<[u8; 3]>,
}

impl Colouring {
    /// Fits the ranges (speed, layer) to the segments that will be drawn.
    pub fn new(by: ColourBy, tool_colours: Vec<Srgb8>, toolpaths: &[&Toolpath]) -> Self {
        let mut speed = (f32::INFINITY, f32::NEG_INFINITY);
        let mut layers = (u32::MAX, 0);
        for s in toolpaths.iter().flat_map(|t| &t.segments).filter(|s| s.extruding) {
            speed = (speed.0.min(s.feed_mm_s), speed.1.max(s.feed_mm_s));
            layers = (layers.0.min(s.layer), layers.1.max(s.layer));
        }
        if speed.0 > speed.1 {
            speed = (0.0, 0.0);
            layers = (0, 0);
        }
        Colouring { by, tool_colours, speed_mm_s: speed, layers, ramp: ramp_table() }
    }

    fn tool_colour(&self, tool: u16) -> Srgb8 {
        let t = tool as usize;
        self.tool_colours.get(t).copied().unwrap_or(TOOL_COLOURS[t % TOOL_COLOURS.len()])
    }

    fn ramp_at(&self, v: f32, lo: f32, hi: f32) -> [u8; 3] {
        let f = if hi > lo { ((v - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 };
        self.ramp[(f * 255.0).round() as usize]
    }

    /// The colour of one segment (travel is [`TRAVEL_COLOUR`] whatever the colouring).
    pub fn colour(&self, s: &Segment) -> [u8; 3] {
        if !s.extruding {
            return [TRAVEL_COLOUR.r, TRAVEL_COLOUR.g, TRAVEL_COLOUR.b];
        }
        let c = match self.by {
            ColourBy::Tool => self.tool_colour(s.tool),
            ColourBy::Mix => return s.mix_rgb,
            ColourBy::Feature => FEATURE_COLOURS[s.feature as usize],
            ColourBy::Speed => return self.ramp_at(s.feed_mm_s, self.speed_mm_s.0, self.speed_mm_s.1),
            ColourBy::Layer => {
                return self.ramp_at(s.layer as f32, self.layers.0 as f32, self.layers.1 as f32)
            }
        };
        [c.r, c.g, c.b]
    }

    /// What the colours mean, for the segments in `toolpaths`.
    pub fn legend(&self, toolpaths: &[&Toolpath]) -> Vec<LegendEntry> {
        let entry = |label: String, c: [u8; 3]| LegendEntry { label, colour: Srgb8::new(c[0], c[1], c[2]) };
        let extruding = || toolpaths.iter().flat_map(|t| &t.segments).filter(|s| s.extruding);
        match self.by {
            ColourBy::Tool => {
                let mut used: Vec<u16> = extruding().map(|s| s.tool).collect();
                used.sort_unstable();
                used.dedup();
                // Binder-jet drops come from inkjet heads, not extruders.
                let heads = toolpaths.iter().any(|t| t.heads);
                used.into_iter()
                    .map(|t| {
                        let c = self.tool_colour(t);
                        entry(if heads { format!("head {t}") } else { format!("T{t}") }, [c.r, c.g, c.b])
                    })
                    .collect()
            }
            ColourBy::Mix => {
                // The colours printed longest (settled mixes; transitions are short).
                let mut length_mm: HashMap<[u8; 3], f32> = HashMap::new();
                extruding().for_each(|s| *length_mm.entry(s.mix_rgb).or_default() += s.len_mm());
                let mut by_length: Vec<([u8; 3], f32)> = length_mm.into_iter().collect();
                by_length.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
                // The tail of a washout differs from the settled colour by a level or two: one
                // entry for colours closer than that.
                let mut shown: Vec<[u8; 3]> = Vec::new();
                for (c, _) in by_length {
                    let near = |o: &[u8; 3]| (0..3).all(|k| c[k].abs_diff(o[k]) <= MIX_LEGEND_NEAR);
                    if shown.len() < MIX_LEGEND_ENTRIES && !shown.iter().any(near) {
                        shown.push(c);
                    }
                }
                // Named by the mix that prints the colour (a palette name or its ratios).
                let name = |c: [u8; 3]| {
                    toolpaths
                        .iter()
                        .find_map(|t| t.mix_names.get(&c).cloned())
                        .unwrap_or_else(|| Srgb8::new(c[0], c[1], c[2]).to_string())
                };
                shown.into_iter().map(|c| entry(name(c), c)).collect()
            }
            ColourBy::Feature => {
                let mut seen = [false; ALL_FEATURES.len()];
                extruding().for_each(|s| seen[s.feature as usize] = true);
                ALL_FEATURES
                    .iter()
                    .filter(|f| seen[**f as usize])
                    .map(|f: &Feature| {
                        let c = FEATURE_COLOURS[*f as usize];
                        entry(f.name().replace('_', " "), [c.r, c.g, c.b])
                    })
                    .collect()
            }
            ColourBy::Speed => {
                let (lo, hi) = self.speed_mm_s;
                (0..5)
                    .map(|i| {
                        let v = lo + (hi - lo) * i as f32 / 4.0;
                        entry(format!("{v:.0} mm/s"), self.ramp_at(v, lo, hi))
                    })
                    .collect()
            }
            ColourBy::Layer => {
                let (lo, hi) = self.layers;
                let n = (hi - lo).min(4);
                (0..=n)
                    .map(|i| {
                        let l = lo + (hi - lo) * i / n.max(1);
                        entry(format!("layer {l}"), self.ramp_at(l as f32, lo as f32, hi as f32))
                    })
                    .collect()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(tool: u16, feed: f32, layer: u32) -> Segment {
        Segment {
            start: [0.0; 3],
            end: [1.0, 0.0, 0.0],
            tool,
            feature: Feature::Infill,
            feed_mm_s: feed,
            layer,
            extruding: true,
            mix_rgb: [tool as u8, 0, 0],
        }
    }

    #[test]
    fn ramp_runs_blue_to_red() {
        let tp = Toolpath {
            segments: vec![seg(0, 10.0, 0), seg(0, 50.0, 9)],
            layer_z_mm: vec![0.0; 10],
            tools: 1,
            ..Toolpath::default()
        };
        let c = Colouring::new(ColourBy::Speed, vec![], &[&tp]);
        let slow = c.colour(&tp.segments[0]);
        let fast = c.colour(&tp.segments[1]);
        assert_eq!(slow, [0x2b, 0x3a, 0xb8]);
        assert_eq!(fast, [0xd6, 0x27, 0x28]);
        let by_layer = Colouring::new(ColourBy::Layer, vec![], &[&tp]);
        assert_eq!(by_layer.colour(&tp.segments[1]), fast);
        assert_eq!(by_layer.legend(&[&tp]).len(), 5);
    }

    #[test]
    fn tool_table_overrides_defaults_and_mix_draws_each_segments_colour() {
        let red = Srgb8::new(200, 10, 10);
        let mut long = seg(2, 10.0, 0);
        long.end = [5.0, 0.0, 0.0];
        long.mix_rgb = [200, 0, 0];
        let tp = Toolpath {
            segments: vec![seg(1, 10.0, 0), long],
            layer_z_mm: vec![0.0],
            tools: 3,
            mix_names: [([200, 0, 0], "Red".to_owned())].into(),
            ..Toolpath::default()
        };
        let c = Colouring::new(ColourBy::Tool, vec![TOOL_COLOURS[0], red], &[&tp]);
        assert_eq!(c.colour(&tp.segments[0]), [200, 10, 10]);
        let t2 = TOOL_COLOURS[2];
        assert_eq!(c.colour(&tp.segments[1]), [t2.r, t2.g, t2.b], "no table entry: default colour");
        let m = Colouring::new(ColourBy::Mix, vec![], &[&tp]);
        assert_eq!(m.colour(&tp.segments[0]), [1, 0, 0]);
        let mut near = tp.clone();
        near.segments[1].mix_rgb = [9, 2, 0];
        assert_eq!(m.legend(&[&near]).len(), 1, "a washout's tail shares its colour's entry");
        let legend = m.legend(&[&tp]);
        assert_eq!(legend.len(), 2);
        assert_eq!(
            (legend[0].label.as_str(), legend[0].colour),
            ("Red", Srgb8::new(200, 0, 0)),
            "longest first, by the name of its mix"
        );
        assert_eq!(legend[1].label, "#010000", "a colour without a name shows its value");
    }

    #[test]
    fn parses_names() {
        for c in ColourBy::ALL {
            assert_eq!(c.name().parse::<ColourBy>(), Ok(c));
        }
        assert!("rainbow".parse::<ColourBy>().is_err());
    }
}
