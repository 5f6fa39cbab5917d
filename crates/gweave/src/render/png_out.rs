//! A [`Drawing`] as pixels: strokes rasterised front to back, skipping what they hide, then the
//! legend and panel titles ([`crate::picture`] paints and encodes).

use super::cull::{overdraw_stride, Opaque};
use super::legend;
use super::view::{Drawing, Stroke};
use crate::pass::{Progress, Quiet};
use crate::picture::{text, Image, Painter};

const INK: [u8; 3] = [0x20, 0x20, 0x20];
const LEGEND_BOX: [u8; 3] = [0xff, 0xff, 0xff];
/// Size of panel title text, px (as the legend's).
const TEXT_PX: f32 = legend::TEXT_PX;

/// Rasterises a drawing (strokes, legend, titles). A blank drawing is the background only.
///
/// The strokes are painted last first, each behind what is painted
/// ([`Painter::behind`]), then the background behind them all: the picture painting them in
/// order gives (to 8-bit rounding where strokes are not opaque), where a stroke that the ones
/// after it hide is found hidden by the image itself and skipped (`render::cull`). Strokes
/// that follow on (the end of one is the start of the next, in one colour, width and opacity)
/// are painted as one polyline with round joins, so their joints have no seams.
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

/// [`rasterise`], reporting the work as the stage "drawing", one unit per stroke, so that a
/// bar covers the whole of a long drawing.
pub fn rasterise_with_progress(d: &Drawing, progress: &mut dyn Progress) -> Image {
    let stride = overdraw_stride(&d.strokes, d.width_px, d.height_px);
    let kept: Vec<Stroke>;
    let strokes = if stride == 1 {
        &d.strokes
    } else {
        kept = d.strokes.iter().skip(stride - 1).step_by(stride).copied().collect();
        &kept
    };
    let n = strokes.len();
    progress.stage("drawing", n as u64);
    let img = paint_strokes(d, strokes, true, progress);
    progress.advance(n as u64);
    let mut img = img;
    let line_h = text::line_height(TEXT_PX) + 4;
    for p in &d.panels {
        img.text(p.x_px as i32 + 12, d.height_px as i32 - line_h as i32 - 4, &p.title, TEXT_PX, INK);
        if p.x_px > 0 {
            img.rect(p.x_px as i32, 0, 1, d.height_px, INK, 0.3);
        }
    }
    if let Some([x, y, w, h]) = legend::legend_box(&d.legend) {
        img.rect(x as i32, y as i32, w, h, LEGEND_BOX, 0.85);
        let line_h = legend::line_px();
        for (i, e) in d.legend.iter().enumerate() {
            let y = 14 + (i as u32 * line_h) as i32;
            let c = [e.colour.r, e.colour.g, e.colour.b];
            // A thin frame, so a white or pale colour shows on the white box.
            img.rect(13, y + 1, line_h - 6, line_h - 6, INK, 0.5);
            img.rect(14, y + 2, line_h - 8, line_h - 8, c, 1.0);
            img.text(14 + line_h as i32, y, &e.label, TEXT_PX, INK);
        }
    }
    img
}

/// The strokes of `d` painted front to back over its background, skipping those found hidden
/// when `skip_hidden` (which changes no pixel).
fn paint_strokes(d: &Drawing, strokes: &[Stroke], skip_hidden: bool, progress: &mut dyn Progress) -> Image {
    let mut img = Image::transparent(d.width_px, d.height_px);
    if let Some(mut painter) = img.painter() {
        painter.behind();
        let mut opaque = Opaque::new(d.width_px, d.height_px);
        let mut chain = Chain::default();
        for (k, s) in strokes.iter().rev().enumerate() {
            if k.is_multiple_of(REPORT_EVERY) {
                progress.advance(k as u64);
            }
            // A stopped run (Python's Ctrl-C) paints no further: the picture is thrown away,
            // and its write, if any, refused (`interrupt`).
            if k.is_multiple_of(crate::interrupt::CHECK_EVERY) && crate::interrupt::stopped() {
                break;
            }
            // Polylines are cut where they are when every stroke is painted, hidden or not:
            // a polyline is skipped when all its strokes are hidden, and painted whole when one
            // is not. Nothing is painted while one is gathered, so each stroke is tested on the
            // picture the polyline is painted on.
            if !chain.precede(s) {
                chain.paint(&mut painter, &mut opaque);
                chain.start(s);
            }
            if !chain.visible {
                chain.visible = !(skip_hidden && opaque.hides(painter.rgba(), s));
            }
        }
        // Painting a polyline is one call into the rasteriser, not interruptible: a stopped
        // run skips the last one (a file of chained moves is one polyline, painted here).
        if !crate::interrupt::stopped() {
            chain.paint(&mut painter, &mut opaque);
        }
        painter.rect(0, 0, d.width_px, d.height_px, d.background, 1.0);
    }
    img
}

