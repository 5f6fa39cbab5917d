//! Mixes as firmware commands, both ways: render a `Mix` as G-code lines, and
//! follow the mixing commands of a G-code stream in a `MixingState`.
//!
//! Firmware semantics (Marlin's `gcode/feature/mixing/M163-M165.cpp` and `feature/mixing.cpp`;
//! RepRapFirmware's `M563`/`M567` documentation):
//! - Marlin MIXING_EXTRUDER: `M163 S<i> P<f>` sets input i's factor in a
//!   collector (negative -> 0); `M164 S<t>` normalises the collector and stores
//!   it as virtual tool t; `M165 A B C D H I` sets inputs 0-5 at once (missing
//!   letters are 0) into the active tool; `T<n>` selects a stored tool.
//!   Only ratios matter, but an all-zero mix divides by zero: never emit one.
//! - RepRapFirmware: `M563 P<t> D<d0:d1:..> H<h>` defines a tool with several
//!   drives, `M567 P<t> E<a:b:..>` sets its mix, used as written, **not
//!   normalised**: the ratios must sum to 1 or the flow is wrong.
//!
//! Decimal output uses largest-remainder (Hamilton) rounding: scale every ratio
//! to units of `10^-decimals`, round all down, then give the missing units one by
//! one to the largest remainders (ties to the lower input). The printed numbers
//! then sum to exactly 1, and since at least one unit exists, never all zero.

use std::collections::BTreeMap;
use std::fmt::Write;

use super::mix::{Mix, MixError};
use crate::firmware::MixingCode;
use crate::gcode::line::{Block, Command};
use crate::gcode::number::scan;

/// Marlin's M165 letters, inputs 0 to 5.
pub const M165_LETTERS: [char; 6] = ['A', 'B', 'C', 'D', 'H', 'I'];

/// Marlin's default number of virtual tools (MIXING_VIRTUAL_TOOLS).
pub const MARLIN_VIRTUAL_TOOLS: usize = 16;

/// Why a mixing command or a dialect setting is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DialectError {
    /// More decimals than [`Decimals::MAX`].
    #[error("{0} decimals is too many (at most {max})", max = Decimals::MAX)]
    Decimals(u32),
    /// M165 has more input letters than the mix has inputs.
    #[error("M165 has letters for 6 inputs, the mix has {0}")]
    TooManyInputsForM165(usize),
    /// An M563 tool without a drive.
    #[error("a tool needs at least one drive")]
    NoDrives,
    /// An M-code that is not one of the mixing commands.
    #[error("M{code} is not a mixing command")]
    NotMixing {
        /// The M-code's number.
        code: u16,
    },
    /// A mixing command without a word it needs.
    #[error("M{code} needs the word {letter}")]
    MissingWord {
        /// The M-code's number.
        code: u16,
        /// The missing word's letter.
        letter: char,
    },
    /// A word whose value is NaN or infinite.
    #[error("M{code} {letter}{value}: not a finite number")]
    NotFinite {
        /// The M-code's number.
        code: u16,
        /// The word's letter.
        letter: char,
        /// The value as read.
        value: f64,
    },
    /// A word that should be a tool or input index but is negative, fractional or too large.
    #[error("M{code} {letter}{value}: not an index")]
    BadIndex {
        /// The M-code's number.
        code: u16,
        /// The word's letter.
        letter: char,
        /// The value as read.
        value: f64,
    },
    /// An input index at or past the number of inputs.
    #[error("input {index} does not exist ({inputs} inputs)")]
    NoSuchInput {
        /// The index as written.
        index: usize,
        /// The number of inputs of the mixer.
        inputs: usize,
    },
    /// A virtual tool at or past the number of tools.
    #[error("virtual tool {tool} does not exist ({tools} tools)")]
    NoSuchTool {
        /// The tool as written.
        tool: usize,
        /// The number of virtual tools.
        tools: usize,
    },
    /// A command that would store a mix of all zeros.
    #[error("M{code} would store an all-zero mix; the firmware would divide by zero")]
    AllZero {
        /// The M-code's number.
        code: u16,
    },
    /// The mix itself is invalid.
    #[error(transparent)]
    Mix(#[from] MixError),
}

