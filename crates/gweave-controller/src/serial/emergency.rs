//! The emergency parser: the few commands that act the moment they arrive.
//!
//! A command waits in the line queue behind the ones sent before it, and a full queue stops
//! the board reading the serial line at all. `M112` (stop everything) and `M108` (stop waiting
//! for a heater) cannot wait: the host sends them because the board is busy. Marlin's
//! `EMERGENCY_PARSER` (`Marlin/src/feature/e_parser.h`) reads every byte as it is received,
//! ahead of the queue, with a small state machine; this is the same machine. As in Marlin, the
//! board's receive interrupt feeds it each byte the moment the byte arrives, before it is put
//! in the receive buffer, so neither a queue full of lines nor a buffer full of bytes hides an
//! `M112`: what it hears waits as [`Heard`] for the main loop
//! ([`crate::Controller::heard`]). The line still goes to the queue in its turn, as in Marlin.
//!
//! A line is urgent when its command, after an optional line number (`N12 M112*7`), is one of
//! these, followed by the end of the line, a space, a parameter or the checksum: `M117 Press
//! M112` is no stop, nor is `M1120`. Upper case only, as Marlin reads it.

/// A command the emergency parser acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Urgent {
    /// `M108`: stop waiting for a heater (the wait ends, the target stays).
    Continue,
    /// `M112`: kill the board.
    Kill,
}

/// The urgent commands heard since the main loop last looked: the receive interrupt adds, the
/// main loop takes. One byte of RAM.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Heard(u8);

impl Heard {
    /// Nothing heard (a `const`, for a board's `static`).
    pub const fn new() -> Heard {
        Heard(0)
    }

    /// As one byte, and back: for a board that keeps what its interrupt heard in an atomic.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// See [`Heard::bits`].
    pub const fn from_bits(bits: u8) -> Heard {
        Heard(bits)
    }

    /// `urgent` was heard too.
    pub fn add(&mut self, urgent: Urgent) {
        self.0 |= 1 << urgent as u8;
    }

    /// Whether `urgent` was heard.
    pub fn has(self, urgent: Urgent) -> bool {
        self.0 & (1 << urgent as u8) != 0
    }
}

/// Where the parser is in the current line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum State {
    /// At the start of a line, or in the spaces before its command.
    #[default]
    LineStart,
    /// In a line number (`N` and its digits).
    LineNumber,
    /// `M`, `M1`, `M10`, `M11`: the code so far.
    Code(u16),
    /// A whole code read: what it is, if urgent, once its number has ended.
    Command(Option<Urgent>),
    /// A line that is not urgent, to its end.
    Ignore,
}

/// The parser's state: a few bytes of the board's RAM (the code read so far is a `u16`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EmergencyParser {
    state: State,
}

impl EmergencyParser {
    /// At the start of a line (a `const`, for a board's `static`).
    pub const fn new() -> EmergencyParser {
        EmergencyParser { state: State::LineStart }
    }

    /// Reads one received byte into `heard`: at the end of an urgent line, what to do.
    #[inline]
    pub fn hear_into(&mut self, byte: u8, heard: &mut Heard) {
        if let Some(urgent) = self.hear(byte) {
            heard.add(urgent);
        }
    }

    /// Reads one received byte; at the end of an urgent line, what to do.
    pub fn hear(&mut self, byte: u8) -> Option<Urgent> {
        if matches!(byte, b'\n' | b'\r') {
            let urgent = match self.state {
                State::Command(urgent) => urgent,
                State::Code(code) => urgent(code),
                _ => None,
            };
            self.state = State::LineStart;
            return urgent;
        }
        self.state = match (self.state, byte) {
            (State::LineStart, b' ') => State::LineStart,
            (State::LineStart, b'N') => State::LineNumber,
            (State::LineNumber, b'0'..=b'9' | b'-' | b' ') => State::LineNumber,
            (State::LineStart | State::LineNumber, b'M') => State::Code(0),
            (State::Code(code), b'0'..=b'9') if code < 1000 => {
                State::Code(code * 10 + u16::from(byte - b'0'))
            }
            (State::Code(code), _) => match urgent(code) {
                Some(urgent) => State::Command(Some(urgent)),
                None => State::Ignore,
            },
            (State::Command(urgent), _) => State::Command(urgent),
            _ => State::Ignore,
        };
        None
    }
}

/// The urgent command an M-code is, if any.
fn urgent(code: u16) -> Option<Urgent> {
    match code {
        108 => Some(Urgent::Continue),
        112 => Some(Urgent::Kill),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn heard(text: &[u8]) -> std::vec::Vec<Urgent> {
        let mut p = EmergencyParser::default();
        text.iter().filter_map(|&b| p.hear(b)).collect()
    }

    /// Regression (a breaking session: `M117 Press M112 to abort`, `M105 (M112)` and
    /// `G4 P1 M112` halted the printer): only a line whose command is `M112` (or `M108`) is
    /// urgent, with a line number or a checksum, a parameter, a comment.
    #[test]
    fn only_a_line_whose_command_is_urgent_is() {
        for (line, urgent) in [
            (&b"M112\n"[..], Some(Urgent::Kill)),
            (b"  N12 M112*7\r\n", Some(Urgent::Kill)),
            (b"N-1 M112 ; now\n", Some(Urgent::Kill)),
            (b"M108\n", Some(Urgent::Continue)),
            (b"M117 Press M112 to abort\n", None),
            (b"M105 (M112)\n", None),
            (b"G4 P1 M112\n", None),
            (b"M1120\n", None),
            (b"M11\n", None),
            (b"; M112\n", None),
            (b"m112\n", None),
        ] {
            assert_eq!(heard(line).first().copied(), urgent, "{line:?}");
        }
    }

    /// A code not yet ended when the line ends (`M112` with its line end) acts; bytes of the
    /// lines around it, in any number, leave it alone.
    #[test]
    fn each_line_is_read_on_its_own() {
        assert_eq!(heard(b"G4 S10\nG4 S1\nM112\nM105\nM108\n"), [Urgent::Kill, Urgent::Continue]);
        assert_eq!(heard(b"M112"), []);
    }

    /// What the interrupt hears between two looks of the main loop is kept, each kind once.
    #[test]
    fn heard_keeps_each_urgent_command_until_taken() {
        let (mut p, mut heard) = (EmergencyParser::default(), Heard::default());
        for &b in b"M108\nG1 X1\nM108\n" {
            p.hear_into(b, &mut heard);
        }
        assert!(heard.has(Urgent::Continue) && !heard.has(Urgent::Kill));
        for &b in b"M112\n" {
            p.hear_into(b, &mut heard);
        }
        assert!(heard.has(Urgent::Continue) && heard.has(Urgent::Kill));
        // Taken by the main loop, the set starts empty again.
        assert!(core::mem::take(&mut heard).has(Urgent::Kill));
        assert_eq!(heard, Heard::default());
    }
}
