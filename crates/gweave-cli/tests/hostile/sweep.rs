//! Every G-code command against every kind of hostile input: whatever the bytes, each run ends
//! by itself (a result or a refusal with exit code 1), without a panic, within its time limit and
//! a fixed memory budget, leaving the input as it was and no temporary file behind.

use std::fs;
use std::path::Path;
use std::time::Duration;

use crate::harness::*;

/// Peak memory any command may use on these inputs, whatever their bytes (the budget in
/// docs/reliability.md).
const BUDGET_MIB: f64 = 64.0;

/// Megabytes of each garbage input: enough that memory growing with the line shows (the old
/// reader held about 40 bytes per byte of such a line), small enough for a debug build in CI.
const GARBAGE: usize = 8 << 20;

/// The hostile inputs, by name.
fn inputs() -> Vec<(&'static str, Vec<u8>)> {
    let fixture = fs::read(fixture_path("cura/cura_torus.gcode")).expect("fixture");
    let head = &fixture[..200_000];
    let mut utf16 = vec![0xFF, 0xFE];
    utf16.extend(head.iter().flat_map(|&b| [b, 0]));
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(head);
    let words = b"G1 X1 Y1 E1 ".repeat(GARBAGE / 12);
    let mut numbers = b"M104 S200\nM109 S200\nG28\nG92 E0\n".to_vec();
    for n in ["1e308", "-1e308", &"9".repeat(400), "nan", "inf", "-0", "0x10", "1e-320"] {
        numbers.extend(format!("G1 X{n} Y{n} E{n} F{n}\nG4 P{n}\nM104 S{n}\nG92 E{n}\n").bytes());
    }
    let arcs = b"M104 S200\nM109 S200\nG28\nG92 E0\nG1 X10 Y10 F3000\n\
                 G2 X10 Y0 I10000000 J0 E1 F1000\nG3 X0 Y0 R1e9 E2\nG2 X1 Y1 I1e-12 J0 E3\n"
        .to_vec();
    vec![
        ("zeros", vec![0; GARBAGE]),
        ("ff", vec![0xFF; GARBAGE]),
        ("hashes", vec![b'#'; GARBAGE]),
        ("one_line_of_words", words),
        ("cr_only", fixture.iter().map(|&b| if b == b'\n' { b'\r' } else { b }).collect()),
        ("utf16", utf16),
        ("bom", bom),
        ("huge_numbers", numbers),
        ("huge_arcs", arcs),
        ("empty", Vec::new()),
        ("newlines", vec![b'\n'; 100_000]),
    ]
}

/// Each command as a user would type it on `in.gcode`.
const COMMANDS: &[&[&str]] = &[
    &["stats", "in.gcode"],
    &["check", "in.gcode"],
    &["cat", "in.gcode", "-o", "out.gcode"],
    &["cat", "in.gcode", "-o", "out.gcode", "--lenient"],
    &["sim", "in.gcode"],
    &["estimate", "in.gcode"],
    &["mix", "in.gcode", "--at-layer", "0=Orange", "-o", "out.gcode"],
    &["purge-shift", "in.gcode", "--purge-mm", "2", "-o", "out.gcode"],
    &["rotary", "wrap", "in.gcode", "--mandrel-diameter", "30", "-o", "out.gcode"],
    &["preview", "in.gcode", "-o", "out.png"],
    &["preview", "in.gcode", "-o", "out.html", "--view", "iso"],
];

/// Runs every command on `bytes`; returns what went wrong, one line per failed run. (`check`
/// reports on standard output, the others on standard error.)
fn sweep(name: &str, bytes: &[u8]) -> Vec<String> {
    let mut failures = Vec::new();
    for args in COMMANDS {
        let dir = tempfile::tempdir().expect("temp dir");
        let input = dir.path().join("in.gcode");
        fs::write(&input, bytes).expect("input written");
        let outcome = gweave(dir.path(), args).limit(Duration::from_secs(30)).run();
        let what = format!("{name}: gweave {}", args.join(" "));
        let first_error = outcome.stderr.lines().next().unwrap_or("").to_string();
        if outcome.hung {
            failures.push(format!("{what}: hung (killed after {:?})", outcome.elapsed));
        } else if outcome.signal.is_some() || outcome.stderr.contains("panicked") {
            failures.push(format!("{what}: crashed (signal {:?}): {first_error}", outcome.signal));
        } else if !matches!(outcome.code, Some(0 | 1)) {
            failures.push(format!("{what}: exit {:?}: {first_error}", outcome.code));
        } else if outcome.code == Some(1) && outcome.stderr.trim().is_empty() && outcome.stdout.is_empty() {
            failures.push(format!("{what}: refused without a word"));
        }
        if outcome.peak_mib >= BUDGET_MIB {
            failures.push(format!("{what}: peak memory {:.0} MiB", outcome.peak_mib));
        }
        if fs::read(&input).ok().as_deref() != Some(bytes) {
            failures.push(format!("{what}: input changed"));
        }
        if snapshot(dir.path())
            .keys()
            .any(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(".gweave-")))
        {
            failures.push(format!("{what}: temporary file left"));
        }
        if outcome.code == Some(1) && Path::new(&dir.path().join("out.gcode")).exists() {
            failures.push(format!("{what}: partial output left"));
        }
    }
    failures
}

#[test]
fn every_command_survives_every_hostile_input() {
    let failures: Vec<String> = inputs().iter().flat_map(|(name, bytes)| sweep(name, bytes)).collect();
    assert!(failures.is_empty(), "{} failed runs:\n{}", failures.len(), failures.join("\n"));
}