/// Number of decimals printed, 0 to 9.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decimals(u32);

impl Decimals {
    /// The most decimals a mixing command is written with.
    pub const MAX: u32 = 9;

    /// `decimals` places, refused above [`Decimals::MAX`].
    pub fn new(decimals: u32) -> Result<Self, DialectError> {
        if decimals <= Self::MAX {
            Ok(Self(decimals))
        } else {
            Err(DialectError::Decimals(decimals))
        }
    }

    fn scale(self) -> u64 {
        10u64.pow(self.0)
    }
}

impl Default for Decimals {
    /// Four decimals: 0.01 % steps, finer than any hotend can meter.
    fn default() -> Self {
        Self(4)
    }
}

/// Ratios in integer units of `10^-decimals` summing to exactly `10^decimals`
/// (largest-remainder rounding, see the module docs).
pub fn round_to_units(mix: &Mix, decimals: Decimals) -> Vec<u64> {
    let scale = decimals.scale();
    let scaled: Vec<f64> = mix.ratios().iter().map(|r| r * scale as f64).collect();
    // Ratios are in [0, 1], so the casts are within range.
    let mut units: Vec<u64> = scaled.iter().map(|q| q.floor() as u64).collect();
    let given: u64 = units.iter().sum();
    let mut order: Vec<usize> = (0..units.len()).collect();
    // Largest remainder first; the stable sort keeps ties in input order.
    order.sort_by(|&a, &b| {
        let ra = scaled[a] - units[a] as f64;
        let rb = scaled[b] - units[b] as f64;
        rb.total_cmp(&ra)
    });
    // A normalised mix sums to 1 within rounding, so the floors fall short of
    // `scale` by less than the number of inputs.
    for &i in order.iter().cycle().take(scale.saturating_sub(given) as usize) {
        units[i] += 1;
    }
    units
}

/// `units * 10^-decimals` as the shortest decimal: `0.25`, `1`, `0`.
fn format_units(units: u64, decimals: Decimals) -> String {
    let scale = decimals.scale();
    let (whole, frac) = (units / scale, units % scale);
    if frac == 0 {
        return whole.to_string();
    }
    let digits = format!("{frac:0width$}", width = decimals.0 as usize);
    format!("{whole}.{}", digits.trim_end_matches('0'))
}

/// The ratios as the firmware lines write them (trailing zeros trimmed).
pub(crate) fn formatted(mix: &Mix, decimals: Decimals) -> Vec<String> {
    round_to_units(mix, decimals).into_iter().map(|u| format_units(u, decimals)).collect()
}

/// Marlin: `M163 S<i> P<f>` for every input, then `M164 S<tool>`.
pub fn marlin_m163_m164(mix: &Mix, tool: usize, decimals: Decimals) -> Vec<String> {
    let mut lines: Vec<String> =
        formatted(mix, decimals).into_iter().enumerate().map(|(i, p)| format!("M163 S{i} P{p}")).collect();
    lines.push(format!("M164 S{tool}"));
    lines
}

/// Marlin: `M165 A<f> B<f> ...`, the active tool's mix in one line (up to 6 inputs).
pub fn marlin_m165(mix: &Mix, decimals: Decimals) -> Result<String, DialectError> {
    if mix.inputs() > M165_LETTERS.len() {
        return Err(DialectError::TooManyInputsForM165(mix.inputs()));
    }
    let mut line = String::from("M165");
    for (letter, p) in M165_LETTERS.iter().zip(formatted(mix, decimals)) {
        let _ = write!(line, " {letter}{p}");
    }
    Ok(line)
}

/// RepRapFirmware: `M567 P<tool> E<a:b:...>`, the printed ratios summing to exactly 1.
pub fn rrf_m567(mix: &Mix, tool: u32, decimals: Decimals) -> String {
    format!("M567 P{tool} E{}", formatted(mix, decimals).join(":"))
}

/// RepRapFirmware: `M563 P<tool> D<d0:d1:...> H<heater>`, a tool fed by several drives.
pub fn rrf_m563(tool: u32, drives: &[u32], heater: u32) -> Result<String, DialectError> {
    if drives.is_empty() {
        return Err(DialectError::NoDrives);
    }
    let d: Vec<String> = drives.iter().map(u32::to_string).collect();
    Ok(format!("M563 P{tool} D{} H{heater}", d.join(":")))
}

