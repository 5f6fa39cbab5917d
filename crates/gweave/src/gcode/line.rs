//! What one line of G-code says, as written: the command, its words, comments, line number and
//! checksum, each with its byte span in the original line. Nothing here knows what the machine
//! does with it; that is [`crate::gcode::state`].

use super::diag::{Diagnostic, Finding, Severity, MAX_LINE_DIAGNOSTICS};

/// A byte range `start..end` inside one line (without its line ending).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    /// First byte, 0-based.
    pub start: u32,
    /// One past the last byte.
    pub end: u32,
}

impl Span {
    /// The span `start..end`.
    pub fn new(start: usize, end: usize) -> Self {
        Span { start: start as u32, end: end as u32 }
    }

    /// The bytes this span covers in `raw`.
    pub fn of<'a>(&self, raw: &'a [u8]) -> &'a [u8] {
        &raw[self.start as usize..self.end as usize]
    }
}

/// The command a line starts with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Command {
    /// No command: an empty line, a comment, or words that continue the modal motion (`X10 Y5`).
    #[default]
    None,
    /// A letter-number command: `G1`, `M104`, `T2`, `G29.1` (`sub` = 1).
    Code {
        /// The command letter, upper-cased (`G`, `M`, `T`).
        letter: u8,
        /// The number after the letter.
        number: u32,
        /// The number after a dot, if any.
        sub: Option<u32>,
    },
    /// A Klipper/RepRapFirmware extended command such as `SET_VELOCITY_LIMIT` or `echo`; its
    /// arguments are kept as text in [`Block::text`].
    Extended,
}

impl Command {
    /// `true` for `G<number>` with no subcode.
    #[inline]
    pub fn is_g(&self, n: u32) -> bool {
        matches!(self, Command::Code { letter: b'G', number, sub: None } if *number == n)
    }

    /// `true` for `M<number>` with no subcode.
    #[inline]
    pub fn is_m(&self, n: u32) -> bool {
        matches!(self, Command::Code { letter: b'M', number, sub: None } if *number == n)
    }

    /// The number of an `M<n>` command.
    #[inline]
    pub fn m(&self) -> Option<u32> {
        match self {
            Command::Code { letter: b'M', number, sub: None } => Some(*number),
            _ => None,
        }
    }

    /// The tool number of a `T<n>` command.
    #[inline]
    pub fn tool(&self) -> Option<u32> {
        match self {
            Command::Code { letter: b'T', number, sub: None } => Some(*number),
            _ => None,
        }
    }
}

/// The value of a word.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// A number.
    Number(f64),
    /// A letter with no value, as in `G28 X Y` or `M84 E`.
    Empty,
    /// A quoted string (RepRapFirmware `M291 P"text"`); the span excludes the quotes.
    Text(Span),
    /// A RepRapFirmware `{expression}`; the span includes the braces.
    Expr(Span),
    /// Not a number (`1..2`, `NaN`); a diagnostic says why.
    Invalid,
}

/// One parameter word: a letter (upper-cased) and its value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Word {
    /// The letter, upper-cased.
    pub letter: u8,
    /// What follows the letter.
    pub value: Value,
    /// The whole word as written, letter included.
    pub span: Span,
}

impl Word {
    /// The numeric value, if the word has one.
    #[inline]
    pub fn number(&self) -> Option<f64> {
        match self.value {
            Value::Number(v) => Some(v),
            _ => None,
        }
    }
}

/// A line's checksum: what was written after `*` and the XOR of every byte before it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Checksum {
    /// The number written after `*`.
    pub given: u32,
    /// The XOR of every byte before `*`.
    pub computed: u8,
    /// From the `*` to the end of the digits.
    pub span: Span,
}

impl Checksum {
    /// The written checksum matches the line.
    pub fn is_valid(&self) -> bool {
        self.given == u32::from(self.computed)
    }
}

/// The numbers of a plain move (`G0`/`G1` with only X, Y, Z, E and F words, each a number), by
/// letter: what the lexer's fast path read, kept so that the machine state need not go through
/// the words again for the lines a print is made of. The words are in [`Block::words`] too.
#[derive(Clone, Copy, Default)]
pub struct PlainMove {
    /// Bit i: a word with letter [`PlainMove::LETTERS`]`[i]` was read (the last one wins).
    /// 0 on every other line, and on a plain `G1` without words.
    pub present: u8,
    /// The values by letter; only those whose bit is set mean anything.
    pub values: [f64; 5],
    /// `G0` (else `G1`), meaningful when `present` is not 0.
    pub rapid: bool,
}

/// Shows the words read, not what earlier lines left in the other fields.
impl std::fmt::Debug for PlainMove {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut s = f.debug_struct("PlainMove");
        for (i, letter) in PlainMove::LETTERS.iter().enumerate() {
            if self.present >> i & 1 != 0 {
                s.field(&char::from(*letter).to_string(), &self.values[i]);
            }
        }
        if self.present != 0 {
            s.field("rapid", &self.rapid);
        }
        s.finish()
    }
}

impl PlainMove {
    /// The letters, in the order of the machine's axes (X Y Z E), then the feed rate.
    pub const LETTERS: [u8; 5] = [b'X', b'Y', b'Z', b'E', b'F'];

