//! Errors cut to a readable length and naming what the user typed: a TOML error echoed the whole
//! offending line (a 50 MB value printed 50 MB), `rotary wrap` on `F0` spoke of a feed rate never
//! set, a gzip with bytes after its end was an "invalid gzip header", `check` said nothing of a
//! line that `sim` calls an unknown command, `--in-place` on a symlink replaced the link with a
//! file, and `serve --log` stopped logging on a full disk without a word.

use std::fs;
use std::io::Write;
use std::path::Path;

use flate2::write::GzEncoder;
use flate2::Compression;
use gweave_sim::test_support::{connect, lines_through, lines_until_ok};

use crate::harness::*;
use crate::outputs::Tmpfs;
use crate::serve::Server;

const MOVES: &str = "M104 S200\nM109 S200\nG28\nG92 E0\nG1 X10 Y10 Z0.2 F3000\nG1 X20 Y10 E1 F1200\n";

/// Regression: a TOML error quoted the whole offending line, so a long value printed itself
/// whole to standard error (50 MB for a 50 MB value). The quoted line is cut to a window around
/// the error's column, a wrong-typed value to its first thousand characters.
#[test]
fn a_toml_error_on_a_long_line_is_cut_to_a_readable_length() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("in.gcode"), MOVES).unwrap();
    let long = "x".repeat(200_000);
    let cases = [
        // A string never closed: the error is at the end of the line.
        (format!("name = \"{long}\n"), "p.toml: machine profile: TOML parse error at line 1, column"),
        // A value of the wrong type, quoted in the message's last line.
        (format!("[bed]\nx_mm = \"{long}\"\n"), "invalid type: string \"xxxxxxxx"),
    ];
    for (text, message) in cases {
        fs::write(dir.path().join("p.toml"), text).unwrap();
        let out = gweave(dir.path(), &["sim", "in.gcode", "--machine", "p.toml"]).run();
        out.assert_refused(message);
        assert!(out.stderr.len() < 2_500, "a message of {} bytes", out.stderr.len());
        assert!(
            out.stderr.contains("...xxx") || out.stderr.contains("xxx..."),
            "cut, and marked: {}",
            out.stderr
        );
    }
}

/// Regression: `rotary wrap` on a move at `F0` said "a move before any feed rate was set"; it
/// names the F0 now, and keeps the old words for a move with no F before it.
#[test]
fn rotary_wrap_names_an_f0_feed() {
    let dir = tempfile::tempdir().unwrap();
    let wrap = |gcode: &str| {
        fs::write(dir.path().join("in.gcode"), gcode).unwrap();
        gweave(dir.path(), &["rotary", "wrap", "in.gcode", "--mandrel-diameter", "30", "-o", "out.gcode"])
            .run()
    };
    wrap("G1 X1 F600\nG1 X2 E1 F0\n").assert_refused(
        "in.gcode:2: invalid rotary setting `F`: a move at F0: set a feed rate above 0 before it",
    );
    wrap("G1 F0\nG1 X2 E1\n").assert_refused("a move at F0");
    wrap("G1 X2 E1\n").assert_refused("a move before any feed rate was set");
    assert!(!dir.path().join("out.gcode").exists());
}

/// Regression: bytes after a gzip file's end were "invalid gzip header", sending the user to the
/// start of the file. They are trailing data now, and no output is left.
#[test]
fn trailing_bytes_after_a_gzip_stream_are_called_so() {
    let dir = tempfile::tempdir().unwrap();
    let mut z = GzEncoder::new(Vec::new(), Compression::default());
    z.write_all(MOVES.as_bytes()).unwrap();
    let mut file = z.finish().unwrap();
    file.extend_from_slice(b"garbage appended by a download\n");
    fs::write(dir.path().join("in.gcode.gz"), file).unwrap();
    for args in [&["stats", "in.gcode.gz"][..], &["cat", "in.gcode.gz", "-o", "out.gcode"]] {
        let out = gweave(dir.path(), args).run();
        out.assert_refused("in.gcode.gz: trailing data after the gzip stream");
        assert!(!out.stderr.contains("invalid gzip header"), "{}", out.stderr);
    }
    assert!(!dir.path().join("out.gcode").exists());
    assert_no_temp_left(dir.path());
}

