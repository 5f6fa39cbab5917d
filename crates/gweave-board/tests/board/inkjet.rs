//! The inkjet build (`gweave-ramps-inkjet.elf`) on the emulated board: `gweave raster`'s
//! output streamed line by line, the nozzle pulses decoded from the InkShield's pins, and the
//! drops they make equal, pixel for pixel, to the drops `gweave sim` deposits for the same file
//! on the binder-jet machine (`examples/machines/inkjet-c6602.toml`). docs/firmware.md, "Inkjet".

use std::path::{Path, PathBuf};
use std::sync::mpsc;

use gweave::gen::bitmap::ThresholdOptions;
use gweave::gen::raster::{raster_image_stacks, test_pattern, ImageStack, RasterConfig};
use gweave_board::inkshield::{Fire, Timing};
use gweave_board::{Board, Wiring, CPU_HZ};
use gweave_sim::{CanvasGeometry, InkjetCanvas, InkjetLayer, Machine, MachineProfile, Outcome};

/// The firmware's steps per mm (`firmware/printer.toml`, the default printer): X, Y, Z.
const STEPS_PER_MM: [f64; 3] = [80.0, 80.0, 400.0];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The inkjet image `make firmware` built (`GWEAVE_INKJET_FIRMWARE_ELF` overrides the path).
fn inkjet_elf() -> PathBuf {
    let path = std::env::var_os("GWEAVE_INKJET_FIRMWARE_ELF")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("firmware/out/gweave-ramps-inkjet.elf"));
    assert!(path.exists(), "{} is missing: run `make firmware` first", path.display());
    path
}

fn machine_profile() -> MachineProfile {
    let text = std::fs::read_to_string(repo().join("examples/machines/inkjet-c6602.toml")).unwrap();
    MachineProfile::from_toml_str(&text).unwrap()
}

/// What `gweave sim` deposits for `gcode`: the canvas of every layer.
fn sim_layers(gcode: &str) -> Vec<InkjetLayer> {
    let mut machine = Machine::new(machine_profile()).unwrap();
    let (sink, finished) = mpsc::channel();
    machine.send_inkjet_layers_to(Box::new(sink));
    for line in gcode.lines() {
        assert_eq!(machine.execute(line.as_bytes(), &mut |_, _| {}), Outcome::Ok, "{line}");
    }
    machine.finish(&mut |_, _| {});
    finished.try_iter().collect()
}

/// Streams `gcode` to the inkjet board as a host does (a line after each `ok`), starting with
/// the head 5 mm, 5 mm and 0.5 mm from the endstops; returns the fires decoded from the pins.
fn board_fires(gcode: &str) -> (Vec<Fire>, Timing) {
    let wiring = Wiring { start_steps: [400, 400, 200], ..Wiring::default() };
    let mut board = Board::new(&inkjet_elf(), wiring).unwrap();
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    for line in gcode.lines() {
        let command = line.split(';').next().unwrap_or("").trim();
        if command.is_empty() {
            continue;
        }
        let mut reply = board.command(command, 60.0).unwrap();
        // Homing takes seconds: the keepalive says so meanwhile.
        reply.retain(|l| l != "echo:busy: processing");
        assert_eq!(reply, ["ok"], "{command}");
    }
    let ink = &mut board.shield_mut().inkshield;
    (ink.finish().to_vec(), ink.timing)
}

/// The drops of the board's fires, by `gweave sim`'s drop rule (the printhead's nozzle map and
/// pitch), the head's position from the step counts.
fn board_layers(fires: &[Fire], like: &[InkjetLayer]) -> Vec<InkjetLayer> {
    let profile = machine_profile();
    let inkjet = profile.inkjet.as_ref().unwrap();
    let first = &like[0].heads[0];
    let geometry = CanvasGeometry {
        origin_x_mm: inkjet.origin_x_mm,
        origin_y_mm: inkjet.origin_y_mm,
        width_px: first.width(),
        height_px: first.height(),
    };
    let mut canvas = InkjetCanvas::new(&inkjet.printhead, geometry).unwrap();
    let (sink, finished) = mpsc::channel();
    canvas.send_layers_to(Box::new(sink));
    let mut warnings = Vec::new();
    for f in fires {
        let mm = |axis: usize| f.steps[axis] as f64 / STEPS_PER_MM[axis];
        canvas.on_m700(
            Some(u32::from(f.head)),
            u64::from(f.nozzles),
            [mm(0), mm(1), mm(2)],
            false,
            &mut warnings,
        );
    }
    assert!(warnings.is_empty(), "{warnings:?}");
    canvas.finish();
    finished.try_iter().collect()
}

/// The pulses' timing against the InkShield's: 5 us pulses (at most 6), at least a microsecond
/// between two, at least 800 us between two fires of a head, and no fault.
fn assert_inkshield_timing(t: &Timing) {
    let us = |cycles: Option<u64>| cycles.unwrap() as f64 * 1e6 / f64::from(CPU_HZ);
    assert!(us(t.width_min) >= 5.0 && us(t.width_max) <= 6.0, "{t:?}");
    assert!(us(t.gap_min) >= 1.0, "{t:?}");
    assert!(us(t.refill_min) >= 800.0, "{t:?}");
    assert_eq!(t.faults, 0, "{t:?}");
}

fn assert_same_drops(gcode: &str) -> (usize, u64) {
    let want = sim_layers(gcode);
    let (fires, timing) = board_fires(gcode);
    let got = board_layers(&fires, &want);
    assert_eq!(got.len(), want.len());
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert!(
            (g.z_mm - w.z_mm).abs() < 1e-9,
            "layer {k}: Z {} on the board, {} in the sim",
            g.z_mm,
            w.z_mm
        );
        assert_eq!(g.heads, w.heads, "layer {k}");
    }
    assert_inkshield_timing(&timing);
    let drops = want.iter().flat_map(|l| &l.heads).map(|b| b.count_ones()).sum();
    (want.len(), drops)
}

#[test]
fn the_raster_test_pattern_prints_the_drops_gweave_sim_deposits() {
    let printhead = machine_profile().inkjet.unwrap().printhead;
    let mut gcode = Vec::new();
    test_pattern(&mut gcode, &printhead, &RasterConfig::default(), 2).unwrap();
    let (layers, drops) = assert_same_drops(&String::from_utf8(gcode).unwrap());
    // 12 nozzle addresses, 2 columns each, one drop a column.
    assert_eq!((layers, drops), (1, 24));
}

#[test]
fn the_smiley_badge_prints_the_drops_gweave_sim_deposits() {
    // The inkjet document's example drawing (examples/raster/make_layers.py): a 40 x 40 px
    // smiley badge; its first three layers, serpentine, as `gweave raster layers/ --flip-y`.
    let printhead = machine_profile().inkjet.unwrap().printhead;
    let paths = (0..3).map(|k| repo().join(format!("examples/raster/layers/badge_{k}.bmp"))).collect();
    let stack = ImageStack { paths, threshold: ThresholdOptions::default(), flip_y: true };
    let mut gcode = Vec::new();
    raster_image_stacks(&mut gcode, &printhead, &RasterConfig::default(), &[stack], None).unwrap();
    let (layers, drops) = assert_same_drops(&String::from_utf8(gcode).unwrap());
    assert_eq!(layers, 3);
    assert!(drops > 1_000, "{drops} drops");
}
