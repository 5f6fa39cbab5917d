//! Heatshrink: the LZSS compression of Prusa binary G-code's blocks (compression 2: window
//! 2^11, lookahead 2^4; compression 3: window 2^12, lookahead 2^4), as the reference library
//! (atomicobject/heatshrink, used by libbgcode and Prusa's firmware) writes it.
//!
//! The stream is a sequence of bits, most significant first. A `1` bit is followed by a literal
//! byte (8 bits); a `0` bit by a back-reference: `window` bits holding the distance minus one,
//! then `lookahead` bits holding the length minus one, copied from the bytes already output
//! (the window). The last byte is padded with zero bits, which a decoder ignores because they
//! never complete a token. Bytes before the start of the output read as zero, as the reference
//! decoder's zero-filled window gives them.
//!
//! Why not the `heatshrink` crate (0.2): its encoder tries every position of the window for every
//! byte (about 2^12 x 16 comparisons a byte with window 12, minutes for one print), and its
//! decoder reads one bit at a time through a state machine. A G-code file has tens of thousands
//! of blocks; this module decodes from 64-bit windows of the input, up to four tokens at a time,
//! and encodes with hash chains.

use std::io;

/// Window and lookahead, in bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Params {
    pub window_bits: u32,
    pub lookahead_bits: u32,
}

/// Bytes a back-reference copies at once: the longest one (lookahead 4 bits).
const COPY: usize = 16;

/// Tokens the decoder looks at for a run of literals at once.
const LITERALS: usize = 4;

/// Longest chain of earlier positions the encoder follows for one match: enough for G-code's
/// repetitive text (the compressed size is within 1 % of following them all), bounded time.
const MAX_CHAIN: usize = 48;

/// Decodes `input` into `out` (replacing what it held), which must come to `expected` bytes:
/// the whole stream, not its first `expected` bytes. A stream that goes on past `expected` (a
/// header whose size was lowered: the rest of the block would be dropped without a word) is
/// refused as one that ends short of it is, with the size it decodes to.
pub(crate) fn decode(input: &[u8], p: Params, expected: usize, out: &mut Vec<u8>) -> io::Result<()> {
    // Room for a whole 16-byte copy past the end; not cleared (only grown: a block's buffer is
    // reused for the next), since every byte up to `expected` is written before it is read.
    out.resize(expected + COPY, 0);
    let longest = p.longest();
    // The position in the input, in bits: all that carries from one token to the next.
    let mut bit = 0;
    let mut at = 0;
    // Far from both ends, in rounds: the literals among the next four tokens up to the first
    // back-reference, then that back-reference. A round's cost is set by the chain from one
    // round's position to the next (a load, shifts, a count of leading zeros, a compare, adds:
    // about 20 cycles for some six bytes out), so the round neither branches on a token's kind (the kinds come mixed, about
    // three literals to a back-reference) nor keeps a bit buffer to top up: it loads the 64
    // bits at its position, of which it takes at most 3 x 9 + `longest` = 44. The four
    // candidates' bytes are stored at once (those past the run are overwritten later); a round
    // of four literals makes an empty copy. A round ends at most 3 + `COPY` bytes on, inside
    // `expected` by the loop's condition: only the tokens near the end can overrun it.
    while at + LITERALS + COPY <= expected && bit / 8 + 8 <= input.len() {
        let w = u64::from_be_bytes(input[bit / 8..bit / 8 + 8].try_into().expect("8 bytes")) << (bit % 8);
        // Bits before the first zero among the tags the four tokens would have as literals
        // (bits 63, 54, 45, 36), 36 when they are all literals: nine times the run.
        let run_bits = (!w & LITERAL_TAGS | 1 << 27).leading_zeros() as usize;
        // One 4-byte store: a later copy's 16-byte load over bytes stored one at a time would
        // wait for all of them to be written (no store forwarding from several stores).
        let bytes = (w >> 55 & 0xFF) | (w >> 38 & 0xFF00) | (w >> 21 & 0xFF_0000) | (w >> 4 & 0xFF00_0000);
        out[at..at + LITERALS].copy_from_slice(&(bytes as u32).to_le_bytes());
        at += run_bits / 9;
        // The back-reference, unless the four were literals: then an empty copy, from far
        // enough back to take the fast path. Masks, not a branch: which of the two comes is as
        // unpredictable as the kinds.
        let follows = usize::from(run_bits < 9 * LITERALS).wrapping_neg();
        let (dist, len) = p.reference(w << run_bits);
        bit += run_bits + (longest & follows);
        let (dist, len) = (dist & follows | at.max(COPY) & !follows, len & follows);
        copy(out, at, dist, len);
        at += len;
    }
    // Near the ends, a token at a time, as long as the input holds a whole one (the last
    // byte's padding never does) and it ends within `expected`.
    while let Some(t) = tail_token(input, bit, p).filter(|t| at + t.len <= expected) {
        match t.dist {
            0 => out[at] = (window(input, bit) >> 55) as u8,
            dist => copy(out, at, dist, t.len),
        }
        bit = t.end;
        at += t.len;
    }
    out.truncate(at);
    // Whole tokens left mean the stream is longer than the header says (one whose size was
    // lowered would otherwise lose the rest of its block without a word): counted, not
    // decoded, for the message. Nothing is left in a stream of the right size.
    let rest = std::iter::successors(tail_token(input, bit, p), |t| tail_token(input, t.end, p));
    let total = at + rest.map(|t| t.len).sum::<usize>();
    if total != expected {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("heatshrink data decodes to {total} bytes, not the {expected} its header says"),
        ));
    }
    Ok(())
}

