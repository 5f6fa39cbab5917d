//! Reply lines, with numbers written by hand.
//!
//! `core::fmt` would do, but its machinery (and float formatting above all) costs several
//! kilobytes of flash on an AVR. Replies need only integers and numbers with two decimals
//! (`T:210.00`, `X:10.00`), so a small line buffer with three writers is all there is.

use crate::Io;

/// The longest reply line, in bytes (the longest is an `M105` with two hotends and the bed, or
/// an echoed unknown command). Longer text is cut, never overflowed.
pub const MAX_REPLY: usize = 128;

/// One reply line being built; [`Reply::send`] writes it with its `\n`.
pub struct Reply {
    buf: [u8; MAX_REPLY],
    len: usize,
}

impl Default for Reply {
    fn default() -> Self {
        Reply::new()
    }
}

impl Reply {
    /// An empty line.
    pub fn new() -> Self {
        Reply { buf: [0; MAX_REPLY], len: 0 }
    }

    /// Appends bytes (cut at [`MAX_REPLY`]).
    pub fn s(&mut self, text: &[u8]) -> &mut Self {
        for &b in text {
            if self.len < MAX_REPLY {
                self.buf[self.len] = b;
                self.len += 1;
            }
        }
        self
    }

    /// Appends an unsigned integer in decimal.
    pub fn u32(&mut self, mut n: u32) -> &mut Self {
        let mut digits = [0u8; 10];
        let mut i = digits.len();
        loop {
            i -= 1;
            digits[i] = b'0' + (n % 10) as u8;
            n /= 10;
            if n == 0 {
                break;
            }
        }
        self.s(&digits[i..])
    }

    /// Appends a signed integer in decimal.
    pub fn i32(&mut self, n: i32) -> &mut Self {
        if n < 0 {
            self.s(b"-");
        }
        self.u32(n.unsigned_abs())
    }

    /// Appends a number with two decimals, rounded half away from zero (`-1.005` may print
    /// `-1.00` or `-1.01`: the float is not exactly that decimal). Magnitudes beyond 4e7 print
    /// as that bound; NaN prints `nan`.
    pub fn f2(&mut self, x: f32) -> &mut Self {
        if x.is_nan() {
            return self.s(b"nan");
        }
        let hundredths = (x.abs() * 100.0 + 0.5).min(4.0e9) as u32;
        if x < 0.0 && hundredths != 0 {
            self.s(b"-");
        }
        self.u32(hundredths / 100).s(b".");
        let frac = hundredths % 100;
        self.s(&[b'0' + (frac / 10) as u8, b'0' + (frac % 10) as u8])
    }

    /// Appends `text` with every byte a reply must not carry (control bytes, bytes above ASCII,
    /// the quote) replaced by `?`, for echoing what the host sent.
    pub fn escaped(&mut self, text: &[u8]) -> &mut Self {
        for &b in text {
            let printable = (0x20..0x7F).contains(&b) && b != b'"';
            self.s(&[if printable { b } else { b'?' }]);
        }
        self
    }

    /// The line so far, without its end.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Sends the line and its `\n`, and empties the buffer for the next line.
    pub fn send(&mut self, io: &mut impl Io) {
        io.send(&self.buf[..self.len]);
        io.send(b"\n");
        self.len = 0;
    }
}

/// Sends one fixed line and its `\n`.
pub fn line(io: &mut impl Io, text: &[u8]) {
    io.send(text);
    io.send(b"\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(f: impl FnOnce(&mut Reply)) -> std::string::String {
        let mut r = Reply::new();
        f(&mut r);
        std::string::String::from_utf8(r.as_bytes().to_vec()).unwrap()
    }

    #[test]
    fn numbers_are_written_as_marlin_prints_them() {
        assert_eq!(
            text(|r| {
                r.f2(210.0);
            }),
            "210.00"
        );
        assert_eq!(
            text(|r| {
                r.f2(-0.004);
            }),
            "0.00"
        );
        assert_eq!(
            text(|r| {
                r.f2(-12.345);
            }),
            "-12.35"
        );
        assert_eq!(
            text(|r| {
                r.f2(0.013);
            }),
            "0.01"
        );
        assert_eq!(
            text(|r| {
                r.i32(-800).s(b" ").u32(0).s(b" ").u32(u32::MAX);
            }),
            "-800 0 4294967295"
        );
    }

    #[test]
    fn a_reply_is_cut_not_overflowed() {
        let long = [b'a'; 300];
        assert_eq!(
            text(|r| {
                r.s(&long);
            })
            .len(),
            MAX_REPLY
        );
        assert_eq!(
            text(|r| {
                r.escaped(b"G1\x00\xff\"");
            }),
            "G1???"
        );
    }
}
