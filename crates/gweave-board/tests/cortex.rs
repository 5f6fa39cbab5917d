//! The 32-bit firmware (firmware/cortex, `make firmware-cortex`) on an emulated STM32F405:
//! QEMU's Netduino Plus 2, its USART1 on QEMU's standard input and output.
//!
//! QEMU models no GPIO for this chip, only an "unimplemented device" where each port sits, but
//! it can log every write to a device's registers (`-d trace:memory_region_ops_write`): the
//! firmware drives its pins through the ports' BSRR registers (a bit in the low half sets a
//! pin, in the high half clears it), so the log holds every rising edge of every STEP pin, in
//! order, and the level of every DIR pin at that moment.

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

/// The firmware `make firmware-cortex` built (`GWEAVE_CORTEX_ELF` overrides the path).
fn elf() -> PathBuf {
    let path = std::env::var_os("GWEAVE_CORTEX_ELF").map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware/out/gweave-cortex.elf")
    });
    assert!(path.exists(), "{} is missing: run `make firmware-cortex` first", path.display());
    path
}

/// The SKR Pro's pins this test watches (firmware/cortex/src/pins.rs): `(port, bit)`.
const X_STEP: (char, u32) = ('E', 9);
const Y_STEP: (char, u32) = ('E', 11);
const Z_STEP: (char, u32) = ('E', 13);
const E0_STEP: (char, u32) = ('E', 14);
const X_DIR: (char, u32) = ('F', 1);

/// GPIO port A's address; port n is 0x400 further, its BSRR at 0x18 (RM0090).
const GPIO_BASE: u64 = 0x4002_0000;
const BSRR: u64 = 0x18;

/// A running QEMU: the serial line's input, its lines as they come, the write log.
struct Qemu {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<String>,
    log: PathBuf,
}

impl Qemu {
    /// Power the board on and wait for the firmware's `start`.
    fn boot(name: &str) -> Qemu {
        let log = std::env::temp_dir().join(format!("gweave-cortex-{name}-{}.log", std::process::id()));
        let mut child = Command::new("qemu-system-arm")
            .args(["-M", "netduinoplus2", "-nographic", "-monitor", "none", "-serial", "stdio"])
            .arg("-kernel")
            .arg(elf())
            .args(["-d", "trace:memory_region_ops_write", "-D"])
            .arg(&log)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("qemu-system-arm runs (Debian: qemu-system-arm; `make firmware-deps`)");
        let stdin = child.stdin.take().unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut qemu = Qemu { child, stdin, lines, log };
        qemu.until(|l| l == "start");
        qemu
    }

    /// Send one line to the firmware.
    fn send(&mut self, line: &str) {
        self.stdin.write_all(format!("{line}\n").as_bytes()).unwrap();
        self.stdin.flush().unwrap();
    }

    /// The lines received up to and including the first that `done` accepts (10 s at most).
    fn until(&mut self, done: impl Fn(&str) -> bool) -> Vec<String> {
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut got = Vec::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    let last = done(&line);
                    got.push(line);
                    if last {
                        return got;
                    }
                }
                Err(_) => panic!("no awaited line within 10 s; got {got:?}"),
            }
        }
    }

    /// Send `line` and return the replies up to its `ok` (or an `ok ...` report).
    fn command(&mut self, line: &str) -> Vec<String> {
        self.send(line);
        self.until(|l| l == "ok" || l.starts_with("ok "))
    }

    /// Stop QEMU (SIGTERM: it exits cleanly, so its log is complete) and return the register
    /// writes it logged, `(address, value)` in order.
    fn stop(mut self) -> Vec<(u64, u64)> {
        let pid = self.child.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).status();
        let _ = self.child.wait();
        let text = std::fs::read_to_string(&self.log).unwrap();
        let _ = std::fs::remove_file(&self.log);
        text.lines().filter_map(write_of).collect()
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        // A failed assertion must not leave QEMU running.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `(address, value)` of a log line `memory_region_ops_write cpu 0 mr 0x... addr 0x40021018
/// value 0x200 size 4 name 'GPIOE'`.
fn write_of(line: &str) -> Option<(u64, u64)> {
    let mut words = line.split_whitespace();
    let hex = |w: Option<&str>| u64::from_str_radix(w?.strip_prefix("0x")?, 16).ok();
    words.find(|&w| w == "addr")?;
    let addr = hex(words.next())?;
    words.next().filter(|&w| w == "value")?;
    Some((addr, hex(words.next())?))
}

fn bsrr_of(port: char) -> u64 {
    GPIO_BASE + 0x400 * u64::from(port as u8 - b'A') + BSRR
}

/// The pins' levels after every write, and per watched STEP pin the DIR level of X at each of
/// its rising edges.
struct Pins {
    level: HashMap<(char, u32), bool>,
    rising: HashMap<(char, u32), Vec<bool>>,
}