/// Strokes that follow on, gathered last first into one polyline.
#[derive(Default)]
struct Chain {
    /// The points, first first.
    points: Vec<[f32; 2]>,
    /// The strokes, last first.
    strokes: Vec<Stroke>,
    /// Whether a stroke of the chain may show: else painting it changes no pixel.
    visible: bool,
}

impl Chain {
    /// Puts `s` in front of the chain if it ends where the chain starts, in its style.
    fn precede(&mut self, s: &Stroke) -> bool {
        let Some(first) = self.strokes.last() else {
            return false;
        };
        let same = (first.colour, first.width_px, first.alpha) == (s.colour, s.width_px, s.alpha);
        if !(same && s.to == first.from) {
            return false;
        }
        self.strokes.push(*s);
        self.points.push(s.from);
        true
    }

    fn start(&mut self, s: &Stroke) {
        self.strokes.push(*s);
        self.points.extend([s.to, s.from]);
    }

    /// Paints the chain (points first to last) if it may show, and empties it.
    fn paint(&mut self, painter: &mut Painter<'_>, opaque: &mut Opaque) {
        if let Some(s) = self.strokes.first().filter(|_| self.visible) {
            self.points.reverse();
            painter.polyline(&self.points, s.width_px, s.colour, s.alpha);
            for s in &self.strokes {
                opaque.painted(s);
            }
        }
        self.points.clear();
        self.strokes.clear();
        self.visible = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::view::BACKGROUND;

    fn drawing(width_px: u32, height_px: u32, strokes: Vec<Stroke>) -> Drawing {
        Drawing {
            width_px,
            height_px,
            background: BACKGROUND,
            strokes,
            legend: vec![],
            panels: vec![],
            layers_drawn: None,
        }
    }

    fn st(from: [f32; 2], to: [f32; 2], colour: [u8; 3], width_px: f32) -> Stroke {
        Stroke { from, to, colour, width_px, alpha: 1.0 }
    }

    /// The largest difference of two images in a channel.
    fn max_diff(a: &Image, b: &Image) -> u8 {
        a.rgba.iter().zip(&b.rgba).map(|(a, b)| a.abs_diff(*b)).max().unwrap()
    }

    /// Every stroke painted in order, over the background.
    fn painted_in_order(d: &Drawing) -> Image {
        let mut img = Image::new(d.width_px, d.height_px, d.background);
        for s in &d.strokes {
            img.line(s.from, s.to, s.width_px, s.colour, s.alpha);
        }
        img
    }

    #[test]
    fn a_stroke_on_the_background() {
        let d = drawing(30, 20, vec![st([2.0, 10.0], [28.0, 10.0], [10, 200, 30], 4.0)]);
        let img = rasterise(&d);
        assert_eq!(img.pixel(15, 10), [10, 200, 30, 255]);
        assert_eq!(img.pixel(15, 2), [BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 255]);
        // The same as painting over the background, to 8-bit rounding on the anti-aliased edges.
        assert_eq!(max_diff(&img, &painted_in_order(&d)), 1);
    }

    /// Regression: a preview of 300 000 layers over 10 mm took 146 s, every pixel under
    /// thousands of strokes; the strokes drawn are now thinned past 256 pictures of ink.
    #[test]
    fn overdraw_is_thinned_to_a_budget() {
        let stroke = |y: f32| st([0.0, y], [99.0, y], [0, 0, 0], 2.0);
        // A 100 x 100 picture: 100 strokes of ~600 visited pixels are 6 pictures, drawn whole.
        let few: Vec<Stroke> = (0..100).map(|i| stroke(i as f32)).collect();
        assert_eq!(overdraw_stride(&few, 100, 100), 1);
        // 300 000 of them over the same rows (18 000 pictures): every 71st is drawn.
        let many: Vec<Stroke> = (0..300_000).map(|i| stroke((i % 100) as f32)).collect();
        assert_eq!(overdraw_stride(&many, 100, 100), 71);
    }

    #[test]
    fn hidden_strokes_are_found() {
        let strokes = [
            st([10.0, 20.0], [50.0, 20.0], [255, 0, 0], 3.0), // under the wide blue one: hidden
            st([10.0, 5.0], [50.0, 5.0], [0, 255, 0], 3.0),   // beside it: visible
            st([10.0, 26.0], [50.0, 26.0], [0, 255, 0], 3.0), // partly under its edge: visible
            st([5.0, 21.0], [55.0, 21.0], [0, 0, 255], 12.0),
        ];
        let mut img = Image::transparent(60, 40);
        let mut p = img.painter().unwrap();
        p.behind();
        let mut opaque = Opaque::new(60, 40);
        let mut hidden = [false; 4];
        for (i, s) in strokes.iter().enumerate().rev() {
            hidden[i] = opaque.hides(p.rgba(), s);
            if !hidden[i] {
                p.line(s.from, s.to, s.width_px, s.colour, s.alpha);
                opaque.painted(s);
            }
        }
        assert_eq!(hidden, [true, false, false, false]);
    }

    /// `n` strokes at random positions, angles and lengths (up to 12 px) on a `w` x `h`
    /// picture, `width(i, r)` px wide (`r` random in 0..1), every 17th half transparent. The
    /// tests' pictures are not whole tiles wide or high, so that the last tiles are cut.
    fn random_strokes(n: usize, w: u32, h: u32, width: impl Fn(usize, f32) -> f32) -> Vec<Stroke> {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            // xorshift64 (Marsaglia, 2003): deterministic and dependency-free.
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|i| {
                let from = [next() * w as f32, next() * h as f32];
                // Every 11th a dot (a move along the line of sight, or shorter than a pixel).
                let (len, angle) =
                    (if i.is_multiple_of(11) { 0.0 } else { next() * 12.0 }, next() * std::f32::consts::TAU);
                let to = [from[0] + len * angle.cos(), from[1] + len * angle.sin()];
                let colour = [(i % 251) as u8, (i * 7 % 253) as u8, 90];
                Stroke {
                    alpha: if i.is_multiple_of(17) { 0.35 } else { 1.0 },
                    ..st(from, to, colour, width(i, next()))
                }
            })
            .collect()
    }

