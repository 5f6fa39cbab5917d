//! The text of the lines purge-shift holds back, in one buffer (and the lines the finishing
//! step's windows hold, `gweave-sim`'s `finish/delta.rs`, for the same reason).
//!
//! ## Why
//! Every line of the print proper is held until the extrusion after it reaches the largest
//! purge (a few dozen lines at 2.5 mm), so every line is copied once into the window and
//! written once from it. A line of its own (two `Vec`s, its bytes and its ending, recycled
//! through a free list) cost two copies and the bookkeeping of both buffers going in, and two
//! writes coming out: about 200 instructions a line on the guard's input, a third of the pass.
//! Here the lines are appended, ending included, to one buffer that the window consumes from
//! the front: one copy in, one write out, and a held line is a position and two lengths.
//!
//! ## Bounded memory
//! Positions are counted from the start of the run, so they survive the buffer being cut: the
//! bytes before the first line still held are dropped when the window empties, or when they are
//! at least `CUT_BYTES` (64 KiB) and half the buffer (each byte is moved at most once on
//! average). The buffer is at most about twice the held lines' text plus `CUT_BYTES`.

/// Bytes written from the front that are dropped at once, at least (a cut moves what is left).
const CUT_BYTES: usize = 64 << 10;

/// Where a held line's text is: its start (counted from the start of the run) and the lengths
/// of its content and its ending.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TextRef {
    start: u64,
    len: u32,
    eol_len: u8,
}

/// The held lines' text; see the module docs.
#[derive(Debug, Default)]
pub struct HeldText {
    buf: Vec<u8>,
    /// The position of `buf[0]`.
    base: u64,
}

impl HeldText {
    /// Appends a line (its content and its ending, at most 2 bytes) and says where it is.
    #[inline]
    pub fn push(&mut self, bytes: &[u8], eol: &[u8]) -> TextRef {
        let start = self.base + self.buf.len() as u64;
        self.buf.reserve(bytes.len() + eol.len());
        self.buf.extend_from_slice(bytes);
        self.buf.extend_from_slice(eol);
        // A whole line is at most `MAX_LINE` (256 KiB) and its ending at most `\r\n`.
        TextRef { start, len: bytes.len() as u32, eol_len: eol.len() as u8 }
    }

    /// Appends a line whose content and ending are one slice (`whole`, ending `eol_len` bytes).
    #[inline]
    pub fn push_whole(&mut self, whole: &[u8], eol_len: usize) -> TextRef {
        let start = self.base + self.buf.len() as u64;
        self.buf.extend_from_slice(whole);
        TextRef { start, len: (whole.len() - eol_len) as u32, eol_len: eol_len as u8 }
    }

    /// The line with its ending.
    #[inline]
    pub fn whole(&self, r: TextRef) -> &[u8] {
        let at = (r.start - self.base) as usize;
        &self.buf[at..at + r.len as usize + usize::from(r.eol_len)]
    }

    /// The line's content.
    pub fn bytes(&self, r: TextRef) -> &[u8] {
        let at = (r.start - self.base) as usize;
        &self.buf[at..at + r.len as usize]
    }

    /// The line's ending.
    pub fn eol(&self, r: TextRef) -> &[u8] {
        let at = (r.start - self.base) as usize + r.len as usize;
        &self.buf[at..at + usize::from(r.eol_len)]
    }

    /// Every line before `first` (the first line still held; none: no line is held) has been
    /// written: its text may go.
    #[inline]
    pub fn written_up_to(&mut self, first: Option<TextRef>) {
        let Some(first) = first else {
            self.base += self.buf.len() as u64;
            self.buf.clear();
            return;
        };
        let dead = (first.start - self.base) as usize;
        if dead >= CUT_BYTES && dead * 2 >= self.buf.len() {
            self.buf.drain(..dead);
            self.base = first.start;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_keep_their_text_across_cuts() {
        let mut text = HeldText::default();
        let mut held = std::collections::VecDeque::new();
        let mut written = Vec::new();
        let mut expected = Vec::new();
        for i in 0..20_000u32 {
            let line = format!("G1 X{i} E0.{i}");
            let eol: &[u8] = if i % 3 == 0 { b"\r\n" } else { b"\n" };
            expected.extend_from_slice(line.as_bytes());
            expected.extend_from_slice(eol);
            let r = if i % 2 == 0 {
                text.push(line.as_bytes(), eol)
            } else {
                text.push_whole(&[line.as_bytes(), eol].concat(), eol.len())
            };
            assert_eq!((text.bytes(r), text.eol(r)), (line.as_bytes(), eol));
            held.push_back(r);
            // A window of 50 lines, emptied now and then.
            while held.len() > 50 || (i % 997 == 0 && !held.is_empty()) {
                let r = held.pop_front().unwrap();
                written.extend_from_slice(text.whole(r));
                text.written_up_to(held.front().copied());
            }
            assert!(text.buf.len() <= 2 * 50 * 20 + CUT_BYTES + 20, "{}", text.buf.len());
        }
        while let Some(r) = held.pop_front() {
            written.extend_from_slice(text.whole(r));
            text.written_up_to(held.front().copied());
        }
        assert_eq!(written, expected);
        assert!(text.buf.is_empty());
    }
}
