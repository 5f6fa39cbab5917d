//! Settings files: mutated copies of every shipped profile (each numeric key set to 1e308, -1,
//! nan and 0) run through the command that reads them, under a time limit: refused cleanly with
//! a one-line message naming the file, or run fine; never a hang or a panic. The settings inside
//! an `.sl1` archive likewise.

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::harness::*;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A copy of `example` in `dir` with line `key = ...` set to `value`.
fn mutated(dir: &Path, example: &str, key: &str, value: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo().join(example)).unwrap();
    let line = text.lines().find(|l| l.starts_with(&format!("{key} ="))).unwrap_or_else(|| panic!("{key}"));
    let path = dir.join("printer.toml");
    std::fs::write(&path, text.replace(line, &format!("{key} = {value}"))).unwrap();
    path
}

/// The numeric `key = value` lines of a TOML file (index, key).
fn numeric_keys(text: &str) -> Vec<(usize, String)> {
    text.lines()
        .enumerate()
        .filter_map(|(i, line)| {
            let (key, value) = line.split_once(" = ")?;
            let value = value.split('#').next()?.trim();
            value.parse::<f64>().ok().map(|_| (i, key.trim().to_owned()))
        })
        .collect()
}

const MOVES: &str = "G28\nM104 S200\nM109 S200\nG1 X10 Y10 Z0.2 F3000\nG1 X20 Y10 E1 F1200\nM104 S0\n";

/// Regression: `x_min_mm = 1e308` made `sim` loop for ever in the thermal loop (homing across
/// 1e308 mm); a sample period of 1e308 s did the same. Both are refused, by `sim` and by
/// `estimate` with the same message (one validation path).
#[test]
fn huge_bed_origin_and_sample_period_are_refused_not_hung() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("in.gcode"), MOVES).unwrap();
    let cases = [
        ("x_min_mm", "printer.toml: [bed] x_min_mm = 1e308 is out of range: -10000 to 10000 mm"),
        ("sample_period_s", "printer.toml: [thermal] sample_period_s = 1e308 is out of range: 0.001 to 10 s"),
    ];
    for (key, message) in cases {
        mutated(dir.path(), "examples/machines/marlin-ramps.toml", key, "1e308");
        for command in ["sim", "estimate"] {
            let out = gweave(dir.path(), &[command, "in.gcode", "--machine", "printer.toml"])
                .limit(Duration::from_secs(20))
                .run();
            out.assert_refused(message);
            assert_eq!(out.stderr.lines().count(), 1, "{command}: one line: {}", out.stderr);
        }
    }
}

/// Regression: `estimate` accepted NaN heater values that `sim` refused.
#[test]
fn estimate_and_sim_refuse_a_nan_heater_alike() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("in.gcode"), MOVES).unwrap();
    mutated(dir.path(), "examples/machines/marlin-ramps.toml", "heater_lag_s", "nan");
    let run = |command| {
        gweave(dir.path(), &[command, "in.gcode", "--machine", "printer.toml"])
            .limit(Duration::from_secs(20))
            .run()
    };
    let (sim, estimate) = (run("sim"), run("estimate"));
    sim.assert_refused("printer.toml: [thermal.hotends[0]] heater_lag_s = nan is out of range: 0 to 600 s");
    estimate.assert_refused("heater_lag_s = nan");
    assert_eq!(sim.stderr, estimate.stderr);
}

/// Each numeric key of `example` set to 1e308, -1, nan and 0 in `dir/name`, then `args` run in
/// `dir`: refused naming the file, or run fine, within 20 s. Returns what went wrong.
fn sweep(dir: &Path, example: &Path, name: &str, args: &[&str]) -> Vec<String> {
    let text = std::fs::read_to_string(example).unwrap();
    let mut failures = Vec::new();
    for (index, key) in numeric_keys(&text) {
        for bad in ["1e308", "-1", "nan", "0"] {
            let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
            lines[index] = format!("{key} = {bad}");
            std::fs::write(dir.join(name), lines.join("\n")).unwrap();
            let out = gweave(dir, args).limit(Duration::from_secs(20)).run();
            let sound = !out.hung && out.signal.is_none() && !out.stderr.contains("panicked");
            let clean = match out.code {
                Some(0) => true,
                Some(1) => out.stderr.starts_with(&format!("gweave: error: {name}: ")),
                _ => false,
            };
            if !(sound && clean) {
                failures.push(format!("{}: {key} = {bad}: {:?} {}", example.display(), out.code, out.stderr));
            }
        }
    }
    failures
}

