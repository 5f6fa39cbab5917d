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
//! One canvas per head per layer; a new layer starts when a fire happens at a new Z. Only the
//! layer being fired is held: a finished one goes to the machine's [`LayerSink`] and its
//! canvases are cleared for the next ([`layers`]), so memory stays at one layer's canvases,
//! held to [`CANVAS_BUDGET_BYTES`], however many layers a file or a host fires. Two
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

pub(crate) mod layers;
pub(crate) mod recoat;

use std::path::PathBuf;

use gweave::gen::bitmap::BitmapError;
use gweave::gen::printhead::{PrintheadError, PrintheadProfile};
use gweave::range::{short, Ceiling, TooLarge, MAX_IMAGE_SIDE_PX};
use serde::Serialize;
use thiserror::Error;

use layers::HeldLayer;
pub use layers::{InkjetLayer, LayerSink, CANVAS_BUDGET_BYTES};

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
    /// The printhead profile is not usable.
    #[error(transparent)]
    Profile(#[from] PrintheadError),
    /// The canvas' origin is not a finite position.
    #[error("the inkjet canvas' origin must be a finite position on the bed")]
    Geometry,
    /// A layer's image could not be written.
    #[error(transparent)]
    Image(#[from] BitmapError),
    /// A canvas side past [`MAX_IMAGE_SIDE_PX`].
    #[error(transparent)]
    TooLarge(#[from] TooLarge),
    /// One layer's canvases would hold more than [`CANVAS_BUDGET_BYTES`].
    #[error(
        "the inkjet canvases of one layer, {width_px} x {height_px} nozzle pitches for each of {heads} heads, would take {} MiB, more than the limit of {} MiB: give a smaller [inkjet] width_px and height_px (left out, they reach the bed's end at the printhead's dpi) or fewer [[inkjet.printhead.heads]]",
        mib(*bytes),
        CANVAS_BUDGET_BYTES >> 20
    )]
    #[allow(missing_docs)] // the canvas' size in nozzle pitches, the heads and the bytes needed
    OverBudget { width_px: usize, height_px: usize, heads: usize, bytes: u64 },
    /// The folder of the layers' images could not be made.
    #[error("{path}: {source}")]
    #[allow(missing_docs)] // the folder and why
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

/// Collects fired drops into 1-bit canvases, one per head, a layer at a time.
#[derive(Debug)]
pub struct InkjetCanvas {
    geometry: CanvasGeometry,
    /// The heads, which say where a fire command's drops land.
    printhead: PrintheadProfile,
    pitch_mm: f64,
    /// The layer being fired, its canvases made at the first fire and reused after.
    held: Option<HeldLayer>,
    /// Layers started so far, each with at least one fire.
    layers: usize,
    /// Where finished layers go, and its first failure, after which they are only cleared.
    sink: Option<Box<dyn LayerSink>>,
    failure: Option<InkjetError>,
    drops_per_head: Vec<u64>,
}

/// MiB, with one decimal.
fn mib(bytes: u64) -> String {
    format!("{:.1}", bytes as f64 / f64::from(1 << 20))
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
        // Then what one layer of them takes, every head together: the only layer ever held.
        let (width_px, height_px, heads) = (geometry.width_px, geometry.height_px, profile.heads.len());
        let bytes = layers::layer_bytes(heads, width_px, height_px);
        if bytes > CANVAS_BUDGET_BYTES {
            return Err(InkjetError::OverBudget { width_px, height_px, heads, bytes });
        }
        Ok(InkjetCanvas {
            geometry,
            printhead: profile.clone(),
            pitch_mm: profile.pitch_mm(),
            held: None,
            layers: 0,
            sink: None,
            failure: None,
            drops_per_head: vec![0; heads],
        })
    }

    /// Hands each finished layer to `sink` from now on.
    pub fn send_layers_to(&mut self, sink: Box<dyn LayerSink>) {
        self.sink = Some(sink);
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
        let same_layer = matches!(&self.held, Some(h) if (h.layer().z_mm - z_mm).abs() <= SAME_Z_MM);
        if !same_layer {
            self.hand_over();
            match &mut self.held {
                Some(held) => held.restart(z_mm),
                None => self.held = Some(HeldLayer::new(z_mm, heads, g.width_px, g.height_px)),
            }
            self.layers += 1;
        }
        let Some(held) = &mut self.held else {
            return;
        };
        self.drops_per_head[head as usize] += u64::from(self.printhead.drops_of_fire(bits));
        let mut lost = 0;
        for [x, y] in self.printhead.drops_mm(head as usize, bits, [x_mm, y_mm]) {
            let px = ((x - g.origin_x_mm) / self.pitch_mm).floor();
            let py = ((y - g.origin_y_mm) / self.pitch_mm).floor();
            let inside = px >= 0.0 && py >= 0.0 && held.ink(head as usize, px as usize, py as usize);
            if !inside {
                lost += 1;
            }
        }
        if lost > 0 {
            warnings.push(InkjetWarning::OffCanvas { head, x_mm, y_mm, lost });
        }
    }

    /// Lends the layer being fired to the sink, unless an earlier layer failed there.
    fn hand_over(&mut self) {
        if let (Some(held), Some(sink), None) = (&self.held, &mut self.sink, &self.failure) {
            if let Err(e) = sink.layer(self.layers - 1, held.layer()) {
                self.failure = Some(e);
            }
        }
    }

    /// The end of the job: the last layer goes to the sink, and its canvases are let go.
    pub fn finish(&mut self) {
        self.hand_over();
        self.held = None;
    }

    /// The sink's first failure, if a layer could not be handed over (the layers after it
    /// were not).
    pub fn take_failure(&mut self) -> Option<InkjetError> {
        self.failure.take()
    }

    /// Layers with at least one fire so far.
    pub fn layer_count(&self) -> usize {
        self.layers
    }

    /// The layer being fired, if any.
    pub fn layer(&self) -> Option<&InkjetLayer> {
        self.held.as_ref().map(HeldLayer::layer)
    }

    /// The bytes the canvases hold now: one layer's (at most [`CANVAS_BUDGET_BYTES`]), or none
    /// before the first fire and after [`InkjetCanvas::finish`].
    pub fn held_bytes(&self) -> u64 {
        self.held.as_ref().map_or(0, HeldLayer::bytes)
    }

    /// Drops fired by each head (inside or outside the canvas).
    pub fn drops_per_head(&self) -> &[u64] {
        &self.drops_per_head
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

    /// The budget holds one layer, every head together: one head of the largest canvas fits,
    /// sixteen are refused before anything is made, naming the keys that size them.
    #[test]
    fn a_layer_past_the_canvas_budget_is_refused_naming_its_keys() {
        let largest =
            CanvasGeometry { origin_x_mm: 0.0, origin_y_mm: 0.0, width_px: 20_000, height_px: 20_000 };
        let one = InkjetCanvas::new(&PrintheadProfile::default(), largest).unwrap();
        assert_eq!(one.held_bytes(), 0, "nothing is made before the first fire");
        let sixteen =
            PrintheadProfile { heads: vec![HeadOffset::default(); 16], ..PrintheadProfile::default() };
        let err = InkjetCanvas::new(&sixteen, largest).unwrap_err();
        assert_eq!(
            err.to_string(),
            "the inkjet canvases of one layer, 20000 x 20000 nozzle pitches for each of 16 heads, would \
             take 765.7 MiB, more than the limit of 64 MiB: give a smaller [inkjet] width_px and \
             height_px (left out, they reach the bed's end at the printhead's dpi) or fewer \
             [[inkjet.printhead.heads]]"
        );
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
        let (sink, finished) = std::sync::mpsc::channel();
        c.send_layers_to(Box::new(sink));
        let mut w = Vec::new();
        // Address 0 (bit 0) fires row 2; carriage at pixel (1, 0) centre.
        c.on_m700(Some(0), 0b001, [11.5, 20.5, 0.1], false, &mut w);
        // Head 1, address 1 -> row 0, shifted by (2, 1) mm -> pixel (3, 1).
        c.on_m700(Some(1), 0b010, [11.5, 20.5, 0.1], false, &mut w);
        assert!(w.is_empty(), "{w:?}");
        assert!(finished.try_recv().is_err(), "the layer is still being fired");
        // A new Z opens a new layer: the first is handed over, and its drops cleared.
        c.on_m700(Some(0), 0b111, [11.5, 20.5, 0.2], false, &mut w);
        let l = finished.try_recv().unwrap();
        assert_eq!(l.z_mm, 0.1);
        assert!(l.heads[0].get(1, 2) && l.heads[0].count_ones() == 1);
        assert!(l.heads[1].get(3, 1) && l.heads[1].count_ones() == 1);
        c.finish();
        let l = finished.try_recv().unwrap();
        assert_eq!((l.z_mm, l.heads[0].count_ones(), l.heads[1].count_ones()), (0.2, 3, 0));
        assert_eq!((c.layer_count(), c.held_bytes()), (2, 0));
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
        assert_eq!(c.layer().unwrap().heads[0].count_ones(), 6);
    }

    #[test]
    fn layer_pngs_read_back() {
        let profile = PrintheadProfile { dpi: 25.4, ..PrintheadProfile::default() };
        let mut c = canvas(&profile);
        let dir = tempfile::tempdir().unwrap();
        c.send_layers_to(Box::new(layers::LayerPngs::new(dir.path()).unwrap()));
        c.on_m700(Some(0), 0b101, [13.5, 20.5, 0.1], false, &mut Vec::new());
        c.on_m700(Some(0), 0b1, [10.5, 20.5, 0.2], false, &mut Vec::new());
        c.finish();
        assert!(c.take_failure().is_none());
        let read = |k: usize| {
            let path = dir.path().join(format!("layer_{k:05}_head0.png"));
            gweave::gen::bitmap::load_image(&path, &Default::default(), 0.1).unwrap()
        };
        let (first, second) = (read(0), read(1));
        assert!(first.get(3, 0) && first.get(3, 2) && first.count_ones() == 2);
        assert!(second.get(0, 0) && second.count_ones() == 1);
    }

    /// A layer that cannot be written is the run's error, said once; the layers after it are
    /// not handed over.
    #[test]
    fn a_layer_that_cannot_be_written_is_the_failure() {
        let dir = tempfile::tempdir().unwrap();
        let mut c = canvas(&PrintheadProfile::default());
        c.send_layers_to(Box::new(layers::LayerPngs::new(dir.path()).unwrap()));
        // A folder in the way of the first layer's file.
        std::fs::create_dir(dir.path().join("layer_00000_head0.png")).unwrap();
        for z in [0.1, 0.2, 0.3] {
            c.on_m700(Some(0), 1, [10.1, 20.1, z], false, &mut Vec::new());
        }
        c.finish();
        let err = c.take_failure().unwrap();
        assert!(err.to_string().contains("layer_00000_head0.png"), "{err}");
        assert!(c.take_failure().is_none());
        assert!(!dir.path().join("layer_00001_head0.png").exists());
    }
}
