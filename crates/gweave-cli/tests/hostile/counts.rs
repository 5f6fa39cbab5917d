//! Counts and sizes a profile or an `M503` report gives, checked against their ceilings before
//! anything is sized by them: `mixing_inputs = 4294967296` once asked for 34 GB before its range
//! was checked, `M92 T99999999999 E1` for 4.8 TB. Every profile type (machine, mix, printhead,
//! rotary, purge-shift) with a count bomb in it is refused at once, in a few MiB, naming the
//! file, the key and its range; a profile at its ceiling loads in linear time.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::harness::*;

/// Memory any of these runs may take: the command's own, nothing sized by the count.
const BUDGET_MIB: f64 = 64.0;

const MOVES: &str = "G28\nM104 S200\nM109 S200\nG1 X10 Y10 Z0.2 F3000\nG1 X20 Y10 E1 F1200\nM104 S0\n";

/// `args` run in `dir`: refused within a few seconds, in budget, with `message` in the error.
#[track_caller]
fn refused(dir: &Path, args: &[&str], message: &str) {
    let out = gweave(dir, args).limit(Duration::from_secs(30)).cpu_limit(Duration::from_secs(10)).run();
    out.assert_refused(message).assert_peak_under(BUDGET_MIB);
    assert!(out.stderr.len() < 2_000, "{args:?}: a long message: {} bytes", out.stderr.len());
    assert_no_temp_left(dir);
}

/// Regression: `mixing_inputs = 9223372036854775807` panicked with "capacity overflow" in
/// `estimate`, `sim` and `serve`, `4294967296` aborted allocating 34 GB: the range is checked
/// before the per-input steps are filled. The count prints whole.
#[test]
fn a_huge_mixing_inputs_count_is_refused_before_it_allocates() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("in.gcode"), MOVES).unwrap();
    for count in ["9223372036854775807", "4294967296", "1000000"] {
        fs::write(dir.path().join("m.toml"), format!("mixing_inputs = {count}\n")).unwrap();
        let message = format!("m.toml: mixing_inputs = {count} is out of range: 0 to 16 inputs");
        for command in ["estimate", "sim"] {
            refused(dir.path(), &[command, "in.gcode", "--machine", "m.toml"], &message);
        }
    }
}

