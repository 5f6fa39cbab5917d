//! `gweave sim` with `[firmware] kind = "gweave"`: the file runs on gweave's own controller core
//! (the firmware of the RAMPS board), and ends where the Marlin model ends.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

/// The `Count X.. Y.. Z..` of a summary's end position line.
fn counts(stdout: &str) -> Vec<i64> {
    let line = stdout.lines().find(|l| l.contains("end position")).expect("an end position line");
    let tail = &line[line.find("Count").expect("counts")..];
    tail.split(|c: char| !(c.is_ascii_digit() || c == '-')).filter_map(|w| w.parse().ok()).take(3).collect()
}

#[test]
fn sim_on_the_controller_core_ends_where_the_marlin_model_ends() {
    // The first layers of a real Cura file, without the heating waits (minutes of board time):
    // both machines refuse the cold extrusion alike, and move alike.
    let text = std::fs::read_to_string(repo("tests/data/cura/cura_torus.gcode")).unwrap();
    let cut: String = text
        .lines()
        .take(1500)
        .filter(|l| !(l.starts_with("M109") || l.starts_with("M190")))
        .flat_map(|l| [l, "\n"])
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cut.gcode");
    std::fs::write(&file, cut).unwrap();
    let core_profile = repo("examples/machines/gweave-ramps.toml");
    let marlin_profile = dir.path().join("marlin.toml");
    let profile = std::fs::read_to_string(&core_profile).unwrap();
    std::fs::write(&marlin_profile, profile.replace("kind = \"gweave\"", "kind = \"marlin\"")).unwrap();

    let core = gweave(&["sim", file.to_str().unwrap(), "--machine", core_profile.to_str().unwrap()]);
    let core_out = String::from_utf8_lossy(&core.stdout);
    assert!(core.status.success(), "{core_out}{}", String::from_utf8_lossy(&core.stderr));
    assert!(core_out.contains("(gweave controller core)"), "{core_out}");
    let marlin = gweave(&["sim", file.to_str().unwrap(), "--machine", marlin_profile.to_str().unwrap()]);
    let marlin_out = String::from_utf8_lossy(&marlin.stdout);
    assert!(marlin.status.success(), "{marlin_out}");
    let (core_counts, marlin_counts) = (counts(&core_out), counts(&marlin_out));
    assert_eq!(core_counts.len(), 3);
    assert_eq!(core_counts, marlin_counts, "core:\n{core_out}\nmarlin:\n{marlin_out}");
}

