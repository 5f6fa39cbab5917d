//! gweave firmware for an Arduino Mega 2560 with a RAMPS 1.4 shield.
//!
//! Everything a printer's firmware *means* (the serial protocol, G-code, the planner, the step
//! timing, temperature control and its safety rules) is the controller core,
//! `crates/gweave-controller`, the same code the virtual printer runs on the host. This crate
//! is only the board: it moves bytes, readings and outputs between the core and the chip's
//! peripherals.
//!
//! - the main loop ([`main`]): serial bytes in, ADC readings and endstops in, one turn of the
//!   controller, heater/fan duties and stepper enables out;
//! - the step interrupt (Timer1, [`step_interrupt`]): the core's stepper says which STEP pins
//!   to pulse, which way the DIR pins point, and when to come back;
//! - the millisecond interrupt (Timer0, `clock.rs`): the clock and the heaters' PWM;
//! - the serial receive interrupt (`uart.rs`): bytes into a ring buffer.
//!
//! Safety: every output starts off (a reset leaves all pins as inputs, so the MOSFETs' gates
//! are pulled low), the watchdog resets the chip if the main loop stops, and a halt of the core
//! (a thermal fault, M112) switches the heaters off at once.
#![no_std]
#![no_main]
#![feature(asm_experimental_arch, abi_avr_interrupt)]

mod adc;
mod clock;
mod eeprom;
#[cfg(feature = "inkjet")]
mod inkshield;
mod pins;
mod regs;
mod step_timer;
mod uart;
mod watchdog;

mod config {
    include!(concat!(env!("OUT_DIR"), "/printer.rs"));
}

use core::cell::UnsafeCell;

use gweave_controller::board::{self, Pin as _};
use gweave_controller::serial::emergency::Heard;
use gweave_controller::{Controller, Inputs, Io, Outputs, StepQueue, Stepper, HEATERS};

/// The Mega's crystal.
const CPU_HZ: u32 = 16_000_000;

// The core counts step intervals in Timer1's ticks.
const _: () = assert!(step_timer::TICKS_PER_S == gweave_controller::limits::TICKS_PER_S);

/// The blocks between the main loop (which plans them) and the step interrupt (which runs
/// them). The queue itself is safe to share: the core makes it single-producer,
/// single-consumer.
static QUEUE: StepQueue = StepQueue::new();

/// The step interrupt's own state, set up once before the interrupt is enabled.
struct IsrOnly<T>(UnsafeCell<Option<T>>);
// SAFETY: written once by `main` with the step interrupt still off, then used only by it.
unsafe impl<T> Sync for IsrOnly<T> {}
static STEPPER: IsrOnly<Stepper<'static>> = IsrOnly(UnsafeCell::new(None));

/// The ADC channels in the core's heater order: hotend 0 (A13), hotend 1 (A15), bed (A14).
const ADC_CHANNELS: [u8; HEATERS] = [pins::ADC_TEMP_0, pins::ADC_TEMP_1, pins::ADC_TEMP_BED];

/// What the core asks of the board: serial line, clock, thermistors, endstops, outputs,
/// EEPROM, watchdog.
struct Ramps {
    adc: adc::Sampler<HEATERS>,
    /// The thermistors' latest readings (0-1023 each).
    adc_now: [u16; HEATERS],
}

impl Ramps {
    /// The board's peripherals, once the first full set of thermistor readings is in (16
    /// rounds of 104 us conversions), so that the core's first turn sees real temperatures.
    fn new() -> Self {
        let mut adc = adc::Sampler::new(ADC_CHANNELS);
        let adc_now = loop {
            if let Some(sums) = adc.poll() {
                break sums.map(|s| s / adc::OVERSAMPLE);
            }
        };
        Ramps { adc, adc_now }
    }
}

impl board::Board for Ramps {
    fn receive(&mut self) -> Option<u8> {
        uart::read()
    }

    fn heard(&mut self) -> Heard {
        uart::heard()
    }

    fn inputs(&mut self) -> Inputs {
        if let Some(sums) = self.adc.poll() {
            self.adc_now = sums.map(|s| s / adc::OVERSAMPLE);
        }
        Inputs { now_ms: clock::now_ms(), adc: self.adc_now, endstops: endstops() }
    }

    fn apply(&mut self, out: &Outputs) {
        let [hotend0, hotend1, bed] = out.heater_duty;
        // D9 is the fan on an "EFB" board, the second hotend's heater on "EEB".
        let d9 = if config::SETTINGS.hotends == 2 { hotend1 } else { out.fan_duty };
        clock::set_duty([hotend0, bed, d9]);
        pins::LED.write(hotend0 | hotend1 | bed != 0);
        board::write_enables(&pins::DRIVERS[..config::DRIVERS], out.steppers_enabled);
    }
}

impl Io for Ramps {
    fn send(&mut self, bytes: &[u8]) {
        uart::write(bytes);
    }

    fn build_settings(&self) -> gweave_controller::Settings {
        build_settings()
    }

    fn eeprom_read(&mut self, addr: u16, buf: &mut [u8]) {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = eeprom::read(addr.wrapping_add(i as u16));
        }
    }

    fn eeprom_write(&mut self, addr: u16, data: &[u8]) {
        for (i, &b) in data.iter().enumerate() {
            eeprom::write(addr.wrapping_add(i as u16), b);
            // A byte takes 3.4 ms: a long save must not look like a hang.
            watchdog::feed();
        }
    }

    fn watchdog_feed(&mut self) {
        watchdog::feed();
    }

    #[cfg(feature = "inkjet")]
    fn inkjet_fire(&mut self, head: u8, nozzles: u16) {
        inkshield::fire(head, nozzles);
    }
}

