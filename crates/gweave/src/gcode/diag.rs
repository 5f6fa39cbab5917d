//! Diagnostics: what is wrong with a line, where, and how bad it is.

use std::fmt;

/// How serious a finding is. Errors make `gweave check` fail and stop transforms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Suspicious but the line still means something; `gweave check` passes.
    Warning,
    /// The line cannot be trusted; `gweave check` fails.
    Error,
}

/// What was found.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Finding {
    /// A word whose value is not a number (`X1..2`).
    MalformedNumber {
        /// The word's letter.
        letter: char,
    },
    /// `NaN` or `inf` where a number belongs.
    NotFinite {
        /// The word's letter.
        letter: char,
    },
    /// A motion word with no value (`G1 X`).
    MissingValue {
        /// The word's letter.
        letter: char,
    },
    /// A number in exponent notation (`F1e300`), read as two words (`F1 E300`) as Marlin and
    /// Klipper do.
    ExponentNotation {
        /// The word as written, exponent included (`F1e300`): a lower-case `e` after an
        /// upper-case letter, as `printf` writes it, is an error; one case (words written
        /// without spaces, maybe) a warning. Boxed, and the case read from it, to keep every
        /// finding (and the errors that carry one) as small as before.
        word: Box<str>,
    },
    /// The file's last line has no line ending and is malformed: the file looks cut short.
    Truncated {
        /// What is wrong with the line.
        cause: Box<Finding>,
    },
    /// The file's last line has no line ending, and the file lacks the last line its slicer
    /// always writes ([`missing_footer`](crate::gcode::ends::missing_footer)): the file looks
    /// cut short, though its last line reads (`G1 X1 E1` of `E17.54688`).
    NoFooter {
        /// The slicer, and the line it ends its files with.
        footer: crate::gcode::ends::Footer,
    },
    /// A byte that cannot start a word.
    UnexpectedByte {
        /// The byte found.
        byte: u8,
    },
    /// A `(` comment that the line ends inside.
    UnclosedComment,
    /// A `"` string that the line ends inside.
    UnclosedString,
    /// A `{` expression that the line ends inside.
    UnclosedExpression,
    /// A checksum that is not the XOR of the bytes before `*`.
    ChecksumMismatch {
        /// The checksum written after `*`.
        given: u32,
        /// The XOR of every byte before `*`.
        computed: u8,
    },
    /// `*` not followed by digits, or followed by more words.
    BadChecksum,
    /// `N` not followed by an integer.
    BadLineNumber,
    /// A line number that does not follow the previous one.
    LineNumberSequence {
        /// The number that should have come next.
        expected: i64,
        /// The number written.
        found: i64,
    },
    /// A command no firmware gweave knows runs.
    UnknownCommand {
        /// The command as written (`M999`, `G12`).
        command: String,
    },
    /// Extrusion while no hotend temperature has been set.
    ExtrusionBeforeHeating,
    /// A move that leaves the bed given with `--bed`.
    OutsideBed {
        /// The axis that leaves the bed.
        axis: char,
        /// The position it reaches, mm.
        value_mm: f64,
    },
    /// A feed rate no printer can do (or zero/negative).
    AbsurdFeedRate {
        /// The feed rate written, mm/min.
        feed_mm_min: f64,
    },
    /// Relative extrusion running long without a `G92 E` reset (float drift in the firmware).
    RelativeEDrift {
        /// Filament fed since the last reset, mm.
        since_reset_mm: f64,
    },
    /// Absolute E values so large that single-precision firmware loses resolution.
    AbsoluteEPrecision {
        /// The absolute E value, mm.
        e_mm: f64,
    },
    /// `T<n>` past [`MAX_TOOLS`](super::limits::MAX_TOOLS): no machine has that tool.
    ToolOutOfRange {
        /// The command as written, in upper case (`T99999999999999999999`: its number read
        /// saturates, so the text is what a user recognises). Boxed: a second `String` beside
        /// [`Finding::UnknownCommand`]'s made every finding, and every error that may hold one,
        /// 8 bytes larger.
        command: Box<str>,
    },
    /// A number word outside the physical range its command declares (the machine's table,
    /// [`WordRanges`](crate::check::WordRanges)): the printer refuses the whole line. Boxed: a
    /// finding travels with every block, and three strings inline made each a third larger.
    OutOfRange(Box<WordOutOfRange>),
    /// A line longer than [`MAX_LINE`](crate::gcode::reader::MAX_LINE): not parsed.
    LineTooLong {
        /// The line's length in bytes, line ending excluded.
        len: u64,
    },
    /// A `G2`/`G3` the firmware the file is read for refuses ([`crate::gcode::arc`]): the
    /// machine does not move (Klipper stops the print). Boxed, as [`Finding::OutOfRange`].
    ArcRefused(Box<RefusedArc>),
    /// One move feeding more filament than the firmware takes in one move
    /// ([`CheckOptions`](crate::CheckOptions)): Marlin drops its E, Klipper stops the print.
    LongExtrusion {
        /// The firmware the file is read for.
        firmware: crate::Firmware,
        /// The filament the move feeds, mm (negative: a retraction).
        e_mm: f64,
        /// The firmware's limit, mm (single precision keeps a finding, which travels with every
        /// line, at its size).
        max_mm: f32,
    },
    /// A printing move whose filament makes a wider bead than Klipper's
    /// `max_extrude_cross_section` ([`KlipperExtruder`](crate::KlipperExtruder)): Klipper
    /// stops the print ("Move exceeds maximum extrusion").
    OverExtrusion {
        /// The bead's cross-section, mm²: the filament fed per mm of path times its area.
        area_mm2: f64,
        /// Klipper's limit, mm².
        max_mm2: f32,
    },
    /// More findings on the line than are kept ([`MAX_LINE_DIAGNOSTICS`]).
    MoreFindings {
        /// How many findings were dropped.
        count: u32,
    },
}

