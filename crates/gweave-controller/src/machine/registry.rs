//! The commands the controller runs, declared once: one row per command with what it needs
//! (its build feature, as a `#[cfg]` on the row; the machine's hardware, [`Needs`]) and the
//! range of every number word it takes. The board and the virtual printer
//! (`gweave sim --machine gweave-*`, which runs this core on its twin) read the same rows.
//!
//! [`row`] is what the controller asks first of each command line: a command
//! without a row is unknown (`echo:Unknown command`), a number outside its row's range is
//! refused before anything changes. What each command does is `commands.rs`'s dispatch; the
//! test `the_registry_is_exactly_what_the_controller_runs` checks, on machines with and without
//! each piece of hardware, that every G, M and T code from 0 to 1000 runs if and only if it
//! has a row here.
//!
//! A `match`, not a table of rows: on the AVR every constant table is copied into RAM at
//! start-up (about 400 bytes for these rows), while a match stays in flash.

/// The physical range of every number a command takes: a value outside is refused whole.
/// Feed rates up to 100 000 mm/min, positions within ±100 m, temperatures 0-500 °C, settings
/// positive and below a million.
const FEED_MM_MIN: (f32, f32) = (0.01, 100_000.0);
const POSITION_MM: (f32, f32) = (-100_000.0, 100_000.0);
/// A rotary axis' angle: ±2 778 turns (past it a float's step is above a hundredth of a degree;
/// `rotary tube` re-declares its angle every hundred turns).
#[cfg(feature = "rotary")]
const ANGLE_DEG: (f32, f32) = (-1_000_000.0, 1_000_000.0);
const TEMP_C: (f32, f32) = (0.0, 500.0);
const SETTING: (f32, f32) = (0.000_001, 1_000_000.0);
const GAIN: (f32, f32) = (0.0, 100_000.0);
const DUTY: (f32, f32) = (0.0, 255.0);
const DWELL_MS: (f32, f32) = (0.0, 3_600_000.0);
/// `G4 S`: a dwell of at most an hour.
const DWELL_S: (f32, f32) = (0.0, 3600.0);
/// `M104 T`, `M109 T`: the hotend, 0 or 1.
const HOTEND: (f32, f32) = (0.0, 1.0);
/// `M110 N`: the next line's number; printcore's `N-1` starts a print at `N0`.
const LINE_NUMBER: (f32, f32) = (-1.0, 2_000_000_000.0);
/// `M211 S`: software endstops off (0) or on (1).
const ON_OFF: (f32, f32) = (0.0, 1.0);
/// `M155 S`: seconds between temperature reports, 0 for none (Marlin caps it at 60).
const AUTO_REPORT_S: (f32, f32) = (0.0, 60.0);
/// `M205 J`: the junction deviation, mm.
const JUNCTION_MM: (f32, f32) = (0.0, 10.0);
/// An inkjet head (`M700 P`), of those a build may wire, and a C6602's nozzle mask (`S`, 12
/// bits).
#[cfg(feature = "inkjet")]
const INKJET_HEAD: (f32, f32) = (0.0, (crate::limits::INKJET_HEADS - 1) as f32);
#[cfg(feature = "inkjet")]
const NOZZLE_MASK: (f32, f32) = (0.0, crate::inkjet::ALL_NOZZLES as f32);
/// A mixing weight: only ratios matter, a negative one counts as 0; a million bounds the sum.
const MIX_WEIGHT: (f32, f32) = (-1_000_000.0, 1_000_000.0);

/// What a command needs of the machine, beyond its build's features.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Needs {
    /// Every machine runs it.
    Nothing,
    /// A mixing hotend (`Settings::mixing_inputs`): `M163`-`M165` and the virtual tools `T<n>`.
    Mixing,
    /// Inkjet heads wired (`Settings::inkjet_heads`): `M700`, in a build with the feature.
    #[cfg(feature = "inkjet")]
    Inkjet,
    /// A second hotend fitted (an "EEB" board): `T1`.
    SecondHotend,
}