/// What a mixing command changed.
#[derive(Debug, Clone, PartialEq)]
pub enum MixingUpdate {
    /// M163: one input's factor in Marlin's collector.
    Factor {
        /// The input (0-based) whose factor was set.
        input: usize,
        /// The factor as written, not yet normalised.
        factor: f64,
    },
    /// M164 / M165: a Marlin virtual tool now holds this mix.
    Stored {
        /// The virtual tool that now holds `mix`.
        tool: usize,
        /// The normalised mix stored.
        mix: Mix,
    },
    /// M567: a RepRapFirmware tool's ratios as written; `sum` should be 1.
    RrfMix {
        /// The RepRapFirmware tool number (M567 P).
        tool: u32,
        /// The ratios as written (M567 E), one per drive.
        ratios: Vec<f64>,
        /// Their sum, which should be 1.
        sum: f64,
    },
}

/// The mixing part of the machine state, fed one command at a time.
///
/// Initial state (Marlin's reset, our reading of `mixing.cpp`): virtual tool
/// t < inputs is 100 % input t, the others 100 % input 0; the collector holds
/// tool 0's mix; tool 0 is active.
#[derive(Debug, Clone, PartialEq)]
pub struct MixingState {
    collector: Vec<f64>,
    tools: Vec<Mix>,
    active: usize,
    rrf: BTreeMap<u32, Vec<f64>>,
}

fn word(words: &[(char, f64)], letter: char) -> Option<f64> {
    words.iter().find(|(l, _)| l.eq_ignore_ascii_case(&letter)).map(|&(_, v)| v)
}

fn number(code: u16, words: &[(char, f64)], letter: char) -> Result<Option<f64>, DialectError> {
    match word(words, letter) {
        Some(value) if !value.is_finite() => Err(DialectError::NotFinite { code, letter, value }),
        other => Ok(other),
    }
}

fn index(code: u16, words: &[(char, f64)], letter: char) -> Result<Option<usize>, DialectError> {
    match number(code, words, letter)? {
        Some(value) if value < 0.0 || value.fract() != 0.0 || value > u32::MAX as f64 => {
            Err(DialectError::BadIndex { code, letter, value })
        }
        other => Ok(other.map(|v| v as usize)),
    }
}

