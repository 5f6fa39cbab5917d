//! The emulated board: the chip running the firmware on its shield, on the board's own clock.
//!
//! [`Board::run_for`] advances the board by a span of its time in slices of
//! [`SLICE_CYCLES`]: between slices the serial bytes waiting for the chip are put on the line
//! (as fast as its receiver takes them, the wire's pace) and the thermal plants advance with
//! the heaters' duty, their thermistor voltages going back to the analog inputs.

use std::collections::VecDeque;
use std::path::Path;

use crate::ramps::{Axis, Plant, THERMISTOR_ADC};
use crate::ramps::{
    Shield, Wiring, DRIVERS, MOSFETS, PIN_DIR, PIN_ENABLE, PIN_INK_ADDRESS, PIN_INK_PULSE, PIN_MOSFET,
    PIN_STEP, STEP_DIR_ENABLE,
};
use crate::sim::{Avr, LoadError, Stopped};

/// The Mega 2560's crystal.
pub const CPU_HZ: u32 = 16_000_000;
/// Cycles between two visits of the harness: 100 us, two and a half bytes at 250000 baud.
pub const SLICE_CYCLES: u64 = 1_600;
/// The thermal plants advance every 10 ms of board time (the heaters' PWM period is 256 ms,
/// the plants' time constants seconds: the duty over 10 ms is exact enough).
const PLANT_CYCLES: u64 = CPU_HZ as u64 / 100;

/// What can go wrong with the board.
#[derive(Debug, thiserror::Error)]
pub enum BoardError {
    #[error(transparent)]
    Load(#[from] LoadError),
    #[error("thermal plant: {0}")]
    Plant(#[from] gweave_sim::ThermalError),
    #[error("the firmware stopped ({0:?}) after {1:.3} s of board time")]
    Stopped(Stopped, f64),
    #[error("no line matching after {waited_s} s of board time; the firmware said:\n{said}")]
    Timeout { waited_s: f64, said: String },
}

/// The board, the firmware on it, and the host's end of its serial line.
pub struct Board {
    avr: Avr<Shield>,
    /// Bytes sent by the host, not yet on the wire.
    to_chip: VecDeque<u8>,
    /// Text the firmware sent that is not a whole line yet.
    partial: Vec<u8>,
    next_plant_cycle: u64,
}

impl Board {
    /// A board wired as `wiring`, running the firmware ELF at `elf`.
    pub fn new(elf: &Path, wiring: Wiring) -> Result<Board, BoardError> {
        let shield = Shield::new(wiring)?;
        let mut avr = Avr::load(elf, CPU_HZ, shield)?;
        for (i, [step, dir, enable]) in STEP_DIR_ENABLE.into_iter().enumerate() {
            let i = i as u32;
            avr.watch(step, PIN_STEP + i);
            avr.watch(dir, PIN_DIR + i);
            avr.watch(enable, PIN_ENABLE + i);
        }
        for (i, pin) in MOSFETS.into_iter().enumerate() {
            avr.watch(pin, PIN_MOSFET + i as u32);
        }
        for (i, pin) in crate::inkshield::ADDRESS.into_iter().enumerate() {
            avr.watch(pin, PIN_INK_ADDRESS + i as u32);
        }
        for (i, pin) in crate::inkshield::PULSE.into_iter().enumerate() {
            avr.watch(pin, PIN_INK_PULSE + i as u32);
        }
        let mut board = Board { avr, to_chip: VecDeque::new(), partial: Vec::new(), next_plant_cycle: 0 };
        board.sync_inputs();
        Ok(board)
    }

    /// Board time since start-up, s.
    pub fn now_s(&self) -> f64 {
        self.avr.cycle() as f64 / f64::from(CPU_HZ)
    }

    /// Cycles since start-up.
    pub fn cycle(&self) -> u64 {
        self.avr.cycle()
    }

    /// Queue bytes from the host; they go on the wire as the board runs.
    pub fn send(&mut self, bytes: &[u8]) {
        self.to_chip.extend(bytes);
    }

    /// Queue one line from the host (a newline is added).
    pub fn send_line(&mut self, line: &str) {
        self.send(line.as_bytes());
        self.send(b"\n");
    }

    /// Bytes the firmware sent since the last call.
    pub fn take_serial(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.avr.wires_mut().serial_out)
    }

    /// Run the board for `seconds` of its time.
    pub fn run_for(&mut self, seconds: f64) -> Result<(), BoardError> {
        let until = self.avr.cycle() + (seconds * f64::from(CPU_HZ)) as u64;
        while self.avr.cycle() < until {
            self.slice(until)?;
        }
        Ok(())
    }

    /// One slice: feed the serial line, run, then bring the inputs up to date.
    fn slice(&mut self, until: u64) -> Result<(), BoardError> {
        while !self.to_chip.is_empty() && self.avr.serial_ready() {
            let byte = self.to_chip.pop_front().unwrap_or_default();
            self.avr.serial_in(byte);
        }
        let end =
            (self.avr.cycle() + SLICE_CYCLES).min(until).min(self.next_plant_cycle.max(self.avr.cycle() + 1));
        self.avr.run(end).map_err(|s| BoardError::Stopped(s, self.now_s()))?;
        self.sync_inputs();
        Ok(())
    }

    /// Endstops from the axes, thermistor voltages from the plants when their time has come.
    fn sync_inputs(&mut self) {
        let cycle = self.avr.cycle();
        let mut levels = Vec::new();
        self.avr.wires_mut().drive_endstops(|pin, level| levels.push((pin, level)));
        for (pin, level) in levels {
            self.avr.drive(pin, level);
        }
        if cycle >= self.next_plant_cycle {
            let mv = self.avr.wires_mut().advance_plants(cycle, CPU_HZ);
            for (channel, mv) in THERMISTOR_ADC.into_iter().zip(mv) {
                self.avr.set_adc_mv(channel, mv);
            }
            self.next_plant_cycle = cycle + PLANT_CYCLES;
        }
    }

    /// The whole lines the firmware sent since the last call (without line ends); a line not
    /// finished yet waits for its end.
    pub fn lines(&mut self) -> Vec<String> {
        let bytes = self.take_serial();
        self.partial.extend(bytes);
        let mut lines = Vec::new();
        while let Some(end) = self.partial.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.partial.drain(..=end).collect();
            lines.push(String::from_utf8_lossy(&line[..end]).trim_end_matches('\r').to_string());
        }
        lines
    }