/// Number words and their ranges: each letter of the string takes the range.
pub(crate) type Ranges = &'static [(&'static [u8], (f32, f32))];

/// The row of the command `letter` `code` (`b'M'`, 104) on a machine that has what `has` says:
/// its number words' ranges, or `None`: the controller does not run it there.
pub(crate) fn row(letter: u8, code: u16, has: impl Fn(Needs) -> bool) -> Option<Ranges> {
    use Needs::{Mixing, Nothing, SecondHotend};
    let declared = |needs: Needs, ranges: Ranges| has(needs).then_some(ranges);
    match (letter, code) {
        (b'G', 0 | 1) => declared(
            Nothing,
            &[
                (b"XYZE", POSITION_MM),
                #[cfg(feature = "rotary")]
                (b"A", ANGLE_DEG),
                (b"F", FEED_MM_MIN),
            ],
        ),
        (b'G', 4) => declared(Nothing, &[(b"P", DWELL_MS), (b"S", DWELL_S)]),
        // Millimetres, homing, absolute and relative axes.
        (b'G', 21 | 28 | 90 | 91) => declared(Nothing, &[]),
        (b'G', 92) => declared(
            Nothing,
            &[
                (b"XYZE", POSITION_MM),
                #[cfg(feature = "rotary")]
                (b"A", ANGLE_DEG),
            ],
        ),
        // Inverse time and back to units per minute: a rotary build's.
        #[cfg(feature = "rotary")]
        (b'G', 93 | 94) => declared(Nothing, &[]),
        // Program stop, stepper enables, absolute and relative E.
        (b'M', 0 | 17 | 18 | 82 | 83 | 84) => declared(Nothing, &[]),
        (b'M', 92 | 201 | 203) => declared(Nothing, &[(b"XYZE", SETTING)]),
        (b'M', 104 | 109 | 140 | 190) => declared(Nothing, &[(b"SR", TEMP_C), (b"T", HOTEND)]),
        (b'M', 106) => declared(Nothing, &[(b"S", DUTY)]),
        (b'M', 110) => declared(Nothing, &[(b"N", LINE_NUMBER)]),
        (b'M', 155) => declared(Nothing, &[(b"S", AUTO_REPORT_S)]),
        (b'M', 204) => declared(Nothing, &[(b"SPRT", SETTING)]),
        (b'M', 205) => declared(Nothing, &[(b"J", JUNCTION_MM)]),
        (b'M', 211) => declared(Nothing, &[(b"S", ON_OFF)]),
        (b'M', 301) => declared(Nothing, &[(b"PID", GAIN)]),
        // Reports, the fan off, the kill, waiting for the moves, the EEPROM's settings.
        (b'M', 105 | 107 | 108 | 112 | 114 | 115 | 119 | 400 | 500 | 501 | 502 | 503) => {
            declared(Nothing, &[])
        }
        (b'M', 163) => declared(Mixing, &[(b"P", MIX_WEIGHT)]),
        (b'M', 164) => declared(Mixing, &[]),
        (b'M', 165) => declared(Mixing, &[(b"ABCD", MIX_WEIGHT)]),
        #[cfg(feature = "inkjet")]
        (b'M', 700) => declared(Needs::Inkjet, &[(b"P", INKJET_HEAD), (b"S", NOZZLE_MASK)]),
        // A main loop that hangs, for a board's watchdog test (never in a normal build).
        #[cfg(feature = "fault-injection")]
        (b'M', 9999) => declared(Nothing, &[]),
        // A mixing hotend's virtual tools (the mixer refuses a number past its tools), else
        // the hotends.
        (b'T', _) if has(Mixing) => declared(Mixing, &[]),
        (b'T', 0) => declared(Nothing, &[]),
        (b'T', 1) => declared(SecondHotend, &[]),
        _ => None,
    }
}
