//! Unix manners (issue 21): several files per `stats` and `check`, `-q` with one meaning,
//! `--lenient` wherever a command stops at bad input, a bed with an origin or read from the
//! slicer's settings, JSON numbers as numbers, summaries without raw JSON, errors said once.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn fixture(name: &str) -> String {
    let p: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name);
    p.to_str().unwrap().to_owned()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", text(&out.stdout)))
}

/// A file in a temporary folder.
fn write(dir: &tempfile::TempDir, name: &str, body: &str) -> String {
    let path = dir.path().join(name);
    std::fs::write(&path, body).unwrap();
    path.to_str().unwrap().to_owned()
}

/// PrusaSlicer's MK3S start: the purge line runs at Y = -3, on the bed its profile describes.
const MK3S: &str = "M104 S215\nM109 S215\nG28\nG92 E0\nG1 Y-3 F1000\nG1 X60 E9 F1000\nG1 X100 E12.5\n\
    G1 X120 Y50 Z0.2 F3000\n; bed_shape = 0x-4,250x-4,250x210,0x210\n; max_print_height = 210\n";

#[test]
fn stats_of_several_files_reports_each_and_the_total() {
    let (a, b) = (fixture("prusaslicer/pr_box_mach3.gcode"), fixture("cura/cura_torus.gcode"));
    let out = gweave(&["stats", &a, &b, "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let j = json(&out);
    let files = j["files"].as_array().unwrap();
    assert_eq!(files.len(), 2);
    assert_eq!(files[0]["path"], a.as_str());
    let sum = |key: &str| files.iter().map(|f| f[key].as_f64().unwrap()).sum::<f64>();
    assert_eq!(j["total"]["files"], 2);
    assert_eq!(j["total"]["lines"].as_f64().unwrap(), sum("lines"));
    let t0 = |f: &serde_json::Value| f["filament"][0]["extruded_mm"].as_f64().unwrap();
    let total_t0 = j["total"]["filament"][0]["extruded_mm"].as_f64().unwrap();
    assert!((total_t0 - (t0(&files[0]) + t0(&files[1]))).abs() < 1e-9);
    // One file: the document it always was.
    let one = json(&gweave(&["stats", &a, "--json"]));
    assert_eq!(one["lines"], files[0]["lines"]);
    assert!(one.get("total").is_none());
    let human = text(&gweave(&["stats", &a, &b]).stdout);
    assert!(human.contains("\ntotal of 2 files\n"), "{human}");
}

#[test]
fn check_of_several_files_fails_when_one_fails_and_totals_them() {
    let dir = tempfile::tempdir().unwrap();
    let bad = write(&dir, "bad.gcode", "M104 S200\nG1 X1..2 F600\n");
    let good = fixture("prusaslicer/pr_box_mach3.gcode");
    let out = gweave(&["check", &good, &bad]);
    assert_eq!(out.status.code(), Some(1));
    let said = text(&out.stdout);
    assert!(said.contains(&format!("{bad}:2:5: error: malformed number after 'X'")), "{said}");
    assert!(said.ends_with("total: 2 files, 6675 lines, 1 errors, 0 warnings; 1 failed\n"), "{said}");
    let j = json(&gweave(&["check", &good, &bad, "--json"]));
    assert_eq!(j["total"]["failed_files"], 1);
    assert_eq!(j["files"][1]["path"], bad.as_str());
    assert_eq!(gweave(&["check", &good, &good]).status.code(), Some(0));
}

#[test]
fn check_json_writes_figures_as_numbers() {
    let dir = tempfile::tempdir().unwrap();
    // (Two lines: a feed rate out of range refuses its line, which then moves nowhere.)
    let file = write(&dir, "far.gcode", "M104 S200\nG1 X300.12345 Y5\nG1 F200000\n");
    let j = json(&gweave(&["check", &file, "--bed", "200,200,200", "--json"]));
    let findings = j["findings"].as_array().unwrap();
    let feed = findings.iter().find(|f| f["kind"] == "absurd_feed_rate").unwrap();
    assert_eq!(feed["feed_mm_min"].as_f64(), Some(200000.0));
    let bed = findings.iter().find(|f| f["kind"] == "outside_bed").unwrap();
    assert_eq!(bed["value_mm"].as_f64(), Some(300.123));
    assert_eq!(j["bed_from"], "given");
}

#[test]
fn check_reads_the_bed_from_prusaslicer_settings_so_its_purge_line_passes() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(&dir, "mk3s.gcode", MK3S);
    let out = gweave(&["check", &file]);
    let said = text(&out.stdout);
    assert!(out.status.success() && said.contains("0 warnings"), "{said}");
    assert!(said.contains("bed X 0 .. 250, Y -4 .. 210, Z 0 .. 210 mm (the file's bed_shape = 0x-4,250x-4,250x210,0x210, max_print_height = 210)"), "{said}");
    // The same bed given with its origin, four or five numbers; from the origin, Y-3 is off it.
    for bed in ["0,-4,250,210", "0,-4,250,210,210"] {
        let said = text(&gweave(&["check", &file, "--bed", bed]).stdout);
        assert!(said.contains("0 warnings"), "{bed}: {said}");
    }
    let said = text(&gweave(&["check", &file, "--bed", "250,210,210"]).stdout);
    // The purge line's three moves at Y -3 are one finding line (issue 39: one line per kind).
    assert!(
        said.contains(":5:4: warning: moves outside the bed: Y=-3.000 mm, 3 moves, lines 5 .. 7"),
        "{said}"
    );
    let out = gweave(&["check", &file, "--bed", "200,200"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("expected X,Y,Z or X0,Y0,X1,Y1[,Z] (mm), got \"200,200\""));
}

#[test]
fn check_reads_the_bed_of_every_prusaslicer_fixture() {
    for name in
        ["prusaslicer/pr_box_mach3.gcode", "prusaslicer/pr_torus_pva.gcode", "slic3r/slic3r_cone_2tool.gcode"]
    {
        let j = json(&gweave(&["check", &fixture(name), "--json"]));
        assert_eq!(j["bed"]["x_mm"], serde_json::json!([0.0, 200.0]), "{name}");
        assert!(j["bed_from"].as_str().unwrap().starts_with("bed_shape = 0x0,200x0,200x200,0x200"), "{name}");
        assert_eq!(j["warnings"], 0, "{name}");
    }
    // Cura's fixtures carry no machine size: no bed, no bounds check, and it says so.
    let said = text(&gweave(&["check", &fixture("cura/cura_torus.gcode")]).stdout);
    assert!(said.contains("no bed given or found in the file: bounds not checked"), "{said}");
}

#[test]
fn quiet_hides_the_summary_never_the_findings() {
    let file = fixture("prusaslicer/pr_box_mach3.gcode");
    let out = gweave(&["stats", &file, "-q"]);
    assert!(out.status.success() && out.stdout.is_empty() && out.stderr.is_empty());
    // -q with --json: the JSON still prints.
    assert_eq!(json(&gweave(&["stats", &file, "-q", "--json"]))["lines"], 6673);
    let dir = tempfile::tempdir().unwrap();
    let bad = write(&dir, "bad.gcode", "M104 S200\nG1 X1..2 F600\n");
    let out = gweave(&["check", &bad, "-q"]);
    assert_eq!(text(&out.stdout), format!("{bad}:2:5: error: malformed number after 'X'\n"));
    let copy = dir.path().join("copy.gcode");
    let out = gweave(&["cat", &file, "-o", copy.to_str().unwrap(), "-q"]);
    assert!(out.status.success() && out.stdout.is_empty(), "{}", text(&out.stdout));
}

#[test]
fn stats_and_preview_read_past_malformed_lines_with_lenient() {
    let dir = tempfile::tempdir().unwrap();
    let bad = write(&dir, "bad.gcode", "M104 S200\nG1 X1 Y1 F600\nG1 X1..2\nG1 X3 E1\nG1 X4 *x\n");
    let out = gweave(&["stats", &bad]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("bad.gcode:3:5: malformed number after 'X'"), "{}", text(&out.stderr));
    let j = json(&gweave(&["stats", &bad, "--lenient", "--json"]));
    assert_eq!((j["malformed_lines"].as_u64(), j["first_malformed_line"].as_u64()), (Some(2), Some(3)));
    assert_eq!(j["filament"][0]["extruded_mm"].as_f64(), Some(1.0));
    let png = dir.path().join("bad.png");
    let png = png.to_str().unwrap();
    assert_eq!(gweave(&["preview", &bad, "-o", png]).status.code(), Some(1));
    let out = gweave(&["preview", &bad, "-o", png, "--lenient"]);
    assert!(text(&out.stdout).contains("malformed       2 lines read past (first: line 3; see gweave check)"));
}

#[test]
fn sim_summary_says_warnings_in_words_without_json() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(&dir, "far.gcode", "G28\nG1 X250.1 F3000\n");
    let said = text(&gweave(&["sim", &file]).stdout);
    assert!(said.contains("line 2: X = 250.100 mm is outside the axis range"), "{said}");
    assert!(!said.contains("{\""), "{said}");
}

#[test]
fn a_failed_report_names_its_file_once() {
    let file = fixture("prusaslicer/pr_box_mach3.gcode");
    let out = gweave(&["stats", &file, "--report", "/nonexistent/r.json", "-q"]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        text(&out.stderr),
        // Refused before the run now (every output is checked first), as `serve --report`.
        "gweave: error: --report /nonexistent/r.json: No such file or directory (os error 2)\n"
    );
}

#[test]
fn us_spellings_and_older_names_run() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("p.png");
    let file = fixture("prusaslicer/pr_box_mach3.gcode");
    let out = gweave(&["preview", &file, "-o", png.to_str().unwrap(), "--color-by", "feature", "--json"]);
    assert_eq!(json(&out)["colour_by"], "feature");
    let cone = fixture("slic3r/slic3r_cone_2tool.gcode");
    let a = dir.path().join("a.gcode");
    let b = dir.path().join("b.gcode");
    assert!(gweave(&["purge-shift", &cone, "-o", a.to_str().unwrap(), "--purge-mm", "2.5", "-q"])
        .status
        .success());
    assert!(gweave(&["purge-shift", &cone, "-o", b.to_str().unwrap(), "--purge", "2.5", "-q"])
        .status
        .success());
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

/// Regression (issue 40): `rotary wrap -o -` printed no summary at all, where every other
/// transform writes it to standard error (docs/pipeline.md: `-o -` writes the output, and
/// nothing else, to standard output); it now runs through the transforms' one run.
#[test]
fn rotary_wrap_to_standard_output_says_its_summary_on_standard_error() {
    let plate = fixture("rotary/plate.gcode");
    let out = gweave(&["rotary", "wrap", &plate, "-o", "-", "--mandrel-diameter", "30"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert!(stdout.starts_with("; gweave 0.1.0 rotary wrap --mandrel-diameter 30 (generated)"), "{stdout}");
    assert!(!stdout.contains("  mandrel "), "the summary stays off the G-code");
    assert!(stderr.contains("  mandrel         30.000 mm (circumference 94.248 mm)"), "{stderr}");
    let quiet = gweave(&["rotary", "wrap", &plate, "-o", "-", "--mandrel-diameter", "30", "-q"]);
    assert_eq!((quiet.stdout, text(&quiet.stderr)), (out.stdout, String::new()));
}