fn examples(folder: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join(folder))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

/// Every example machine profile through `sim`.
#[test]
fn every_machine_profile_key_mutated_is_refused_or_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("in.gcode"), MOVES).unwrap();
    let args = ["sim", "in.gcode", "--machine", "printer.toml", "-q"];
    let failures: Vec<String> = examples("examples/machines")
        .iter()
        .flat_map(|e| sweep(dir.path(), e, "printer.toml", &args))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every example mix profile through `mix`.
#[test]
fn every_mix_profile_key_mutated_is_refused_or_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("in.gcode"), MOVES).unwrap();
    let args = ["mix", "in.gcode", "-c", "mix.toml", "-o", "out.gcode"];
    let failures: Vec<String> =
        examples("examples/mix").iter().flat_map(|e| sweep(dir.path(), e, "mix.toml", &args)).collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every example printhead profile through `raster`.
#[test]
fn every_printhead_profile_key_mutated_is_refused_or_runs() {
    let dir = tempfile::tempdir().unwrap();
    let image = repo().join("examples/raster/layers/badge_0.bmp");
    std::fs::copy(image, dir.path().join("badge.bmp")).unwrap();
    let args = ["raster", "badge.bmp", "-o", "out.gcode", "--head", "head.toml"];
    let failures: Vec<String> =
        examples("examples/raster").iter().flat_map(|e| sweep(dir.path(), e, "head.toml", &args)).collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every example rotary settings file through `rotary tube` or `rotary wrap`.
#[test]
fn every_rotary_settings_key_mutated_is_refused_or_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(repo().join("tests/data/rotary/plate.gcode"), dir.path().join("plate.gcode")).unwrap();
    let mut failures = Vec::new();
    for example in examples("examples/rotary") {
        let wrap = example.file_name().unwrap().to_str().unwrap().starts_with("wrap");
        let args: &[&str] = if wrap {
            &["rotary", "wrap", "plate.gcode", "-c", "rotary.toml", "-o", "out.gcode"]
        } else {
            &["rotary", "tube", "-c", "rotary.toml", "-o", "out.gcode"]
        };
        failures.extend(sweep(dir.path(), &example, "rotary.toml", args));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A purge-shift config with every numeric key written out (no example ships one), each key
/// mutated through `purge-shift`.
#[test]
fn every_purge_shift_config_key_mutated_is_refused_or_runs() {
    let dir = tempfile::tempdir().unwrap();
    let config = "purge_mm = 20.0\nfilament_diameter_mm = 1.75\nmax_window_lines = 1000\nfallback = \"tower\"\n\
                  [[pair]]\nfrom = 0\nto = 1\npurge_mm = 30.0\n\
                  [block]\nretract_mm = 4.0\nlift_mm = 15.0\nx_mm = 10.0\ny_mm = 10.0\nwipe_mm = 5.0\n\
                  travel_feed_mm_min = 1320.0\nextrude_feed_mm_min = 200.0\nretract_feed_mm_min = 2400.0\n\
                  z_feed_mm_min = 200.0\n\
                  [tower]\nx_mm = 150.0\ny_mm = 150.0\ngap_mm = 5.0\nbed_mm = [200.0, 200.0]\nline_width_mm = 0.5\n\
                  layer_height_mm = 0.2\nlift_mm = 0.0\ntravel_feed_mm_min = 6000.0\nextrude_feed_mm_min = 1200.0\n\
                  retract_feed_mm_min = 2400.0\n";
    let example = dir.path().join("example.toml");
    std::fs::write(&example, config).unwrap();
    let gcode = "G21\nG90\nM82\nT0\nG1 Z0.2 F600\nG1 X10 Y10 E1 F1200\nT1\nG1 X20 Y10 E2\nG1 X30 Y10 E3\n";
    std::fs::write(dir.path().join("in.gcode"), gcode).unwrap();
    let args = ["purge-shift", "in.gcode", "-c", "ps.toml", "-o", "out.gcode"];
    let failures = sweep(dir.path(), &example, "ps.toml", &args);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A copy of `tests/data/sla/sphere.sl1` at `path`, `old` replaced by `new` in its settings file
/// `member` (the layers copied as they are stored).
fn edited_sl1(path: &Path, member: &str, old: &str, new: &str) {
    use std::io::{Read, Write};
    let mut src =
        zip::ZipArchive::new(std::fs::File::open(repo().join("tests/data/sla/sphere.sl1")).unwrap()).unwrap();
    let mut out = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    for i in 0..src.len() {
        let mut entry = src.by_index(i).unwrap();
        if entry.name() != member {
            out.raw_copy_file(entry).unwrap();
            continue;
        }
        let mut text = String::new();
        entry.read_to_string(&mut text).unwrap();
        assert!(text.contains(old), "{old}");
        out.start_file(member, zip::write::SimpleFileOptions::default()).unwrap();
        out.write_all(text.replace(old, new).as_bytes()).unwrap();
    }
    out.finish().unwrap();
}

/// Regression (B3): an `.sl1`'s `layerHeight` was never range-checked: `nan` wrote `G1 ZNaN`,
/// `-5` wrote `G1 Z-5`, `1e300` a 301-digit Z, all with exit 0; `display_width = 0.0000001` left
/// no pixel for a nozzle and printed nothing, exit 0; `display_width = -120` was refused naming
/// another key (`display_pixels_x`). `raster` refuses each, naming the archive, the file in it,
/// the key, the value and its range, and writes nothing.
#[test]
fn b3_raster_refuses_sl1_settings_out_of_their_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            "nan",
            "config.ini",
            "layerHeight = 0.1",
            "layerHeight = nan",
            "layerHeight = nan is out of range: 0.001 to 10 mm",
        ),
        (
            "neg",
            "config.ini",
            "layerHeight = 0.1",
            "layerHeight = -5",
            "layerHeight = -5 is out of range: 0.001 to 10 mm",
        ),
        (
            "huge",
            "config.ini",
            "layerHeight = 0.1",
            "layerHeight = 1e300",
            "layerHeight = 1e300 is out of range: 0.001 to 10 mm",
        ),
        (
            "tinypx",
            "prusaslicer.ini",
            "display_width = 120",
            "display_width = 0.0000001",
            "display_width = 1e-7 is out of range: 1 to 10000 mm",
        ),
        (
            "negw",
            "prusaslicer.ini",
            "display_width = 120",
            "display_width = -120",
            "display_width = -120 is out of range: 1 to 10000 mm",
        ),
    ];
    for (name, member, old, new, message) in cases {
        edited_sl1(&d.join(format!("{name}.sl1")), member, old, new);
        let out = gweave(d, &["raster", &format!("{name}.sl1"), "-o", "out.gcode"])
            .limit(Duration::from_secs(20))
            .run();
        out.assert_refused(&format!(
            "gweave: error: reading {name}.sl1\n  caused by: sl1 {member}: {message}\n"
        ));
        assert!(!d.join("out.gcode").exists(), "{name}: an output was written");
        assert_no_temp_left(d);
    }
    // The archive as shipped prints its 308 layers, 0.1 mm apart.
    edited_sl1(&d.join("sphere.sl1"), "config.ini", "layerHeight = 0.1", "layerHeight = 0.1");
    gweave(d, &["raster", "sphere.sl1", "-o", "out.gcode"]).limit(Duration::from_secs(60)).run().assert_ok();
    let text = std::fs::read_to_string(d.join("out.gcode")).unwrap();
    let z: Vec<&str> = text.lines().filter(|l| l.starts_with("G1 Z")).collect();
    assert_eq!((z.len(), z[0], z[307]), (308, "G1 Z0.1", "G1 Z30.8"));
}
