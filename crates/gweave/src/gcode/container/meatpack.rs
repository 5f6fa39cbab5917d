//! MeatPack: the encoding of Prusa binary G-code's G-code blocks 1 (comments removed) and 2
//! (comment lines kept). Two characters of the fifteen most common in G-code (`0`-`9`, `.`,
//! space, newline, `G`, `X`) share one byte, four bits each; the nibble `1111` means "a whole
//! byte follows" for that character. `0xFF 0xFF` followed by a command byte switches packing on
//! (251) or off (250, for the comment lines kept as text), and the "no spaces" mode (247/246),
//! in which the space's code stands for `E` and spaces are left out of G lines.
//!
//! Decoding follows libbgcode's `MeatPack::unbinarize` (src/LibBGCode/binarize/meatpack.cpp),
//! which is what defines the text of such a block for PrusaSlicer, PrusaLink and the firmware: a
//! space goes back before each parameter letter of a `G` line (`G1X10Y5` -> `G1 X10 Y5`), and a
//! newline right after a newline is dropped. Each block is decoded on its own, from a reset
//! state, as libbgcode does.

/// The command that follows two signal bytes.
const SIGNAL: u8 = 0xFF;
const ENABLE_PACKING: u8 = 251;
const DISABLE_PACKING: u8 = 250;
const RESET_ALL: u8 = 249;
const ENABLE_NO_SPACES: u8 = 247;
const DISABLE_NO_SPACES: u8 = 246;

/// The letters after which libbgcode puts a space back on a `G` line: G0/G1 (X Y Z E F), G2/G3
/// (I J R), G4 (S), G29 (G P W H C A).
fn is_g_parameter(c: u8) -> bool {
    matches!(
        c,
        b'X' | b'Y'
            | b'Z'
            | b'E'
            | b'F'
            | b'I'
            | b'J'
            | b'R'
            | b'S'
            | b'G'
            | b'P'
            | b'W'
            | b'H'
            | b'C'
            | b'A'
    )
}

/// Decodes one block's MeatPack bytes, appending the text to `out`.
pub fn decode(input: &[u8], out: &mut Vec<u8>) {
    let mut d = Decoder { out, packing: false, no_spaces: false, pending: 0, queue: 0, add_space: false };
    let (mut signals, mut command) = (0u8, false);
    for &c in input {
        if c == SIGNAL {
            if signals > 0 {
                command = true;
                signals = 0;
            } else {
                signals += 1;
            }
        } else if command {
            match c {
                ENABLE_PACKING => d.packing = true,
                DISABLE_PACKING | RESET_ALL => d.packing = false,
                ENABLE_NO_SPACES => d.no_spaces = true,
                DISABLE_NO_SPACES => d.no_spaces = false,
                _ => {}
            }
            command = false;
        } else {
            if signals > 0 {
                d.byte(SIGNAL);
                signals = 0;
            }
            d.byte(c);
        }
    }
}

struct Decoder<'a> {
    out: &'a mut Vec<u8>,
    packing: bool,
    no_spaces: bool,
    /// A packed character waiting for the whole byte that comes before it.
    pending: u8,
    /// Whole bytes still to come.
    queue: u8,
    /// Inside a `G` line: parameters get their space back.
    add_space: bool,
}

impl Decoder<'_> {
    fn byte(&mut self, c: u8) {
        if !self.packing {
            return self.emit(c);
        }
        if self.queue > 0 {
            self.emit(c);
            if self.pending > 0 {
                let p = std::mem::take(&mut self.pending);
                self.emit(p);
            }
            self.queue -= 1;
            return;
        }
        let (low, high) = (c & 0x0F, c >> 4);
        match (low == 0x0F, high == 0x0F) {
            (true, true) => self.queue += 2,
            (true, false) => {
                self.queue += 1;
                self.pending = self.char_of(high);
            }
            (false, second_whole) => {
                let first = self.char_of(low);
                self.emit(first);
                if first != b'\n' {
                    if second_whole {
                        self.queue += 1;
                    } else {
                        let second = self.char_of(high);
                        self.emit(second);
                    }
                }
            }
        }
    }

    fn char_of(&self, nibble: u8) -> u8 {
        match nibble {
            0..=9 => b'0' + nibble,
            10 => b'.',
            11 if self.no_spaces => b'E',
            11 => b' ',
            12 => b'\n',
            13 => b'G',
            14 => b'X',
            _ => 0,
        }
    }

    /// Appends a decoded character, with libbgcode's spacing of `G` lines.
    fn emit(&mut self, c: u8) {
        let last = self.out.last().copied();
        let line_start = last.is_none() || last == Some(b'\n');
        let mut new_line = false;
        if c == b'G' && line_start {
            self.add_space = true;
            new_line = true;
        } else if c == b'\n' {
            self.add_space = false;
        }
        if !new_line && self.add_space && last != Some(b' ') && is_g_parameter(c) {
            self.out.push(b' ');
        }
        if c != b'\n' || self.out.last() != Some(&b'\n') {
            self.out.push(c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decoded(input: &[u8]) -> String {
        let mut out = Vec::new();
        decode(input, &mut out);
        String::from_utf8(out).unwrap()
    }

    /// `G1 X1` as libbgcode's encoder writes it with no spaces: packing and no-spaces on, then
    /// `G1` (0x1D: G low, 1 high), `X1` (0x1E), a newline pair (0xCC).
    #[test]
    fn a_packed_move_gets_its_spaces_back() {
        let bytes = [0xFF, 0xFF, ENABLE_PACKING, 0xFF, 0xFF, ENABLE_NO_SPACES, 0x1D, 0x1E, 0xCC];
        assert_eq!(decoded(&bytes), "G1 X1\n");
        // `E` is the space's code in no-spaces mode; after a 1111 low nibble the whole byte
        // (`Y`) comes first, then the high nibble's character.
        let bytes = [0xFF, 0xFF, ENABLE_PACKING, 0xFF, 0xFF, ENABLE_NO_SPACES, 0x1D, 0xBF, b'Y', 0xCC];
        assert_eq!(decoded(&bytes), "G1 Y E\n");
    }

    #[test]
    fn comment_lines_pass_through_with_packing_off() {
        let mut bytes = vec![0xFF, 0xFF, DISABLE_PACKING];
        bytes.extend_from_slice(b";LAYER_CHANGE\n");
        bytes.extend_from_slice(&[0xFF, 0xFF, ENABLE_PACKING, 0x1D, 0xCC]);
        assert_eq!(decoded(&bytes), ";LAYER_CHANGE\nG1\n");
    }

    proptest::proptest! {
        #[test]
        fn garbage_never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..500)) {
            decoded_lossy(&bytes);
        }
    }

    fn decoded_lossy(input: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        decode(input, &mut out);
        out
    }
}
