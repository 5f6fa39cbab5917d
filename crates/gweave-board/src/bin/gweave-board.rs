//! `gweave-board ELF --pty LINK`: the emulated RAMPS board on a pseudo-terminal, for real hosts
//! (Printrun's printcore, OctoPrint, `screen LINK 250000`).
//!
//! The board runs at most as fast as a real one (its clock is held to the wall clock), so a
//! host's timeouts mean what they do with the real board. Opening the link resets the chip, as
//! opening a Mega's USB port does (the serial chip's DTR line pulls RESET low).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Parser;
use gweave_board::{Board, Wiring};
use gweave_sim::{Endpoint, PtyEndpoint};

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
}

/// Board time run between two looks at the pty: 1 ms.
const TICK_S: f64 = 0.001;

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let mut board = Board::new(&args.elf, Wiring::default())?;
    let mut pty = PtyEndpoint::open(&args.pty).with_context(|| format!("opening {}", args.pty.display()))?;
    eprintln!("gweave-board: {} on {}", args.elf.display(), args.pty.display());
    let stop = AtomicBool::new(false);
    let start = Instant::now();
    let start_board_s = board.now_s();
    let mut buf = [0u8; 512];
    loop {
        if args.seconds.is_some_and(|s| board.now_s() >= s) {
            return Ok(());
        }
        match pty.wait(&mut buf, Duration::ZERO)? {
            gweave_sim::EndpointEvent::Connected => board.reset(),
            gweave_sim::EndpointEvent::Data(n) => board.send(&buf[..n]),
            _ => {}
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
}
