//! The one rasteriser of every picture gweave draws: an RGBA8 image painted by `tiny-skia`
//! (anti-aliased strokes with round caps, filled rectangles, text as glyph outlines, alpha
//! blending).
//!
//! `tiny-skia` is a port of Skia's CPU rasteriser: a path is scan-converted with 4 x 4
//! supersampling (Skia's `SkScan_AntiPath`), so a pixel's coverage is the share of its 16 sample
//! points inside the shape, and a pixel wholly inside is fully covered. A line of width `w` is
//! filled as the points within `w/2` of the segment (round caps, as polygons within a tenth of
//! a pixel of their arcs); a line thinner than a pixel is drawn one pixel wide with its alpha
//! scaled by its width (Skia's "modulated hairline"). The colour is blended "over" the image:
//! `dst = src * a + dst * (1 - a)` with `a = alpha * coverage` (Porter and Duff, 1984).
//!
//! A finished image is opaque (its background is), so the premultiplied RGBA that `tiny-skia`
//! works in is plain RGBA: [`Image::rgba`] is read and encoded as it is. While a picture is
//! painted front to back ([`Painter::behind`]) it starts transparent, and the alpha of a pixel
//! says how much of it is painted.

use tiny_skia::{
    BlendMode, FillRule, LineCap, LineJoin, Paint, PathBuilder, PixmapMut, Rect, Stroke, Transform,
};

use super::text;

/// An RGBA8 image, rows top first.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// `width * height * 4` bytes, opaque.
    pub rgba: Vec<u8>,
}

impl Image {
    /// An opaque image filled with `background`.
    pub fn new(width: u32, height: u32, background: [u8; 3]) -> Image {
        let px = [background[0], background[1], background[2], 255];
        Image { width, height, rgba: px.repeat(width as usize * height as usize) }
    }

    /// An image with nothing painted (every pixel transparent black), to paint front to back
    /// ([`Painter::behind`]).
    pub fn transparent(width: u32, height: u32) -> Image {
        Image { width, height, rgba: vec![0; width as usize * height as usize * 4] }
    }

    /// The pixel at (x, y) as RGBA.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = (y as usize * self.width as usize + x as usize) * 4;
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2], self.rgba[i + 3]]
    }

    /// A painter on this image, for drawing many shapes in a row. `None` for an empty image.
    pub fn painter(&mut self) -> Option<Painter<'_>> {
        let pixmap = PixmapMut::from_bytes(&mut self.rgba, self.width, self.height)?;
        Some(Painter {
            pixmap,
            paint: Paint::default(),
            stroke: Stroke { line_cap: LineCap::Round, line_join: LineJoin::Round, ..Stroke::default() },
            builder: PathBuilder::new(),
        })
    }

    /// An anti-aliased line from `p0` to `p1` (pixel coordinates, centres at +0.5), `width_px`
    /// wide, with round ends.
    pub fn line(&mut self, p0: [f32; 2], p1: [f32; 2], width_px: f32, c: [u8; 3], alpha: f32) {
        if let Some(mut p) = self.painter() {
            p.line(p0, p1, width_px, c, alpha);
        }
    }

    /// A filled rectangle, clipped to the image.
    pub fn rect(&mut self, x: i32, y: i32, w: u32, h: u32, c: [u8; 3], alpha: f32) {
        if let Some(mut p) = self.painter() {
            p.rect(x, y, w, h, c, alpha);
        }
    }

    /// Text in the embedded font, `size_px` tall ([`text::line_height`]), its top left at
    /// (`x`, `y`), anti-aliased and clipped to the image. Returns the width drawn, px.
    pub fn text(&mut self, x: i32, y: i32, s: &str, size_px: f32, c: [u8; 3]) -> u32 {
        match self.painter() {
            Some(mut p) => p.text(x, y, s, size_px, c),
            None => text::width(s, size_px),
        }
    }
}

/// Draws on an [`Image`]; the paint and stroke settings are kept from one shape to the next.
pub struct Painter<'a> {
    pixmap: PixmapMut<'a>,
    paint: Paint<'static>,
    stroke: Stroke,
    /// Kept from one line to the next, with its buffers: a preview paints hundreds of
    /// thousands of short lines.
    builder: PathBuilder,
}

