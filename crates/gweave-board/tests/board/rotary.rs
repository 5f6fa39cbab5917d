//! The rotary image (`firmware/out/gweave-ramps-rotary.elf`, built by `make firmware` from
//! `firmware/printer-rotary.toml`: the mandrel's axis A on RAMPS's E1 socket, 3200 steps per
//! turn, F read the NIST way) printing `gweave rotary` output on the emulated board: the STEP
//! pulses of the mandrel (E1 socket), of X along it and of Z off it, counted on the pins, equal
//! the virtual printer's, both the core's twin (`gweave sim --machine
//! examples/machines/gweave-rotary.toml`) and the simulator's own Marlin model of the same
//! machine; and a pure-A move turns at the speed its F says.
//!
//! The counts are those after the file's `G28`: the homing moves' own steps depend on where
//! each machine happens to start (the board 20 mm above Z's endstop, the twin 50 mm).

use std::path::{Path, PathBuf};

use gweave::rotary::cylinder::RotaryConfig;
use gweave_board::{Board, Wiring};
use gweave_sim::{run_on_core, CoreReport};
use gweave_sim::{FirmwareKind, Machine, MachineProfile};

/// The sockets: X, Z, E0 and E1 (the mandrel).
const X: usize = 0;
const Z: usize = 2;
const E0: usize = 3;
const A: usize = 4;

/// `gweave rotary tube -o rotary_tube.gcode --mandrel-diameter 20 --length 2 --layer-count 2`:
/// two interwoven helical layers of 5 turns each (3600 degrees), 32 s of printing.
const TUBE: &str = include_str!("../data/rotary_tube.gcode");

/// The first 120 lines of `tests/data/rotary/plate.gcode` (PrusaSlicer's start, the first
/// layer's perimeter and the start of its infill) through `gweave rotary wrap
/// --mandrel-diameter 30`: 670 lines, 31 s of printing round a 30 mm mandrel.
const WRAPPED: &str = include_str!("../data/plate_start.wrap.gcode");

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

fn profile() -> MachineProfile {
    MachineProfile::from_file(&repo("examples/machines/gweave-rotary.toml")).unwrap()
}

/// What `gweave sim --machine examples/machines/gweave-rotary.toml` reports for `text`: the
/// firmware's core on the host.
fn twin(text: &str) -> CoreReport {
    let mut next = text.lines().map(|l| l.as_bytes().to_vec());
    let report = run_on_core(&profile(), &mut || next.next()).unwrap();
    assert!(!report.halted && report.errors.is_empty(), "{:?}", report.errors);
    report
}

/// The X, Z, E and A step pulses of the simulator's Marlin model of the same machine, reading F
/// by the convention the file's header declares (as `gweave sim` does).
fn marlin_model(text: &str) -> [u64; 4] {
    let mut profile = profile();
    profile.firmware.kind = FirmwareKind::Marlin;
    let mut machine = Machine::new(profile).unwrap();
    machine.declare_rotary(RotaryConfig::from_header(text).expect("a rotary program's header"));
    let mut errors = Vec::new();
    let mut out = |_: f64, l: &str| {
        if l.starts_with("Error:") {
            errors.push(l.to_owned());
        }
    };
    for line in text.lines() {
        machine.execute(line.as_bytes(), &mut out);
    }
    machine.finish(&mut out);
    assert!(errors.is_empty(), "{errors:?}");
    let steps = machine.report().steps.axes;
    [steps[0], steps[2], steps[3], steps[4]]
}

/// The lines a host sends: comments and blank lines are not.
fn sent(line: &str) -> Option<&str> {
    let code = line.split(';').next().unwrap_or_default().trim();
    (!code.is_empty()).then_some(code)
}

/// A board with the rotary image, the hotend at `hotend_c` and held there (`M104`), as a printer
/// on standby: the file's `M109` returns at once (the steps do not depend on how long heating
/// takes, and the board's seconds are precious).
fn board(hotend_c: f64) -> Board {
    // The image `make firmware` built from `firmware/printer-rotary.toml`.
    let elf = crate::common::image("GWEAVE_ROTARY_FIRMWARE_ELF", "gweave-ramps-rotary.elf");
    let mut board = Board::new(&elf, Wiring { record_steps: true, ..Wiring::default() }).unwrap();
    board.shield_mut().plants[0].heater.set_temperature(hotend_c);
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    assert_eq!(board.command(&format!("M104 S{hotend_c}"), 1.0).unwrap().last().unwrap(), "ok");
    board
}

/// The lines of `text` up to its homing line (`G28 ...`), included (the header too).
fn through_homing(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let g28 = lines.iter().position(|l| l.starts_with("G28")).expect("the file homes");
    lines[..=g28].join("\n")
}

/// Prints `text` on the board to the end; returns the X, Z, E0 and A pulses after its `G28`.
fn print(board: &mut Board, text: &str) -> [u64; 4] {
    let pulses = |board: &Board| [X, Z, E0, A].map(|s| board.axis(s).steps_plus + board.axis(s).steps_minus);
    let mut homed = None;
    for line in text.lines().filter_map(sent) {
        let reply = board.command(line, 120.0).unwrap();
        assert!(!reply.iter().any(|l| l.starts_with("Error:")), "{line}: {reply:?}");
        if line.starts_with("G28") {
            homed = Some(pulses(board));
        }
    }
    assert_eq!(board.command("M400", 120.0).unwrap().last().unwrap(), "ok");
    for socket in [X, Z, E0, A] {
        assert_eq!(board.axis(socket).steps_while_disabled, 0, "socket {socket}");
    }
    let homed = homed.expect("the file homes");
    let end = pulses(board);
    std::array::from_fn(|i| end[i] - homed[i])
}

