//! Number words outside their command's physical range (the virtual printer's registry
//! declares each: `crates/gweave-sim/src/interp/commands.rs`): `sim` refuses the line,
//! `estimate` skips the same lines and says so, and `check` flags them, each naming the line.

use crate::harness::*;

/// A move and a dwell each side of five lines no printer should carry out: a 10^29 mm move, a
/// dwell of 10^30 s, a feed of 1 000 000 mm/min, a hotend at 10^30 degrees, a negative
/// acceleration. Numbers written out in full: `1e29` reads as `1` and an `E29` word.
const FILE: &str = "G90\nG1 X10 Y10 F3000\nG1 X100000000000000000000000000000\n\
                    G4 S1000000000000000000000000000000\nG1 F1000000\n\
                    M109 S1000000000000000000000000000000\nM204 S-5\nG1 X20 Y20\nG4 S1\n";
const REFUSED_LINES: [u64; 5] = [3, 4, 5, 6, 7];

fn json(out: &Outcome) -> serde_json::Value {
    out.assert_ok();
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Regression (estimate_plans_values_sim_refuses): `estimate` planned every one of these
/// (2 135 039 823 346 h) where `sim` refused them; `check` said nothing of the dwell and the
/// temperature. Now `estimate` skips the same lines as `sim` (1.581 s each: the two moves and
/// the one-second dwell) and counts them; `check` flags them as errors at their lines.
#[test]
fn estimate_plans_values_sim_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out-of-range.gcode");
    std::fs::write(&path, FILE).unwrap();
    let file = path.to_str().unwrap();

    let estimate = json(&gweave(dir.path(), &["estimate", file, "--json"]).run());
    let sim = json(&gweave(dir.path(), &["sim", file, "--json"]).run());
    let total_s = estimate["total_s"].as_f64().unwrap();
    let sim_s = sim["time"]["motion_s"].as_f64().unwrap() + sim["time"]["dwell_s"].as_f64().unwrap();
    assert!((total_s - sim_s).abs() < 1e-6, "estimate {total_s} s, sim {sim_s} s");
    assert!((total_s - 1.581).abs() < 1e-3, "{total_s} s");
    assert_eq!(estimate["dwell_s"].as_f64(), Some(1.0));
    assert_eq!(estimate["refused_lines"].as_u64(), Some(REFUSED_LINES.len() as u64));
    assert_eq!(estimate["first_refused_line"].as_u64(), Some(REFUSED_LINES[0]));
    assert_eq!(estimate["first_refusal"].as_str(), Some("G1 X = 1e29 is out of range: -10000 to 10000 mm"));
    let refused_by_sim: Vec<u64> = sim["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|w| w["kind"] == "refused")
        .map(|w| w["line"].as_u64().unwrap())
        .collect();
    assert_eq!(refused_by_sim, REFUSED_LINES);

    let human = gweave(dir.path(), &["estimate", file]).run();
    human.assert_ok();
    assert!(
        human
            .stdout_text()
            .contains("refused         5 lines, skipped as the printer refuses them (first: line 3"),
        "{}",
        human.stdout_text()
    );

    let check = gweave(dir.path(), &["check", file, "--json"]).run();
    assert_eq!(check.code, Some(1), "errors fail the check; stderr: {}", check.stderr);
    let check: serde_json::Value = serde_json::from_slice(&check.stdout).unwrap();
    let flagged: Vec<(u64, String)> = check["findings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["kind"] == "out_of_range")
        .map(|f| {
            (
                f["line"].as_u64().unwrap(),
                format!("{} = {}", f["word"].as_str().unwrap(), f["value"].as_str().unwrap()),
            )
        })
        .collect();
    let expected = [
        (3, "G1 X = 1e29"),
        (4, "G4 S = 1e30"),
        (5, "G1 F = 1000000"),
        (6, "M109 S = 1e30"),
        (7, "M204 S = -5"),
    ];
    assert_eq!(flagged, expected.map(|(line, word)| (line, word.to_owned())));
}
