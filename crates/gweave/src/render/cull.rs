//! Which strokes of a drawing are worth rasterising: past an ink budget only every `k`-th
//! ([`overdraw_stride`]), and never one that the strokes in front of it hide ([`Opaque`]).
//!
//! A whole print seen from above is mostly covered by its top layers, and skipping what cannot
//! show makes a picture of a 17-million-segment file several times faster. The strokes are
//! painted front to back, each behind what is painted already
//! ([`crate::picture::Painter::behind`]), so the image itself is the mask: a pixel whose alpha
//! reached 255 takes no more paint, and a stroke is hidden when every pixel it could change is
//! opaque. Skipping it changes no pixel, so the picture is the one painting everything gives,
//! with no margin to guess for the rasteriser's anti-aliasing: a pixel on the edge of two
//! strokes counts as covered once the two together have covered it.
//!
//! The test is cheap beside painting: the image is cut into 8 x 8 tiles, a tile found opaque
//! stays opaque (paint behind never lowers an alpha), and a tile is looked at again only after
//! a stroke was painted on it; a stroke on opaque tiles is skipped without looking at a pixel,
//! one on other tiles by the alpha of the pixels within its reach.

use super::view::Stroke;

/// How many pictures' worth of pixels drawing may visit before the strokes are thinned: 2.8e8
/// visits for a 1200 x 900 picture, about 4 s in a release build. Whole prints of the test
/// files visit 4 to 140 pictures' worth (the most: a 400 x 300 picture of a 200-layer print
/// seen from the side), a file of a million travel moves across the bed about 5 000.
const MAX_OVERDRAW: f64 = 256.0;

