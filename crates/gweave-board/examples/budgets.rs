//! The firmware's budgets on the emulated board (run by `bench/firmware.sh`, not a test):
//! the stack's high-water mark over a working session, and the highest step rate the step
//! interrupt keeps up with on one axis and on X+Y+E together; with `--mixing` (the mixing
//! image), on X, Y and the four inputs of the mixing hotend together instead.
//!
//! `cargo run --release -p gweave-board --example budgets -- firmware/out/gweave-ramps.elf`
//! `cargo run --release -p gweave-board --example budgets -- firmware/out/gweave-ramps-mixing.elf --mixing`

use gweave_board::{Board, Wiring, CPU_HZ};

/// Top of the ATmega2560's RAM: the stack starts here and grows down.
const RAMEND: u16 = 0x21FF;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let elf = std::env::args().nth(1).ok_or("usage: budgets FIRMWARE.elf [--mixing]")?;
    let mut board = Board::new(elf.as_ref(), Wiring { record_steps: true, ..Wiring::default() })?;
    board.run_until_line(|l| l == "start", 1.0)?;
    if std::env::args().nth(2).as_deref() == Some("--mixing") {
        return mixing_rates(&mut board);
    }
    board.time_step_interrupt();
    // A working session: every reply path, homing, moves, heating, settings.
    for line in ["M115", "M503", "G28", "G1 X50 Y50 Z5 F6000", "M104 S200", "M105", "M114", "M119", "M400"] {
        board.command(line, 120.0)?;
    }
    board.run_for(5.0)?;
    let sp = board.min_stack_pointer();
    println!("stack high-water mark: {} bytes (lowest SP {sp:#06x})", RAMEND - sp);
    println!(
        "step interrupt: longest {} cycles, mean {} cycles",
        board.step_interrupt_max_cycles(),
        board.step_interrupt_mean_cycles()
    );

    // A host streaming short segments, one line after each `ok`: does the planner run dry?
    for line in ["G28", "G90", "G1 X10 Y10 F3600", "M400"] {
        board.command(line, 60.0)?;
    }
    let first = board.axis(0).step_log.len();
    for i in 1..=200 {
        board.command(&format!("G1 X{:.1} F3600", 10.0 + 0.5 * f64::from(i)), 5.0)?;
    }
    board.command("M400", 10.0)?;
    let log = &board.axis(0).step_log[first..];
    // The middle of the run, away from the ramps at either end: at 60 mm/s a step every
    // 3333 cycles; a gap of two steps' time means the planner had nothing left to run.
    let middle = &log[log.len() / 10..log.len() * 9 / 10];
    let longest = middle.windows(2).map(|w| w[1].0 - w[0].0).max().unwrap_or(0);
    println!(
        "0.5 mm segments at 60 mm/s over {} baud: longest step gap {:.2} ms ({})",
        250_000,
        longest as f64 / f64::from(CPU_HZ) * 1000.0,
        if longest > 2 * 3333 { "the planner ran dry" } else { "never dry" }
    );

    // Limits out of the way, so the rate is the interrupt's, not the planner's; the hotend
    // hot (unheated), or the core would drop E (it has no M302).
    board.shield_mut().plants[0].heater.set_temperature(210.0);
    board.run_for(0.3)?;
    limits_out_of_the_way(&mut board)?;
    for (name, axes) in [("X alone", &[(0usize, 1.0)][..]), ("X+Y+E", &[(0, 1.0), (1, 1.0), (3, 1.0)][..])] {
        highest_rate_held(&mut board, name, axes, &[axes[0].0], 2_500)?;
    }
    Ok(())
}

