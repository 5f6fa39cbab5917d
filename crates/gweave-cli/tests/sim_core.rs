//! `gweave sim` with `[firmware] kind = "gweave"`: the file runs on gweave's own controller core
//! (the firmware of the RAMPS board), and ends where the Marlin model ends.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

/// The `Count X.. Y.. Z..` of a summary's end position line.
fn counts(stdout: &str) -> Vec<i64> {
    let line = stdout.lines().find(|l| l.contains("end position")).expect("an end position line");
    let tail = &line[line.find("Count").expect("counts")..];
    tail.split(|c: char| !(c.is_ascii_digit() || c == '-')).filter_map(|w| w.parse().ok()).take(3).collect()
}

#[test]
fn sim_on_the_controller_core_ends_where_the_marlin_model_ends() {
    // The first layers of a real Cura file, without the heating waits (minutes of board time):
    // both machines refuse the cold extrusion alike, and move alike.
    let text = std::fs::read_to_string(repo("tests/data/cura/cura_torus.gcode")).unwrap();
    let cut: String = text
        .lines()
        .take(1500)
        .filter(|l| !(l.starts_with("M109") || l.starts_with("M190")))
        .flat_map(|l| [l, "\n"])
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cut.gcode");
    std::fs::write(&file, cut).unwrap();
    let core_profile = repo("examples/machines/gweave-ramps.toml");
    let marlin_profile = dir.path().join("marlin.toml");
    let profile = std::fs::read_to_string(&core_profile).unwrap();
    std::fs::write(&marlin_profile, profile.replace("kind = \"gweave\"", "kind = \"marlin\"")).unwrap();

    let core = gweave(&["sim", file.to_str().unwrap(), "--machine", core_profile.to_str().unwrap()]);
    let core_out = String::from_utf8_lossy(&core.stdout);
    assert!(core.status.success(), "{core_out}{}", String::from_utf8_lossy(&core.stderr));
    assert!(core_out.contains("(gweave controller core)"), "{core_out}");
    let marlin = gweave(&["sim", file.to_str().unwrap(), "--machine", marlin_profile.to_str().unwrap()]);
    let marlin_out = String::from_utf8_lossy(&marlin.stdout);
    assert!(marlin.status.success(), "{marlin_out}");
    let (core_counts, marlin_counts) = (counts(&core_out), counts(&marlin_out));
    assert_eq!(core_counts.len(), 3);
    assert_eq!(core_counts, marlin_counts, "core:\n{core_out}\nmarlin:\n{marlin_out}");
}

#[test]
fn sim_on_the_controller_core_refuses_the_marlin_models_flags() {
    let profile = repo("examples/machines/gweave-ramps.toml");
    let out = gweave(&["sim", "-", "--machine", profile.to_str().unwrap(), "--plot", "t.png"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--plot is for the Marlin model"), "{stderr}");
}
