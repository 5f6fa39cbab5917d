//! The fallbacks for a change with too little room before it: what is missing of the purge
//! (the shortfall) is extruded right after the change, before the new colour's own path.
//!
//! - `block`: `gweave mix`'s purge block ([`crate::post::purge_block`]): retract, lift, travel to
//!   the purge spot, extrude the shortfall in place, wipe, come back, lower, unretract, and
//!   `G92 E` back to the E the file had. In the file's own E mode (M82/M83, `G92` respected).
//! - `tower`: the same sequence with the file's own retraction around the travels, no lift by
//!   default, and the blob replaced by a compact zigzag at the layer's Z, a layer of a small
//!   purge tower beside the part. Its flow is that of a line `w` wide and `h` high, so a
//!   shortfall `s` mm of filament (cross-section `A`) is a path of
//!
//!   ```text
//!   L = s A / (w h),   rows n = ceil(sqrt(L / w)),   row length (L - (n - 1) w) / n
//!   ```
//!
//!   a patch about `sqrt(L w)` on a side. It goes `gap_mm` to the right of the print's XY extent
//!   seen so far (to the left if the bed ends there), or at a configured corner; a second tower
//!   on the same layer goes behind the first.
//!
//! Either way the block starts and ends at the exact position of the change (XYZ as written,
//! E by `G92 E`), so every line after it prints as before: only the filament of the purge and
//! the block's own lines are added.

use super::config::{Fallback, Rules, TowerConfig};
use crate::gcode::number::NumberFormat;
use crate::gcode::retraction::Retraction;
use crate::gcode::state::{Move, X, Y};
use crate::post::purge_block::{write_purge_job, PurgeJob, PurgeMotion, PurgePattern, PurgeStart};

/// Inserted lines carry the split's precision: 0.01 um positions, 1e-6 mm of filament.
pub(super) const FORMAT: NumberFormat = NumberFormat {
    position_decimals: super::split::POSITION_DECIMALS,
    extrusion_decimals: super::split::E_DECIMALS,
    feed_decimals: 0,
    trim_zeros: true,
    drop_leading_zero: false,
};

/// The machine where a change sits: where a fallback purge starts and must return to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Spot {
    pub start: PurgeStart,
    /// G20 in force: the fallbacks write millimetres and are skipped.
    pub inches: bool,
}

/// What the pass has seen that the fallbacks need.
#[derive(Debug, Clone, Default)]
pub(crate) struct Surroundings {
    /// XY extent of the print's extrusion so far: min X, min Y, max X, max Y, mm.
    extent: Option<[f64; 4]>,
    /// The file's last ordinary retraction (an E-only move backwards between two extrusions of
    /// one tool), mm, and its feed, mm/min; a retraction before a tool change (often much
    /// longer, to unload) does not count.
    retract_mm: f64,
    retract_feed_mm_min: Option<f64>,
    /// The last retraction since the last extrusion: ordinary if an extrusion comes before a change.
    pending: Option<(f64, f64)>,
    /// The layer of the last tower, and the Y its towers take up so far on that layer, mm.
    tower_layer: Option<u32>,
    tower_used_y_mm: f64,
}

impl Surroundings {
    /// Follows one move of the file.
    pub(super) fn observe(&mut self, mv: &Move, in_print: bool) {
        let e_mm = mv.e_mm();
        if mv.is_extruding() {
            if let Some((mm, feed)) = self.pending.take() {
                self.retract_mm = mm;
                self.retract_feed_mm_min = Some(feed).filter(|f| *f > 0.0);
            }
            if in_print {
                let [x0, y0, x1, y1] = self.extent.unwrap_or([
                    f64::INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NEG_INFINITY,
                ]);
                self.extent = Some([
                    x0.min(mv.from[X]).min(mv.to[X]),
                    y0.min(mv.from[Y]).min(mv.to[Y]),
                    x1.max(mv.from[X]).max(mv.to[X]),
                    y1.max(mv.from[Y]).max(mv.to[Y]),
                ]);
            }
        } else if e_mm < 0.0 && Retraction::moves_filament_only(mv) {
            self.pending = Some((-e_mm, mv.feed_mm_min));
        }
    }

