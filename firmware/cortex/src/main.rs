//! gweave firmware for a 32-bit board: an STM32F405/F407 (Cortex-M4F at 168 MHz) wired as
//! BIGTREETECH's SKR Pro 1.x, run in `make test` on QEMU's Netduino Plus 2 (an STM32F405).
//!
//! As on the Arduino Mega (firmware/ramps), everything a printer's firmware *means* is the
//! controller core, `crates/gweave-controller`; this crate is only the board:
//!
//! - the main loop ([`main`]): serial bytes in, thermistor readings and endstops in, one turn
//!   of the controller, heater/fan duties and stepper enables out;
//! - the step interrupt (SysTick, [`step_interrupt`]): the core's stepper says which STEP
//!   pins to pulse, which way the DIR pins point, and when to come back; the same interrupt
//!   keeps the millisecond clock and the heaters' PWM (`clock.rs`);
//! - the serial receive interrupt (`uart.rs`): bytes into a ring buffer.
//!
//! What this build does not do yet on a real board (docs/firmware.md, "A 32-bit board"): set
//! the clock tree up (QEMU does not model the STM32's RCC, so the code assumes 168 MHz and
//! leaves it at reset), read the thermistors (QEMU's ADC returns a sawtooth: the build reads a
//! fixed room temperature, [`ROOM_ADC`]), and keep the settings in flash (`M500` keeps them in
//! RAM until power-off).
//!
//! Safety: every output starts off (a reset leaves all pins as inputs, and the MOSFETs' gates
//! are pulled low), the watchdog resets the chip if the main loop stops, a halt of the core
//! (a thermal fault, M112) switches the heaters off at once, and so does any fault.
#![no_std]
#![no_main]

mod clock;
mod pins;
mod regs;
mod start;
mod step_timer;
mod uart;
mod watchdog;

mod config {
    include!(concat!(env!("OUT_DIR"), "/printer.rs"));
}

use core::cell::UnsafeCell;

use gweave_controller::board::{self, Pin as _};
use gweave_controller::serial::emergency::Heard;
use gweave_controller::{Controller, Inputs, Io, Outputs, StepQueue, Stepper, HEATERS, MOTORS};

use crate::pins::{write_port, DRIVERS, PORTS};

/// The CPU clock the timings are computed for: an STM32F4 on its PLL at 168 MHz, as QEMU's
/// Netduino Plus 2 runs (a real chip starts on its 16 MHz internal oscillator: see the docs).
pub const CPU_HZ: u32 = 168_000_000;
/// USART1's bus (APB2) runs at half the CPU clock.
const APB2_HZ: u32 = CPU_HZ / 2;

// The core counts step intervals in 2 MHz ticks.
const _: () = assert!(step_timer::TICKS_PER_S == gweave_controller::limits::TICKS_PER_S);
// The core asks for at most MAX_TIMER_TICKS at once; SysTick's 24 bits hold more.
const _: () = assert!(gweave_controller::limits::MAX_TIMER_TICKS <= step_timer::MAX_TICKS);
// The printer file's drivers fit the board's six (a 4-input mixing hotend needs seven): a
// printer this board cannot drive stops the build.
const _: () = assert!(config::DRIVERS <= DRIVERS.len(), "the printer needs more drivers than the board has");

/// The raw 10-bit reading of every thermistor: 977 is 25 °C on the EPCOS 100 kΩ (type 1) with
/// its 4.7 kΩ pull-up (`crates/gweave-controller/src/heat/thermistor.rs`). QEMU models no
/// thermistor, and a real board's reading needs the ADC driver a port adds (see the docs).
/// With a fixed reading a heater never warms: the core's thermal protection stops it, as it
/// would on a board whose heater is unplugged.
const ROOM_ADC: u16 = 977;

/// The blocks between the main loop (which plans them) and the step interrupt (which runs
/// them); the core makes the queue single-producer, single-consumer.
static QUEUE: StepQueue = StepQueue::new();

