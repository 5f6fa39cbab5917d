//! `sim` and `serve` on inkjet machines: the canvases of one layer are held, however many layers
//! a file or a host fires, and fires the firmware ignores leave nothing behind (issue B6: every
//! layer's canvases were kept, 114 MiB for 3 000 layers of a 20 000 x 20 000 pitch canvas and an
//! abort under a 4 GB limit; a host aborted `serve` after 82 layers).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use gweave_sim::test_support::{connect, lines_through, lines_until_ok};

use crate::harness::*;
use crate::serve::Server;

/// `gweave machine show binder-jet` with its canvas `side_px` nozzle pitches square and
/// `heads` heads, written to `big.toml` in `dir`.
fn binder_jet(dir: &Path, side_px: usize, heads: usize) {
    let shown = gweave(dir, &["machine", "show", "binder-jet"]).run();
    shown.assert_ok();
    let mut toml: String = shown
        .stdout_text()
        .lines()
        .map(|l| match l.split('=').next().map(str::trim) {
            Some(key @ ("width_px" | "height_px")) => format!("{key} = {side_px}\n"),
            _ => format!("{l}\n"),
        })
        .collect();
    assert_eq!(toml.matches(&format!("_px = {side_px}")).count(), 2, "{toml}");
    // The profile's one head is its last table: more are added after it, 5 mm apart.
    for h in 1..heads {
        let _ = write!(toml, "\n[[inkjet.printhead.heads]]\noffset_x_mm = {}.0\n", 5 * h);
    }
    std::fs::write(dir.join("big.toml"), toml).unwrap();
}

/// `layers` layers of one full fire of each of `heads` heads, 0.01 mm apart, as the issue's
/// reproduction fires them.
fn fire_lines(layers: usize, heads: usize) -> String {
    let mut text = String::from("G28\n");
    for k in 1..=layers {
        let _ = write!(text, "G1 Z{:.2} F300\nG1 X30 Y30 F3000\nM400\n", 0.01 * k as f64);
        for h in 0..heads {
            let _ = writeln!(text, "M700 P{h} S4095");
        }
    }
    text
}

#[test]
fn sim_keeps_one_inkjet_layer_of_the_largest_canvas() {
    let dir = tempfile::tempdir().unwrap();
    binder_jet(dir.path(), 20_000, 1);
    std::fs::write(dir.path().join("fire.gcode"), fire_lines(3000, 1)).unwrap();
    let run = gweave(dir.path(), &["sim", "fire.gcode", "--machine", "big.toml", "--json", "-q"]).run();
    run.assert_ok().assert_peak_under(64.0);
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(report["inkjet"]["layers"], 3000);
    assert_eq!(report["inkjet"]["drops_per_head"], serde_json::json!([36000]));
}

/// Sixteen heads of that canvas (766 MiB a layer) are refused before the first line is read.
#[test]
fn sim_refuses_a_layer_past_the_canvas_budget_naming_the_keys() {
    let dir = tempfile::tempdir().unwrap();
    binder_jet(dir.path(), 20_000, 16);
    std::fs::write(dir.path().join("fire.gcode"), fire_lines(4, 16)).unwrap();
    gweave(dir.path(), &["sim", "fire.gcode", "--machine", "big.toml"])
        .run()
        .assert_refused("the inkjet canvases of one layer, 20000 x 20000 nozzle pitches for each of 16 heads, would take 765.7 MiB, more than the limit of 64 MiB: give a smaller [inkjet] width_px and height_px")
        .assert_peak_under(64.0);
}

/// A million `M700 S1` (no head named: the firmware fires nothing) were a million warnings kept
/// by the canvas, 51 MiB; the report keeps the first thousand and counts the rest.
#[test]
fn a_million_ignored_fires_keep_memory_flat() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("nohead.gcode"), "M700 S1\n".repeat(1_000_000)).unwrap();
    let run = gweave(dir.path(), &["sim", "nohead.gcode", "--machine", "binder-jet", "--json", "-q"]).run();
    run.assert_ok().assert_peak_under(32.0);
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(report["warning_counts"]["inkjet"], 1_000_000);
    assert_eq!(report["warnings"].as_array().unwrap().len(), 1000);
}

/// A host prints 100 layers of four heads on a 10 000 x 10 000 pitch canvas through `serve`
/// (50 MiB a layer, within the budget; a layer more a layer kept aborted the server after 82).
#[test]
fn serve_keeps_one_inkjet_layer_whatever_the_host_prints() {
    let dir = tempfile::tempdir().unwrap();
    binder_jet(dir.path(), 10_000, 4);
    let (server, addr) = Server::tcp(dir.path(), &["--machine", "big.toml"]);
    let (mut host, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    // A layer at a time, each line answered before the next layer is sent.
    for layer in fire_lines(100, 4).split_inclusive("M700 P3 S4095\n") {
        host.write_all(layer.as_bytes()).unwrap();
        let got = lines_until_ok(&mut reader, layer.lines().count());
        assert!(got.iter().all(|l| l == "ok" || l.starts_with("echo:busy")), "{got:?}");
    }
    host.write_all(b"M105\n").unwrap();
    lines_through(&mut reader, "ok T:");
    drop((host, reader));
    server.stop().assert_ok().assert_peak_under(64.0);
}
