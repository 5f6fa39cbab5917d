//! Standard streams, gzip and Prusa binary G-code: `-` reads standard input and `-o -` writes
//! only the output to standard output, through a real shell pipeline; `.gz` and `.bgcode` round
//! trip; a damaged binary block (bad CRC, truncated, a size its data does not decode to) is
//! refused naming the file and the block, with nothing written.

use std::fs;
use std::path::Path;
use std::process::Command;

use crate::bgcode_bombs::refused_by_every_reader;
use crate::harness::*;

/// `sh -c SCRIPT` in `dir` with the binary as `$G`: (exit code, stdout, stderr).
pub(crate) fn shell(dir: &Path, script: &str) -> (i32, Vec<u8>, String) {
    let out = Command::new("sh")
        .arg("-c")
        .arg(script)
        .current_dir(dir)
        .env("G", env!("CARGO_BIN_EXE_gweave"))
        .output()
        .expect("sh runs");
    (out.status.code().unwrap_or(-1), out.stdout, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The "done when": `purge-shift - -o - < a.gcode > b.gcode` equals the file-to-file
/// run, byte for byte, and standard output holds the G-code only (the summary goes to stderr).
#[test]
fn purge_shift_through_a_pipe_equals_the_file_run() {
    let (dir, _) = dir_with_fixture("prusaslicer/pr_bunny_3tool_rel.gcode", "a.gcode");
    let (code, _, err) = shell(
        dir.path(),
        "\"$G\" purge-shift a.gcode -o file.gcode --purge 5 && \
         \"$G\" purge-shift - -o - --purge 5 < a.gcode > pipe.gcode",
    );
    assert_eq!(code, 0, "{err}");
    let (file, pipe) =
        (fs::read(dir.path().join("file.gcode")).unwrap(), fs::read(dir.path().join("pipe.gcode")).unwrap());
    assert!(file.len() > 1_000_000 && file == pipe, "{} vs {} bytes", file.len(), pipe.len());
    assert!(err.contains("changes"), "the summary goes to standard error: {err}");
    // Through `cat |` too (a pipe, not a redirected file), and a flavour at the end still found.
    let (code, out, err) = shell(dir.path(), "cat a.gcode | \"$G\" purge-shift - -o - --purge 5");
    assert_eq!(code, 0, "{err}");
    assert!(out == file);
    assert_no_temp_left(dir.path());
}

/// `stats -` equals `stats FILE`; `cat - -o -` is the identity through a pipe.
#[test]
fn stats_and_cat_read_standard_input() {
    let (dir, _) = dir_with_fixture("cura/cura_torus.gcode", "a.gcode");
    let (_, file, _) = shell(dir.path(), "\"$G\" stats a.gcode --json");
    let (code, piped, err) = shell(dir.path(), "cat a.gcode | \"$G\" stats - --json");
    assert_eq!(code, 0, "{err}");
    assert!(!file.is_empty() && file == piped);
    let (code, out, err) = shell(dir.path(), "cat a.gcode | \"$G\" cat - -o -");
    assert_eq!((code, err.as_str()), (0, ""));
    assert!(out == fs::read(dir.path().join("a.gcode")).unwrap());
}

/// `--json` with `-o -` would put JSON after the G-code: refused before anything is written.
#[test]
fn json_with_standard_output_is_refused() {
    let (dir, _) = dir_with_fixture("cura/cura_torus.gcode", "a.gcode");
    for args in [
        &["cat", "a.gcode", "-o", "-", "--json"][..],
        &["purge-shift", "a.gcode", "-o", "-", "--json", "--purge", "5"],
        &["preview", "a.gcode", "-o", "-", "--format", "png", "--json"],
    ] {
        let out = gweave(dir.path(), args).run();
        out.assert_refused("--json and -o - would both write to standard output");
        assert!(out.stdout.is_empty(), "{args:?} wrote to standard output");
    }
    gweave(dir.path(), &["purge-shift", "-", "--in-place", "--purge", "5"])
        .run()
        .assert_refused("--in-place needs a file to replace, not standard input (-)");
}

/// `preview -o - --format png` writes the PNG alone on standard output.
#[test]
fn preview_writes_a_picture_to_standard_output() {
    let (dir, _) = dir_with_fixture("cura/cura_torus.gcode", "a.gcode");
    let (code, out, err) = shell(dir.path(), "cat a.gcode | \"$G\" preview - -o - --format png --size 64x48");
    assert_eq!(code, 0, "{err}");
    assert_eq!(&out[..8], b"\x89PNG\r\n\x1a\n");
    assert!(err.contains("64x48"), "summary on standard error: {err}");
    gweave(dir.path(), &["preview", "a.gcode", "-o", "-"]).run().assert_refused("-o - needs --format");
}

/// `.gz` by name on output, by magic bytes on input: gzip's own tool agrees, and every
/// command reads it as the text (stats equal).
#[test]
fn gzip_round_trips() {
    let (dir, _) = dir_with_fixture("prusaslicer/pr_torus_pva.gcode", "a.gcode");
    let (code, _, err) = shell(
        dir.path(),
        "\"$G\" cat a.gcode -o a.gcode.gz && gzip -dc a.gcode.gz > back.gcode && cp a.gcode.gz renamed.bin \
         && \"$G\" stats a.gcode --json > t.json && \"$G\" stats renamed.bin --json > z.json",
    );
    assert_eq!(code, 0, "{err}");
    let read = |n: &str| fs::read(dir.path().join(n)).unwrap();
    assert!(read("back.gcode") == read("a.gcode"));
    assert!(read("a.gcode.gz").len() < read("a.gcode").len() / 3);
    assert_eq!(String::from_utf8(read("t.json")).unwrap(), String::from_utf8(read("z.json")).unwrap());
}

/// gweave's binary G-code comes back as its text (empty lines aside, which the format does not
/// keep), and a transform from binary to binary keeps the metadata.
#[test]
fn bgcode_round_trips() {
    let (dir, _) = dir_with_fixture("prusaslicer/pr_torus_pva.gcode", "a.gcode");
    let (code, _, err) = shell(
        dir.path(),
        "\"$G\" cat a.gcode -o a.bgcode && \"$G\" cat a.bgcode -o back.gcode \
         && \"$G\" purge-shift a.bgcode -o b.bgcode --purge 5 && \"$G\" cat b.bgcode -o b.gcode",
    );
    assert_eq!(code, 0, "{err}");
    let read = |n: &str| fs::read(dir.path().join(n)).unwrap();
    let bgcode = read("a.bgcode");
    assert_eq!(&bgcode[..4], b"GCDE");
    assert!(bgcode.len() < read("a.gcode").len() / 2);
    let text = String::from_utf8(read("back.gcode")).unwrap();
    let gcode: String = String::from_utf8(read("a.gcode"))
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && l.trim() != ";")
        .map(|l| format!("{l}\n"))
        .collect();
    // The file metadata (gweave's header), the printer metadata PrusaSlicer's settings and the
    // footer's figures give, then the G-code, then its settings block, now slicer metadata
    // rendered after the G-code.
    let settings = gcode.find("; prusaslicer_config = begin").unwrap();
    let at = text.find(&gcode[..settings]).expect("the G-code comes back whole");
    let head = &text[..at];
    assert!(
        head.starts_with(&format!("; generated by gweave {}\n\n\n", env!("CARGO_PKG_VERSION"))),
        "{head}"
    );
    for printer in ["; filament_type = PLA\n", "; layer_height = 0.2\n", "; temperature = 210\n"] {
        assert!(head.contains(printer), "{printer} missing from {head}");
    }
    assert!(head.contains("; estimated printing time (normal mode) = "), "{head}");
    assert!(text.ends_with(&format!("\n\n{}\n", &gcode[settings..])));
    // b.bgcode carried a.bgcode's metadata: one header, not two.
    let b = String::from_utf8(read("b.gcode")).unwrap();
    assert_eq!(b.matches("; generated by gweave").count(), 1, "{}", &b[..200]);
    assert_eq!(b.matches("; prusaslicer_config = begin").count(), 1);
}

/// Regression: `cat` said "copied byte for byte" of a `.bgcode` output, where empty lines are
/// not kept; a text copy is byte for byte.
#[test]
fn cat_to_bgcode_does_not_claim_byte_for_byte() {
    let (dir, _) = dir_with_fixture("prusaslicer/pr_torus_pva.gcode", "a.gcode");
    let out = gweave(dir.path(), &["cat", "a.gcode", "-o", "a.bgcode"]).run();
    out.assert_ok();
    let summary = out.stdout_text();
    assert!(!summary.contains("byte for byte"), "{summary}");
    assert!(summary.contains("written as binary G-code: empty lines and lone `;` not kept"), "{summary}");
    let out = gweave(dir.path(), &["cat", "a.bgcode", "-o", "b.gcode"]).run();
    out.assert_ok();
    assert!(out.stdout_text().contains(", copied byte for byte\n"), "{}", out.stdout_text());
}

/// A damaged block: the error names the file and the block, exit code 1, no output left.
#[test]
fn damaged_bgcode_blocks_are_refused() {
    let (dir, _) = dir_with_fixture("prusaslicer/pr_torus_pva.gcode", "a.gcode");
    gweave(dir.path(), &["cat", "a.gcode", "-o", "good.bgcode"]).run().assert_ok();
    let good = fs::read(dir.path().join("good.bgcode")).unwrap();
    // A flipped byte in the middle of the G-code: its block's CRC32 no longer matches.
    let mut flipped = good.clone();
    let mid = good.len() / 2;
    flipped[mid] ^= 0x40;
    fs::write(dir.path().join("flipped.bgcode"), &flipped).unwrap();
    let before = snapshot(dir.path());
    for command in ["stats", "cat", "check", "sim", "estimate"] {
        let mut args = vec![command, "flipped.bgcode"];
        if command == "cat" {
            args.extend(["-o", "out.gcode"]);
        }
        let out = gweave(dir.path(), &args).run();
        out.assert_refused("flipped.bgcode");
        assert!(
            out.stderr.contains("checksum mismatch") && out.stderr.contains("(G-code at byte"),
            "{command}: {}",
            out.stderr
        );
    }
    assert_eq!(snapshot(dir.path()), before, "a refused run wrote something");
    assert_no_temp_left(dir.path());
    // Cut in the middle of a block.
    fs::write(dir.path().join("cut.bgcode"), &good[..mid]).unwrap();
    let out = gweave(dir.path(), &["purge-shift", "cut.bgcode", "-o", "out.bgcode", "--purge", "5"]).run();
    out.assert_refused("cut.bgcode: block ");
    assert!(out.stderr.contains("truncated"), "{}", out.stderr);
    assert!(!dir.path().join("out.bgcode").exists());
    assert_no_temp_left(dir.path());
}

/// The first heatshrink-compressed G-code block of a binary G-code file with CRC32s: its
/// number, the byte offset of its header, its uncompressed size and the offset of its CRC32
/// (libbgcode's layout: type, compression, uncompressed size, stored size, parameters, data,
/// CRC32).
fn first_heatshrink_gcode_block(file: &[u8]) -> (u32, usize, u32, usize) {
    let u16_at = |at: usize| u16::from_le_bytes([file[at], file[at + 1]]);
    let u32_at = |at: usize| u32::from_le_bytes(file[at..at + 4].try_into().unwrap());
    let (mut at, mut number) = (10, 1);
    loop {
        let (kind, compression, size) = (u16_at(at), u16_at(at + 2), u32_at(at + 4));
        let (header, stored) = if compression == 0 { (8, size) } else { (12, u32_at(at + 8)) };
        let params = if kind == 5 { 6 } else { 2 };
        let crc = at + header + params + stored as usize;
        if kind == 1 && compression == 3 {
            return (number, at, size, crc);
        }
        (at, number) = (crc + 4, number + 1);
    }
}

/// Regression (B2): a heatshrink G-code block whose header gave a smaller size than its data
/// decodes to was cut short without a word. The first block's size set to 0 (its CRC32 made
/// good again): `cat` wrote 266 991 bytes of the 332 504 and exited 0, and so did `stats`,
/// `check`, `estimate` and `purge-shift`. Every reader refuses it, as it refused a larger size,
/// naming the block and both sizes; one byte short or over too.
#[test]
fn b2_a_heatshrink_block_whose_header_lowers_its_size_is_refused() {
    let (dir, _) = dir_with_fixture("prusaslicer/pr_torus_pva.gcode", "a.gcode");
    gweave(dir.path(), &["cat", "a.gcode", "-o", "a.bgcode"]).run().assert_ok();
    let good = fs::read(dir.path().join("a.bgcode")).unwrap();
    let (number, at, size, crc) = first_heatshrink_gcode_block(&good);
    for lie in [0, size - 1, size + 1] {
        let mut file = good.clone();
        file[at + 4..at + 8].copy_from_slice(&lie.to_le_bytes());
        let checksum = crc32fast::hash(&file[at..crc]);
        file[crc..crc + 4].copy_from_slice(&checksum.to_le_bytes());
        refused_by_every_reader(
            &file,
            &format!(
                "in.bgcode: block {number} (G-code at byte {at}): heatshrink data decodes to {size} bytes, \
                 not the {lie} its header says"
            ),
        );
    }
}