/// A count bomb in every profile type, through the command that reads it: the message names
/// the file, the key (a list's length as `key (count)`) and the range.
#[test]
fn count_bombs_in_every_profile_type_are_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("in.gcode"), MOVES).unwrap();
    fs::write(d.join("layer.bmp"), crate::bombs::bmp_header(4, 4)).unwrap();
    let huge = "9223372036854775807";
    let many = |header: &str, n: usize| header.repeat(n);
    let tube = fs::read_to_string(repo().join("examples/rotary/tube.toml")).unwrap();
    let cases: Vec<(&str, String, Vec<&str>, String)> = vec![
        (
            "machine extruders",
            many("[[motion.extruders]]\n", 1000),
            vec!["sim", "in.gcode", "--machine", "p.toml"],
            "p.toml: [motion] extruders (count) = 1000 is out of range: 0 to 8 extruders".into(),
        ),
        (
            "machine lookahead",
            format!("[motion.corners]\nmode = \"marlin\"\nlookahead_blocks = {huge}\n"),
            vec!["estimate", "in.gcode", "--machine", "p.toml"],
            format!("p.toml: [motion.corners] lookahead_blocks = {huge} is out of range: 2 to 1024 blocks"),
        ),
        (
            "machine samples",
            format!("[thermal]\nrecord_max_samples = {huge}\n"),
            vec!["sim", "in.gcode", "--machine", "p.toml"],
            format!("p.toml: [thermal] record_max_samples = {huge} is out of range"),
        ),
        (
            "mix virtual tools",
            format!("[hardware]\nvirtual_tools = {huge}\n"),
            vec!["mix", "in.gcode", "--config", "p.toml", "-o", "out.gcode"],
            format!("p.toml: [hardware] virtual_tools = {huge} is out of range: 0 to 1000 tools"),
        ),
        (
            "mix tool map",
            format!("[map]\n{}", (0..5000).map(|t| format!("T{t} = \"Red\"\n")).collect::<String>()),
            vec!["mix", "in.gcode", "--config", "p.toml", "-o", "out.gcode"],
            "p.toml: map (count) = 5000 is out of range: 0 to 4096 entries".into(),
        ),
        (
            "printhead nozzles",
            "nozzle_count = 4294967295\n".into(),
            vec!["raster", "layer.bmp", "--head", "p.toml", "-o", "out.gcode"],
            "p.toml: nozzle_count = 4294967295 is out of range: 1 to 64 nozzles".into(),
        ),
        (
            "printhead map",
            format!("nozzle_rows = [{}]\n", "0, ".repeat(1000)),
            vec!["raster", "layer.bmp", "--head", "p.toml", "-o", "out.gcode"],
            "p.toml: nozzle_rows (count) = 1000 is out of range: 0 to 64 rows".into(),
        ),
        (
            "printhead heads",
            many("[[heads]]\n", 1000),
            vec!["raster", "layer.bmp", "--head", "p.toml", "-o", "out.gcode"],
            "p.toml: heads (count) = 1000 is out of range: 0 to 16 heads".into(),
        ),
        (
            "rotary layers",
            tube.replace("layers = 4", "layers = 4294967295"),
            vec!["rotary", "tube", "-c", "p.toml", "-o", "out.gcode"],
            "layers".into(),
        ),
        (
            "purge-shift window",
            format!("purge_mm = 5\nmax_window_lines = {huge}\n"),
            vec!["purge-shift", "in.gcode", "-c", "p.toml", "-o", "out.gcode"],
            format!("p.toml: max_window_lines = {huge} is out of range: 1 to 10000000 lines"),
        ),
        (
            "purge-shift colours",
            format!("purge_mm = 5\ncolours = [{}]\n", "\"#ffffff\", ".repeat(1000)),
            vec!["purge-shift", "in.gcode", "-c", "p.toml", "-o", "out.gcode"],
            "p.toml: colours (count) = 1000 is out of range: 0 to 256 tools".into(),
        ),
    ];
    for (what, text, args, message) in cases {
        fs::write(d.join("p.toml"), text).unwrap();
        let out = gweave(d, &args).limit(Duration::from_secs(30)).cpu_limit(Duration::from_secs(10)).run();
        out.assert_refused(&message).assert_peak_under(BUDGET_MIB);
        assert!(out.stderr.len() < 2_000, "{what}: a {} byte message", out.stderr.len());
        assert!(!d.join("out.gcode").exists(), "{what}: an output was written");
        assert_no_temp_left(d);
    }
}

/// Regression: `machine from-m503` on `M92 T99999999999 E1` aborted allocating 4.8 TB, 10 000
/// extruder lines took 14 s, and `M205 J1e60` made a profile `estimate` then refused. The
/// extruder is held to Marlin's eight before the list grows, every line's values to the
/// profile's ranges at that line, and the report reads in linear time.
#[test]
fn m503_extruders_and_values_are_checked_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            "echo:  M92 T99999999999 E1\n",
            "line 1: M92 T99999999999: no such extruder (a Marlin build has at most 8, T0 to T7)",
        ),
        ("M203 X500\nM201 T8 E100\n", "line 2: M201 T8: no such extruder"),
        ("M92 T1.5 E100\n", "line 1: M92 T1.5: no such extruder"),
        (
            "M92 X80\nM205 J1e60\n",
            "line 2: [motion.corners] junction_deviation_mm = 1e60 is out of range: 0.0001 to 10 mm",
        ),
        ("M92 X80\nM205 X1e60 Y10\n", "line 2: [motion.corners.jerk_mm_s] x = 1e60 is out of range"),
    ];
    for (report, message) in cases {
        fs::write(d.join("m503.txt"), report).unwrap();
        refused(d, &["machine", "from-m503", "m503.txt", "-o", "p.toml"], message);
        assert!(!d.join("p.toml").exists());
    }
    // Ten thousand lines, each setting an extruder: read at once, the last value kept.
    let mut report = String::new();
    for i in 0..10_000 {
        writeln!(report, "echo:  M92 T{} E{}", 1 + i % 7, 100 + i).unwrap();
    }
    fs::write(d.join("m503.txt"), report).unwrap();
    let started = Instant::now();
    let out = gweave(d, &["machine", "from-m503", "m503.txt", "-o", "p.toml"]).run();
    out.assert_ok().assert_peak_under(BUDGET_MIB);
    assert!(started.elapsed() < Duration::from_secs(5), "took {:?}", started.elapsed());
    let profile = fs::read_to_string(d.join("p.toml")).unwrap();
    assert!(profile.contains("steps_per_mm = 10099.0"), "the last M92 T7 E10099 is kept:\n{profile}");
    // The profile made is one `estimate` takes.
    fs::write(d.join("in.gcode"), MOVES).unwrap();
    gweave(d, &["estimate", "in.gcode", "--machine", "p.toml"]).run().assert_ok();
}