    /// Every stroke of `d` painted front to back, none skipped.
    fn painted_behind(d: &Drawing) -> Image {
        let mut all = Image::transparent(d.width_px, d.height_px);
        let mut p = all.painter().unwrap();
        p.behind();
        for s in d.strokes.iter().rev() {
            p.line(s.from, s.to, s.width_px, s.colour, s.alpha);
        }
        p.rect(0, 0, d.width_px, d.height_px, d.background, 1.0);
        all
    }

    /// How many strokes of `d` are found hidden, painted front to back.
    fn count_hidden(d: &Drawing) -> usize {
        let mut img = Image::transparent(d.width_px, d.height_px);
        let mut p = img.painter().unwrap();
        p.behind();
        let mut opaque = Opaque::new(d.width_px, d.height_px);
        let mut hidden = 0;
        for s in d.strokes.iter().rev() {
            if opaque.hides(p.rgba(), s) {
                hidden += 1;
            } else {
                p.line(s.from, s.to, s.width_px, s.colour, s.alpha);
                opaque.painted(s);
            }
        }
        hidden
    }

    /// Painting front to back and skipping hidden strokes gives the picture painting every
    /// stroke in order gives: many strokes at random positions, angles and widths (1 to 8 px,
    /// as previews draw them), a few half transparent, piled up, with many found hidden.
    #[test]
    fn skipping_hidden_strokes_never_changes_the_picture() {
        let (w, h) = (61, 45);
        let d = drawing(w, h, random_strokes(3000, w, h, |_, r| 1.0 + r * 7.0));
        let all = painted_behind(&d);
        assert!(rasterise(&d) == all, "skipping hidden strokes changed the picture");
        // Painting in order gives the same picture to a few steps of 8-bit rounding where
        // half-transparent edges pile up.
        let off = max_diff(&all, &painted_in_order(&d));
        assert!(off <= 8, "{off}");
        // Most of the 3000 strokes are under later ones.
        let hidden = count_hidden(&d);
        assert!(hidden > 2000, "{hidden} hidden");
    }

