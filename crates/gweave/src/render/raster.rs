//! A small software rasteriser: an RGBA8 image, anti-aliased wide lines with alpha blending,
//! filled rectangles and text in the embedded font ([`super::text`]).
//!
//! A line of width `w` is the set of points within `w/2` of the segment (a capsule). Each pixel
//! in the capsule's bounding box gets coverage `clamp(w/2 + 1/2 - d, 0, 1)`, where `d` is the
//! distance from the pixel centre to the segment: a one-pixel linear ramp across the edge, the
//! usual cheap approximation of box-filtered area coverage. The colour is blended "over" the
//! image: `dst = src * a + dst * (1 - a)` with `a = alpha * coverage` (Porter and Duff, 1984).

use super::text;

/// An RGBA8 image, rows top first.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba: Vec<u8>,
}

impl Image {
    /// An opaque image filled with `background`.
    pub fn new(width: u32, height: u32, background: [u8; 3]) -> Image {
        let px = [background[0], background[1], background[2], 255];
        Image { width, height, rgba: px.repeat(width as usize * height as usize) }
    }

    /// The pixel at (x, y) as RGBA.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = (y as usize * self.width as usize + x as usize) * 4;
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2], self.rgba[i + 3]]
    }

    #[inline]
    fn blend(&mut self, x: usize, y: usize, c: [u8; 3], a: f32) {
        let i = (y * self.width as usize + x) * 4;
        let px = &mut self.rgba[i..i + 3];
        for k in 0..3 {
            px[k] = (c[k] as f32 * a + px[k] as f32 * (1.0 - a) + 0.5) as u8;
        }
    }

    /// An anti-aliased line from `p0` to `p1` (pixel coordinates, centres at +0.5), `width_px`
    /// wide, with round ends.
    pub fn line(&mut self, p0: [f32; 2], p1: [f32; 2], width_px: f32, c: [u8; 3], alpha: f32) {
        let (w, h) = (self.width, self.height);
        line_pixels(p0, p1, width_px, w, h, |x, y, cover| {
            self.blend(x, y, c, alpha * cover);
            true
        });
    }

    /// A filled rectangle, clipped to the image.
    pub fn rect(&mut self, x: i32, y: i32, w: u32, h: u32, c: [u8; 3], alpha: f32) {
        let x0 = x.max(0) as usize;
        let y0 = y.max(0) as usize;
        let x1 = (x + w as i32).clamp(0, self.width as i32) as usize;
        let y1 = (y + h as i32).clamp(0, self.height as i32) as usize;
        for yy in y0..y1 {
            for xx in x0..x1 {
                self.blend(xx, yy, c, alpha);
            }
        }
    }

    /// Text in the embedded font, `size_px` tall ([`text::line_height`]), its top left at
    /// (`x`, `y`), anti-aliased and clipped to the image. Returns the width drawn, px.
    pub fn text(&mut self, x: i32, y: i32, s: &str, size_px: f32, c: [u8; 3]) -> u32 {
        let (w, h) = (self.width as i32, self.height as i32);
        text::rasterise(s, size_px, x as f32, y as f32, |px, py, cover| {
            if (0..w).contains(&px) && (0..h).contains(&py) && cover > 0.0 {
                self.blend(px as usize, py as usize, c, cover.min(1.0));
            }
        })
    }
}

/// Calls `f(x, y, cover)` for every pixel of a `width` x `height` image that a line from `p0`
/// to `p1`, `width_px` wide, covers (`cover > 0`; see the module notes), rows top first, until
/// `f` returns `false`. Returns whether every call returned `true`. NaN coordinates cover
/// nothing.
pub(crate) fn line_pixels(
    p0: [f32; 2],
    p1: [f32; 2],
    width_px: f32,
    width: u32,
    height: u32,
    mut f: impl FnMut(usize, usize, f32) -> bool,
) -> bool {
    let reach = width_px.max(0.5) / 2.0 + 0.5;
    // Squared distances at or beyond this are surely past `reach`: no square root for them.
    let beyond2 = reach * reach * 1.0001;
    let thin = width_px < 1.0;
    within(p0, p1, reach, width, height, |x, y, dist2| {
        if dist2 >= beyond2 {
            return true;
        }
        let mut cover = (reach - dist2.sqrt()).clamp(0.0, 1.0);
        if thin {
            cover *= width_px;
        }
        // NaN coordinates give a NaN cover: nothing drawn.
        if cover > 0.0 {
            f(x, y, cover)
        } else {
            true
        }
    })
}

