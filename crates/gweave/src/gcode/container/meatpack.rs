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
//!
//! What a character adds to the text depends only on the class of the character before it
//! (none yet, newline, space, other) and on whether the line is a `G` line: eight states. So
//! decoding is table-driven: [`CHAR`] gives, for a state and a character, the bytes it adds and
//! the next state; [`PAIR`] does the same for a whole packed byte (two characters, up to four
//! bytes of text with their spaces), the common case, which then costs one look-up and one
//! 4-byte store; [`NEXT`] gives a packed byte's next state from every state at once, so that
//! the state carried from byte to byte is a shift rather than a look-up. The tables are built at
//! compile time from the rules above ([`step`]).

use std::mem::MaybeUninit;

/// The command that follows two signal bytes.
const SIGNAL: u8 = 0xFF;
const ENABLE_PACKING: u8 = 251;
const DISABLE_PACKING: u8 = 250;
const RESET_ALL: u8 = 249;
const ENABLE_NO_SPACES: u8 = 247;
const DISABLE_NO_SPACES: u8 = 246;

/// The letters after which libbgcode puts a space back on a `G` line: G0/G1 (X Y Z E F), G2/G3
/// (I J R), G4 (S), G29 (G P W H C A).
const fn is_g_parameter(c: u8) -> bool {
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

/// The class of the last character written (the state's low two bits).
const START: u8 = 0;
const NEWLINE: u8 = 1;
const SPACE: u8 = 2;
const OTHER: u8 = 3;
/// The state's third bit: inside a `G` line, parameters get their space back.
const G_LINE: u8 = 4;

/// What one decoded character adds in state `st`: up to two bytes (a space, the character),
/// their count, and the next state. libbgcode's `unbinarize` appends a character so: a `G` at
/// the start of a line starts a `G` line, a newline ends it; a parameter letter of a `G` line
/// not after a space gets one; a newline right after a newline is dropped.
const fn step(st: u8, c: u8) -> ([u8; 2], usize, u8) {
    let mut last = st & 3;
    let mut g_line = st & G_LINE != 0;
    let mut new_line = false;
    if c == b'G' && (last == START || last == NEWLINE) {
        g_line = true;
        new_line = true;
    } else if c == b'\n' {
        g_line = false;
    }
    let mut out = [0u8; 2];
    let mut n = 0;
    if !new_line && g_line && last != SPACE && is_g_parameter(c) {
        out[n] = b' ';
        n += 1;
        last = SPACE;
    }
    if c != b'\n' || last != NEWLINE {
        out[n] = c;
        n += 1;
        last = match c {
            b'\n' => NEWLINE,
            b' ' => SPACE,
            _ => OTHER,
        };
    }
    (out, n, last | if g_line { G_LINE } else { 0 })
}

/// A table entry: the bytes added (little-endian, low bytes first), their count in bits 32-39,
/// the next state in bits 40-47. The count is at most four (checked when the tables are built,
/// at compile time): [`decode`] relies on it to know every byte of its text written.
const fn entry(out: [u8; 4], n: usize, st: u8) -> u64 {
    assert!(n <= 4, "a table entry adds at most the four bytes it holds");
    u32::from_le_bytes(out) as u64 | (n as u64) << 32 | (st as u64) << 40
}

/// Decoded character of a packed nibble (`0xF`, a whole byte, never looked up).
const fn char_of(nibble: u8, no_spaces: bool) -> u8 {
    match nibble {
        0..=9 => b'0' + nibble,
        10 => b'.',
        11 if no_spaces => b'E',
        11 => b' ',
        12 => b'\n',
        13 => b'G',
        14 => b'X',
        _ => 0,
    }
}

/// Every no-spaces mode by nibble: its character ([`char_of`]).
static NIBBLE: [[u8; 16]; 2] = {
    let mut t = [[0u8; 16]; 2];
    let mut n = 0;
    while n < 16 {
        t[0][n] = char_of(n as u8, false);
        t[1][n] = char_of(n as u8, true);
        n += 1;
    }
    t
};

/// Every state by every character.
static CHAR: [u64; 8 * 256] = {
    let mut t = [0u64; 8 * 256];
    let mut i = 0;
    while i < t.len() {
        let (out, n, next) = step((i >> 8) as u8, i as u8);
        t[i] = entry([out[0], out[1], 0, 0], n, next);
        i += 1;
    }
    t
};

/// [`PAIR`]'s entry for a byte with a `1111` nibble (a whole byte follows), signals included.
const NOT_A_PAIR: u64 = u64::MAX;

/// [`PAIR`]'s entry for a packed byte `b` in state `st`: the low nibble's character, then the
/// high one's unless the first is a newline (libbgcode reads a newline as the end of the pair,
/// so a newline beside `1111` is a pair too: no whole byte follows it).
const fn pair(no_spaces: bool, st: u8, b: u8) -> u64 {
    let (low, high) = (b & 0x0F, b >> 4);
    if low == 0x0F {
        return NOT_A_PAIR;
    }
    let first = char_of(low, no_spaces);
    let (a, na, st1) = step(st, first);
    if first == b'\n' {
        return entry([a[0], a[1], 0, 0], na, st1);
    }
    if high == 0x0F {
        return NOT_A_PAIR;
    }
    let (b2, nb, st2) = step(st1, char_of(high, no_spaces));
    let mut out = [0u8; 4];
    let mut k = 0;
    while k < nb {
        out[na + k] = b2[k];
        k += 1;
    }
    if na > 0 {
        out[0] = a[0];
    }
    if na > 1 {
        out[1] = a[1];
    }
    entry(out, na + nb, st2)
}

/// Every no-spaces mode by state by packed byte whose nibbles are both characters ([`pair`]).
static PAIR: [u64; 2 * 8 * 256] = {
    let mut t = [NOT_A_PAIR; 2 * 8 * 256];
    let mut i = 0;
    while i < t.len() {
        t[i] = pair(i >> 11 == 1, ((i >> 8) & 7) as u8, i as u8);
        i += 1;
    }
    t
};

/// Every no-spaces mode by packed byte: the state after the byte from each of the eight states,
/// a byte per state (from state `s`, bits `8s..8s+8` hold eight times the next state), or
/// [`NOT_A_PAIR`]. The state is all that carries from one byte to the next; looked up in
/// [`PAIR`] it waits for a load (about five cycles) a byte, where this word depends on the
/// input alone, is loaded ahead, and the next state is one shift of it.
static NEXT: [u64; 2 * 256] = {
    let mut t = [NOT_A_PAIR; 2 * 256];
    let mut i = 0;
    while i < t.len() {
        let (no_spaces, b) = (i >> 8 == 1, i as u8);
        if pair(no_spaces, 0, b) != NOT_A_PAIR {
            let mut word = 0u64;
            let mut st = 0;
            while st < 8 {
                let next = (pair(no_spaces, st, b) >> 40) as u8;
                word |= ((next as u64) << 3) << (8 * st);
                st += 1;
            }
            t[i] = word;
        }
        i += 1;
    }
    t
};

/// Decodes one block's MeatPack bytes, appending the text to `out`.
pub(crate) fn decode(input: &[u8], out: &mut Vec<u8>) {
    let start = out.len();
    // At most four bytes of text an input byte (two characters, each with a space), and room
    // for a whole 4-byte store past the last. Written, not zeroed first: the text is about half
    // of that room, and zeroing all of it for every block was 2 % of `stats` of a PrusaSlicer
    // `.bgcode` (docs/performance.md).
    let room = 4 * input.len() + 4;
    out.reserve(room);
    let mut d = Decoder {
        out: &mut out.spare_capacity_mut()[..room],
        at: 0,
        st: START,
        packing: false,
        no_spaces: false,
        pending: 0,
        queue: 0,
        signals: 0,
        command: false,
    };
    let mut i = 0;
    while i < input.len() {
        if d.packing && d.queue == 0 && d.signals == 0 && !d.command {
            // The common case, packed pairs one after the other: a byte is two look-ups (its
            // text, its next state) and one store. The state is kept as eight times itself, a
            // shift count. A character packed beside a whole byte (a `1111` nibble: a letter
            // such as `Y`, `Z` or `F`, one byte in twelve of a G-code block) is decoded here
            // too, a character at a time; a signal ends the run.
            let mode = usize::from(d.no_spaces);
            let (pairs, next) = (&PAIR[mode << 11..][..8 << 8], &NEXT[mode << 8..][..256]);
            let nibbles = &NIBBLE[mode];
            let mut st8 = usize::from(d.st) << 3;
            while let Some(&c) = input.get(i) {
                let word = next[usize::from(c)];
                if word != NOT_A_PAIR {
                    // `st8` is a multiple of 8 below 64; the mask tells the compiler so.
                    let e = pairs[(st8 & 0x38) << 5 | usize::from(c)];
                    store(d.out, &mut d.at, e);
                    st8 = usize::from((word >> st8) as u8);
                    i += 1;
                    continue;
                }
                let Some(&whole) = input.get(i + 1) else { break };
                if c == SIGNAL || whole == SIGNAL {
                    break;
                }
                // libbgcode's queue: the whole byte first when it stands for the low nibble
                // (the high one's character waits for it), else after the low one's character.
                let (low, high) = (usize::from(c & 0x0F), usize::from(c >> 4));
                let (first, second) =
                    if low == 0x0F { (whole, nibbles[high]) } else { (nibbles[low], whole) };
                for ch in [first, second] {
                    let e = CHAR[(st8 & 0x38) << 5 | usize::from(ch)];
                    store(d.out, &mut d.at, e);
                    st8 = usize::from((e >> 40) as u8) << 3;
                }
                i += 2;
            }
            d.st = (st8 >> 3) as u8;
            let Some(&c) = input.get(i) else { break };
            d.input(c);
        } else {
            d.input(input[i]);
        }
        i += 1;
    }
    let written = d.at;
    // SAFETY: within the room reserved above (`store` slices it, checked), and every byte below
    // `at` is written: `store` writes four bytes at `at` and moves it by a table entry's count,
    // at most four ([`entry`]; `NOT_A_PAIR` is never stored).
    unsafe { out.set_len(start + written) };
}

/// Stores a table entry's four bytes at `at` (those past its count are overwritten later) and
/// moves `at` past its text, at most four bytes.
#[inline(always)]
fn store(out: &mut [MaybeUninit<u8>], at: &mut usize, e: u64) {
    // What `decode`'s `set_len` relies on; the property tests run it on random streams.
    debug_assert!(e >> 32 & 0xFF <= 4, "an entry of more than four bytes: {e:#x}");
    out[*at..*at + 4].copy_from_slice(&(e as u32).to_le_bytes().map(MaybeUninit::new));
    *at += (e >> 32 & 0xFF) as usize;
}

/// The decoder's state between input bytes.
struct Decoder<'a> {
    /// Text written up to `at`; room for four bytes more past every byte still to decode.
    out: &'a mut [MaybeUninit<u8>],
    at: usize,
    /// [`step`]'s state.
    st: u8,
    packing: bool,
    no_spaces: bool,
    /// A packed character waiting for the whole byte that comes before it (0: none).
    pending: u8,
    /// Whole bytes still to come.
    queue: u8,
    /// Signal bytes seen (one), or two seen: the next byte is a command.
    signals: u8,
    command: bool,
}

