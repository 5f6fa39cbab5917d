//! The calibration card on the virtual printer's mixing machine: every swatch (its purge and its
//! patch) feeds the inputs in exactly its ratios, nothing halts, and nothing leaves the bed.

use std::path::PathBuf;

use gweave::post::mix::card::calibration_card;
use gweave::post::mix::profile::MixProfile;
use gweave_sim::MachineProfile;
use gweave_sim::{Machine, SimReport};

fn sim_mixing(text: &str) -> SimReport {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/mixing-4in.toml");
    let machine = MachineProfile::from_toml_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    let mut m = Machine::new(machine).unwrap();
    let mut out = |_t: f64, _l: &str| {};
    for line in text.split('\n') {
        m.execute(line.as_bytes(), &mut out);
    }
    m.finish(&mut out);
    m.report()
}

#[test]
fn each_swatch_feeds_its_own_ratios() {
    let (gcode, report) = calibration_card(&MixProfile::default()).unwrap();
    let text = String::from_utf8(gcode).unwrap();
    // Where each swatch (and, after the last, the end) starts.
    let mut starts: Vec<usize> = text.match_indices("; gweave card: ").map(|(i, _)| i).collect();
    starts.push(text.len());
    assert_eq!(starts.len(), report.swatches.len() + 2);
    let mut before = sim_mixing(&text[..starts[0]]).mixing_input_mm;
    assert!(before.iter().all(|&mm| mm == 0.0), "nothing extrudes before swatch 1: {before:?}");
    for (s, end) in report.swatches.iter().zip(&starts[1..]) {
        let after = sim_mixing(&text[..*end]).mixing_input_mm;
        let used: Vec<f64> = after.iter().zip(&before).map(|(a, b)| a - b).collect();
        let total: f64 = used.iter().sum();
        // The patch (5 layers of 15 x 15 mm) and at least the 25 mm purge.
        assert!(total > 25.0 + 50.0, "swatch {}: {total} mm", s.id);
        for (u, r) in used.iter().zip(&s.ratios) {
            assert!((u - total * r).abs() < 1e-3 * total, "swatch {}: {used:?} vs {:?}", s.id, s.ratios);
        }
        before = after;
    }
    let whole = sim_mixing(&text);
    assert!(!whole.halted);
    for kind in ["out_of_bounds", "below_bed", "cold_extrusion"] {
        assert_eq!(
            whole.warning_counts.get(kind).copied().unwrap_or(0),
            0,
            "{kind}: {:?}",
            whole.warnings.first()
        );
    }
}
