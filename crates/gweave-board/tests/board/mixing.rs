//! The mixing image (`firmware/out/gweave-ramps-mixing.elf`, built by `make firmware` from
//! `firmware/printer-mixing.toml`: a 4-input mixing hotend, E0 and E1 on RAMPS's extruder
//! sockets, E2 and E3 on AUX-2) printing `gweave mix` output on the emulated board: every
//! input's STEP pulses, counted on its pins, equal the virtual printer's (`gweave sim` with
//! `examples/machines/gweave-mixing.toml`: the same core on the host), and each input's share
//! switches at the step where the file changes colour.

use std::path::{Path, PathBuf};

use gweave_board::{Board, Wiring};
use gweave_sim::MachineProfile;
use gweave_sim::{run_on_core, CoreReport};

/// Sockets E0..E3 (E0 on the E0 socket, E1 on E1, E2 and E3 on AUX-2).
const INPUTS: std::ops::Range<usize> = 3..7;

/// The first three layers of `tests/data/cura/cura_torus.gcode` (`head -n 3811`: Cura's start
/// code with its two-line prime, then layers 0 to 2) through
/// `gweave mix torus_3_layers.gcode -c torus_3_layers.toml -o torus_3_layers.mix.gcode`, the
/// configuration beside it: Orange on layer 0 (the prime line included), Pink from layer 1,
/// Blue from layer 2, so every input runs and the colour changes twice, each with a purge.
const MIXED: &str = include_str!("../data/torus_3_layers.mix.gcode");

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

/// The image `make firmware` built from `firmware/printer-mixing.toml`
/// (`GWEAVE_MIXING_FIRMWARE_ELF` overrides the path).
fn mixing_elf() -> PathBuf {
    let path = std::env::var_os("GWEAVE_MIXING_FIRMWARE_ELF")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo("firmware/out/gweave-ramps-mixing.elf"));
    assert!(path.exists(), "{} is missing: run `make firmware` first", path.display());
    path
}

/// What `gweave sim --machine examples/machines/gweave-mixing.toml` reports for `lines`.
fn sim(lines: &[&str]) -> CoreReport {
    let path = repo("examples/machines/gweave-mixing.toml");
    let profile = MachineProfile::from_file(&path).unwrap();
    let mut next = lines.iter().map(|l| l.as_bytes().to_vec());
    run_on_core(&profile, &mut || next.next()).unwrap()
}

/// The lines a host sends: comments and blank lines are not (printcore and OctoPrint strip
/// them; the firmware would ignore them).
fn sent(line: &str) -> Option<&str> {
    let code = line.split(';').next().unwrap_or_default().trim();
    (!code.is_empty()).then_some(code)
}

