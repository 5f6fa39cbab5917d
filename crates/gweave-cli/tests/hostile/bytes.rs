//! Reading any bytes: a line of any length and any bytes in bounded memory, lines ended by LF,
//! CRLF or a lone CR, UTF-16 refused by name, a UTF-8 byte order mark read and kept, arcs of
//! any size planned without holding their chords.

use std::fs;
use std::io::Write;
use std::path::Path;

use crate::harness::*;

/// 20 MiB: enough to show memory that grows with the line (it cost 40 bytes a byte), small
/// enough for a debug build in CI. By hand, 1 GB runs under the same limit (docs/reliability.md).
const LONG: usize = 20 << 20;
const PEAK_MIB: f64 = 64.0;

fn write(dir: &Path, name: &str, bytes: &[u8]) {
    fs::write(dir.join(name), bytes).unwrap();
}

/// Compares two files a MiB at a time.
fn assert_same_bytes(a: &Path, b: &Path) {
    use std::io::Read;
    let (mut a, mut b) = (fs::File::open(a).unwrap(), fs::File::open(b).unwrap());
    let (mut x, mut y) = (vec![0; 1 << 20], vec![0; 1 << 20]);
    loop {
        let n = a.read(&mut x).unwrap();
        b.read_exact(&mut y[..n]).unwrap();
        assert!(x[..n] == y[..n], "the copy differs");
        if n == 0 {
            assert_eq!(b.read(&mut y).unwrap(), 0, "the copy is longer");
            return;
        }
    }
}

/// Every command on one long line, `bytes` repeated: strict commands stop with its length,
/// lenient ones skip or copy it, all in bounded memory.
fn a_long_line_is_handled_in_bounded_memory(unit: &[u8]) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Written in pieces: the peak memory measured for the child counts what this process held
    // when it started it.
    let mut file = std::io::BufWriter::new(fs::File::create(d.join("long.gcode")).unwrap());
    file.write_all(b"G28\nG1 X10 Y10 F600\n").unwrap();
    let piece: Vec<u8> = unit.iter().cycle().take(1 << 20).copied().collect();
    (0..LONG >> 20).for_each(|_| file.write_all(&piece).unwrap());
    file.write_all(b"\nG1 X20 Y20\n").unwrap();
    file.into_inner().unwrap().sync_all().unwrap();
    drop(piece);
    let refusal = format!("long.gcode:3:1: line of {LONG} bytes is longer than the limit of 262144");
    for args in [
        &["stats", "long.gcode"][..],
        &["cat", "long.gcode", "-o", "out.gcode"],
        &["mix", "long.gcode", "-o", "out.gcode", "--map", "T0=Cyan"],
        &["purge-shift", "long.gcode", "-o", "out.gcode", "--purge-mm", "2"],
        &["rotary", "wrap", "long.gcode", "-o", "out.gcode", "--mandrel-diameter", "30"],
        &["preview", "long.gcode", "-o", "out.png"],
    ] {
        let run = gweave(d, args).run();
        run.assert_refused(&refusal).assert_peak_under(PEAK_MIB);
        assert!(!d.join("out.gcode").exists(), "{args:?}");
    }
    let check = gweave(d, &["check", "long.gcode"]).run();
    check.assert_refused("").assert_peak_under(PEAK_MIB);
    let finding = format!("long.gcode:3:1: error: line of {LONG} bytes is longer than the limit of 262144");
    assert!(check.stdout_text().contains(&finding), "{}", check.stdout_text());
    for command in ["sim", "estimate"] {
        let run = gweave(d, &[command, "long.gcode"]).run();
        run.assert_ok().assert_peak_under(PEAK_MIB);
        let text = run.stdout_text();
        assert!(text.contains("malformed       1 lines read past (first: line 3"), "{command}: {text}");
    }
    let copy = gweave(d, &["cat", "long.gcode", "--lenient", "-o", "copy.gcode", "-q"]).run();
    copy.assert_ok().assert_peak_under(PEAK_MIB);
    assert_same_bytes(&d.join("long.gcode"), &d.join("copy.gcode"));
    assert_no_temp_left(d);
}

#[test]
fn a_line_of_zeros_is_read_in_bounded_memory() {
    a_long_line_is_handled_in_bounded_memory(b"\0");
}

#[test]
fn a_line_of_0xff_is_read_in_bounded_memory() {
    a_long_line_is_handled_in_bounded_memory(b"\xff");
}

#[test]
fn a_line_of_words_is_read_in_bounded_memory() {
    a_long_line_is_handled_in_bounded_memory(b"G1 X1 Y1 E1 ");
}

/// Regression: `G1 X10 Y10 E1\rG1 X500 Y10 E2\rM104 S0` read as one line: no warning, and
/// the `M104 S0` vanished.
#[test]
fn a_lone_cr_ends_a_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = b"M104 S200\rG1 X10 Y10 E1\rG1 X500 Y10 E2\rM104 S0";
    write(d, "cr.gcode", input);
    let check = gweave(d, &["check", "cr.gcode", "--bed", "220,220,250"]).run();
    check.assert_ok();
    let text = check.stdout_text() + &check.stderr;
    assert!(text.contains("cr.gcode:3:4: warning: move outside the bed: X=500.000 mm"), "{text}");
    assert!(text.contains("4 lines"), "{text}");
    let stats = gweave(d, &["stats", "cr.gcode", "--json"]).run();
    stats.assert_ok();
    assert!(stats.stdout_text().contains("\"lines\": 4"), "{}", stats.stdout_text());
    gweave(d, &["cat", "cr.gcode", "-o", "copy.gcode", "-q"]).run().assert_ok();
    assert_eq!(fs::read(d.join("copy.gcode")).unwrap(), input);
}

