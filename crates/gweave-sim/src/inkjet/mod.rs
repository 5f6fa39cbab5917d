//! Inkjet (binder-jet) executor of the virtual printer: records where the drops land, and
//! checks the powder recoats between layers ([`recoat`]).
//!
//! The interpreter calls [`InkjetCanvas::on_m700`] for every `M700 P<head> S<bits>` (Marlin
//! hpc6602) or `M578 P S` (RepRapFirmware) with the carriage position at that moment. Each set
//! bit of `S` is a nozzle address; the profile's bit order and nozzle map turn it into a
//! physical nozzle row `r`, whose drop lands
//! ([`PrintheadProfile::drops_mm`], the same rule the previews draw with) at
//!
//! ```text
//! x = carriage_x + head_offset_x            y = carriage_y + head_offset_y + r * pitch
//! pixel = floor((x - origin_x) / pitch),  floor((y - origin_y) / pitch)
//! ```
//!
//! with `pitch = 25.4 / dpi`: the generator aims at pixel centres, so rounding of the written
//! coordinates (well under half a pitch) never moves a drop to the next pixel.
//!
//! One canvas per head per layer; a new layer starts when a fire happens at a new Z. Two
//! firmware pitfalls become typed warnings (`sjkelly/Marlin` branch hpc6602, `Marlin_main.cpp`): `M700` runs as soon as it is parsed,
//! so without an `M400` since the last move it fires while the carriage is still travelling;
//! and the firmware reads `S` only when `P` is given, so `M700` without `P` fires nothing.
//!
//! **The time a fire takes.** The InkShield library (`NicholasCLewis/InkShield`,
//! `InkShieldMega.cpp`, `spray_ink`) pulses each set nozzle for 5 us and then waits 800 us
//! (`delayMicroseconds(800)`, "so we don't fire nozzles too fast and burn them out") whatever
//! the mask, even an empty one; the patch calls it from the command parser, which waits too.
//! After an `M400` nothing else runs meanwhile, so each fire adds the profile's
//! `min_fire_interval_us` to the print, as the raster generator's own estimate counts it (the
//! pulses, 60 us at most, are left out of both). A fire without the `M400` waits while the
//! queued moves run on: it costs no time of its own. The estimator counts that wait
//! ([`FireWait`], given by `Estimator::fires`), so `estimate`, `sim` and `raster` agree on an
//! inkjet machine.

pub(crate) mod recoat;

use std::path::{Path, PathBuf};

use gweave::gen::bitmap::{Bitmap, BitmapError};
use gweave::gen::printhead::{PrintheadError, PrintheadProfile};
use gweave::range::{short, Ceiling, TooLarge, MAX_IMAGE_SIDE_PX};
use serde::Serialize;
use thiserror::Error;

/// What a fire costs the print on a machine with a printhead: the firmware's wait after each
/// fire that runs with nothing moving (after an `M400` or a `G4`), for a `P` naming one of its
/// heads (no head fires otherwise, and the patch does not wait).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FireWait {
    /// The wait after one fire, s (the profile's `min_fire_interval_us`).
    pub wait_s: f64,
    /// How many heads the machine has: `P0` up to `P<heads - 1>` fire.
    pub heads: u32,
}

impl FireWait {
    /// The wait of `printhead`'s fires.
    pub fn of(printhead: &PrintheadProfile) -> Self {
        let heads = u32::try_from(printhead.heads.len()).unwrap_or(u32::MAX);
        Self { wait_s: printhead.fire_time_s(1), heads }
    }

    /// The head a `P` word names as the firmware reads it (an integer, negatives as 0).
    pub fn head(p: f64) -> u32 {
        p.max(0.0) as u32
    }

    /// Whether a fire with this `P` word fires one of the heads.
    pub fn fires(&self, p: Option<f64>) -> bool {
        p.is_some_and(|p| Self::head(p) < self.heads)
    }
}