/// Replay the BSRR writes: count each STEP pin's rising edges, noting X's DIR level at each.
fn replay(writes: &[(u64, u64)], steps: &[(char, u32)]) -> Pins {
    let mut pins = Pins { level: HashMap::new(), rising: HashMap::new() };
    for &(addr, value) in writes {
        let Some(port) = ('A'..='G').find(|&p| bsrr_of(p) == addr) else { continue };
        for bit in 0..16 {
            let (set, clear) = (value & (1 << bit) != 0, value & (1 << (bit + 16)) != 0);
            if !set && !clear {
                continue;
            }
            let was = pins.level.insert((port, bit), set).unwrap_or(false);
            if set && !was && steps.contains(&(port, bit)) {
                let dir = pins.level.get(&X_DIR).copied().unwrap_or(false);
                pins.rising.entry((port, bit)).or_default().push(dir);
            }
        }
    }
    pins
}

/// `N<n> <command>*<checksum>`: a line as a host numbers it.
fn numbered(n: u32, command: &str) -> String {
    let body = format!("N{n} {command}");
    let sum = body.bytes().fold(0u8, |a, b| a ^ b);
    format!("{body}*{sum}")
}

#[test]
fn the_serial_protocol_runs_end_to_end_on_the_32_bit_board() {
    let mut qemu = Qemu::boot("protocol");
    let m115 = qemu.command("M115");
    assert!(m115[0].starts_with("FIRMWARE_NAME:gweave-controller PROTOCOL_VERSION:1.0"), "{m115:?}");
    assert!(m115.iter().any(|l| l == "Cap:EEPROM:1"), "{m115:?}");
    assert!(m115.iter().any(|l| l == "Cap:THERMAL_PROTECTION:1"), "{m115:?}");

    // A damaged line: its checksum is off by one. The host is told which line to send again.
    let good = numbered(1, "M105");
    let (body, sum) = good.split_once('*').unwrap();
    let bad = format!("{body}*{}", sum.parse::<u8>().unwrap() ^ 1);
    assert_eq!(
        qemu.command(&bad),
        ["Error:checksum mismatch, Last Line: 0", "Resend: 1", "ok"],
        "the reply to {bad:?}"
    );
    // The same line, sent again whole: the board's thermistors read 25 °C (ROOM_ADC).
    assert_eq!(qemu.command(&good), ["ok T:25.00 /0.00 B:25.00 /0.00 @:0 B@:0"]);
    assert_eq!(qemu.command(&numbered(2, "M105")), ["ok T:25.00 /0.00 B:25.00 /0.00 @:0 B@:0"]);
    // Out of order: line 4 after line 2.
    let skipped = qemu.command(&numbered(4, "M105"));
    assert_eq!(skipped, ["Error:Line Number is not Last Line Number+1, Last Line: 2", "Resend: 3", "ok"]);
    qemu.stop();
}

#[test]
fn a_g1_move_gives_exactly_its_steps_on_every_axis_of_the_32_bit_board() {
    let mut qemu = Qemu::boot("motion");
    qemu.command("G91");
    // 80 steps/mm on X and Y, 400 on Z (firmware/printer.toml). The hotend is cold, so the E
    // part is dropped (Marlin's PREVENT_COLD_EXTRUSION) and E0's STEP pin must stay still.
    let g1 = qemu.command("G1 X10 Y5 Z1 E2 F3000");
    assert!(g1.iter().any(|l| l == "echo: cold extrusion prevented"), "{g1:?}");
    // Then back on X alone: its DIR pin must turn before these steps.
    qemu.command("G1 X-2.5 F3000");
    qemu.command("M400");
    let m114 = qemu.command("M114");
    // E counts as moved, as in Marlin: a prevented extrusion still moves the E position.
    assert_eq!(m114, ["X:7.50 Y:5.00 Z:1.00 E:2.00 Count X:600 Y:400 Z:400", "ok"]);

    let pins = replay(&qemu.stop(), &[X_STEP, Y_STEP, Z_STEP, E0_STEP]);
    let count = |pin| pins.rising.get(&pin).map_or(0, Vec::len);
    assert_eq!(count(X_STEP), 800 + 200, "X steps");
    assert_eq!(count(Y_STEP), 400, "Y steps");
    assert_eq!(count(Z_STEP), 400, "Z steps");
    assert_eq!(count(E0_STEP), 0, "E0 steps of a cold extrusion");
    // The 800 steps out all with one DIR level, the 200 back all with the other.
    let x_dirs = &pins.rising[&X_STEP];
    assert!(x_dirs[..800].iter().all(|&d| d == x_dirs[0]), "X's DIR changed during the first move");
    assert!(x_dirs[800..].iter().all(|&d| d != x_dirs[0]), "X's DIR did not turn for the move back");
}
