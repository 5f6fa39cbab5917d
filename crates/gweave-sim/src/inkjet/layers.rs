//! The canvases of the layer being fired, and where each layer goes once it is finished.
//!
//! A binder-jet print is thousands of layers, and one head's canvas of one layer can be
//! 20 000 x 20 000 nozzle pitches (47.8 MiB at a bit a pitch). So only the layer being fired is
//! held ([`HeldLayer`]): when a fire comes at a new Z, the finished layer is lent to the
//! [`LayerSink`] the machine was given (`sim --raster-out` writes it as PNGs, [`LayerPngs`];
//! `serve` gives none), then its bitmaps are cleared and fired into again. What the inkjet holds
//! is one layer's canvases whatever the number of layers, at most [`CANVAS_BUDGET_BYTES`],
//! which the profile is held to when the machine is built.
//!
//! Only the rows that took a drop are cleared: a fire marks at most `nozzle_count` rows, so
//! starting a layer costs what its fires cost. Clearing the whole canvas instead would cost a
//! file of one fire a layer 48 MB of writes a line on the largest canvas.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::mpsc;

use gweave::gen::bitmap::Bitmap;

use super::InkjetError;

/// The most the canvases of one layer may hold, every head together, with their rows'
/// bookkeeping: 64 MiB. That is a canvas of the largest side (20 000 x 20 000 nozzle pitches,
/// 47.8 MiB) for one head, or sixteen heads of a 600 dpi printhead over a 200 x 200 mm bed
/// (4 725 pitches a side, 2.7 MiB each). A profile asking for more is refused when the machine
/// is built ([`InkjetError::OverBudget`]), before anything is allocated.
pub const CANVAS_BUDGET_BYTES: u64 = 64 << 20;

/// What a canvas holds for each of its rows besides its pixels: whether the row took a drop,
/// and its place in the list of rows to clear.
const ROW_BOOKKEEPING_BYTES: u64 = (size_of::<bool>() + size_of::<u32>()) as u64;

/// The bytes the canvases of one layer hold: for each head a bitmap and its rows' bookkeeping.
pub(crate) fn layer_bytes(heads: usize, width_px: usize, height_px: usize) -> u64 {
    let head = Bitmap::bytes_for(width_px, height_px) + height_px as u64 * ROW_BOOKKEEPING_BYTES;
    heads as u64 * head
}

/// The drops of one layer, one bitmap per head (row 0 at the lowest Y).
#[derive(Debug, Clone, PartialEq)]
pub struct InkjetLayer {
    /// The carriage's Z when the layer's first fire ran, mm.
    pub z_mm: f64,
    /// One canvas per head, in head order.
    pub heads: Vec<Bitmap>,
}

/// Where an [`InkjetCanvas`](super::InkjetCanvas) hands each layer once its fires are over (when
/// a fire comes at another Z, and the last layer at the end of the job). The canvas holds only
/// the layer being fired: whatever is kept of the others is the sink's to keep. The layer is
/// lent, and cleared after.
pub trait LayerSink: fmt::Debug + Send {
    /// Layer `index` (from 0, in the order the layers were fired) is finished. An error stops
    /// the handing over: the layers after it are only cleared, and the error is the run's.
    fn layer(&mut self, index: usize, layer: &InkjetLayer) -> Result<(), InkjetError>;
}

/// Writes each layer as 1-bit PNGs `layer_<k>_head<h>.png` (k from 0, five digits) into a
/// folder, one file per head, each whole or absent (`sim --raster-out DIR`).
#[derive(Debug)]
pub(crate) struct LayerPngs {
    dir: PathBuf,
}

impl LayerPngs {
    /// Writes into `dir`, made first if it does not exist (before the run, so a folder that
    /// cannot be made fails at once).
    pub(crate) fn new(dir: &Path) -> Result<Self, InkjetError> {
        std::fs::create_dir_all(dir).map_err(|source| InkjetError::Io { path: dir.to_path_buf(), source })?;
        Ok(LayerPngs { dir: dir.to_path_buf() })
    }
}