/// Runs `$body` once for each stepper socket the build drives (X, Y, Z, E0, then a mixing
/// hotend's other inputs: `config::DRIVERS` of them), with `$axis` a constant: unrolled by hand,
/// so each pin is a fixed port and bit and its write a couple of instructions, and a socket the
/// build does not use compiles to nothing. (A loop over the table made the step interrupt read
/// each pin's port from RAM and shift its bit into place at run time: hundreds of cycles per
/// interrupt.)
macro_rules! each_driver {
    (|$axis:ident, $d:ident| $body:block) => {{
        const _: () = assert!(config::DRIVERS <= pins::DRIVERS.len());
        const _: () = assert!(pins::DRIVERS.len() == gweave_controller::MOTORS);
        each_driver!(@one 0, $axis, $d, $body);
        each_driver!(@one 1, $axis, $d, $body);
        each_driver!(@one 2, $axis, $d, $body);
        each_driver!(@one 3, $axis, $d, $body);
        each_driver!(@one 4, $axis, $d, $body);
        each_driver!(@one 5, $axis, $d, $body);
        each_driver!(@one 6, $axis, $d, $body);
    }};
    (@one $i:literal, $axis:ident, $d:ident, $body:block) => {{
        const $axis: usize = $i;
        if $axis < config::DRIVERS {
            let $d = pins::DRIVERS[$axis];
            $body
        }
    }};
}

/// The endstop pins' levels, bit `1 << axis` (X, Y, Z).
#[inline(always)]
fn endstops() -> u8 {
    board::endstop_bits(&pins::ENDSTOPS_MIN)
}

#[no_mangle]
pub extern "C" fn main() -> ! {
    let by_watchdog = watchdog::start();
    board::set_up_pins(&pins::DRIVERS[..config::DRIVERS], &pins::ENDSTOPS_MIN);
    pins::LED.make_output();
    #[cfg(feature = "inkjet")]
    inkshield::init();
    clock::init([pins::HEATER_0, pins::HEATER_BED, pins::D9]);
    uart::init(CPU_HZ, config::BAUD);

    let mut controller = Controller::new(&QUEUE, build_settings());
    // SAFETY: the step interrupt is not enabled yet, so nothing else reads STEPPER.
    unsafe { *STEPPER.0.get() = Some(Stepper::new(&QUEUE)) };
    regs::enable_interrupts();
    step_timer::start(1000);
    board::run(&mut controller, &mut Ramps::new(), by_watchdog)
}

/// The printer file's settings, and an inkjet build's heads: what the core starts with and
/// what `M502` restores (built from the program's constants, in flash, not kept in RAM).
fn build_settings() -> gweave_controller::Settings {
    #[cfg(not(feature = "inkjet"))]
    let settings = config::SETTINGS;
    #[cfg(feature = "inkjet")]
    let settings = gweave_controller::Settings { inkjet_heads: inkshield::HEADS, ..config::SETTINGS };
    settings
}

/// The step interrupt (Timer1 compare match A, vector 17).
///
/// The STEP pins due now go high, stay high for at least two microseconds (the A4988 and
/// DRV8825 drivers of RAMPS need 1 us and 1.9 us), then low; the DIR pins are set after the
/// pulse for the next steps, so they are steady long before the next rising edge (the drivers
/// need 200-650 ns). At high step rates the core asks for several step events in one
/// interrupt (an interval of 0: multi-stepping); each is pulsed in turn, the core's next
/// event computed between them, which keeps each STEP pin low for longer than a driver needs.
#[no_mangle]
pub unsafe extern "avr-interrupt" fn __vector_17() {
    // SAFETY: set before this interrupt was enabled; only this handler uses it.
    let Some(stepper) = (unsafe { &mut *STEPPER.0.get() }) else { return };
    loop {
        let out = stepper.tick(endstops());
        if out.step_bits != 0 {
            pulse(out.step_bits);
        }
        if out.interval_ticks != 0 {
            // The directions change only from one segment to the next, never within the
            // events of one interrupt: set once, for the next interrupt's steps.
            each_driver!(|AXIS, d| {
                d.dir.write_in_interrupt(out.dir_bits & (1 << AXIS) != 0);
            });
            step_timer::set_next_in_interrupt(out.interval_ticks);
            return;
        }
    }
}

/// One STEP pulse on the drivers of `step_bits`.
#[inline(always)]
fn pulse(step_bits: u8) {
    each_driver!(|AXIS, d| {
        if step_bits & (1 << AXIS) != 0 {
            // The core asks for the enables after its turn, but a block it queued in that turn
            // may start here first: a driver is enabled before its first step, or the step
            // is lost. (ENABLE is active low.)
            d.enable.write_in_interrupt(false);
            d.step.write_in_interrupt(true);
        }
    });
    // 2 us high (32 cycles, the DRV8825's 1.9 us; the emulated board's test
    // `a_g1_move_gives_exactly_its_steps_on_every_axis` checks every pulse).
    pulse_delay();
    each_driver!(|_AXIS, d| {
        d.step.write_in_interrupt(false);
    });
}

/// About 30 cycles: ten turns of a three-cycle loop (`dec`, then `brne` taken), the rest of
/// the pulse's 32 cycles in the writes around it.
#[inline(always)]
fn pulse_delay() {
    // SAFETY: counts a scratch register down to zero; touches nothing else.
    unsafe {
        core::arch::asm!(
            "ldi {n}, 10",
            "1:",
            "dec {n}",
            "brne 1b",
            n = out(reg_upper) _,
            options(nomem, nostack),
        )
    };
}

/// A bug in the firmware: heaters off, then wait for the watchdog's reset.
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    clock::all_off();
    loop {}
}
