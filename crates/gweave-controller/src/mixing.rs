//! A mixing hotend: several extruder steppers (inputs E0, E1, ...) pushing filament into one
//! nozzle, in the ratios of the active *virtual tool*, as Marlin's `MIXING_EXTRUDER` does
//! (`MarlinFirmware/Marlin:Marlin/src/feature/mixing.cpp`, `gcode/feature/mixing/M163-M165.cpp`).
//!
//! # The commands
//!
//! - `M163 S<input> P<weight>`: one input's weight in the *collector* (a negative weight counts
//!   as 0). Only ratios matter: `P0.6`/`P0.4` is `P60`/`P40`.
//! - `M164 S<tool>`: the collector, normalised, becomes virtual tool `S` (the active tool
//!   without `S`). An all-zero collector is refused (Marlin would divide by zero).
//! - `M165 A B C D`: the collector from the letters (inputs 0-3, a letter not given is 0), then
//!   normalised into the active tool: a mix in one line.
//! - `T<n>`: the moves planned from here on use tool `n`'s mix. Nothing else happens (no park,
//!   no purge: that is the G-code's business).
//!
//! At power-on tool `t` is input `t` alone for `t` below the number of inputs, input 0 alone
//! above (Marlin's `reset_vtools`); `M500` keeps the tools in EEPROM after the settings, `M501`
//! and a reset read them back, `M502` restores the power-on tools, `M503` prints them as the
//! `M163`/`M164` lines that set them.
//!
//! # Integers: units of 1/10 000
//!
//! A mix is stored as integer *units* summing to exactly [`MIX_UNITS`] (10 000, so the 4-decimal
//! ratios `gweave mix` writes, which sum to exactly 1, are kept exactly). Normalising gives each
//! input the floor of its share and the units left over to the largest remainders, so the sum
//! is exact whatever the weights (the largest-remainder method).
//!
//! # Sharing the E steps: cumulative shares, rounded prefix sums
//!
//! Each planned move's E steps (signed) are shared among the inputs in the main loop, when the
//! move is planned with the mix active then. Every input keeps its *ideal* cumulative share of
//! all E steps so far, exactly, as whole steps plus a remainder in units (`ideal_k +=
//! units_k * e / 10 000`: integers, no drift over a print of millions of steps). What each input
//! is given cumulatively is the difference of consecutive rounded prefix sums of the ideals:
//! `given_k = round(I_0 + ... + I_k) - round(I_0 + ... + I_(k-1))`. So
//!
//! - the inputs' totals add up to exactly the E steps (the last prefix is the E total: the units
//!   sum to 10 000), and
//! - each input's cumulative steps are within one step of its ideal share (two roundings of half
//!   a step at most), across moves and across changes of mix: a mix change shifts nothing.
//!
//! The move's share of input `k` is `given_k` now less `given_k` before. This is the split the
//! virtual printer's Marlin model makes (`gweave-sim`'s `motion/stepper.rs`), so a file's
//! per-input step counts are the same on both, step for step.
//!
//! # In the step interrupt: each input a Bresenham axis
//!
//! Each input is a motor of its own in the move's step block (its step and direction bits are
//! `1 << (E + input)`), stepped by the same Bresenham counters as X, Y and Z
//! ([`crate::stepper`]): its steps are spread evenly over the move's step events, so at every
//! moment of a move each input has made its share of the steps so far within one step
//! (Bresenham's error term), and ends on its exact count. The interrupt does one more 32-bit
//! addition and comparison per input and event, nothing else: the sharing is done before.
//! (Marlin instead gives each E step to one input, chosen in the interrupt by per-input
//! accumulators: `feature/mixing.h`'s `get_next_stepper` and `stepper.cpp`'s mixing stepper
//! selection; its inputs never step at once, ours may, which drivers do not mind.)

use crate::limits::{MIX_INPUTS, MIX_TOOLS};
use crate::settings::crc16;
use crate::Io;

/// A mix's units: the shares of all inputs sum to exactly this.
pub const MIX_UNITS: u16 = 10_000;

/// A mix: the units of each input (E0 first), summing to [`MIX_UNITS`] over the inputs fitted.
pub type Mix = [u16; MIX_INPUTS];

/// Why a mixing command was refused (nothing changed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MixError {
    /// An input at or past the inputs fitted.
    Input,
    /// A tool at or past [`MIX_TOOLS`].
    Tool,
    /// A collector of all zeros: no mix to store.
    AllZero,
}

/// The mixer: the collector, the virtual tools, the active tool, and the shares so far.
#[derive(Debug, Clone, PartialEq)]
pub struct Mixer {
    /// Inputs fitted (2 to [`MIX_INPUTS`]; 0 when the hotend does not mix).
    inputs: u8,
    collector: [f32; MIX_INPUTS],
    tools: [Mix; MIX_TOOLS],
    active: u8,
    /// Each input's ideal cumulative share of E steps: `whole + units / MIX_UNITS` steps, with
    /// `0 <= units < MIX_UNITS` (so a negative share has a negative `whole`). What each input
    /// was given follows from them (the rounded prefix sums), so it is not kept.
    ideal_whole: [i32; MIX_INPUTS],
    ideal_units: [u16; MIX_INPUTS],
}

