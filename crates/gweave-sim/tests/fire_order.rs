//! `--fire-order before` (the binder-jet seed's fire, `M400`, move) through the virtual printer:
//! the drops land on the same pixels, and every fire but the first of each pass comes while the
//! carriage is still moving onto its column, which the printer reports; the default order has
//! no such fire.

use gweave::gen::bitmap::Bitmap;
use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster::{FireOrder, RasterConfig, RasterWriter};
use gweave_sim::{CanvasGeometry, InkjetWarning};
use gweave_sim::{Inkjet, MachineProfile};
use gweave_sim::{Machine, Outcome};

#[test]
fn seed_fire_order_fires_while_moving_and_lands_on_the_same_pixels() {
    let profile = PrintheadProfile::default();
    // A 30 x 30 px ring: three bands of 12 rows, several columns each.
    let mut image = Bitmap::new(30, 30);
    for y in 0..30i32 {
        for x in 0..30i32 {
            let d2 = (x - 15).pow(2) + (y - 15).pow(2);
            image.set(x as usize, y as usize, (64..=196).contains(&d2));
        }
    }
    let geometry = CanvasGeometry { origin_x_mm: 20.0, origin_y_mm: 20.0, width_px: 30, height_px: 30 };
    for order in [FireOrder::After, FireOrder::Before] {
        let cfg = RasterConfig { fire_order: order, ..RasterConfig::default() };
        let mut w = RasterWriter::new(Vec::new(), &profile, &cfg, None).unwrap();
        w.layer(std::slice::from_ref(&image)).unwrap();
        let (gcode, report) = w.finish().unwrap();
        let inkjet = Inkjet {
            printhead: profile.clone(),
            origin_x_mm: geometry.origin_x_mm,
            origin_y_mm: geometry.origin_y_mm,
            width_px: Some(geometry.width_px),
            height_px: Some(geometry.height_px),
        };
        let mut machine =
            Machine::new(MachineProfile { inkjet: Some(inkjet), ..MachineProfile::default() }).unwrap();
        let (sink, finished) = std::sync::mpsc::channel();
        machine.send_inkjet_layers_to(Box::new(sink));
        for line in gcode.split(|&b| b == b'\n') {
            assert_eq!(machine.execute(line, &mut |_, _| {}), Outcome::Ok);
        }
        machine.finish(&mut |_, _| {});
        let layers: Vec<_> = finished.try_iter().collect();
        assert_eq!(layers.len(), 1);
        assert_eq!(layers[0].heads[0], image, "{order:?}: the drops land on the image");
        let sim = machine.report();
        let moving =
            sim.inkjet_warnings().filter(|w| matches!(w, InkjetWarning::FireWithoutM400 { .. })).count();
        let expected = match order {
            FireOrder::After => 0,
            FireOrder::Before => (report.columns_fired - report.bands_printed) as usize,
        };
        assert_eq!(moving, expected, "{order:?}");
        assert!(report.columns_fired > 3 * report.bands_printed);
    }
}
