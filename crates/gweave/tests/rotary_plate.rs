//! A real PrusaSlicer slice of a flat plate (tests/data/rotary/README.md) wrapped onto the
//! mandrel it was modelled for, read back as the machine runs it.

use std::f64::consts::PI;
use std::path::Path;

use gweave::rotary::cylinder::{FeedConvention, RotaryConfig};
use gweave::rotary::wrap::WrapConfig;
use gweave::{wrap_file, Run, Target};

fn plate() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/rotary/plate.gcode")
}

/// Bead width of every PrusaSlicer extrusion in the fixture, mm.
const BEAD_MM: f64 = 0.45;

#[test]
fn the_wrapped_plate_closes_on_itself_at_every_layer() {
    let dir = tempfile::tempdir().unwrap();
    for convention in [FeedConvention::Nist, FeedConvention::Combined, FeedConvention::InverseTime] {
        let mut machine = RotaryConfig::new(30.0);
        machine.feed_convention = convention;
        let mut config = WrapConfig::new(machine);
        config.unwrap.seam_rotation_per_layer_deg = 12.0;
        let out = dir.path().join("sleeve.gcode");
        let (report, _) = wrap_file(&config, Run::file(&plate()).to(&Target::File(out)), None).unwrap();
        assert_eq!(report.layers.len(), 10);
        let bead_deg = 360.0 * BEAD_MM / (PI * 30.0);
        let first = report.layers[0].layer.theta_range_deg[0];
        for (k, l) in report.layers.iter().enumerate() {
            // The outer bead edges meet at the weld line: span + one bead = one turn.
            assert!((l.span_deg + bead_deg - 360.0).abs() < 0.005, "layer {k}: span {}", l.span_deg);
            // Each layer is turned 12 degrees further, and its seam is reported there.
            assert!((l.layer.theta_range_deg[0] - first - 12.0 * k as f64).abs() < 0.002, "layer {k}");
            assert!((l.seam_deg - (12.0 * k as f64) % 360.0).abs() < 1e-9);
            // The nozzle rides at R0 + z, z = 0.2 (k + 1).
            assert!((l.layer.radius_mm - (15.0 + 0.2 * (k + 1) as f64)).abs() < 1e-9);
        }
        // The same filament whatever the convention; the time as the firmware reads F agrees
        // across conventions to the rounding of the F words (travel takes the short way round:
        // 1796 s the long way).
        assert!((report.filament_mm - 1888.8007).abs() < 1e-3, "{}", report.filament_mm);
        assert!((report.time_s - 1793.5).abs() < 2.0, "{convention:?}: {}", report.time_s);
    }
}
