//! Text in pictures: one embedded font, Open Sans Regular (`crates/gweave/assets/`, Apache-2.0,
//! its licence beside it), laid out and rasterised by `ab_glyph`.
//!
//! A line of text is laid out on a baseline: each glyph's advance plus the kerning with the one
//! before it, scaled to the size asked (the size is the font's height from descender to ascender
//! in pixels, `ab_glyph`'s `PxScale`). The glyph outlines (lines and quadratic or cubic Beziers)
//! become one path that `super::raster` fills like any other shape, with the same
//! anti-aliasing. The PNG charts of `gweave sim --plot` are drawn with these outlines too (their
//! `plotters` backend lays text out with [`width`] and [`line_height`]); the SVG charts name the
//! font and `plotters` measures them with the same file ([`FONT_TTF`]), so every picture gweave
//! draws has one typeface.

use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, OutlineCurve, PxScale, ScaleFont};

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

/// The outlines of `s` at `size_px` whose top left is at (`x`, `y`) (the top of the line, the
/// ascender), as one path in pixels for the rasteriser to fill (nonzero winding, as TrueType
/// outlines are drawn), and the width of the line, px. `None` when nothing has ink (spaces).
pub(crate) fn outline(s: &str, size_px: f32, x: f32, y: f32) -> (Option<tiny_skia::Path>, u32) {
    let scaled = font().as_scaled(PxScale::from(size_px));
    let (sx, sy) = (scaled.h_scale_factor(), scaled.v_scale_factor());
    let baseline = y + scaled.ascent();
    let mut pb = tiny_skia::PathBuilder::new();
    let w = layout(s, size_px, |id, pen_x| {
        let Some(outline) = font().outline(id) else {
            return;
        };
        // Font units, y up, to pixels, y down.
        let px = |p: ab_glyph::Point| (x + pen_x + p.x * sx, baseline - p.y * sy);
        let mut at = None;
        for curve in &outline.curves {
            let (start, end) = match *curve {
                OutlineCurve::Line(a, b) | OutlineCurve::Quad(a, _, b) | OutlineCurve::Cubic(a, _, _, b) => {
                    (a, b)
                }
            };
            // The curves of a contour follow on; a new contour starts where they do not.
            if at != Some(start) {
                let (x0, y0) = px(start);
                pb.move_to(x0, y0);
            }
            match *curve {
                OutlineCurve::Line(_, b) => {
                    let (x1, y1) = px(b);
                    pb.line_to(x1, y1);
                }
                OutlineCurve::Quad(_, c, b) => {
                    let ((cx, cy), (x1, y1)) = (px(c), px(b));
                    pb.quad_to(cx, cy, x1, y1);
                }
                OutlineCurve::Cubic(_, c0, c1, b) => {
                    let ((ax, ay), (bx, by), (x1, y1)) = (px(c0), px(c1), px(b));
                    pb.cubic_to(ax, ay, bx, by, x1, y1);
                }
            }
            at = Some(end);
        }
    });
    (pb.finish(), w.ceil() as u32)
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
    fn outlines_lie_inside_their_line() {
        let (path, w) = outline("Hg", 20.0, 10.0, 5.0);
        let b = path.unwrap().bounds();
        assert_eq!(w, width("Hg", 20.0));
        // Ink starts at or just right of the pen and ends within the advance; it spans the line,
        // from near the ascender (H) to near the descender (g).
        let h = line_height(20.0) as f32;
        assert!(b.left() >= 10.0 && b.left() < 12.0 && b.right() <= 10.0 + w as f32, "{b:?}");
        assert!(b.top() >= 5.0 && b.top() < 5.0 + h / 3.0, "{b:?}");
        assert!(b.bottom() <= 5.0 + h && b.bottom() > 5.0 + 2.0 * h / 3.0, "{b:?}");
        assert!(outline(" ", 20.0, 0.0, 0.0).0.is_none());
    }
}