#[test]
fn gweave_mix_output_prints_with_the_virtual_printers_steps_on_every_input() {
    let mut board = Board::new(&mixing_elf(), Wiring { record_steps: true, ..Wiring::default() }).unwrap();
    // A printer just used: the hotend and the bed at the file's targets, so M190/M109 return at
    // once (the steps do not depend on how long heating takes).
    for (plant, c) in [(0, 215.0), (1, 60.0)] {
        board.shield_mut().plants[plant].heater.set_temperature(c);
    }
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    let lines: Vec<&str> = MIXED.lines().collect();
    for line in lines.iter().filter_map(|l| sent(l)) {
        // Up to its `ok` (`ok T:...` for M105).
        let reply = board.command(line, 120.0).unwrap();
        assert!(!reply.iter().any(|l| l.starts_with("Error:")), "{line}: {reply:?}");
    }
    assert_eq!(board.command("M400", 120.0).unwrap().last().unwrap(), "ok");
    let pulses = |socket: usize| board.axis(socket).steps_plus + board.axis(socket).steps_minus;
    let on_board: Vec<u64> = INPUTS.map(pulses).collect();
    let expected = sim(&lines);
    assert!(!expected.halted && expected.errors.is_empty(), "{:?}", expected.errors);
    assert_eq!(on_board, expected.mixing_steps);
    // Every input ran, none on a disabled driver.
    for socket in INPUTS {
        assert!(pulses(socket) > 1000, "socket {socket}: {on_board:?}");
        assert_eq!(board.axis(socket).steps_while_disabled, 0, "socket {socket}");
    }

    // The split over time: the inputs' pulses in the order the board made them (by cycle).
    let mut events: Vec<(u64, usize)> = INPUTS
        .flat_map(|socket| {
            board.axis(socket).step_log.iter().map(move |&(cycle, _)| (cycle, socket - INPUTS.start))
        })
        .collect();
    events.sort_unstable();
    // At the end of the prime line and at each colour change (the line that selects the new
    // mix), the virtual printer's count of each input for the file up to there equals the
    // board's within one step, taken at the same total of E pulses: the board changed the
    // ratio at the step the file says.
    let prime_end = lines.iter().position(|l| l.contains("Draw the second line")).unwrap();
    let changes = lines.iter().enumerate().filter(|(_, l)| is_mix_change(l)).map(|(i, _)| i);
    let marks: Vec<usize> = std::iter::once(prime_end).chain(changes).collect();
    assert!(marks.len() >= 3, "the prime and two colour changes: {marks:?}");
    for &mark in &marks {
        let prefix = sim(&lines[..=mark]);
        let total: u64 = prefix.mixing_steps.iter().sum();
        let mut split = [0u64; 4];
        for &(_, input) in &events[..total as usize] {
            split[input] += 1;
        }
        for (input, (&board_steps, &sim_steps)) in split.iter().zip(&prefix.mixing_steps).enumerate() {
            assert!(
                board_steps.abs_diff(sim_steps) <= 1,
                "line {} ({}): input E{input} made {board_steps} of the first {total} E steps, \
                 the virtual printer {sim_steps}",
                mark + 1,
                lines[mark]
            );
        }
    }
}

/// A line that selects a mix: a virtual tool (`T<n>`) or a direct mix (`M165`).
fn is_mix_change(line: &str) -> bool {
    let code = sent(line).unwrap_or_default();
    code.starts_with("M165") || (code.starts_with('T') && code[1..].bytes().all(|b| b.is_ascii_digit()))
}

/// Regression: the mixing image held only 3 500 steps/s per motor with X, Y and the four
/// inputs moving (22 500 on X+Y+E0): the planner counted E's total steps as the block's step
/// events after splitting them over the inputs, so the step interrupt ran four events per
/// input step and left the main loop too little time. Here each of the six motors is asked
/// 10 000 steps/s, and must hold it over the cruise.
#[test]
fn x_y_and_four_mixing_inputs_hold_ten_thousand_steps_a_second() {
    const RATE_HZ: f64 = 10_000.0;
    // Half a second of steps on each motor: X and Y 5000 steps (62.5 mm at 80 steps/mm), E
    // four times 5000 (215.05 mm at 93 steps/mm), a quarter to each input by M165.
    const STEPS: usize = 5000;
    let mut board = Board::new(&mixing_elf(), Wiring { record_steps: true, ..Wiring::default() }).unwrap();
    // Hot (unheated), or the core would drop E; the limits out of the way, so the rate is the
    // board's, not the planner's.
    board.shield_mut().plants[0].heater.set_temperature(210.0);
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    board.run_for(0.3).unwrap();
    for line in [
        "M104 S0",
        "M203 X2000 Y2000 E2000",
        "M201 X200000 Y200000 E200000",
        "M204 P200000 T200000 R200000",
        "M165 A0.25 B0.25 C0.25 D0.25",
        "G91",
        "G1 X62.5 Y62.5 E215.0538 F10606.6",
        "M400",
    ] {
        assert_eq!(board.command(line, 10.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    for socket in [0, 1, 3, 4, 5, 6] {
        let log = &board.axis(socket).step_log;
        assert_eq!(log.len(), STEPS, "socket {socket}");
        // The middle half of the move: the cruise.
        let (a, b) = (STEPS / 4, 3 * STEPS / 4);
        let held_hz = (b - a) as f64 * f64::from(gweave_board::CPU_HZ) / (log[b].0 - log[a].0) as f64;
        assert!(held_hz >= 0.99 * RATE_HZ, "socket {socket} held {held_hz:.0} of {RATE_HZ} steps/s");
        assert_eq!(board.axis(socket).steps_while_disabled, 0, "socket {socket}");
    }
}