    /// The same for lines thinner than a pixel (hairlines, which reach further than their
    /// width), among wider ones that hide them.
    #[test]
    fn skipping_hidden_hairlines_never_changes_the_picture() {
        let (w, h) = (61, 45);
        let width = |i: usize, r: f32| if i.is_multiple_of(3) { 3.0 + r * 5.0 } else { 0.1 + r * 0.85 };
        let d = drawing(w, h, random_strokes(6000, w, h, width));
        assert!(rasterise(&d) == painted_behind(&d), "skipping hidden hairlines changed the picture");
        let hidden = count_hidden(&d);
        assert!(hidden > 3000, "{hidden} hidden");
    }

    /// Regression: a hidden stroke could not start a polyline, so a stroke following on from it
    /// joined the polyline in front instead when that one started at the same point, and the two
    /// were covered as one shape where painting everything covers them one after the other (19
    /// pixels of the benchmark's iso view, by up to 12 levels). Here `a` runs right from `p`,
    /// `b` runs down from `p` under the wide stroke in front, and `c` comes back along `a` into
    /// `p`: `c` follows on from `b`, and would from `a` too.
    #[test]
    fn hidden_strokes_do_not_change_where_polylines_are_cut() {
        let (p, orange) = ([10.3, 10.4], [230, 120, 20]);
        // In drawing order, back to front: c, b, a, then the wide stroke over b.
        let c = st([30.3, 11.6], p, orange, 3.0);
        let b = st(p, [10.3, 22.4], orange, 3.0);
        let a = st(p, [30.3, 10.4], orange, 3.0);
        let wide = st([10.3, 6.0], [10.3, 30.0], [20, 20, 200], 8.0);
        let d = drawing(40, 36, vec![c, b, a, wide]);
        let mut opaque = Opaque::new(40, 36);
        let mut img = Image::transparent(40, 36);
        let mut painter = img.painter().unwrap();
        painter.behind();
        painter.line(wide.from, wide.to, wide.width_px, wide.colour, wide.alpha);
        opaque.painted(&wide);
        assert!(opaque.hides(painter.rgba(), &b), "b is under the wide stroke");
        let all = paint_strokes(&d, &d.strokes, false, &mut Quiet);
        let skipped = paint_strokes(&d, &d.strokes, true, &mut Quiet);
        assert!(skipped == all, "max difference {}", max_diff(&skipped, &all));
    }

    /// The same on a real print: both tools of `cura_dual`, layers 40 to 80, from the side
    /// and from the top.
    #[test]
    fn skipping_hidden_strokes_leaves_the_pixels_unchanged() {
        let dual =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cura/cura_dual.gcode");
        for kind in [crate::render::ViewKind::Iso, crate::render::ViewKind::Top] {
            let view = crate::render::ViewOptions {
                kind,
                layers: Some(40..=80),
                width_px: 400,
                height_px: 300,
                ..Default::default()
            };
            let options = crate::render::PreviewSettings { view, ..Default::default() };
            let d = crate::render::drawing(&dual, None, &options, &mut Quiet).unwrap();
            let skipped = paint_strokes(&d, &d.strokes, true, &mut Quiet);
            let all = paint_strokes(&d, &d.strokes, false, &mut Quiet);
            let differ = skipped.rgba.chunks(4).zip(all.rgba.chunks(4)).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "{kind}");
        }
    }

    #[test]
    fn strokes_that_follow_on_are_one_polyline() {
        // Two halves of a vertical line meeting at y = 10.25: as one polyline, the joint is
        // covered once, fully, like the rest of the line.
        let d = drawing(
            20,
            20,
            vec![
                st([10.5, 2.5], [10.5, 10.25], [0, 0, 200], 1.0),
                st([10.5, 10.25], [10.5, 18.5], [0, 0, 200], 1.0),
            ],
        );
        let img = rasterise(&d);
        assert!((3..18).all(|y| img.pixel(10, y) == [0, 0, 200, 255]));
    }
}
