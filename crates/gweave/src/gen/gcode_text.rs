//! Fast G-code text for generators: numbers with a fixed number of decimals and no trailing
//! zeros (`20.2646`, `20`, `-0.5`), written straight into a byte buffer without going through
//! `fmt`, and tables of pre-formatted lines.

/// Formats `v` with at most `decimals` digits, without trailing zeros: `20.2646`, `20`, `-0.5`.
pub(crate) fn push_num(buf: &mut Vec<u8>, v: f64, decimals: u32) {
    let scale = 10i64.pow(decimals);
    let scaled = (v * scale as f64).round();
    if scaled.is_nan() || scaled.abs() >= 9.0e18 {
        // Outside i64 (or NaN): no bed is that large; keep the value readable anyway.
        buf.extend_from_slice(v.to_string().as_bytes());
        return;
    }
    let n = scaled as i64;
    if n < 0 {
        buf.push(b'-');
    }
    let n = n.unsigned_abs();
    let (int, mut frac) = (n / scale as u64, n % scale as u64);
    push_uint(buf, int);
    if frac != 0 {
        buf.push(b'.');
        let mut digits = decimals;
        while frac % 10 == 0 {
            frac /= 10;
            digits -= 1;
        }
        let start = buf.len();
        push_uint(buf, frac);
        // Leading zeros of the fraction.
        let written = (buf.len() - start) as u32;
        for _ in written..digits {
            buf.insert(start, b'0');
        }
    }
}

pub(crate) fn push_uint(buf: &mut Vec<u8>, mut n: u64) {
    let mut tmp = [0u8; 20];
    let mut i = tmp.len();
    loop {
        i -= 1;
        tmp[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    buf.extend_from_slice(&tmp[i..]);
}

/// Short lines of text in slots of `N` bytes each, zero-padded: a line is copied out with one
/// copy of `N` bytes (two vector moves for 16 or 32), where a copy of its exact length is a call
/// to `memcpy` with its size tests. The raster writes tens of millions of them (a column's move
/// and fire: about 30 bytes), so this is most of its cost (docs/performance.md).
#[derive(Debug, Clone, Default)]
pub(crate) struct SlotTable<const N: usize> {
    slots: Vec<[u8; N]>,
    lens: Vec<u8>,
}

impl<const N: usize> SlotTable<N> {
    pub(crate) fn len(&self) -> usize {
        self.slots.len()
    }

    /// Adds `text` as the next slot; `false` (nothing added) when it does not fit.
    pub(crate) fn push(&mut self, text: &[u8]) -> bool {
        let mut slot = [0; N];
        let Some(to) = slot.get_mut(..text.len()) else { return false };
        to.copy_from_slice(text);
        self.slots.push(slot);
        self.lens.push(text.len() as u8);
        true
    }

    /// Copies slot `i` to the start of `out` (which must hold `N` bytes: the padding is written
    /// too, and overwritten by what follows) and returns the length of its text.
    #[inline]
    pub(crate) fn put(&self, i: usize, out: &mut [u8]) -> usize {
        out[..N].copy_from_slice(&self.slots[i]);
        usize::from(self.lens[i])
    }
}

/// Writes `M<code> P<head> S<bits>\n`.
pub(crate) fn push_fire(buf: &mut Vec<u8>, code: u32, head: usize, s: u64) {
    buf.push(b'M');
    push_uint(buf, u64::from(code));
    buf.extend_from_slice(b" P");
    push_uint(buf, head as u64);
    buf.extend_from_slice(b" S");
    push_uint(buf, s);
    buf.push(b'\n');
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn num(v: f64, d: u32) -> String {
        let mut b = Vec::new();
        push_num(&mut b, v, d);
        String::from_utf8(b).unwrap()
    }

    #[test]
    fn numbers_without_trailing_noise() {
        assert_eq!(num(20.0 + 25.4 / 96.0, 4), "20.2646");
        assert_eq!(num(20.0, 4), "20");
        assert_eq!(num(0.5, 4), "0.5");
        assert_eq!(num(-0.5, 4), "-0.5");
        assert_eq!(num(-0.00001, 4), "0");
        assert_eq!(num(3.0001, 4), "3.0001");
        assert_eq!(num(3.05, 2), "3.05");
        assert_eq!(num(7.4, 0), "7");
        assert_eq!(num(123456.000_000_000_1, 9), "123456");
        assert_eq!(num(123456.000_000_1, 9), "123456.0000001");
        assert_eq!(num(1e30, 4), "1000000000000000000000000000000");
    }

    proptest! {
        /// The text parses back to the value rounded to the decimals, with no trailing zero.
        #[test]
        fn num_parses_back(v in -1.0e6f64..1.0e6, d in 0u32..7) {
            let t = num(v, d);
            let scale = 10f64.powi(d as i32);
            let back: f64 = t.parse().unwrap();
            prop_assert!((back - (v * scale).round() / scale).abs() <= 0.5 / scale + 1e-9, "{} {}", v, t);
            prop_assert!(!t.ends_with('0') || !t.contains('.'));
            prop_assert!(!t.ends_with('.'));
            prop_assert!(t.split('.').nth(1).map_or(0, str::len) <= d as usize);
        }

        /// A slot copied out with its padding reads as the text pushed, whatever follows it.
        #[test]
        fn slots_give_back_their_text(texts in prop::collection::vec("[ -~]{0,20}", 1..20)) {
            let mut table = SlotTable::<16>::default();
            let mut out = vec![0u8; 16 * texts.len() + 16];
            let (mut pos, mut expected) = (0, Vec::new());
            for t in &texts {
                if table.push(t.as_bytes()) {
                    pos += table.put(table.len() - 1, &mut out[pos..]);
                    expected.extend_from_slice(t.as_bytes());
                } else {
                    prop_assert!(t.len() > 16);
                }
            }
            prop_assert_eq!(&out[..pos], &expected[..]);
        }

        #[test]
        fn uint_matches_display(n in any::<u64>()) {
            let mut b = Vec::new();
            push_uint(&mut b, n);
            prop_assert_eq!(String::from_utf8(b).unwrap(), n.to_string());
        }
    }
}
