//! The binary G-code target: any bytes, read as a Prusa `.bgcode` file (every command reads one
//! through this reader when a file starts with `GCDE`). The text is read through to its end, and
//! the end alone as `stats` reads it for the slicer's settings; either gives text or an error,
//! never a panic, and never an allocation sized by a header past the reader's ceilings (a block
//! of 8 MiB, 8 MiB of metadata and thumbnails). A file that reads gives the same end both ways.

use std::io::{Cursor, Read};

use gweave::gcode::container::bgcode::read::{tail, Reader};

/// Bytes of the end read alone, as `stats` asks for its settings.
const TAIL: usize = 4096;

/// Reads `bytes` as binary G-code: whole, then its end alone.
pub fn bgcode(bytes: &[u8]) {
    // The fuzzer rarely finds the magic by itself: every input is also tried behind it.
    let mut with_magic = b"GCDE\x01\x00\x00\x00".to_vec();
    with_magic.extend_from_slice(bytes);
    for input in [bytes, &with_magic] {
        let whole = Reader::new(Cursor::new(input)).and_then(|mut r| {
            let mut text = Vec::new();
            r.read_to_end(&mut text).map(|_| text)
        });
        let end = tail(Cursor::new(input), TAIL);
        if let (Ok(whole), Ok(end)) = (whole, end) {
            let want = &whole[whole.len().saturating_sub(TAIL)..];
            assert!(want.ends_with(&end) || end.ends_with(want), "the end read alone differs");
        }
    }
}
