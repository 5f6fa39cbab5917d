//! The rotary seed's helical unwrapping through the virtual printer: a real PrusaSlicer plate
//! wrapped with `helical`, run on the rotary machine profile; every extruding move lies on its
//! layer's helix (radius rising one layer height per turn) within 0.01 mm, and each layer ends
//! where the next begins.

use std::path::Path;

use gweave::rotary::cylinder::RotaryConfig;
use gweave::rotary::wrap::{wrap_bytes, WrapConfig};
use gweave_sim::Machine;
use gweave_sim::MachineProfile;

#[test]
fn helical_wrap_puts_every_bead_on_its_helix() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let profile = std::fs::read_to_string(root.join("examples/machines/rotary.toml")).unwrap();
    let mut machine = Machine::new(MachineProfile::from_toml_str(&profile).unwrap()).unwrap();
    let flat = std::fs::read(root.join("tests/data/rotary/plate.gcode")).unwrap();
    // The plate is the unwrapped shell of a 30 mm mandrel's sleeve: 10 layers of 0.2 mm; its
    // extrusions start at y0 = 0.225 (half a 0.45 mm bead in from the edge).
    let mut config = WrapConfig::new(RotaryConfig::new(30.0));
    config.unwrap.helical = true;
    let wrapped = wrap_bytes(config, &flat).unwrap();
    let c = std::f64::consts::PI * 30.0;
    let (h, y0) = (0.2, 0.225);
    let mut layer_z: Option<f64> = None;
    let mut layers_seen = 0;
    let mut beads = 0;
    let mut worst: f64 = 0.0;
    // Per layer: the radial height at the largest angle (the end of its turn).
    let mut ends: Vec<(f64, f64)> = Vec::new();
    let mut starts: Vec<(f64, f64)> = Vec::new();
    for (n, line) in wrapped.split(|&b| b == b'\n').enumerate() {
        let text = String::from_utf8_lossy(line);
        if let Some(z) = text.strip_prefix(";Z:") {
            layer_z = Some(z.trim().parse().unwrap());
            layers_seen += 1;
            ends.push((f64::MIN, 0.0));
            starts.push((f64::MAX, 0.0));
        }
        let before = machine.position();
        machine.execute(line, &mut |_, reply: &str| {
            assert!(!reply.starts_with("Error"), "line {}: {reply}", n + 1)
        });
        let after = machine.position();
        let [_, _, z1, e1, a1] = after;
        if e1 > before[3] + 1e-9 && (a1 - before[4]).abs() > 1e-9 {
            let z_layer = layer_z.unwrap();
            // The first layer is flat; every later one rises h per turn from y0.
            let turn = (a1 / 360.0) - y0 / c;
            let expected = if layers_seen == 1 { z_layer } else { z_layer - h * (1.0 - turn) };
            worst = worst.max((z1 - expected).abs());
            assert!((z1 - expected).abs() <= 0.01, "line {}: radial {z1}, helix {expected}", n + 1);
            beads += 1;
            let k = layers_seen - 1;
            if a1 > ends[k].0 {
                ends[k] = (a1, z1);
            }
            if a1 < starts[k].0 {
                starts[k] = (a1, z1);
            }
        }
    }
    assert_eq!(layers_seen, 10);
    assert!(beads > 1000, "{beads} beads");
    assert!(worst <= 0.0015, "rounding to 3 decimals only: {worst}");
    // Layer k's end of turn (one bead short of a full turn) is one bead's rise below layer
    // k+1's height: the layers join without a step.
    let bead_rise = h * 0.45 / c;
    for k in 1..9 {
        let (a_end, z_end) = ends[k];
        let (a_next, z_next) = starts[k + 1];
        let step = z_next + h * ((a_end - a_next) / 360.0 - 1.0) - z_end;
        assert!(step.abs() <= 0.01, "layer {k} -> {}: step {step} mm (bead rise {bead_rise})", k + 1);
    }
}

/// Travel goes the short way round: a travel across the seam turns the mandrel the short way,
/// every bead still lands on its mapped angle (the `G92` after a short travel puts the angle
/// back on the mapping), and the machine pushes the same filament as without it.
#[test]
fn travel_takes_the_short_way_round() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let profile = std::fs::read_to_string(root.join("examples/machines/rotary.toml")).unwrap();
    // The profile's 25 mm mandrel: a bead at y = 2, a travel across the seam to y = C - 2, a bead
    // there, and back.
    let c = std::f64::consts::PI * 25.0;
    let flat = format!(
        "M83\nM104 S200\nG1 Z0.2 F600\nG1 X10 Y2 F6000\nG1 X20 Y2 E0.5 F1200\nG0 X20 Y{0:.3} F6000\n\
         G1 X10 Y{0:.3} E0.5 F1200\nG0 X10 Y2 F6000\nG1 X20 Y2 E0.5 F1200\n",
        c - 2.0
    );
    let run = |short: bool| {
        let mut machine = Machine::new(MachineProfile::from_toml_str(&profile).unwrap()).unwrap();
        machine.execute(b"M302 P1", &mut |_, _| {});
        let mut config = WrapConfig::new(RotaryConfig::new(25.0));
        config.short_travel = short;
        let wrapped = wrap_bytes(config, flat.as_bytes()).unwrap();
        // A travel is cut into chords: add up the turn between two beads.
        let (mut longest_travel, mut travel): (f64, f64) = (0.0, 0.0);
        let mut bead_angles = Vec::new();
        for line in wrapped.split(|&b| b == b'\n') {
            let before = machine.position();
            machine.execute(line, &mut |_, _| {});
            let after = machine.position();
            if line.starts_with(b"G92") {
                continue;
            }
            if after[3] > before[3] + 1e-9 {
                bead_angles.push((before[4].rem_euclid(360.0) * 1000.0).round() as i64);
                travel = 0.0;
            } else {
                travel += after[4] - before[4];
                longest_travel = longest_travel.max(travel.abs());
            }
        }
        machine.finish(&mut |_, _| {});
        (longest_travel, bead_angles, machine.position()[3], wrapped)
    };
    let (long_way, beads_long, fed_long, _) = run(false);
    let (short_way, beads_short, fed_short, text) = run(true);
    let text = String::from_utf8(text).unwrap();
    assert!(long_way > 340.0, "mapped, the travel turns almost a full turn: {long_way}");
    assert!(
        (short_way - 4.0 * 360.0 / c).abs() < 0.01,
        "the short way is 4 mm of circumference: {short_way}"
    );
    assert!(text.contains("\nG0 A-9.166 F"), "{text}");
    assert!(text.contains("\nG92 A350.834\nG1 X10.000 E0.50000"), "{text}");
    assert_eq!(beads_long, beads_short, "beads on the same angles");
    assert_eq!(beads_short.len(), 3);
    assert!((fed_long - fed_short).abs() < 1e-9 && fed_short > 1.4, "{fed_long} {fed_short}");
}
