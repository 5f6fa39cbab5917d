//! `gweave sim` and `gweave estimate` on `gweave rotary` output: the feed convention the file
//! declares.

use std::path::Path;
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap();
    assert!(out.status.success(), "gweave {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

/// The `--json` report of `gweave COMMAND FILE --machine rotary` (the built-in lathe profile).
fn on_lathe(command: &str, file: &Path) -> serde_json::Value {
    let out = gweave(&[command, file.to_str().unwrap(), "--machine", "rotary", "--json"]);
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The motion time `gweave sim --json` reports for a file on the built-in lathe profile, s.
fn motion_s(file: &Path) -> f64 {
    on_lathe("sim", file)["time"]["motion_s"].as_f64().unwrap()
}

/// `gweave rotary tube` of a 20 mm mandrel (`--length 20 --layer-count 3`: thousands of helix
/// steps of a few X steps each) under `convention`, written to `dir`.
fn tube(dir: &Path, convention: &str) -> std::path::PathBuf {
    let path = dir.join(format!("tube-{convention}.gcode"));
    let out = path.to_str().unwrap();
    gweave(&[
        "rotary",
        "tube",
        "-o",
        out,
        "--mandrel-diameter",
        "20",
        "--length",
        "20",
        "--layer-count",
        "3",
        "--feed-convention",
        convention,
    ]);
    path
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

/// `gweave rotary wrap` of the flat plate (tests/data/rotary) on a 30 mm mandrel under
/// `convention`, written to `dir`.
fn wrap(dir: &Path, convention: &str) -> std::path::PathBuf {
    let plate = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/rotary/plate.gcode");
    let path = dir.join(format!("wrap-{convention}.gcode"));
    let (plate, out) = (plate.to_str().unwrap(), path.to_str().unwrap());
    gweave(&[
        "rotary",
        "wrap",
        plate,
        "-o",
        out,
        "--mandrel-diameter",
        "30",
        "--feed-convention",
        convention,
    ]);
    path
}

/// `gweave estimate`'s total and `gweave sim`'s motion and dwell (the sim also homes and heats,
/// which the estimate does not count), s.
fn estimate_and_sim_s(file: &Path) -> (f64, f64) {
    let estimate = on_lathe("estimate", file)["total_s"].as_f64().unwrap();
    let sim = on_lathe("sim", file);
    let time = |key: &str| sim["time"][key].as_f64().unwrap();
    (estimate, time("motion_s") + time("dwell_s"))
}

/// The bug: `gweave estimate` read a rotary program's F words as the firmware model does, not
/// as its header declares them (which `gweave sim` had been taught): a NIST tube the generator
/// times at 8 min was estimated at 90 h 44 min (sim: 8 min 6 s), and a wrapped plate at 69 s,
/// 16 s and 88 s under the three conventions (sim: 21.5 s for each). Now both read the
/// convention in one place, the estimator's, and agree to the microsecond; without the header
/// both keep the model's reading.
#[test]
fn gweave_estimate_reads_the_rotary_feed_convention_as_gweave_sim_does() {
    let dir = tempfile::tempdir().unwrap();
    for convention in ["nist", "combined", "inverse-time"] {
        for (shape, path) in [("tube", tube(dir.path(), convention)), ("wrap", wrap(dir.path(), convention))]
        {
            let (estimate_s, sim_s) = estimate_and_sim_s(&path);
            assert!(
                (estimate_s - sim_s).abs() < 1e-6,
                "{shape} {convention}: estimate {estimate_s} s, sim {sim_s} s"
            );
            // The writer's time ("time (F only)": 8 min 5 s for the tube, 29 min 53 s for the
            // plate) plus the accelerations.
            let expected = if shape == "tube" { 485.0..=500.0 } else { 1793.0..=1900.0 };
            assert!(expected.contains(&estimate_s), "{shape} {convention}: {estimate_s} s");
        }
    }
    // Without the header (`; axes: ... feed Nist`) both read F as Marlin does, along A for a
    // helix step of fewer than 6 X steps: the 8-minute tube takes 90 h 44 min.
    let nist = std::fs::read_to_string(tube(dir.path(), "nist")).unwrap();
    let bare = dir.path().join("tube-bare.gcode");
    let lines: Vec<&str> = nist.lines().filter(|l| !l.starts_with("; axes:")).collect();
    std::fs::write(&bare, lines.join("\n")).unwrap();
    let (estimate_s, sim_s) = estimate_and_sim_s(&bare);
    assert!((estimate_s - sim_s).abs() < 1e-6, "bare tube: estimate {estimate_s} s, sim {sim_s} s");
    assert!(estimate_s > 90.0 * 3600.0, "bare tube: {estimate_s} s");
}

/// `sim` read a rotary program's header with a second open of the file by its path, `estimate`
/// from the stream it reads; both now read it from the stream's head. A tube stored as gzip,
/// as binary G-code or piped in on standard input declares its feed convention to both as the
/// text file does: the same times to the microsecond, and a NIST tube's 8 minutes, not the
/// 90 hours of F read along A.
#[test]
fn a_rotary_header_is_read_from_the_stream_in_every_container_and_from_standard_input() {
    let dir = tempfile::tempdir().unwrap();
    let text = tube(dir.path(), "nist");
    let (estimate_s, sim_s) = estimate_and_sim_s(&text);
    assert!((485.0..=500.0).contains(&estimate_s), "{estimate_s} s");
    for name in ["tube.gcode.gz", "tube.bgcode"] {
        let stored = dir.path().join(name);
        gweave(&["cat", text.to_str().unwrap(), "-o", stored.to_str().unwrap(), "-q"]);
        let (e_s, s_s) = estimate_and_sim_s(&stored);
        assert!((e_s - estimate_s).abs() < 1e-6 && (s_s - sim_s).abs() < 1e-6, "{name}: {e_s} s, {s_s} s");
    }
    let piped = |command: &str| -> serde_json::Value {
        let stdin = std::fs::File::open(&text).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_gweave"))
            .args([command, "-", "--machine", "rotary", "--json"])
            .stdin(stdin)
            .output()
            .unwrap();
        assert!(out.status.success(), "{command} -: {}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let e_s = piped("estimate")["total_s"].as_f64().unwrap();
    let sim = piped("sim");
    let s_s = sim["time"]["motion_s"].as_f64().unwrap() + sim["time"]["dwell_s"].as_f64().unwrap();
    assert!((e_s - estimate_s).abs() < 1e-6 && (s_s - sim_s).abs() < 1e-6, "stdin: {e_s} s, {s_s} s");
}

/// Regression (stats_of_a_rotary_wrap_ignores_a, end to end): `stats` of a wrapped plate read
/// the mandrel's turns as no move. Measured on the mandrel, its print is the flat one's with
/// each circumferential length grown by (R0 + z) / R0 (z 0.2 to 2 mm on a 15 mm radius), its
/// axial extents the flat X ones and its angles within one turn.
#[test]
fn stats_of_a_rotary_wrap_measures_the_mandrel() {
    let dir = tempfile::tempdir().unwrap();
    let plate = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/rotary/plate.gcode");
    let wrapped = dir.path().join("wrapped.gcode");
    gweave(&["rotary", "wrap", plate, "-o", wrapped.to_str().unwrap(), "--mandrel-diameter", "30", "-q"]);
    let stats = |file: &str| -> serde_json::Value {
        serde_json::from_slice(&gweave(&["stats", file, "--json"]).stdout).unwrap()
    };
    let (flat, round) = (stats(plate), stats(wrapped.to_str().unwrap()));
    let (flat_mm, round_mm) = (flat["print_mm"].as_f64().unwrap(), round["print_mm"].as_f64().unwrap());
    assert!(flat_mm < round_mm && round_mm < flat_mm * 17.0 / 15.0, "{flat_mm} -> {round_mm}");
    assert!(flat.get("rotary").is_none());
    let r = &round["rotary"];
    assert_eq!(r["mandrel_diameter_mm"], 30.0);
    let bounds = &flat["extrusion_bounds"];
    for (i, side) in ["min", "max"].iter().enumerate() {
        let flat_x = bounds[side][0].as_f64().unwrap();
        assert!((r["axial_mm"][i].as_f64().unwrap() - flat_x).abs() < 1e-3, "{r}");
        assert!((0.0..=360.0).contains(&r["angle_deg"][i].as_f64().unwrap()), "{r}");
        let radius = r["radius_mm"][i].as_f64().unwrap();
        assert!((15.2 - 1e-6..=17.0 + 1e-6).contains(&radius), "{r}");
    }
}
