//! Line assembly, as Marlin's `GCodeQueue::get_serial_commands` does it byte by byte
//! (`MarlinFirmware/Marlin:Marlin/src/gcode/queue.cpp`): `\n` or `\r` ends a line; `;` starts a
//! comment that runs to the end of the line and is dropped; a line keeps at most
//! [`MAX_LINE_BYTES`] bytes, and one past that is refused as a whole. The protocol's queue
//! ([`crate::link::serial`]) and the emergency parser's early look at what arrives while the
//! board is busy ([`crate::link::early`]) assemble with this one, so both cut the host's bytes
//! into the same lines.

use super::serial::MAX_LINE_BYTES;

/// Where the assembler is inside the current line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum Scan {
    #[default]
    Normal,
    /// After `;`: drop bytes up to the end of the line.
    Comment,
    /// Past [`MAX_LINE_BYTES`]: drop bytes, refuse the line.
    Overflow,
}

/// The line being received.
#[derive(Debug, Default)]
pub(crate) struct Assembler {
    /// The line so far, comment excluded, at most [`MAX_LINE_BYTES`].
    pub(crate) line: Vec<u8>,
    pub(crate) scan: Scan,
}

impl Assembler {
    pub(crate) fn new() -> Self {
        Assembler { line: Vec::with_capacity(MAX_LINE_BYTES), scan: Scan::Normal }
    }

    /// Takes one byte; `true` when it ends a line, which is then in [`Assembler::line`] and
    /// [`Assembler::scan`] until [`Assembler::restart`].
    #[inline]
    pub(crate) fn push(&mut self, b: u8) -> bool {
        match (b, self.scan) {
            (b'\n' | b'\r', _) => return true,
            (_, Scan::Comment | Scan::Overflow) => {}
            (b';', Scan::Normal) => self.scan = Scan::Comment,
            (_, Scan::Normal) if self.line.len() >= MAX_LINE_BYTES => self.scan = Scan::Overflow,
            (_, Scan::Normal) => self.line.push(b),
        }
        false
    }

    /// Starts the next line (the buffer is kept: assembling allocates nothing in the long run).
    pub(crate) fn restart(&mut self) {
        self.line.clear();
        self.scan = Scan::Normal;
    }
}

/// The command of a line as the emergency parser reads it: spaces around it, `N<n>` and, on a
/// numbered line, `*<checksum>` removed.
pub(crate) fn urgent_text(line: &[u8]) -> &[u8] {
    let start = line.iter().position(|&b| b != b' ').unwrap_or(line.len());
    let end = line.iter().rposition(|&b| b != b' ').map_or(start, |i| i + 1);
    command_body(&line[start..end])
}

/// The command of an accepted line: without its `N<n>` and, on a numbered line, without its
/// `*<checksum>` (what Marlin's parser skips).
pub(crate) fn command_body(cmd: &[u8]) -> &[u8] {
    if cmd.first() != Some(&b'N') {
        return cmd;
    }
    let end = cmd.iter().rposition(|&b| b == b'*').unwrap_or(cmd.len());
    let number_end =
        cmd[1..].iter().position(|b| !(b.is_ascii_digit() || *b == b'-')).map_or(cmd.len(), |i| i + 1);
    let body = &cmd[number_end.min(end)..end];
    let first = body.iter().position(|&b| b != b' ').unwrap_or(body.len());
    let last = body.iter().rposition(|&b| b != b' ').map_or(first, |i| i + 1);
    &body[first..last]
}
