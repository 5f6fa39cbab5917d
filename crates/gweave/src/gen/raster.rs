//! Binder-jet raster G-code: layer images -> `G1` / `M400` / `M700 P S` per column.
//!
//! Method (the binder-jet seed, docs/seeds.md, and `sjkelly/image_to_gcode`): each layer image, already at the nozzle pitch
//! `p = 25.4 / dpi`, is cut into bands as tall as the nozzle row (12 rows on the C6602). For
//! every band the head sweeps along X and stops at each column that has at least one ink pixel:
//!
//! ```text
//! G1 X<x> Y<y>     ; carriage to the column (Y only when it changes)
//! M400             ; M700 fires when parsed, not in step with the motion queue: drain it
//! M700 P0 S<bits>  ; bit = nozzle address firing the band row (after the nozzle map)
//! ```
//!
//! Pixel (i, j) of the image has its centre at `origin + (i + 1/2) p` (X) and
//! `origin + (j + 1/2) p` (Y): image row 0 is printed at the lowest Y. Nozzle row `r` of a head
//! sits at carriage + head offset + `r p` along Y, so band `b` (rows `12 b ..`) needs the
//! carriage at `Y = origin_y + (12 b + 1/2) p - offset_y`, and column `i` at
//! `X = origin_x + (i + 1/2) p - offset_x`.
//!
//! Empty columns are passed over without stopping and empty bands are skipped without any
//! move. Passes alternate direction (serpentine) unless one-way printing is asked for; the
//! direction restarts left-to-right on every layer. The last, partial band of an image is
//! printed too (the reference generator `sjkelly/image_to_gcode` drops it). Each layer starts
//! with `;LAYER:<k>`, the recoat (from the second layer on) and `G1 Z<z>`. The recoat is motion
//! when the printhead profile has a `[recoat]` table ([`super::recoat`]), else the job's
//! `recoat_gcode`.
//!
//! Several heads (`P0`, `P1`, ...) each print their own plane (an image channel or an image
//! set): every band is swept once per head, in head order, with that head's offset taken off
//! the carriage position. `density` repeats the fire command at each column; the firmware
//! spaces repeated fires by its minimum interval (800 us on the C6602), which the report's
//! time estimate counts.
//!
//! `fire_order = "before"` writes the binder-jet seed's order instead: fire, `M400`, then the
//! move to the next column (`M700 P0 S15`, `M400`, `G1 X20.265 ...`). Its first fire of a
//! pass follows a move and an `M400`, as every fire of the default does; each later one is
//! parsed right after a move is queued, so on Marlin (whose `M700` fires when parsed) it fires
//! while the carriage is still travelling to its column, and the virtual printer warns about
//! every such fire. It reproduces the seed's file for a firmware whose fire command waits for
//! the moves itself.
//!
//! The output is written in 1 MiB chunks to any `Write`; the layers come one at a time,
//! so memory is bounded by one layer per head.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::band::BandGather;
use super::bitmap::{load_image, Bitmap, BitmapError, ThresholdOptions};
use super::gcode_text::{push_num, push_uint};
use super::printhead::{HeadOffset, PrintheadError, PrintheadProfile};
use super::sl1::{Sl1Error, Sl1Reader};
use super::sweep::{drops_table, HeadText, Sweep};
use crate::range::{OutOfRange, Range, FEED_MM_MIN, LAYER_HEIGHT_MM, POSITION_MM};

/// Layer height used for image stacks when the configuration gives none.
pub const DEFAULT_LAYER_HEIGHT_MM: f64 = 0.1;