impl LayerSink for LayerPngs {
    fn layer(&mut self, index: usize, layer: &InkjetLayer) -> Result<(), InkjetError> {
        for (h, bitmap) in layer.heads.iter().enumerate() {
            bitmap.save_png(&self.dir.join(format!("layer_{index:05}_head{h}.png")))?;
        }
        Ok(())
    }
}

/// A channel: each layer is sent, copied, to whoever holds the receiver (a thread that keeps
/// or writes them, a test that compares every layer). A receiver that has gone takes nothing,
/// which is no failure of the print.
impl LayerSink for mpsc::Sender<InkjetLayer> {
    fn layer(&mut self, _index: usize, layer: &InkjetLayer) -> Result<(), InkjetError> {
        let _ = self.send(layer.clone());
        Ok(())
    }
}

/// The layer being fired: a canvas a head, and the rows of each that took a drop.
#[derive(Debug)]
pub(crate) struct HeldLayer {
    layer: InkjetLayer,
    inked: Vec<InkedRows>,
}

/// The rows of one head's canvas that took a drop in the layer being fired, each once.
#[derive(Debug)]
struct InkedRows {
    /// One flag a row of the canvas.
    marked: Vec<bool>,
    /// The rows marked, in the order they took their first drop; never more than the canvas'
    /// height, for which room is made at once.
    rows: Vec<u32>,
}

impl HeldLayer {
    /// Empty canvases of `width_px` x `height_px` for `heads` heads, at `z_mm` (at most
    /// [`MAX_IMAGE_SIDE_PX`](gweave::range::MAX_IMAGE_SIDE_PX) a side, checked by the canvas).
    pub(crate) fn new(z_mm: f64, heads: usize, width_px: usize, height_px: usize) -> Self {
        let inked = (0..heads)
            .map(|_| InkedRows { marked: vec![false; height_px], rows: Vec::with_capacity(height_px) })
            .collect();
        // Each made zeroed, not cloned: the system hands out zeroed pages as they are first
        // written, so a canvas costs the rows its drops touch until then.
        let layer =
            InkjetLayer { z_mm, heads: (0..heads).map(|_| Bitmap::new(width_px, height_px)).collect() };
        HeldLayer { layer, inked }
    }

    /// The layer as it stands.
    pub(crate) fn layer(&self) -> &InkjetLayer {
        &self.layer
    }

    /// A drop of `head` on pixel (`x`, `y`); false when it falls outside the canvas.
    pub(crate) fn ink(&mut self, head: usize, x: usize, y: usize) -> bool {
        let inside = self.layer.heads[head].set(x, y, true);
        let rows = &mut self.inked[head];
        if inside && !rows.marked[y] {
            rows.marked[y] = true;
            rows.rows.push(y as u32);
        }
        inside
    }

    /// Empties the canvases, the inked rows only, for the layer at `z_mm`.
    pub(crate) fn restart(&mut self, z_mm: f64) {
        for (bitmap, rows) in self.layer.heads.iter_mut().zip(&mut self.inked) {
            for y in rows.rows.drain(..) {
                bitmap.clear_row(y as usize);
                rows.marked[y as usize] = false;
            }
        }
        self.layer.z_mm = z_mm;
    }

    /// The bytes held: the bitmaps' words and the rows' bookkeeping, as allocated (what
    /// [`layer_bytes`] counts before they are).
    pub(crate) fn bytes(&self) -> u64 {
        let bitmaps = self.layer.heads.iter().map(|b| (b.words_per_row() * 8 * b.height()) as u64);
        let rows =
            self.inked.iter().map(|r| (r.marked.capacity() + r.rows.capacity() * size_of::<u32>()) as u64);
        bitmaps.chain(rows).sum()
    }
}