#[test]
fn sim_on_the_controller_core_refuses_the_marlin_models_flags() {
    let profile = repo("examples/machines/gweave-ramps.toml");
    let out = gweave(&["sim", "-", "--machine", profile.to_str().unwrap(), "--plot", "t.png"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--plot is for the Marlin model"), "{stderr}");
}

/// `gweave serve`, killed when the test ends however it ends.
struct Serve(std::process::Child);

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The lines a host reads until one starts with `last`, failing after 20 s.
fn read_through(reader: &mut impl std::io::BufRead, last: &str) -> Vec<String> {
    let mut got = Vec::new();
    loop {
        let mut line = String::new();
        assert!(reader.read_line(&mut line).unwrap() > 0, "the board hung up: {got:?}");
        got.push(line.trim_end().to_owned());
        if line.starts_with(last) {
            return got;
        }
    }
}

#[test]
fn serve_puts_the_controller_core_behind_the_port() {
    use std::io::{BufReader, Write};
    use std::net::{TcpListener, TcpStream};
    use std::time::{Duration, Instant};

    let addr = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    let profile = repo("examples/machines/gweave-ramps.toml");
    let args = ["serve", "--tcp", &addr.to_string(), "--machine", profile.to_str().unwrap()];
    let _server = Serve(Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).spawn().unwrap());
    let deadline = Instant::now() + Duration::from_secs(20);
    let host = loop {
        if let Ok(host) = TcpStream::connect(addr) {
            break host;
        }
        assert!(Instant::now() < deadline, "the server never listened");
        std::thread::sleep(Duration::from_millis(20));
    };
    host.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    let mut reader = BufReader::new(host.try_clone().unwrap());
    assert_eq!(read_through(&mut reader, "start"), ["start"]);
    (&host).write_all(b"N0 M110 N0*125\nN1 G28*18\nN2 M114*37\n").unwrap();
    let mut got = read_through(&mut reader, "X:");
    got.retain(|l| l != "echo:busy: processing");
    assert_eq!(got, ["ok", "ok", "X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0"]);
    (&host).write_all(b"M115\n").unwrap();
    let got = read_through(&mut reader, "FIRMWARE_NAME");
    assert!(got.last().unwrap().starts_with("FIRMWARE_NAME:gweave-controller"), "{got:?}");
}

/// `steps.mixing` of the Marlin model's JSON report, or `mixing_steps` of the core's.
fn mixing_steps(out: &Output) -> Vec<u64> {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let steps = report.pointer("/steps/mixing").or(report.get("mixing_steps")).expect("mixing steps");
    steps.as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect()
}

#[test]
fn gweave_mix_output_splits_alike_on_the_core_and_the_marlin_model() {
    // The seed's layer schedule on a Cura torus: virtual tools from M163/M164, T<n> at the
    // layer changes, purges; heated, so every extrusion runs. Each input's steps on the
    // controller core's mixer equal the Marlin model's, exactly.
    let dir = tempfile::tempdir().unwrap();
    let mixed = dir.path().join("torus.mix.gcode");
    let config = repo("examples/mix/seed_layers.toml");
    let input = repo("tests/data/cura/cura_torus.gcode");
    let mix = gweave(&[
        "mix",
        input.to_str().unwrap(),
        "-c",
        config.to_str().unwrap(),
        "-o",
        mixed.to_str().unwrap(),
    ]);
    assert!(mix.status.success(), "{}", String::from_utf8_lossy(&mix.stderr));
    let core_profile = repo("examples/machines/gweave-mixing.toml");
    let marlin_profile = dir.path().join("marlin.toml");
    let profile = std::fs::read_to_string(&core_profile).unwrap();
    std::fs::write(&marlin_profile, profile.replace("kind = \"gweave\"", "kind = \"marlin\"")).unwrap();
    let sim =
        |p: &Path| gweave(&["sim", mixed.to_str().unwrap(), "--machine", p.to_str().unwrap(), "--json"]);
    let (core, marlin) = (mixing_steps(&sim(&core_profile)), mixing_steps(&sim(&marlin_profile)));
    assert_eq!(core, marlin);
    // The torus has 28 layers: Orange and Pink only, no cyan (E0).
    assert_eq!(core, [0, 31815, 40121, 12189]);
}

/// Regression (the thirty-second session's breaking session: on the EEB board `T1` was accepted
/// but every E step went to E0): a real two-extruder PrusaSlicer file, both hotends heated, runs
/// on the core's EEB board (`--machine gweave-ramps-eeb`) with each extruder's steps equal to
/// the Marlin model's per tool, exactly, and shown in the summary.
#[test]
fn a_two_extruder_file_steps_each_extruder_alike_on_the_core_and_the_marlin_model() {
    let dir = tempfile::tempdir().unwrap();
    let input = repo("tests/data/prusaslicer/pr_screw_2t_trim.gcode");
    let core_profile = repo("examples/machines/gweave-ramps-eeb.toml");
    let marlin_profile = dir.path().join("marlin.toml");
    let profile = std::fs::read_to_string(&core_profile).unwrap();
    std::fs::write(&marlin_profile, profile.replace("kind = \"gweave\"", "kind = \"marlin\"")).unwrap();
    let sim = |p: &Path, json: bool| {
        let mut args = vec!["sim", input.to_str().unwrap(), "--machine", p.to_str().unwrap()];
        args.extend(json.then_some("--json"));
        let out = gweave(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        out
    };
    let steps = |out: &Output, pointer: &str| -> Vec<u64> {
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let steps = report.pointer(pointer).unwrap_or_else(|| panic!("{pointer} in the report"));
        steps.as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect()
    };
    let core = steps(&sim(&core_profile, true), "/extruder_steps");
    assert_eq!(core, steps(&sim(&marlin_profile, true), "/steps/tools"));
    // Four changes each way: both extruders print.
    assert_eq!(core, [11944, 10570]);
    let summary = String::from_utf8(sim(&core_profile, false).stdout).unwrap();
    assert!(summary.contains("  extruder steps  E0 11944 E1 10570\n"), "{summary}");
}