/// The hotend hot (unheated), or the core would drop E (it has no M302), and the limits out of
/// the way, so the rate is the interrupt's, not the planner's; the software endstops off too:
/// the rising rates run X on past the end of the homed 200 mm rail.
fn limits_out_of_the_way(board: &mut Board) -> Result<(), Box<dyn std::error::Error>> {
    board.shield_mut().plants[0].heater.set_temperature(210.0);
    board.run_for(0.3)?;
    for line in [
        "M104 S0",
        "M211 S0",
        "M203 X2000 Y2000 E2000",
        "M201 X200000 Y200000 E200000",
        "M204 P200000 T200000 R200000",
        "G91",
    ] {
        board.command(line, 5.0)?;
    }
    Ok(())
}

/// The mixing image: X, Y and the four inputs (E0 and E1 on their sockets, E2 and E3 on AUX-2)
/// at once, each input a quarter of E (`M165`), so six motors step at the same rate.
fn mixing_rates(board: &mut Board) -> Result<(), Box<dyn std::error::Error>> {
    limits_out_of_the_way(board)?;
    board.command("M165 A0.25 B0.25 C0.25 D0.25", 5.0)?;
    board.time_step_interrupt();
    highest_rate_held(board, "X+Y+4 mixing inputs", &[(0, 1.0), (1, 1.0), (3, 4.0)], &[0, 3, 4, 5, 6], 500)?;
    println!(
        "step interrupt meanwhile: longest {} cycles, mean {} cycles",
        board.step_interrupt_max_cycles(),
        board.step_interrupt_mean_cycles()
    );
    Ok(())
}

/// Raises the rate of `axes` (each `(axis, steps as a multiple of the rate)`) by `step_hz`
/// until one of the `watched` sockets falls 1 % short of it; prints the highest held.
fn highest_rate_held(
    board: &mut Board,
    name: &str,
    axes: &[(usize, f64)],
    watched: &[usize],
    step_hz: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    let mut held_hz = 0;
    for rate_hz in (step_hz as u32..=30_000).step_by(step_hz) {
        let achieved_hz = cruise_rate_hz(board, axes, watched, f64::from(rate_hz))?;
        println!("  {name}: asked {rate_hz} steps/s, held {achieved_hz:.0}");
        if achieved_hz < 0.99 * f64::from(rate_hz) {
            // Faster starves the main loop, and the watchdog resets the board.
            break;
        }
        held_hz = rate_hz;
    }
    println!("highest step rate held, {name}: {held_hz} steps/s per motor");
    Ok(())
}

/// Move `axes` together (each `(axis, factor)`: `factor × rate_hz` steps per second) and return
/// the lowest step rate of the `watched` sockets over the middle half of the move (the cruise).
fn cruise_rate_hz(
    board: &mut Board,
    axes: &[(usize, f64)],
    watched: &[usize],
    rate_hz: f64,
) -> Result<f64, Box<dyn std::error::Error>> {
    const STEPS_PER_MM: [f64; 4] = [80.0, 80.0, 400.0, 93.0];
    // Half a second of steps on each axis; the feed is along the XYZ path (E only paces).
    let steps = rate_hz * 0.5;
    let mut words = String::new();
    let mut path2_mm2 = 0.0;
    for &(a, factor) in axes {
        let mm = factor * steps / STEPS_PER_MM[a];
        words += &format!(" {}{mm:.4}", ["X", "Y", "Z", "E"][a]);
        if a < 3 {
            path2_mm2 += mm * mm;
        }
    }
    let feed_mm_min = f64::sqrt(path2_mm2) / 0.5 * 60.0;
    let first: Vec<usize> = watched.iter().map(|&s| board.axis(s).step_log.len()).collect();
    board.command(&format!("G1{words} F{feed_mm_min:.1}"), 10.0)?;
    board.command("M400", 10.0)?;
    let mut lowest = f64::INFINITY;
    for (&socket, &first) in watched.iter().zip(&first) {
        let log = &board.axis(socket).step_log[first..];
        let (a, b) = (log.len() / 4, 3 * log.len() / 4);
        if b <= a + 1 {
            return Ok(0.0);
        }
        let cycles = (log[b].0 - log[a].0) as f64;
        lowest = lowest.min((b - a) as f64 * f64::from(CPU_HZ) / cycles);
    }
    Ok(lowest)
}