/// A settings file is read to at most 256 KiB: `--machine /dev/zero` is refused after that,
/// not read until memory runs out; a file of 256 KiB of numbers stays in budget.
#[test]
fn an_endless_settings_file_is_refused_at_its_ceiling() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("in.gcode"), MOVES).unwrap();
    for args in [
        &["sim", "in.gcode", "--machine", "/dev/zero"][..],
        &["mix", "in.gcode", "--config", "/dev/zero", "-o", "out.gcode"],
        &["machine", "from-m503", "/dev/zero"],
    ] {
        refused(dir.path(), args, "larger than the limit of 256 KiB for a settings file");
    }
    // The costliest TOML there is, an array of one-digit numbers, just under the ceiling.
    let text = format!("motion = [{}]\n", "0,".repeat(130_000));
    fs::write(dir.path().join("p.toml"), text).unwrap();
    refused(dir.path(), &["sim", "in.gcode", "--machine", "p.toml"], "p.toml: machine profile: ");
}

/// A mix profile of `n` user mixes, `m0` to `m{n-1}`, each its own ratios.
fn mixes(n: usize) -> String {
    let mut text = String::new();
    for i in 0..n {
        let a = (i % 100) as f64 / 100.0;
        writeln!(text, "[mix.m{i}]\nratios = [{a}, {}, 0, 0]", 1.0 - a).unwrap();
    }
    text
}

/// Regression: a mix profile of 20 000 mixes took 92 s (10 000: 20 s): every mix added to the
/// palette compared its name with every one before it. Names are looked up by a map now, so
/// 4 096 mixes (the ceiling) take little more than 100, and 4 097 are refused.
#[test]
fn a_mix_profile_of_many_mixes_loads_in_linear_time() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("in.gcode"), MOVES).unwrap();
    let run = |n: usize| {
        fs::write(d.join("p.toml"), mixes(n)).unwrap();
        let last = format!("0=m{}", n - 1);
        let args = ["mix", "in.gcode", "--config", "p.toml", "--at-layer", &last, "-o", "out.gcode"];
        let started = Instant::now();
        let out = gweave(d, &args).limit(Duration::from_secs(60)).run();
        out.assert_ok().assert_peak_under(BUDGET_MIB);
        started.elapsed()
    };
    let (few, many) = (run(100), run(4_096));
    // Quadratic, 4 096 took 12 s in this debug build; linear, a second or two more than 100.
    assert!(many < few + Duration::from_secs(5), "100 mixes: {few:?}, 4 096: {many:?}");
    fs::write(d.join("p.toml"), mixes(4_097)).unwrap();
    refused(
        d,
        &["mix", "in.gcode", "--config", "p.toml", "-o", "out.gcode"],
        "p.toml: mix (count) = 4097 is out of range: 0 to 4096 entries",
    );
}

fn repo() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}
