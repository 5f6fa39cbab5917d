//! Lines that arrive while the board is busy with a command.
//!
//! Marlin's emergency parser (`Marlin/src/feature/e_parser.h`, `EMERGENCY_PARSER`) reads each
//! byte as the serial interrupt receives it, before the command queue does: `M108` ends a
//! heating wait and `M112` kills the board at once, even while `M109` holds the queue for
//! minutes. The board's replies to a command are paced in wall time when `gweave serve` runs at
//! a real-time speed ([`crate::link::transport`]); while they wait for their time the transport
//! keeps reading the host into an [`Early`], which completes lines and hands each to the board
//! ([`EarlyLines`], read by [`Device::listen`](crate::link::serial::Device::listen)'s listener
//! between the steps of a wait). The bytes themselves are fed to the protocol afterwards, in
//! order, as Marlin's queue still runs every line the parser has seen.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, PoisonError};

use super::serial::{command_body, MAX_LINE_BYTES};

/// At most this many bytes are read ahead while the board is busy: a host that streams more
/// waits in its own buffer (the socket's or the pty's), as it waits for a board's full receive
/// buffer; memory stays small whatever it sends.
const MAX_EARLY_BYTES: usize = 64 * 1024;

/// Lines received while the board is busy, for its emergency parser: the transport puts, the
/// board takes. Each is the command as Marlin's parser sees it (comment, leading spaces, `N<n>`
/// and `*<checksum>` removed).
#[derive(Debug, Clone, Default)]
pub struct EarlyLines(Arc<Mutex<VecDeque<Vec<u8>>>>);

impl EarlyLines {
    /// The lines received since the last call, oldest first.
    pub fn take(&self) -> Vec<Vec<u8>> {
        // A panic elsewhere cannot leave a queue of byte strings inconsistent.
        let mut lines = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        lines.drain(..).collect()
    }

    fn put(&self, line: Vec<u8>) {
        self.0.lock().unwrap_or_else(PoisonError::into_inner).push_back(line);
    }
}

/// The transport's side: bytes read ahead while the board is busy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum Scan {
    #[default]
    Normal,
    Comment,
    Overflow,
}

#[derive(Debug, Default)]
pub(crate) struct Early {
    /// Everything read ahead, for the protocol once the command is answered.
    bytes: Vec<u8>,
    /// The line being completed, comment excluded, at most [`MAX_LINE_BYTES`].
    line: Vec<u8>,
    /// Where the line is: its comment is not looked at, and a line past Marlin's limit is no
    /// command (the protocol refuses it).
    scan: Scan,
    lines: EarlyLines,
}

impl Early {
    /// Read ahead with `lines` as the board's listener.
    pub(crate) fn new(lines: EarlyLines) -> Self {
        Early { lines, ..Early::default() }
    }

    /// How many more bytes may be read ahead.
    pub(crate) fn room(&self) -> usize {
        MAX_EARLY_BYTES.saturating_sub(self.bytes.len())
    }

    /// Bytes the host sent: kept for the protocol, and each line they complete handed to the
    /// board.
    pub(crate) fn receive(&mut self, bytes: &[u8]) {
        self.bytes.extend_from_slice(bytes);
        for &b in bytes {
            match (b, self.scan) {
                (b'\n' | b'\r', scan) => {
                    let start = self.line.iter().position(|&b| b != b' ').unwrap_or(self.line.len());
                    let end = self.line.iter().rposition(|&b| b != b' ').map_or(start, |i| i + 1);
                    let body = command_body(&self.line[start..end]);
                    if scan != Scan::Overflow && !body.is_empty() {
                        self.lines.put(body.to_vec());
                    }
                    self.line.clear();
                    self.scan = Scan::Normal;
                }
                (_, Scan::Comment | Scan::Overflow) => {}
                (b';', Scan::Normal) => self.scan = Scan::Comment,
                (_, Scan::Normal) if self.line.len() >= MAX_LINE_BYTES => self.scan = Scan::Overflow,
                (_, Scan::Normal) => self.line.push(b),
            }
        }
    }

    /// The bytes read ahead, for the protocol, once the board is no longer busy. The lines it
    /// did not hear meanwhile are forgotten with them: the queue runs them now, and a stale
    /// `M108` must not end the next heating wait.
    pub(crate) fn take_bytes(&mut self) -> Vec<u8> {
        self.lines.take();
        std::mem::take(&mut self.bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each completed line reaches the board as the emergency parser reads it, in any chunking;
    /// every byte is kept for the protocol; a half line waits for its end.
    #[test]
    fn lines_reach_the_board_as_they_complete_and_the_bytes_stay_for_the_queue() {
        let lines = EarlyLines::default();
        let mut early = Early::new(lines.clone());
        early.receive(b"N5 M1");
        assert!(lines.take().is_empty());
        early.receive(b"12*23\n  M108 ; go on\r\n;only a comment\nG1 X");
        assert_eq!(lines.take(), [b"M112".to_vec(), b"M108".to_vec()]);
        assert_eq!(early.take_bytes(), b"N5 M112*23\n  M108 ; go on\r\n;only a comment\nG1 X");
        assert!(early.take_bytes().is_empty());
        early.receive(b"1\n");
        assert_eq!(lines.take(), [b"G1 X1".to_vec()]);
        // A line the board did not hear while busy goes to the queue only.
        early.receive(b"M108\n");
        assert_eq!(early.take_bytes(), b"1\nM108\n");
        assert!(lines.take().is_empty());
    }

    /// A host that streams while the board is busy is read up to a bound, and a line past
    /// Marlin's limit is no command.
    #[test]
    fn reading_ahead_is_bounded() {
        let lines = EarlyLines::default();
        let mut early = Early::new(lines.clone());
        early.receive(&vec![b'X'; 10_000]);
        assert_eq!(early.room(), MAX_EARLY_BYTES - 10_000);
        early.receive(b"\n");
        assert!(lines.take().is_empty());
    }
}
