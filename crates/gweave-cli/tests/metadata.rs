//! Metadata that stays true after every transform, and second runs that never stack (issue 21),
//! through the real binary on the real slicer fixtures.

#[path = "../../gweave/tests/one_nozzle/mod.rs"]
mod one_nozzle;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn ok(out: Output) -> Output {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn fixture(name: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name);
    p.to_str().unwrap().to_owned()
}

fn stats(path: &Path) -> serde_json::Value {
    let out = ok(gweave(&["stats", path.to_str().unwrap(), "--json", "-q"]));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The slicer fixtures, and the mix flags each takes (RepRapFirmware's mixing commands use
/// colon lists, which `stats` does not read yet: that file is mixed for Marlin).
const FIXTURES: &[(&str, &[&str])] = &[
    ("prusaslicer/pr_torus_pva.gcode", &[]),
    ("prusaslicer/pr_bunny_3tool_rel.gcode", &[]),
    ("prusaslicer/pr_sphere_rrf_fwretract.gcode", &["--dialect", "marlin"]),
    ("slic3r/slic3r_cone_2tool.gcode", &[]),
    ("cura/cura_torus.gcode", &[]),
    ("cura/cura_dual.gcode", &[]),
];

/// Runs `args` with `-o out` added and returns the output's text.
fn transform(args: &[&str], out: &Path) -> String {
    let mut all = args.to_vec();
    all.extend(["-o", out.to_str().unwrap()]);
    // `rotary tube` has no progress bar to hide.
    if !args.starts_with(&["rotary", "tube"]) {
        all.push("-q");
    }
    ok(gweave(&all));
    std::fs::read_to_string(out).unwrap()
}

/// The estimated time the file states, if any (PrusaSlicer's footer, Cura's), s.
fn stated_time_s(s: &serde_json::Value) -> Option<f64> {
    s["slicer_figures"]["estimated_time_s"].as_f64()
}

/// How a transform's stated time is checked.
#[derive(Clone, Copy)]
enum Time<'a> {
    /// The rotary commands and `raster` time their output themselves.
    Own,
    /// The input states its times (`input`): the output's are those plus what the transform
    /// changed, so the stated times moved by what the full estimates of the two files differ
    /// by, in each mode the file states.
    Changes(&'a Path),
    /// The input states none (a Griffin file, Cura's placeholder): the output states the
    /// virtual printer's estimate of itself.
    Estimated,
}

/// Whether the file states its print time (PrusaSlicer's footer, Cura's `;TIME:` unless it is
/// CuraEngine's placeholder 6666, Griffin's `;PRINT.TIME:`).
fn states_time(text: &str) -> bool {
    text.contains("\n; estimated printing time (normal mode) = ")
        || text
            .lines()
            .any(|l| l.starts_with(";PRINT.TIME:") || (l.starts_with(";TIME:") && l != ";TIME:6666"))
}

/// PrusaSlicer's `; estimated printing time (<mode> mode) = 1h 2m 3s`, s.
fn footer_s(text: &str, mode: &str) -> Option<f64> {
    let value =
        text.lines().find_map(|l| l.strip_prefix(&format!("; estimated printing time ({mode} mode) = ")))?;
    let scale = |unit: char| match unit {
        'd' => 86400.0,
        'h' => 3600.0,
        'm' => 60.0,
        _ => 1.0,
    };
    Some(
        value
            .split_whitespace()
            .map(|p| p[..p.len() - 1].parse::<f64>().unwrap() * scale(p.chars().last().unwrap()))
            .sum(),
    )
}

/// `gweave estimate`'s total for the file: with the limits the slicer wrote into it, else the
/// default machine's, s.
fn estimate_s(path: &Path) -> f64 {
    let path = path.to_str().unwrap();
    let est = gweave(&["estimate", path, "--machine", "slicer", "--json", "-q"]);
    let est = if est.status.success() { est } else { ok(gweave(&["estimate", path, "--json", "-q"])) };
    let est: serde_json::Value = serde_json::from_slice(&est.stdout).unwrap();
    est["total_s"].as_f64().unwrap()
}

/// A copy of `path`, in `dir`, whose `machine_max_*` pairs are swapped, so that
/// `estimate --machine slicer` estimates its silent mode.
fn silent_copy(path: &Path, dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(path).unwrap();
    let swapped: String = text
        .lines()
        .map(|l| match (l.starts_with("; machine_max_"), l.split_once(" = ")) {
            (true, Some((key, value))) if value.contains(',') => {
                let (a, b) = value.split_once(',').unwrap();
                format!("{key} = {b},{a}\n")
            }
            _ => format!("{l}\n"),
        })
        .collect();
    let copy = dir.join(format!("{}.silent.gcode", path.file_stem().unwrap().to_str().unwrap()));
    std::fs::write(&copy, swapped).unwrap();
    copy
}

/// How far the change in stated time may be from the change in the full estimates, s: each
/// footer is rounded to the second (two roundings), and each change's window plans a few
/// unchanged lines of context, which on the fixtures moves the sum by under 0.1 s
/// (docs/performance.md).
const CHANGES_TOLERANCE_S: f64 = 1.1;

/// What every transform's output must say of itself: one gweave header naming the command,
/// filament figures that `stats` finds true (with the purges counted), and times as `time`
/// says.
fn check_output(text: &str, out: &Path, command: &str, time: Time<'_>) {
    let headers: Vec<&str> =
        text.lines().filter(|l| l.starts_with("; gweave ") && l.ends_with(" (generated)")).collect();
    assert_eq!(headers.len(), 1, "{}: {headers:?}", out.display());
    let header = headers[0];
    let expected = format!("; gweave {} {command} ", env!("CARGO_PKG_VERSION"));
    assert!(header.starts_with(&expected) && header.ends_with(" (generated)"), "{header}");
    let s = stats(out);
    assert_eq!(s["filament_matches_slicer"], serde_json::Value::Bool(true), "{}: {}", out.display(), s);
    match time {
        Time::Own => {}
        Time::Estimated => {
            if let Some(t) = stated_time_s(&s) {
                let total = estimate_s(out);
                assert!((t - total).abs() <= 0.5, "{}: states {t} s, estimate {total} s", out.display());
            }
        }
        Time::Changes(input) => {
            let before = std::fs::read_to_string(input).unwrap();
            for mode in ["normal", "silent"] {
                let Some(stated_in) = footer_s(&before, mode) else { continue };
                let stated_out = footer_s(text, mode).unwrap();
                let (est_in, est_out) = match mode {
                    "normal" => (estimate_s(input), estimate_s(out)),
                    _ => {
                        // Beside the output, in the test's directory (the input is a fixture).
                        let dir = out.parent().unwrap();
                        (estimate_s(&silent_copy(input, dir)), estimate_s(&silent_copy(out, dir)))
                    }
                };
                let (stated, estimated) = (stated_out - stated_in, est_out - est_in);
                assert!(
                    (stated - estimated).abs() <= CHANGES_TOLERANCE_S,
                    "{} ({mode} mode): the stated time moved by {stated} s, the estimate by {estimated} s",
                    out.display()
                );
                eprintln!("{} {mode}: stated {stated:+.0} s, estimates {estimated:+.3} s", out.display());
            }
        }
    }
}

#[test]
fn stats_of_every_transform_agrees_with_the_metadata_inside_it() {
    let dir = tempfile::tempdir().unwrap();
    for (rel, mix_flags) in FIXTURES {
        let input = fixture(rel);
        let name = Path::new(rel).file_stem().unwrap().to_str().unwrap();
        let out = dir.path().join(format!("{name}.mix.gcode"));
        let mut args =
            vec!["mix", &input, "--at-layer", "0=Orange", "--at-layer", "3=Blue", "--purge-mm", "25"];
        args.extend_from_slice(mix_flags);
        let text = transform(&args, &out);
        let original = std::fs::read_to_string(&input).unwrap();
        let time = if states_time(&original) { Time::Changes(Path::new(&input)) } else { Time::Estimated };
        check_output(&text, &out, "mix", time);
        // The figures were rewritten: mix's purges and dropped tool changes change them.
        let stated = |s: &serde_json::Value| s["slicer_figures"]["filament_used_mm"].clone();
        let before = stated(&stats(Path::new(&input)));
        assert!(before.is_null() || before != stated(&stats(&out)), "{rel}: {before}");

        let out = dir.path().join(format!("{name}.shifted.gcode"));
        // purge-shift refuses Cura's dual file as sliced (a nozzle per tool): as for one nozzle.
        let input = match *rel {
            "cura/cura_dual.gcode" => one_nozzle::one_nozzle_in(dir.path(), rel).to_str().unwrap().to_owned(),
            _ => input,
        };
        let text = transform(&["purge-shift", &input, "--purge-mm", "2.5"], &out);
        let time = if states_time(&original) { Time::Changes(Path::new(&input)) } else { Time::Estimated };
        check_output(&text, &out, "purge-shift", time);
    }
    let out = dir.path().join("sleeve.gcode");
    let text =
        transform(&["rotary", "wrap", &fixture("rotary/plate.gcode"), "--mandrel-diameter", "30"], &out);
    check_output(&text, &out, "rotary wrap", Time::Own);
    let out = dir.path().join("tube.gcode");
    let text =
        transform(&["rotary", "tube", "--mandrel-diameter", "20", "--length", "20", "--layers", "4"], &out);
    check_output(&text, &out, "rotary tube", Time::Own);
    // A generated file gets the PrusaSlicer footer, with the rotary command's own time.
    let tube = stats(&out);
    assert!(stated_time_s(&tube).is_some_and(|t| t > 60.0 && t < 3600.0), "{tube}");
    // An inkjet raster extrudes nothing, and says so.
    let out = dir.path().join("sphere.inkjet.gcode");
    let text = transform(&["raster", &fixture("sla/sphere.sl1")], &out);
    check_output(&text, &out, "raster", Time::Own);
    assert!(text.contains("\n; filament used [mm] = 0.00\n"));
}

/// The values of `letter` on the `M73` lines that carry it.
fn m73_of(text: &str, letter: char) -> Vec<u32> {
    text.lines()
        .filter(|l| l.starts_with("M73 "))
        .filter_map(|l| l.split_whitespace().find_map(|w| w.strip_prefix(letter)?.parse().ok()))
        .collect()
}

#[test]
fn m73_progress_is_recomputed_monotone_from_0_to_100() {
    let dir = tempfile::tempdir().unwrap();
    // PrusaSlicer's progress lines, as with `remaining_times = 1`: at the start, at each layer
    // change and at the end of the print, in normal and silent mode, with the times the slicer
    // states (7m 46s and 8m 5s in all, in proportion to the layers).
    let text = std::fs::read_to_string(fixture("prusaslicer/pr_torus_pva.gcode")).unwrap();
    let layers = text.matches("\n;LAYER_CHANGE\n").count() as f64;
    let [normal_s, silent_s] = [466.0, 485.0];
    let m73 = |done: f64| {
        let left = |total: f64| (total * (1.0 - done) / 60.0).round();
        let p = (100.0 * done).round();
        format!("M73 P{p} R{}\nM73 Q{p} S{}\n", left(normal_s), left(silent_s))
    };
    let (mut with_m73, mut layer) = (m73(0.0), 0.0);
    for line in text.lines() {
        if line == ";LAYER_CHANGE" {
            with_m73.push_str(&m73(layer / layers));
            layer += 1.0;
        }
        if line == "; filament used [mm] = 525.88, 123.16" {
            with_m73.push_str(&m73(1.0));
        }
        with_m73.push_str(line);
        with_m73.push('\n');
    }
    let input = dir.path().join("torus_m73.gcode");
    std::fs::write(&input, &with_m73).unwrap();
    let stated_in = m73_of(&with_m73, 'P');
    let input = input.to_str().unwrap();
    for (name, args) in [
        ("mix", vec!["mix", input, "--at-layer", "0=Orange", "--at-layer", "3=Blue"]),
        ("purge-shift", vec!["purge-shift", input, "--purge-mm", "2.5"]),
    ] {
        let out = dir.path().join(format!("{name}.gcode"));
        let text = transform(&args, &out);
        for (p, r) in [('P', 'R'), ('Q', 'S')] {
            let (percent, minutes) = (m73_of(&text, p), m73_of(&text, r));
            assert_eq!(percent.len(), with_m73.matches(&format!("M73 {p}")).count(), "{name}");
            assert!(percent.windows(2).all(|w| w[0] <= w[1]), "{name} {p}: {percent:?}");
            assert!(minutes.windows(2).all(|w| w[0] >= w[1]), "{name} {r}: {minutes:?}");
            assert_eq!(
                (percent[0], *percent.last().unwrap(), *minutes.last().unwrap()),
                (0, 100, 0),
                "{name}"
            );
        }
        // The slicer's progress, moved by what the transform changed (mix's purges add 32 s to
        // 466 s), not recomputed from nothing: by that share at most, and a point of rounding.
        let (percent, total_s) = (m73_of(&text, 'P'), stated_time_s(&stats(&out)).unwrap());
        let most = (100.0 * (total_s - normal_s).abs() / normal_s).ceil() as u32 + 1;
        assert!(percent.iter().zip(&stated_in).all(|(&o, &i)| o.abs_diff(i) <= most), "{name}: {percent:?}");
        // R at the start is the stated total in minutes.
        let t = stated_time_s(&stats(&out)).unwrap();
        assert_eq!(m73_of(&text, 'R')[0], (t / 60.0).round() as u32, "{name}");
    }
}

/// Issue 21: a transform run on its own output stacked silently (mix commented out the first
/// run's T lines and wrote a second definition block; purge-shift shifted again). It is refused,
/// naming the earlier run, and writes nothing.
#[test]
fn a_second_run_of_the_same_transform_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let torus = fixture("prusaslicer/pr_torus_pva.gcode");
    let plate = fixture("rotary/plate.gcode");
    let runs: [(&str, Vec<&str>, &str); 3] = [
        ("mix", vec!["mix", "--at-layer", "0=Orange", "--at-layer", "3=Blue"], &torus),
        ("purge-shift", vec!["purge-shift", "--purge-mm", "2.5"], &torus),
        ("rotary wrap", vec!["rotary", "wrap", "--mandrel-diameter", "30"], &plate),
    ];
    for (command, args, input) in runs {
        let once = dir.path().join("once.gcode");
        let mut first = args.clone();
        first.insert(command.split(' ').count(), input);
        transform(&first, &once);
        let twice = dir.path().join("twice.gcode");
        let mut second = args.clone();
        second.insert(command.split(' ').count(), once.to_str().unwrap());
        second.extend(["-o", twice.to_str().unwrap()]);
        let out = gweave(&second);
        assert!(!out.status.success(), "{command}");
        let err = String::from_utf8_lossy(&out.stderr);
        // The run's options, without its files.
        let options = args[command.split(' ').count()..].join(" ");
        let expected = format!(
            "{}:1: this file was written by `gweave {} {command} {options}`",
            once.display(),
            env!("CARGO_PKG_VERSION")
        );
        assert!(err.contains(&expected), "{command}: {err}");
        assert!(err.contains(&format!("a second {command} would stack on the first")), "{err}");
        assert!(!twice.exists(), "{command}");
        // --in-place is refused the same way and leaves the file as it was.
        let before = std::fs::read(&once).unwrap();
        let mut in_place = args.clone();
        in_place.insert(command.split(' ').count(), once.to_str().unwrap());
        in_place.push("--in-place");
        assert!(!gweave(&in_place).status.success(), "{command}");
        assert_eq!(std::fs::read(&once).unwrap(), before, "{command}");
    }
}

/// A chain of different transforms (mix, then purge-shift: PrusaSlicer's post-processing) is
/// not a second run: each adds its own header line, the newest on top, and the figures stay
/// true.
#[test]
fn a_chain_of_transforms_keeps_one_header_line_per_run() {
    let dir = tempfile::tempdir().unwrap();
    let mixed = dir.path().join("mixed.gcode");
    transform(
        &[
            "mix",
            &fixture("prusaslicer/pr_torus_pva.gcode"),
            "--at-layer",
            "0=Orange",
            "--at-layer",
            "3=Blue",
        ],
        &mixed,
    );
    let shifted = dir.path().join("shifted.gcode");
    let text = transform(&["purge-shift", mixed.to_str().unwrap(), "--purge-mm", "2.5"], &shifted);
    let lines: Vec<&str> = text.lines().take(3).collect();
    assert!(lines[0].starts_with("; gweave 0.1.0 purge-shift "), "{lines:?}");
    assert!(lines[1].starts_with("; gweave 0.1.0 mix "), "{lines:?}");
    assert!(lines[2].starts_with("; generated by PrusaSlicer"), "{lines:?}");
    assert_eq!(stats(&shifted)["filament_matches_slicer"], serde_json::Value::Bool(true));
    assert_eq!(stats(&shifted)["slicer"], "prusaslicer");
}

/// Regression: purge-shift moved the changes of Cura's dual-extrusion file (a nozzle per tool)
/// before the file's heating of the new nozzle (13 cold extrusions on `sim --machine
/// dual-extruder`). It is refused, naming the line and the way out, and writes nothing; the file
/// after `gweave mix` (one nozzle) is accepted, and so is PrusaSlicer's after mix, though mix
/// keeps its `; single_extruder_multi_material = 0`.
#[test]
fn a_file_for_a_nozzle_per_tool_is_refused_and_mix_output_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("shifted.gcode");
    let (dual, cone) = (fixture("cura/cura_dual.gcode"), fixture("prusaslicer/pr_cone_2tool.gcode"));
    let refused = gweave(&["purge-shift", &dual, "--purge-mm", "2.5", "-o", out.to_str().unwrap(), "-q"]);
    assert_eq!(refused.status.code(), Some(1));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.starts_with(&format!(
            "gweave: error: {dual}:4249: here, at the first command after the temperatures, T0's nozzle is \
             at 200 °C (set on line 4247) and T1's at 215 °C (line 3974): the file heats a nozzle per tool. \
             purge-shift moves colour changes on one nozzle"
        )),
        "{err}"
    );
    assert!(err.contains("or run `gweave mix` on it first"), "{err}");
    assert!(!out.exists() && std::fs::read_dir(dir.path()).unwrap().next().is_none());
    let refused = gweave(&["purge-shift", &cone, "--purge-mm", "2.5", "-o", out.to_str().unwrap(), "-q"]);
    assert_eq!(refused.status.code(), Some(1));
    let err = String::from_utf8_lossy(&refused.stderr);
    let setting = "(`; single_extruder_multi_material = 0`) and this line changes to T1";
    assert!(
        err.starts_with(&format!(
            "gweave: error: {cone}:504: the file was sliced for a nozzle per extruder {setting}"
        )),
        "{err}"
    );
    assert!(!out.exists());
    for input in [dual, cone] {
        let mixed = dir.path().join("mixed.gcode");
        transform(&["mix", &input, "-c", &fixture("../../examples/mix/tool_map.toml")], &mixed);
        let text = transform(&["purge-shift", mixed.to_str().unwrap(), "--purge-mm", "2.5"], &out);
        assert!(text.contains("; gweave 0.1.0 purge-shift --purge-mm 2.5 (generated)\n"), "{input}");
    }
}

