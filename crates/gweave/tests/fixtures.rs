//! Every real slicer fixture: byte-exact round trip, slicer and layer structure, and filament
//! figures equal to the slicer's own to 0.01 %.

use std::path::{Path, PathBuf};

use gweave::gcode::layers::{Region, Slicer};
use gweave::{Identity, Run, Stats, StatsPass};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(rel)
}

const FIXTURES: [&str; 7] = [
    "prusaslicer/pr_torus_pva.gcode",
    "prusaslicer/pr_box_mach3.gcode",
    "prusaslicer/pr_bunny_3tool_rel.gcode",
    "prusaslicer/pr_sphere_rrf_fwretract.gcode",
    "cura/cura_torus.gcode",
    "cura/cura_dual.gcode",
    "slic3r/slic3r_cone_2tool.gcode",
];

fn stats(rel: &str) -> (Stats, gweave::State) {
    let mut pass = StatsPass::new(None);
    let state = Run::file(&data(rel)).scan(&mut pass).unwrap();
    (pass.into_stats(&state), state)
}

#[test]
fn every_fixture_round_trips_byte_exact() {
    for rel in FIXTURES {
        let bytes = std::fs::read(data(rel)).unwrap();
        let mut copy = Identity::default();
        let out = Run::text(&bytes).to_memory().run(&mut copy).unwrap().output;
        assert!(out == bytes, "{rel} did not round-trip");
        let newlines = bytes.iter().filter(|&&b| b == b'\n').count() as u64;
        let lines = newlines + u64::from(bytes.last() != Some(&b'\n'));
        assert_eq!((copy.report.lines, copy.report.bytes), (lines, bytes.len() as u64), "{rel}");
        assert_eq!(copy.report.malformed.malformed_lines, 0, "{rel}");
    }
}

#[test]
fn filament_equals_the_slicers_own_figures() {
    for rel in FIXTURES.iter().filter(|r| !r.starts_with("cura")) {
        let (s, _) = stats(rel);
        let theirs = s.slicer_figures.filament_used_mm.clone().expect(rel);
        assert_eq!(theirs.len(), s.filament.len(), "{rel}");
        for (ours, theirs) in s.filament.iter().zip(&theirs) {
            // The slicer rounds to 0.01 mm (Slic3r to 0.1 mm): allow that rounding or 0.01 %.
            let tolerance = (theirs * 1e-4).max(if rel.starts_with("slic3r") { 0.05 } else { 0.005 });
            assert!(
                (ours.extruded_mm - theirs).abs() <= tolerance,
                "{rel} T{}: {} vs {theirs}",
                ours.tool,
                ours.extruded_mm
            );
        }
    }
}

#[test]
fn layers_and_regions_per_slicer() {
    let expect: [(&str, Slicer, u32, [f64; 2]); 6] = [
        ("prusaslicer/pr_torus_pva.gcode", Slicer::PrusaSlicer, 28, [0.35, 5.75]),
        ("prusaslicer/pr_bunny_3tool_rel.gcode", Slicer::PrusaSlicer, 535, [0.35, 107.15]),
        ("prusaslicer/pr_sphere_rrf_fwretract.gcode", Slicer::PrusaSlicer, 154, [0.35, 30.95]),
        ("cura/cura_torus.gcode", Slicer::Cura, 28, [0.3, 5.7]),
        ("cura/cura_dual.gcode", Slicer::Cura, 204, [0.3, 42.9]),
        ("slic3r/slic3r_cone_2tool.gcode", Slicer::Slic3r, 121, [0.35, 24.35]),
    ];
    for (rel, slicer, layers, z) in expect {
        let (s, state) = stats(rel);
        assert_eq!(s.slicer, slicer, "{rel}");
        assert_eq!(s.layers, layers, "{rel}");
        let [lo, hi] = s.z_range_mm.unwrap();
        assert!((lo - z[0]).abs() < 1e-9 && (hi - z[1]).abs() < 1e-9, "{rel}: {lo}..{hi}");
        if slicer != Slicer::Slic3r {
            assert_eq!(state.structure.region, Region::End, "{rel}: end G-code not found");
            assert!(
                s.end_lines > 5 && s.start_lines > 10,
                "{rel}: {} start, {} end lines",
                s.start_lines,
                s.end_lines
            );
        }
    }
}

#[test]
fn tool_changes_as_the_fixture_readme_says() {
    // The README counts `T` commands; the first (`T0` while on tool 0) changes nothing.
    assert_eq!(stats("prusaslicer/pr_torus_pva.gcode").0.tool_changes, 2);
    assert_eq!(stats("slic3r/slic3r_cone_2tool.gcode").0.tool_changes, 108);
    let (bunny, _) = stats("prusaslicer/pr_bunny_3tool_rel.gcode");
    assert_eq!(bunny.tool_changes, 793);
    assert!(bunny.filament.len() == 3);
}

/// Klipper's `max_extrude_cross_section` check finds no bead too wide in any fixture read for
/// Klipper: real slicer output, purge lines, wipe towers and their ramming print on a Klipper
/// printer with its defaults (the nozzle and filament from each file's settings, as
/// `check_file` takes them), so the check flags blobs, not prints.
#[test]
fn no_fixture_makes_a_bead_wider_than_klipper_takes() {
    use gweave::{CheckOptions, CheckPass, Finding, Firmware, KlipperExtruder};
    for rel in FIXTURES {
        let path = data(rel);
        let ends = gweave::gcode::ends::read_ends(&path).unwrap();
        let klipper = KlipperExtruder::default().from_settings(&String::from_utf8_lossy(&ends));
        let mut pass = CheckPass::new(CheckOptions { klipper, ..CheckOptions::default() });
        Run::file(&path).firmware(Some(Firmware::Klipper)).scan(&mut pass).unwrap();
        let wide: Vec<(u64, String)> = pass
            .report
            .findings
            .iter()
            .filter(|f| matches!(f.diagnostic.finding, Finding::OverExtrusion { .. }))
            .map(|f| (f.line, f.diagnostic.finding.to_string()))
            .collect();
        assert_eq!(wide, Vec::new(), "{rel}");
    }
}

/// `gweave check` finds nothing wrong in any fixture: they are real slicer output that prints.
/// In particular PrusaSlicer's RepRapFirmware flavour heats with `G10 P0 S200` (then `M116`),
/// which is a temperature, not a missing one, and Cura's Griffin flavour primes with `G280`,
/// which Ultimaker's firmware knows (the file says `;FLAVOR:Griffin`).
#[test]
fn check_finds_only_real_problems_in_the_fixtures() {
    use gweave::{CheckOptions, CheckPass};
    for rel in FIXTURES {
        let mut pass = CheckPass::new(CheckOptions::default());
        Run::file(&data(rel)).scan(&mut pass).unwrap();
        let found: Vec<(u64, String)> =
            pass.report.findings.iter().map(|f| (f.line, f.diagnostic.finding.to_string())).collect();
        assert_eq!(found, Vec::new(), "{rel}");
    }
}
