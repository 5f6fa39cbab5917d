//! `gweave mix` on the mixing machine: everything a file extrudes before its first layer (the
//! start G-code's prime line, the initial purge) already runs on the first mix, as the virtual
//! printer's per-input filament shows.

use std::path::PathBuf;

use gweave::post::mix::mix_bytes;
use gweave::post::mix::profile::MixProfile;
use gweave_sim::MachineProfile;
use gweave_sim::{Machine, SimReport};

fn repo(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..").join(rel)
}

fn read(rel: &str) -> Vec<u8> {
    let p = repo(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Runs `text` on `examples/machines/mixing-4in.toml`.
fn sim_mixing(text: &[u8]) -> SimReport {
    let machine = String::from_utf8(read("examples/machines/mixing-4in.toml")).unwrap();
    let mut m = Machine::new(MachineProfile::from_toml_str(&machine).unwrap()).unwrap();
    let mut out = |_t: f64, _l: &str| {};
    for line in text.split(|&b| b == b'\n') {
        m.execute(line, &mut out);
    }
    m.finish(&mut out);
    m.report()
}

/// The lines before the first `;LAYER:0`.
fn before_layer_0(text: &[u8]) -> &[u8] {
    let at = text.windows(9).position(|w| w == b";LAYER:0\n").expect("a ;LAYER:0 line");
    &text[..at]
}

/// Asserts that `used` (mm per input) is `total_mm` split in `ratios`.
fn assert_split(used: &[f64], total_mm: f64, ratios: &[f64]) {
    assert_eq!(used.len(), ratios.len(), "{used:?}");
    for (u, r) in used.iter().zip(ratios) {
        assert!((u - total_mm * r).abs() < 0.01, "used {used:?}, expected {total_mm} mm as {ratios:?}");
    }
}

#[test]
fn the_prime_line_before_layer_0_runs_on_the_first_mix() {
    // Cura's start G-code primes 23.5 mm; with the definitions at ;LAYER:0 it ran on the
    // firmware's default mix (input 0, cyan, alone).
    let input = read("tests/data/cura/cura_torus.gcode");
    let orange = [0.0, 0.1717, 0.8283, 0.0];
    for (initial_mm, extra) in [(0.0, ""), (30.0, "[purge]\ninitial_mm = 30\n")] {
        let profile =
            MixProfile::from_toml_str(&format!("[[schedule]]\nlayer = 0\nmix = \"Orange\"\n{extra}"))
                .unwrap();
        let (out, report) = mix_bytes(profile, &input).unwrap();
        let pre = sim_mixing(before_layer_0(&out));
        assert!(!pre.halted);
        assert_split(&pre.mixing_input_mm, 23.5 + initial_mm, &orange);
        // The report counts the prime line and the purge too.
        assert_eq!(report.purge.count, u32::from(initial_mm > 0.0), "initial {initial_mm}");
        assert!((report.purge.filament_mm - initial_mm).abs() < 1e-9);
    }
}

#[test]
fn a_tool_mapped_file_primes_in_its_first_tools_mix() {
    // A two-tool Cura file: before layer 0, T0 retracts 6.5 mm, already in T0's mix (the
    // unretraction at layer 0 must push back what was pulled).
    let input = read("tests/data/cura/cura_dual.gcode");
    let mut profile = MixProfile::default();
    profile.add_map("T0=Green").unwrap();
    profile.add_map("T1=Red").unwrap();
    let (out, _) = mix_bytes(profile, &input).unwrap();
    let pre = sim_mixing(before_layer_0(&out));
    assert_split(&pre.mixing_input_mm, -6.5, &[0.5, 0.0, 0.5, 0.0]);
}
