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

use super::assembly::{urgent_text, Assembler};

/// At most this many bytes are read ahead while the board is busy: a host that streams more
/// waits in its own buffer (the socket's or the pty's), as it waits for a board's full receive
/// buffer; memory stays small whatever it sends.
pub(crate) const MAX_EARLY_BYTES: usize = 64 * 1024;

/// Lines received while the board is busy, for its emergency parser: the transport puts, the
/// board takes. Each is an `M` command as Marlin's parser sees it (comment, spaces around it,
/// `N<n>` and `*<checksum>` removed); other lines cannot be urgent and are not kept.
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
#[derive(Debug, Default)]
pub(crate) struct Early {
    /// Everything read ahead, for the protocol once the command is answered.
    bytes: Vec<u8>,
    /// Every byte of the host's passes through this assembler, read ahead or not, so that a
    /// line begun in one way and ended in the other is the line the queue sees.
    assembler: Assembler,
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

    /// Bytes the host sent while the board is busy: kept for the protocol, and each line they
    /// complete handed to the board.
    pub(crate) fn receive(&mut self, bytes: &[u8]) {
        self.bytes.extend_from_slice(bytes);
        self.assemble(bytes, true);
    }

    /// Bytes the host sent while the board was free, which go to the protocol at once: only
    /// followed, as the board runs the lines they complete in turn.
    pub(crate) fn follow(&mut self, bytes: &[u8]) {
        self.assemble(bytes, false);
    }

    fn assemble(&mut self, bytes: &[u8], hear: bool) {
        for &b in bytes {
            if !self.assembler.push(b) {
                continue;
            }
            // Only an `M` command can be urgent; the others are not kept. A line past Marlin's
            // limit is heard too: the parser reads bytes, not the queue's lines (the protocol
            // then refuses it, as the queue does).
            if hear {
                let text = urgent_text(&self.assembler.line);
                if text.first().is_some_and(|c| c.eq_ignore_ascii_case(&b'M')) {
                    self.lines.put(text.to_vec());
                }
            }
            self.assembler.restart();
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

    /// Each completed `M` line reaches the board as the emergency parser reads it, in any
    /// chunking; every byte is kept for the protocol; a half line waits for its end.
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
        // Lines that cannot be urgent are not kept for the board.
        early.receive(b"1\nm105 \nG4 P1\n");
        assert_eq!(lines.take(), [b"m105".to_vec()]);
        // A line the board did not hear while busy goes to the queue only.
        early.receive(b"M108\n");
        assert_eq!(early.take_bytes(), b"1\nm105 \nG4 P1\nM108\n");
        assert!(lines.take().is_empty());
    }

    /// Regression (review of the emergency parser during paced waits: a line begun in the
    /// bytes read ahead and ended in bytes the board read itself stayed half in the early
    /// assembler, so the next `M112` completed `G1 XM112`, or, after a `;`, was skipped as a
    /// comment): the bytes the board reads while free are followed too.
    #[test]
    fn a_line_cut_between_the_read_ahead_and_the_board_leaves_no_half_line_behind() {
        for (ahead, free) in [(&b"G1 X"[..], &b"1\n"[..]), (b"G1 X1 ; a comment", b" to its end\n")] {
            let lines = EarlyLines::default();
            let mut early = Early::new(lines.clone());
            early.receive(ahead);
            early.take_bytes();
            early.follow(free);
            early.receive(b"M112\n");
            assert_eq!(lines.take(), [b"M112".to_vec()], "{:?}", String::from_utf8_lossy(ahead));
        }
        // Regression (the previous session's note: the firmware's parser, in its receive
        // interrupt, heard `M112` in a line past Marlin's limit, and serve did not): an overlong
        // line's command is heard, as Marlin's `e_parser.h` reads bytes, not lines.
        let lines = EarlyLines::default();
        let mut early = Early::new(lines.clone());
        early.receive(format!("M112 {}\nM108\n", "X".repeat(100)).as_bytes());
        let heard: Vec<Vec<u8>> = lines.take().iter().map(|l| l[..4].to_vec()).collect();
        assert_eq!(heard, [b"M112".to_vec(), b"M108".to_vec()]);
        // What the board reads while free is never handed to it early.
        let lines = EarlyLines::default();
        let mut early = Early::new(lines.clone());
        early.follow(b"M108\nM11");
        early.receive(b"2\n");
        assert_eq!(lines.take(), [b"M112".to_vec()]);
    }
}