/// The twin's X, Z, E0 and A pulses after the file's `G28`.
fn twin_pulses(text: &str) -> [u64; 4] {
    let pulses = |r: CoreReport| {
        [r.axis_steps[0], r.axis_steps[2], r.axis_steps[3], r.rotary_steps.expect("a rotary axis")]
    };
    let (end, homed) = (pulses(twin(text)), pulses(twin(&through_homing(text))));
    std::array::from_fn(|i| end[i] - homed[i])
}

/// The Marlin model's X, Z, E0 and A pulses after the file's `G28`.
fn marlin_pulses(text: &str) -> [u64; 4] {
    let (end, homed) = (marlin_model(text), marlin_model(&through_homing(text)));
    std::array::from_fn(|i| end[i] - homed[i])
}

#[test]
fn gweave_rotary_tube_prints_with_the_virtual_printers_steps() {
    let mut board = board(190.0);
    let on_board = print(&mut board, TUBE);
    assert_eq!(on_board, twin_pulses(TUBE), "X, Z, E0, A on the board and on the twin");
    // X: the approach to 0.2 mm, then 1.6 mm out and back (128 steps each way); Z: 0.2 mm down
    // to the first layer, 0.2 mm up to the second, 5 mm off the part at the end; E: 21.31625 mm
    // at 93 steps/mm; A: two layers of 5 turns and the half turns closing their ends, 3600
    // degrees at 3200 steps a turn.
    assert_eq!(on_board, [16 + 2 * 128, 80 + 80 + 2000, 1982, 32_000]);
    assert_eq!(on_board, marlin_pulses(TUBE), "the simulator's Marlin model");
}

#[test]
fn gweave_rotary_wrap_output_prints_with_the_virtual_printers_steps() {
    let mut board = board(200.0);
    let on_board = print(&mut board, WRAPPED);
    assert_eq!(on_board, twin_pulses(WRAPPED), "X, Z, E0, A on the board and on the twin");
    // The perimeter goes round the mandrel and back (0.859 to 359.141 degrees and back: at
    // least 2 x 3184 steps), then the infill's diagonals turn it some more.
    assert!(on_board[3] > 2 * 3184, "{on_board:?}");
    assert_eq!(on_board, marlin_pulses(WRAPPED), "the simulator's Marlin model");
}

#[test]
fn a_pure_a_move_turns_at_f_degrees_per_minute_on_the_board() {
    // G1 A360 F3600 under NIST: 60 deg/s, 533.3 steps/s, a step every 1875 us: 30 000 cycles
    // of the 16 MHz chip. The cruise (the most common interval) within 1 %.
    let mut board = board(20.0);
    assert_eq!(board.command("G1 A360 F3600", 5.0).unwrap().last().unwrap(), "ok");
    assert_eq!(board.command("M400", 20.0).unwrap().last().unwrap(), "ok");
    let log = &board.axis(A).step_log;
    assert_eq!(log.len(), 3200);
    assert!(log.iter().all(|&(_, dir)| dir == 1));
    let mut intervals: Vec<u64> = log.windows(2).map(|w| w[1].0 - w[0].0).collect();
    intervals.sort_unstable();
    let cruise = intervals[intervals.len() / 2] as f64;
    let planned = 16e6 / (60.0 * 3200.0 / 360.0);
    assert!((cruise - planned).abs() / planned < 0.01, "{cruise} cycles, planned {planned}");
    // The whole turn takes its 6 s, and the ramps (7200 deg/s²: 8 ms each) little more.
    let took_s = (log[log.len() - 1].0 - log[0].0) as f64 / 16e6;
    assert!((took_s - 6.0).abs() < 0.02, "{took_s} s");
}

#[test]
fn a_re_declared_angle_steps_alike_on_the_twin_and_the_marlin_model() {
    // On the host only: `rotary tube` re-declares the angle modulo a turn past 36 000 degrees
    // (`G92 A`), `rotary wrap` after each short-way travel. Both count A's steps from where the
    // angle was named, so fractions of a step are neither lost nor counted twice: 3600.4
    // degrees is 32 003.6 steps (32 004); named A0.4 there, A720.4 is 6400 steps on, A-3.3 is
    // -32.9 steps from the naming (6433 back); named A356.7, A360.05 is 29.8 steps on (30).
    let header = "; gweave rotary tube: mandrel 20 mm\n\
                  ; axes: axial X, rotary A (Degrees), radial Z (0 = on the mandrel); feed Nist\n";
    let moves = "G92 A0\nG1 A3600.4 F43200\nG92 A0.4\nG1 A720.4\nG1 A-3.3\nG92 A356.7\nG1 A360.05\n";
    let text = format!("{header}{moves}");
    let r = twin(&text);
    let a = r.rotary_steps.unwrap();
    assert_eq!(a, 32_004 + 6400 + 6433 + 30, "{r:?}");
    assert_eq!(marlin_model(&text)[3], a);
}
