//! Where the main loop's cycles go while a host streams short segments (run by
//! `bench/firmware.sh`, not a test): the program counter's profile of the chip, cycles per
//! function (from the ELF's symbols, `avr-nm`), over 200 lines of 0.5 mm at 60 mm/s sent one
//! after each `ok` at 250000 baud, and the main loop's time per line against the line's motion.
//!
//! `cargo run --release -p gweave-board --example profile -- firmware/out/gweave-ramps.elf`

use std::collections::HashMap;
use std::process::Command;

use gweave_board::{Board, Wiring, CPU_HZ};

/// Lines streamed, and their length and speed: 0.5 mm at 60 mm/s is 8.3 ms of motion each.
const LINES: u32 = 200;
const SEGMENT_MM: f64 = 0.5;
const FEED_MM_MIN: f64 = 3600.0;
/// How many functions to list.
const TOP: usize = 12;

/// A function symbol of the ELF: (start byte address, size in bytes, name).
type Function = (u32, u32, String);

/// A Rust (v0-mangled) symbol's path, `crate::module::function`: its identifiers (a length,
/// then so many characters), skipping crate hashes, disambiguators (`s..._`) and back
/// references (`B..._`); avr-nm's `-C` does not know Rust's mangling. Other names unchanged.
fn demangle(name: &str) -> String {
    let Some(rest) = name.strip_prefix("_R") else { return name.to_owned() };
    let bytes = rest.as_bytes();
    let (mut parts, mut i) = (Vec::new(), 0);
    while i < bytes.len() {
        match bytes[i] {
            b'0'..=b'9' => {
                let digits = bytes[i..].iter().take_while(|b| b.is_ascii_digit()).count();
                let n: usize = rest[i..i + digits].parse().unwrap_or(usize::MAX);
                i += digits;
                // An identifier starting with a digit or `_` has a `_` before it.
                if bytes.get(i) == Some(&b'_') {
                    i += 1;
                }
                let Some(ident) = rest.get(i..i.saturating_add(n)) else { break };
                parts.push(ident);
                i += n;
            }
            b's' | b'B' => i += bytes[i..].iter().position(|&b| b == b'_').map_or(bytes.len(), |p| p + 1),
            b'N' => i += 2,
            _ => i += 1,
        }
    }
    parts.join("::")
}

/// Function symbols of `elf` (avr-nm), by address.
fn functions(elf: &str) -> Result<Vec<Function>, Box<dyn std::error::Error>> {
    let out = Command::new("avr-nm").args(["-C", "-S", "--size-sort", elf]).output()?;
    let mut symbols: Vec<Function> = String::from_utf8(out.stdout)?
        .lines()
        .filter_map(|l| {
            let mut f = l.splitn(4, ' ');
            let (addr, size, kind, name) = (f.next()?, f.next()?, f.next()?, f.next()?);
            // Code: `t`/`T` (text); AVR's flash addresses are below 0x800000 (RAM's).
            let addr = u32::from_str_radix(addr, 16).ok()?;
            (kind.eq_ignore_ascii_case("t") && addr < 0x80_0000)
                .then(|| Some((addr, u32::from_str_radix(size, 16).ok()?, demangle(name))))?
        })
        .collect();
    symbols.sort();
    Ok(symbols)
}

/// The main loop's time to read and plan a line while it steps the ones before: from rest,
/// `LATENCY_LINES` lines (fewer than the planner holds, so no `ok` waits for room), each sent
/// after the last one's `ok`; from the line's last byte on the wire (250000 baud, 10 bits a
/// byte: 40 us each) to its `ok`. Mean and worst, ms.
fn line_latency(board: &mut Board) -> Result<(f64, f64), Box<dyn std::error::Error>> {
    const LATENCY_LINES: u32 = 12;
    const BYTE_CYCLES: u64 = CPU_HZ as u64 * 10 / 250_000;
    let (mut sum_ms, mut worst_ms) = (0.0f64, 0.0f64);
    for i in 1..=LATENCY_LINES {
        // Back along the line the streamed run drew (it ended at X = 10 + LINES × 0.5).
        let line = format!("G1 X{:.1} F{FEED_MM_MIN}", 10.0 + SEGMENT_MM * f64::from(LINES - i));
        let sent = board.cycle() + (line.len() as u64 + 1) * BYTE_CYCLES;
        board.command(&line, 5.0)?;
        let ms = board.cycle().saturating_sub(sent) as f64 / f64::from(CPU_HZ) * 1e3;
        sum_ms += ms;
        worst_ms = worst_ms.max(ms);
    }
    board.command("M400", 10.0)?;
    Ok((sum_ms / f64::from(LATENCY_LINES), worst_ms))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let elf = std::env::args().nth(1).ok_or("usage: profile FIRMWARE.elf")?;
    let symbols = functions(&elf)?;
    let mut board = Board::new(elf.as_ref(), Wiring::default())?;
    board.run_until_line(|l| l == "start", 1.0)?;
    for line in ["G28", "G90", "G1 X10 Y10 F3600", "M400"] {
        board.command(line, 60.0)?;
    }
    let entries: Vec<u32> = symbols.iter().map(|s| s.0).collect();
    board.profile(Some(&entries));
    let start = board.cycle();
    for i in 1..=LINES {
        let x = 10.0 + SEGMENT_MM * f64::from(i);
        board.command(&format!("G1 X{x:.1} F{FEED_MM_MIN}"), 5.0)?;
    }
    let per_line_ms = (board.cycle() - start) as f64 / f64::from(LINES) / f64::from(CPU_HZ) * 1e3;
    let own = board.profile_counts(false);
    let inclusive = board.profile_counts(true);
    board.profile(None);
    board.command("M400", 10.0)?;
    let (mean_ms, worst_ms) = line_latency(&mut board)?;

    let total: u64 = own.iter().map(|&c| u64::from(c)).sum();
    let motion_ms = SEGMENT_MM / (FEED_MM_MIN / 60.0) * 1e3;
    println!(
        "{LINES} lines of {SEGMENT_MM} mm at {} mm/s: {per_line_ms:.2} ms of board time per line \
         (ok to ok; the planner full, so the motion's pace) against {motion_ms:.2} ms of motion",
        FEED_MM_MIN / 60.0
    );
    println!(
        "reading and planning a line (its last byte in to its ok, the planner not full): \
         {mean_ms:.2} ms mean, {worst_ms:.2} ms at most; margin {:.1}x the line's motion",
        motion_ms / worst_ms
    );
    for (title, counts) in [("with what it calls", &inclusive), ("its own code", &own)] {
        let mut by_function: HashMap<&str, u64> = HashMap::new();
        for (word, &cycles) in counts.iter().enumerate().filter(|(_, &c)| c > 0) {
            let addr = word as u32 * 2;
            let i = symbols.partition_point(|s| s.0 <= addr);
            let name = match i.checked_sub(1).map(|i| &symbols[i]) {
                Some((start, size, name)) if addr < start + size.max(&2) => name.as_str(),
                _ => "(no symbol)",
            };
            *by_function.entry(name).or_default() += u64::from(cycles);
        }
        let mut rows: Vec<_> = by_function.into_iter().collect();
        rows.sort_by_key(|r| std::cmp::Reverse(r.1));
        println!("cycles per line, by function ({title}; main loop and interrupts):");
        for (name, cycles) in rows.iter().take(TOP) {
            println!(
                "{:>9.0} {:5.1} %  {name}",
                *cycles as f64 / f64::from(LINES),
                100.0 * *cycles as f64 / total as f64
            );
        }
    }
    Ok(())
}
