//! What colour each segment is drawn in: by tool, feature type, speed, layer, or the colour a
//! mixing hotend is predicted to print.
//!
//! Speed and layer use a ramp from blue (slow, low) to red (fast, high), interpolated in CIELAB
//! so that equal steps look equally different, precomputed into a 256-entry table so that the
//! per-segment cost is one lookup.
//!
//! The mix hook: [`ColourBy::Mix`] colours each segment by its tool's entry in a per-tool table
//! of predicted colours. [`mix_table`] fills that table from the mixing model
//! ([`crate::colour::MixingModel::predict`]) for one [`Mix`] per virtual tool; the mix pass (and
//! its washout model, which makes the colour change gradually after a tool change) will hand
//! over a table or, later, per-segment colours through the same [`Colouring::tool_colours`].

use std::fmt;
use std::str::FromStr;

use crate::colour::{Lab, Mix, MixError, MixingModel, Srgb8};
use crate::gcode::layers::{Feature, ALL_FEATURES};

use super::toolpath::{Segment, Toolpath};

/// The attribute that picks a segment's colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColourBy {
    #[default]
    Tool,
    Feature,
    Speed,
    Layer,
    /// Predicted printed colour of each tool's mix (from [`Colouring::tool_colours`]).
    Mix,
}

impl ColourBy {
    pub const ALL: [ColourBy; 5] =
        [ColourBy::Tool, ColourBy::Feature, ColourBy::Speed, ColourBy::Layer, ColourBy::Mix];

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
    let labs: Vec<Lab> = RAMP_STOPS.iter().map(|&c| Lab::from_srgb8(c)).collect();
    let spans = (labs.len() - 1) as f64;
    (0..256)
        .map(|i| {
            let x = i as f64 / 255.0 * spans;
            let k = (x.floor() as usize).min(labs.len() - 2);
            let c = labs[k].lerp(labs[k + 1], x - k as f64).to_srgb8();
            [c.r, c.g, c.b]
        })
        .collect()
}

/// Predicted colours for one mix per virtual tool (the `mix` colouring's table).
pub fn mix_table(model: &MixingModel, tool_mixes: &[Mix]) -> Result<Vec<Srgb8>, MixError> {
    tool_mixes.iter().map(|m| model.predict(m)).collect()
}

/// One entry of a legend.
#[derive(Debug, Clone, PartialEq)]
pub struct LegendEntry {
    pub label: String,
    pub colour: Srgb8,
}

/// A colouring fitted to one toolpath.
#[derive(Debug, Clone)]
pub struct Colouring {
    pub by: ColourBy,
    /// Per-tool colours (tool and mix colourings); missing tools fall back to [`TOOL_COLOURS`].
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
            ColourBy::Tool | ColourBy::Mix => self.tool_colour(s.tool),
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
            ColourBy::Tool | ColourBy::Mix => {
                let mut used: Vec<u16> = extruding().map(|s| s.tool).collect();
                used.sort_unstable();
                used.dedup();
                used.into_iter()
                    .map(|t| {
                        let c = self.tool_colour(t);
                        let label =
                            if self.by == ColourBy::Mix { format!("T{t} {c}") } else { format!("T{t}") };
                        entry(label, [c.r, c.g, c.b])
                    })
                    .collect()
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
        }
    }

    #[test]
    fn ramp_runs_blue_to_red() {
        let tp = Toolpath {
            segments: vec![seg(0, 10.0, 0), seg(0, 50.0, 9)],
            layer_z_mm: vec![0.0; 10],
            tools: 1,
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
    fn tool_table_overrides_defaults_and_mix_uses_the_model() {
        let model = MixingModel::new(&[Srgb8::new(0, 255, 255), Srgb8::new(255, 255, 0)]).unwrap();
        let table =
            mix_table(&model, &[Mix::new(&[1.0, 0.0]).unwrap(), Mix::new(&[0.5, 0.5]).unwrap()]).unwrap();
        assert_eq!(table[0], model.predict(&Mix::new(&[1.0, 0.0]).unwrap()).unwrap());
        // Cyan and yellow mix subtractively to a green: green channel dominates.
        assert!(table[1].g > table[1].r && table[1].g > table[1].b, "{}", table[1]);
        let tp =
            Toolpath { segments: vec![seg(1, 10.0, 0), seg(2, 10.0, 0)], layer_z_mm: vec![0.0], tools: 3 };
        let c = Colouring::new(ColourBy::Mix, table.clone(), &[&tp]);
        assert_eq!(c.colour(&tp.segments[0]), [table[1].r, table[1].g, table[1].b]);
        let t2 = TOOL_COLOURS[2];
        assert_eq!(c.colour(&tp.segments[1]), [t2.r, t2.g, t2.b], "no table entry: default colour");
        let legend = c.legend(&[&tp]);
        assert_eq!(legend[0].label, format!("T1 {}", table[1]));
    }

    #[test]
    fn parses_names() {
        for c in ColourBy::ALL {
            assert_eq!(c.name().parse::<ColourBy>(), Ok(c));
        }
        assert!("rainbow".parse::<ColourBy>().is_err());
    }
}
