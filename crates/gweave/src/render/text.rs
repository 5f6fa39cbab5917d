//! Text in pictures: one embedded font, Open Sans Regular (`crates/gweave/assets/`, Apache-2.0,
//! its licence beside it), laid out and rasterised by `ab_glyph`.
//!
//! A line of text is laid out on a baseline: each glyph's advance plus the kerning with the one
//! before it, scaled to the size asked (the size is the font's height from descender to ascender
//! in pixels, `ab_glyph`'s `PxScale`). Each glyph outline is then rasterised to a coverage per
//! pixel (0..1, the area of the pixel inside the outline), which [`super::raster::Image`] blends
//! like any other anti-aliased shape. The charts of `gweave sim --plot` use the same font
//! through `plotters` ([`FONT_TTF`]), so every picture gweave draws has one typeface.

use std::sync::OnceLock;

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};

/// The font file, for libraries that take the bytes (`plotters`).
pub const FONT_TTF: &[u8] = include_bytes!("../../assets/OpenSans-Regular.ttf");

/// The parsed font.
fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    // The bytes are part of the binary and parsed in a test: this cannot fail at run time.
    FONT.get_or_init(|| FontRef::try_from_slice(FONT_TTF).expect("the embedded font is a valid TTF"))
}

/// Height of a line of text at `size_px`: ascender to descender, rounded up, px.
pub fn line_height(size_px: f32) -> u32 {
    let f = font().as_scaled(PxScale::from(size_px));
    (f.ascent() - f.descent()).ceil() as u32
}

/// Width of `s` at `size_px`, px.
pub fn width(s: &str, size_px: f32) -> u32 {
    layout(s, size_px, |_, _| {}).ceil() as u32
}

/// The longest start of `s` that is at most `max_px` wide at `size_px`.
pub fn fitting(s: &str, size_px: f32, max_px: u32) -> &str {
    let mut end = 0;
    for (i, c) in s.char_indices() {
        let next = i + c.len_utf8();
        if width(&s[..next], size_px) > max_px {
            break;
        }
        end = next;
    }
    &s[..end]
}

/// Calls `coverage(x, y, c)` for the pixels of `s` at `size_px` whose top left is at (`x`, `y`)
/// (the top of the line, the ascender), `c` in 0..=1. Returns the width, px.
pub(crate) fn rasterise(
    s: &str,
    size_px: f32,
    x: f32,
    y: f32,
    mut coverage: impl FnMut(i32, i32, f32),
) -> u32 {
    let scale = PxScale::from(size_px);
    let ascent = font().as_scaled(scale).ascent();
    let w = layout(s, size_px, |id, pen_x| {
        let glyph = id.with_scale_and_position(scale, point(x + pen_x, y + ascent));
        if let Some(outline) = font().outline_glyph(glyph) {
            let b = outline.px_bounds();
            outline.draw(|gx, gy, c| coverage(b.min.x as i32 + gx as i32, b.min.y as i32 + gy as i32, c));
        }
    });
    w.ceil() as u32
}

/// Lays `s` out from pen position 0: calls `glyph(id, pen_x)` for each character and returns
/// the advance of the whole line, px.
fn layout(s: &str, size_px: f32, mut glyph: impl FnMut(ab_glyph::GlyphId, f32)) -> f32 {
    let f = font().as_scaled(PxScale::from(size_px));
    let mut pen = 0.0;
    let mut last = None;
    for c in s.chars() {
        let id = f.glyph_id(c);
        if let Some(prev) = last {
            pen += f.kern(prev, id);
        }
        glyph(id, pen);
        pen += f.h_advance(id);
        last = Some(id);
    }
    pen
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_font_parses_and_measures() {
        assert!(FontRef::try_from_slice(FONT_TTF).is_ok());
        // A 20 px line is 20 px from descender to ascender; "W" is wider than "i".
        assert_eq!(line_height(20.0), 20);
        assert!(width("W", 20.0) > 2 * width("i", 20.0));
        assert_eq!(width("", 20.0), 0);
        assert_eq!(fitting("hotend T0", 20.0, width("hotend", 20.0)), "hotend");
        assert_eq!(fitting("abc", 20.0, 0), "");
    }

    #[test]
    fn glyphs_cover_pixels_inside_their_box() {
        let mut covered = Vec::new();
        let w = rasterise("H", 20.0, 10.0, 5.0, |x, y, c| {
            if c > 0.5 {
                covered.push((x, y));
            }
        });
        assert!(w > 8, "{w}");
        assert!(!covered.is_empty());
        // All ink is right of x = 10 and within one line below y = 5.
        let h = line_height(20.0) as i32;
        assert!(covered.iter().all(|&(x, y)| (10..10 + w as i32).contains(&x) && (5..5 + h).contains(&y)));
        // "H" has two stems: a column through its middle height has ink at both sides only.
        let row = covered.iter().map(|p| p.1).min().unwrap() + 3;
        let xs: Vec<i32> = covered.iter().filter(|p| p.1 == row).map(|p| p.0).collect();
        let (lo, hi) = (*xs.iter().min().unwrap(), *xs.iter().max().unwrap());
        assert!(!xs.contains(&((lo + hi) / 2)), "{xs:?}");
    }
}
