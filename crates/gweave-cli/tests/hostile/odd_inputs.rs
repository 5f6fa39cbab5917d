//! Odd inputs that read as something else: a file cut mid-word, a number in exponent notation,
//! a NUL inside a number. Each is named where it is, and no command takes it silently.

use std::fs;

use crate::harness::*;

/// A print cut short on its last line, mid-word and without a line ending.
const TRUNCATED: &str = "M104 S200\nM109 S200\nG28\nG1 X10 Y10 F3000\nG1 X113.115 Y";
const TRUNCATION: &str = "cut.gcode:5:13: the file looks truncated (its last line is malformed and has no \
                          line ending): 'Y' has no number";

/// Regression: a text file whose last line is cut mid-word passed every command but `check`
/// with exit 0. Strict commands now stop at it and write nothing; `check` fails; lenient ones
/// copy it and count it; a good last line without a line ending stays fine.
#[test]
fn truncated_file_passes_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("cut.gcode"), TRUNCATED).unwrap();
    for args in [
        &["stats", "cut.gcode"][..],
        &["cat", "cut.gcode", "-o", "out.gcode"],
        &["mix", "cut.gcode", "-o", "out.gcode", "--map", "T0=Cyan"],
        &["purge-shift", "cut.gcode", "-o", "out.gcode", "--purge-mm", "2"],
        &["rotary", "wrap", "cut.gcode", "-o", "out.gcode", "--mandrel-diameter", "30"],
    ] {
        gweave(d, args).run().assert_refused(TRUNCATION);
        assert!(!d.join("out.gcode").exists(), "{args:?} wrote a partial output");
    }
    let check = gweave(d, &["check", "cut.gcode"]).run();
    check.assert_refused("");
    let said = check.stdout_text();
    assert!(said.contains(&TRUNCATION.replacen(": the", ": error: the", 1)), "{said}");
    assert!(said.contains("5 lines, 1 errors, 0 warnings"), "{said}");
    let copy = gweave(d, &["cat", "cut.gcode", "--lenient", "-o", "copy.gcode"]).run();
    copy.assert_ok();
    assert!(copy.stdout_text().contains("malformed       1 (copied as written; the first at line 5)"));
    assert_eq!(fs::read(d.join("copy.gcode")).unwrap(), TRUNCATED.as_bytes());
    // Cut after a whole word: nothing to see, as in files that end without a line ending.
    fs::write(d.join("end.gcode"), &TRUNCATED[..TRUNCATED.len() - 2]).unwrap();
    gweave(d, &["check", "end.gcode"]).run().assert_ok();
    gweave(d, &["stats", "end.gcode"]).run().assert_ok();
    assert_no_temp_left(d);
}

