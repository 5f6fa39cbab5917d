//! A palette as a PNG swatch chart.
//!
//! One square per colour, filled with the colour the mixing model predicts.
//! When the colour was asked for by value, a bar across the bottom of the square
//! shows the target on the left half against the prediction on the right, so a
//! poor match is visible at a glance. Under each square, optionally, the name
//! and the predicted `#rrggbb` in a built-in 5 x 7 font.
//!
//! ```text
//!   +--------+ +--------+
//!   |        | |        |     square: predicted colour
//!   |        | |########|     bar: target | predicted
//!   +--------+ +--------+
//!    NAME       NAME
//!    #RRGGBB    #RRGGBB
//! ```

use super::font::{glyph, ADVANCE, GLYPH_H};
use super::palette::Resolved;
use super::srgb::Srgb8;

const BACKGROUND: Srgb8 = Srgb8::new(250, 250, 250);
const INK: Srgb8 = Srgb8::new(20, 20, 20);
const GAP_PX: u32 = 6;
/// Two text lines of 7 px with 2 px leading, plus 2 px above.
const LABEL_PX: u32 = 2 + 2 * (GLYPH_H + 2);

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SwatchError {
    #[error("nothing to draw")]
    Empty,
    #[error("swatch squares must be 16 to 1024 px, got {0}")]
    CellSize(u32),
    #[error("a swatch chart needs at least one column")]
    NoColumns,
    #[error("PNG encoding failed: {0}")]
    Encode(String),
}

/// One colour to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct SwatchEntry {
    pub name: String,
    pub predicted: Srgb8,
    pub target: Option<Srgb8>,
}

impl From<&Resolved> for SwatchEntry {
    fn from(r: &Resolved) -> Self {
        Self { name: r.name.clone(), predicted: r.predicted, target: r.target }
    }
}

/// Size and arrangement of the chart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwatchLayout {
    /// Side of each colour square.
    pub cell_px: u32,
    pub columns: u32,
    /// Draw the name and hex code under each square.
    pub labels: bool,
}

impl Default for SwatchLayout {
    fn default() -> Self {
        Self { cell_px: 96, columns: 6, labels: true }
    }
}

/// An RGB8 raster.
struct Canvas {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Canvas {
    fn new(width: u32, height: u32, fill: Srgb8) -> Self {
        let rgb = [fill.r, fill.g, fill.b].repeat((width * height) as usize);
        Self { width, height, rgb }
    }

    fn set(&mut self, x: u32, y: u32, c: Srgb8) {
        if x < self.width && y < self.height {
            let i = 3 * (y * self.width + x) as usize;
            self.rgb[i..i + 3].copy_from_slice(&[c.r, c.g, c.b]);
        }
    }

    fn fill_rect(&mut self, x0: u32, y0: u32, w: u32, h: u32, c: Srgb8) {
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                self.set(x, y, c);
            }
        }
    }

    /// Draw as many characters of `text` as fit in `max_w` pixels.
    fn text(&mut self, x0: u32, y0: u32, max_w: u32, text: &str, c: Srgb8) {
        let fitting = ((max_w + 1) / ADVANCE) as usize;
        for (k, ch) in text.chars().take(fitting).enumerate() {
            let gx = x0 + k as u32 * ADVANCE;
            for (row, bits) in (0u32..).zip(glyph(ch)) {
                for col in 0..5u32 {
                    if bits & (0x10 >> col) != 0 {
                        self.set(gx + col, y0 + row, c);
                    }
                }
            }
        }
    }
}

/// Render `entries` as a PNG (RGB8); returns the encoded bytes.
pub fn render_png(entries: &[SwatchEntry], layout: &SwatchLayout) -> Result<Vec<u8>, SwatchError> {
    if entries.is_empty() {
        return Err(SwatchError::Empty);
    }
    if !(16..=1024).contains(&layout.cell_px) {
        return Err(SwatchError::CellSize(layout.cell_px));
    }
    if layout.columns == 0 {
        return Err(SwatchError::NoColumns);
    }
    let count = entries.len() as u32;
    let columns = layout.columns.min(count);
    let rows = count.div_ceil(columns);
    let label_px = if layout.labels { LABEL_PX } else { 0 };
    let pitch_x = layout.cell_px + GAP_PX;
    let pitch_y = layout.cell_px + label_px + GAP_PX;
    let mut canvas = Canvas::new(GAP_PX + columns * pitch_x, GAP_PX + rows * pitch_y, BACKGROUND);
    for (k, entry) in (0u32..).zip(entries) {
        let x = GAP_PX + (k % columns) * pitch_x;
        let y = GAP_PX + (k / columns) * pitch_y;
        let side = layout.cell_px;
        canvas.fill_rect(x, y, side, side, entry.predicted);
        if let Some(target) = entry.target {
            let bar = side / 5;
            canvas.fill_rect(x, y + side - bar, side / 2, bar, target);
        }
        if layout.labels {
            let ty = y + side + 2;
            canvas.text(x, ty, side, &entry.name, INK);
            canvas.text(x, ty + GLYPH_H + 2, side, &entry.predicted.to_hex(), INK);
        }
    }
    encode(&canvas)
}

