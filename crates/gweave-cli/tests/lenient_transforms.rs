//! `--lenient` on the transforms (issue 21: "wherever a command stops at bad input"): `mix`,
//! `purge-shift` and `rotary wrap` stop at a malformed line with file:line:column and write
//! nothing; with `--lenient` they copy the line through as written and count it, as `stats`
//! and `preview` do.

use std::path::Path;
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Two layers, the second one with a malformed number on line 7.
const BAD: &str = "M104 S200\nM83\n;LAYER_CHANGE\nG1 Z0.2 F100\nG1 X10 Y5 E1 F1800\n;LAYER_CHANGE\n\
    G1 X1..2\nG1 Z0.4 F100\nG1 X0 E2\n";
const BAD_LINE: &str = "\nG1 X1..2\n";

/// Each transform with the options it needs beside the input and the output.
fn transforms() -> Vec<(&'static str, Vec<&'static str>)> {
    vec![
        ("mix", vec!["mix", "--at-layer", "0=Red", "--at-layer", "1=Blue"]),
        ("purge-shift", vec!["purge-shift", "--purge-mm", "1"]),
        ("rotary wrap", vec!["rotary", "wrap", "--mandrel-diameter", "30"]),
    ]
}

fn run(name: &str, options: &[&str], input: &Path, output: &Path, extra: &[&str]) -> Output {
    let (input, output) = (input.to_str().unwrap(), output.to_str().unwrap());
    let mut args = options.to_vec();
    args.extend([input, "-o", output]);
    args.extend(extra);
    let out = gweave(&args);
    assert!(out.status.code().is_some(), "{name}: killed");
    out
}

#[test]
fn a_strict_transform_names_the_bad_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("bad.gcode");
    std::fs::write(&input, BAD).unwrap();
    for (name, options) in transforms() {
        let output = dir.path().join("out.gcode");
        let out = run(name, &options, &input, &output, &[]);
        assert_eq!(out.status.code(), Some(1), "{name}: {}", text(&out.stderr));
        let said = text(&out.stderr);
        assert!(said.contains("bad.gcode:7:5: malformed number after 'X'"), "{name}: {said}");
        assert!(!output.exists(), "{name} wrote a partial output");
    }
}

#[test]
fn a_lenient_transform_copies_the_bad_line_through_and_counts_it() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("bad.gcode");
    std::fs::write(&input, BAD).unwrap();
    for (name, options) in transforms() {
        let output = dir.path().join(format!("{}.gcode", name.replace(' ', "-")));
        let out = run(name, &options, &input, &output, &["--lenient", "--json"]);
        assert!(out.status.success(), "{name}: {}", text(&out.stderr));
        let written = std::fs::read_to_string(&output).unwrap();
        assert!(written.contains(BAD_LINE), "{name}: the bad line is not in\n{written}");
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let count = (j["malformed_lines"].as_u64(), j["first_malformed_line"].as_u64());
        assert_eq!(count, (Some(1), Some(7)), "{name}: {j}");
        // The human summary says it too.
        let out = run(name, &options, &input, &output, &["--lenient"]);
        let said = text(&out.stdout);
        assert!(
            said.contains("malformed       1 lines read past (first: line 7; see gweave check)"),
            "{name}: {said}"
        );
    }
}

/// A strict run's report stays the document it was: no count of lines it never reads past.
#[test]
fn a_strict_report_has_no_malformed_count() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("good.gcode");
    std::fs::write(&input, BAD.replace("G1 X1..2\n", "G1 X1.2\n")).unwrap();
    for (name, options) in transforms() {
        let output = dir.path().join("out.gcode");
        let out = run(name, &options, &input, &output, &["--json"]);
        assert!(out.status.success(), "{name}: {}", text(&out.stderr));
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(j.get("malformed_lines").is_none(), "{name}: {j}");
    }
}

/// Regression (issue 40): the engine's refusals named the CLI's flags to Python users too; they
/// carry the options' identity now, and the CLI names the flags (Python the keywords:
/// `crates/gweave-py/tests/test_options.py`).
#[test]
fn a_refusal_names_the_options_by_their_flags() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("t1.gcode");
    std::fs::write(&input, "M83\n;LAYER_CHANGE\nG1 X1 E1\nT1\nG1 X2 E1\n").unwrap();
    let output = dir.path().join("out.gcode");
    let said = |options: &[&str]| {
        let out = run(options[0], options, &input, &output, &["-q"]);
        assert!(!out.status.success() && !output.exists());
        text(&out.stderr)
    };
    assert_eq!(
        said(&["mix", "--map", "T0=Red"]),
        format!(
            "gweave: error: {}:4: the file selects T1, which has no mix: add --map T1=<mix>\n",
            input.display()
        )
    );
    assert_eq!(
        said(&["mix"]),
        "gweave: error: mix profile: nothing to do: give a schedule (--at-layer, --at-z, [[schedule]]), \
         a gradient (--gradient, [[gradient]]) or a tool map (--map, [map])\n"
    );
    assert_eq!(
        said(&["purge-shift"]),
        "gweave: error: no purge amount: give --purge-mm or --purge-mm3, or in the config purge_mm, \
         purge_mm3, colours, pairs or a washout tolerance\n"
    );
}
