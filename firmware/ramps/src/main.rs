//! gweave firmware for an Arduino Mega 2560 with a RAMPS 1.4 shield.
#![no_std]
#![no_main]
#![feature(asm_experimental_arch, abi_avr_interrupt)]

mod adc;
mod clock;
mod eeprom;
mod pins;
mod regs;
mod step_timer;
mod uart;
mod watchdog;

mod config {
    include!(concat!(env!("OUT_DIR"), "/printer.rs"));
}

/// The Mega's crystal.
const CPU_HZ: u32 = 16_000_000;

#[no_mangle]
pub extern "C" fn main() -> ! {
    let by_watchdog = watchdog::start();
    clock::init([pins::HEATER_0, pins::HEATER_BED, pins::D9]);
    uart::init(CPU_HZ, config::BAUD);
    let mut adc = adc::Sampler::new([pins::ADC_TEMP_0, pins::ADC_TEMP_BED, pins::ADC_TEMP_1]);
    regs::enable_interrupts();
    if by_watchdog {
        uart::write(b"echo: Watchdog Reset\n");
    }
    uart::write(b"start\n");
    let mut line = [0u8; 96];
    let mut len = 0;
    let mut temps = [0u16; 3];
    loop {
        watchdog::feed();
        if let Some(t) = adc.poll() {
            temps = t;
        }
        if let Some(b) = uart::read() {
            if b == b'\n' {
                if line[..len].starts_with(b"M105") {
                    uart::write(b"ok T:");
                    write_u16(temps[0]);
                    uart::write(b"\n");
                } else {
                    uart::write(b"ok\n");
                }
                len = 0;
            } else if len < line.len() {
                line[len] = b;
                len += 1;
            }
        }
    }
}

fn write_u16(mut v: u16) {
    let mut buf = [0u8; 5];
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    uart::write(&buf[i..]);
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    clock::all_off();
    loop {}
}
