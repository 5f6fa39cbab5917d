//! Helical unwrapping and the part's width round the mandrel (the rotary seed's weld line).
//!
//! ## The weld line, and winding each layer as a helix
//! A flat part wrapped layer by layer closes each layer on itself where flat `y = 0` meets
//! `y = C` (the circumference): every layer starts and ends on the same line down the part,
//! and the seed reports that line as the weakest place of the print. The seed's remedy is to
//! unwrap the part *helically*: the radial height rises by one layer height `h` per turn, so a
//! layer is one turn of a helicoid and its end meets the next layer's start at the same height.
//!
//! For layer `k` at flat height `z_k`, with `h = z_k - z_(k-1)`, a flat point `(x, y, z)` goes to
//!
//! ```text
//! theta = 360 (y - y0) / C            (as the flat wrap)
//! r     = R0 + z - h (1 - (y - y0)/C)  (the flat radius, lowered by the part of a turn to come)
//! ```
//!
//! where `y0` is the part's smallest `y`. So at `y = y0 + C` layer `k` is at `R0 + z_k`, exactly
//! where layer `k + 1` starts at `y0` (same angle, same radius): no step and no seam. The radius
//! is linear in `y`, and so in the angle: a chord the machine interpolates linearly in (A, Z)
//! lies on the helix, whatever its length.
//!
//! The first layer stays on its cylinder (nothing below it to ramp on). The second ramps up from
//! it, so the gap under the nozzle grows from 0 to `h` over its turn; its extrusion is scaled by
//! that fraction, as PrusaSlicer's spiral vase does for its first spiral layer. From the third
//! layer on the gap is `h` everywhere and E is the flat wrap's. The ramp's own slope, `h/C`
//! (0.002 for 0.2 mm on a 30 mm mandrel), lengthens a bead by less than 1e-5: not counted.
//!
//! ## Parts wider than the circumference
//! A flat part whose extrusions span more than `C` in `y` wraps over itself. The wrap reads the
//! file once before writing to find that span and refuses such a part, naming both widths,
//! unless overlap is allowed ([`check_width`]).

use std::io::Write;

use super::cylinder::RotaryConfig;
use super::{Result, RotaryError};
use crate::gcode::layers::{Region, Structure};
use crate::gcode::state::{Effect, Y};
use crate::pass::{Ctx, Flow, Pass, Step};
use crate::run::Run;

/// The `y` range of a part's extrusions in the print proper, mm (arcs by their end points).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartExtent {
    pub y_min_mm: f64,
    pub y_max_mm: f64,
}

impl PartExtent {
    pub fn width_mm(&self) -> f64 {
        self.y_max_mm - self.y_min_mm
    }
}

#[derive(Default)]
struct ExtentPass {
    extent: Option<PartExtent>,
}

impl Pass for ExtentPass {
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        if let Effect::Move(m) = ctx.effect {
            if m.is_extruding() && ctx.state.structure.region == Region::Print {
                let (a, b) = (m.from[Y], m.to[Y]);
                let e = self.extent.get_or_insert(PartExtent { y_min_mm: a, y_max_mm: a });
                e.y_min_mm = e.y_min_mm.min(a).min(b);
                e.y_max_mm = e.y_max_mm.max(a).max(b);
            }
        }
        Ok(Flow::Continue)
    }

    fn reads_words(&self) -> bool {
        false
    }
}

/// The extent of the part `run` reads (`None`: no extrusion in the print proper), read
/// before the run proper.
pub(crate) fn part_extent(run: &mut Run<'_>) -> crate::Result<Option<PartExtent>> {
    let mut pass = ExtentPass::default();
    run.prescan(&mut pass)?;
    Ok(pass.extent)
}

/// Refuses a part wider than the circumference, unless `allow_overlap`.
pub(crate) fn check_width(
    machine: &RotaryConfig,
    extent: Option<PartExtent>,
    allow_overlap: bool,
) -> Result<()> {
    let (Some(e), false) = (extent, allow_overlap) else { return Ok(()) };
    let c = machine.circumference_mm();
    // A part that closes on itself spans C less a bead width; rounding in the file's last
    // digit must not refuse it.
    if e.width_mm() <= c + 1e-3 {
        return Ok(());
    }
    Err(RotaryError::WiderThanMandrel(format!(
            "the part's extrusions span {:.3} mm round the mandrel (flat Y {:.3} .. {:.3}), more than its \
             circumference {c:.3} mm (mandrel {:.3} mm): it would wrap over itself ({:.1} deg); use a mandrel \
             of at least {:.3} mm, or allow it with --allow-overlap",
            e.width_mm(),
            e.y_min_mm,
            e.y_max_mm,
            machine.mandrel_diameter_mm,
            360.0 * e.width_mm() / c,
            e.width_mm() / std::f64::consts::PI,
    )))
}