/// Cura's Griffin header must stay at the very top (Ultimaker printers read it there): the
/// gweave line goes after it. Cura's placeholder `;TIME:` and `;Filament used: 0m` are filled.
#[test]
fn cura_headers_stay_first_and_get_true_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("dual.gcode");
    let input = one_nozzle::one_nozzle_in(dir.path(), "cura/cura_dual.gcode");
    let text = transform(&["purge-shift", input.to_str().unwrap(), "--purge-mm", "2.5"], &out);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], ";START_OF_HEADER");
    let end = lines.iter().position(|l| *l == ";END_OF_HEADER").unwrap();
    assert!(lines[end + 1].starts_with("; gweave 0.1.0 purge-shift "), "{:?}", &lines[end..end + 2]);
    let out = dir.path().join("torus.gcode");
    let text = transform(&["purge-shift", &fixture("cura/cura_torus.gcode"), "--purge-mm", "2.5"], &out);
    let s = stats(&out);
    let mm = s["filament"][0]["extruded_mm"].as_f64().unwrap();
    let stated = text.lines().find_map(|l| l.strip_prefix(";Filament used: ")).unwrap();
    assert_eq!(stated, format!("{:.5}m", mm / 1000.0));
    let time: f64 = text.lines().find_map(|l| l.strip_prefix(";TIME:")).unwrap().parse().unwrap();
    assert_ne!(time, 6666.0);
    let elapsed: Vec<f64> =
        text.lines().filter_map(|l| l.strip_prefix(";TIME_ELAPSED:")).map(|t| t.parse().unwrap()).collect();
    assert!(
        elapsed.windows(2).all(|w| w[0] <= w[1]) && *elapsed.last().unwrap() <= time + 1.0,
        "{elapsed:?}"
    );
}

