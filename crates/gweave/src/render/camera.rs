//! An orthographic camera: 3D millimetres to pixel coordinates plus a depth.
//!
//! The eye looks at the scene from the direction `d = (cos el cos az, cos el sin az, sin el)`
//! (azimuth `az` about +Z from +X, elevation `el` above the XY plane). The screen axes are
//! `right = (-sin az, cos az, 0)` and `up = d x right`, so at `el = 90` (top view, `az = -90`)
//! X points right and Y up. A point `p` lands at `(p . right, p . up)` in millimetres on the
//! screen, and its depth is `-(p . d)`: smaller is nearer the eye. The isometric view is
//! `az = 45, el = atan(1/sqrt 2) = 35.264 deg`, where the three axes look equally long.
//!
//! [`Camera::fitted`] scales and centres the screen millimetres so that a set of points fills
//! the image inside a margin; pixel y grows downwards, as in the image.

/// An orthographic view with a pixel mapping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    right: [f64; 3],
    up: [f64; 3],
    toward_eye: [f64; 3],
    /// Pixels per millimetre.
    scale_px_mm: f64,
    /// Screen millimetres at the image centre.
    centre_mm: [f64; 2],
    /// Pixel position of the image centre.
    centre_px: [f64; 2],
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Camera {
    /// A view from azimuth `azimuth_deg` and elevation `elevation_deg` (see the module docs),
    /// one pixel per millimetre, the origin at pixel (0, 0) until [`Self::fitted`].
    pub fn new(azimuth_deg: f64, elevation_deg: f64) -> Self {
        let (sin_az, cos_az) = azimuth_deg.to_radians().sin_cos();
        let (sin_el, cos_el) = elevation_deg.to_radians().sin_cos();
        let d = [cos_el * cos_az, cos_el * sin_az, sin_el];
        let right = [-sin_az, cos_az, 0.0];
        let up = [
            d[1] * right[2] - d[2] * right[1],
            d[2] * right[0] - d[0] * right[2],
            d[0] * right[1] - d[1] * right[0],
        ];
        Self { right, up, toward_eye: d, scale_px_mm: 1.0, centre_mm: [0.0; 2], centre_px: [0.0; 2] }
    }

    /// The classic isometric view from (+1, +1, +1).
    pub fn isometric() -> Self {
        Self::new(45.0, (1.0 / 2f64.sqrt()).atan().to_degrees())
    }

    /// Looking straight down -Z with X to the right and Y up.
    pub fn top() -> Self {
        Self::new(-90.0, 90.0)
    }

    /// Screen millimetres of a point: (right, up).
    fn screen_mm(&self, p: [f64; 3]) -> [f64; 2] {
        [dot(p, self.right), dot(p, self.up)]
    }

    /// This view scaled and centred so that `points` fill a `width_px` x `height_px` image
    /// with `margin_px` to spare on every side. No (finite) points: unchanged.
    pub fn fitted(
        mut self,
        points: impl IntoIterator<Item = [f64; 3]>,
        width_px: u32,
        height_px: u32,
        margin_px: f64,
    ) -> Self {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in points {
            let s = self.screen_mm(p);
            if s.iter().all(|v| v.is_finite()) {
                for i in 0..2 {
                    lo[i] = lo[i].min(s[i]);
                    hi[i] = hi[i].max(s[i]);
                }
            }
        }
        if lo[0] > hi[0] {
            return self;
        }
        let room = [f64::from(width_px) - 2.0 * margin_px, f64::from(height_px) - 2.0 * margin_px];
        let span = [(hi[0] - lo[0]).max(1e-9), (hi[1] - lo[1]).max(1e-9)];
        self.scale_px_mm = (room[0] / span[0]).min(room[1] / span[1]).max(1e-9);
        self.centre_mm = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        self.centre_px = [f64::from(width_px) / 2.0, f64::from(height_px) / 2.0];
        self
    }

    /// Pixels per millimetre.
    pub fn scale_px_mm(&self) -> f64 {
        self.scale_px_mm
    }

    /// `[x_px, y_px, depth_mm]` of a point (pixel y downwards; smaller depth is nearer).
    pub fn project(&self, p: [f64; 3]) -> [f64; 3] {
        let [u, v] = self.screen_mm(p);
        [
            self.centre_px[0] + (u - self.centre_mm[0]) * self.scale_px_mm,
            self.centre_px[1] - (v - self.centre_mm[1]) * self.scale_px_mm,
            -dot(p, self.toward_eye),
        ]
    }

    /// Cosine between a unit `normal` and the direction to the eye: 1 facing the camera,
    /// 0 edge-on, negative facing away (for simple shading).
    pub fn facing(&self, normal: [f64; 3]) -> f64 {
        dot(normal, self.toward_eye)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-9)
    }

    #[test]
    fn top_view_keeps_x_right_and_y_up() {
        let cam = Camera::top();
        // Pixel y falls as Y grows; depth is -Z.
        assert!(close(cam.project([3.0, 2.0, 5.0]), [3.0, -2.0, -5.0]));
    }

    #[test]
    fn isometric_axes_look_equally_long() {
        let cam = Camera::isometric();
        let len = |p: [f64; 3]| {
            let [x, y, _] = cam.project(p);
            x.hypot(y)
        };
        let expected = (2.0f64 / 3.0).sqrt();
        for axis in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            assert!((len(axis) - expected).abs() < 1e-12, "{axis:?}");
        }
        // The corner nearest the eye is (1, 1, 1).
        assert!(cam.project([1.0, 1.0, 1.0])[2] < cam.project([0.0, 0.0, 0.0])[2]);
        assert!((cam.facing([1.0 / 3f64.sqrt(); 3]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn fitting_fills_the_image_inside_the_margin() {
        let pts = [[0.0, 0.0, 0.0], [100.0, 50.0, 0.0]];
        let cam = Camera::top().fitted(pts, 220, 220, 10.0);
        // 100 mm across 200 px: 2 px/mm, centred; Y 0..50 spans pixel rows 160..60.
        assert!((cam.scale_px_mm() - 2.0).abs() < 1e-12);
        assert!(close(cam.project(pts[0]), [10.0, 160.0, 0.0]));
        assert!(close(cam.project(pts[1]), [210.0, 60.0, 0.0]));
        let unchanged = Camera::top().fitted([], 10, 10, 1.0);
        assert_eq!(unchanged, Camera::top());
    }
}
