//! The line and chunk readers on awkward input: every line ending, every length, any bytes,
//! read in any pieces.

use super::*;

type Line = (Vec<u8>, Vec<u8>);

fn collect(input: &[u8]) -> Vec<Line> {
    let mut r = LineReader::new(input);
    let mut out = Vec::new();
    while let Some(l) = r.next_line().unwrap() {
        out.push((l.bytes.to_vec(), l.eol.to_vec()));
    }
    out
}

fn line(bytes: &[u8], eol: &[u8]) -> Line {
    (bytes.to_vec(), eol.to_vec())
}

#[test]
fn keeps_line_endings_exactly() {
    let lines = collect(b"G1 X1\r\nG1 X2\n\nlast");
    assert_eq!(lines, [line(b"G1 X1", b"\r\n"), line(b"G1 X2", b"\n"), line(b"", b"\n"), line(b"last", b"")]);
    assert!(collect(b"").is_empty());
    assert_eq!(collect(b"\r"), [line(b"", b"\r")]);
}

#[test]
fn a_lone_cr_ends_a_line() {
    let lines = collect(b"G1 X10 Y10 E1\rG1 X500 Y10 E2\rM104 S0");
    assert_eq!(lines, [line(b"G1 X10 Y10 E1", b"\r"), line(b"G1 X500 Y10 E2", b"\r"), line(b"M104 S0", b"")]);
    // `\r\r\n`: a line ended by a lone CR, then an empty one ended by CRLF.
    assert_eq!(
        collect(b"G1\r\r\nG2\n\r"),
        [line(b"G1", b"\r"), line(b"", b"\r\n"), line(b"G2", b"\n"), line(b"", b"\r")]
    );
}

#[test]
fn a_cr_only_file_reads_as_many_lines() {
    let input: Vec<u8> = (0..5000).flat_map(|i| format!("G1 X{i}\r").into_bytes()).collect();
    for step in [1, 7, 4096, CHUNK] {
        let mut r = LineReader::new(Trickle(&input, step));
        let mut n = 0;
        while let Some(l) = r.next_line().unwrap() {
            assert_eq!((l.bytes, l.eol, l.part), (format!("G1 X{n}").as_bytes(), &b"\r"[..], Part::Whole));
            n += 1;
        }
        assert_eq!(n, 5000, "step {step}");
    }
}

#[test]
fn finds_the_line_end_at_every_offset() {
    for len in 0..600 {
        for end in [b'\n', b'\r'] {
            let mut text = vec![b'x'; len];
            assert_eq!(find_line_end(&text), None);
            text.push(end);
            text.extend_from_slice(b"tail\n");
            assert_eq!(find_line_end(&text), Some(len), "line of {len} bytes");
        }
    }
}

/// Hands out its bytes a few at a time, as a pipe may.
struct Trickle<'a>(&'a [u8], usize);

impl Read for Trickle<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.1.min(buf.len()).min(self.0.len());
        buf[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        Ok(n)
    }
}

#[test]
fn every_line_has_its_lookahead() {
    // Long lines then a short last one without a line ending: the buffer is compacted over
    // digits, which must not show past the last line's content.
    let mut input = Vec::new();
    for i in 0..3000 {
        input.extend_from_slice(format!("G1 X{i}.123456789 Y987654321\n").as_bytes());
    }
    input.extend_from_slice(b"G1 X1");
    for step in [1, 3, 7, 4096, CHUNK] {
        let mut r = LineReader::new(Trickle(&input, step));
        let mut last = Vec::new();
        while let Some(l) = r.next_line().unwrap() {
            let ahead = l.with_lookahead();
            assert!(ahead.len() >= l.bytes.len() + LOOKAHEAD);
            assert_eq!(&ahead[..l.bytes.len() + l.eol.len()], [l.bytes, l.eol].concat().as_slice());
            assert!(!ahead[l.bytes.len()].is_ascii_digit(), "step {step}, line {}", l.number);
            last = ahead[l.bytes.len()..l.bytes.len() + LOOKAHEAD].to_vec();
        }
        assert_eq!(last, [0; LOOKAHEAD], "step {step}");
    }
}

/// Each line's text and ending: `\n`, `\r\n`, `\r` or `\r\r\n` by its number, none after
/// the last one unless `last_eol`.
fn joined(lines: &[(String, u8)], last_eol: bool) -> Vec<u8> {
    let mut input = Vec::new();
    for (i, (text, eol)) in lines.iter().enumerate() {
        input.extend_from_slice(text.as_bytes());
        if i + 1 < lines.len() || last_eol {
            input.extend_from_slice([&b"\n"[..], b"\r\n", b"\r", b"\r\r\n"][*eol as usize]);
        }
    }
    input
}