impl Params {
    /// Bits of the longest token: a back-reference's tag, index and count.
    fn longest(self) -> usize {
        (1 + self.window_bits + self.lookahead_bits) as usize
    }

    /// The distance and length of the back-reference whose tag is the top bit of `w`.
    #[inline(always)]
    fn reference(self, w: u64) -> (usize, usize) {
        let (wb, lb) = (self.window_bits, self.lookahead_bits);
        let t = (w >> (64 - self.longest())) as usize;
        ((t >> lb & ((1 << wb) - 1)) + 1, (t & ((1 << lb) - 1)) + 1)
    }
}

/// A whole token read a bit at a time near the ends: `dist` 0 for a literal.
#[derive(Clone, Copy)]
struct Token {
    dist: usize,
    len: usize,
    /// The bit after it.
    end: usize,
}

/// The token at bit `bit`, if the input holds all of it.
fn tail_token(input: &[u8], bit: usize, p: Params) -> Option<Token> {
    let left = 8 * input.len() - bit;
    let w = window(input, bit);
    if w >> 63 == 1 {
        (left >= 9).then_some(Token { dist: 0, len: 1, end: bit + 9 })
    } else {
        let (dist, len) = p.reference(w);
        (left >= p.longest()).then_some(Token { dist, len, end: bit + p.longest() })
    }
}

/// Where the tags of four literals in a row sit in 64 bits read most significant first.
const LITERAL_TAGS: u64 = 1 << 63 | 1 << 54 | 1 << 45 | 1 << 36;

/// The (up to) 64 bits of `input` from bit `bit` on, most significant first; zeros past its end.
fn window(input: &[u8], bit: usize) -> u64 {
    let rest = &input[bit / 8..];
    let mut bytes = [0u8; 8];
    let n = rest.len().min(8);
    bytes[..n].copy_from_slice(&rest[..n]);
    u64::from_be_bytes(bytes) << (bit % 8)
}

/// Copies `len` bytes from `dist` back to `at`, with room for [`COPY`] bytes past `at`.
#[inline(always)]
fn copy(out: &mut [u8], at: usize, dist: usize, len: usize) {
    if dist <= at && dist >= COPY && len <= COPY {
        // A fixed-size copy (no call to memcpy); the bytes past `len` are overwritten later.
        let from = at - dist;
        let chunk: [u8; COPY] = out[from..from + COPY].try_into().expect("16 bytes");
        out[at..at + COPY].copy_from_slice(&chunk);
    } else {
        // Overlapping (a run), or before the start, where the reference decoder's window is
        // zero-filled.
        for k in at..at + len {
            out[k] = k.checked_sub(dist).map_or(0, |from| out[from]);
        }
    }
}

