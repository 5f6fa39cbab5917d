//! The board's twin on the host: the core run on a simulated clock, with the step interrupt
//! called when its timer says, endstops that close where the axes' minimum is, and a thermal
//! plant behind the thermistor inputs. (Feature `std`.)
//!
//! This is how the core is tested (`machine/tests.rs`), and how other code runs the very
//! firmware without a board: the emulated board's tests compare its step counts with the
//! twin's for the same file, and the virtual printer can put it behind its serial port.
//!
//! ```
//! use gweave_controller::twin::{FirstOrder, Twin};
//! use gweave_controller::{Settings, StepQueue};
//!
//! let queue = StepQueue::new();
//! let mut twin = Twin::new(&queue, Settings::DEFAULT, FirstOrder::default());
//! twin.run_lines(b"G28\nG1 X10 Y5 F3000\nM400\n", 60_000).unwrap();
//! assert_eq!(twin.steps_from_home(), [800, 400, 0, 0]);
//! ```

use core::mem::ManuallyDrop;
use core::ptr::NonNull;
use std::vec::Vec;

use crate::heat::thermistor::TYPE_1;
use crate::limits::TICKS_PER_S;
use crate::serial::emergency::{EmergencyParser, Heard};
use crate::{Controller, Inputs, Io, Settings, StepQueue, Stepper, AXES, HEATERS, MOTORS};

/// The temperatures behind the thermistor inputs, driven by the heater duties.
pub trait Plant {
    /// The raw ADC readings the sensors give now.
    fn adc(&self) -> [u16; HEATERS];
    /// Lets `dt_s` seconds pass with the heaters at `duty` (0-255).
    fn advance(&mut self, duty: [u8; HEATERS], dt_s: f32);
}

/// A first-order plant per heater on type 1 thermistors: each heater body (heat capacity `C`)
/// gains the heater's power and loses `k (T - T_room)` to the air, so
/// `C dT/dt = P duty/255 - k (T - T_room)`: a 40 W hotend of 10 J/K losing 0.1 W/K (400 °C
/// at full power, a time constant of 100 s), a 200 W bed of 400 J/K losing 0.8 W/K.
#[derive(Debug, Clone, PartialEq)]
pub struct FirstOrder {
    /// Temperatures, °C.
    pub temp_c: [f32; HEATERS],
    /// Room temperature, °C.
    pub room_c: f32,
    /// Heater power at full duty, W.
    pub watts: [f32; HEATERS],
    /// Heat capacities, J/K.
    pub capacity_j_k: [f32; HEATERS],
    /// Losses, W/K.
    pub loss_w_k: [f32; HEATERS],
    /// Heaters that work (a failed cartridge gives no heat).
    pub heating: [bool; HEATERS],
    /// A reading that replaces the sensor's (an open thermistor reads 1023, a short 0).
    pub adc_override: [Option<u16>; HEATERS],
}

impl Default for FirstOrder {
    fn default() -> Self {
        FirstOrder {
            temp_c: [20.0; HEATERS],
            room_c: 20.0,
            watts: [40.0, 40.0, 200.0],
            capacity_j_k: [10.0, 10.0, 400.0],
            loss_w_k: [0.1, 0.1, 0.8],
            heating: [true; HEATERS],
            adc_override: [None; HEATERS],
        }
    }
}

impl Plant for FirstOrder {
    fn adc(&self) -> [u16; HEATERS] {
        core::array::from_fn(|i| self.adc_override[i].unwrap_or_else(|| type_1_adc(self.temp_c[i])))
    }

    fn advance(&mut self, duty: [u8; HEATERS], dt_s: f32) {
        for (i, (temp_c, duty)) in self.temp_c.iter_mut().zip(duty).enumerate() {
            let power = if self.heating[i] { self.watts[i] * f32::from(duty) / 255.0 } else { 0.0 };
            let loss = self.loss_w_k[i] * (*temp_c - self.room_c);
            *temp_c += (power - loss) / self.capacity_j_k[i] * dt_s;
        }
    }
}

/// The ADC reading of a temperature on a type 1 thermistor: the firmware's table read
/// backwards, so that the firmware reads the plant's temperature back exactly.
pub fn type_1_adc(t_c: f32) -> u16 {
    let i = TYPE_1.iter().position(|&(_, t)| f32::from(t) <= t_c).unwrap_or(TYPE_1.len() - 1);
    if i == 0 {
        return TYPE_1[0].0;
    }
    let ((a0, t0), (a1, t1)) = (TYPE_1[i - 1], TYPE_1[i]);
    let f = ((f32::from(t0) - t_c) / f32::from(t0 - t1)).clamp(0.0, 1.0);
    (f32::from(a0) + f * f32::from(a1 - a0)).round() as u16
}