impl Finding {
    /// Exponent notation as `printf` writes it into a template: `F1e300`, an upper-case letter
    /// and a lower-case `e`.
    fn is_mixed_case_exponent(&self) -> bool {
        match self {
            Finding::ExponentNotation { word } => {
                word.starts_with(|c: char| c.is_ascii_uppercase()) && word.contains('e')
            }
            _ => false,
        }
    }

    /// How serious this finding is.
    pub fn severity(&self) -> Severity {
        match self {
            Finding::UnknownCommand { .. }
            | Finding::ExtrusionBeforeHeating
            | Finding::OutsideBed { .. }
            | Finding::RelativeEDrift { .. }
            | Finding::AbsoluteEPrecision { .. }
            | Finding::LineNumberSequence { .. }
            | Finding::NoFooter { .. } => Severity::Warning,
            // Marlin goes on without the E; Klipper stops the print.
            Finding::LongExtrusion { firmware, .. } if *firmware != crate::Firmware::Klipper => {
                Severity::Warning
            }
            Finding::ExponentNotation { .. } if !self.is_mixed_case_exponent() => Severity::Warning,
            // The findings it stands for were errors, each counted when kept.
            Finding::MoreFindings { .. } => Severity::Error,
            _ => Severity::Error,
        }
    }
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Finding::MalformedNumber { letter } => write!(f, "malformed number after '{letter}'"),
            Finding::NotFinite { letter } => write!(f, "'{letter}' is not a finite number"),
            Finding::MissingValue { letter } => write!(f, "'{letter}' has no number"),
            Finding::ExponentNotation { word } => {
                // `F1e300`: the letter, the number up to the `e`, and the word the rest makes.
                let upper = word.to_ascii_uppercase();
                let split = upper.get(1..).and_then(|rest| rest.find('E')).map_or(upper.len(), |i| i + 1);
                let (first, second) = upper.split_at(split);
                write!(
                    f,
                    "'{word}' is exponent notation, which G-code does not have: read as {first} and \
                     {second}, as Marlin and Klipper do (RepRapFirmware reads one number)"
                )
            }
            Finding::Truncated { cause } => {
                write!(
                    f,
                    "the file looks truncated (its last line is malformed and has no line ending): {cause}"
                )
            }
            Finding::NoFooter { footer } => write!(
                f,
                "the file looks truncated: its last line has no line ending, and the file lacks the line \
                 {} ends its files with ('{}')",
                footer.slicer(),
                footer.marker().trim_end()
            ),
            Finding::UnexpectedByte { byte } => {
                if byte.is_ascii_graphic() {
                    write!(f, "unexpected character '{}'", *byte as char)
                } else {
                    write!(f, "unexpected byte 0x{byte:02x}")
                }
            }
            Finding::UnclosedComment => write!(f, "'(' comment is not closed"),
            Finding::UnclosedString => write!(f, "string is not closed"),
            Finding::UnclosedExpression => write!(f, "'{{' expression is not closed"),
            Finding::ChecksumMismatch { given, computed } => {
                write!(f, "checksum mismatch: line says {given}, bytes give {computed}")
            }
            Finding::BadChecksum => write!(f, "'*' must be followed by the checksum digits only"),
            Finding::BadLineNumber => write!(f, "'N' must be followed by an integer"),
            Finding::LineNumberSequence { expected, found } => {
                write!(f, "line number N{found} does not follow (expected N{expected})")
            }
            Finding::UnknownCommand { command } => write!(f, "unknown command {command}"),
            Finding::ExtrusionBeforeHeating => {
                write!(f, "extrusion before any hotend temperature was set")
            }
            Finding::OutsideBed { axis, value_mm } => {
                write!(f, "move outside the bed: {axis}={value_mm:.3} mm")
            }
            Finding::AbsurdFeedRate { feed_mm_min } => {
                write!(f, "absurd feed rate F{feed_mm_min:.3} mm/min")
            }
            Finding::RelativeEDrift { since_reset_mm } => {
                write!(f, "relative extrusion ran {since_reset_mm:.3} mm without a G92 E reset (float drift)")
            }
            Finding::AbsoluteEPrecision { e_mm } => {
                write!(f, "absolute E reached {e_mm:.3} mm without a reset (precision loss)")
            }
            Finding::LineTooLong { len } => write!(
                f,
                "line of {len} bytes is longer than the limit of {} (not read)",
                super::reader::MAX_LINE
            ),
            Finding::OutOfRange(w) => {
                write!(
                    f,
                    "{} = {} is out of range: {} (the printer refuses the line)",
                    w.word, w.value, w.range
                )
            }
            Finding::ArcRefused(arc) => {
                write!(f, "{} refuses this arc, and the machine does not move: {}", arc.firmware, arc.refusal)
            }
            Finding::LongExtrusion { firmware: crate::Firmware::Klipper, e_mm, max_mm } => write!(
                f,
                "an extrude-only move of {e_mm:.3} mm: klipper stops the print past {max_mm} mm ('Extrude only \
                 move too long', its max_extrude_only_distance)"
            ),
            Finding::LongExtrusion { firmware, e_mm, max_mm } => write!(
                f,
                "a move feeding {e_mm:.3} mm of filament: {firmware} skips the E of a move past {max_mm} mm \
                 ('too long extrusion prevented', its EXTRUDE_MAXLENGTH)"
            ),
            Finding::OverExtrusion { area_mm2, max_mm2 } => write!(
                f,
                "a move extruding a {area_mm2:.3} mm² bead: klipper stops the print past {max_mm2:.3} mm² \
                 ('Move exceeds maximum extrusion', its max_extrude_cross_section: 4 x nozzle_diameter² \
                 unless set)"
            ),
            Finding::MoreFindings { count } => write!(f, "{count} more findings on this line"),
            Finding::ToolOutOfRange { command } => write!(
                f,
                "{command} names no tool (at most {} are read; the tool stays as it was)",
                super::limits::MAX_TOOLS
            ),
        }
    }
}

/// An arc its firmware refuses ([`Finding::ArcRefused`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RefusedArc {
    /// The firmware the file is read for.
    pub firmware: crate::Firmware,
    /// Why it refuses the arc.
    #[serde(flatten)]
    pub refusal: crate::gcode::arc::ArcRefusal,
}

/// A word outside its command's range ([`Finding::OutOfRange`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WordOutOfRange {
    /// The command and the word (`G4 S`).
    pub word: String,
    /// The value written.
    pub value: String,
    /// The range (`0 to 86400 s`).
    pub range: String,
}

/// Findings kept per line; the rest are counted in one [`Finding::MoreFindings`]. A line of
/// NUL bytes would otherwise make one finding per byte.
pub const MAX_LINE_DIAGNOSTICS: usize = 16;

/// A finding at a 1-based column of a line.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Diagnostic {
    /// The column of the finding, from 1.
    pub column: u32,
    /// What was found.
    #[serde(flatten)]
    pub finding: Finding,
}

impl Diagnostic {
    /// `finding` at the 0-based byte `byte_index` of the line.
    pub fn at(byte_index: usize, finding: Finding) -> Self {
        Diagnostic { column: byte_index as u32 + 1, finding }
    }
}
