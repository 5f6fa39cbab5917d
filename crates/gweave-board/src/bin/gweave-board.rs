//! `gweave-board ELF --pty LINK`: the emulated RAMPS board on a pseudo-terminal, for real hosts
//! (Printrun's printcore, OctoPrint, `screen LINK 250000`).
//!
//! The board runs at most as fast as a real one (its clock is held to the wall clock), so a
//! host's timeouts mean what they do with the real board. Opening the link resets the chip, as
//! opening a Mega's USB port does (the serial chip's DTR line pulls RESET low).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Parser;
use gweave_board::{Board, Wiring};
use gweave_sim::{Endpoint, EndpointEvent, PtyEndpoint};

#[derive(Parser)]
#[command(about = "The gweave firmware on an emulated Arduino Mega 2560 + RAMPS 1.4, on a pseudo-terminal")]
struct Args {
    /// The firmware (firmware/out/gweave-ramps.elf from `make firmware`).
    elf: PathBuf,
    /// Where to link the pseudo-terminal hosts open (e.g. /tmp/gweave-ramps).
    #[arg(long)]
    pty: PathBuf,
    /// Run as fast as the emulator can instead of holding to the wall clock.
    #[arg(long)]
    fast: bool,
    /// Stop after this many seconds of board time (default: run until killed).
    #[arg(long)]
    seconds: Option<f64>,
    /// Start with the hotend at this temperature, °C (a printer just used: tests skip the
    /// minute of heating from cold).
    #[arg(long, value_parser = parse_celsius)]
    hotend_c: Option<f64>,
    /// When a host that sent anything closes the port, write what the pins did to this file
    /// (JSON: each axis's position in microsteps from its endstop and its net steps) and exit.
    /// A host that opens and closes the port without a byte (Printrun runs `stty -F PORT -hup`
    /// before it connects) was only setting the line up: the board keeps running.
    #[arg(long)]
    report: Option<PathBuf>,
}

/// Board time run between two looks at the pty: 1 ms.
const TICK_S: f64 = 0.001;

fn main() -> std::process::ExitCode {
    match run(Args::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gweave-board: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    let mut board = Board::new(&args.elf, Wiring::default())?;
    if let Some(c) = args.hotend_c {
        board.shield_mut().plants[0].heater.set_temperature(c);
    }
    // Ctrl-C or a TERM ends the loop, so that the endpoint's drop removes the link (the
    // default action killed the process and left the link behind). Installed before the link
    // exists: a signal sent the moment it appears (CI's test, on a loaded machine) found the
    // default action still in place.
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop)).context("installing the signal handler")?;
    }
    let mut pty = PtyEndpoint::open(&args.pty).with_context(|| format!("opening {}", args.pty.display()))?;
    eprintln!("gweave-board: {} on {}", args.elf.display(), args.pty.display());
    let start = Instant::now();
    let start_board_s = board.now_s();
    let mut buf = [0u8; 512];
    // Bytes the connected host has sent since it opened the port.
    let mut session_bytes = 0usize;
    while !stop.load(Ordering::Relaxed) {
        if args.seconds.is_some_and(|s| board.now_s() >= s) {
            return Ok(());
        }
        match pty.wait(&mut buf, Duration::ZERO)? {
            EndpointEvent::Connected => {
                session_bytes = 0;
                board.reset();
            }
            EndpointEvent::Data(n) => {
                session_bytes += n;
                board.send(&buf[..n]);
            }
            EndpointEvent::Disconnected => {
                if let Some(path) = args.report.as_ref().filter(|_| session_bytes > 0) {
                    return write_report(&board, path);
                }
            }
            EndpointEvent::Nothing => {}
        }
        board.run_for(TICK_S)?;
        let out = board.take_serial();
        if !out.is_empty() && pty.send(&out, &stop).is_err() {
            pty.hang_up();
        }
        if !args.fast {
            let ahead_s = (board.now_s() - start_board_s) - start.elapsed().as_secs_f64();
            if ahead_s > 0.0 {
                std::thread::sleep(Duration::from_secs_f64(ahead_s));
            }
        }
    }
    Ok(())
}

/// The pins' account of the session: per socket (X, Y, Z, E0, E1) the position in microsteps
/// and the net steps, with the board time.
fn write_report(board: &Board, path: &std::path::Path) -> anyhow::Result<()> {
    let positions: Vec<String> = (0..5).map(|i| board.axis(i).position.to_string()).collect();
    let net: Vec<String> = board.net_steps().iter().map(i64::to_string).collect();
    let json = format!(
        "{{\"board_s\": {:.3}, \"position_steps\": [{}], \"net_steps\": [{}]}}\n",
        board.now_s(),
        positions.join(", "),
        net.join(", ")
    );
    std::fs::write(path, json).with_context(|| format!("writing {}", path.display()))
}

/// A temperature a hotend can have, °C.
fn parse_celsius(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(c) if (0.0..=400.0).contains(&c) => Ok(c),
        _ => Err(format!("{text} is not a temperature within 0..=400 °C")),
    }
}
