//! A [`Drawing`] as a PNG: strokes rasterised in order, then the legend and panel titles; and
//! the one PNG encoder every picture gweave writes goes through ([`write_png`]).

use std::io::Write;

use super::raster::{line_pixels, within, Image};
use super::text;
use super::view::{Drawing, Stroke};
use super::RenderError;
use crate::pass::{Progress, Quiet};

const INK: [u8; 3] = [0x20, 0x20, 0x20];
const LEGEND_BOX: [u8; 3] = [0xff, 0xff, 0xff];
/// Size of legend and panel title text, px.
const TEXT_PX: f32 = 16.0;

/// Rasterises a drawing (strokes, legend, titles). A blank drawing is the background only.
///
/// Strokes hidden under later opaque strokes are skipped: a whole print seen from above is
/// mostly covered by its top layers, and skipping what cannot show makes a picture of a
/// 17-million-segment file several times faster. A reverse pass keeps a mask of the pixels that
/// later opaque strokes cover fully (with a count per 8 x 8 tile); a stroke is hidden when every
/// pixel it would change is in the mask (checked tile by tile first, then pixel by pixel), so
/// every pixel it would change is one that a later stroke overwrites. Then the visible strokes
/// are drawn in order: the picture is the one drawing everything gives.
///
/// The work of drawing grows with the ink: the pixels all strokes visit together. A file of
/// 300 000 layers over 10 mm, or a million travel moves across the bed, lays each pixel under
/// thousands of strokes; past 256 pictures' worth (`MAX_OVERDRAW`) only every `k`-th stroke
/// is drawn (the last of each `k`, so the top of a stack stays on top), which such a picture
/// cannot show anyway, and the time is bounded whatever the file.
pub fn rasterise(d: &Drawing) -> Image {
    rasterise_with_progress(d, &mut Quiet)
}

/// Strokes between two progress reports.
const REPORT_EVERY: usize = 1 << 16;

/// [`rasterise`], reporting the work as the stage "drawing": two units per stroke (finding the
/// hidden ones, then drawing the rest), so that a bar covers the whole of a long drawing.
pub fn rasterise_with_progress(d: &Drawing, progress: &mut dyn Progress) -> Image {
    let mut img = Image::new(d.width_px, d.height_px, d.background);
    let stride = overdraw_stride(&d.strokes, d.width_px, d.height_px);
    let kept: Vec<Stroke> =
        d.strokes.iter().enumerate().filter(|(i, _)| i % stride == stride - 1).map(|(_, s)| *s).collect();
    let strokes = if stride == 1 { &d.strokes } else { &kept };
    let n = strokes.len();
    progress.stage("drawing", 2 * n as u64);
    let visible =
        visible_strokes(strokes, d.width_px, d.height_px, &mut |done| progress.advance(done as u64));
    for (i, s) in strokes.iter().enumerate() {
        if visible[i] {
            img.line(s.from, s.to, s.width_px, s.colour, s.alpha);
        }
        if i.is_multiple_of(REPORT_EVERY) {
            progress.advance((n + i) as u64);
        }
    }
    progress.advance(2 * n as u64);
    let line_h = text::line_height(TEXT_PX) + 4;
    for p in &d.panels {
        img.text(p.x_px as i32 + 12, d.height_px as i32 - line_h as i32 - 4, &p.title, TEXT_PX, INK);
        if p.x_px > 0 {
            img.rect(p.x_px as i32, 0, 1, d.height_px, INK, 0.3);
        }
    }
    if !d.legend.is_empty() {
        let longest = d.legend.iter().map(|e| text::width(&e.label, TEXT_PX)).max().unwrap_or(0);
        let box_w = 12 + line_h + longest + 8;
        let box_h = 8 + line_h * d.legend.len() as u32 + 4;
        img.rect(8, 8, box_w, box_h, LEGEND_BOX, 0.85);
        for (i, e) in d.legend.iter().enumerate() {
            let y = 14 + (i as u32 * line_h) as i32;
            let c = [e.colour.r, e.colour.g, e.colour.b];
            img.rect(14, y + 2, line_h - 8, line_h - 8, c, 1.0);
            img.text(14 + line_h as i32, y, &e.label, TEXT_PX, INK);
        }
    }
    img
}

/// How many pictures' worth of pixels drawing may visit before the strokes are thinned: 2.8e8
/// visits for a 1200 x 900 picture, about 4 s in a release build. Whole prints of the test
/// files visit 4 to 140 pictures' worth (the most: a 400 x 300 picture of a 200-layer print
/// seen from the side), a file of a million travel moves across the bed about 5 000.
const MAX_OVERDRAW: f64 = 256.0;

