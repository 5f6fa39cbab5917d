//! Machine limits from where the user has them: `gweave estimate --machine slicer` and
//! `gweave machine from-m503`, through the real binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use gweave_sim::MachineProfile;
use gweave_sim::{Jerk, MarlinCorners};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name)
}

fn total_s(out: &Output) -> f64 {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    json["total_s"].as_f64().unwrap()
}

#[test]
fn estimate_with_the_limits_prusaslicer_wrote() {
    let file = fixture("prusaslicer/pr_torus_pva.gcode");
    let file = file.to_str().unwrap();
    let out = gweave(&["estimate", file, "--machine", "slicer", "--json", "-q"]);
    let from_file = total_s(&out);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.starts_with("PrusaSlicer's machine limits in the file, flavour marlin2: "), "{said}");
    assert!(
        said.contains("machine_max_acceleration_x = 9000") && said.contains("machine_max_jerk_z = 0.2"),
        "{said}"
    );
    // The same limits written by hand.
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("prusa.toml");
    std::fs::write(
        &toml,
        "[motion.max_feed_mm_s]\nx = 500.0\ny = 500.0\nz = 12.0\ne = 120.0\na = 360.0\n\
         [motion.max_accel_mm_s2]\nx = 9000.0\ny = 9000.0\nz = 500.0\ne = 10000.0\na = 3600.0\n\
         [motion.accel]\nprint_mm_s2 = 1500.0\nretract_mm_s2 = 1500.0\ntravel_mm_s2 = 1500.0\n\
         [motion.corners]\nmode = \"marlin\"\njerk_mm_s = { x = 10.0, y = 10.0, z = 0.2, e = 2.5 }\n",
    )
    .unwrap();
    let by_hand = total_s(&gweave(&["estimate", file, "--machine", toml.to_str().unwrap(), "--json", "-q"]));
    assert_eq!(from_file, by_hand);
    // A file without limits is refused with the reason.
    let cura = fixture("cura/cura_torus.gcode");
    let out = gweave(&["estimate", cura.to_str().unwrap(), "--machine", "slicer", "-q"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("holds no machine limits"));
}

#[test]
fn profile_from_an_m503_report() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("m503.txt");
    std::fs::write(
        &report,
        "Send: M503\nRecv: echo:  G21    ; Units in mm (mm)\nRecv: echo:  M92 X80.00 Y80.00 Z400.00 E93.00\n\
         Recv: echo:  M203 X500.00 Y500.00 Z5.00 E25.00\nRecv: echo:  M201 X500.00 Y500.00 Z100.00 E5000.00\n\
         Recv: echo:  M204 P500.00 R500.00 T1000.00\n\
         Recv: echo:  M205 B20000.00 S0.00 T0.00 X10.00 Y10.00 Z0.30 E5.00\n\
         Recv: echo:  M301 P21.73 I1.54 D76.55\nRecv: echo:  M851 X-40.00 Y-10.00 Z-1.50\nRecv: ok\n",
    )
    .unwrap();
    let toml = dir.path().join("printer.toml");
    let out = gweave(&["machine", "from-m503", report.to_str().unwrap(), "-o", toml.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not used: M851 X-40.00 Y-10.00 Z-1.50"));
    let text = std::fs::read_to_string(&toml).unwrap();
    assert!(text.contains("# used: M92 X80.00 Y80.00 Z400.00 E93.00"), "{text}");
    let p = MachineProfile::from_toml_str(&text).unwrap();
    assert_eq!(
        (p.motion.steps.e, p.motion.max_accel_mm_s2.x, p.motion.accel.travel_mm_s2),
        (93.0, 500.0, 1000.0)
    );
    let jerk = Jerk { x: 10.0, y: 10.0, z: 0.3, e: 5.0 };
    assert_eq!(p.motion.corners.marlin_corners(), Some(MarlinCorners::Jerk(jerk)));
    // The profile estimates.
    let file = fixture("cura/cura_torus.gcode");
    assert!(
        total_s(&gweave(&[
            "estimate",
            file.to_str().unwrap(),
            "--machine",
            toml.to_str().unwrap(),
            "--json",
            "-q"
        ])) > 0.0
    );
    // Writing over the report is refused; a report without settings is an error.
    let out = gweave(&["machine", "from-m503", report.to_str().unwrap(), "-o", report.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    std::fs::write(&report, "ok\n").unwrap();
    let out = gweave(&["machine", "from-m503", report.to_str().unwrap()]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("not an M503 report"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Regression (issue 40): `--machine` was loaded by the CLI and by Python each its own way; one
/// loader now says the same for both: a missing value names the built-in profiles, a refused
/// profile names its file.
#[test]
fn machine_is_loaded_once_for_every_front_end() {
    let file = fixture("prusaslicer/pr_torus_pva.gcode");
    let file = file.to_str().unwrap();
    let out = gweave(&["estimate", file, "--machine", "no-such-printer", "-q"]);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        said.starts_with("gweave: error: reading no-such-printer: No such file or directory (os error 2) (neither a file nor a built-in profile; built in: "),
        "{said}"
    );
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[bed]\nx_mm = -1\n").unwrap();
    let out = gweave(&["sim", file, "--machine", bad.to_str().unwrap(), "-q"]);
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.starts_with(&format!("gweave: error: {}: ", bad.display())), "{said}");
    assert!(said.contains("x_mm = -1 is out of range"), "{said}");
}