/// The step interrupt's own state.
struct StepState {
    stepper: Stepper<'static>,
    clock: clock::Clock,
    /// The interval now being timed, in ticks.
    period_ticks: u32,
    /// Ticks still to wait, after this interval, before asking the stepper again.
    wait_ticks: u32,
    /// The DIR pins' levels, bit `1 << motor` (all low after reset).
    dir_bits: u8,
}

/// The step interrupt's state, set up once before the interrupt is enabled.
struct IsrOnly<T>(UnsafeCell<Option<T>>);
// SAFETY: written once by `main` with the step interrupt still off, then used only by it.
unsafe impl<T> Sync for IsrOnly<T> {}
static STEP: IsrOnly<StepState> = IsrOnly(UnsafeCell::new(None));

/// What the core asks of the board: serial line, clock, thermistors, endstops, outputs,
/// EEPROM, watchdog.
struct Board {
    /// The settings `M500` saves: in RAM, so they last until power-off. A port keeps them in a
    /// flash sector (see the docs). Erased, as a new EEPROM is: 0xFF.
    eeprom: [u8; EEPROM_BYTES],
    /// The stepper enables last written (none yet): pins are written only when they change.
    enabled: Option<u8>,
}

/// Bytes of the emulated EEPROM: the core's settings and mixing tools.
const EEPROM_BYTES: usize =
    (gweave_controller::settings::EEPROM_BYTES + gweave_controller::mixing::EEPROM_BYTES) as usize;

impl Io for Board {
    fn send(&mut self, bytes: &[u8]) {
        uart::write(bytes);
    }

    fn build_settings(&self) -> gweave_controller::Settings {
        config::SETTINGS
    }

    fn eeprom_read(&mut self, addr: u16, buf: &mut [u8]) {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = self.eeprom.get(usize::from(addr) + i).copied().unwrap_or(0xFF);
        }
    }

    fn eeprom_write(&mut self, addr: u16, data: &[u8]) {
        for (i, &b) in data.iter().enumerate() {
            if let Some(cell) = self.eeprom.get_mut(usize::from(addr) + i) {
                *cell = b;
            }
        }
    }

    fn watchdog_feed(&mut self) {
        watchdog::feed();
    }
}

impl board::Board for Board {
    fn receive(&mut self) -> Option<u8> {
        uart::read()
    }

    fn heard(&mut self) -> Heard {
        uart::heard()
    }

    fn inputs(&mut self) -> Inputs {
        Inputs { now_ms: clock::now_ms(), adc: [ROOM_ADC; HEATERS], endstops: endstops() }
    }

    fn apply(&mut self, out: &Outputs) {
        let [hotend0, hotend1, bed] = out.heater_duty;
        clock::set_duty([hotend0, hotend1, bed, out.fan_duty]);
        if self.enabled != Some(out.steppers_enabled) {
            self.enabled = Some(out.steppers_enabled);
            board::write_enables(&DRIVERS, out.steppers_enabled);
        }
    }
}

/// The endstop pins' levels, bit `1 << axis` (X, Y, Z).
fn endstops() -> u8 {
    board::endstop_bits(&pins::ENDSTOPS_MIN)
}

/// The program, from the reset handler (`start.rs`). Never inlined there, so that no float
/// register is saved before the reset handler switched the FPU on.
#[inline(never)]
pub fn main() -> ! {
    let by_watchdog = watchdog::start();
    pins::enable_ports();
    board::set_up_pins(&DRIVERS, &pins::ENDSTOPS_MIN);
    for p in pins::POWER {
        p.write(false);
        p.make_output();
    }
    uart::init(APB2_HZ, config::BAUD);

    let mut controller = Controller::new(&QUEUE, config::SETTINGS);
    let first_ticks = clock::TICKS_PER_MS;
    let state = StepState {
        stepper: Stepper::new(&QUEUE),
        clock: clock::Clock::new(),
        period_ticks: first_ticks,
        wait_ticks: 0,
        dir_bits: 0,
    };
    // SAFETY: the step interrupt is not started yet, so nothing else reads STEP.
    unsafe { *STEP.0.get() = Some(state) };
    step_timer::start(first_ticks);
    regs::enable_interrupts();
    board::run(&mut controller, &mut Board { eeprom: [0xFF; EEPROM_BYTES], enabled: None }, by_watchdog)
}