/// Issue 21: `stats` counted 2 mm for a file that extrudes 27 (a 25 mm stationary purge, and a
/// retraction undone by its prime).
#[test]
fn stats_counts_a_stationary_purge() {
    let dir = tempfile::tempdir().unwrap();
    let file: PathBuf = dir.path().join("purge.gcode");
    std::fs::write(
        &file,
        "M104 S200\nM109 S200\nG92 E0\nG1 X10 Y10 F3000\nG1 E25 F200\nG1 X20 Y10 E26\nG92 E0\nG1 E-1\nG1 E0\nG1 X30 E1\n",
    )
    .unwrap();
    assert_eq!(stats(&file)["filament"][0]["extruded_mm"].as_f64(), Some(27.0));
}

/// The header names the run's options, not its files: the same run to a file, to standard
/// output and in place writes the same bytes.
#[test]
fn the_same_run_writes_the_same_bytes_wherever_it_writes() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("slic3r/slic3r_cone_2tool.gcode");
    let to_file = dir.path().join("out.gcode");
    let text = transform(&["purge-shift", &input, "--purge-mm", "2"], &to_file);
    assert!(text.starts_with(&format!(
        "; gweave {} purge-shift --purge-mm 2 (generated)\n",
        env!("CARGO_PKG_VERSION")
    )));
    let piped = ok(gweave(&["purge-shift", &input, "--purge-mm", "2", "-o", "-", "-q"]));
    assert_eq!(String::from_utf8(piped.stdout).unwrap(), text);
    let copy = dir.path().join("copy.gcode");
    std::fs::copy(&input, &copy).unwrap();
    ok(gweave(&["purge-shift", copy.to_str().unwrap(), "--purge-mm", "2", "--in-place", "-q"]));
    assert_eq!(std::fs::read_to_string(&copy).unwrap(), text);
    assert_eq!(std::fs::read(dir.path().join("copy.gcode.bak")).unwrap(), std::fs::read(&input).unwrap());
}

