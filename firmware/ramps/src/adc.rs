//! The analog-to-digital converter, sampling the thermistors without blocking.
//!
//! A conversion takes 13 ADC clocks; the ADC clock is the CPU clock divided by 128 (125 kHz,
//! within the 50-200 kHz the datasheet asks for full 10-bit precision), so 104 us. Rather than
//! wait, the main loop calls [`Sampler::poll`]: when a conversion is done it adds the result
//! to its channel's sum and starts the next channel. Each reading is the sum of
//! [`OVERSAMPLE`] conversions, which averages the noise away (as Marlin's `OVERSAMPLENR`).

use crate::regs::{ADCSRA, ADCSRB, ADCW, ADMUX, DIDR2};

/// ADMUX: reference = AVCC (the 5 V the thermistor dividers hang from).
const REFS0: u8 = 1 << 6;
/// ADCSRA: enable, start conversion, prescaler 128.
const ADEN: u8 = 1 << 7;
const ADSC: u8 = 1 << 6;
const ADPS_DIV128: u8 = 0b111;
/// ADCSRB: MUX5, the high bit of the channel number (channels 8-15).
const MUX5: u8 = 1 << 3;

/// Conversions summed per reading.
pub const OVERSAMPLE: u16 = 16;

/// Round-robin sampler of `N` channels.
pub struct Sampler<const N: usize> {
    channels: [u8; N],
    sums: [u16; N],
    /// The channel being converted now (index into `channels`).
    current: usize,
    /// Conversions summed so far into every channel of this round.
    count: u16,
}

impl<const N: usize> Sampler<N> {
    /// Enable the ADC on `channels` (0-15) and start the first conversion.
    pub fn new(channels: [u8; N]) -> Self {
        // The thermistor pins are analog only: switch their digital input buffers off.
        let mut didr = 0;
        for &c in &channels {
            if c >= 8 {
                didr |= 1 << (c - 8);
            }
        }
        DIDR2.write(didr);
        ADCSRA.write(ADEN | ADPS_DIV128);
        let s = Sampler { channels, sums: [0; N], current: 0, count: 0 };
        s.start();
        s
    }

    fn start(&self) {
        let c = self.channels[self.current];
        // The channel number is split: its low three bits in ADMUX, bit 3 as MUX5 in ADCSRB.
        ADCSRB.write(if c >= 8 { MUX5 } else { 0 });
        ADMUX.write(REFS0 | (c & 7));
        ADCSRA.write(ADEN | ADSC | ADPS_DIV128);
    }

    /// Take a finished conversion and start the next. Every `OVERSAMPLE` rounds it returns the
    /// sums, one per channel (0..=1023 * OVERSAMPLE).
    pub fn poll(&mut self) -> Option<[u16; N]> {
        if ADCSRA.read() & ADSC != 0 {
            return None;
        }
        self.sums[self.current] += ADCW.read() & 0x3FF;
        self.current += 1;
        let mut done = None;
        if self.current == N {
            self.current = 0;
            self.count += 1;
            if self.count == OVERSAMPLE {
                done = Some(self.sums);
                self.sums = [0; N];
                self.count = 0;
            }
        }
        self.start();
        done
    }
}