/// Where the tools start in EEPROM (after the settings), and the mark of their layout.
const EEPROM_MARK: [u8; 4] = *b"GWM1";
const EEPROM_AT: u16 = crate::settings::EEPROM_BYTES;
/// Bytes of the tools in EEPROM: the mark, two bytes per input and tool, a CRC-16.
pub const EEPROM_BYTES: u16 = 4 + (2 * MIX_INPUTS * MIX_TOOLS) as u16 + 2;

impl Mixer {
    /// A mixer of `inputs` inputs (clamped to [`MIX_INPUTS`]; below 2 nothing mixes) with the
    /// power-on tools.
    pub fn new(inputs: u8) -> Mixer {
        let inputs = if inputs < 2 { 0 } else { inputs.min(MIX_INPUTS as u8) };
        let mut mixer = Mixer {
            inputs,
            collector: [0.0; MIX_INPUTS],
            tools: [[0; MIX_INPUTS]; MIX_TOOLS],
            active: 0,
            ideal_whole: [0; MIX_INPUTS],
            ideal_units: [0; MIX_INPUTS],
        };
        mixer.reset_tools();
        mixer
    }

    /// Inputs fitted (0: no mixing).
    pub fn inputs(&self) -> usize {
        self.inputs as usize
    }

    /// Tool `t` is input `t` alone (input 0 alone past the inputs), Marlin's `reset_vtools`.
    pub fn reset_tools(&mut self) {
        let inputs = self.inputs();
        for (t, mix) in self.tools.iter_mut().enumerate() {
            *mix = [0; MIX_INPUTS];
            mix[if t < inputs { t } else { 0 }] = MIX_UNITS;
        }
    }

    /// `M163`: input `input`'s weight in the collector (negative counts as 0).
    pub fn set_weight(&mut self, input: usize, weight: f32) -> Result<(), MixError> {
        if input >= self.inputs() {
            return Err(MixError::Input);
        }
        self.collector[input] = if weight > 0.0 { weight } else { 0.0 };
        Ok(())
    }

    /// `M164`: stores the collector, normalised, as tool `tool` (the active tool if `None`).
    pub fn store(&mut self, tool: Option<usize>) -> Result<(), MixError> {
        let tool = tool.unwrap_or(usize::from(self.active));
        if tool >= MIX_TOOLS {
            return Err(MixError::Tool);
        }
        self.tools[tool] = normalise(&self.collector[..self.inputs()]).ok_or(MixError::AllZero)?;
        Ok(())
    }

    /// `M165`: the collector from `weights` (one per input, `None` is 0), stored into the
    /// active tool. An all-zero mix changes nothing.
    pub fn set_active(&mut self, weights: [Option<f32>; MIX_INPUTS]) -> Result<(), MixError> {
        let mut collector = [0.0; MIX_INPUTS];
        for (c, w) in collector.iter_mut().zip(weights).take(self.inputs()) {
            *c = w.filter(|w| *w > 0.0).unwrap_or(0.0);
        }
        let mix = normalise(&collector[..self.inputs()]).ok_or(MixError::AllZero)?;
        self.collector = collector;
        self.tools[usize::from(self.active)] = mix;
        Ok(())
    }

    /// `T<tool>`: the moves planned from now on use this tool's mix.
    pub fn select(&mut self, tool: usize) -> Result<(), MixError> {
        if tool >= MIX_TOOLS {
            return Err(MixError::Tool);
        }
        self.active = tool as u8;
        Ok(())
    }

    /// The active tool.
    pub fn active(&self) -> usize {
        usize::from(self.active)
    }

    /// The largest input's share of the active tool's E steps (1 without a mixing hotend): the
    /// most one motor feeds of a move's E.
    pub fn largest_share(&self) -> f32 {
        match self.inputs {
            0 => 1.0,
            _ => {
                f32::from(self.tools[usize::from(self.active)].iter().copied().max().unwrap_or(0))
                    / f32::from(MIX_UNITS)
            }
        }
    }

    /// Tool `t`'s mix.
    pub fn tool(&self, t: usize) -> Mix {
        self.tools[t]
    }

