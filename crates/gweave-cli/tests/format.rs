//! `--format` (issue 21): a transform's G-code on standard output stored as gzip or binary
//! G-code, through a real shell pipe, the same bytes as to a file so named; a file whose name
//! disagrees with `--format` is refused.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gweave() -> &'static str {
    env!("CARGO_BIN_EXE_gweave")
}

fn run(args: &[&str]) -> Output {
    Command::new(gweave()).args(args).output().unwrap()
}

fn fixture(name: &str) -> String {
    let p: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name);
    p.to_str().unwrap().to_owned()
}

/// `sh -c` with the binary as `$G` and the fixture as `$F`.
fn shell(script: &str) -> Output {
    let out = Command::new("sh")
        .args(["-c", script])
        .env("G", gweave())
        .env("F", fixture("prusaslicer/pr_torus_pva.gcode"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{script}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

#[test]
fn a_pipe_carries_binary_gcode_as_a_named_file_holds_it() {
    let dir = tempfile::tempdir().unwrap();
    let named = dir.path().join("named.bgcode");
    let f = fixture("prusaslicer/pr_torus_pva.gcode");
    let out = run(&["purge-shift", &f, "--purge", "5", "-o", named.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let piped = shell(r#"cat "$F" | "$G" purge-shift - --purge 5 -o - --format bgcode | cat"#).stdout;
    assert_eq!(&piped[..4], b"GCDE");
    assert!(piped == std::fs::read(&named).unwrap(), "the pipe's bytes differ from the named file's");
    // And back: the binary G-code read from a pipe is the text the named file holds.
    let back = shell(r#""$G" cat "$F" -o - --format bgcode | "$G" cat - -o -"#).stdout;
    let text = dir.path().join("t.bgcode");
    assert!(run(&["cat", &f, "-o", text.to_str().unwrap()]).status.success());
    assert!(back == run(&["cat", text.to_str().unwrap(), "-o", "-"]).stdout);
}

#[test]
fn a_pipe_carries_gzip() {
    let zipped = shell(r#""$G" cat "$F" -o - --format gz | gzip -dc"#).stdout;
    let plain = run(&["cat", &fixture("prusaslicer/pr_torus_pva.gcode"), "-o", "-"]).stdout;
    assert!(zipped == plain);
    // Without --format, standard output is text.
    assert_eq!(&plain[..2], b"; ");
}

#[test]
fn a_file_named_otherwise_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("x.gcode");
    let out = run(&[
        "cat",
        &fixture("prusaslicer/pr_torus_pva.gcode"),
        "-o",
        out_path.to_str().unwrap(),
        "--format",
        "bgcode",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--format bgcode but -o") && err.contains("is named for text"), "{err}");
    assert!(!out_path.exists());
}

/// Regression (merge of the scratch file's shown name with `Target::Stdout(Container)`): a
/// transform that finishes through a scratch file wrote `x.gcode.gz` compressed twice (the
/// scratch took the container of the name it stands for). One gzip stream, the text of `-o -`.
#[test]
fn gz_output_is_compressed_once() {
    let dir = tempfile::tempdir().unwrap();
    let zipped = dir.path().join("shifted.gcode.gz");
    let f = fixture("prusaslicer/pr_torus_pva.gcode");
    let out = run(&["purge-shift", &f, "--purge", "5", "-o", zipped.to_str().unwrap(), "-q"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let script = format!("gzip -dc '{}'", zipped.display());
    let unzipped = Command::new("sh").args(["-c", &script]).output().unwrap().stdout;
    let text = run(&["purge-shift", &f, "--purge", "5", "-o", "-"]).stdout;
    assert!(text.starts_with(b"; gweave"));
    assert!(unzipped == text, "the .gz holds other bytes than the text output");
}
