//! `plotters` drawing on gweave's one rasteriser: a [`DrawingBackend`] over a
//! [`gweave::picture::Image`], so that a PNG chart has the anti-aliasing (`tiny-skia`), the
//! typeface (the embedded Open Sans, laid out and drawn as glyph outlines by
//! [`gweave::picture::text`]) and the PNG writer of every other picture gweave draws.
//!
//! plotters gives whole pixel coordinates, a pixel's number being its top left corner: lines,
//! paths and polygons go through the pixels' centres (+0.5), a filled rectangle covers its
//! corner pixels, both included, as plotters' own bitmap backend draws them.

use std::convert::Infallible;

use gweave::picture::{text, Image, Painter};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    FontTransform,
};

/// A chart's pixels, drawn by plotters.
pub(crate) struct ChartCanvas<'a> {
    image: &'a mut Image,
}

impl<'a> ChartCanvas<'a> {
    /// Draws on `image` (which sets the chart's size).
    pub(crate) fn new(image: &'a mut Image) -> Self {
        ChartCanvas { image }
    }

    fn paint(&mut self, f: impl FnOnce(&mut Painter<'_>)) -> Result<(), DrawingErrorKind<Infallible>> {
        if let Some(mut p) = self.image.painter() {
            f(&mut p);
        }
        Ok(())
    }
}

fn colour(c: BackendColor) -> ([u8; 3], f32) {
    ([c.rgb.0, c.rgb.1, c.rgb.2], c.alpha as f32)
}

/// The centre of pixel `p`.
fn centre(p: BackendCoord) -> [f32; 2] {
    [p.0 as f32 + 0.5, p.1 as f32 + 0.5]
}

impl DrawingBackend for ChartCanvas<'_> {
    type ErrorType = Infallible;

    fn get_size(&self) -> (u32, u32) {
        (self.image.width, self.image.height)
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Infallible>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Infallible>> {
        Ok(())
    }

    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> Result<(), DrawingErrorKind<Infallible>> {
        let (rgb, alpha) = colour(c);
        self.paint(|painter| painter.rect(p.0, p.1, 1, 1, rgb, alpha))
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        self.draw_path([from, to], style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        let (x0, x1) = (upper_left.0.min(bottom_right.0), upper_left.0.max(bottom_right.0));
        let (y0, y1) = (upper_left.1.min(bottom_right.1), upper_left.1.max(bottom_right.1));
        if fill {
            let (rgb, alpha) = colour(style.color());
            let (w, h) = ((x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32);
            self.paint(|painter| painter.rect(x0, y0, w, h, rgb, alpha))
        } else {
            self.draw_path([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)], style)
        }
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        let points: Vec<[f32; 2]> = path.into_iter().map(centre).collect();
        let (rgb, alpha) = colour(style.color());
        let width = style.stroke_width() as f32;
        self.paint(|painter| painter.polyline(&points, width, rgb, alpha))
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        c: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        let (rgb, alpha) = colour(style.color());
        let outline = (!fill).then_some(style.stroke_width() as f32);
        self.paint(|painter| painter.circle(centre(c), radius as f32, rgb, alpha, outline))
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vertices: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        let points: Vec<[f32; 2]> = vertices.into_iter().map(centre).collect();
        let (rgb, alpha) = colour(style.color());
        self.paint(|painter| painter.polygon(&points, rgb, alpha))
    }

    /// Text in the embedded font: its box is the line's advance by its height (ascender to
    /// descender), placed by the style's anchor and turned by its transform about the anchor.
    fn draw_text<T: BackendTextStyle>(
        &mut self,
        s: &str,
        style: &T,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        let size = style.size() as f32;
        let (w, h) = (text::width(s, size) as i32, text::line_height(size) as i32);
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0,
            HPos::Center => -w / 2,
            HPos::Right => -w,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0,
            VPos::Center => -h / 2,
            VPos::Bottom => -h,
        };
        let transform = style.transform();
        let turns = match transform {
            FontTransform::None => 0,
            FontTransform::Rotate90 => 1,
            FontTransform::Rotate180 => 2,
            FontTransform::Rotate270 => 3,
        };
        // The box's top left, turned with the text about the anchor.
        let (ox, oy) = transform.transform(dx, dy);
        let (x, y) = ((pos.0 + ox) as f32, (pos.1 + oy) as f32);
        let (rgb, _) = colour(style.color());
        self.paint(|painter| {
            painter.text_turned(x, y, s, size, rgb, turns);
        })
    }

    fn estimate_text_size<T: BackendTextStyle>(
        &self,
        s: &str,
        style: &T,
    ) -> Result<(u32, u32), DrawingErrorKind<Infallible>> {
        let size = style.size() as f32;
        Ok((text::width(s, size), text::line_height(size)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::prelude::*;

    #[test]
    fn shapes_land_on_their_pixels() {
        let mut img = Image::new(40, 30, [255, 255, 255]);
        {
            let root = ChartCanvas::new(&mut img).into_drawing_area();
            root.draw(&Rectangle::new([(2, 2), (5, 4)], RED.filled())).unwrap();
            root.draw(&PathElement::new(vec![(10, 10), (30, 10)], BLUE)).unwrap();
            root.present().unwrap();
        }
        // The filled rectangle covers its corner pixels, both included, and nothing past them.
        assert_eq!(img.pixel(2, 2), [255, 0, 0, 255]);
        assert_eq!(img.pixel(5, 4), [255, 0, 0, 255]);
        assert_eq!(img.pixel(6, 4), [255, 255, 255, 255]);
        // A one-pixel line through pixel centres fills its row of pixels.
        assert_eq!(img.pixel(20, 10), [0, 0, 255, 255]);
        assert_eq!(img.pixel(20, 11), [255, 255, 255, 255]);
    }

    #[test]
    fn text_is_anchored_and_measured_in_the_embedded_font() {
        let mut img = Image::new(120, 40, [255, 255, 255]);
        let canvas = ChartCanvas::new(&mut img);
        let style = TextStyle::from(("sans-serif", 20).into_font());
        assert_eq!(canvas.estimate_text_size("bed", &style).unwrap(), (text::width("bed", 20.0), 20));
        let root = canvas.into_drawing_area();
        // Anchored by its right end at x = 100: all ink left of it.
        let right = style.pos(plotters_backend::text_anchor::Pos::new(HPos::Right, VPos::Top));
        root.draw_text("bed", &right, (100, 5)).unwrap();
        root.present().unwrap();
        drop(root);
        let ink: Vec<u32> = (0..120).filter(|&x| (0..40).any(|y| img.pixel(x, y)[0] < 100)).collect();
        assert!(!ink.is_empty() && *ink.last().unwrap() < 100, "{ink:?}");
        assert!(ink[0] >= 100 - text::width("bed", 20.0), "{ink:?}");
    }
}