/// Draw every `k`-th stroke so that the ink stays under [`MAX_OVERDRAW`] pictures (1: all).
pub(super) fn overdraw_stride(strokes: &[Stroke], width: u32, height: u32) -> usize {
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

/// Side of the square tiles, px.
const TILE: usize = 8;
/// How far past its half width a line 1 px wide or more may change pixels (their centres), px.
/// A line is filled as a polygon inside its capsule ([`crate::picture::Painter::polyline`]),
/// and `tiny-skia` covers a pixel by point samples (Skia's `SkScan_AntiPath`, 4 x 4 per pixel):
/// sample rows a quarter pixel apart through the row centres at 1/8, 3/8, 5/8 and 7/8, and along
/// a row the span between two edges rounded to a quarter pixel, which takes in the columns whose
/// centres (the same eighths) lie inside. A covered sample is therefore a point of the shape at
/// most `3/8 * sqrt(2)` = 0.530 px from the pixel's centre. The rest is the fixed point of the
/// edge walker (coordinates in 1/256 px, slopes in 1/65536 of a sample row: under 0.02 px
/// down a 900 px edge), with more than three times that to spare. The tests that paint with and
/// without skipping fail from 0.5 down. Every pixel looked at beyond the reach makes strokes
/// seem visible that are not: with 1.0, the iso view of the benchmark file painted 45 % more
/// strokes (63 600 against 43 800), to the same picture.
const REACH_PX: f32 = 0.6;

/// How far from its middle line a line thinner than a pixel may change pixels, px: `tiny-skia`
/// draws it as an anti-aliased hairline (Skia's "modulated hairline"), one pixel wide, whose
/// coverage falls off to nothing one pixel away from the line, and whose round ends lengthen it
/// by half a pixel; 0.1 px to spare. The hairline test fails from 1.0 down.
const HAIRLINE_REACH_PX: f32 = 1.6;

/// What the strokes painted so far hide, read from the image they are painted on.
pub(super) struct Opaque {
    w: usize,
    h: usize,
    tiles_x: usize,
    /// Tiles whose every pixel is opaque (for good: alpha never drops).
    full: Vec<bool>,
    /// Tiles painted on since they were last looked at.
    painted: Vec<bool>,
}

impl Opaque {
    /// Nothing is hidden on a `w` x `h` image with nothing painted.
    pub(super) fn new(w: u32, h: u32) -> Self {
        let (w, h) = (w as usize, h as usize);
        let tiles = w.div_ceil(TILE) * h.div_ceil(TILE);
        Opaque { w, h, tiles_x: w.div_ceil(TILE), full: vec![false; tiles], painted: vec![false; tiles] }
    }

    /// The pixel box `s` could change, clipped to the image: `x0, y0, x1, y1`, or `None` when
    /// it draws nothing (off the picture, or NaN).
    fn reach(&self, s: &Stroke) -> Option<(f32, [usize; 4])> {
        let reach = if s.width_px >= 1.0 { s.width_px / 2.0 + REACH_PX } else { HAIRLINE_REACH_PX };
        let x0 = floor(s.from[0].min(s.to[0]) - reach).max(0.0);
        let y0 = floor(s.from[1].min(s.to[1]) - reach).max(0.0);
        let x1 = ceil(s.from[0].max(s.to[0]) + reach).min(self.w as f32);
        let y1 = ceil(s.from[1].max(s.to[1]) + reach).min(self.h as f32);
        (x0 < x1 && y0 < y1).then_some((reach, [x0 as usize, y0 as usize, x1 as usize, y1 as usize]))
    }

    /// Tile numbers of the pixel box `x0, y0, x1, y1`: rows of tiles, each a range.
    fn tile_rows(&self, [x0, y0, x1, y1]: [usize; 4]) -> impl Iterator<Item = std::ops::Range<usize>> {
        let (tiles_x, (tx0, tx1)) = (self.tiles_x, (x0 / TILE, x1.div_ceil(TILE)));
        (y0 / TILE..y1.div_ceil(TILE)).map(move |ty| ty * tiles_x + tx0..ty * tiles_x + tx1)
    }

    /// Whether every pixel of tile `t` of `rgba` is opaque.
    fn tile_opaque(&self, rgba: &[u8], t: usize) -> bool {
        let (x0, y0) = ((t % self.tiles_x) * TILE, (t / self.tiles_x) * TILE);
        let (x1, y1) = ((x0 + TILE).min(self.w), (y0 + TILE).min(self.h));
        (y0..y1).all(|y| {
            let row = &rgba[(y * self.w + x0) * 4..(y * self.w + x1) * 4];
            row.chunks_exact(4).all(|px| px[3] == 255)
        })
    }

    /// Nothing `s` would paint on `rgba` (premultiplied, painted front to back) can show:
    /// every pixel it could change is opaque.
    pub(super) fn hides(&mut self, rgba: &[u8], s: &Stroke) -> bool {
        let Some((reach, bbox)) = self.reach(s) else {
            return true;
        };
        let mut all_full = true;
        for row in self.tile_rows(bbox) {
            for t in row {
                if !self.full[t] && self.painted[t] {
                    self.painted[t] = false;
                    self.full[t] = self.tile_opaque(rgba, t);
                }
                all_full &= self.full[t];
            }
        }
        if all_full {
            return true;
        }
        let (w, h) = (self.w as u32, self.h as u32);
        let reach2 = reach * reach;
        // The alpha first: most pixels looked at are opaque, and the distance is the dearer
        // test.
        within(s.from, s.to, reach, w, h, |x, y, centre| {
            rgba[(y * self.w + x) * 4 + 3] == 255 || centre.dist2() > reach2
        })
    }

    /// `s` is painted: its tiles may have become opaque.
    pub(super) fn painted(&mut self, s: &Stroke) {
        if let Some((_, bbox)) = self.reach(s) {
            for row in self.tile_rows(bbox) {
                self.painted[row].fill(true);
            }
        }
    }
}

/// `v.floor()` without a call into the C library (x86-64 before SSE 4.1 has no instruction for
/// it), for the pixel positions of a picture (well within `i32`).
fn floor(v: f32) -> f32 {
    let t = v as i32 as f32;
    if t > v {
        t - 1.0
    } else {
        t
    }
}

/// `v.ceil()`, as [`floor`].
fn ceil(v: f32) -> f32 {
    let t = v as i32 as f32;
    if t < v {
        t + 1.0
    } else {
        t
    }
}

/// Calls `f(x, y, centre)` for the pixels of a `width` x `height` image whose centres may lie
/// within `reach` of the segment `p0`-`p1` (every one that does, and a few that do not),
/// `centre.dist2()` giving the square of the centre's distance to the segment (worked out only
/// when `f` asks); stops when `f` returns `false`. Returns whether every call returned `true`.
///
/// Each row is scanned only where the capsule can be: a point within `reach` of the segment is
/// within `reach` of its line, and on the row `y` those points are
/// `|x - x_line(y)| <= reach * len / |dy|`. For a long diagonal this visits about `len * width`
/// pixels instead of the `len^2 / 2` of its bounding box.
fn within(
    p0: [f32; 2],
    p1: [f32; 2],
    reach: f32,
    width: u32,
    height: u32,
    mut f: impl FnMut(usize, usize, Centre) -> bool,
) -> bool {
    let x_lo = floor(p0[0].min(p1[0]) - reach).max(0.0);
    let y_lo = floor(p0[1].min(p1[1]) - reach).max(0.0);
    let x_hi = ceil(p0[0].max(p1[0]) + reach).min(width as f32);
    let y_hi = ceil(p0[1].max(p1[1]) + reach).min(height as f32);
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
            xa = xa.max(floor(x_line - half_span - 1.5));
            xb = xb.min(ceil(x_line + half_span + 0.5));
        }
        if xa >= xb {
            continue;
        }
        for x in xa as usize..xb as usize {
            if !f(x, y, Centre { p: [x as f32 + 0.5, py], p0, d, len2 }) {
                return false;
            }
        }
    }
    true
}

/// A pixel's centre `p` beside the segment from `p0` along `d` (`len2`: its length squared).
struct Centre {
    p: [f32; 2],
    p0: [f32; 2],
    d: [f32; 2],
    len2: f32,
}

impl Centre {
    /// The square of the distance from the centre to the nearest point of the segment.
    #[inline]
    fn dist2(&self) -> f32 {
        let ([px, py], p0, d) = (self.p, self.p0, self.d);
        let t = if self.len2 > 0.0 {
            (((px - p0[0]) * d[0] + (py - p0[1]) * d[1]) / self.len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (qx, qy) = (p0[0] + d[0] * t - px, p0[1] + d[1] * t - py);
        qx * qx + qy * qy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_and_ceil_are_the_library_ones() {
        for v in [-2.5f32, -1.0, -0.25, 0.0, 0.25, 1.0, 1.5, 899.999, 1200.0, 4096.5] {
            assert_eq!(floor(v), v.floor(), "{v}");
            assert_eq!(ceil(v), v.ceil(), "{v}");
        }
    }
}
