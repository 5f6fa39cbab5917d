//! The inkjet build's timing on the emulated board (run by `bench/firmware.sh`, not a test):
//! the nozzle pulses decoded from the InkShield's pins against the InkShield's own timing
//! (5 us pulses; `NicholasCLewis/InkShield`), and how fast a host can fire: `M700` alone, and
//! columns as `gweave raster` writes them (`G1` one pixel, `M400`, `M700`).
//!
//! `cargo run --release -p gweave-board --example inkjet_budgets -- firmware/out/gweave-ramps-inkjet.elf`

use gweave_board::{Board, Wiring, CPU_HZ};

/// Fires (and columns) per measurement.
const FIRES: usize = 200;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let elf = std::env::args().nth(1).ok_or("usage: inkjet_budgets FIRMWARE.elf")?;
    let wiring = Wiring { start_steps: [400, 400, 200], ..Wiring::default() };
    let mut board = Board::new(elf.as_ref(), wiring)?;
    board.run_until_line(|l| l == "start", 1.0)?;
    board.time_step_interrupt();
    for line in ["G28", "G1 X20 Y20 F3000", "M400"] {
        board.command(line, 60.0)?;
    }
    let us = |cycles: u64| cycles as f64 * 1e6 / f64::from(CPU_HZ);

    // Every nozzle, fire after fire: the refill wait is the limit.
    let start = board.cycle();
    for _ in 0..FIRES {
        board.command("M700 P0 S4095", 5.0)?;
    }
    let fire_s = (board.cycle() - start) as f64 / f64::from(CPU_HZ);
    // Columns one pixel apart, as `gweave raster` writes them.
    let start = board.cycle();
    for i in 1..=FIRES {
        let x = 20.0 + (i as f64 + 0.5) * 25.4 / 96.0;
        for line in [format!("G1 X{x:.4}"), "M400".into(), "M700 P0 S4095".into()] {
            board.command(&line, 5.0)?;
        }
    }
    let column_s = (board.cycle() - start) as f64 / f64::from(CPU_HZ);

    let ink = &mut board.shield_mut().inkshield;
    let fires = ink.finish().len();
    let t = ink.timing;
    let opt = |c: Option<u64>| c.map_or(f64::NAN, us);
    println!("fires decoded: {fires} of {} sent, faults {}", 2 * FIRES, t.faults);
    println!(
        "nozzle pulse: {:.2} to {:.2} us   InkShield: 5 us (its library's delayMicroseconds(5))",
        opt(t.width_min),
        opt(t.width_max)
    );
    println!("gap between two nozzles: at least {:.2} us   goal >= 1 us", opt(t.gap_min));
    println!("between two fires of the head: at least {:.0} us   C6602 refill: >= 800 us", opt(t.refill_min));
    println!(
        "M700 P0 S4095 streamed: {:.0} fires/s ({:.2} ms each)   refill limit: 1250/s",
        FIRES as f64 / fire_s,
        fire_s * 1000.0 / FIRES as f64
    );
    println!(
        "raster columns (G1 one pixel, M400, M700): {:.0} columns/s ({:.2} ms each)   seed: one column per M700 + M400",
        FIRES as f64 / column_s,
        column_s * 1000.0 / FIRES as f64
    );
    println!(
        "step interrupt meanwhile: longest {} cycles, mean {}",
        board.step_interrupt_max_cycles(),
        board.step_interrupt_mean_cycles()
    );
    Ok(())
}
