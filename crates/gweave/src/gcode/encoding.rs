//! What the first bytes of a file say about its encoding. gweave reads G-code as bytes, ASCII
//! in practice (UTF-8 in comments passes through): a UTF-8 byte order mark is skipped by the
//! lexer and kept by copies. UTF-16 text (a Windows editor's "Unicode") is refused with a
//! message that names it, rather than read as lines of NUL bytes.

use std::io;

/// The bytes [`refuse_utf16`] looks at: a reader gives it this many, or the whole input if
/// shorter, so that the answer does not depend on how the input arrives.
pub(crate) const ENCODING_HEAD: usize = 32;

/// An error if `head` (the first bytes of the input) is UTF-16: a byte order mark, or ASCII
/// with a NUL after (little-endian) or before (big-endian) every character, which no G-code
/// file holds.
pub(crate) fn refuse_utf16(head: &[u8]) -> io::Result<()> {
    let order = match head {
        [0xff, 0xfe, ..] => "little-endian, with a byte order mark",
        [0xfe, 0xff, ..] => "big-endian, with a byte order mark",
        _ if nul_interleaved(head, 1) => "little-endian",
        _ if nul_interleaved(head, 0) => "big-endian",
        _ => return Ok(()),
    };
    Err(io::Error::new(
        io::ErrorKind::InvalidData,
        format!("UTF-16 text ({order}): save the file as UTF-8 or ASCII"),
    ))
}

/// Whether the first pairs of bytes (up to [`ENCODING_HEAD`]) are ASCII characters with the NUL
/// at `nul`.
fn nul_interleaved(head: &[u8], nul: usize) -> bool {
    let mut pairs = head[..head.len().min(ENCODING_HEAD)].chunks_exact(2).peekable();
    pairs.peek().is_some() && pairs.all(|pair| pair[nul] == 0 && matches!(pair[1 - nul], 1..=0x7f))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn utf16(text: &str, big_endian: bool) -> Vec<u8> {
        text.encode_utf16().flat_map(|u| if big_endian { u.to_be_bytes() } else { u.to_le_bytes() }).collect()
    }

    #[test]
    fn utf16_is_refused_with_its_name() {
        for (bytes, order) in [
            ([&[0xff, 0xfe][..], &utf16("G1 X1\n", false)].concat(), "little-endian, with a byte order mark"),
            ([&[0xfe, 0xff][..], &utf16("G1 X1\n", true)].concat(), "big-endian, with a byte order mark"),
            (utf16("G28\nG1 X1\n", false), "little-endian"),
            (utf16("G28\nG1 X1\n", true), "big-endian"),
        ] {
            let err = refuse_utf16(&bytes).unwrap_err();
            assert_eq!(err.to_string(), format!("UTF-16 text ({order}): save the file as UTF-8 or ASCII"));
        }
    }

    #[test]
    fn gcode_and_zeros_are_not_utf16() {
        for head in [&b"G1 X1\n"[..], b"", b"G", b"\0\0\0\0", b"\xef\xbb\xbfG1", b";\xc3\xa9\n"] {
            assert!(refuse_utf16(head).is_ok(), "{head:?}");
        }
    }
}