/// A CR-only file of many lines is many lines, everywhere, and round-trips.
#[test]
fn a_cr_only_file_reads_as_many_lines() {
    let (dir, input) = dir_with_fixture("cura/cura_torus.gcode", "lf.gcode");
    let d = dir.path();
    let lf = fs::read(&input).unwrap();
    let cr: Vec<u8> = lf.iter().map(|&b| if b == b'\n' { b'\r' } else { b }).collect();
    write(d, "cr.gcode", &cr);
    let stdout = |args: &[&str]| {
        let run = gweave(d, args).run();
        run.assert_ok();
        run.stdout_text()
    };
    for command in ["stats", "estimate"] {
        let (a, b) = (stdout(&[command, "lf.gcode", "--json"]), stdout(&[command, "cr.gcode", "--json"]));
        assert_eq!(a.replace("lf.gcode", "cr.gcode"), b, "{command}");
    }
    gweave(d, &["cat", "cr.gcode", "-o", "copy.gcode", "-q"]).run().assert_ok();
    assert!(fs::read(d.join("copy.gcode")).unwrap() == cr);
}

/// Regression: a UTF-16 file gave "unexpected byte" errors, or "0 planned blocks" and exit 0.
#[test]
fn a_utf16_file_is_refused_with_its_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = "M104 S200\r\nG28\r\nG1 X10 Y10 E1 F600\r\n";
    let le: Vec<u8> =
        [0xff, 0xfe].into_iter().chain(text.encode_utf16().flat_map(u16::to_le_bytes)).collect();
    let be: Vec<u8> = text.encode_utf16().flat_map(u16::to_be_bytes).collect();
    write(d, "le.gcode", &le);
    write(d, "be.gcode", &be);
    for (file, order) in [("le.gcode", "little-endian, with a byte order mark"), ("be.gcode", "big-endian")] {
        let message = format!("UTF-16 text ({order}): save the file as UTF-8 or ASCII");
        for command in ["stats", "check", "cat", "sim", "estimate"] {
            gweave(d, &[command, file, "-o", "out.gcode"][..if command == "cat" { 4 } else { 2 }])
                .run()
                .assert_refused(&message);
        }
    }
}

/// Regression: a UTF-8 byte order mark was "unexpected byte 0xef"; it is skipped, and kept by
/// copies.
#[test]
fn a_utf8_bom_is_skipped_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = b"\xef\xbb\xbfM104 S200\nG28\nG1 X10 Y10 E1 F600\n";
    write(d, "bom.gcode", input);
    let check = gweave(d, &["check", "bom.gcode"]).run();
    check.assert_ok();
    assert!(check.stdout_text().contains("0 errors, 0 warnings"), "{}", check.stdout_text());
    gweave(d, &["cat", "bom.gcode", "-o", "copy.gcode", "-q"]).run().assert_ok();
    assert_eq!(fs::read(d.join("copy.gcode")).unwrap(), input);
}

/// Regression: `G2 ... I10000000` made estimate and sim take 6.9 GB and 30 s: every chord was
/// pushed into one Vec.
#[test]
fn a_huge_arc_is_planned_without_a_vec_of_chords() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = "M104 S200\nG28\nG1 X0 Y0 F600\nG2 X0 Y0 I10000000 J0 E1\nG1 X10\nM104 S0\n";
    write(d, "arc.gcode", input.as_bytes());
    let limit = std::time::Duration::from_secs(20);
    // Both refuse the arc's centre, 10 km away: beyond any machine (the G2 row's range).
    let run = gweave(d, &["estimate", "arc.gcode"]).limit(limit).run();
    run.assert_ok().assert_peak_under(PEAK_MIB);
    let text = run.stdout_text();
    assert!(
        text.contains("refused         1 lines, skipped as the printer refuses them (first: line 4, G2 I = 10000000 is out of range: -10000 to 10000 mm"),
        "{text}"
    );
    let run = gweave(d, &["sim", "arc.gcode"]).limit(limit).run();
    run.assert_ok().assert_peak_under(PEAK_MIB);
    assert!(
        run.stdout_text().contains("line 4: refused: G2 I = 10000000 is out of range: -10000 to 10000 mm"),
        "{}",
        run.stdout_text()
    );
    // In inches the same words are in range (the ranges are on the words as written): a radius
    // of 254 m, 1.6 million chords of 1 mm, planned as 100 000 longer ones.
    let input = "M104 S200\nG28\nG20\nG1 X0 Y0 F600\nG2 X0 Y0 I10000 J0 E1\nG1 X10\nM104 S0\n";
    write(d, "arc-inches.gcode", input.as_bytes());
    let run = gweave(d, &["estimate", "arc-inches.gcode"]).limit(limit).run();
    run.assert_ok().assert_peak_under(PEAK_MIB);
    let text = run.stdout_text();
    assert!(
        text.contains(
            "huge arcs       1 of more than 100000 chords, planned with longer ones (first: line 5)"
        ),
        "{text}"
    );
}