/// Palette colours resolved for some filaments, straight to a PNG.
pub fn render_resolved_png(resolved: &[Resolved], layout: &SwatchLayout) -> Result<Vec<u8>, SwatchError> {
    let entries: Vec<SwatchEntry> = resolved.iter().map(SwatchEntry::from).collect();
    render_png(&entries, layout)
}

fn encode(canvas: &Canvas) -> Result<Vec<u8>, SwatchError> {
    let err = |e: png::EncodingError| SwatchError::Encode(e.to_string());
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, canvas.width, canvas.height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // Mark the pixels as sRGB so viewers do not colour-manage them twice.
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(err)?;
    writer.write_image_data(&canvas.rgb).map_err(err)?;
    writer.finish().map_err(err)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::mixing::MixingModel;
    use crate::colour::palette::{Palette, CMYW_FILAMENTS};

    struct Decoded {
        width: u32,
        height: u32,
        rgb: Vec<u8>,
    }

    impl Decoded {
        fn at(&self, x: u32, y: u32) -> Srgb8 {
            let i = 3 * (y * self.width + x) as usize;
            Srgb8::new(self.rgb[i], self.rgb[i + 1], self.rgb[i + 2])
        }
    }

    fn decode(bytes: &[u8]) -> Decoded {
        let mut reader = png::Decoder::new(bytes).read_info().unwrap();
        let mut rgb = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut rgb).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        rgb.truncate(info.buffer_size());
        Decoded { width: info.width, height: info.height, rgb }
    }

    fn entry(name: &str, predicted: Srgb8, target: Option<Srgb8>) -> SwatchEntry {
        SwatchEntry { name: name.into(), predicted, target }
    }

    #[test]
    fn squares_bars_and_labels() {
        let red = Srgb8::new(200, 30, 40);
        let pink = Srgb8::new(255, 136, 170);
        let near_pink = Srgb8::new(244, 136, 167);
        let layout = SwatchLayout { cell_px: 40, columns: 2, labels: true };
        let entries = [
            entry("Red", red, None),
            entry("Pink", near_pink, Some(pink)),
            entry("Key", Srgb8::new(0, 0, 0), None),
        ];
        let img = decode(&render_png(&entries, &layout).unwrap());
        // 2 columns x 2 rows of (40 + 6) px plus a 6 px margin; label strip 20 px.
        assert_eq!((img.width, img.height), (6 + 2 * 46, 6 + 2 * (46 + 20)));
        assert_eq!(img.at(6 + 20, 6 + 10), red);
        // Second square: prediction above and right, target in the bottom-left bar.
        let (x, y) = (6 + 46, 6);
        assert_eq!(img.at(x + 20, y + 10), near_pink);
        assert_eq!(img.at(x + 5, y + 37), pink);
        assert_eq!(img.at(x + 30, y + 37), near_pink);
        // Third square starts the second row.
        assert_eq!(img.at(6 + 20, 6 + 66 + 10), Srgb8::new(0, 0, 0));
        assert_eq!(img.at(2, 2), BACKGROUND);
        // The "R" of "Red": its top row is 4 ink pixels then a gap.
        let ty = 6 + 40 + 2;
        let row: Vec<bool> = (6..12).map(|x| img.at(x, ty) == INK).collect();
        assert_eq!(row, [true, true, true, true, false, false]);
    }

    #[test]
    fn without_labels_the_chart_is_shorter() {
        let layout = SwatchLayout { cell_px: 16, columns: 10, labels: false };
        let img = decode(&render_png(&[entry("X", Srgb8::new(1, 2, 3), None)], &layout).unwrap());
        assert_eq!((img.width, img.height), (6 + 22, 6 + 22));
    }

    #[test]
    fn whole_seed_palette() {
        let model = MixingModel::new(&CMYW_FILAMENTS).unwrap();
        let resolved = Palette::seed().resolve_all(&model).unwrap();
        let png = render_resolved_png(&resolved, &SwatchLayout::default()).unwrap();
        let img = decode(&png);
        // 17 colours in 6 columns: 3 rows.
        assert_eq!((img.width, img.height), (6 + 6 * 102, 6 + 3 * (102 + 20)));
        // Yellow is the 9th colour: row 1, column 2.
        let yellow = resolved[8].predicted;
        // The yellow filament (255, 224, 0) with its blue lifted to RGB_MIN.
        assert_eq!(yellow, Srgb8::new(255, 224, 3));
        assert_eq!(img.at(6 + 2 * 102 + 48, 6 + 122 + 48), yellow);
    }

    #[test]
    fn bad_layouts() {
        let e = [entry("A", Srgb8::new(0, 0, 0), None)];
        assert_eq!(render_png(&[], &SwatchLayout::default()), Err(SwatchError::Empty));
        let tiny = SwatchLayout { cell_px: 8, ..SwatchLayout::default() };
        assert_eq!(render_png(&e, &tiny), Err(SwatchError::CellSize(8)));
        let no_columns = SwatchLayout { columns: 0, ..SwatchLayout::default() };
        assert_eq!(render_png(&e, &no_columns), Err(SwatchError::NoColumns));
    }
}