impl Decoder<'_> {
    /// One input byte: a signal, a command, or data.
    #[inline(always)]
    fn input(&mut self, c: u8) {
        if c == SIGNAL {
            if self.signals > 0 {
                self.command = true;
                self.signals = 0;
            } else {
                self.signals += 1;
            }
        } else if self.command {
            match c {
                ENABLE_PACKING => self.packing = true,
                DISABLE_PACKING | RESET_ALL => self.packing = false,
                ENABLE_NO_SPACES => self.no_spaces = true,
                DISABLE_NO_SPACES => self.no_spaces = false,
                _ => {}
            }
            self.command = false;
        } else {
            if self.signals > 0 {
                self.byte(SIGNAL);
                self.signals = 0;
            }
            self.byte(c);
        }
    }

    /// One data byte.
    #[inline(always)]
    fn byte(&mut self, c: u8) {
        if !self.packing {
            return self.char(c);
        }
        if self.queue > 0 {
            self.char(c);
            if self.pending > 0 {
                let p = std::mem::take(&mut self.pending);
                self.char(p);
            }
            self.queue -= 1;
            return;
        }
        let (low, high) = (c & 0x0F, c >> 4);
        if low == 0x0F && high == 0x0F {
            self.queue += 2;
        } else if low == 0x0F {
            self.queue += 1;
            self.pending = char_of(high, self.no_spaces);
        } else if high == 0x0F {
            // A packed character, then a whole byte (unless the first ends the line).
            let first = char_of(low, self.no_spaces);
            self.char(first);
            if first != b'\n' {
                self.queue += 1;
            }
        } else {
            self.put(PAIR[usize::from(self.no_spaces) << 11 | usize::from(self.st) << 8 | usize::from(c)]);
        }
    }

    #[inline(always)]
    fn char(&mut self, c: u8) {
        self.put(CHAR[usize::from(self.st) << 8 | usize::from(c)]);
    }

    #[inline(always)]
    fn put(&mut self, e: u64) {
        store(self.out, &mut self.at, e);
        self.st = (e >> 40) as u8;
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

    /// Appends to what `out` holds.
    #[test]
    fn appends() {
        let mut out = b"; kept\n".to_vec();
        decode(&[0xFF, 0xFF, ENABLE_PACKING, 0x1D, 0xCC], &mut out);
        assert_eq!(out, b"; kept\nG1\n");
    }

    /// libbgcode's `unbinarize` written out a character at a time, as the tables are built
    /// from: the oracle the table-driven decoder must equal byte for byte.
    fn reference(input: &[u8]) -> Vec<u8> {
        let mut out: Vec<u8> = Vec::new();
        let (mut packing, mut no_spaces, mut pending, mut queue, mut add_space) =
            (false, false, 0u8, 0u8, false);
        let mut emit = |c: u8, add_space: &mut bool| {
            let last = out.last().copied();
            let line_start = last.is_none() || last == Some(b'\n');
            let mut new_line = false;
            if c == b'G' && line_start {
                *add_space = true;
                new_line = true;
            } else if c == b'\n' {
                *add_space = false;
            }
            if !new_line && *add_space && last != Some(b' ') && is_g_parameter(c) {
                out.push(b' ');
            }
            if c != b'\n' || out.last() != Some(&b'\n') {
                out.push(c);
            }
        };
        let mut byte = |c: u8, packing: bool, no_spaces: bool| {
            if !packing {
                return emit(c, &mut add_space);
            }
            if queue > 0 {
                emit(c, &mut add_space);
                if pending > 0 {
                    emit(std::mem::take(&mut pending), &mut add_space);
                }
                queue -= 1;
                return;
            }
            let (low, high) = (c & 0x0F, c >> 4);
            match (low == 0x0F, high == 0x0F) {
                (true, true) => queue += 2,
                (true, false) => {
                    queue += 1;
                    pending = char_of(high, no_spaces);
                }
                (false, second_whole) => {
                    let first = char_of(low, no_spaces);
                    emit(first, &mut add_space);
                    if first != b'\n' {
                        if second_whole {
                            queue += 1;
                        } else {
                            emit(char_of(high, no_spaces), &mut add_space);
                        }
                    }
                }
            }
        };
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
                    ENABLE_PACKING => packing = true,
                    DISABLE_PACKING | RESET_ALL => packing = false,
                    ENABLE_NO_SPACES => no_spaces = true,
                    DISABLE_NO_SPACES => no_spaces = false,
                    _ => {}
                }
                command = false;
            } else {
                if signals > 0 {
                    byte(SIGNAL, packing, no_spaces);
                    signals = 0;
                }
                byte(c, packing, no_spaces);
            }
        }
        out
    }

    /// Bytes as MeatPack streams hold them: commands, packed pairs, whole bytes, text.
    fn stream() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        let piece = prop_oneof![
            4 => any::<u8>().prop_map(|b| vec![b]),
            2 => proptest::sample::select(vec![
                ENABLE_PACKING, DISABLE_PACKING, RESET_ALL, ENABLE_NO_SPACES, DISABLE_NO_SPACES, 0, SIGNAL
            ])
            .prop_map(|cmd| vec![SIGNAL, SIGNAL, cmd]),
            6 => (0u8..15, 0u8..15).prop_map(|(l, h)| vec![h << 4 | l]),
            1 => proptest::sample::select(b"G1X Y;\n EPS".to_vec()).prop_map(|b| vec![b]),
        ];
        proptest::collection::vec(piece, 0..400).prop_map(|v| v.concat())
    }

    proptest::proptest! {
        #[test]
        fn the_tables_decode_as_libbgcode(bytes in stream()) {
            let mut out = Vec::new();
            decode(&bytes, &mut out);
            proptest::prop_assert_eq!(out, reference(&bytes));
        }
    }
}