/// Errors of the inkjet executor.
#[derive(Debug, Error)]
pub enum InkjetError {
    #[error(transparent)]
    Profile(#[from] PrintheadError),
    #[error("canvas pixel size must be positive and finite")]
    Geometry,
    #[error(transparent)]
    Image(#[from] BitmapError),
    #[error(transparent)]
    TooLarge(#[from] TooLarge),
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// Something the G-code asked for that a real printer would do wrongly.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum InkjetWarning {
    /// Fire with a move since the last `M400`: the drops land somewhere along the move.
    #[allow(missing_docs)] // the head and the carriage position, mm
    FireWithoutM400 { head: u32, x_mm: f64, y_mm: f64 },
    /// Fire without `P`: the firmware ignores `S`, nothing is fired.
    #[allow(missing_docs)] // the carriage position, mm
    MissingHead { x_mm: f64, y_mm: f64 },
    /// `P` names a head the profile does not have: nothing is fired.
    #[allow(missing_docs)] // the head named
    UnknownHead { head: u32 },
    /// Some drops of this fire fall outside the canvas (`lost` of them).
    #[allow(missing_docs)] // the head, the carriage position (mm) and the drops lost
    OffCanvas { head: u32, x_mm: f64, y_mm: f64, lost: u32 },
    /// A fire after the recoat's pistons moved and before its spreader crossed the bed.
    #[allow(missing_docs)] // the carriage position, mm
    FireDuringRecoat { x_mm: f64, y_mm: f64 },
    /// A new layer fired without any recoat since the last one.
    #[allow(missing_docs)] // the new layer's Z, mm
    NoRecoat { z_mm: f64 },
    /// A recoat piston moved other than the layer height asks (times the powder ratio for the
    /// feed piston).
    #[allow(missing_docs)] // the piston's axis, its travel and the travel expected, mm
    PistonTravel { axis: char, moved_mm: f64, expected_mm: f64 },
    /// The last recoat's spreader did not cross the whole bed.
    #[allow(missing_docs)] // the spreader's reach and the bed's span along its axis, mm
    SpreaderShort { reach_mm: [f64; 2], bed_mm: [f64; 2] },
}

/// The bed area recorded, in nozzle pitches (one pixel = one pitch square).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CanvasGeometry {
    /// Bed X of the canvas' first pixel column, mm.
    pub origin_x_mm: f64,
    /// Bed Y of the canvas' first pixel row, mm.
    pub origin_y_mm: f64,
    /// Width in pixels (nozzle pitches).
    pub width_px: usize,
    /// Height in pixels (nozzle pitches).
    pub height_px: usize,
}

/// The drops of one layer, one bitmap per head (row 0 at the lowest Y).
#[derive(Debug, Clone, PartialEq)]
pub struct InkjetLayer {
    /// The carriage's Z when the layer's first fire ran, mm.
    pub z_mm: f64,
    /// One canvas per head, in head order.
    pub heads: Vec<Bitmap>,
}

/// Collects fired drops into per-layer 1-bit canvases.
#[derive(Debug, Clone)]
pub struct InkjetCanvas {
    geometry: CanvasGeometry,
    /// The heads, which say where a fire command's drops land.
    printhead: PrintheadProfile,
    pitch_mm: f64,
    layers: Vec<InkjetLayer>,
    drops_per_head: Vec<u64>,
}

/// Two Z values closer than this are the same layer.
const SAME_Z_MM: f64 = 1e-6;

impl InkjetCanvas {
    /// An empty canvas for the printhead, over `geometry` of the bed.
    pub fn new(profile: &PrintheadProfile, geometry: CanvasGeometry) -> Result<Self, InkjetError> {
        profile.validate()?;
        if !(geometry.origin_x_mm.is_finite() && geometry.origin_y_mm.is_finite()) {
            return Err(InkjetError::Geometry);
        }
        // Each layer holds a canvas per head: its size is checked before the first is made
        // (a bed of 1e308 mm, or a 1e308 dpi head, asks for an endless canvas).
        let side = Ceiling::new(MAX_IMAGE_SIDE_PX, "pixels per canvas side");
        let because = || {
            format!(
                "the inkjet canvas ({} x {} nozzle pitches of {} mm)",
                geometry.width_px,
                geometry.height_px,
                short(profile.pitch_mm())
            )
        };
        side.check(geometry.width_px.max(geometry.height_px) as f64, because)?;
        Ok(InkjetCanvas {
            geometry,
            printhead: profile.clone(),
            pitch_mm: profile.pitch_mm(),
            layers: Vec::new(),
            drops_per_head: vec![0; profile.heads.len()],
        })
    }

    /// Records one fire command. `head` is the `P` word (None when absent), `bits` the `S`
    /// word, `at_mm` the carriage's X, Y and Z when it runs, and `moved_since_m400`
    /// whether a move was queued after the last `M400`. What was wrong with it is added to
    /// `warnings`: the canvas keeps none, since a file of a million bad fires would grow them
    /// without bound (the machine's report keeps the first ones and counts the rest). The time
    /// it takes is the estimator's (`FireWait`).
    pub fn on_m700(
        &mut self,
        head: Option<u32>,
        bits: u64,
        at_mm: [f64; 3],
        moved_since_m400: bool,
        warnings: &mut Vec<InkjetWarning>,
    ) {
        let [x_mm, y_mm, z_mm] = at_mm;
        let Some(head) = head else {
            warnings.push(InkjetWarning::MissingHead { x_mm, y_mm });
            return;
        };
        let heads = self.printhead.heads.len();
        if head as usize >= heads {
            warnings.push(InkjetWarning::UnknownHead { head });
            return;
        }
        if moved_since_m400 {
            warnings.push(InkjetWarning::FireWithoutM400 { head, x_mm, y_mm });
        }
        let g = self.geometry;
        let same_layer = matches!(self.layers.last(), Some(l) if (l.z_mm - z_mm).abs() <= SAME_Z_MM);
        if !same_layer {
            self.layers.push(InkjetLayer { z_mm, heads: vec![Bitmap::new(g.width_px, g.height_px); heads] });
        }
        let canvas = match self.layers.last_mut() {
            Some(layer) => &mut layer.heads[head as usize],
            None => return,
        };
        self.drops_per_head[head as usize] += u64::from(self.printhead.drops_of_fire(bits));
        let mut lost = 0;
        for [x, y] in self.printhead.drops_mm(head as usize, bits, [x_mm, y_mm]) {
            let px = ((x - g.origin_x_mm) / self.pitch_mm).floor();
            let py = ((y - g.origin_y_mm) / self.pitch_mm).floor();
            let inside = px >= 0.0 && py >= 0.0 && canvas.set(px as usize, py as usize, true);
            if !inside {
                lost += 1;
            }
        }
        if lost > 0 {
            warnings.push(InkjetWarning::OffCanvas { head, x_mm, y_mm, lost });
        }
    }

    /// Layers with at least one fire, in the order they were started.
    pub fn layers(&self) -> &[InkjetLayer] {
        &self.layers
    }

    /// Hands over the recorded layers (to stream them out and bound memory).
    pub fn take_layers(&mut self) -> Vec<InkjetLayer> {
        std::mem::take(&mut self.layers)
    }

    /// Drops fired by each head (inside or outside the canvas).
    pub fn drops_per_head(&self) -> &[u64] {
        &self.drops_per_head
    }

    /// Writes every layer and head as a 1-bit PNG `layer_<k>_head<h>.png` (k from 0, five
    /// digits) into `dir` and returns the paths.
    pub fn write_layer_pngs(&self, dir: &Path) -> Result<Vec<PathBuf>, InkjetError> {
        std::fs::create_dir_all(dir).map_err(|source| InkjetError::Io { path: dir.to_path_buf(), source })?;
        let mut paths = Vec::new();
        for (k, layer) in self.layers.iter().enumerate() {
            for (h, bitmap) in layer.heads.iter().enumerate() {
                let path = dir.join(format!("layer_{k:05}_head{h}.png"));
                bitmap.save_png(&path)?;
                paths.push(path);
            }
        }
        Ok(paths)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gweave::gen::printhead::HeadOffset;

    fn canvas(profile: &PrintheadProfile) -> InkjetCanvas {
        let geometry = CanvasGeometry { origin_x_mm: 10.0, origin_y_mm: 20.0, width_px: 8, height_px: 6 };
        InkjetCanvas::new(profile, geometry).unwrap()
    }

    /// Regression: a canvas of a 1e308 mm bed (or a 1e308 dpi head) was allocated and aborted;
    /// its size is checked first.
    #[test]
    fn an_endless_canvas_is_refused() {
        let geometry =
            CanvasGeometry { origin_x_mm: 0.0, origin_y_mm: 0.0, width_px: usize::MAX, height_px: 6 };
        let err = InkjetCanvas::new(&PrintheadProfile::default(), geometry).unwrap_err();
        assert!(err.to_string().ends_with("pixels per canvas side, more than the limit of 20000"), "{err}");
    }

    #[test]
    fn drops_land_on_rows_after_map_and_offsets() {
        let profile = PrintheadProfile {
            nozzle_count: 3,
            dpi: 25.4, // 1 mm pitch
            nozzle_rows: vec![2, 0, 1],
            heads: vec![HeadOffset::default(), HeadOffset { offset_x_mm: 2.0, offset_y_mm: 1.0 }],
            ..PrintheadProfile::default()
        };
        let mut c = canvas(&profile);
        let mut w = Vec::new();
        // Address 0 (bit 0) fires row 2; carriage at pixel (1, 0) centre.
        c.on_m700(Some(0), 0b001, [11.5, 20.5, 0.1], false, &mut w);
        // Head 1, address 1 -> row 0, shifted by (2, 1) mm -> pixel (3, 1).
        c.on_m700(Some(1), 0b010, [11.5, 20.5, 0.1], false, &mut w);
        assert!(w.is_empty(), "{w:?}");
        let l = &c.layers()[0];
        assert_eq!(l.z_mm, 0.1);
        assert!(l.heads[0].get(1, 2) && l.heads[0].count_ones() == 1);
        assert!(l.heads[1].get(3, 1) && l.heads[1].count_ones() == 1);
        // A new Z opens a new layer.
        c.on_m700(Some(0), 0b111, [11.5, 20.5, 0.2], false, &mut w);
        assert_eq!(c.layers().len(), 2);
        assert_eq!(c.layers()[1].heads[0].count_ones(), 3);
        assert_eq!(c.drops_per_head(), &[4, 1]);
    }

    #[test]
    fn typed_warnings() {
        let profile = PrintheadProfile { dpi: 25.4, ..PrintheadProfile::default() };
        let mut c = canvas(&profile);
        let mut w = Vec::new();
        c.on_m700(None, 1, [10.5, 20.5, 0.1], false, &mut w);
        c.on_m700(Some(3), 1, [10.5, 20.5, 0.1], false, &mut w);
        c.on_m700(Some(0), 1, [10.5, 20.5, 0.1], true, &mut w);
        // 12 rows from y pixel 0: rows 6..11 fall off the 6-row canvas; x = 9.5 is off too.
        c.on_m700(Some(0), 0xFFF, [10.5, 20.5, 0.1], false, &mut w);
        c.on_m700(Some(0), 1, [9.5, 20.5, 0.1], false, &mut w);
        assert_eq!(
            w,
            [
                InkjetWarning::MissingHead { x_mm: 10.5, y_mm: 20.5 },
                InkjetWarning::UnknownHead { head: 3 },
                InkjetWarning::FireWithoutM400 { head: 0, x_mm: 10.5, y_mm: 20.5 },
                InkjetWarning::OffCanvas { head: 0, x_mm: 10.5, y_mm: 20.5, lost: 6 },
                InkjetWarning::OffCanvas { head: 0, x_mm: 9.5, y_mm: 20.5, lost: 1 },
            ]
        );
        // The fire without M400 still lands where it was asked (here: pixel (0, 0)).
        assert_eq!(c.layers()[0].heads[0].count_ones(), 6);
    }

    #[test]
    fn layer_pngs_read_back() {
        let profile = PrintheadProfile { dpi: 25.4, ..PrintheadProfile::default() };
        let mut c = canvas(&profile);
        c.on_m700(Some(0), 0b101, [13.5, 20.5, 0.1], false, &mut Vec::new());
        let dir = tempfile::tempdir().unwrap();
        let paths = c.write_layer_pngs(dir.path()).unwrap();
        assert_eq!(paths, vec![dir.path().join("layer_00000_head0.png")]);
        let back = gweave::gen::bitmap::load_image(&paths[0], &Default::default(), 0.1).unwrap();
        assert_eq!(back, c.layers()[0].heads[0]);
        assert!(back.get(3, 0) && back.get(3, 2));
    }
}