/// Regression: `check` reported nothing on a line of garbage words that `sim` calls an unknown
/// command (a name, as Klipper macros are, on a file for Marlin). Both say so now; a file for
/// Klipper keeps its macros.
#[test]
fn check_reports_the_unknown_commands_sim_reports() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("in.gcode"), format!("{MOVES}hello world\nQWERTY\n")).unwrap();
    let check = gweave(dir.path(), &["check", "in.gcode"]).run();
    let said = check.stdout_text();
    assert!(said.contains("in.gcode:7:1: warning: unknown command hello"), "{said}");
    assert!(said.contains("in.gcode:8:1: warning: unknown command QWERTY"), "{said}");
    let sim = gweave(dir.path(), &["sim", "in.gcode"]).run();
    assert!(sim.stderr.contains("QWERTY x1, hello x1") || sim.stdout_text().contains("QWERTY x1, hello x1"));
    fs::write(dir.path().join("k.gcode"), format!("; gcode_flavor = klipper\n{MOVES}PRINT_START\n")).unwrap();
    let said = gweave(dir.path(), &["check", "k.gcode"]).run().stdout_text();
    assert!(!said.contains("unknown command"), "{said}");
}

/// Regression: `--in-place` on a symbolic link replaced the link with a file and left its
/// target as it was. The target is replaced and the link kept, as an editor saving does.
#[test]
fn in_place_on_a_symlink_replaces_the_target_and_keeps_the_link() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::create_dir(d.join("real")).unwrap();
    fs::write(d.join("real/part.gcode"), format!("{MOVES}T1\nG1 X30 E2\n")).unwrap();
    std::os::unix::fs::symlink("real/part.gcode", d.join("link.gcode")).unwrap();
    gweave(d, &["purge-shift", "link.gcode", "--in-place", "--purge-mm", "1", "--no-backup"])
        .run()
        .assert_ok();
    assert!(fs::symlink_metadata(d.join("link.gcode")).unwrap().file_type().is_symlink(), "the link stays");
    assert_eq!(fs::read_link(d.join("link.gcode")).unwrap(), Path::new("real/part.gcode"));
    let target = fs::read_to_string(d.join("real/part.gcode")).unwrap();
    assert!(target.contains("purge-shift"), "the target holds the new text:\n{target}");
    assert_no_temp_left(d);
}

/// Regression: `serve --log` on a full disk stopped logging without a word. It says so on
/// standard error, once, and the printer goes on answering.
#[test]
fn serve_says_when_its_log_cannot_be_written() {
    let Some(fs) = Tmpfs::mount("16k") else { return };
    let dir = tempfile::tempdir().unwrap();
    let log = fs.0.path().join("session.log");
    let log_arg = log.display().to_string();
    let (server, addr) = Server::tcp(dir.path(), &["--log", &log_arg]);
    let (mut host, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    // Each M114 logs three lines of about 40 bytes: a thousand fill 16 KiB several times over.
    for _ in 0..10 {
        host.write_all("M114\n".repeat(100).as_bytes()).unwrap();
        lines_until_ok(&mut reader, 100);
    }
    host.write_all(b"M115\n").unwrap();
    let answer = lines_through(&mut reader, "ok");
    assert!(answer.iter().any(|l| l.starts_with("FIRMWARE_NAME")), "the printer goes on: {answer:?}");
    drop((host, reader));
    let outcome = server.stop();
    outcome.assert_ok();
    let warning = format!("gweave serve: --log {log_arg}: No space left on device");
    assert_eq!(outcome.stderr.matches(&warning).count(), 1, "{}", outcome.stderr);
    assert!(outcome.stderr.contains("the log stops here, the printer goes on"), "{}", outcome.stderr);
}

/// A new user's trial: a strict run stopped at an unreadable line (`unexpected byte 0xa0`, a
/// 50 MB line) without a word of `--lenient`, which reads past it. The error says the way
/// past; an error of another kind does not.
#[test]
fn a_line_that_cannot_be_read_points_to_lenient() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("in.gcode"), b"G1 X10\xa0Y10\n").unwrap();
    let out = gweave(dir.path(), &["cat", "in.gcode", "-o", "out.gcode"]).run();
    out.assert_refused("in.gcode:1:7: unexpected byte 0xa0");
    assert!(
        out.stderr.ends_with("  hint: --lenient reads past such lines (a transform copies them unchanged)\n"),
        "{}",
        out.stderr
    );
    gweave(dir.path(), &["cat", "in.gcode", "-o", "out.gcode", "--lenient"]).run().assert_ok();
    assert_eq!(fs::read(dir.path().join("out.gcode")).unwrap(), b"G1 X10\xa0Y10\n");
    let missing = gweave(dir.path(), &["cat", "nowhere.gcode", "-o", "o2.gcode"]).run();
    assert!(!missing.stderr.contains("hint"), "{}", missing.stderr);
}