/// Encodes `input` into `out` (appended).
pub(crate) fn encode(input: &[u8], p: Params, out: &mut Vec<u8>) {
    const HASH_BITS: u32 = 14;
    let window = 1usize << p.window_bits;
    let max_len = 1usize << p.lookahead_bits;
    // A back-reference costs 1 + window + lookahead bits, a literal 9: worth it from this length.
    let min_len = (1 + p.window_bits + p.lookahead_bits).div_ceil(9) as usize + 1;
    let mut head = vec![u32::MAX; 1 << HASH_BITS];
    let mut prev = vec![u32::MAX; input.len()];
    let hash = |i: usize| {
        let v = u32::from(input[i]) | u32::from(input[i + 1]) << 8 | u32::from(input[i + 2]) << 16;
        (v.wrapping_mul(0x9E37_79B1) >> (32 - HASH_BITS)) as usize
    };
    let insert = |i: usize, head: &mut Vec<u32>, prev: &mut Vec<u32>| {
        if i + 2 < input.len() {
            let h = hash(i);
            prev[i] = head[h];
            head[h] = i as u32;
        }
    };
    let mut w = BitWriter { out, buf: 0, have: 0 };
    let mut i = 0;
    while i < input.len() {
        let (mut best_len, mut best_dist) = (0, 0);
        if i + 2 < input.len() {
            let limit = max_len.min(input.len() - i);
            let mut cand = head[hash(i)];
            let mut chain = 0;
            while cand != u32::MAX && chain < MAX_CHAIN {
                let c = cand as usize;
                if i - c > window {
                    break;
                }
                let len = input[c..].iter().zip(&input[i..i + limit]).take_while(|(a, b)| a == b).count();
                if len > best_len {
                    (best_len, best_dist) = (len, i - c);
                    if len == limit {
                        break;
                    }
                }
                cand = prev[c];
                chain += 1;
            }
        }
        if best_len >= min_len {
            w.put(0, 1);
            w.put((best_dist - 1) as u32, p.window_bits);
            w.put((best_len - 1) as u32, p.lookahead_bits);
            for k in i..i + best_len {
                insert(k, &mut head, &mut prev);
            }
            i += best_len;
        } else {
            w.put(0x100 | u32::from(input[i]), 9);
            insert(i, &mut head, &mut prev);
            i += 1;
        }
    }
    w.finish();
}

struct BitWriter<'a> {
    out: &'a mut Vec<u8>,
    buf: u64,
    have: u32,
}