impl MixingState {
    /// State for `inputs` inputs (>= 1) and `virtual_tools` Marlin tools (>= 1).
    pub fn new(inputs: usize, virtual_tools: usize) -> Result<Self, DialectError> {
        if virtual_tools == 0 {
            return Err(DialectError::NoSuchTool { tool: 0, tools: 0 });
        }
        let single = |i: usize| {
            let mut r = vec![0.0; inputs];
            if let Some(v) = r.get_mut(i) {
                *v = 1.0;
            }
            Mix::new(&r)
        };
        let tools = (0..virtual_tools)
            .map(|t| single(if t < inputs { t } else { 0 }))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { collector: tools[0].ratios().to_vec(), tools, active: 0, rrf: BTreeMap::new() })
    }

    /// The number of inputs (filaments) of the mixer.
    pub fn inputs(&self) -> usize {
        self.collector.len()
    }

    /// Marlin's collector: factors set by M163, not yet normalised.
    pub fn collector(&self) -> &[f64] {
        &self.collector
    }

    /// The active Marlin virtual tool.
    pub fn active_tool(&self) -> usize {
        self.active
    }

    /// The mix the next extrusion uses (Marlin).
    pub fn active_mix(&self) -> &Mix {
        &self.tools[self.active]
    }

    /// The mix a Marlin virtual tool holds, if the tool exists.
    pub fn tool(&self, tool: usize) -> Option<&Mix> {
        self.tools.get(tool)
    }

    /// A RepRapFirmware tool's ratios as set by M567.
    pub fn rrf_mix(&self, tool: u32) -> Option<&[f64]> {
        self.rrf.get(&tool).map(Vec::as_slice)
    }

    /// `T<n>`: select a stored virtual tool (no park, retract or purge).
    pub fn select_tool(&mut self, tool: usize) -> Result<&Mix, DialectError> {
        self.check_tool(tool)?;
        self.active = tool;
        Ok(&self.tools[tool])
    }

    fn check_tool(&self, tool: usize) -> Result<(), DialectError> {
        if tool < self.tools.len() {
            Ok(())
        } else {
            Err(DialectError::NoSuchTool { tool, tools: self.tools.len() })
        }
    }

    fn check_input(&self, index: usize) -> Result<(), DialectError> {
        if index < self.inputs() {
            Ok(())
        } else {
            Err(DialectError::NoSuchInput { index, inputs: self.inputs() })
        }
    }

    /// Apply `M<code>` with its words (letter, value) and, for M567, the
    /// colon-separated list of its E word (`E0.2:0.8` -> `[0.2, 0.8]`; a plain
    /// `E1` may come as the word or as a one-element list). The whole line is
    /// checked before any state changes.
    pub fn apply(
        &mut self,
        code: u16,
        words: &[(char, f64)],
        e_list: &[f64],
    ) -> Result<MixingUpdate, DialectError> {
        match code {
            163 => {
                let input =
                    index(code, words, 'S')?.ok_or(DialectError::MissingWord { code, letter: 'S' })?;
                self.check_input(input)?;
                let p = number(code, words, 'P')?.ok_or(DialectError::MissingWord { code, letter: 'P' })?;
                let factor = p.max(0.0);
                self.collector[input] = factor;
                Ok(MixingUpdate::Factor { input, factor })
            }
            164 => {
                let tool = index(code, words, 'S')?.unwrap_or(self.active);
                self.check_tool(tool)?;
                self.store(code, tool, self.collector.clone())
            }
            165 => {
                let mut factors = vec![0.0; self.inputs()];
                for (i, &letter) in M165_LETTERS.iter().enumerate() {
                    if let Some(v) = number(code, words, letter)? {
                        self.check_input(i)?;
                        factors[i] = v.max(0.0);
                    }
                }
                self.store(code, self.active, factors)
            }
            567 => {
                let tool = index(code, words, 'P')?.ok_or(DialectError::MissingWord { code, letter: 'P' })?;
                let ratios = match (e_list, number(code, words, 'E')?) {
                    ([], Some(e)) => vec![e],
                    ([], None) => return Err(DialectError::MissingWord { code, letter: 'E' }),
                    (list, _) => list.to_vec(),
                };
                if let Some(&value) = ratios.iter().find(|v| !v.is_finite()) {
                    return Err(DialectError::NotFinite { code, letter: 'E', value });
                }
                let sum = ratios.iter().sum();
                let tool = tool as u32; // `index` keeps it within u32.
                self.rrf.insert(tool, ratios.clone());
                Ok(MixingUpdate::RrfMix { tool, ratios, sum })
            }
            _ => Err(DialectError::NotMixing { code }),
        }
    }

    /// Follows one parsed G-code line (`raw` is its text, `block` the parse): `T<n>` selects a
    /// virtual tool, `M163`-`M165` and `M567` are applied, anything else is ignored (`Ok(None)`).
    /// On error nothing changed, as in the firmware, which refuses the line.
    pub fn follow_line(&mut self, raw: &[u8], block: &Block) -> Result<Option<MixingUpdate>, DialectError> {
        let Command::Code { letter, number, sub: None } = block.command else { return Ok(None) };
        if letter == b'T' {
            // A RepRapFirmware tool with an M567 mix selects that mix, whatever Marlin's virtual
            // tools hold (and however many there are).
            if let Some(ratios) = self.rrf_mix(number) {
                let (ratios, sum) = (ratios.to_vec(), ratios.iter().sum());
                return Ok(Some(MixingUpdate::RrfMix { tool: number, ratios, sum }));
            }
            let tool = number as usize;
            return self.select_tool(tool).map(|mix| Some(MixingUpdate::Stored { tool, mix: mix.clone() }));
        }
        if letter != b'M' || !MixingCode::sets_a_mix(number) {
            return Ok(None);
        }
        let words: Vec<(char, f64)> =
            block.words.iter().filter_map(|w| w.number().map(|v| (w.letter as char, v))).collect();
        let e_list = if number == 567 { colon_list(raw, block) } else { Vec::new() };
        self.apply(number as u16, &words, &e_list).map(Some)
    }

    fn store(&mut self, code: u16, tool: usize, factors: Vec<f64>) -> Result<MixingUpdate, DialectError> {
        let mix = Mix::new(&factors).map_err(|e| match e {
            MixError::AllZero => DialectError::AllZero { code },
            other => DialectError::Mix(other),
        })?;
        self.tools[tool] = mix.clone();
        Ok(MixingUpdate::Stored { tool, mix })
    }
}