/// What a line reader should give, by the simplest means: (content, ending, number,
/// offset) of each line, a line ending at `\n`, `\r\n` or a lone `\r`.
fn reference_lines(input: &[u8]) -> Vec<(Vec<u8>, Vec<u8>, u64, u64)> {
    let (mut out, mut start, mut i) = (Vec::new(), 0, 0);
    while i < input.len() {
        let eol = match (input[i], input.get(i + 1)) {
            (b'\r', Some(b'\n')) => 2,
            (b'\r' | b'\n', _) => 1,
            _ => 0,
        };
        if eol > 0 {
            out.push((
                input[start..i].to_vec(),
                input[i..i + eol].to_vec(),
                out.len() as u64 + 1,
                start as u64,
            ));
            i += eol;
            start = i;
        } else {
            i += 1;
        }
    }
    if start < input.len() {
        out.push((input[start..].to_vec(), Vec::new(), out.len() as u64 + 1, start as u64));
    }
    out
}

/// Every line of `input` read in pieces of `step` bytes, with lines longer than `max_line`
/// put together from their pieces (which must be what [`Part`] says).
fn read_all(input: &[u8], step: usize, max_line: usize) -> Vec<(Vec<u8>, Vec<u8>, u64, u64)> {
    let mut r = LineReader::new(Trickle(input, step));
    r.max_line = max_line;
    let mut got: Vec<(Vec<u8>, Vec<u8>, u64, u64)> = Vec::new();
    let mut open = false;
    while let Some(l) = r.next_line().unwrap() {
        assert!(l.with_lookahead().len() >= l.bytes.len() + LOOKAHEAD);
        let (bytes, eol) = (l.bytes.to_vec(), l.eol.to_vec());
        if open {
            let last = got.last_mut().unwrap();
            assert_eq!(last.2, l.number);
            last.0.extend_from_slice(&bytes);
            last.1 = eol;
        } else {
            got.push((bytes, eol, l.number, l.offset));
        }
        match l.part {
            Part::Whole => assert!(l.bytes.len() <= max_line && !open),
            Part::Piece => assert!(l.eol.is_empty()),
            Part::Last { len } => assert_eq!(got.last().unwrap().0.len() as u64, len),
        }
        open = l.part == Part::Piece;
    }
    assert!(!open);
    got
}

proptest::proptest! {
    /// The line reader gives every line with its ending as written, numbered and placed,
    /// however the input arrives: lines short enough for its first look for the end and
    /// longer ones, ends falling at the edge of what has been read so far.
    #[test]
    fn lines_come_whole_in_any_pieces(
        lines in proptest::collection::vec(("[ -~]{0,70}", 0..4u8), 0..60),
        last_eol in proptest::bool::ANY,
        step in 1usize..80,
    ) {
        let input = joined(&lines, last_eol);
        proptest::prop_assert_eq!(read_all(&input, step, MAX_LINE), reference_lines(&input));
    }

    /// Any bytes, cut into lines and joined again with their endings, give the input back;
    /// the lines are the reference splitter's in any pieces, however long.
    #[test]
    fn any_bytes_split_into_lines_and_rejoined_give_the_input_back(
        lines in proptest::collection::vec((proptest::collection::vec(proptest::num::u8::ANY, 0..120), 0..4u8), 0..12),
        step in 1usize..50,
        // The first look for a line's end takes a line of up to 32 bytes whole.
        max_line in 32usize..100,
    ) {
        let input: Vec<u8> = lines.into_iter().flat_map(|(bytes, eol)| [bytes, joined(&[(String::new(), eol)], true)].concat()).collect();
        proptest::prop_assume!(refuse_utf16(&input).is_ok());
        let got = read_all(&input, step, max_line);
        let rejoined: Vec<u8> = got.iter().flat_map(|l| [&l.0[..], &l.1[..]].concat()).collect();
        proptest::prop_assert_eq!(&rejoined, &input);
        proptest::prop_assert_eq!(got, reference_lines(&input));
    }

    /// Chunks give the lines, numbers and offsets of the line reader, each with its
    /// look-ahead bytes, for any input read in any pieces.
    #[test]
    fn chunks_give_the_same_lines(
        lines in proptest::collection::vec(("[ -~]{0,40}", 0..4u8), 0..60),
        last_eol in proptest::bool::ANY,
        step in 1usize..50,
    ) {
        let input = joined(&lines, last_eol);
        let want = reference_lines(&input);
        let mut got = Vec::new();
        let mut chunks = ChunkReader::new(Trickle(&input, step));
        let mut buf = Vec::new();
        let mut number = 0;
        while let Some(chunk) = chunks.next_chunk(std::mem::take(&mut buf)).unwrap() {
            let mut lines = chunk.lines(number);
            while let Some(l) = lines.next_line() {
                // What follows the line ending may differ (the next line, or zeros at a chunk's end).
                let ahead = l.with_lookahead();
                proptest::prop_assert!(ahead.len() >= l.bytes.len() + LOOKAHEAD);
                let whole = [l.bytes, l.eol].concat();
                proptest::prop_assert_eq!(&ahead[..whole.len()], whole.as_slice());
                got.push((l.bytes.to_vec(), l.eol.to_vec(), l.number, l.offset));
            }
            number = lines.number();
            buf = chunk.into_buffer();
        }
        proptest::prop_assert_eq!(got, want);
    }

    /// Passing over a line known from elsewhere (`skip_line`, its length taken from the
    /// reference) leaves the reader where reading it would: the lines after it are the
    /// reference's, numbered and placed alike, in any pieces. A line not ended by `\n` (a lone
    /// `\r`, the last without one) or not all read yet is not passed over, and is read.
    #[test]
    fn skipping_a_known_line_reads_on_as_reading_it(
        lines in proptest::collection::vec(("[ -~]{0,40}", 0..4u8), 0..60),
        last_eol in proptest::bool::ANY,
        skip in proptest::collection::vec(proptest::bool::ANY, 60),
        step in 1usize..50,
    ) {
        let input = joined(&lines, last_eol);
        let want = reference_lines(&input);
        let mut r = LineReader::new(Trickle(&input, step));
        let mut got = Vec::new();
        for (i, line) in want.iter().enumerate() {
            let len = line.0.len() + line.1.len();
            let passable = line.1.ends_with(b"\n") && r.unread().len() >= len;
            if skip[i % skip.len()] && r.skip_line(len) {
                proptest::prop_assert!(passable);
                got.push(line.clone());
                continue;
            }
            proptest::prop_assert!(!skip[i % skip.len()] || !passable);
            let l = r.next_line().unwrap().unwrap();
            got.push((l.bytes.to_vec(), l.eol.to_vec(), l.number, l.offset));
        }
        proptest::prop_assert!(r.next_line().unwrap().is_none());
        proptest::prop_assert_eq!(got, want);
    }
}

