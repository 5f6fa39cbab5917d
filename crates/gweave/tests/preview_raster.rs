//! `gweave preview` of binder-jet raster output: the drops of a layer are drawn where the image
//! was black, and nowhere else.
//!
//! `examples/raster/layers/badge_0.bmp` (black on white) is rasterised for the default HP
//! C6602 head (12 nozzles at 96 dpi, pitch 0.2646 mm) with the image corner at (20, 20) mm:
//! pixel (i, j) is printed at X = 20 + (i + 1/2) p, Y = 20 + (j + 1/2) p. Every pixel centre
//! of the picture there must be lit exactly when the BMP pixel is black. The drops are drawn
//! 0.2 mm wide, less than a pitch, so that a white pixel next to a black one stays clear.

use std::path::Path;

use gweave::gen::bitmap::{load_image, ThresholdOptions};
use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster::{RasterConfig, RasterWriter};
use gweave::render::png_out::rasterise;
use gweave::render::view::BACKGROUND;
use gweave::render::{drawing, ViewOptions};
use gweave::PreviewSettings;

#[test]
fn raster_output_lights_the_pixels_where_the_bmp_is_black() {
    let bmp = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/raster/layers/badge_0.bmp");
    let image =
        load_image(&bmp, &ThresholdOptions { invert: true, ..ThresholdOptions::default() }, 0.1).unwrap();
    let head = PrintheadProfile::default();
    let cfg = RasterConfig::default();
    let mut writer = RasterWriter::new(Vec::new(), &head, &cfg, None).unwrap();
    writer.layer(std::slice::from_ref(&image)).unwrap();
    writer.layer(std::slice::from_ref(&image)).unwrap();
    let (gcode, _) = writer.finish().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("badge.gcode");
    std::fs::write(&path, gcode).unwrap();

    let view = ViewOptions {
        layers: Some(1..=1),
        width_px: 500,
        height_px: 500,
        line_width_mm: 0.2,
        ..Default::default()
    };
    let options = PreviewSettings { view, ..PreviewSettings::default() };
    let d = drawing(&path, None, &options, &mut gweave::Quiet).unwrap();
    let img = rasterise(&d);
    let proj = d.panels[0].projection;
    let p = head.pitch_mm();
    let (mut black, mut mismatched) = (0, Vec::new());
    for j in 0..image.height() {
        for i in 0..image.width() {
            let x = cfg.origin_x_mm + (i as f64 + 0.5) * p;
            let y = cfg.origin_y_mm + (j as f64 + 0.5) * p;
            let [px, py] = proj.project([x as f32, y as f32, 0.0]);
            let c = img.pixel(px as u32, py as u32);
            let lit = [c[0], c[1], c[2]] != BACKGROUND;
            black += usize::from(image.get(i, j));
            if lit != image.get(i, j) {
                mismatched.push((i, j));
            }
        }
    }
    assert!(black > 300, "the badge has {black} black pixels");
    assert!(
        mismatched.is_empty(),
        "{} pixels differ: {:?}",
        mismatched.len(),
        &mismatched[..mismatched.len().min(10)]
    );
    assert_eq!(d.strokes.len(), black, "one drop per black pixel of the layer");
    // Regression (issue 23): the legend named the inkjet head "T0", like an extruder.
    let labels: Vec<&str> = d.legend.iter().map(|e| e.label.as_str()).collect();
    assert_eq!(labels, ["head 0"]);
}