/// The helical ramp of the layer being wrapped.
#[derive(Debug, Clone, Default)]
pub(crate) struct Ramp {
    /// Where a turn starts, flat mm.
    y0_mm: f64,
    /// The rise of this layer over the one below, mm (0 on the first layer).
    rise_mm: f64,
    /// The layer ramps off the flat first layer: its extrusion grows with the gap.
    off_flat: bool,
    layer: Option<u32>,
    layer_z_mm: f64,
    /// The Z of the layer below (none on the first).
    below_z_mm: Option<f64>,
    /// Layers entered so far with a ramp (the first has none).
    ramped_layers: u32,
}

impl Ramp {
    pub(crate) fn new(y0_mm: f64) -> Self {
        Ramp { y0_mm, ..Ramp::default() }
    }

    /// Follows the slicer's layers (the Z of a layer may come a line after its start).
    pub(crate) fn observe(&mut self, s: &Structure) {
        if s.layer != self.layer {
            if self.layer.is_some() {
                self.below_z_mm = Some(self.layer_z_mm);
                self.ramped_layers += 1;
            }
            self.off_flat = self.ramped_layers == 1;
            self.layer = s.layer;
        }
        self.layer_z_mm = s.layer_z_mm;
        self.rise_mm = self.below_z_mm.map_or(0.0, |below| (self.layer_z_mm - below).max(0.0));
    }

    /// Fraction of a turn from the ramp's start at flat `y_mm`.
    fn turn(&self, y_mm: f64, circumference_mm: f64) -> f64 {
        (y_mm - self.y0_mm) / circumference_mm
    }

    /// How far below its flat radius the point at `y_mm` goes, mm.
    pub(crate) fn drop_mm(&self, y_mm: f64, circumference_mm: f64) -> f64 {
        self.rise_mm * (1.0 - self.turn(y_mm, circumference_mm))
    }

    /// Factor on the extrusion of a piece from `ya` to `yb`: the gap under the nozzle over the
    /// layer height, at the piece's middle (1 but on the layer that ramps off the flat one).
    pub(crate) fn e_factor(&self, ya: f64, yb: f64, circumference_mm: f64) -> f64 {
        if !self.off_flat {
            return 1.0;
        }
        self.turn(0.5 * (ya + yb), circumference_mm).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn width_over_the_circumference_is_refused_naming_both() {
        // The issue's case: a 94 mm plate on a 20 mm mandrel spans 537 degrees.
        let m = RotaryConfig::new(20.0);
        let plate = PartExtent { y_min_mm: 0.0, y_max_mm: 94.0 };
        let e = check_width(&m, Some(plate), false).unwrap_err().to_string();
        assert!(
            e.contains("span 94.000 mm round the mandrel") && e.contains("circumference 62.832 mm"),
            "{e}"
        );
        assert!(e.contains("(538.6 deg)") && e.contains("at least 29.921 mm"), "{e}");
        assert!(check_width(&m, Some(plate), true).is_ok());
        assert!(check_width(&RotaryConfig::new(30.0), Some(plate), false).is_ok());
        assert!(check_width(&m, None, false).is_ok());
    }

    #[test]
    fn ramp_joins_one_layer_to_the_next() {
        let c = 60.0;
        let mut ramp = Ramp::new(5.0);
        let mut s = Structure::default();
        s.layer = Some(0);
        s.layer_z_mm = 0.2;
        ramp.observe(&s);
        assert_eq!(ramp.drop_mm(30.0, c), 0.0, "the first layer is flat");
        s.layer = Some(1);
        s.layer_z_mm = 0.4;
        ramp.observe(&s);
        // Layer 1 at its start is on layer 0's height; at the end of its turn, on its own.
        assert!((0.4 - ramp.drop_mm(5.0, c) - 0.2).abs() < 1e-12);
        assert!(ramp.drop_mm(65.0, c).abs() < 1e-12);
        assert!((ramp.e_factor(5.0, 35.0, c) - 0.25).abs() < 1e-12, "a quarter of the gap a quarter turn in");
        s.layer = Some(2);
        s.layer_z_mm = 0.6;
        ramp.observe(&s);
        assert!((0.6 - ramp.drop_mm(5.0, c) - 0.4).abs() < 1e-12, "layer 2 starts where layer 1 ended");
        assert_eq!(ramp.e_factor(5.0, 35.0, c), 1.0);
    }
}
