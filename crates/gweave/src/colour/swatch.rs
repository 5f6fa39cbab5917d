//! A palette as a PNG swatch chart.
//!
//! One square per colour, filled with the colour the mixing model predicts.
//! When the colour was asked for by value, a bar across the bottom of the square
//! shows the target on the left half against the prediction on the right, so a
//! poor match is visible at a glance. Under each square, optionally, the name
//! and the predicted `#rrggbb` in the embedded font ([`crate::picture::text`]). It is drawn and
//! encoded with the preview's image and PNG encoder.
//!
//! ```text
//!   +--------+ +--------+
//!   |        | |        |     square: predicted colour
//!   |        | |########|     bar: target | predicted
//!   +--------+ +--------+
//!    NAME       NAME
//!    #RRGGBB    #RRGGBB
//! ```

use super::named_mixes::Resolved;
use super::srgb::Srgb8;
use crate::picture::{encode, text, Image};

const BACKGROUND: [u8; 3] = [250, 250, 250];
const INK: [u8; 3] = [20, 20, 20];
const GAP_PX: u32 = 6;
/// Size of the label text, px.
const TEXT_PX: f32 = 12.0;

/// Two text lines, plus 2 px above.
fn label_px() -> u32 {
    2 + 2 * text::line_height(TEXT_PX)
}

/// Why a swatch chart cannot be drawn.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SwatchError {
    /// No colour to draw.
    #[error("nothing to draw")]
    Empty,
    /// A square size outside 16 to 1024 px.
    #[error("swatch squares must be 16 to 1024 px, got {0}")]
    CellSize(u32),
    /// Zero columns.
    #[error("a swatch chart needs at least one column")]
    NoColumns,
    /// The PNG encoder failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
}

/// One colour to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct SwatchEntry {
    /// The colour's name, written under its square.
    pub name: String,
    /// The colour the mixing model predicts, drawn in the square.
    pub predicted: Srgb8,
    /// The colour asked for, drawn beside the prediction when given.
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
    /// Squares per row.
    pub columns: u32,
    /// Draw the name and hex code under each square.
    pub labels: bool,
}

impl Default for SwatchLayout {
    fn default() -> Self {
        Self { cell_px: 96, columns: 6, labels: true }
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
    let label_px = if layout.labels { label_px() } else { 0 };
    let pitch_x = layout.cell_px + GAP_PX;
    let pitch_y = layout.cell_px + label_px + GAP_PX;
    let mut img = Image::new(GAP_PX + columns * pitch_x, GAP_PX + rows * pitch_y, BACKGROUND);
    let rgb = |c: Srgb8| [c.r, c.g, c.b];
    for (k, entry) in (0u32..).zip(entries) {
        let x = (GAP_PX + (k % columns) * pitch_x) as i32;
        let y = (GAP_PX + (k / columns) * pitch_y) as i32;
        let side = layout.cell_px;
        img.rect(x, y, side, side, rgb(entry.predicted), 1.0);
        if let Some(target) = entry.target {
            let bar = side / 5;
            img.rect(x, y + (side - bar) as i32, side / 2, bar, rgb(target), 1.0);
        }
        if layout.labels {
            let ty = y + side as i32 + 2;
            // As much of each label as fits under its square.
            for (line, label) in [entry.name.clone(), entry.predicted.to_hex()].iter().enumerate() {
                let shown = text::fitting(label, TEXT_PX, side);
                img.text(x, ty + (line as u32 * text::line_height(TEXT_PX)) as i32, shown, TEXT_PX, INK);
            }
        }
    }
    encode(&img).map_err(|e| SwatchError::Encode(e.to_string()))
}

/// Palette colours resolved for some filaments, straight to a PNG.
pub fn render_resolved_png(resolved: &[Resolved], layout: &SwatchLayout) -> Result<Vec<u8>, SwatchError> {
    let entries: Vec<SwatchEntry> = resolved.iter().map(SwatchEntry::from).collect();
    render_png(&entries, layout)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::mixing::MixingModel;
    use crate::colour::named_mixes::Palette;
    use crate::colour::pigments::CMYW_FILAMENTS;

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
        let img = image::load_from_memory(bytes).unwrap();
        assert_eq!(img.color(), image::ColorType::Rgb8);
        Decoded { width: img.width(), height: img.height(), rgb: img.into_rgb8().into_raw() }
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
        // 2 columns x 2 rows of (40 + 6) px plus a 6 px margin, and the label strip.
        let label = label_px();
        assert_eq!((img.width, img.height), (6 + 2 * 46, 6 + 2 * (46 + label)));
        assert_eq!(img.at(6 + 20, 6 + 10), red);
        // Second square: prediction above and right, target in the bottom-left bar.
        let (x, y) = (6 + 46, 6);
        assert_eq!(img.at(x + 20, y + 10), near_pink);
        assert_eq!(img.at(x + 5, y + 37), pink);
        assert_eq!(img.at(x + 30, y + 37), near_pink);
        // Third square starts the second row.
        assert_eq!(img.at(6 + 20, 6 + 46 + label + 10), Srgb8::new(0, 0, 0));
        assert_eq!(img.at(2, 2), Srgb8::new(250, 250, 250));
        // Under the first square, its name and hex code in dark ink, each on its own line.
        let ink = |x0: u32, y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x0 + 40).map(move |x| (x, y)))
                .filter(|&(x, y)| img.at(x, y).r < 160)
                .count()
        };
        let line = text::line_height(TEXT_PX);
        let (name, hex) = (ink(6, 48, 48 + line), ink(6, 48 + line, 48 + 2 * line));
        assert!(name > 10 && hex > 2 * name, "{name} {hex}");
    }

    #[test]
    fn long_names_are_cut_to_their_square() {
        let layout = SwatchLayout { cell_px: 30, columns: 2, labels: true };
        let long = entry("Wwwwwwwwwwwwwwwwwwwwwwwwwww", Srgb8::new(10, 10, 10), None);
        let img = decode(&render_png(&[long, entry("B", Srgb8::new(9, 9, 9), None)], &layout).unwrap());
        // The gap between the squares stays free of the first name's ink.
        let y0 = 6 + 30 + 2;
        let gap_ink = (y0..y0 + label_px() - 2).flat_map(|y| (36..42).map(move |x| (x, y)));
        assert!(gap_ink.clone().all(|(x, y)| img.at(x, y) == Srgb8::new(250, 250, 250)));
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
        assert_eq!((img.width, img.height), (6 + 6 * 102, 6 + 3 * (102 + label_px())));
        // Yellow is the 9th colour: row 1, column 2.
        let yellow = resolved[8].predicted;
        // The yellow filament (255, 224, 0) with its blue lifted to RGB_MIN.
        assert_eq!(yellow, Srgb8::new(255, 224, 3));
        assert_eq!(img.at(6 + 2 * 102 + 48, 6 + 102 + label_px() + 48), yellow);
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
