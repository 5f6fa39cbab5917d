//! A z-buffered RGB image with line drawing and PNG output.
//!
//! Lines are rasterised with a DDA: `n = ceil(max(|dx|, |dy|))` equal steps from one end to the
//! other (every pixel column or row is visited once), each step stamping a square of the
//! line's width. Depth is interpolated linearly along the line and a pixel is only written when
//! it is nearer than what is there (the z-buffer), so the front of a tube hides its back
//! whatever order the lines come in.

use std::io::{self, Write};

use super::png_out::{write_png, Pixels};

/// An RGB image with a depth per pixel.
#[derive(Clone, Debug)]
pub struct Canvas {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    depth: Vec<f64>,
}

impl Canvas {
    /// A `width` x `height` image filled with `background`, nothing drawn (depth infinite).
    pub fn new(width: u32, height: u32, background: [u8; 3]) -> Self {
        let n = width as usize * height as usize;
        let mut rgb = Vec::with_capacity(n * 3);
        for _ in 0..n {
            rgb.extend_from_slice(&background);
        }
        Self { width, height, rgb, depth: vec![f64::INFINITY; n] }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The colour at pixel (x, y), `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        (x < self.width && y < self.height).then(|| {
            let i = 3 * (y as usize * self.width as usize + x as usize);
            [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
        })
    }

    /// Writes `rgb` at pixel (x, y) if it is inside the image and `depth` is nearer (smaller)
    /// than what is there.
    pub fn plot(&mut self, x: i64, y: i64, depth: f64, rgb: [u8; 3]) {
        if x < 0 || y < 0 || x >= i64::from(self.width) || y >= i64::from(self.height) {
            return;
        }
        let i = y as usize * self.width as usize + x as usize;
        if depth < self.depth[i] {
            self.depth[i] = depth;
            self.rgb[3 * i..3 * i + 3].copy_from_slice(&rgb);
        }
    }

    /// Draws a line between two `[x_px, y_px, depth]` points (as an orthographic camera
    /// gives them), `width_px` wide (at least 1). Non-finite points draw nothing.
    pub fn line(&mut self, a: [f64; 3], b: [f64; 3], rgb: [u8; 3], width_px: u32) {
        if a.iter().chain(&b).any(|v| !v.is_finite()) {
            return;
        }
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        // Lines longer than the image diagonal many times over are clipped by the bounds check
        // anyway; cap the step count so a wild point cannot stall the renderer.
        let limit = 4.0 * f64::from(self.width + self.height);
        let steps = dx.abs().max(dy.abs()).ceil().clamp(1.0, limit) as u32;
        let w = i64::from(width_px.max(1));
        let lo = -(w - 1) / 2;
        for i in 0..=steps {
            let t = f64::from(i) / f64::from(steps);
            let x = (a[0] + dx * t).round() as i64;
            let y = (a[1] + dy * t).round() as i64;
            let depth = a[2] + (b[2] - a[2]) * t;
            for oy in lo..lo + w {
                for ox in lo..lo + w {
                    self.plot(x + ox, y + oy, depth, rgb);
                }
            }
        }
    }

    /// Writes the image as an 8-bit RGB PNG ([`super::png_out::write_png`]).
    pub fn write_png(&self, out: impl Write) -> io::Result<()> {
        write_png(out, self.width, self.height, Pixels::Rgb(&self.rgb)).map_err(io::Error::other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WHITE: [u8; 3] = [255, 255, 255];
    const RED: [u8; 3] = [255, 0, 0];
    const BLUE: [u8; 3] = [0, 0, 255];

    #[test]
    fn a_diagonal_visits_every_column_once() {
        let mut c = Canvas::new(10, 10, WHITE);
        c.line([1.0, 1.0, 0.0], [8.0, 4.5, 0.0], RED, 1);
        let lit: Vec<(u32, u32)> = (0..10)
            .flat_map(|y| (0..10).map(move |x| (x, y)))
            .filter(|&(x, y)| c.pixel(x, y) == Some(RED))
            .collect();
        assert_eq!(lit.len(), 8);
        let columns: std::collections::BTreeSet<u32> = lit.iter().map(|p| p.0).collect();
        assert_eq!(columns.into_iter().collect::<Vec<_>>(), (1..=8).collect::<Vec<_>>());
        assert!(lit.contains(&(1, 1)) && lit.contains(&(8, 5)));
        assert_eq!(c.pixel(0, 0), Some(WHITE));
        assert_eq!(c.pixel(10, 0), None);
    }

    #[test]
    fn nearer_lines_win_whatever_the_order() {
        for order in [[0.0, 5.0], [5.0, 0.0]] {
            let mut c = Canvas::new(5, 5, WHITE);
            c.line([0.0, 2.0, order[0]], [4.0, 2.0, order[0]], if order[0] == 0.0 { RED } else { BLUE }, 1);
            c.line([2.0, 0.0, order[1]], [2.0, 4.0, order[1]], if order[1] == 0.0 { RED } else { BLUE }, 1);
            // The red line is at depth 0, nearer than the blue one at 5: it owns the crossing.
            assert_eq!(c.pixel(2, 2), Some(RED));
        }
    }

    #[test]
    fn wide_lines_and_clipping() {
        let mut c = Canvas::new(6, 6, WHITE);
        c.line([-10.0, 2.0, 0.0], [2.0, 2.0, 0.0], RED, 3);
        // Three rows (1..=3), columns up to 3; nothing wraps around.
        assert_eq!(c.pixel(3, 1), Some(RED));
        assert_eq!(c.pixel(3, 3), Some(RED));
        assert_eq!(c.pixel(4, 2), Some(WHITE));
        assert_eq!(c.pixel(0, 4), Some(WHITE));
        c.line([f64::NAN, 0.0, 0.0], [1.0, 1.0, 0.0], BLUE, 1);
        assert_eq!(c.pixel(1, 1), Some(RED));
    }

    #[test]
    fn png_round_trip() {
        let mut c = Canvas::new(3, 2, WHITE);
        c.plot(2, 1, 0.0, BLUE);
        let mut bytes = Vec::new();
        c.write_png(&mut bytes).unwrap();
        let img = image::load_from_memory(&bytes).unwrap();
        assert_eq!((img.width(), img.height(), img.color()), (3, 2, image::ColorType::Rgb8));
        let buf = img.into_rgb8().into_raw();
        assert_eq!(&buf[15..18], &BLUE);
        assert_eq!(&buf[0..3], &WHITE);
    }
}