/// Errors from raster generation.
#[derive(Debug, Error)]
pub enum RasterError {
    /// The output cannot be written.
    #[error("write failed: {0}")]
    Io(#[from] std::io::Error),
    /// The printhead profile is invalid.
    #[error(transparent)]
    Printhead(#[from] PrintheadError),
    /// An image cannot be read.
    #[error(transparent)]
    Bitmap(#[from] BitmapError),
    /// A `.sl1` archive cannot be read.
    #[error(transparent)]
    Sl1(#[from] Sl1Error),
    /// An invalid job setting.
    #[error("invalid raster config: {0}")]
    Config(String),
    /// A number outside its range.
    #[error(transparent)]
    Range(#[from] OutOfRange),
    /// More image planes than heads.
    #[error("{planes} image planes given but the profile has {heads} heads")]
    TooManyPlanes {
        /// Image planes given.
        planes: usize,
        /// Heads in the profile.
        heads: usize,
    },
}

/// Fires per pixel (binder saturation): past 16 the powder is flooded.
pub const DENSITY: Range<u32> = Range::new(1, 16, "fires per pixel");
/// Columns per nozzle address in the test pattern.
pub const PATTERN_COLUMNS: Range<u32> = Range::new(1, 100, "columns");
/// Heads a job drives (the fire command's P).
pub const HEADS: Range<u32> = Range::new(1, 16, "heads");
/// Fraction of full scale at or above which a pixel gets binder.
pub const THRESHOLD: Range<f64> = Range::new(0.0, 1.0, "");

/// Where a column's fire command goes relative to the move onto the column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FireOrder {
    /// `G1 X<column>`, `M400`, `M700`: the head fires once it stands at the column.
    #[default]
    After,
    /// The binder-jet seed's order: `M700`, `M400`, then `G1` to the next column.
    Before,
}

/// Raster job settings (TOML, all keys optional, unknown keys rejected).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RasterConfig {
    /// Bed position of the image's corner (the binder-jet seed: 20 mm from the edges).
    pub origin_x_mm: f64,
    /// Bed Y of the image's corner, mm.
    pub origin_y_mm: f64,
    /// Layer thickness; `None` takes it from the source (`.sl1`) or uses 0.1 mm.
    pub layer_height_mm: Option<f64>,
    /// Z of the first layer; `None` means one layer height.
    pub first_layer_z_mm: Option<f64>,
    /// Alternate the sweep direction between passes.
    pub serpentine: bool,
    /// Fires per pixel (repeated `M700` at the same column).
    pub density: u32,
    /// Feed rate set once before the first move, mm/min.
    pub feed_mm_min: f64,
    /// Decimals of coordinates (trailing zeros are dropped), 0..=9.
    pub decimals: u32,
    /// G-code written before the first layer.
    pub start_gcode: String,
    /// G-code written after the last layer.
    pub end_gcode: String,
    /// G-code between layers (powder recoat); `{layer}` and `{z}` are replaced by the coming
    /// layer's index and Z.
    pub recoat_gcode: String,
    /// The fire command after the move onto its column (default) or before the next move.
    pub fire_order: FireOrder,
}

impl Default for RasterConfig {
    fn default() -> Self {
        RasterConfig {
            origin_x_mm: 20.0,
            origin_y_mm: 20.0,
            layer_height_mm: None,
            first_layer_z_mm: None,
            serpentine: true,
            density: 1,
            feed_mm_min: 3000.0,
            decimals: 4,
            start_gcode: "G21 ; millimetres\nG90 ; absolute positions\nG28 ; home\n".into(),
            end_gcode: "M400\nG28 X Y ; park the carriage\n".into(),
            recoat_gcode: "M400\n; recoat: spread powder for layer {layer} (Z{z})\n".into(),
            fire_order: FireOrder::After,
        }
    }
}

impl RasterConfig {
    /// Parses and validates a TOML job file.
    pub fn from_toml(text: &str) -> Result<Self, RasterError> {
        let c: RasterConfig =
            toml::from_str(text).map_err(|e| RasterError::Config(crate::settings::toml_message(&e)))?;
        c.validate()?;
        Ok(c)
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), RasterError> {
        let bad = |m: String| Err(RasterError::Config(m));
        POSITION_MM.check("origin_x_mm", self.origin_x_mm)?;
        POSITION_MM.check("origin_y_mm", self.origin_y_mm)?;
        if let Some(h) = self.layer_height_mm {
            LAYER_HEIGHT_MM.check("layer_height_mm", h)?;
        }
        if let Some(z) = self.first_layer_z_mm {
            POSITION_MM.check("first_layer_z_mm", z)?;
        }
        DENSITY.check("density", self.density)?;
        FEED_MM_MIN.check("feed_mm_min", self.feed_mm_min)?;
        if self.decimals > 9 {
            return bad(format!("decimals must be 0..=9, got {}", self.decimals));
        }
        Ok(())
    }
}

/// What a raster job did (counts per head pass: one head sweeping one band).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct RasterReport {
    /// Layers printed.
    pub layers: u64,
    /// Passes that fired at least once.
    pub bands_printed: u64,
    /// (head, band) pairs with no ink, skipped without moving.
    pub bands_skipped: u64,
    /// Columns where the head stopped and fired.
    pub columns_fired: u64,
    /// Empty columns inside printed passes (crossed without stopping).
    pub columns_skipped: u64,
    /// `M700`/`M578` lines written.
    pub fire_commands: u64,
    /// Drops fired by each head (set bits times density).
    pub drops_per_head: Vec<u64>,
    /// Total binder in microlitres, when the profile gives a drop volume.
    pub binder_volume_ul: Option<f64>,
    /// `G1` moves in XY and in Z.
    pub xy_moves: u64,
    /// `G1` moves in Z.
    pub z_moves: u64,
    /// XY path length from the first move on.
    pub xy_path_mm: f64,
    /// Lower bound on print time: path at the feed rate (no acceleration) plus the minimum
    /// fire interval per fire command.
    pub estimated_time_s: f64,
}

/// Streaming raster G-code writer: `new`, then `layer` per layer, then `finish`.
pub struct RasterWriter<W: Write> {
    out: W,
    /// The text not yet written out is `buf[..filled]`; past it, room made ahead for the passes
    /// (zero-filled when made, then written over: a pass writes whole slots and the padding is
    /// overwritten by what follows), kept from pass to pass so it is zero-filled only once.
    buf: Vec<u8>,
    filled: usize,
    /// The text of a layer's start, put into `buf` at once.
    scratch: Vec<u8>,
    profile: PrintheadProfile,
    cfg: RasterConfig,
    layer_height_mm: f64,
    pitch_mm: f64,
    band: BandGather,
    /// Per head: the pre-formatted moves and fires ...
    heads: Vec<HeadText>,
    /// ... and the drops of each pre-formatted fire.
    drops_of_s: Vec<u8>,
    /// Reused per pass: (column, S bits).
    columns: Vec<(usize, u64)>,
    pos_mm: Option<(f64, f64)>,
    last_y_mm: Option<f64>,
    report: RasterReport,
}

/// The output is written in pieces of this size: as large as the output's buffer
/// (`gcode::writer`), so that it takes them without copying them (pieces of 128 KiB, which
/// would stay in the cache while written, were slower: the buffer copies them,
/// docs/performance.md).
const FLUSH_BYTES: usize = 1 << 20;

impl<W: Write> RasterWriter<W> {
    /// Validates the profile and config and writes the start G-code. `source_layer_height_mm`
    /// is used when the config gives none.
    pub fn new(
        out: W,
        profile: &PrintheadProfile,
        cfg: &RasterConfig,
        source_layer_height_mm: Option<f64>,
    ) -> Result<Self, RasterError> {
        profile.validate()?;
        cfg.validate()?;
        let layer_height_mm =
            cfg.layer_height_mm.or(source_layer_height_mm).unwrap_or(DEFAULT_LAYER_HEIGHT_MM);
        let mut w = RasterWriter {
            out,
            buf: Vec::with_capacity(FLUSH_BYTES + 4096),
            filled: 0,
            scratch: Vec::new(),
            profile: profile.clone(),
            cfg: cfg.clone(),
            layer_height_mm,
            pitch_mm: profile.pitch_mm(),
            band: BandGather::new(&profile.row_to_s_bit()),
            heads: (0..profile.heads.len()).map(|h| HeadText::new(profile, h)).collect(),
            drops_of_s: drops_table(profile),
            columns: Vec::new(),
            pos_mm: None,
            last_y_mm: None,
            report: RasterReport { drops_per_head: vec![0; profile.heads.len()], ..RasterReport::default() },
        };
        let mut start = b"; gweave raster: binder-jet inkjet\n".to_vec();
        push_block(&mut start, &cfg.start_gcode);
        start.extend_from_slice(b"G1 F");
        push_num(&mut start, cfg.feed_mm_min, cfg.decimals);
        start.push(b'\n');
        w.put(&start);
        Ok(w)
    }

    fn z_of_layer(&self, k: u64) -> f64 {
        let first = self.cfg.first_layer_z_mm.unwrap_or(self.layer_height_mm);
        first + k as f64 * self.layer_height_mm
    }

    /// Appends `text` to the text not yet written out.
    fn put(&mut self, text: &[u8]) {
        let end = self.filled + text.len();
        if self.buf.len() < end {
            self.buf.resize(end, 0);
        }
        self.buf[self.filled..end].copy_from_slice(text);
        self.filled = end;
    }

    fn flush_if_full(&mut self) -> Result<(), RasterError> {
        if self.filled >= FLUSH_BYTES {
            self.out.write_all(&self.buf[..self.filled])?;
            self.filled = 0;
        }
        Ok(())
    }

    /// Starts layer `k`: marker, recoat (after the first layer) and the Z move.
    fn begin_layer(&mut self) {
        let k = self.report.layers;
        let z = self.z_of_layer(k);
        let d = self.cfg.decimals;
        let mut text = std::mem::take(&mut self.scratch);
        text.clear();
        text.extend_from_slice(b";LAYER:");
        push_uint(&mut text, k);
        text.push(b'\n');
        let first_z = self.z_of_layer(0);
        if let (true, Some(recoat)) = (k > 0, &self.profile.recoat) {
            recoat.write(&mut text, k, z, first_z, d);
            // The spreader may ride on the carriage's axes: the next move states X and Y.
            self.last_y_mm = None;
            self.pos_mm = None;
        } else if k > 0 {
            let mut z_text = Vec::new();
            push_num(&mut z_text, z, d);
            let block = self
                .cfg
                .recoat_gcode
                .replace("{layer}", &k.to_string())
                .replace("{z}", &String::from_utf8_lossy(&z_text));
            push_block(&mut text, &block);
        }
        text.extend_from_slice(b"G1 Z");
        push_num(&mut text, z, d);
        text.push(b'\n');
        self.put(&text);
        self.scratch = text;
        self.report.z_moves += 1;
        self.report.layers += 1;
    }

    /// Prints one layer: `planes[h]` is the image of head `h` at the nozzle pitch (fewer planes
    /// than heads leave the remaining heads idle).
    pub fn layer(&mut self, planes: &[Bitmap]) -> Result<(), RasterError> {
        if planes.len() > self.profile.heads.len() {
            return Err(RasterError::TooManyPlanes { planes: planes.len(), heads: self.profile.heads.len() });
        }
        self.begin_layer();
        let n = self.profile.nozzle_count as usize;
        let bands = planes.iter().map(|p| p.height().div_ceil(n)).max().unwrap_or(0);
        let mut forward = true;
        for band in 0..bands {
            for (head, plane) in planes.iter().enumerate() {
                if band * n >= plane.height() {
                    continue;
                }
                self.band.collect(plane, band * n, &mut self.columns);
                if self.columns.is_empty() {
                    self.report.bands_skipped += 1;
                    continue;
                }
                self.report.columns_skipped += (plane.width() - self.columns.len()) as u64;
                self.write_pass(head, band * n, plane.width(), forward)?;
                if self.cfg.serpentine {
                    forward = !forward;
                }
            }
        }
        Ok(())
    }

    /// Writes one pass of head `head` over the band at row `j0` (image `width` columns wide):
    /// for each column of `self.columns`, in the pass's direction, the move onto it and its fires
    /// ([`Sweep`]).
    fn write_pass(&mut self, head: usize, j0: usize, width: usize, forward: bool) -> Result<(), RasterError> {
        let (cfg, pitch_mm, offset) = (&self.cfg, self.pitch_mm, &self.profile.heads[head]);
        self.heads[head]
            .extend(width, cfg.fire_order, cfg.decimals, |i| column_x_mm(cfg, pitch_mm, offset, i));
        let y = cfg.origin_y_mm + (j0 as f64 + 0.5) * pitch_mm - offset.offset_y_mm;
        let mut y_text = Vec::new();
        if self.last_y_mm != Some(y) {
            y_text.extend_from_slice(b" Y");
            push_num(&mut y_text, y, cfg.decimals);
        }
        let sweep = Sweep {
            text: &self.heads[head],
            drops_of_s: &self.drops_of_s,
            profile: &self.profile,
            head,
            density: cfg.density as usize,
            order: cfg.fire_order,
        };
        let swept =
            sweep.write(&self.columns, forward, &mut self.buf, self.filled, self.pos_mm, (y, &y_text));
        self.filled = swept.end;
        let count = self.columns.len() as u64;
        if count > 0 {
            self.pos_mm = Some((swept.x_mm, y));
            self.last_y_mm = Some(y);
        }
        let density = u64::from(cfg.density);
        let r = &mut self.report;
        r.xy_path_mm += swept.path_mm;
        r.xy_moves += count;
        r.columns_fired += count;
        r.fire_commands += count * density;
        r.drops_per_head[head] += swept.drops * density;
        r.bands_printed += 1;
        self.flush_if_full()
    }

    /// Writes the end G-code, flushes, and returns the writer and the report.
    pub fn finish(mut self) -> Result<(W, RasterReport), RasterError> {
        let mut end = Vec::new();
        push_block(&mut end, &self.cfg.end_gcode);
        self.put(&end);
        self.out.write_all(&self.buf[..self.filled])?;
        self.out.flush()?;
        let drops: u64 = self.report.drops_per_head.iter().sum();
        self.report.binder_volume_ul = self.profile.binder_volume_ul(drops);
        self.report.estimated_time_s = self.report.xy_path_mm / (self.cfg.feed_mm_min / 60.0)
            + self.profile.fire_time_s(self.report.fire_commands);
        Ok((self.out, self.report))
    }
}

/// Carriage X that puts `head` over the centre of column `i` at nozzle pitch `pitch_mm`.
#[inline]
fn column_x_mm(cfg: &RasterConfig, pitch_mm: f64, head: &HeadOffset, i: usize) -> f64 {
    cfg.origin_x_mm + (i as f64 + 0.5) * pitch_mm - head.offset_x_mm
}

/// Appends a user block, making sure it ends with a newline.
fn push_block(buf: &mut Vec<u8>, block: &str) {
    if !block.is_empty() {
        buf.extend_from_slice(block.as_bytes());
        if !block.ends_with('\n') {
            buf.push(b'\n');
        }
    }
}

/// Images of one head: one file per layer, and how to threshold them (e.g. the red channel).
#[derive(Debug, Clone, PartialEq)]
pub struct ImageStack {
    /// The layer images, one per layer, bottom first.
    pub paths: Vec<PathBuf>,
    /// How each image is turned into fire/no-fire bits.
    pub threshold: ThresholdOptions,
    /// The files' first row is the far edge (highest Y), as in a picture viewed with +Y up;
    /// without it the first row is printed at the lowest Y (the binder-jet seed's order).
    pub flip_y: bool,
}

/// Rasters image stacks, stack `h` printed by head `h`, layer `k` from image `k` of each stack
/// (a shorter stack leaves its head idle). `source_pixel_mm` is the images' pixel size; when
/// given they are resampled to the nozzle pitch, otherwise one image pixel is one nozzle pitch.
pub fn raster_image_stacks<W: Write>(
    out: W,
    profile: &PrintheadProfile,
    cfg: &RasterConfig,
    stacks: &[ImageStack],
    source_pixel_mm: Option<f64>,
) -> Result<RasterReport, RasterError> {
    let mut w = RasterWriter::new(out, profile, cfg, None)?;
    let layers = stacks.iter().map(|s| s.paths.len()).max().unwrap_or(0);
    let pitch = profile.pitch_mm();
    for k in 0..layers {
        let mut planes = Vec::with_capacity(stacks.len());
        for s in stacks {
            let plane = match s.paths.get(k) {
                Some(p) => {
                    let b = load_image(p, &s.threshold, source_pixel_mm.unwrap_or(pitch))?;
                    let b = if s.flip_y { b.mirror_y() } else { b };
                    match source_pixel_mm {
                        Some(px) => b.resample(px, px, pitch)?,
                        None => b,
                    }
                }
                None => Bitmap::new(0, 0),
            };
            planes.push(plane);
        }
        w.layer(&planes)?;
    }
    Ok(w.finish()?.1)
}

/// Rasters a PrusaSlicer `.sl1` archive with head 0: each layer is turned into the bed view
/// (undoing the display's orientation and mirroring, see [`Sl1Reader::bed_layer`]) and
/// resampled to the nozzle pitch; the layer height comes from the archive unless the config
/// sets one.
pub fn raster_sl1<W: Write>(
    out: W,
    profile: &PrintheadProfile,
    cfg: &RasterConfig,
    path: &Path,
    threshold: &ThresholdOptions,
) -> Result<RasterReport, RasterError> {
    let mut reader = Sl1Reader::open(path)?;
    let layer_height_mm = reader.info().layer_height_mm;
    let (px_x, px_y) = reader.bed_pixel_mm();
    let mut w = RasterWriter::new(out, profile, cfg, Some(layer_height_mm))?;
    let pitch = profile.pitch_mm();
    for k in 0..reader.layer_count() {
        let plane = reader.bed_layer(k, threshold)?.resample(px_x, px_y, pitch)?;
        w.layer(std::slice::from_ref(&plane))?;
    }
    Ok(w.finish()?.1)
}

/// Writes a nozzle test pattern: for each head (one band each, head `h` on band `h`) and each
/// nozzle address `a` in order, `group_columns` columns firing only address `a` (`S` =
/// `1 << bit(a)`, ignoring the nozzle map), then one blank column. The printed dots show
/// which physical row each address fires, i.e. the `nozzle_rows` map.
pub fn test_pattern<W: Write>(
    out: W,
    profile: &PrintheadProfile,
    cfg: &RasterConfig,
    group_columns: u32,
) -> Result<RasterReport, RasterError> {
    let group_columns = PATTERN_COLUMNS.check("pattern columns", group_columns)? as usize;
    let mut w = RasterWriter::new(out, profile, cfg, None)?;
    w.begin_layer();
    let n = profile.nozzle_count as usize;
    let stride = group_columns + 1;
    for head in 0..profile.heads.len() {
        w.columns.clear();
        for a in 0..profile.nozzle_count {
            let s = 1u64 << profile.s_bit_of_address(a);
            for c in 0..group_columns {
                w.columns.push((a as usize * stride + c, s));
            }
        }
        if w.columns.is_empty() {
            continue;
        }
        w.write_pass(head, head * n, n * stride, true)?;
    }
    Ok(w.finish()?.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gcode(profile: &PrintheadProfile, cfg: &RasterConfig, planes: &[Bitmap]) -> (String, RasterReport) {
        let mut w = RasterWriter::new(Vec::new(), profile, cfg, None).unwrap();
        w.layer(planes).unwrap();
        let (out, rep) = w.finish().unwrap();
        (String::from_utf8(out).unwrap(), rep)
    }

    fn bare() -> RasterConfig {
        RasterConfig {
            start_gcode: String::new(),
            end_gcode: String::new(),
            origin_x_mm: 0.0,
            origin_y_mm: 0.0,
            ..RasterConfig::default()
        }
    }

    #[test]
    fn one_band_exact_output() {
        let p = PrintheadProfile { nozzle_count: 2, dpi: 25.4, ..PrintheadProfile::default() };
        // pitch 1 mm; 3 rows -> bands {0,1} and the partial top band {2}.
        let mut b = Bitmap::new(4, 3);
        for (x, y) in [(0, 0), (0, 1), (2, 1), (3, 2)] {
            b.set(x, y, true);
        }
        let (g, rep) = gcode(&p, &bare(), &[b]);
        assert_eq!(
            g,
            "; gweave raster: binder-jet inkjet\nG1 F3000\n;LAYER:0\nG1 Z0.1\n\
             G1 X0.5 Y0.5\nM400\nM700 P0 S3\nG1 X2.5\nM400\nM700 P0 S2\n\
             G1 X3.5 Y2.5\nM400\nM700 P0 S1\n"
        );
        assert_eq!(rep.bands_printed, 2);
        assert_eq!(rep.columns_fired, 3);
        assert_eq!(rep.columns_skipped, 2 + 3);
        assert_eq!(rep.drops_per_head, vec![4]);
        assert_eq!(rep.xy_moves, 3);
        assert!((rep.xy_path_mm - (2.0 + 1f64.hypot(2.0))).abs() < 1e-9);
    }

    #[test]
    fn fire_order_before_is_the_seeds_fire_drain_move() {
        let p = PrintheadProfile { nozzle_count: 2, dpi: 25.4, ..PrintheadProfile::default() };
        let mut b = Bitmap::new(4, 3);
        for (x, y) in [(0, 0), (0, 1), (2, 1), (3, 2)] {
            b.set(x, y, true);
        }
        let cfg = RasterConfig { fire_order: FireOrder::Before, ..bare() };
        let (g, rep) = gcode(&p, &cfg, &[b]);
        // Onto the band and drained, then per column: fire, M400, move to the next column.
        assert_eq!(
            g,
            "; gweave raster: binder-jet inkjet\nG1 F3000\n;LAYER:0\nG1 Z0.1\n\
             G1 X0.5 Y0.5\nM400\nM700 P0 S3\nM400\nG1 X2.5\nM700 P0 S2\nM400\n\
             G1 X3.5 Y2.5\nM400\nM700 P0 S1\nM400\n"
        );
        assert_eq!((rep.columns_fired, rep.drops_per_head[0]), (3, 4));
    }

    #[test]
    fn serpentine_reverses_and_one_way_does_not() {
        let p = PrintheadProfile { nozzle_count: 1, dpi: 25.4, ..PrintheadProfile::default() };
        let mut b = Bitmap::new(3, 3);
        for (x, y) in [(0, 0), (2, 0), (0, 2), (2, 2)] {
            b.set(x, y, true);
        }
        let xs = |g: &str| -> Vec<String> {
            g.lines()
                .filter(|l| l.starts_with("G1 X"))
                .map(|l| l.split(' ').nth(1).unwrap().to_string())
                .collect()
        };
        let (g, rep) = gcode(&p, &bare(), std::slice::from_ref(&b));
        assert_eq!(xs(&g), ["X0.5", "X2.5", "X2.5", "X0.5"]);
        // Row 1 is empty: skipped without any move.
        assert_eq!(rep.bands_skipped, 1);
        assert!(!g.contains("Y1.5"));
        let one_way = RasterConfig { serpentine: false, ..bare() };
        let (g, _) = gcode(&p, &one_way, &[b]);
        assert_eq!(xs(&g), ["X0.5", "X2.5", "X0.5", "X2.5"]);
    }

    #[test]
    fn nozzle_map_density_dialect_and_heads() {
        let p = PrintheadProfile {
            nozzle_count: 3,
            dpi: 25.4,
            nozzle_rows: vec![2, 0, 1],
            dialect: crate::firmware::Firmware::RepRapFirmware,
            heads: vec![
                Default::default(),
                super::super::printhead::HeadOffset { offset_x_mm: 10.0, offset_y_mm: 1.0 },
            ],
            drop_volume_pl: Some(100.0),
            ..PrintheadProfile::default()
        };
        let mut a = Bitmap::new(1, 3);
        a.set(0, 0, true); // row 0 -> address 1
        let mut b = Bitmap::new(1, 3);
        b.set(0, 2, true); // row 2 -> address 0
        let cfg = RasterConfig { density: 2, ..bare() };
        let (g, rep) = gcode(&p, &cfg, &[a, b]);
        assert!(g.contains("G1 X0.5 Y0.5\nM400\nM578 P0 S2\nM578 P0 S2\n"), "{g}");
        // Head 1 sits 10 mm right and 1 mm up: carriage at 0.5 - 10, 0.5 - 1.
        assert!(g.contains("G1 X-9.5 Y-0.5\nM400\nM578 P1 S1\nM578 P1 S1\n"), "{g}");
        assert_eq!(rep.drops_per_head, vec![2, 2]);
        assert_eq!(rep.fire_commands, 4);
        assert!((rep.binder_volume_ul.unwrap() - 4.0 * 100e-6).abs() < 1e-15);
        let three = [Bitmap::new(1, 1), Bitmap::new(1, 1), Bitmap::new(1, 1)];
        let mut w = RasterWriter::new(Vec::new(), &p, &cfg, None).unwrap();
        assert!(matches!(w.layer(&three), Err(RasterError::TooManyPlanes { .. })));
    }

    #[test]
    fn layers_recoat_and_z() {
        let p = PrintheadProfile::default();
        let cfg = RasterConfig {
            layer_height_mm: Some(0.25),
            first_layer_z_mm: Some(0.3),
            recoat_gcode: "RECOAT {layer} {z}".into(),
            ..bare()
        };
        let mut w = RasterWriter::new(Vec::new(), &p, &cfg, Some(0.1)).unwrap();
        for _ in 0..3 {
            w.layer(&[Bitmap::new(5, 5)]).unwrap();
        }
        let (out, rep) = w.finish().unwrap();
        let g = String::from_utf8(out).unwrap();
        assert!(
            g.ends_with(
                ";LAYER:0\nG1 Z0.3\n;LAYER:1\nRECOAT 1 0.55\nG1 Z0.55\n;LAYER:2\nRECOAT 2 0.8\nG1 Z0.8\n"
            ),
            "{g}"
        );
        assert_eq!((rep.layers, rep.z_moves, rep.xy_moves, rep.bands_skipped), (3, 3, 0, 3));
    }

    #[test]
    fn test_pattern_fires_each_address_alone() {
        let p = PrintheadProfile {
            nozzle_count: 4,
            bit_order: super::super::printhead::BitOrder::MsbFirst,
            ..PrintheadProfile::default()
        };
        let mut out = Vec::new();
        let rep = test_pattern(&mut out, &p, &bare(), 2).unwrap();
        let g = String::from_utf8(out).unwrap();
        let s: Vec<&str> = g.lines().filter(|l| l.starts_with("M700")).collect();
        assert_eq!(
            s,
            [
                "M700 P0 S8",
                "M700 P0 S8",
                "M700 P0 S4",
                "M700 P0 S4",
                "M700 P0 S2",
                "M700 P0 S2",
                "M700 P0 S1",
                "M700 P0 S1"
            ]
        );
        assert_eq!(rep.columns_fired, 8);
    }

    #[test]
    fn config_toml_rejects_unknown_and_bad_values() {
        let c = RasterConfig::from_toml("serpentine = false\ndecimals = 3\n").unwrap();
        assert!(!c.serpentine);
        assert!(RasterConfig::from_toml("serpentin = false").is_err());
        assert!(RasterConfig::from_toml("density = 0").is_err());
        assert!(RasterConfig::from_toml("decimals = 12").is_err());
    }

    #[test]
    fn image_stack_flip_y() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("l0.png");
        // 1 x 2 image, only the first file row inked.
        let mut b = Bitmap::new(1, 2);
        b.set(0, 0, true);
        b.save_png(&path).unwrap();
        let p = PrintheadProfile { nozzle_count: 1, dpi: 25.4, ..PrintheadProfile::default() };
        let fire_y = |flip_y| {
            let stack =
                ImageStack { paths: vec![path.clone()], threshold: ThresholdOptions::default(), flip_y };
            let mut out = Vec::new();
            raster_image_stacks(&mut out, &p, &bare(), &[stack], None).unwrap();
            let g = String::from_utf8(out).unwrap();
            g.lines().find(|l| l.starts_with("G1 X")).unwrap().to_string()
        };
        assert_eq!(fire_y(false), "G1 X0.5 Y0.5");
        assert_eq!(fire_y(true), "G1 X0.5 Y1.5");
    }
}