/// A step pulse's width: the DRV8825 needs 1.9 us high, the A4988 1 us, TMC22xx 100 ns.
const STEP_PULSE_CYCLES: u32 = CPU_HZ / 500_000;

/// The step interrupt (SysTick).
///
/// The STEP pins due now go high, stay high 2 us, then low; the DIR pins are set with the
/// falling edge for the next steps, so they are steady long before the next rising edge (the
/// drivers need 200-650 ns). An interval longer than a millisecond is waited out in pieces of
/// at most one, so that the clock sees every millisecond.
///
/// # Safety
/// Called by the core for the SysTick exception only.
pub unsafe extern "C" fn step_interrupt() {
    step_timer::begin_in_interrupt();
    // SAFETY: set before this interrupt was enabled; only this handler uses it.
    let Some(state) = (unsafe { &mut *STEP.0.get() }) else { return };
    state.clock.advance_in_interrupt(state.period_ticks);
    if state.wait_ticks != 0 {
        schedule(state);
        return;
    }
    // At high step rates the core asks for several step events in one interrupt (an interval
    // of 0: multi-stepping): each is pulsed in turn, the next computed between them.
    loop {
        let out = state.stepper.tick(endstops());
        // Per port, the BSRR words that raise the STEP pins due now, then lower them and set
        // the DIR pins that change: one write per port and edge, none when idle.
        let mut high = [0u32; PORTS];
        let mut low = [0u32; PORTS];
        let dir_changes = out.dir_bits ^ state.dir_bits;
        state.dir_bits = out.dir_bits;
        for (motor, d) in DRIVERS.iter().enumerate().take(MOTORS) {
            let bit = 1 << motor;
            if out.step_bits & bit != 0 {
                // The core asks for the enables after its turn, but a block it queued in that
                // turn may start here first: a driver is enabled before its first step, or the
                // step is lost. (ENABLE is active low.)
                d.enable.write(false);
                high[usize::from(d.step.port)] |= d.step.mask();
                low[usize::from(d.step.port)] |= d.step.mask() << 16;
            }
            if dir_changes & bit != 0 {
                let shift = if out.dir_bits & bit != 0 { 0 } else { 16 };
                low[usize::from(d.dir.port)] |= d.dir.mask() << shift;
            }
        }
        for (port, &bits) in high.iter().enumerate() {
            if bits != 0 {
                write_port(port, bits);
            }
        }
        let last = out.interval_ticks != 0;
        if last {
            state.wait_ticks = u32::from(out.interval_ticks);
            schedule(state);
        }
        if out.step_bits != 0 {
            step_timer::wait_in_interrupt(STEP_PULSE_CYCLES);
        }
        for (port, &bits) in low.iter().enumerate() {
            if bits != 0 {
                write_port(port, bits);
            }
        }
        if last {
            return;
        }
    }
}

/// Time the next piece (at most a millisecond) of the ticks still to wait.
fn schedule(state: &mut StepState) {
    let piece = state.wait_ticks.min(clock::TICKS_PER_MS);
    state.wait_ticks -= piece;
    state.period_ticks = piece;
    step_timer::set_next_in_interrupt(piece);
}

/// Any fault (a bug: a bad address, an undefined instruction) or interrupt this firmware did
/// not ask for: heaters off, then wait for the watchdog's reset.
///
/// # Safety
/// Called by the core for an exception only.
pub unsafe extern "C" fn fault() {
    clock::all_off();
    #[allow(clippy::empty_loop)]
    loop {}
}

/// A bug in the firmware: heaters off, then wait for the watchdog's reset.
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    clock::all_off();
    #[allow(clippy::empty_loop)]
    loop {}
}