/// The colon-separated list of an `M567` `E` word (`E0.2:0.8`), read from the raw line (the
/// lexer reads only the first number of a word).
fn colon_list(raw: &[u8], block: &Block) -> Vec<f64> {
    let Some(word) = block.word(b'E') else { return Vec::new() };
    let mut i = word.span.start as usize + 1;
    let mut list = Vec::new();
    while let Ok((v, used)) = scan(&raw[i.min(raw.len())..]) {
        list.push(v);
        i += used;
        if raw.get(i) != Some(&b':') {
            break;
        }
        i += 1;
    }
    list
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn mix(r: &[f64]) -> Mix {
        Mix::new(r).unwrap()
    }

    #[test]
    fn follows_parsed_lines_including_m567_lists() {
        let mut state = MixingState::new(2, 4).unwrap();
        let mut block = Block::default();
        let mut follow = |state: &mut MixingState, text: &str| {
            crate::gcode::lexer::parse_into(text.as_bytes(), &mut block);
            state.follow_line(text.as_bytes(), &block)
        };
        assert_eq!(follow(&mut state, "G1 X1 E2"), Ok(None));
        follow(&mut state, "M163 S0 P0.25").unwrap();
        follow(&mut state, "M163 S1 P0.75").unwrap();
        follow(&mut state, "M164 S2").unwrap();
        assert_eq!(
            follow(&mut state, "T2"),
            Ok(Some(MixingUpdate::Stored { tool: 2, mix: mix(&[0.25, 0.75]) }))
        );
        assert_eq!(state.active_mix(), &mix(&[0.25, 0.75]));
        follow(&mut state, "M567 P1 E0.2:0.8").unwrap();
        assert_eq!(state.rrf_mix(1), Some(&[0.2, 0.8][..]));
        assert!(follow(&mut state, "T9").is_err(), "no such virtual tool");
        assert_eq!(state.active_tool(), 2, "a refused line changes nothing");
        // A tool with an M567 mix selects it, even past the virtual tools.
        follow(&mut state, "M567 P20 E0.6:0.4").unwrap();
        assert_eq!(
            follow(&mut state, "T20"),
            Ok(Some(MixingUpdate::RrfMix { tool: 20, ratios: vec![0.6, 0.4], sum: 1.0 }))
        );
    }

    fn close(got: &[f64], want: &[f64]) {
        assert_eq!(got.len(), want.len());
        assert!(got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-12), "{got:?} != {want:?}");
    }

    fn d(n: u32) -> Decimals {
        Decimals::new(n).unwrap()
    }

    #[test]
    fn marlin_lines_for_seed_orange() {
        // 0.17 : 0.82 normalised is 0.171717 : 0.828283; 3 decimals round to 0.172 : 0.828.
        let orange = mix(&[0.0, 0.17, 0.82, 0.0]);
        assert_eq!(
            marlin_m163_m164(&orange, 2, d(3)),
            ["M163 S0 P0", "M163 S1 P0.172", "M163 S2 P0.828", "M163 S3 P0", "M164 S2"]
        );
        assert_eq!(marlin_m165(&orange, d(2)).unwrap(), "M165 A0 B0.17 C0.83 D0");
        assert_eq!(marlin_m165(&mix(&[1.0; 7]), d(2)), Err(DialectError::TooManyInputsForM165(7)));
    }

    #[test]
    fn rrf_lines() {
        let thirds = mix(&[1.0, 1.0, 1.0]);
        // 0.33 * 3 = 0.99: the missing unit goes to the first input (ties in order).
        assert_eq!(rrf_m567(&thirds, 1, d(2)), "M567 P1 E0.34:0.33:0.33");
        assert_eq!(rrf_m567(&thirds, 1, d(0)), "M567 P1 E1:0:0");
        assert_eq!(rrf_m567(&mix(&[1.0, 3.0]), 0, Decimals::default()), "M567 P0 E0.25:0.75");
        assert_eq!(rrf_m563(0, &[0, 1, 2, 3], 1).unwrap(), "M563 P0 D0:1:2:3 H1");
        assert_eq!(rrf_m563(0, &[], 1), Err(DialectError::NoDrives));
        assert_eq!(Decimals::new(10), Err(DialectError::Decimals(10)));
    }

    #[test]
    fn largest_remainder_beats_plain_rounding() {
        // Plain rounding of 1/6, 1/6, 2/3 at 1 decimal gives 0.2 + 0.2 + 0.7 = 1.1.
        assert_eq!(round_to_units(&mix(&[1.0, 1.0, 4.0]), d(1)), [2, 2, 6]);
        // A share too small to show at this precision rounds to zero, the sum stays 1.
        assert_eq!(round_to_units(&mix(&[1.0, 1e-6]), d(3)), [1000, 0]);
    }

    #[test]
    fn marlin_collector_and_tools() {
        let mut s = MixingState::new(4, MARLIN_VIRTUAL_TOOLS).unwrap();
        assert_eq!(s.tool(2).unwrap().ratios(), [0.0, 0.0, 1.0, 0.0]);
        assert_eq!(s.tool(9).unwrap().ratios(), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(
            s.apply(163, &[('S', 1.0), ('P', -2.0)], &[]),
            Ok(MixingUpdate::Factor { input: 1, factor: 0.0 })
        );
        s.apply(163, &[('S', 0.0), ('P', 60.0)], &[]).unwrap();
        s.apply(163, &[('s', 2.0), ('p', 40.0)], &[]).unwrap();
        assert_eq!(s.collector(), [60.0, 0.0, 40.0, 0.0]);
        let stored = s.apply(164, &[('S', 3.0)], &[]).unwrap();
        let MixingUpdate::Stored { tool: 3, mix: m } = stored else { panic!("{stored:?}") };
        close(m.ratios(), &[0.6, 0.0, 0.4, 0.0]);
        // Storing does not select.
        assert_eq!(s.active_tool(), 0);
        close(s.select_tool(3).unwrap().ratios(), &[0.6, 0.0, 0.4, 0.0]);
        close(s.active_mix().ratios(), &[0.6, 0.0, 0.4, 0.0]);
        // M165 overwrites the active tool; missing letters are 0.
        s.apply(165, &[('A', 1.0), ('C', 3.0)], &[]).unwrap();
        close(s.tool(3).unwrap().ratios(), &[0.25, 0.0, 0.75, 0.0]);
        // M164 without S stores into the active tool.
        s.apply(164, &[], &[]).unwrap();
        close(s.tool(3).unwrap().ratios(), &[0.6, 0.0, 0.4, 0.0]);
    }

    #[test]
    fn bad_lines_change_nothing() {
        let mut s = MixingState::new(4, 16).unwrap();
        for i in 0..4 {
            s.apply(163, &[('S', i as f64), ('P', 0.0)], &[]).unwrap();
        }
        let before = s.clone();
        assert_eq!(s.apply(164, &[('S', 5.0)], &[]), Err(DialectError::AllZero { code: 164 }));
        assert_eq!(s.apply(165, &[('A', 0.0)], &[]), Err(DialectError::AllZero { code: 165 }));
        assert_eq!(
            s.apply(163, &[('S', 4.0), ('P', 1.0)], &[]),
            Err(DialectError::NoSuchInput { index: 4, inputs: 4 })
        );
        assert_eq!(
            s.apply(163, &[('S', 1.5), ('P', 1.0)], &[]),
            Err(DialectError::BadIndex { code: 163, letter: 'S', value: 1.5 })
        );
        assert_eq!(
            s.apply(163, &[('S', 1.0)], &[]),
            Err(DialectError::MissingWord { code: 163, letter: 'P' })
        );
        assert!(matches!(
            s.apply(163, &[('S', 1.0), ('P', f64::NAN)], &[]),
            Err(DialectError::NotFinite { .. })
        ));
        assert_eq!(s.apply(164, &[('S', 16.0)], &[]), Err(DialectError::NoSuchTool { tool: 16, tools: 16 }));
        assert_eq!(
            MixingState::new(4, 2).unwrap().apply(165, &[('H', 1.0)], &[]),
            Err(DialectError::NoSuchInput { index: 4, inputs: 4 })
        );
        assert_eq!(s.apply(104, &[], &[]), Err(DialectError::NotMixing { code: 104 }));
        assert_eq!(s, before);
    }

    #[test]
    fn rrf_mix_is_kept_as_written() {
        let mut s = MixingState::new(4, 1).unwrap();
        let u = s.apply(567, &[('P', 0.0)], &[0.2, 0.3]).unwrap();
        assert_eq!(u, MixingUpdate::RrfMix { tool: 0, ratios: vec![0.2, 0.3], sum: 0.5 });
        assert_eq!(s.rrf_mix(0), Some(&[0.2, 0.3][..]));
        s.apply(567, &[('P', 2.0), ('E', 1.0)], &[]).unwrap();
        assert_eq!(s.rrf_mix(2), Some(&[1.0][..]));
        assert_eq!(
            s.apply(567, &[('E', 1.0)], &[]),
            Err(DialectError::MissingWord { code: 567, letter: 'P' })
        );
    }

    /// Split a rendered line into its code and (letter, value) words, M567's E list apart.
    fn words(line: &str) -> (u16, Vec<(char, f64)>, Vec<f64>) {
        let mut parts = line.split(' ');
        let code = parts.next().unwrap()[1..].parse().unwrap();
        let mut pairs = Vec::new();
        let mut list = Vec::new();
        for p in parts {
            let letter = p.chars().next().unwrap();
            if p.contains(':') {
                list = p[1..].split(':').map(|v| v.parse().unwrap()).collect();
            } else {
                pairs.push((letter, p[1..].parse().unwrap()));
            }
        }
        (code, pairs, list)
    }

    proptest! {
        #[test]
        fn m567_ratios_sum_to_exactly_one(
            r in prop::collection::vec(0.0f64..100.0, 1..8)
                .prop_filter("not all zero", |r| r.iter().any(|&v| v > 0.0)),
            decimals in 0u32..=6,
        ) {
            let line = rrf_m567(&mix(&r), 0, d(decimals));
            let list = line.split(" E").nth(1).unwrap();
            // Sum the printed decimals exactly, as integers of 10^-decimals.
            let scale = 10u64.pow(decimals);
            let mut total = 0u64;
            for v in list.split(':') {
                let (whole, frac) = v.split_once('.').unwrap_or((v, ""));
                prop_assert!(frac.len() as u32 <= decimals);
                let frac_units = format!("{frac:0<width$}", width = decimals as usize);
                total += whole.parse::<u64>().unwrap() * scale
                    + frac_units.parse::<u64>().unwrap_or(0);
            }
            prop_assert_eq!(total, scale, "{}", line);
        }

        #[test]
        fn rendered_marlin_lines_parse_back(r in prop::collection::vec(0.0f64..1.0, 4)
            .prop_filter("not all zero", |r| r.iter().any(|&v| v > 0.0))) {
            let m = mix(&r);
            let mut s = MixingState::new(4, 16).unwrap();
            for line in marlin_m163_m164(&m, 5, Decimals::default()) {
                let (code, pairs, list) = words(&line);
                s.apply(code, &pairs, &list).unwrap();
            }
            let (code, pairs, list) = words(&rrf_m567(&m, 7, Decimals::default()));
            let rrf = s.apply(code, &pairs, &list).unwrap();
            let sum_is_one = matches!(rrf, MixingUpdate::RrfMix { sum, .. } if (sum - 1.0).abs() < 1e-9);
            prop_assert!(sum_is_one, "{:?}", rrf);
            for (got, want) in s.tool(5).unwrap().ratios().iter().zip(m.ratios()) {
                prop_assert!((got - want).abs() <= 0.5e-4 * 4.0);
            }
        }
    }
}