/// The board's serial output and EEPROM, in memory.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Memory {
    /// The build's settings (`M502`).
    pub build: Settings,
    /// Everything the core sent.
    pub sent: Vec<u8>,
    /// The EEPROM (grows as written; unwritten bytes read `0xFF`).
    pub eeprom: Vec<u8>,
    /// How many times the watchdog was fed.
    pub watchdog_feeds: u64,
    /// The inkjet fires asked for (`M700`), head and nozzle mask, not yet taken by the twin.
    #[cfg(feature = "inkjet")]
    pub inkjet_fires: Vec<(u8, u16)>,
}

impl Io for Memory {
    fn send(&mut self, bytes: &[u8]) {
        self.sent.extend_from_slice(bytes);
    }
    fn build_settings(&self) -> Settings {
        self.build
    }
    fn eeprom_read(&mut self, addr: u16, buf: &mut [u8]) {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = self.eeprom.get(usize::from(addr) + i).copied().unwrap_or(0xFF);
        }
    }
    fn eeprom_write(&mut self, addr: u16, data: &[u8]) {
        let end = usize::from(addr) + data.len();
        if self.eeprom.len() < end {
            self.eeprom.resize(end, 0xFF);
        }
        self.eeprom[usize::from(addr)..end].copy_from_slice(data);
    }
    fn watchdog_feed(&mut self) {
        self.watchdog_feeds += 1;
    }
    #[cfg(feature = "inkjet")]
    fn inkjet_fire(&mut self, head: u8, nozzles: u16) {
        self.inkjet_fires.push((head, nozzles));
    }
}

/// One inkjet fire on the twin: which head and nozzles, when, and where the motors were.
#[cfg(feature = "inkjet")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fire {
    /// The head (`M700 P`).
    pub head: u8,
    /// The nozzles fired (`M700 S`: bit `a` is address `a`).
    pub nozzles: u16,
    /// The board's time, ms.
    pub ms: u64,
    /// Where each motor was, in steps from the homed origin ([`Twin::steps_from_home`]).
    pub steps: [i64; AXES],
}

/// The main loop's period on the twin, in timer ticks (1 ms).
const POLL_TICKS: u64 = TICKS_PER_S as u64 / 1000;

/// The core on a simulated board.
pub struct Twin<'q, P: Plant> {
    /// The controller (the main loop's half).
    pub controller: Controller<'q>,
    stepper: Stepper<'q>,
    /// The receive interrupt's emergency parser: it hears each byte as it arrives.
    parser: EmergencyParser,
    /// Serial output and EEPROM.
    pub memory: Memory,
    /// The thermal plant.
    pub plant: P,
    /// Where each motor is, in steps from where it was at power-on.
    pub steps: [i64; AXES],
    /// Where the X, Y and Z endstops close, in steps: an endstop reads triggered at or below
    /// this position (set by [`Twin::new`] so that the machine starts 100 mm, 100 mm and 50 mm
    /// from them; a test may move them).
    pub endstop_steps: [i64; 3],
    /// Step pulses per motor ([`MOTORS`]: X, Y, Z, E0 and a mixing hotend's other inputs),
    /// both directions counted.
    pub pulses: [u64; MOTORS],
    /// The inkjet fires so far, in order.
    #[cfg(feature = "inkjet")]
    pub fires: Vec<Fire>,
    /// Called with the motor ([`MOTORS`]) and the time (ticks) of each step, for timing checks.
    pub on_step: Option<std::boxed::Box<dyn FnMut(usize, u64) + 'q>>,
    dir_bits: u8,
    ticks: u64,
    next_step: u64,
    next_poll: u64,
}

/// A twin's run that did not end as asked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TwinError {
    /// The board halted (a fault or `M112`); the replies so far.
    Halted(Vec<u8>),
    /// The `ok`s did not all come within the time limit; the replies so far.
    Timeout(Vec<u8>),
}

impl<'q, P: Plant> Twin<'q, P> {
    /// Powers the board on: `start`, the settings from its (empty) EEPROM.
    pub fn new(queue: &'q StepQueue, settings: Settings, plant: P) -> Self {
        Twin::with_memory(queue, settings, plant, Memory::default())
    }

