//! `gweave sim` on `gweave rotary` output: the feed convention the file declares.

use std::path::Path;
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap();
    assert!(out.status.success(), "gweave {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

/// The motion time `gweave sim --json` reports for a file on the built-in lathe profile, s.
fn motion_s(file: &Path) -> f64 {
    let out = gweave(&["sim", file.to_str().unwrap(), "--machine", "rotary", "--json"]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    report["time"]["motion_s"].as_f64().unwrap()
}

/// The bug: `gweave rotary tube` writes F under the NIST convention by default (the axial
/// speed; its header says `feed Nist`), and `gweave sim` read every F as Marlin does, along A
/// for a helix step of fewer than 6 X steps: a 3-minute tube took 5 h 23 min on the virtual
/// printer. Now the sim takes the convention from the header, and the same tube written with
/// either convention takes the time its F words say.
#[test]
fn gweave_sim_reads_the_feed_convention_the_rotary_file_declares() {
    let dir = tempfile::tempdir().unwrap();
    let tube = |convention: &str| {
        let path = dir.path().join(format!("tube-{convention}.gcode"));
        let args = [
            "rotary",
            "tube",
            "-o",
            path.to_str().unwrap(),
            "--mandrel-diameter",
            "20",
            "--length",
            "40",
            "--layer-count",
            "4",
            "--pitch",
            "3",
            "--feed-convention",
            convention,
        ];
        gweave(&args);
        path
    };
    let (nist, combined) = (motion_s(&tube("nist")), motion_s(&tube("combined")));
    // Inverse time: `G93` at the start, F = 1 / minutes of each move, `G94` at the end.
    let inverse = motion_s(&tube("inverse-time"));
    // The writer's own figure ("time (F only)") is 3 min 6 s; the sim adds the accelerations.
    for (name, t_s) in [("nist", nist), ("combined", combined), ("inverse-time", inverse)] {
        assert!((186.0..=200.0).contains(&t_s), "{name}: {t_s:.1} s of motion");
    }
    assert!((nist / combined - 1.0).abs() < 0.01, "nist {nist:.1} s, combined {combined:.1} s");
    assert!((nist / inverse - 1.0).abs() < 0.01, "nist {nist:.1} s, inverse time {inverse:.1} s");
}
