//! Drawing G-code paths as images: a z-buffered RGB [`canvas::Canvas`] with line drawing and
//! PNG output, and an orthographic [`camera::Camera`] (isometric or top view) that maps 3D
//! millimetres to pixels.
//!
//! ```
//! use gweave::render::{camera::Camera, canvas::Canvas};
//! let points = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 10.0, 5.0]];
//! let camera = Camera::isometric().fitted(points, 200, 100, 4.0);
//! let mut canvas = Canvas::new(200, 100, [255, 255, 255]);
//! canvas.line(camera.project(points[0]), camera.project(points[1]), [200, 0, 0], 1);
//! let mut png = Vec::new();
//! canvas.write_png(&mut png).unwrap();
//! assert_eq!(&png[1..4], b"PNG");
//! ```

pub mod camera;
pub mod canvas;
