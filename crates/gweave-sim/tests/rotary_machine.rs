//! Rotary output through the virtual printer (issue "Rotary", done-when): a generated tube runs
//! on the rotary machine profile without errors, every extruding move ends on its layer's
//! cylinder, the helix turns the other way every layer, and the filament the machine fed equals
//! the tube wall's volume.

use std::path::Path;

use gweave::rotary::cylinder::RotaryConfig;
use gweave::rotary::helix::TubeParams;
use gweave_sim::MachineProfile;
use gweave_sim::{Machine, Outcome};

fn rotary_machine() -> Machine {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/rotary.toml");
    let profile = MachineProfile::from_toml_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    Machine::new(profile).unwrap()
}

#[test]
fn a_tube_runs_on_the_rotary_machine_on_its_cylinders() {
    // The profile's mandrel: radius 12.5 mm.
    let mut tube = TubeParams::new(RotaryConfig::new(25.0));
    tube.length_mm = 8.0;
    tube.layers = 3;
    let mut gcode = Vec::new();
    tube.write_gcode(&mut gcode).unwrap();

    let mut machine = rotary_machine();
    let mut problems = Vec::new();
    let h = tube.print.layer_height_mm;
    let r0 = tube.machine.mandrel_radius_mm();
    // Per layer: extruding moves seen, and the sign of axial travel per degree of rotation.
    let mut per_layer: Vec<(usize, f64)> = vec![(0, 0.0); tube.layers as usize];
    for (n, line) in gcode.split(|&b| b == b'\n').enumerate() {
        let before = machine.position();
        let outcome = machine.execute(line, &mut |_, reply: &str| {
            if reply.starts_with("Error") || reply.contains("Unknown") || reply.contains("cold extrusion") {
                problems.push(format!("line {}: {reply}", n + 1));
            }
        });
        assert_eq!(outcome, Outcome::Ok, "line {}", n + 1);
        let after = machine.position();
        let [x0, _, _, e0, a0] = before;
        let [x1, _, z1, e1, a1] = after;
        if e1 > e0 + 1e-9 && (a1 - a0).abs() > 1e-9 {
            // The radial word is the nozzle height above the mandrel; the bead's centre line
            // is half a layer below it.
            let k = ((z1 / h).round() as i64 - 1) as usize;
            let r = r0 + z1 - h / 2.0;
            assert!(
                (r - tube.layer_radius_mm(k as u32)).abs() < 0.01,
                "line {}: r {r} off layer {k}'s cylinder",
                n + 1
            );
            per_layer[k].0 += 1;
            per_layer[k].1 += (x1 - x0) * (a1 - a0);
        }
    }
    machine.finish(&mut |_, _| {});
    assert!(problems.is_empty(), "{problems:?}");
    assert!(per_layer.iter().all(|(moves, _)| *moves > 100), "{per_layer:?}");
    // Interwoven: the handedness (sign of axial travel per rotation) alternates layer by layer.
    for pair in per_layer.windows(2) {
        assert!(pair[0].1 * pair[1].1 < 0.0, "{per_layer:?}");
    }
    let report = machine.report();
    let d = tube.print.filament_diameter_mm;
    let fed_mm3 = report.filament_mm.iter().sum::<f64>() * std::f64::consts::PI * d * d / 4.0;
    let wall = tube.wall_volume_mm3();
    assert!((fed_mm3 - wall).abs() < wall * 0.01, "fed {fed_mm3} mm3, wall {wall} mm3");
    assert!(report.steps.axes[4] > 0, "the rotary motor stepped");
}

/// A real PrusaSlicer flat plate (Y length = the circumference of a 30 mm mandrel) wrapped and run
/// on the rotary machine: at every layer the extrusion spans the full turn less one bead width,
/// so the part closes on itself.
#[test]
fn a_wrapped_plate_closes_at_every_layer_on_the_machine() {
    use gweave::rotary::wrap::{wrap_bytes, WrapConfig};
    let plate = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/rotary/plate.gcode");
    let flat = std::fs::read(plate).unwrap();
    let wrapped = wrap_bytes(WrapConfig::new(RotaryConfig::new(30.0)), &flat).unwrap();

    let mut machine = rotary_machine();
    let mut problems = Vec::new();
    // Per layer (by radial height, 0.01 mm buckets): min and max angle of extruding moves.
    let mut spans: std::collections::BTreeMap<i64, (f64, f64)> = Default::default();
    for (n, line) in wrapped.split(|&b| b == b'\n').enumerate() {
        let before = machine.position();
        machine.execute(line, &mut |_, reply: &str| {
            if reply.starts_with("Error") || reply.contains("Unknown") {
                problems.push(format!("line {}: {reply}", n + 1));
            }
        });
        let after = machine.position();
        if after[3] > before[3] + 1e-9 && (after[4] - before[4]).abs() > 1e-9 {
            let span = spans.entry((after[2] * 100.0).round() as i64).or_insert((f64::MAX, f64::MIN));
            for a in [before[4], after[4]] {
                span.0 = span.0.min(a);
                span.1 = span.1.max(a);
            }
        }
    }
    assert!(problems.is_empty(), "{problems:?}");
    assert!(spans.len() >= 5, "{spans:?}");
    // PrusaSlicer's outer perimeter centre line sits half a bead (0.45 mm) inside the plate's
    // edges at y = 0 and y = C, so the turn lacks exactly one bead width.
    let bead_deg = 0.45 * 360.0 / (std::f64::consts::PI * 30.0);
    for (z, (lo, hi)) in &spans {
        let span = hi - lo;
        assert!((span + bead_deg - 360.0).abs() < 0.01, "layer at z {z}: span {span}");
    }
}