/// Draw every `k`-th stroke so that the ink stays under [`MAX_OVERDRAW`] pictures (1: all).
fn overdraw_stride(strokes: &[Stroke], width: u32, height: u32) -> usize {
    let ink: f64 = strokes
        .iter()
        .map(|s| {
            let len = f64::from((s.to[0] - s.from[0]).hypot(s.to[1] - s.from[1]));
            // Off-picture lengths count too, but a stroke draws at most a picture's diagonal.
            let len = if len.is_finite() { len.min(f64::from(width + height)) } else { 0.0 };
            // The pixels drawing it visits: its length times its width and a few to spare.
            (len + 1.0) * (f64::from(s.width_px.max(1.0)) + 4.0)
        })
        .sum();
    let budget = MAX_OVERDRAW * f64::from(width) * f64::from(height);
    (ink / budget).ceil().max(1.0) as usize
}

/// Side of the square tiles of the coverage mask, px.
const TILE: usize = 8;

/// The pixels later opaque strokes cover, with a count per tile so that a stroke lying on fully
/// covered tiles is found hidden without looking at its pixels.
struct Coverage {
    w: usize,
    h: usize,
    covered: Vec<bool>,
    tiles_x: usize,
    /// Covered pixels per tile, and pixels each tile has inside the image.
    count: Vec<u16>,
    size: Vec<u16>,
}

impl Coverage {
    fn new(w: usize, h: usize) -> Self {
        let (tiles_x, tiles_y) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let size = (0..tiles_x * tiles_y)
            .map(|i| {
                let (tx, ty) = (i % tiles_x, i / tiles_x);
                ((w - tx * TILE).min(TILE) * (h - ty * TILE).min(TILE)) as u16
            })
            .collect();
        Coverage { w, h, covered: vec![false; w * h], tiles_x, count: vec![0; tiles_x * tiles_y], size }
    }

    fn cover(&mut self, x: usize, y: usize) {
        let i = y * self.w + x;
        if !self.covered[i] {
            self.covered[i] = true;
            self.count[(y / TILE) * self.tiles_x + x / TILE] += 1;
        }
    }