    /// Powers the board on with `memory`'s EEPROM (a board that has run before).
    pub fn with_memory(queue: &'q StepQueue, settings: Settings, plant: P, memory: Memory) -> Self {
        let spm = settings.steps_per_mm;
        let mut twin = Twin {
            controller: Controller::new(queue, settings),
            stepper: Stepper::new(queue),
            parser: EmergencyParser::default(),
            // The board's build is what it was given: `M502` restores it.
            memory: Memory { build: settings, ..memory },
            plant,
            steps: [0; AXES],
            endstop_steps: [-(100.0 * spm[0]) as i64, -(100.0 * spm[1]) as i64, -(50.0 * spm[2]) as i64],
            pulses: [0; MOTORS],
            #[cfg(feature = "inkjet")]
            fires: Vec::new(),
            on_step: None,
            dir_bits: 0,
            ticks: 0,
            next_step: 0,
            next_poll: 0,
        };
        twin.power_on();
        twin
    }

    /// Restarts the core as a reset does (the EEPROM kept, the motors where they are).
    pub fn power_on(&mut self) {
        self.parser = EmergencyParser::default();
        let inputs = self.inputs();
        self.controller.boot(&mut self.memory, &inputs);
    }

    /// The board's time, ms.
    pub fn now_ms(&self) -> u64 {
        self.ticks / POLL_TICKS
    }

    /// The board's time in step-timer ticks.
    pub fn now_ticks(&self) -> u64 {
        self.ticks
    }

    /// Where each motor is, in steps from the homed origin (the endstops' positions).
    pub fn steps_from_home(&self) -> [i64; AXES] {
        core::array::from_fn(|a| self.steps[a] - if a < 3 { self.endstop_steps[a] } else { 0 })
    }

    fn inputs(&self) -> Inputs {
        let endstops = (0..3).filter(|&a| self.steps[a] <= self.endstop_steps[a]).fold(0, |m, a| m | 1 << a);
        Inputs { now_ms: self.now_ms() as u32, adc: self.plant.adc(), endstops }
    }

    /// Offers bytes to the core as a UART does: all heard by the receive interrupt's emergency
    /// parser as they arrive, then queued, the board running while its line queue is full.
    pub fn send(&mut self, bytes: &[u8]) {
        self.hear(bytes);
        for &b in bytes {
            while !self.controller.receive(b) {
                self.run_ms(1);
            }
        }
    }

    /// One byte off the wire, the board not running meanwhile: heard by the receive
    /// interrupt's emergency parser, then offered to the line queue. `false` when the queue
    /// refused it (a full receive buffer then loses it).
    pub fn arrive(&mut self, byte: u8) -> bool {
        self.hear(&[byte]);
        self.controller.receive(byte)
    }

    /// Bytes heard by the receive interrupt's emergency parser alone, and handed to the main
    /// loop: for a host link whose own protocol layer refused their line (`gweave serve`'s,
    /// which checks line numbers and checksums before the core's queue sees a line), as the
    /// board's parser hears every byte before its queue judges the line. Whether an urgent
    /// command was heard.
    pub fn hear(&mut self, bytes: &[u8]) -> bool {
        let mut heard = Heard::default();
        for &b in bytes {
            self.parser.hear_into(b, &mut heard);
        }
        self.controller.heard(heard);
        heard != Heard::default()
    }

    /// Runs the board for `ms` of its time: the step interrupt when its timer says, the main
    /// loop every millisecond between.
    pub fn run_ms(&mut self, ms: u64) {
        let end = self.ticks + ms * POLL_TICKS;
        while self.ticks < end {
            if self.next_poll <= self.next_step {
                self.ticks = self.next_poll;
                let inputs = self.inputs();
                self.controller.poll(&mut self.memory, &inputs);
                #[cfg(feature = "inkjet")]
                for (head, nozzles) in core::mem::take(&mut self.memory.inkjet_fires) {
                    let (ms, steps) = (self.now_ms(), self.steps_from_home());
                    self.fires.push(Fire { head, nozzles, ms, steps });
                }
                self.plant.advance(self.controller.outputs().heater_duty, 0.001);
                self.next_poll += POLL_TICKS;
                continue;
            }
            self.ticks = self.next_step;
            let out = self.stepper.tick(self.inputs().endstops);
            for motor in (0..MOTORS).filter(|m| out.step_bits & (1 << m) != 0) {
                self.pulses[motor] += 1;
                if motor < AXES {
                    let forward = (self.dir_bits ^ self.controller.settings().invert_dir) & (1 << motor) != 0;
                    self.steps[motor] += if forward { 1 } else { -1 };
                }
                if let Some(f) = self.on_step.as_mut() {
                    f(motor, self.ticks);
                }
            }
            self.dir_bits = out.dir_bits;
            self.next_step += u64::from(out.interval_ticks);
        }
    }

