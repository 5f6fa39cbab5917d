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
