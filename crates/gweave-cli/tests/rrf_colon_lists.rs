//! Regression (rrf_colon_lists_are_malformed): `gweave mix` on a RepRapFirmware file writes mixes
//! as `M567 P<tool> E<a>:<b>:<c>:<d>`, and `check`, `stats` and a strict `purge-shift` refused
//! gweave's own output at the first colon. They read it now, and purge-shift keeps the lists.

use std::path::Path;
use std::process::Command;

fn gweave(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

#[test]
fn rrf_colon_lists_are_read_by_every_command() {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/prusaslicer/pr_sphere_rrf_fwretract.gcode");
    let dir = tempfile::tempdir().unwrap();
    let mixed = dir.path().join("mixed.gcode");
    let shifted = dir.path().join("shifted.gcode");
    let (fixture, mixed_s, shifted_s) =
        (fixture.to_str().unwrap(), mixed.to_str().unwrap(), shifted.to_str().unwrap());
    let out =
        gweave(&["mix", fixture, "--at-layer", "0=Orange", "--at-layer", "5=Blue", "-o", mixed_s, "-q"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&mixed).unwrap();
    let lists: Vec<&str> = text.lines().filter(|l| l.starts_with("M567 ")).collect();
    assert!(lists.len() >= 2 && lists.iter().all(|l| l.matches(':').count() == 3), "{lists:?}");

    for args in [vec!["stats", mixed_s, "-q"], vec!["check", mixed_s, "--json"]] {
        let out = gweave(&args);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(!stdout.contains("unexpected character"), "{args:?}: {stdout}");
        assert!(out.status.success(), "{args:?}: {}{stdout}", String::from_utf8_lossy(&out.stderr));
    }
    let out = gweave(&["purge-shift", mixed_s, "--purge-mm", "5", "-o", shifted_s, "-q"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let shifted_text = std::fs::read_to_string(&shifted).unwrap();
    for list in &lists {
        assert!(shifted_text.lines().any(|l| l == *list), "{list} lost by purge-shift");
    }
}