    /// Run until the firmware sends a line for which `done` holds, for at most `timeout_s` of
    /// board time; returns every line it sent meanwhile, the last one being the match (lines
    /// after it in the same slice wait for the next call).
    pub fn run_until_line(
        &mut self,
        mut done: impl FnMut(&str) -> bool,
        timeout_s: f64,
    ) -> Result<Vec<String>, BoardError> {
        let until = self.avr.cycle() + (timeout_s * f64::from(CPU_HZ)) as u64;
        let mut lines = Vec::new();
        loop {
            let mut new = self.lines().into_iter();
            while let Some(line) = new.next() {
                let hit = done(&line);
                lines.push(line);
                if hit {
                    // Put back what came after the match, for the next call.
                    let rest: Vec<u8> = new.flat_map(|l| l.into_bytes().into_iter().chain([b'\n'])).collect();
                    self.partial.splice(0..0, rest);
                    return Ok(lines);
                }
            }
            if self.avr.cycle() >= until {
                return Err(BoardError::Timeout { waited_s: timeout_s, said: lines.join("\n") });
            }
            self.slice(until)?;
        }
    }

    /// Send `line` and run until the firmware answers `ok`; returns the lines it sent
    /// meanwhile (an `Error:` line comes before its `ok`, as in Marlin).
    pub fn command(&mut self, line: &str, timeout_s: f64) -> Result<Vec<String>, BoardError> {
        self.send_line(line);
        self.run_until_line(|l| l.starts_with("ok"), timeout_s)
    }

    /// One stepper socket (0 X, 1 Y, 2 Z, 3 E0, 4 E1, 5 E2, 6 E3) and its axis.
    pub fn axis(&self, socket: usize) -> &Axis {
        &self.avr.wires().axes[socket.min(DRIVERS - 1)]
    }

    /// Net microsteps of every socket since start-up (+ minus -).
    pub fn net_steps(&self) -> [i64; DRIVERS] {
        std::array::from_fn(|i| {
            let a = &self.avr.wires().axes[i];
            a.steps_plus as i64 - a.steps_minus as i64
        })
    }

    /// A thermal plant (0 hotend, 1 bed, 2 hotend 1).
    pub fn plant(&self, i: usize) -> &Plant {
        &self.avr.wires().plants[i.min(2)]
    }

    /// The shield, to inject faults or move axes by hand.
    pub fn shield_mut(&mut self) -> &mut Shield {
        self.avr.wires_mut()
    }

    /// Reset the chip (as a host opening the port resets an Arduino).
    pub fn reset(&mut self) {
        self.avr.reset();
        self.avr.wires_mut().forget_endstops();
        self.partial.clear();
        self.sync_inputs();
    }

    /// Time the step interrupt's handler (Timer1 compare A, vector 17) from now on.
    pub fn time_step_interrupt(&mut self) {
        self.avr.time_vector(17);
    }

    /// The longest the step interrupt's handler took since [`Board::time_step_interrupt`],
    /// cycles (16 a microsecond).
    pub fn step_interrupt_max_cycles(&self) -> u64 {
        self.avr.isr_max_cycles()
    }

    /// The mean time of the step interrupt's handler, cycles.
    pub fn step_interrupt_mean_cycles(&self) -> u64 {
        self.avr.isr_mean_cycles()
    }

    /// Profile the program counter from now on, the functions starting at the byte
    /// addresses `entries` (the ELF's symbols), or stop (`None`): see
    /// [`Board::profile_counts`].
    pub fn profile(&mut self, entries: Option<&[u32]>) {
        self.avr.profile(entries);
    }

    /// The cycles spent at each flash word (index: byte address / 2) since
    /// [`Board::profile`] started, or with `inclusive`, in the function starting at each word
    /// with what it called.
    pub fn profile_counts(&self, inclusive: bool) -> Vec<u32> {
        self.avr.profile_counts(inclusive)
    }

    /// The lowest stack pointer seen: the stack's high-water mark is `0x21FF` minus it.
    pub fn min_stack_pointer(&self) -> u16 {
        self.avr.min_stack_pointer()
    }
}