/// Calls `f(x, y, dist2)` for the pixels of a `width` x `height` image whose centres may lie
/// within `reach` of the segment `p0`-`p1` (every one that does, and a few that do not),
/// `dist2` being the square of the centre's distance to the segment; stops when `f` returns
/// `false`.
///
/// Each row is scanned only where the capsule can be: a point within `reach` of the segment is
/// within `reach` of its line, and on the row `y` those points are
/// `|x - x_line(y)| <= reach * len / |dy|`. For a long diagonal this visits about `len * width`
/// pixels instead of the `len^2 / 2` of its bounding box.
pub(crate) fn within(
    p0: [f32; 2],
    p1: [f32; 2],
    reach: f32,
    width: u32,
    height: u32,
    mut f: impl FnMut(usize, usize, f32) -> bool,
) -> bool {
    let x_lo = (p0[0].min(p1[0]) - reach).floor().max(0.0);
    let y_lo = (p0[1].min(p1[1]) - reach).floor().max(0.0);
    let x_hi = (p0[0].max(p1[0]) + reach).ceil().min(width as f32);
    let y_hi = (p0[1].max(p1[1]) + reach).ceil().min(height as f32);
    if !(x_lo < x_hi && y_lo < y_hi) {
        return true;
    }
    let d = [p1[0] - p0[0], p1[1] - p0[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    // Half the row's span around the line, when the line is steep enough for it to help.
    let span = (d[1].abs() > 1e-3).then(|| (reach * len2.sqrt() / d[1].abs(), d[0] / d[1]));
    for y in y_lo as usize..y_hi as usize {
        let py = y as f32 + 0.5;
        let (mut xa, mut xb) = (x_lo, x_hi);
        if let Some((half_span, slope)) = span {
            let x_line = p0[0] + slope * (py - p0[1]);
            // Pixel x has its centre at x + 0.5; one pixel to spare for rounding.
            xa = xa.max((x_line - half_span - 1.5).floor());
            xb = xb.min((x_line + half_span + 0.5).ceil());
        }
        if xa >= xb {
            continue;
        }
        for x in xa as usize..xb as usize {
            let px = x as f32 + 0.5;
            // Distance from the pixel centre to the nearest point of the segment.
            let t = if len2 > 0.0 {
                (((px - p0[0]) * d[0] + (py - p0[1]) * d[1]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (qx, qy) = (p0[0] + d[0] * t - px, p0[1] + d[1] * t - py);
            if !f(x, y, qx * qx + qy * qy) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wide_line_covers_its_body_and_nothing_far_away() {
        let mut img = Image::new(40, 20, [255, 255, 255]);
        img.line([5.0, 10.5], [35.0, 10.5], 4.0, [255, 0, 0], 1.0);
        assert_eq!(img.pixel(20, 10), [255, 0, 0, 255]);
        assert_eq!(img.pixel(20, 9), [255, 0, 0, 255]);
        assert_eq!(img.pixel(20, 14), [255, 255, 255, 255], "3.5 px from the axis, width 4");
        assert_eq!(img.pixel(1, 10), [255, 255, 255, 255], "beyond the round end");
        // Row 12 (centre 12.5) is 2 px from the axis, on the edge: half covered.
        let edge = img.pixel(20, 12);
        assert!(edge[1] > 0 && edge[1] < 255, "{edge:?}");
    }

    #[test]
    fn alpha_blends_over_the_background() {
        let mut img = Image::new(10, 10, [0, 0, 0]);
        img.line([0.0, 5.0], [10.0, 5.0], 3.0, [200, 100, 0], 0.5);
        assert_eq!(img.pixel(5, 5), [100, 50, 0, 255]);
    }

    #[test]
    fn offscreen_and_nan_lines_draw_nothing() {
        let mut img = Image::new(10, 10, [1, 2, 3]);
        let before = img.clone();
        img.line([-50.0, -50.0], [-20.0, -30.0], 3.0, [255, 0, 0], 1.0);
        img.line([f32::NAN, 1.0], [5.0, 5.0], 3.0, [255, 0, 0], 1.0);
        assert_eq!(img, before);
    }

    #[test]
    fn text_is_drawn_in_the_font_and_clipped() {
        let mut img = Image::new(60, 30, [255, 255, 255]);
        let w = img.text(2, 2, "T1", 20.0, [0, 0, 0]);
        assert_eq!(w, text::width("T1", 20.0));
        // T's bar: dark pixels on its top rows, between x = 2 and the width; none below the line.
        let dark = |img: &Image, x: u32, y: u32| img.pixel(x, y)[0] < 100;
        assert!((2..2 + w).any(|x| (2..10).any(|y| dark(&img, x, y))));
        assert!((0..60).all(|x| !dark(&img, x, 29)));
        // Text running off the image is clipped, not wrapped.
        let mut img = Image::new(10, 10, [255, 255, 255]);
        img.text(-5, 2, "WWWW", 20.0, [0, 0, 0]);
        assert!((0..10).any(|x| dark(&img, x, 8)));
    }

    #[test]
    fn row_spans_visit_every_covered_pixel_of_the_bounding_box() {
        // The same pixels and coverage as testing every pixel of the bounding box, for lines in
        // all directions, widths and lengths.
        let cases = [
            ([3.3, 4.1], [60.2, 41.7], 3.0),
            ([50.0, 2.0], [51.0, 60.0], 0.7),
            ([10.0, 30.0], [60.0, 30.2], 5.0),
            ([40.0, 40.0], [40.0, 40.0], 4.0),
            ([61.0, 3.0], [2.0, 58.0], 2.2),
        ];
        for (p0, p1, w) in cases {
            let mut fast = Vec::new();
            line_pixels(p0, p1, w, 64, 64, |x, y, c| {
                fast.push((x, y, c));
                true
            });
            let (reach, d) = (w.max(0.5) / 2.0 + 0.5, [p1[0] - p0[0], p1[1] - p0[1]]);
            let len2 = d[0] * d[0] + d[1] * d[1];
            let mut slow = Vec::new();
            for y in 0..64 {
                for x in 0..64 {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let t = if len2 > 0.0 {
                        (((px - p0[0]) * d[0] + (py - p0[1]) * d[1]) / len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let dist = (p0[0] + d[0] * t - px).hypot(p0[1] + d[1] * t - py);
                    let c = (reach - dist).clamp(0.0, 1.0) * if w < 1.0 { w } else { 1.0 };
                    if c > 0.0 {
                        slow.push((x, y, c));
                    }
                }
            }
            assert_eq!(fast.len(), slow.len(), "{p0:?} {p1:?} {w}");
            assert!(fast
                .iter()
                .zip(&slow)
                .all(|(a, b)| a.0 == b.0 && a.1 == b.1 && (a.2 - b.2).abs() < 1e-5));
        }
    }
}