impl BitWriter<'_> {
    fn put(&mut self, v: u32, n: u32) {
        self.buf = self.buf << n | u64::from(v);
        self.have += n;
        while self.have >= 8 {
            self.have -= 8;
            self.out.push((self.buf >> self.have) as u8);
        }
    }

    /// Pads the last byte with zero bits.
    fn finish(mut self) {
        if self.have > 0 {
            self.out.push((self.buf << (8 - self.have)) as u8);
            self.have = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P12: Params = Params { window_bits: 12, lookahead_bits: 4 };
    const P11: Params = Params { window_bits: 11, lookahead_bits: 4 };

    fn round_trip(input: &[u8], p: Params) -> usize {
        let mut packed = Vec::new();
        encode(input, p, &mut packed);
        let mut back = Vec::new();
        decode(&packed, p, input.len(), &mut back).unwrap();
        assert!(back == input);
        packed.len()
    }

    #[test]
    fn gcode_text_round_trips_and_shrinks() {
        let text = std::fs::read(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../tests/data/prusaslicer/pr_torus_pva.gcode"),
        )
        .unwrap();
        for p in [P11, P12] {
            let packed = round_trip(&text[..65536], p);
            assert!(packed < 65536 / 2, "{packed}");
        }
    }

    /// The reference encoder's output for a tiny input, worked by hand: `1` + 'a', `1` + 'b',
    /// then a back-reference of distance 2, length 4 (`0`, index 1, count 3) with window 4 and
    /// lookahead 3 (the format's smallest), padded.
    #[test]
    fn decodes_a_hand_made_stream() {
        let p = Params { window_bits: 4, lookahead_bits: 3 };
        // 1 01100001 1 01100010 0 0001 011 + padding
        let bits = "10110000110110001000001011";
        let mut bytes = Vec::new();
        for chunk in bits.as_bytes().chunks(8) {
            let s: String = chunk.iter().map(|&b| b as char).collect();
            bytes.push(u8::from_str_radix(&format!("{s:0<8}"), 2).unwrap());
        }
        let mut out = Vec::new();
        decode(&bytes, p, 6, &mut out).unwrap();
        assert_eq!(out, b"ababab");
        let err = decode(&bytes, p, 7, &mut out).unwrap_err();
        assert_eq!(err.to_string(), "heatshrink data decodes to 6 bytes, not the 7 its header says");
    }

    /// Regression (B2): a stream whose header gives fewer bytes than it decodes to was cut at
    /// the header's size without a word (a block's size lowered to 0 dropped the whole block).
    /// Refused as one that decodes to fewer is, with the size the whole stream decodes to:
    /// past the end of a back-reference (5 of its 6 bytes), after the last token (4 of 6) and
    /// with nothing at all decoded (0).
    #[test]
    fn b2_a_stream_longer_than_its_header_says_is_refused() {
        let p = Params { window_bits: 4, lookahead_bits: 3 };
        // `ababab`, as in decodes_a_hand_made_stream.
        let bytes = [0b1011_0000, 0b1101_1000, 0b1000_0010, 0b1100_0000];
        for short in [5, 4, 0] {
            let mut out = Vec::new();
            let err = decode(&bytes, p, short, &mut out).unwrap_err();
            assert_eq!(
                err.to_string(),
                format!("heatshrink data decodes to 6 bytes, not the {short} its header says")
            );
        }
        // A real block: 64 KiB of G-code, given one byte less and one byte more.
        let text = std::fs::read(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../tests/data/prusaslicer/pr_torus_pva.gcode"),
        )
        .unwrap();
        let mut packed = Vec::new();
        encode(&text[..65536], P12, &mut packed);
        for expected in [65535, 65537, 0] {
            let err = decode(&packed, P12, expected, &mut Vec::new()).unwrap_err();
            assert_eq!(
                err.to_string(),
                format!("heatshrink data decodes to 65536 bytes, not the {expected} its header says")
            );
        }
    }

    /// The reference library's decoder, a bit at a time, with its zero-filled window: the
    /// whole stream, whatever size a header gives.
    fn bit_at_a_time(input: &[u8], p: Params) -> Vec<u8> {
        let mut at = 0;
        let mut bits = |n: u32| -> Option<usize> {
            let mut v = 0;
            for _ in 0..n {
                let byte = input.get(at / 8)?;
                v = v << 1 | usize::from(byte >> (7 - at % 8) & 1);
                at += 1;
            }
            Some(v)
        };
        let mut out = Vec::new();
        while let Some(tag) = bits(1) {
            if tag == 1 {
                let Some(b) = bits(8) else { break };
                out.push(b as u8);
                continue;
            }
            let (Some(index), Some(count)) = (bits(p.window_bits), bits(p.lookahead_bits)) else { break };
            for _ in 0..count + 1 {
                out.push(out.len().checked_sub(index + 1).map_or(0, |from| out[from]));
            }
        }
        out
    }

    proptest::proptest! {
        #[test]
        fn any_bytes_round_trip(bytes in proptest::collection::vec(proptest::sample::select(b"G1 X0.5Y\n".to_vec()), 0..3000)) {
            round_trip(&bytes, P12);
            round_trip(&bytes, P11);
        }

        #[test]
        fn garbage_never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..300), n in 0usize..2000) {
            let _ = decode(&bytes, P12, n, &mut Vec::new());
        }

        /// Any bits, decoded into a buffer that held another block's bytes, give what the
        /// reference decoder gives reading a bit at a time: literals, copies (overlapping
        /// ones too), copies reaching before the start (zeros), the end padding. A size other
        /// than the whole stream's is refused, and what was decoded is still the stream's start.
        #[test]
        fn decodes_as_a_bit_at_a_time(
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..600),
            n in 0usize..2000,
            held in proptest::collection::vec(proptest::num::u8::ANY, 0..3000),
            p in proptest::sample::select(vec![P11, P12]),
        ) {
            let mut out = held;
            let result = decode(&bytes, p, n, &mut out);
            let want = bit_at_a_time(&bytes, p);
            proptest::prop_assert_eq!(result.is_ok(), want.len() == n);
            proptest::prop_assert!(want.starts_with(&out), "{} bytes of {}", out.len(), want.len());
            if result.is_ok() {
                proptest::prop_assert_eq!(out, want);
            }
        }
    }
}