    /// The index of a plain move's letter in [`PlainMove::LETTERS`]. A table lookup: a `match`
    /// compiles to a jump through a table, which the processor guesses wrong word after word.
    #[inline(always)]
    pub(crate) fn index_of(letter: u8) -> Option<usize> {
        const NONE: u8 = u8::MAX;
        const INDEX: [u8; 256] = {
            let mut t = [NONE; 256];
            let mut i = 0;
            while i < PlainMove::LETTERS.len() {
                t[PlainMove::LETTERS[i] as usize] = i as u8;
                i += 1;
            }
            t
        };
        // Tested against the length, not `NONE`: the compiler then knows the index fits.
        let index = usize::from(INDEX[usize::from(letter)]);
        (index < PlainMove::LETTERS.len()).then_some(index)
    }
}

/// A parsed line (a "block" in G-code terms). Reused from line to line so that parsing a file
/// allocates nothing once the buffers have grown.
#[derive(Debug, Clone, Default)]
pub struct Block {
    /// `N<n>` line number and its span.
    pub line_number: Option<(i64, Span)>,
    /// `*<n>` checksum, if the line has one.
    pub checksum: Option<Checksum>,
    /// The command the line starts with.
    pub command: Command,
    /// Where the command is written.
    pub command_span: Span,
    /// Parameter words in written order.
    pub words: Vec<Word>,
    /// The string argument of `M117`, `M118`, `M23`... or the raw arguments of an extended command.
    pub text: Option<Span>,
    /// The first `;` comment, without the `;`.
    pub comment: Option<Span>,
    /// The line starts with `/` (block delete).
    pub block_delete: bool,
    /// A `%` tape marker line.
    pub tape_marker: bool,
    /// What is wrong with the line, at most [`MAX_LINE_DIAGNOSTICS`] findings.
    pub diagnostics: Vec<Diagnostic>,
    /// The line's words by letter when it is a plain move ([`PlainMove`]); `present` is 0
    /// otherwise.
    pub plain: PlainMove,
}

impl Block {
    #[inline]
    pub(crate) fn clear(&mut self) {
        self.line_number = None;
        self.checksum = None;
        self.command = Command::None;
        self.command_span = Span::default();
        self.words.clear();
        self.text = None;
        self.comment = None;
        self.block_delete = false;
        self.tape_marker = false;
        self.diagnostics.clear();
        self.plain.present = 0;
    }

    /// Whether the line starts with bytes no firmware reads, before any word (`!!! Z5`,
    /// `$x Y30`) and with no command: a firmware finds no command there (Marlin answers
    /// `Unknown command`, Klipper too), so the words after the junk are no modal move.
    pub fn starts_unreadable(&self) -> bool {
        let first_word = self.words.first().map_or(u32::MAX, |w| w.span.start);
        self.command == Command::None
            && self.diagnostics.first().is_some_and(|d| {
                d.finding.severity() == Severity::Error && d.column.saturating_sub(1) < first_word
            })
    }

    /// Records a finding: the first [`MAX_LINE_DIAGNOSTICS`], then a count of the rest in one
    /// more.
    pub(crate) fn diagnose(&mut self, diagnostic: Diagnostic) {
        match self.diagnostics.len() {
            n if n < MAX_LINE_DIAGNOSTICS => self.diagnostics.push(diagnostic),
            MAX_LINE_DIAGNOSTICS => self
                .diagnostics
                .push(Diagnostic { finding: Finding::MoreFindings { count: 1 }, ..diagnostic }),
            _ => {
                if let Some(Finding::MoreFindings { count }) =
                    self.diagnostics.last_mut().map(|d| &mut d.finding)
                {
                    *count += 1;
                }
            }
        }
    }

    /// Appends a word.
    #[inline]
    pub(crate) fn push_word(&mut self, word: Word) {
        self.words.push(word);
    }

    /// The word with this (upper-case) letter, if present. The last one wins, as in firmware.
    /// A search from the end: lines hold a handful of words, and keeping an index by letter
    /// cost every word of every line more than the lookups it saved.
    #[inline]
    pub fn word(&self, letter: u8) -> Option<&Word> {
        self.words.iter().rev().find(|w| w.letter == letter)
    }

    /// The numeric value of a word, if present and numeric.
    #[inline]
    pub fn get(&self, letter: u8) -> Option<f64> {
        self.word(letter).and_then(Word::number)
    }

    /// Whether the letter is present at all (with or without a value).
    #[inline]
    pub fn has(&self, letter: u8) -> bool {
        self.word(letter).is_some()
    }

    /// Whether the letter is present, listed or as a plain move's number: [`Block::has`] for a
    /// pass that leaves plain moves' words unlisted ([`crate::Pass::reads_words`]).
    #[inline]
    pub fn names(&self, letter: u8) -> bool {
        PlainMove::index_of(letter).is_some_and(|i| self.plain.present >> i & 1 != 0) || self.has(letter)
    }

    /// The comment text (after `;`), from the raw line this block was parsed from.
    pub fn comment_text<'a>(&self, raw: &'a [u8]) -> Option<&'a [u8]> {
        self.comment.map(|s| s.of(raw))
    }

    /// The string argument or extended-command arguments, from the raw line.
    pub fn text_of<'a>(&self, raw: &'a [u8]) -> Option<&'a [u8]> {
        self.text.map(|s| s.of(raw))
    }

    /// `true` when the line carries nothing for the machine (empty, comment only).
    pub fn is_empty(&self) -> bool {
        self.command == Command::None && self.words.is_empty()
    }
}