impl Painter<'_> {
    /// Paints every shape from now on behind what is painted already: Porter and Duff's
    /// "destination over", `dst = dst + src * (1 - dst_alpha)` in premultiplied colour. Shapes
    /// painted front to back this way give the picture painting them back to front "over" gives
    /// (the operator is associative), and a pixel whose alpha reached 255 takes no more paint:
    /// the image itself says what later shapes cannot change.
    pub fn behind(&mut self) {
        self.paint.blend_mode = BlendMode::DestinationOver;
    }

    /// The pixels painted so far, premultiplied RGBA, rows top first.
    pub fn rgba(&self) -> &[u8] {
        self.pixmap.as_ref().data()
    }

    fn colour(&mut self, c: [u8; 3], alpha: f32) {
        let a = (alpha.clamp(0.0, 1.0) * 255.0).round() as u8;
        self.paint.set_color_rgba8(c[0], c[1], c[2], a);
    }

    /// See [`Image::line`]. Lines with a NaN or infinite end draw nothing.
    pub fn line(&mut self, p0: [f32; 2], p1: [f32; 2], width_px: f32, c: [u8; 3], alpha: f32) {
        self.polyline(&[p0, p1], width_px, c, alpha);
    }

    /// Lines through `points` in turn, drawn as one shape with round joins and ends: where
    /// two of them meet, the joint is covered once, without the seam of two anti-aliased
    /// edges blended one over the other. Polylines with a NaN or infinite point draw nothing.
    pub fn polyline(&mut self, points: &[[f32; 2]], width_px: f32, c: [u8; 3], alpha: f32) {
        if points.is_empty() || points.iter().flatten().any(|v| !v.is_finite()) {
            return;
        }
        self.colour(c, alpha);
        let p0 = points[0];
        if points.iter().all(|p| *p == p0) {
            // A dot: its round ends meet.
            if let Some(dot) = PathBuilder::from_circle(p0[0], p0[1], width_px.max(1.0) / 2.0) {
                self.pixmap.fill_path(&dot, &self.paint, FillRule::Winding, Transform::identity(), None);
            }
            return;
        }
        // Lines from 1 px up are drawn as the area they cover; thinner ones as tiny-skia's
        // hairlines (Skia's "modulated hairline": one pixel wide, faded by the width).
        if width_px >= 1.0 {
            let mut pb = std::mem::take(&mut self.builder);
            capsules(&mut pb, points, width_px / 2.0);
            if let Some(path) = pb.finish() {
                self.pixmap.fill_path(&path, &self.paint, FillRule::Winding, Transform::identity(), None);
                self.builder = path.clear();
            }
            return;
        }
        self.stroke.width = width_px.max(0.0);
        let mut pb = PathBuilder::new();
        pb.move_to(p0[0], p0[1]);
        for p in &points[1..] {
            pb.line_to(p[0], p[1]);
        }
        if let Some(path) = pb.finish() {
            self.pixmap.stroke_path(&path, &self.paint, &self.stroke, Transform::identity(), None);
        }
    }

    /// See [`Image::rect`].
    pub fn rect(&mut self, x: i32, y: i32, w: u32, h: u32, c: [u8; 3], alpha: f32) {
        self.colour(c, alpha);
        if let Some(r) = Rect::from_xywh(x as f32, y as f32, w as f32, h as f32) {
            self.pixmap.fill_rect(r, &self.paint, Transform::identity(), None);
        }
    }

    /// A filled polygon through `points` (nonzero winding). Polygons with a NaN or infinite
    /// point draw nothing.
    pub fn polygon(&mut self, points: &[[f32; 2]], c: [u8; 3], alpha: f32) {
        if points.iter().flatten().any(|v| !v.is_finite()) {
            return;
        }
        self.colour(c, alpha);
        let mut pb = PathBuilder::new();
        for (i, p) in points.iter().enumerate() {
            if i == 0 {
                pb.move_to(p[0], p[1]);
            } else {
                pb.line_to(p[0], p[1]);
            }
        }
        pb.close();
        if let Some(path) = pb.finish() {
            self.pixmap.fill_path(&path, &self.paint, FillRule::Winding, Transform::identity(), None);
        }
    }

    /// A circle of `radius_px` about `centre`: filled, or (`outline_px`) its outline that wide.
    pub fn circle(
        &mut self,
        centre: [f32; 2],
        radius_px: f32,
        c: [u8; 3],
        alpha: f32,
        outline_px: Option<f32>,
    ) {
        let Some(path) = PathBuilder::from_circle(centre[0], centre[1], radius_px) else {
            return;
        };
        self.colour(c, alpha);
        match outline_px {
            Some(w) => {
                self.stroke.width = w.max(0.0);
                self.pixmap.stroke_path(&path, &self.paint, &self.stroke, Transform::identity(), None);
            }
            None => self.pixmap.fill_path(&path, &self.paint, FillRule::Winding, Transform::identity(), None),
        }
    }

    /// See [`Image::text`].
    pub fn text(&mut self, x: i32, y: i32, s: &str, size_px: f32, c: [u8; 3]) -> u32 {
        self.text_turned(x as f32, y as f32, s, size_px, c, 0)
    }

    /// Text turned `quarter_turns` times 90 degrees clockwise about its top left (`x`, `y`)
    /// (3: reading upwards, as a y axis's title). Returns its width along the line, px.
    pub fn text_turned(
        &mut self,
        x: f32,
        y: f32,
        s: &str,
        size_px: f32,
        c: [u8; 3],
        quarter_turns: u8,
    ) -> u32 {
        self.colour(c, 1.0);
        let (path, width) = text::outline(s, size_px, x, y);
        let turn = Transform::from_rotate_at(90.0 * f32::from(quarter_turns % 4), x, y);
        if let Some(path) = path {
            self.pixmap.fill_path(&path, &self.paint, FillRule::Winding, turn, None);
        }
        width
    }
}