/// A progress line in the middle of a file only (not in the ends gweave looks at first) is
/// found by the measuring pass and rewritten from the time it states: its percent, stale here,
/// from its minutes left (a quarter of the slicer's 5h 31m 58s done).
#[test]
fn a_progress_line_in_the_middle_only_is_recomputed() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(fixture("prusaslicer/pr_bunny_3tool_rel.gcode")).unwrap();
    let quarter = text.len() / 4;
    let at = quarter + text[quarter..].find('\n').unwrap() + 1;
    let input = dir.path().join("bunny.gcode");
    std::fs::write(&input, format!("{}M73 P99 R249\n{}", &text[..at], &text[at..])).unwrap();
    let out = dir.path().join("out.gcode");
    let written = transform(&["purge-shift", input.to_str().unwrap(), "--purge-mm", "2.5"], &out);
    let (p, r) = (m73_of(&written, 'P'), m73_of(&written, 'R'));
    assert_eq!((p, r), (vec![25], vec![249]));
}

#[test]
fn a_second_run_on_gzip_or_binary_output_is_refused() {
    // The header lives in the text a container holds: the refusal reads through it.
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("prusaslicer/pr_bunny_3tool_rel.gcode");
    for name in ["once.gcode.gz", "once.bgcode"] {
        let once = dir.path().join(name);
        ok(gweave(&["purge-shift", &input, "--purge-mm", "2.5", "-o", once.to_str().unwrap(), "-q"]));
        let twice = dir.path().join(format!("twice-{name}"));
        let out = gweave(&[
            "purge-shift",
            once.to_str().unwrap(),
            "--purge-mm",
            "2.5",
            "-o",
            twice.to_str().unwrap(),
        ]);
        assert!(!out.status.success(), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("a second purge-shift would stack on the first"), "{name}: {err}");
        assert!(!twice.exists(), "{name}");
    }
}

/// Regression: `raster --test-pattern` and `mix --calibration-card` wrote no `; gweave ...`
/// header nor the metadata footer, unlike every other command that writes G-code
/// (`rotary tube` and `raster` of images have them, checked above).
#[test]
fn generators_outputs_carry_the_gweave_header() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pattern.gcode");
    let text = transform(&["raster", "--test-pattern", "--pattern-columns", "2"], &out);
    check_output(&text, &out, "raster --test-pattern --pattern-columns 2", Time::Own);
    assert!(text.contains("\n; filament used [mm] = 0.00\n"), "{text}");
    let out = dir.path().join("card.gcode");
    let text = transform(&["mix", "--calibration-card"], &out);
    check_output(&text, &out, "mix --calibration-card", Time::Own);
    // 30 swatches on the default CMYW hotend, each its own virtual tool, and the time.
    let used = text.lines().find(|l| l.starts_with("; filament used [mm] = ")).unwrap();
    assert!(used.split(", ").count() >= 16, "{used}");
    assert!(text.contains("\n; estimated printing time (normal mode) = "), "{text}");
}
