//! The powder recoat of a binder-jet printer, from the `[recoat]` table of the printhead profile.
//!
//! Between two layers a powder-bed machine lowers the build piston by one layer, raises the
//! feed piston by a little more than that (the powder layer ratio: the spreader pushes some
//! powder past the bed into the overflow, so the layer is full everywhere), and moves a spreader
//! (a counter-rotating roller or a blade) across the whole bed at a slow spreading speed, then
//! back at a faster one. A dwell lets the fresh layer settle before binder lands on it. The
//! binder-jet seed says the printer recoats after each layer without giving the G-code; this
//! writes it, every number from the profile:
//!
//! ```text
//! ; gweave raster: recoat for layer <k>
//! M400                                   ; the last fires and moves are done
//! G1 <build><z_k> F<piston feed>         ; build piston down one layer (the layer's Z)
//! G1 <feed><r * (z_k - z_0)>             ; feed piston up the powder for it
//! G1 <spreader><start> F<return feed>    ; spreader to its start
//! G1 <spreader><start + stroke> F<spread feed>
//! G1 <spreader><start> F<return feed>
//! G4 P<dwell ms>
//! ```
//!
//! The virtual printer checks what it does (`gweave-sim`'s inkjet canvas): pistons moved by the
//! layer height (feed by the ratio), the spreader across the whole bed, and no fire during it.
//!
//! ```toml
//! [recoat]
//! spreader_axis = "Y"        # the axis that carries the roller or blade
//! spreader_start_mm = -20.0  # its parked position, before the bed
//! spreader_stroke_mm = 260.0 # its travel: past the whole bed
//! spread_feed_mm_min = 300.0
//! return_feed_mm_min = 3000.0
//! piston_feed_mm_min = 120.0
//! feed_piston_axis = "A"
//! build_piston_axis = "Z"
//! powder_ratio = 1.5         # feed piston rise per layer height
//! dwell_s = 0.5
//! ```

use serde::{Deserialize, Serialize};

use super::gcode_text::push_num;
use crate::range::{self, OutOfRange, Range};
use crate::settings::{CheckRanges, Table};

/// Feed piston rise over the layer height: 1 is just the layer, 3 floods the overflow.
pub const POWDER_RATIO: Range = Range::new(1.0, 3.0, "");

/// How the machine spreads a powder layer (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recoat {
    /// The axis that carries the roller or blade.
    pub spreader_axis: char,
    /// The spreader's parked position, before the bed, mm.
    pub spreader_start_mm: f64,
    /// The spreader's travel across the bed, mm.
    pub spreader_stroke_mm: f64,
    /// Spreader feed while spreading, mm/min.
    pub spread_feed_mm_min: f64,
    /// Spreader feed on the way back, mm/min.
    pub return_feed_mm_min: f64,
    /// Feed of both pistons, mm/min.
    pub piston_feed_mm_min: f64,
    /// The axis of the feed (powder supply) piston.
    pub feed_piston_axis: char,
    /// The axis of the build piston (the layer's Z).
    #[serde(default = "default_build_axis")]
    pub build_piston_axis: char,
    /// Feed piston rise per layer height, 1 to 3 ([`POWDER_RATIO`]).
    pub powder_ratio: f64,
    /// Settling time after spreading, s.
    #[serde(default)]
    pub dwell_s: f64,
}

fn default_build_axis() -> char {
    'Z'
}

/// Letters a recoat axis may have (the carriage's X and Y, Z, and extra axes; not E).
const AXES: &str = "XYZABCUVW";

impl CheckRanges for Recoat {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("spreader_start_mm", self.spreader_start_mm, range::POSITION_MM)?;
        t.check("spreader_stroke_mm", self.spreader_stroke_mm, range::SIZE_MM)?;
        t.check("spread_feed_mm_min", self.spread_feed_mm_min, range::FEED_MM_MIN)?;
        t.check("return_feed_mm_min", self.return_feed_mm_min, range::FEED_MM_MIN)?;
        t.check("piston_feed_mm_min", self.piston_feed_mm_min, range::FEED_MM_MIN)?;
        t.check("powder_ratio", self.powder_ratio, POWDER_RATIO)?;
        t.check("dwell_s", self.dwell_s, range::PERIOD_S)
    }
}

impl Recoat {
    /// The three axes must be distinct motion axes. Returns the reason when they are not.
    pub(crate) fn axes_problem(&self) -> Option<String> {
        let axes = [self.spreader_axis, self.feed_piston_axis, self.build_piston_axis];
        if let Some(a) = axes.iter().find(|a| !AXES.contains(**a)) {
            return Some(format!("[recoat] axis `{a}` is not one of {AXES}"));
        }
        let distinct = axes[0] != axes[1] && axes[1] != axes[2] && axes[0] != axes[2];
        (!distinct)
            .then(|| format!("[recoat] spreader, feed and build piston axes must differ, got {axes:?}"))
    }

    /// Appends the recoat before layer `layer` at Z `z_mm`, the first layer being at
    /// `first_z_mm`; numbers with `decimals` places.
    pub fn write(&self, out: &mut Vec<u8>, layer: u64, z_mm: f64, first_z_mm: f64, decimals: u32) {
        let mv = |out: &mut Vec<u8>, axis: char, pos: f64, feed: Option<f64>| {
            out.extend_from_slice(b"G1 ");
            out.push(axis as u8);
            push_num(out, pos, decimals);
            if let Some(f) = feed {
                out.extend_from_slice(b" F");
                push_num(out, f, decimals);
            }
            out.push(b'\n');
        };
        out.extend_from_slice(format!("; gweave raster: recoat for layer {layer}\nM400\n").as_bytes());
        mv(out, self.build_piston_axis, z_mm, Some(self.piston_feed_mm_min));
        mv(out, self.feed_piston_axis, self.powder_ratio * (z_mm - first_z_mm), None);
        let (start, end) = (self.spreader_start_mm, self.spreader_start_mm + self.spreader_stroke_mm);
        mv(out, self.spreader_axis, start, Some(self.return_feed_mm_min));
        mv(out, self.spreader_axis, end, Some(self.spread_feed_mm_min));
        mv(out, self.spreader_axis, start, Some(self.return_feed_mm_min));
        if self.dwell_s > 0.0 {
            out.extend_from_slice(b"G4 P");
            push_num(out, (self.dwell_s * 1000.0).round(), 0);
            out.push(b'\n');
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_support::recoat as example;

    #[test]
    fn recoat_motion_from_the_profile() {
        let mut out = Vec::new();
        example().write(&mut out, 2, 0.3, 0.1, 4);
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "; gweave raster: recoat for layer 2\nM400\nG1 Z0.3 F120\nG1 A0.3\n\
             G1 Y-20 F3000\nG1 Y240 F300\nG1 Y-20 F3000\nG4 P500\n"
        );
    }

    #[test]
    fn axes_must_be_distinct_motion_axes() {
        assert_eq!(example().axes_problem(), None);
        let e = Recoat { feed_piston_axis: 'E', ..example() };
        assert!(e.axes_problem().unwrap().contains("`E` is not one of"));
        let same = Recoat { feed_piston_axis: 'Z', ..example() };
        assert!(same.axes_problem().unwrap().contains("must differ"));
        let t = Table::root().sub("recoat");
        let bad = Recoat { powder_ratio: 0.5, ..example() };
        assert!(bad.check_ranges(&t).unwrap_err().to_string().contains("[recoat] powder_ratio"));
    }
}