/// How far a round end drawn as a polygon may fall inside its arc, px.
const ARC_TOLERANCE_PX: f32 = 0.1;

/// Adds to `pb` the points within `radius_px` of the polyline through `points` (a line with
/// round joins and ends) as one capsule per segment: a rectangle along it and a half circle
/// at each end, the half circles as polygons whose corners lie on the arc and whose sides
/// stay within [`ARC_TOLERANCE_PX`] of it. Every capsule turns the same way about its own
/// direction, so filled with the nonzero rule they make their union: the round joins, each
/// pixel covered once.
///
/// Filling straight edges is what `tiny-skia` does fastest: stroking a path instead builds its
/// outline from quadratic arcs, which the scan converter then cuts into lines again, and a
/// preview paints hundreds of thousands of short strokes.
fn capsules(pb: &mut PathBuilder, points: &[[f32; 2]], radius_px: f32) {
    // A chord of angle `step` on a circle of radius r lies r (1 - cos(step / 2)) inside it.
    let step = 2.0 * (1.0 - (ARC_TOLERANCE_PX / radius_px).min(1.0)).acos();
    let n = (std::f32::consts::PI / step).ceil().clamp(2.0, 32.0) as usize;
    // The corners of a half circle of radius `radius_px`, from the left of the direction
    // of travel round the back to its right: (along, across).
    let mut arc = [(0.0, 0.0); 33];
    for (i, corner) in arc[..=n].iter_mut().enumerate() {
        let (sin, cos) = (std::f32::consts::PI * i as f32 / n as f32).sin_cos();
        *corner = (radius_px * sin, radius_px * cos);
    }
    let arc = &arc[..=n];
    for pair in points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = dx.hypot(dy);
        if len == 0.0 {
            // The segments next to it cover the point.
            continue;
        }
        // Along the segment, and to its left.
        let (u, v) = ([dx / len, dy / len], [-dy / len, dx / len]);
        let corner = |p: [f32; 2], along: f32, across: f32| {
            [p[0] + u[0] * along + v[0] * across, p[1] + u[1] * along + v[1] * across]
        };
        let start = corner(a, 0.0, radius_px);
        pb.move_to(start[0], start[1]);
        for &(along, across) in &arc[1..] {
            let c = corner(a, -along, across);
            pb.line_to(c[0], c[1]);
        }
        for &(along, across) in arc {
            let c = corner(b, along, -across);
            pb.line_to(c[0], c[1]);
        }
        pb.close();
    }
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
        // Row 12 spans 1.5..2.5 px from the axis, the edge at 2: half covered.
        let edge = img.pixel(20, 12);
        assert!(edge[1] > 0 && edge[1] < 255, "{edge:?}");
    }

    #[test]
    fn alpha_blends_over_the_background() {
        let mut img = Image::new(10, 10, [0, 0, 0]);
        img.line([0.0, 5.0], [10.0, 5.0], 3.0, [200, 100, 0], 0.5);
        // Alpha 0.5 is 128/255 in 8 bits: 200 * 128 / 255 = 100.4.
        assert_eq!(img.pixel(5, 5), [100, 50, 0, 255]);
    }

    #[test]
    fn a_zero_length_line_is_a_round_dot() {
        let mut img = Image::new(20, 20, [255, 255, 255]);
        img.line([10.0, 10.0], [10.0, 10.0], 6.0, [0, 0, 255], 1.0);
        assert_eq!(img.pixel(9, 9), [0, 0, 255, 255]);
        assert_eq!(img.pixel(8, 10), [0, 0, 255, 255]);
        // Round, not square: the corner pixels of the 6 px square around it are partly covered
        // (one corner 2.8 px from the centre) or not at all (3.6 px).
        assert!(img.pixel(7, 7)[0] > 0 && img.pixel(7, 7)[0] < 255);
        assert_eq!(img.pixel(7, 6), [255, 255, 255, 255]);
    }

    #[test]
    fn a_polyline_has_no_seam_at_its_joints() {
        // Two lines meeting at (10.5, 10.25), as one polyline: the joint is covered once, fully,
        // like the rest of the line.
        let (a, m, b) = ([10.5, 2.5], [10.5, 10.25], [10.5, 18.5]);
        let mut joined = Image::new(20, 20, [255, 255, 255]);
        if let Some(mut p) = joined.painter() {
            p.polyline(&[a, m, b], 1.0, [0, 0, 200], 1.0);
        }
        assert!((3..18).all(|y| joined.pixel(10, y) == [0, 0, 200, 255]));
    }

    #[test]
    fn painting_behind_front_to_back_is_painting_over_back_to_front() {
        // A wide red line, a blue one across it and a half-transparent green one over both.
        // From, to, width, colour, alpha.
        type Line = ([f32; 2], [f32; 2], f32, [u8; 3], f32);
        let lines: [Line; 3] = [
            ([2.0, 10.0], [38.0, 10.0], 6.0, [255, 0, 0], 1.0),
            ([20.0, 2.0], [21.0, 18.0], 4.0, [0, 0, 255], 1.0),
            ([2.0, 16.0], [38.0, 17.0], 3.0, [0, 160, 0], 0.5),
        ];
        let mut over = Image::new(40, 20, [250, 250, 245]);
        for &(a, b, w, c, alpha) in &lines {
            over.line(a, b, w, c, alpha);
        }
        let mut behind = Image::transparent(40, 20);
        let mut p = behind.painter().unwrap();
        p.behind();
        for &(a, b, w, c, alpha) in lines.iter().rev() {
            p.line(a, b, w, c, alpha);
        }
        assert_eq!(p.rgba()[(10 * 40 + 5) * 4 + 3], 255, "inside the red line: opaque");
        p.rect(0, 0, 40, 20, [250, 250, 245], 1.0);
        // The same picture, but for rounding in 8 bits where the half-transparent line blends.
        let off = over.rgba.iter().zip(&behind.rgba).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
        assert!(off <= 2, "{off}");
        assert!(behind.rgba.chunks(4).all(|px| px[3] == 255));
        assert_eq!(behind.pixel(20, 10), [0, 0, 255, 255], "blue over red at the crossing");
    }

    #[test]
    fn thin_lines_are_faint() {
        let mut img = Image::new(20, 10, [255, 255, 255]);
        img.line([0.0, 5.5], [20.0, 5.5], 0.5, [0, 0, 0], 1.0);
        let p = img.pixel(10, 5)[0];
        assert!((100..200).contains(&p), "{p}: about half ink");
    }

    #[test]
    fn offscreen_and_nan_lines_draw_nothing() {
        let mut img = Image::new(10, 10, [1, 2, 3]);
        let before = img.clone();
        img.line([-50.0, -50.0], [-20.0, -30.0], 3.0, [255, 0, 0], 1.0);
        img.line([f32::NAN, 1.0], [5.0, 5.0], 3.0, [255, 0, 0], 1.0);
        img.line([f32::INFINITY, 1.0], [5.0, 5.0], 3.0, [255, 0, 0], 1.0);
        assert_eq!(img, before);
    }

    #[test]
    fn polygons_and_circles_fill_their_inside() {
        let mut img = Image::new(20, 20, [255, 255, 255]);
        let mut p = img.painter().unwrap();
        p.polygon(&[[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]], [255, 0, 0], 1.0);
        p.circle([15.0, 15.0], 4.0, [0, 0, 255], 1.0, None);
        p.circle([5.0, 15.0], 3.0, [0, 0, 0], 1.0, Some(1.0));
        assert_eq!(img.pixel(2, 2), [255, 0, 0, 255]);
        assert_eq!(img.pixel(8, 8), [255, 255, 255, 255], "beyond the diagonal");
        assert_eq!(img.pixel(15, 15), [0, 0, 255, 255]);
        assert_eq!(img.pixel(19, 19), [255, 255, 255, 255], "outside the circle");
        assert_eq!(img.pixel(5, 15), [255, 255, 255, 255], "an outline is hollow");
        assert!(img.pixel(5, 12)[0] < 128, "{:?}: on the outline", img.pixel(5, 12));
    }

    #[test]
    fn rectangles_blend_and_clip() {
        let mut img = Image::new(10, 10, [0, 0, 0]);
        img.rect(-5, 2, 8, 3, [255, 255, 255], 1.0);
        assert_eq!(img.pixel(0, 2), [255, 255, 255, 255]);
        assert_eq!(img.pixel(2, 4), [255, 255, 255, 255]);
        assert_eq!(img.pixel(3, 4), [0, 0, 0, 255]);
        assert_eq!(img.pixel(2, 5), [0, 0, 0, 255]);
        img.rect(5, 5, 20, 20, [200, 0, 0], 0.5);
        assert_eq!(img.pixel(9, 9), [100, 0, 0, 255]);
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
        // "H" has two stems: across its middle, ink at both sides and none in between.
        let mut img = Image::new(60, 30, [255, 255, 255]);
        let w = img.text(10, 5, "H", 20.0, [0, 0, 0]);
        let top = (0..30).find(|&y| (0..60).any(|x| dark(&img, x, y))).unwrap();
        let row: Vec<u32> = (0..60).filter(|&x| dark(&img, x, top + 3)).collect();
        let (lo, hi) = (row[0], row[row.len() - 1]);
        assert!(lo >= 10 && hi < 10 + w && !row.contains(&((lo + hi) / 2)), "{row:?}");
        // Turned a quarter anticlockwise (three clockwise), it reads upwards: the ink of "T1"
        // lies above its start, in a column as wide as the line is high.
        let mut img = Image::new(30, 60, [255, 255, 255]);
        let w = text::width("T1", 20.0);
        img.painter().unwrap().text_turned(4.0, 56.0, "T1", 20.0, [0, 0, 0], 3);
        let ink: Vec<(u32, u32)> =
            (0..30).flat_map(|x| (0..60).map(move |y| (x, y))).filter(|&(x, y)| dark(&img, x, y)).collect();
        assert!(!ink.is_empty());
        assert!(ink.iter().all(|&(x, y)| (4..4 + 20).contains(&x) && (56 - w..56).contains(&y)), "{ink:?}");
        // Text running off the image is clipped, not wrapped.
        let mut img = Image::new(10, 10, [255, 255, 255]);
        img.text(-5, 2, "WWWW", 20.0, [0, 0, 0]);
        assert!((0..10).any(|x| dark(&img, x, 8)));
    }
}
