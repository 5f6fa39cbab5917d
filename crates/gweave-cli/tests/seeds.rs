//! What the five seed documents ask for, through the real binary (docs/seeds.md).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The purge-shift seed's script stops when `;begin` or `;end` is missing; so does gweave,
/// writing nothing (not even to standard output).
#[test]
fn purge_shift_missing_marker_is_an_error_without_output() {
    let cone = fixture("slic3r/slic3r_cone_2tool.gcode");
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("out.gcode");
    for target in [out_file.to_str().unwrap(), "-"] {
        let out = gweave(&[
            "purge-shift",
            cone.to_str().unwrap(),
            "--purge",
            "2.5",
            "--markers",
            "begin,end",
            "-o",
            target,
        ]);
        assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
        assert!(out.stdout.is_empty(), "nothing on standard output");
        assert!(
            stderr(&out)
                .contains("the print-proper marker `;begin` is not in the file: add it as the last line"),
            "{}",
            stderr(&out)
        );
    }
    assert!(!out_file.exists());
    // With `;begin` but no `;end`, the end marker is named.
    let text = std::fs::read_to_string(&cone).unwrap().replacen("T0\n", "T0\n;begin\n", 1);
    let input = dir.path().join("begin_only.gcode");
    std::fs::write(&input, text).unwrap();
    let out = gweave(&[
        "purge-shift",
        input.to_str().unwrap(),
        "--purge",
        "2.5",
        "--markers",
        "begin,end",
        "-o",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    assert!(
        stderr(&out).contains("marker `;end` is not in the file after `;begin` (line"),
        "{}",
        stderr(&out)
    );
}

/// Slic3r writes no feature comments: the outer-wall rule cannot apply, and gweave says so
/// first among the warnings.
#[test]
fn purge_shift_warns_when_the_file_has_no_feature_comments() {
    let cone = fixture("slic3r/slic3r_cone_2tool.gcode");
    let out = gweave(&["purge-shift", cone.to_str().unwrap(), "--purge", "2.5", "-o", "-", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let first =
        stderr(&out).lines().find(|l| l.starts_with("gweave: warning:")).unwrap_or_default().to_string();
    assert!(
        first.starts_with("gweave: warning: the file has no feature comments (;TYPE:), so the rule keeping changes off outer_wall cannot apply"),
        "{first}"
    );
    // A PrusaSlicer file marks its features: no such warning.
    let torus = fixture("prusaslicer/pr_bunny_3tool_rel.gcode");
    let out = gweave(&["purge-shift", torus.to_str().unwrap(), "--purge", "2.5", "-o", "-", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!stderr(&out).contains("no feature comments"), "{}", stderr(&out));
}

/// The rotary seed's flat wrap: a part wider than the circumference is refused, naming both
/// widths, unless --allow-overlap; nothing is written.
#[test]
fn rotary_wrap_refuses_a_part_wider_than_the_circumference() {
    let plate = fixture("rotary/plate.gcode");
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("sleeve.gcode");
    let args = [
        "rotary",
        "wrap",
        plate.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
        "--mandrel-diameter",
        "20",
    ];
    let out = gweave(&args);
    assert_eq!(out.status.code(), Some(1));
    let said = stderr(&out);
    assert!(
        said.contains("span 93.798 mm round the mandrel") && said.contains("circumference 62.832 mm"),
        "{said}"
    );
    assert!(!out_file.exists());
    let out = gweave(&[&args[..], &["--allow-overlap", "-q"]].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(out_file.exists());
}

/// Setup lines of the flat file name the rotary axis (and its unit) after the wrap.
#[test]
fn rotary_wrap_says_setup_lines_for_the_rotary_axis() {
    let dir = tempfile::tempdir().unwrap();
    let flat = dir.path().join("flat.gcode");
    std::fs::write(&flat, "M92 X80 Y80 Z400 E93\nM203 X200 Y200\nG1 X1 Y1 F600\n").unwrap();
    // 60 mm of circumference: 1 mm of flat Y is 6 degrees.
    let d = format!("{}", 60.0 / std::f64::consts::PI);
    let out = gweave(&["rotary", "wrap", flat.to_str().unwrap(), "-o", "-", "--mandrel-diameter", &d]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("\nM92 X80 A13.333 Z400 E93\nM203 X200 A1200.000\n"), "{text}");
}

/// --helical through the CLI: the report says so, the second layer starts on the first.
#[test]
fn rotary_wrap_helical_from_the_command_line() {
    let plate = fixture("rotary/plate.gcode");
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("sleeve.gcode");
    let out = gweave(&[
        "rotary",
        "wrap",
        plate.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
        "--mandrel-diameter",
        "30",
        "--helical",
        "--json",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["helical"], true);
    let r = |k: usize| json["layers"][k]["radius_mm"].as_f64().unwrap();
    // Each layer's first bead is on the layer below's height, at the start of its turn.
    assert!(
        (r(0) - 15.2).abs() < 1e-9 && (r(1) - 15.2).abs() < 0.002 && (r(2) - 15.4).abs() < 0.002,
        "{json}"
    );
    let refused = gweave(&[
        "rotary",
        "wrap",
        plate.to_str().unwrap(),
        "-o",
        "-",
        "--mandrel-diameter",
        "30",
        "--helical",
        "--seam-rotation",
        "5",
    ]);
    assert_eq!(refused.status.code(), Some(2), "clap refuses the pair");
}

/// The controller seed's thermistor table: a profile naming a CSV file beside it, run by
/// `gweave sim` from another folder (the file is found next to the profile).
#[test]
fn sim_reads_the_thermistor_table_next_to_the_profile() {
    let profile = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/seed-controller.toml");
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("heat.gcode");
    std::fs::write(&job, "M104 S200\nM109 S200\nM105\n").unwrap();
    let out = gweave(&["sim", job.to_str().unwrap(), "--machine", profile.to_str().unwrap(), "--json", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // A table that is not there is named.
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[thermal]\nthermistor_table = \"nowhere.csv\"\n").unwrap();
    let out = gweave(&["sim", job.to_str().unwrap(), "--machine", bad.to_str().unwrap(), "-q"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("[thermal] thermistor_table") && stderr(&out).contains("nowhere.csv"),
        "{}",
        stderr(&out)
    );
}

/// The controller seed's M0 (`[firmware] m0 = "seed"`) ends the program: `gweave sim` runs
/// nothing after it; Marlin's M0 goes on.
#[test]
fn sim_stops_at_the_seeds_m0() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.gcode");
    std::fs::write(&job, "G28\nG1 X50 F3000\nM0\nG1 X500\n").unwrap();
    let seed = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/seed-controller.toml");
    let marlin = dir.path().join("marlin.toml");
    std::fs::write(&marlin, "[firmware]\nm0 = \"marlin\"\n").unwrap();
    for (profile, runs_on) in [(seed.as_path(), false), (marlin.as_path(), true)] {
        let out =
            gweave(&["sim", job.to_str().unwrap(), "--machine", profile.to_str().unwrap(), "--json", "-q"]);
        assert!(out.status.success(), "{}", stderr(&out));
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let out_of_bounds = json["warnings"].as_array().unwrap().iter().any(|w| w["kind"] == "out_of_bounds");
        assert_eq!(out_of_bounds, runs_on, "{}: {json}", profile.display());
    }
}

/// The controller seed's constant-speed stepping through `gweave sim` and `gweave estimate`
/// with its example profile: X10 at F600 is 800 steps of 1 / (10 mm/s * 80 steps/mm), exactly
/// 1 s; X20 Y15 at F1200 is Y's 1200 steps of 1 / (20 * 80) s, 0.75 s; the 2 mm retract at
/// F2400 is 1000 E steps of 1 / (40 * 500) s, 0.05 s. (`estimate` read the profile's
/// thermistor table from the working folder and refused the profile from anywhere else.)
#[test]
fn sim_and_estimate_time_the_seeds_constant_speed_moves() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.gcode");
    std::fs::write(&job, "M109 S200\nG1 X10 F600\nG1 X20 Y15 F1200\nG1 E-2 F2400\n").unwrap();
    let seed = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/seed-controller.toml");
    let (job, seed) = (job.to_str().unwrap(), seed.to_str().unwrap());
    let out = gweave(&["sim", job, "--machine", seed, "--json", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let motion_s = json["time"]["motion_s"].as_f64().unwrap();
    assert!((motion_s - 1.8).abs() < 1e-9, "{}", json["time"]);
    assert_eq!(json["steps"]["axes"], serde_json::json!([1600, 1200, 0, 1000, 0]));
    let out = gweave(&["estimate", job, "--machine", seed, "--json", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["planner"], "constant");
    assert!((json["motion_s"].as_f64().unwrap() - 1.8).abs() < 1e-9, "{json}");
}