    /// A change of tool or mix: the retraction before it was the slicer's tool-change one.
    pub(super) fn tool_change(&mut self) {
        self.pending = None;
    }

    /// The tower's zigzag for `purge_mm` and its corner on layer `layer`.
    fn tower(
        &mut self,
        t: &TowerConfig,
        area_mm2: f64,
        purge_mm: f64,
        layer: Option<u32>,
    ) -> (PurgePattern, [f64; 2]) {
        let w = t.line_width_mm;
        let path_mm = purge_mm * area_mm2 / (w * t.layer_height_mm);
        let rows = (path_mm / w).sqrt().ceil().max(1.0);
        let row_mm = (path_mm - (rows - 1.0) * w) / rows;
        let depth_mm = (rows - 1.0) * w;
        let [bed_x, bed_y] = t.bed_mm;
        let (x, y) = match (t.x_mm, t.y_mm, self.extent) {
            (Some(x), Some(y), _) => (x, y),
            (_, _, Some([_, y0, x1, _])) if x1 + t.gap_mm + row_mm <= bed_x => (x1 + t.gap_mm, y0),
            (_, _, Some([x0, y0, ..])) => (x0 - t.gap_mm - row_mm, y0),
            _ => (0.0, 0.0),
        };
        if self.tower_layer != layer {
            (self.tower_layer, self.tower_used_y_mm) = (layer, 0.0);
        }
        let mut y = y + self.tower_used_y_mm;
        if y + depth_mm > bed_y {
            // No room behind the last tower on this layer: start again in front.
            y -= self.tower_used_y_mm;
            self.tower_used_y_mm = 0.0;
        }
        self.tower_used_y_mm += depth_mm + 2.0 * w;
        let clamp = |v: f64, size: f64, bed: f64| v.min(bed - size).max(0.0);
        let pattern = PurgePattern::Zigzag { rows: rows as u32, row_mm, pitch_mm: w };
        (pattern, [clamp(x, row_mm, bed_x), clamp(y, depth_mm, bed_y)])
    }
}

/// The fallback purge of `purge_mm` at `spot` as `\n`-terminated lines, or `None` when the rules
/// say `partial` (or the file is in inches, which the purge blocks do not write).
pub(crate) fn write_fallback(
    rules: &Rules,
    env: &mut Surroundings,
    spot: &Spot,
    layer: Option<u32>,
    purge_mm: f64,
    label: &str,
) -> Option<Vec<u8>> {
    if spot.inches || purge_mm <= 0.0 {
        return None;
    }
    let (motion, pattern) = match rules.fallback {
        Fallback::Partial => return None,
        Fallback::Block => (rules.block, PurgePattern::Blob),
        Fallback::Tower => {
            let t = &rules.tower;
            let (pattern, [x_mm, y_mm]) = env.tower(t, rules.mm3(1.0), purge_mm, layer);
            let motion = PurgeMotion {
                retract_mm: env.retract_mm,
                lift_mm: t.lift_mm,
                x_mm,
                y_mm,
                wipe_mm: 0.0,
                travel_feed_mm_min: t.travel_feed_mm_min,
                extrude_feed_mm_min: t.extrude_feed_mm_min,
                retract_feed_mm_min: env.retract_feed_mm_min.unwrap_or(t.retract_feed_mm_min),
                ..rules.block
            };
            (motion, pattern)
        }
    };
    let by = "purge-shift";
    let mut out = Vec::new();
    write_purge_job(
        &mut out,
        &FORMAT,
        &motion,
        &spot.start,
        &PurgeJob { purge_mm, pattern, by, label, refill_mm: 0.0 },
    );
    Some(out)
}