#[test]
fn a_line_of_zeros_is_read_in_bounded_memory() {
    // Three chunks of NUL bytes, split by a `\r\n` across a read, then a short line.
    let mut input = vec![0u8; CHUNK * 3 + 7];
    input.extend_from_slice(b"\r\nG1\r");
    for step in [CHUNK * 3 + 8, 4096, CHUNK] {
        let mut r = LineReader::new(Trickle(&input, step));
        let (mut pieces, mut total) = (0, 0);
        loop {
            let l = r.next_line().unwrap().unwrap();
            assert_eq!((l.number, l.offset), (1, total as u64));
            total += l.bytes.len();
            assert!(l.bytes.iter().all(|&b| b == 0));
            if let Part::Last { len } = l.part {
                assert_eq!((len, l.eol), ((CHUNK * 3 + 7) as u64, &b"\r\n"[..]));
                break;
            }
            pieces += 1;
        }
        assert!(pieces >= 3, "step {step}: {pieces} pieces");
        let l = r.next_line().unwrap().unwrap();
        assert_eq!((l.bytes, l.eol, l.number, l.part), (&b"G1"[..], &b"\r"[..], 2, Part::Whole));
        assert!(r.next_line().unwrap().is_none());
        assert_eq!(r.buf.len(), CHUNK + PAD, "the buffer grew");
    }
}

#[test]
fn a_long_line_is_skipped_by_chunks_without_holding_it() {
    for ending in [&b"\n"[..], b"\r\n", b"\r", b""] {
        let mut input = b"G1\n".to_vec();
        input.extend(std::iter::repeat_n(b'x', CHUNK * 3 + 7));
        input.extend_from_slice(ending);
        input.extend_from_slice(b"G2");
        let mut chunks = ChunkReader::new(&input[..]);
        let mut got = Vec::new();
        let (mut buf, mut number) = (Vec::new(), 0);
        while let Some(chunk) = chunks.next_chunk(std::mem::take(&mut buf)).unwrap() {
            assert!(chunk.buf.capacity() <= 2 * CHUNK + MAX_LINE, "{}", chunk.buf.capacity());
            let mut lines = chunk.lines(number);
            while let Some(l) = lines.next_line() {
                got.push((l.bytes.to_vec(), l.eol.to_vec(), l.number, l.offset, l.part));
            }
            number = lines.number();
            buf = chunk.into_buffer();
        }
        let long = Part::Last { len: (CHUNK * 3 + 7) as u64 };
        let mut want =
            vec![(b"G1".to_vec(), b"\n".to_vec(), 1, 0, Part::Whole), (vec![], ending.to_vec(), 2, 3, long)];
        if !ending.is_empty() {
            want.push((b"G2".to_vec(), vec![], 3, (input.len() - 2) as u64, Part::Whole));
        } else {
            // No ending: `G2` is the end of the long line.
            want[1].4 = Part::Last { len: (CHUNK * 3 + 9) as u64 };
        }
        assert_eq!(got, want, "ending {ending:?}");
    }
}

#[test]
fn a_utf16_file_is_refused_by_both_readers() {
    let utf16: Vec<u8> = "G1 X1\n".encode_utf16().flat_map(u16::to_le_bytes).collect();
    let mut r = LineReader::new(Trickle(&utf16, 1));
    assert!(r.next_line().unwrap_err().to_string().starts_with("UTF-16 text (little-endian)"));
    let err = ChunkReader::new(&utf16[..]).next_chunk(Vec::new()).unwrap_err();
    assert!(err.to_string().starts_with("UTF-16 text (little-endian)"));
}