    /// Shares a move's `e_steps` (signed) among the inputs by the active mix: each input's
    /// signed steps for the move (see the module's documentation). Zeros without mixing.
    pub fn split(&mut self, e_steps: i32) -> [i32; MIX_INPUTS] {
        let n = self.inputs();
        if n == 0 || e_steps == 0 {
            return [0; MIX_INPUTS];
        }
        let before = self.given();
        let mix = self.tools[usize::from(self.active)];
        // e = q * UNITS + r, 0 <= r < UNITS: units * e / UNITS = units * q + units * r / UNITS,
        // every product within 32 bits (units * r < 10^8; units * q within the E steps).
        let units = i32::from(MIX_UNITS);
        let (q, r) = (e_steps.div_euclid(units), e_steps.rem_euclid(units));
        let ideals = self.ideal_whole.iter_mut().zip(&mut self.ideal_units);
        for ((whole, ideal_units), &u) in ideals.zip(&mix).take(n) {
            let u = i32::from(u);
            let sum_units = i32::from(*ideal_units) + u * r;
            *whole += u * q + sum_units.div_euclid(units);
            *ideal_units = sum_units.rem_euclid(units) as u16;
        }
        let after = self.given();
        core::array::from_fn(|k| after[k] - before[k])
    }

    /// What each input has been given so far, steps: the differences of the rounded prefix
    /// sums of the ideal shares.
    fn given(&self) -> [i32; MIX_INPUTS] {
        let units = i32::from(MIX_UNITS);
        let mut given = [0; MIX_INPUTS];
        let (mut prefix_whole, mut prefix_units) = (0i32, 0i32);
        let mut rounded_before = 0;
        let ideals = self.ideal_whole.iter().zip(&self.ideal_units);
        for (g, (&whole, &ideal_units)) in given.iter_mut().zip(ideals).take(self.inputs()) {
            let sum_units = prefix_units + i32::from(ideal_units);
            prefix_whole += whole + sum_units.div_euclid(units);
            prefix_units = sum_units.rem_euclid(units);
            let rounded = round_half_away(prefix_whole, prefix_units);
            *g = rounded - rounded_before;
            rounded_before = rounded;
        }
        given
    }

    /// `M500`: the tools to EEPROM after the settings.
    pub fn save(&self, io: &mut impl Io) {
        let mut crc = 0xFFFF;
        io.eeprom_write(EEPROM_AT, &EEPROM_MARK);
        let mut at = EEPROM_AT + 4;
        for units in self.tools.iter().flatten() {
            let bytes = units.to_le_bytes();
            crc = crc16(crc, &bytes);
            io.eeprom_write(at, &bytes);
            at += 2;
        }
        io.eeprom_write(at, &crc.to_le_bytes());
    }

    /// `M501` and power-on: the tools from EEPROM; `false`, changing nothing, when there are
    /// none, the CRC is wrong or a mix does not sum to [`MIX_UNITS`] over the inputs fitted.
    pub fn load(&mut self, io: &mut impl Io) -> bool {
        let mut mark = [0u8; 4];
        io.eeprom_read(EEPROM_AT, &mut mark);
        if mark != EEPROM_MARK {
            return false;
        }
        let mut tools = [[0u16; MIX_INPUTS]; MIX_TOOLS];
        let mut crc = 0xFFFF;
        let mut at = EEPROM_AT + 4;
        for units in tools.iter_mut().flatten() {
            let mut bytes = [0u8; 2];
            io.eeprom_read(at, &mut bytes);
            crc = crc16(crc, &bytes);
            *units = u16::from_le_bytes(bytes);
            at += 2;
        }
        let mut stored = [0u8; 2];
        io.eeprom_read(at, &mut stored);
        let n = self.inputs();
        let sums =
            tools.iter().all(|t| t[..n].iter().map(|&u| u32::from(u)).sum::<u32>() == u32::from(MIX_UNITS));
        if u16::from_le_bytes(stored) != crc || !sums {
            return false;
        }
        self.tools = tools;
        true
    }
}

/// Weights (non-negative) to units summing to [`MIX_UNITS`]: floors, then the units left over
/// one each to the largest remainders (the first input on a tie). `None` if all are zero.
fn normalise(weights: &[f32]) -> Option<Mix> {
    let sum: f32 = weights.iter().sum();
    if sum.is_nan() || sum <= 0.0 || sum.is_infinite() {
        return None;
    }
    let mut mix = [0u16; MIX_INPUTS];
    let mut rest = [0.0f32; MIX_INPUTS];
    let mut left = MIX_UNITS;
    for (k, &w) in weights.iter().enumerate() {
        let exact = w * f32::from(MIX_UNITS) / sum;
        mix[k] = (exact as u16).min(left);
        rest[k] = exact - f32::from(mix[k]);
        left -= mix[k];
    }
    while left > 0 {
        let mut best = 0;
        for k in 1..weights.len() {
            if rest[k] > rest[best] {
                best = k;
            }
        }
        mix[best] += 1;
        rest[best] = -1.0;
        left -= 1;
    }
    Some(mix)
}

/// `whole + units / MIX_UNITS` rounded to the nearest step, a half away from zero (as `f64::round`
/// in the virtual printer's model).
fn round_half_away(whole: i32, units: i32) -> i32 {
    let twice = 2 * units;
    let up = if whole >= 0 { twice >= i32::from(MIX_UNITS) } else { twice > i32::from(MIX_UNITS) };
    whole + i32::from(up)
}

#[cfg(test)]
mod tests;