    /// Every tile the pixel box `x0..x1, y0..y1` touches is fully covered.
    fn tiles_full(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> bool {
        (y0 / TILE..y1.div_ceil(TILE)).all(|ty| {
            (x0 / TILE..x1.div_ceil(TILE)).all(|tx| {
                let t = ty * self.tiles_x + tx;
                self.count[t] == self.size[t]
            })
        })
    }

    /// Nothing `s` would draw can show: every pixel it changes is covered (off-picture pixels
    /// are not drawn at all).
    fn hides(&self, s: &Stroke) -> bool {
        let reach = s.width_px.max(0.5) / 2.0 + 0.5;
        let x0 = (s.from[0].min(s.to[0]) - reach).floor().max(0.0);
        let y0 = (s.from[1].min(s.to[1]) - reach).floor().max(0.0);
        let x1 = (s.from[0].max(s.to[0]) + reach).ceil().min(self.w as f32);
        let y1 = (s.from[1].max(s.to[1]) + reach).ceil().min(self.h as f32);
        // Off the picture (or NaN): draws nothing.
        if !(x0 < x1 && y0 < y1) {
            return true;
        }
        if self.tiles_full(x0 as usize, y0 as usize, x1 as usize, y1 as usize) {
            return true;
        }
        let (w, h) = (self.w as u32, self.h as u32);
        line_pixels(s.from, s.to, s.width_px, w, h, |x, y, _| self.covered[y * self.w + x])
    }
}

/// Which strokes are not fully hidden under later opaque ones (see [`rasterise`]): a reverse
/// pass over the strokes; a stroke is hidden when every pixel it would change (the same pixels
/// [`Image::line`] visits) is covered by a later opaque stroke.
/// `done(k)` is called every [`REPORT_EVERY`] strokes with the number looked at so far.
fn visible_strokes(strokes: &[Stroke], width: u32, height: u32, done: &mut dyn FnMut(usize)) -> Vec<bool> {
    let mut coverage = Coverage::new(width as usize, height as usize);
    let mut visible = vec![false; strokes.len()];
    for (i, s) in strokes.iter().enumerate().rev() {
        let k = strokes.len() - i;
        if k.is_multiple_of(REPORT_EVERY) {
            done(k);
        }
        if coverage.hides(s) {
            continue;
        }
        visible[i] = true;
        if s.alpha >= 1.0 && s.width_px >= 2.0 {
            mark_core(&mut coverage, s);
        }
    }
    visible
}

/// Marks the pixels whose centres are at least half a pixel inside the stroke (fully covered).
fn mark_core(coverage: &mut Coverage, s: &Stroke) {
    let core = s.width_px / 2.0 - 0.5;
    let (w, h) = (coverage.w as u32, coverage.h as u32);
    // A hair inside the core, so that rounding never marks a pixel that is not fully covered.
    let core2 = core * core * 0.9999;
    within(s.from, s.to, core, w, h, |x, y, dist2| {
        if dist2 <= core2 {
            coverage.cover(x, y);
        }
        true
    });
}

/// Pixels for [`write_png`], rows top first.
#[derive(Debug, Clone, Copy)]
pub enum Pixels<'a> {
    /// 8-bit sRGB, 3 bytes a pixel: pictures and charts.
    Rgb(&'a [u8]),
    /// 1-bit grey, rows packed most significant bit first and padded to a byte: layer masks.
    Grey1(&'a [u8]),
}

/// Writes a `width` x `height` PNG. Colour pictures are marked sRGB (so viewers do not
/// colour-manage them twice) and compressed with the fast level, as previews always were (their
/// time is in `make bench`). Layer masks keep the default level they always had (the raster
/// benchmark reads 500 of them).
pub fn write_png(
    out: impl Write,
    width: u32,
    height: u32,
    pixels: Pixels<'_>,
) -> Result<(), png::EncodingError> {
    let mut encoder = png::Encoder::new(out, width, height);
    let data = match pixels {
        Pixels::Rgb(data) => {
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
            encoder.set_compression(png::Compression::Fast);
            data
        }
        Pixels::Grey1(data) => {
            encoder.set_color(png::ColorType::Grayscale);
            encoder.set_depth(png::BitDepth::One);
            data
        }
    };
    let mut writer = encoder.write_header()?;
    writer.write_image_data(data)?;
    writer.finish()
}

/// Encodes an image as an 8-bit RGB PNG ([`write_png`]).
pub fn encode(img: &Image) -> Result<Vec<u8>, RenderError> {
    let rgb: Vec<u8> = img.rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    let mut out = Vec::new();
    write_png(&mut out, img.width, img.height, Pixels::Rgb(&rgb))
        .map_err(|e| RenderError::Encode(e.to_string()))?;
    Ok(out)
}

/// Decodes a PNG into an RGBA image with the `image` crate (for tests and for checking output).
pub fn decode(bytes: &[u8]) -> Result<Image, RenderError> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map_err(|e| RenderError::Encode(e.to_string()))?
        .into_rgba8();
    Ok(Image { width: img.width(), height: img.height(), rgba: img.into_raw() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::view::{Stroke, BACKGROUND};

    #[test]
    fn png_round_trips_the_pixels() {
        let mut d = Drawing {
            width_px: 30,
            height_px: 20,
            background: BACKGROUND,
            strokes: vec![],
            legend: vec![],
            panels: vec![],
            layers_drawn: None,
        };
        d.strokes.push(Stroke {
            from: [2.0, 10.0],
            to: [28.0, 10.0],
            colour: [10, 200, 30],
            width_px: 4.0,
            alpha: 1.0,
        });
        let img = rasterise(&d);
        let back = decode(&encode(&img).unwrap()).unwrap();
        assert_eq!(back, img);
        assert_eq!(back.pixel(15, 10), [10, 200, 30, 255]);
        assert_eq!(back.pixel(15, 2), [BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 255]);
    }

    /// Regression: a preview of 300 000 layers over 10 mm took 146 s, every pixel under
    /// thousands of strokes; the strokes drawn are now thinned past 256 pictures of ink.
    #[test]
    fn overdraw_is_thinned_to_a_budget() {
        let stroke =
            |y: f32| Stroke { from: [0.0, y], to: [99.0, y], width_px: 2.0, colour: [0, 0, 0], alpha: 1.0 };
        // A 100 x 100 picture: 100 strokes of ~600 visited pixels are 6 pictures, drawn whole.
        let few: Vec<Stroke> = (0..100).map(|i| stroke(i as f32)).collect();
        assert_eq!(overdraw_stride(&few, 100, 100), 1);
        // 300 000 of them over the same rows (18 000 pictures): every 71st is drawn.
        let many: Vec<Stroke> = (0..300_000).map(|i| stroke((i % 100) as f32)).collect();
        assert_eq!(overdraw_stride(&many, 100, 100), 71);
    }

    #[test]
    fn hidden_strokes_are_skipped_without_changing_the_picture() {
        let st = |from: [f32; 2], to: [f32; 2], colour: [u8; 3], width_px: f32| Stroke {
            from,
            to,
            colour,
            width_px,
            alpha: 1.0,
        };
        let strokes = vec![
            st([10.0, 20.0], [50.0, 20.0], [255, 0, 0], 3.0), // under the wide blue one: hidden
            st([10.0, 5.0], [50.0, 5.0], [0, 255, 0], 3.0),   // beside it: visible
            st([10.0, 26.0], [50.0, 26.0], [0, 255, 0], 3.0), // partly under its edge: visible
            st([5.0, 21.0], [55.0, 21.0], [0, 0, 255], 12.0),
        ];
        assert_eq!(visible_strokes(&strokes, 60, 40, &mut |_| {}), [false, true, true, true]);
        let d = Drawing {
            width_px: 60,
            height_px: 40,
            background: BACKGROUND,
            strokes,
            legend: vec![],
            panels: vec![],
            layers_drawn: None,
        };
        let mut all = Image::new(60, 40, BACKGROUND);
        for s in &d.strokes {
            all.line(s.from, s.to, s.width_px, s.colour, s.alpha);
        }
        assert_eq!(rasterise(&d), all);
    }
}