/// Regression (a new user's trial): a text file cut mid-number (`G1 X112.194 Y106.138 E1` of
/// `E17.55707`, no final newline) reads as a whole line, so `check` passed it silently and
/// `purge-shift` appended its footer to it. Its slicer always ends its files with `;
/// prusaslicer_config = end`: without a line ending and without that line, `check` warns where
/// its text stops, the transforms refuse to finish it and write nothing, and `--lenient`
/// writes it.
#[test]
fn truncated_text_without_a_footer_passes_check() {
    let (dir, _) = dir_with_fixture("prusaslicer/pr_cone_2tool.gcode", "whole.gcode");
    let d = dir.path();
    let text = fs::read_to_string(d.join("whole.gcode")).unwrap();
    let cut_at = text.find("G1 X112.194 Y106.138 E17.55707").unwrap() + "G1 X112.194 Y106.138 E1".len();
    fs::write(d.join("cut.gcode"), &text[..cut_at]).unwrap();
    let line = text[..cut_at].lines().count();
    assert_eq!(line, 387);
    let message = "the file looks truncated: its last line has no line ending, and the file lacks the line \
                   PrusaSlicer ends its files with ('; prusaslicer_config = end')";
    let check = gweave(d, &["check", "cut.gcode"]).run();
    check.assert_ok();
    let said = check.stdout_text();
    assert!(said.contains(&format!("cut.gcode:387:24: warning: {message}")), "{said}");
    assert!(said.contains("387 lines, 0 errors, 1 warnings"), "{said}");
    gweave(d, &["check", "--strict", "cut.gcode"]).run().assert_refused("");
    for args in [
        &["purge-shift", "cut.gcode", "-o", "out.gcode", "--purge-mm", "2"][..],
        &["mix", "cut.gcode", "-o", "out.gcode", "--map", "T0=Cyan", "--map", "T1=Red"],
        &["rotary", "wrap", "cut.gcode", "-o", "out.gcode", "--mandrel-diameter", "30"],
    ] {
        gweave(d, args)
            .run()
            .assert_refused(&format!("cut.gcode:387:24: {message}; the transform would write"));
        assert!(!d.join("out.gcode").exists(), "{args:?} wrote an output");
    }
    // `stats` and `estimate` count and time it to its cut, as a printer runs it, and say so.
    for args in [&["stats", "cut.gcode"][..], &["estimate", "cut.gcode"]] {
        let run = gweave(d, args).run();
        run.assert_ok();
        assert!(
            run.stdout_text().contains(&format!("  warning: {message}\n")),
            "{args:?}: {}",
            run.stdout_text()
        );
    }
    let lenient =
        gweave(d, &["purge-shift", "cut.gcode", "-o", "out.gcode", "--purge-mm", "2", "--lenient", "-q"]);
    lenient.run().assert_ok();
    assert!(fs::read_to_string(d.join("out.gcode")).unwrap().contains("G1 X112.194 Y106.138 E1\n"));
    // The whole file, and the cut one with its line ending, pass as before.
    gweave(d, &["check", "--strict", "whole.gcode"]).run().assert_ok();
    fs::write(d.join("ended.gcode"), format!("{}\n", &text[..cut_at])).unwrap();
    let ended = gweave(d, &["check", "ended.gcode"]).run();
    assert!(ended.stdout_text().contains("387 lines, 0 errors, 0 warnings"), "{}", ended.stdout_text());
    assert_no_temp_left(d);
}

/// Regression: `G1 F1e300` was read as `F1` and `E300`, a 274 mm extrusion, and `check` said
/// nothing. It is still read so (Marlin and Klipper do), and it is an error at its column.
#[test]
fn exponent_notation_extrudes_300_mm() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("exp.gcode"), "M104 S200\nG28\nM82\nG1 X10 Y10 F3000\nG1 F1e300\nG1 X20 E1\n").unwrap();
    let check = gweave(d, &["check", "exp.gcode"]).run();
    check.assert_refused("");
    let said = check.stdout_text();
    assert!(
        said.contains("exp.gcode:5:4: error: 'F1e300' is exponent notation, which G-code does not have: read as F1 and E300"),
        "{said}"
    );
    gweave(d, &["cat", "exp.gcode", "-o", "out.gcode"]).run().assert_refused("exp.gcode:5:4: 'F1e300'");
    assert!(!d.join("out.gcode").exists());
    // Read as firmware reads it: the 300 mm are counted where they are fed.
    let stats = gweave(d, &["stats", "exp.gcode", "--lenient", "--json"]).run();
    stats.assert_ok();
    let json: serde_json::Value = serde_json::from_slice(&stats.stdout).unwrap();
    assert_eq!(json["filament"][0]["extruded_mm"], 300.0, "{json}");
    assert_eq!(json["malformed_lines"], 1, "{json}");
}

/// Regression: `check` counted one NUL byte in a number as 7 errors (the NUL, then each byte of
/// the digits after it).
#[test]
fn check_counts_one_nul_as_7_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("nul.gcode"), b"M104 S200\nG28\nG1 X1\x0042.303 Y2 F600\n").unwrap();
    let check = gweave(d, &["check", "nul.gcode"]).run();
    check.assert_refused("");
    let said = check.stdout_text();
    assert!(said.contains("nul.gcode:3:6: error: unexpected byte 0x00\n"), "{said}");
    assert!(said.contains("3 lines, 1 errors, 0 warnings"), "{said}");
}
