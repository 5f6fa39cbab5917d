//! Two extruders on the test image (`make firmware-fault`, built from `firmware/printer-eeb.toml`:
//! RAMPS "EEB", a second hotend on D9 and A15, a second extruder on the E1 socket): a real
//! two-extruder file prints with each extruder's STEP pulses, counted on its socket's pins,
//! equal to the virtual printer's (`gweave sim --machine gweave-ramps-eeb`: the same core on
//! the host) and to its Marlin model's per tool.

use std::path::{Path, PathBuf};

use gweave_board::Wiring;
use gweave_sim::{run_on_core, MachineProfile};

/// The E0 and E1 sockets.
const EXTRUDERS: [usize; 2] = [3, 4];

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

/// Regression (the thirty-second session's breaking session: `T1` was accepted on the EEB board
/// but every E step went to E0's socket): the first 420 lines of a PrusaSlicer two-extruder
/// screw (`tests/data/prusaslicer/pr_screw_2t_trim.gcode`: its start, T0's first layer, T1's,
/// and back to T0) step E1's socket between `T1` and `T0` and E0's around them, as many pulses
/// on each as the virtual printer's core makes, none on a disabled driver.
#[test]
fn t1_prints_with_the_second_extruder_on_the_eeb_board() {
    let text = std::fs::read_to_string(repo("tests/data/prusaslicer/pr_screw_2t_trim.gcode")).unwrap();
    let lines: Vec<&str> = text.lines().take(420).collect();
    let mut board = crate::common::eeb_board(Wiring { record_steps: true, ..Wiring::default() });
    // A printer just used: both hotends at the file's targets, so `M109` returns at once (the
    // steps do not depend on how long heating takes). Plant 2 is hotend 1's, on D9.
    for (plant, c) in [(0, 210.0), (2, 215.0)] {
        board.shield_mut().plants[plant].heater.set_temperature(c);
    }
    let pulses = |board: &gweave_board::Board, socket: usize| {
        board.axis(socket).steps_plus + board.axis(socket).steps_minus
    };
    let mut at_t1 = None;
    for line in &lines {
        let code = line.split(';').next().unwrap_or_default().trim();
        if code.is_empty() {
            continue;
        }
        if code == "T1" {
            assert_eq!(board.command("M400", 60.0).unwrap().last().unwrap(), "ok");
            at_t1 = Some(EXTRUDERS.map(|s| pulses(&board, s)));
        }
        let reply = board.command(code, 120.0).unwrap();
        assert!(!reply.iter().any(|l| l.starts_with("Error:") || l.contains("cold")), "{code}: {reply:?}");
    }
    assert_eq!(board.command("M400", 120.0).unwrap().last().unwrap(), "ok");
    let on_board = EXTRUDERS.map(|s| pulses(&board, s));
    let profile = MachineProfile::from_file(&repo("examples/machines/gweave-ramps-eeb.toml")).unwrap();
    let mut next = lines.iter().map(|l| l.as_bytes().to_vec());
    let expected = run_on_core(&profile, &mut || next.next()).unwrap();
    assert!(!expected.halted && expected.errors.is_empty(), "{:?}", expected.errors);
    assert_eq!(on_board.to_vec(), expected.extruder_steps);
    // Until `T1` only E0 ran; both ran a layer's worth.
    let at_t1 = at_t1.expect("a T1 in the lines");
    assert!(at_t1[0] > 1000 && at_t1[1] == 0, "{at_t1:?}");
    assert!(on_board[1] > 1000, "{on_board:?}");
    for socket in EXTRUDERS {
        assert_eq!(board.axis(socket).steps_while_disabled, 0, "socket {socket}");
    }
}
