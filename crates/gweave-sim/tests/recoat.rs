//! The powder recoat of the printhead profile's `[recoat]` table, written by the raster
//! generator between layers and checked by the virtual printer (examples/machines/binder-jet.toml):
//! pistons by the layer height, the spreader across the whole bed, no fire during a recoat.

use std::path::Path;

use gweave::gen::bitmap::Bitmap;
use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster::{RasterConfig, RasterWriter};
use gweave_sim::InkjetWarning;
use gweave_sim::MachineProfile;
use gweave_sim::{Machine, Outcome};

fn machine_profile() -> MachineProfile {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/binder-jet.toml");
    MachineProfile::from_toml_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn head_of(profile: &MachineProfile) -> PrintheadProfile {
    profile.inkjet.as_ref().unwrap().printhead.clone()
}

/// Three layers of a filled 24 x 24 px square, generated with the printhead `head`, run on the
/// machine `profile`: its inkjet warnings and the G-code.
fn run(profile: &MachineProfile, head: &PrintheadProfile) -> (Vec<InkjetWarning>, String) {
    let mut square = Bitmap::new(24, 24);
    for y in 0..24 {
        for x in 0..24 {
            square.set(x, y, true);
        }
    }
    let cfg = RasterConfig { layer_height_mm: Some(0.2), ..RasterConfig::default() };
    let mut w = RasterWriter::new(Vec::new(), head, &cfg, None).unwrap();
    for _ in 0..3 {
        w.layer(std::slice::from_ref(&square)).unwrap();
    }
    let (gcode, _) = w.finish().unwrap();
    let mut machine = Machine::new(profile.clone()).unwrap();
    let mut replies = Vec::new();
    for line in gcode.split(|&b| b == b'\n') {
        assert_eq!(machine.execute(line, &mut |_, r: &str| replies.push(r.to_owned())), Outcome::Ok);
    }
    machine.finish(&mut |_, _| {});
    assert!(replies.iter().all(|r| !r.starts_with("Error") && !r.contains("Unknown")), "{replies:?}");
    let warnings = machine.report().inkjet_warnings().cloned().collect();
    (warnings, String::from_utf8(gcode).unwrap())
}

#[test]
fn recoat_from_the_profile_passes_the_virtual_printer() {
    let profile = machine_profile();
    let (warnings, gcode) = run(&profile, &head_of(&profile));
    assert_eq!(warnings, vec![]);
    // Two recoats (before layers 1 and 2), each the profile's motion.
    assert_eq!(gcode.matches("; gweave raster: recoat for layer").count(), 2);
    assert!(
        gcode.contains(
            "M400\nG1 Z0.6 F120\nG1 A0.6\nG1 Y5 F3000\nG1 Y195 F300\nG1 Y5 F3000\nG4 P500\nG1 Z0.6\n"
        ),
        "{gcode}"
    );
}

#[test]
fn a_spreader_short_of_the_bed_is_caught() {
    let profile = machine_profile();
    // To Y 105: the bed runs to 178.75 mm.
    let mut head = head_of(&profile);
    head.recoat.as_mut().unwrap().spreader_stroke_mm = 100.0;
    let (warnings, _) = run(&profile, &head);
    assert!(warnings.iter().any(|w| matches!(w, InkjetWarning::FireDuringRecoat { .. })), "{warnings:?}");
    assert!(
        warnings.contains(&InkjetWarning::SpreaderShort { reach_mm: [5.0, 105.0], bed_mm: [20.0, 178.75] }),
        "{warnings:?}"
    );
}

#[test]
fn a_layer_without_recoat_or_with_a_short_feed_is_caught() {
    let profile = machine_profile();
    // The job written without the profile's table: the build piston (Z) drops, nothing spreads,
    // and each new layer's first fire lands on the old powder.
    let mut head = head_of(&profile);
    head.recoat = None;
    let (warnings, _) = run(&profile, &head);
    // (The spreader rides on the carriage's Y here: the carriage's own moves are all it did.)
    let during = warnings.iter().filter(|w| matches!(w, InkjetWarning::FireDuringRecoat { .. })).count();
    assert_eq!(during, 2, "one per layer after the first: {warnings:?}");
    assert!(
        warnings.iter().all(|w| matches!(
            w,
            InkjetWarning::FireDuringRecoat { .. } | InkjetWarning::SpreaderShort { .. }
        )),
        "{warnings:?}"
    );
    // A feed piston that rises only one layer height where the machine needs 1.5.
    let mut head = head_of(&profile);
    head.recoat.as_mut().unwrap().powder_ratio = 1.0;
    let (warnings, _) = run(&profile, &head);
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(
        warnings.iter().all(|w| matches!(w, InkjetWarning::PistonTravel { axis: 'A', moved_mm, expected_mm }
            if (moved_mm - 0.2).abs() < 1e-9 && (expected_mm - 0.3).abs() < 1e-9)),
        "{warnings:?}"
    );
}