    /// Sends `lines` as a host does, one line after each `ok` (ping-pong), and runs until every
    /// line is answered, within `limit_ms` of board time. Returns the replies.
    pub fn run_lines(&mut self, lines: &[u8], limit_ms: u64) -> Result<Vec<u8>, TwinError> {
        let start = self.memory.sent.len();
        let deadline = self.now_ms() + limit_ms;
        for line in lines.split_inclusive(|&b| b == b'\n') {
            let before = oks(&self.memory.sent[start..]);
            self.send(line);
            let has_command = line.iter().take_while(|&&b| b != b';').any(|b| !b.is_ascii_whitespace());
            while has_command && oks(&self.memory.sent[start..]) == before {
                if self.controller.is_halted() {
                    return Err(TwinError::Halted(self.memory.sent[start..].to_vec()));
                }
                if self.now_ms() >= deadline {
                    return Err(TwinError::Timeout(self.memory.sent[start..].to_vec()));
                }
                self.run_ms(1);
            }
        }
        Ok(self.memory.sent[start..].to_vec())
    }
}

/// A twin that owns its step queue: a board object that lives on its own, as the virtual
/// printer's board for one host session. ([`Twin`] borrows the queue, as the firmware's
/// controller and interrupt share a `static` one.)
pub struct OwnedTwin<P: Plant> {
    /// Dropped by hand, before the queue it borrows.
    twin: ManuallyDrop<Twin<'static, P>>,
    queue: NonNull<StepQueue>,
}

impl<P: Plant> OwnedTwin<P> {
    /// Powers a board on, as [`Twin::with_memory`].
    pub fn new(settings: Settings, plant: P, memory: Memory) -> Self {
        let queue = NonNull::from(std::boxed::Box::leak(std::boxed::Box::new(StepQueue::new())));
        // SAFETY: the queue stays where it is on the heap until `drop` frees it, after the
        // twin, the only holder of references to it. The twin never leaves this struct: it is
        // lent only as `&Twin` (through which no `'static` reference can be taken out), and
        // the methods below act on it in place.
        let twin = Twin::with_memory(unsafe { queue.as_ref() }, settings, plant, memory);
        OwnedTwin { twin: ManuallyDrop::new(twin), queue }
    }

    /// The twin, to look at.
    pub fn twin(&self) -> &Twin<'static, P> {
        &self.twin
    }

    /// The serial output and EEPROM.
    pub fn memory_mut(&mut self) -> &mut Memory {
        &mut self.twin.memory
    }

    /// The thermal plant.
    pub fn plant_mut(&mut self) -> &mut P {
        &mut self.twin.plant
    }

    /// [`Twin::send`].
    pub fn send(&mut self, bytes: &[u8]) {
        self.twin.send(bytes);
    }

    /// [`Twin::hear`].
    pub fn hear(&mut self, bytes: &[u8]) -> bool {
        self.twin.hear(bytes)
    }

    /// [`Twin::run_ms`].
    pub fn run_ms(&mut self, ms: u64) {
        self.twin.run_ms(ms);
    }
}

impl<P: Plant> Drop for OwnedTwin<P> {
    fn drop(&mut self) {
        // SAFETY: the twin is dropped once, here, and the queue after it, once: it came from
        // `Box::leak` in `new` and nothing refers to it any more.
        unsafe {
            ManuallyDrop::drop(&mut self.twin);
            drop(std::boxed::Box::from_raw(self.queue.as_ptr()));
        }
    }
}

/// How many reply lines start with `ok`.
fn oks(replies: &[u8]) -> usize {
    replies.split(|&b| b == b'\n').filter(|l| l.starts_with(b"ok")).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_owned_twin_runs_and_frees_its_queue() {
        for _ in 0..3 {
            let mut t = OwnedTwin::new(Settings::DEFAULT, FirstOrder::default(), Memory::default());
            t.send(b"G91\nG1 X1 F600\nM400\n");
            t.run_ms(500);
            assert_eq!(t.twin().steps[0], 80);
            assert_eq!(t.memory_mut().sent, b"start\nok\nok\nok\n");
        }
    }

    #[test]
    fn the_plant_reads_back_through_the_firmwares_table() {
        for t in [20.0f32, 60.0, 150.0, 210.0, 250.0] {
            let adc = type_1_adc(t);
            let back = crate::heat::thermistor::celsius(&TYPE_1, adc);
            assert!((back - t).abs() < 0.6, "{t} -> {adc} -> {back}");
        }
    }
}
