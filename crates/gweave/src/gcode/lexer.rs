//! Turns the bytes of one line into a [`Block`]: one pass, no allocation, never panics.
//!
//! The grammar is what real files contain, not only what the RS-274 standard allows:
//! `[/] [N<int>] [command] {word | (comment)} [*<checksum>] [;comment]`, where a command is
//! `G`/`M`/`T`/`D` plus an integer (with an optional `.sub`), or a Klipper/RepRapFirmware name
//! (`SET_VELOCITY_LIMIT ACCEL=3000`, `echo`, `EXCLUDE_OBJECT_DEFINE ...`) whose arguments are kept
//! as text. Words may be glued (`G1X10Y-2.5E.4`), lower case, signed, start with a point, hold a
//! quoted string (`P"text"`) or an `{expression}`. String commands (`M117 text`, `M23 name.gcode`)
//! keep their argument as text. A malformed word becomes a diagnostic and parsing goes on.

use super::axes::axis_of;
use super::diag::{Diagnostic, Finding, Severity};
use super::line::{Block, Checksum, Command, PlainMove, Span, Value, Word};
use super::number::{scan_at, scan_before_space, NumberError};
use super::reader::RawLine;

const UTF8_BOM: &[u8] = b"\xef\xbb\xbf";

/// M-codes whose argument is free text up to the comment (Marlin reads it as a string).
fn takes_text(number: u32) -> bool {
    matches!(number, 0 | 1 | 23 | 28 | 30 | 32 | 33 | 117 | 118 | 928)
}

#[inline]
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\x0b' | b'\x0c')
}

#[inline]
fn skip_space(raw: &[u8], mut i: usize) -> usize {
    while i < raw.len() && is_space(raw[i]) {
        i += 1;
    }
    i
}

/// Parses `raw` (one line without its line ending) into `block`, replacing what it held.
pub fn parse_into(raw: &[u8], block: &mut Block) {
    parse_ahead::<true>(raw, raw, block);
}

/// [`parse_into`] for a line from a [`LineReader`](super::reader::LineReader): the bytes it can
/// read past the line let numbers be loaded eight bytes at a time up to the line's end.
#[inline]
pub fn parse_line(line: &RawLine<'_>, block: &mut Block) {
    parse_ahead::<true>(line.bytes, line.with_lookahead(), block);
    if line.eol.is_empty() {
        mark_truncated(block);
    }
}

/// [`parse_line`] for a reader that takes a plain move's numbers from [`Block::plain`] alone:
/// the words of such a line (`G0`/`G1` with X, Y, Z, E and F numbers) are not listed in
/// [`Block::words`], which saves writing them out, word by word, on most lines of a print.
/// Every other line is parsed in full.
#[inline]
pub fn parse_line_lean(line: &RawLine<'_>, block: &mut Block) {
    parse_ahead::<false>(line.bytes, line.with_lookahead(), block);
    if line.eol.is_empty() {
        mark_truncated(block);
    }
}

/// A line without a line ending is the file's last. Many files end so, and that alone is fine;
/// but a last line that is also malformed (`G1 X113.115 Y`, `G1 X1 (comm`) is what a copy or an
/// upload cut short leaves: its first error says so ([`Finding::Truncated`]), and a strict run
/// stops there with it.
#[cold]
#[inline(never)]
pub(crate) fn mark_truncated(block: &mut Block) {
    if let Some(d) = block.diagnostics.iter_mut().find(|d| d.finding.severity() == Severity::Error) {
        let cause = std::mem::replace(&mut d.finding, Finding::MoreFindings { count: 0 });
        d.finding = Finding::Truncated { cause: Box::new(cause) };
    }
}

/// Parses `raw`; `ahead` is `raw` followed by any bytes that may be read past it, the first of
/// which (if any) is not part of a number. `LIST_WORDS`: a plain move's words are listed in
/// [`Block::words`] too.
#[inline(always)]
fn parse_ahead<const LIST_WORDS: bool>(raw: &[u8], ahead: &[u8], block: &mut Block) {
    block.clear();
    if !plain_motion::<LIST_WORDS>(raw, ahead, block) {
        parse_general(raw, block);
    }
}

/// The whole grammar, for every line [`plain_motion`] leaves.
fn parse_general(raw: &[u8], block: &mut Block) {
    // The fast path may have pushed words before it met something it does not take.
    block.clear();
    // A UTF-8 byte order mark (at the start of a file) is no part of the line.
    let mut i = skip_space(raw, if raw.starts_with(UTF8_BOM) { UTF8_BOM.len() } else { 0 });
    if raw.get(i) == Some(&b'/') {
        block.block_delete = true;
        i = skip_space(raw, i + 1);
    }
    if raw.get(i) == Some(&b'%') {
        block.tape_marker = true;
        return;
    }
    if matches!(raw.get(i), Some(b'N' | b'n'))
        && raw.get(i + 1).is_some_and(|b| b.is_ascii_digit() || *b == b'-')
    {
        i = line_number(raw, i, block);
    }
    i = skip_space(raw, i);
    i = command(raw, i, block);
    words(raw, i, block);
}

/// Most lines of a print are a plain move: `G0` or `G1`, then X, Y, Z, E and F words with
/// numbers, one or more spaces before each, nothing else (`G1 X142.303 Y175.183 E2.43766`).
/// This reads exactly those in one tight pass and gives the same block the general grammar
/// would; `false` means the line is something else (a comment, a glued or lower-case word, a
/// malformed number...) and the general lexer reads it from the start.
#[inline(always)]
fn plain_motion<const LIST_WORDS: bool>(raw: &[u8], ahead: &[u8], block: &mut Block) -> bool {
    let Block { plain, words, .. } = block;
    if !plain_words(raw, ahead, plain, |word| {
        if LIST_WORDS {
            words.push(word);
        }
    }) {
        return false;
    }
    let number = u32::from(!block.plain.rapid);
    block.command = Command::Code { letter: b'G', number, sub: None };
    block.command_span = Span::new(0, 2);
    true
}

/// A plain move's words into `plain` (each also given to `word`, in written order), as
/// [`plain_motion`] takes them; `false` for any other line, with `plain` half written.
#[inline(always)]
fn plain_words(raw: &[u8], ahead: &[u8], plain: &mut PlainMove, mut word: impl FnMut(Word)) -> bool {
    plain.rapid = match raw {
        [b'G', b'0', ..] => true,
        [b'G', b'1', ..] => false,
        _ => return false,
    };
    let mut i = 2;
    while let Some(&b) = raw.get(i) {
        // Spaces, then a letter; anything else (a tab, a comment, a sign or a second point glued
        // to the last number) takes the general way.
        if b != b' ' {
            return false;
        }
        i += 1;
        while raw.get(i) == Some(&b' ') {
            i += 1;
        }
        let Some(&letter) = raw.get(i) else { break };
        let Some(index) = PlainMove::index_of(letter) else { return false };
        // Read from `ahead`: the number still ends at the end of `raw`, whose next byte is no
        // part of one. What follows it is tested as the loop goes on.
        let Ok((value, end)) = scan_before_space(ahead, i + 1) else { return false };
        debug_assert!(end <= raw.len());
        word(Word { letter, value: Value::Number(value), span: Span::new(i, end) });
        plain.values[index] = value;
        plain.present |= 1 << index;
        i = end;
    }
    true
}

/// A whole line from a [`LineReader`](super::reader::LineReader) read as a plain move with at
/// least one word (`G0`/`G1` with X, Y, Z, E and F numbers, nothing else), its numbers into
/// `plain`, without a [`Block`]: for a reader that needs those numbers alone, and reads every
/// other line with [`parse_line`] (`false`, `plain` then meaning nothing). The numbers, to
/// the bit, and the lines taken are those of the lexer's own fast path, which this is.
#[inline(always)]
pub fn read_plain_move(line: &RawLine<'_>, plain: &mut PlainMove) -> bool {
    plain.present = 0;
    plain_words(line.bytes, line.with_lookahead(), plain, |_| {}) && plain.present != 0
}

fn line_number(raw: &[u8], start: usize, block: &mut Block) -> usize {
    let mut i = start + 1;
    let negative = raw.get(i) == Some(&b'-');
    if negative {
        i += 1;
    }
    let digits_start = i;
    let mut n: i64 = 0;
    while i < raw.len() && raw[i].is_ascii_digit() {
        n = n.saturating_mul(10).saturating_add(i64::from(raw[i] - b'0'));
        i += 1;
    }
    if i == digits_start || raw.get(i) == Some(&b'.') {
        block.diagnose(Diagnostic::at(start, Finding::BadLineNumber));
    }
    block.line_number = Some((if negative { -n } else { n }, Span::new(start, i)));
    i
}

/// Reads the command, if the line has one, and returns where its arguments start.
fn command(raw: &[u8], start: usize, block: &mut Block) -> usize {
    let Some(&first) = raw.get(start) else {
        return start;
    };
    if !first.is_ascii_alphabetic() {
        return start;
    }
    let letter = first.to_ascii_uppercase();
    let next = raw.get(start + 1).copied();
    if matches!(letter, b'G' | b'M' | b'T' | b'D') && next.is_some_and(|b| b.is_ascii_digit()) {
        let mut i = start + 1;
        let mut number: u32 = 0;
        while i < raw.len() && raw[i].is_ascii_digit() {
            number = number.saturating_mul(10).saturating_add(u32::from(raw[i] - b'0'));
            i += 1;
        }
        let mut sub = None;
        if raw.get(i) == Some(&b'.') && raw.get(i + 1).is_some_and(|b| b.is_ascii_digit()) {
            let mut s: u32 = 0;
            i += 1;
            while i < raw.len() && raw[i].is_ascii_digit() {
                s = s.saturating_mul(10).saturating_add(u32::from(raw[i] - b'0'));
                i += 1;
            }
            sub = Some(s);
        }
        block.command = Command::Code { letter, number, sub };
        block.command_span = Span::new(start, i);
        if letter == b'M' && sub.is_none() && takes_text(number) {
            text_argument(raw, i, block);
            return raw.len();
        }
        return i;
    }
    // An extended command: a name of two or more identifier characters whose second character is
    // not part of a number (so `X10` and `E-2` stay words).
    if next.is_some_and(|b| b.is_ascii_alphabetic() || b == b'_') {
        let mut i = start;
        while i < raw.len() && (raw[i].is_ascii_alphanumeric() || raw[i] == b'_') {
            i += 1;
        }
        block.command = Command::Extended;
        block.command_span = Span::new(start, i);
        text_argument(raw, i, block);
        return raw.len();
    }
    start
}

/// Keeps everything from `start` to the comment or checksum as the line's text argument.
fn text_argument(raw: &[u8], start: usize, block: &mut Block) {
    let begin = skip_space(raw, start);
    let mut end = raw.len();
    if let Some(semi) = memchr::memchr(b';', &raw[begin..]) {
        end = begin + semi;
        block.comment = Some(Span::new(end + 1, raw.len()));
    }
    if block.line_number.is_some() {
        if let Some(star) = memchr::memrchr(b'*', &raw[begin..end]) {
            let star = begin + star;
            checksum(raw, star, end, block);
            end = star;
        }
    }
    while end > begin && is_space(raw[end - 1]) {
        end -= 1;
    }
    if end > begin {
        block.text = Some(Span::new(begin, end));
    }
}

/// Reads `*<digits>` at `star` (digits end before `limit`) and checks the XOR of what precedes it.
fn checksum(raw: &[u8], star: usize, limit: usize, block: &mut Block) -> usize {
    let mut i = star + 1;
    let mut given: u32 = 0;
    while i < limit && raw[i].is_ascii_digit() {
        given = given.saturating_mul(10).saturating_add(u32::from(raw[i] - b'0'));
        i += 1;
    }
    let end = i;
    if end == star + 1 || skip_space(raw, end) < limit {
        block.diagnose(Diagnostic::at(star, Finding::BadChecksum));
    }
    let computed = raw[..star].iter().fold(0u8, |acc, b| acc ^ b);
    let sum = Checksum { given, computed, span: Span::new(star, end) };
    if !sum.is_valid() {
        block.diagnose(Diagnostic::at(star, Finding::ChecksumMismatch { given, computed }));
    }
    block.checksum = Some(sum);
    end
}

fn words(raw: &[u8], mut i: usize, block: &mut Block) {
    while let Some(&b) = raw.get(i) {
        // A letter starts nearly every token here: test for it first, with one comparison.
        if (b | 0x20).wrapping_sub(b'a') < 26 {
            i = word(raw, i, block);
            continue;
        }
        match b {
            _ if is_space(b) => i += 1,
            b';' => {
                block.comment = Some(Span::new(i + 1, raw.len()));
                return;
            }
            b'(' => match memchr::memchr(b')', &raw[i..]) {
                Some(close) => i += close + 1,
                None => {
                    block.diagnose(Diagnostic::at(i, Finding::UnclosedComment));
                    return;
                }
            },
            b'*' => {
                let limit = memchr::memchr(b';', &raw[i..]).map_or(raw.len(), |p| i + p);
                i = checksum(raw, i, limit, block);
                i = skip_space(raw, i);
                if i < limit {
                    i = limit;
                }
            }
            _ => {
                block.diagnose(Diagnostic::at(i, Finding::UnexpectedByte { byte: b }));
                i = junk_end(raw, i + 1);
            }
        }
    }
}

/// The end of a run of bytes that start no token, from `at`: a stray byte and the digits after
/// it (`X1\0375`, a NUL in a number) are one finding, not one per byte; the next letter, space,
/// comment or checksum starts the next token.
fn junk_end(raw: &[u8], mut at: usize) -> usize {
    while at < raw.len()
        && !raw[at].is_ascii_alphabetic()
        && !is_space(raw[at])
        && !matches!(raw[at], b';' | b'(' | b'*')
    {
        at += 1;
    }
    at
}

/// The end of the token at `at`: a bad token is skipped whole, so that its pieces do not read as
/// more words.
fn token_end(raw: &[u8], mut at: usize) -> usize {
    while at < raw.len() && !is_space(raw[at]) && !matches!(raw[at], b';' | b'(' | b'*') {
        at += 1;
    }
    at
}

/// The end of a RepRapFirmware colon list whose first colon is at `colon`: each colon must be
/// followed by a number (`E0.3:` or `E0.3:x` is malformed).
fn colon_list_end(raw: &[u8], mut colon: usize, letter: u8, block: &mut Block) -> usize {
    while raw.get(colon) == Some(&b':') {
        match scan_at(raw, colon + 1) {
            Ok((_, end)) => colon = end,
            Err(_) => {
                block
                    .diagnose(Diagnostic::at(colon + 1, Finding::MalformedNumber { letter: letter as char }));
                return token_end(raw, colon + 1);
            }
        }
    }
    colon
}

/// Reads one word at `start` (a letter) and returns the index after it.
#[inline(always)]
fn word(raw: &[u8], start: usize, block: &mut Block) -> usize {
    let letter = raw[start] & !0x20;
    let at = start + 1;
    let (value, end) = match raw.get(at) {
        Some(b'"') => quoted(raw, at, block),
        Some(b'{') => expression(raw, at, block),
        _ => match scan_at(raw, at) {
            // RepRapFirmware gives a list as numbers joined by colons (`M567 P0 E0.3:0.7`): the
            // word's value is the first, its span the whole list (`colour::dialect` reads it).
            Ok((v, end)) if raw.get(end) == Some(&b':') => {
                (Value::Number(v), colon_list_end(raw, end, letter, block))
            }
            Ok((v, end)) if raw.get(end).is_some_and(|&b| b | 0x20 == b'e') => {
                exponent(raw, start, end, block);
                (Value::Number(v), end)
            }
            Ok((v, end)) => (Value::Number(v), end),
            Err(NumberError::Empty) => {
                missing_value(letter, start, block);
                (Value::Empty, at)
            }
            Err(e) => {
                let finding = match e {
                    NumberError::NotFinite => Finding::NotFinite { letter: letter as char },
                    _ => Finding::MalformedNumber { letter: letter as char },
                };
                block.diagnose(Diagnostic::at(at, finding));
                (Value::Invalid, token_end(raw, at))
            }
        },
    };
    block.push_word(Word { letter, value, span: Span::new(start, end) });
    end
}

/// A number glued to an `e` and an exponent's digits (`F1e300`, `X1.5E-05`), at `start`, its
/// number ending at `e_at`. G-code has no exponent notation, and firmware disagree on it: Marlin
/// reads a number up to the `E` (`parser.h`, `value_float`) and takes `E300` as the next word
/// when the `E` is upper case or its lower-case G-code option is on (off by default: then the
/// `e300` is ignored); Klipper upper-cases the line and reads `F1 E300` too; RepRapFirmware's
/// number reader takes the exponent, `1e300`. gweave reads `F1 E300`, as Marlin and Klipper,
/// and says so. A lower-case `e` after an upper-case letter is what `printf`'s `%g` or Python's
/// `str` writes into a template, never a slicer: an error (the 274 mm extrusion of `F1e300`
/// stops a strict run). The same case as the letter (`X10E5`, `x10e5`) may be words written
/// without spaces, which firmware takes as two: a warning.
#[cold]
#[inline(never)]
fn exponent(raw: &[u8], start: usize, e_at: usize, block: &mut Block) {
    let mut digits_at = e_at + 1;
    if matches!(raw.get(digits_at), Some(b'+' | b'-')) {
        digits_at += 1;
    }
    if !raw.get(digits_at).is_some_and(u8::is_ascii_digit) {
        return;
    }
    let end = digits_at + raw[digits_at..].iter().take_while(|b| b.is_ascii_digit()).count();
    let word = String::from_utf8_lossy(&raw[start..end]).into();
    block.diagnose(Diagnostic::at(start, Finding::ExponentNotation { word }));
}

/// A word without a number (`G1 X113.115 Y`, a line cut short): on a move an error, whatever the
/// firmware makes of it (Marlin ignores the word, Klipper refuses the move, others read 0 and
/// move there); elsewhere (`G28 X`, `M84 E`) a letter alone is how commands take an axis.
#[cold]
#[inline(never)]
fn missing_value(letter: u8, start: usize, block: &mut Block) {
    let is_move = match block.command {
        Command::Code { letter: b'G', number, .. } => number <= 3,
        Command::None => true,
        _ => false,
    };
    if is_move && (axis_of(letter).is_some() || matches!(letter, b'F' | b'I' | b'J' | b'R')) {
        block.diagnose(Diagnostic::at(start, Finding::MissingValue { letter: letter as char }));
    }
}

/// A RepRapFirmware string: `"..."`, with `""` standing for one quote.
fn quoted(raw: &[u8], open: usize, block: &mut Block) -> (Value, usize) {
    let mut i = open + 1;
    while i < raw.len() {
        if raw[i] == b'"' {
            if raw.get(i + 1) == Some(&b'"') {
                i += 2;
                continue;
            }
            return (Value::Text(Span::new(open + 1, i)), i + 1);
        }
        i += 1;
    }
    block.diagnose(Diagnostic::at(open, Finding::UnclosedString));
    (Value::Invalid, raw.len())
}

/// A RepRapFirmware `{expression}`, braces nested.
fn expression(raw: &[u8], open: usize, block: &mut Block) -> (Value, usize) {
    let mut depth = 0usize;
    for (i, &b) in raw.iter().enumerate().skip(open) {
        match b {
            b'{' => depth += 1,
            b'}' => {
                depth -= 1;
                if depth == 0 {
                    return (Value::Expr(Span::new(open, i + 1)), i + 1);
                }
            }
            _ => {}
        }
    }
    block.diagnose(Diagnostic::at(open, Finding::UnclosedExpression));
    (Value::Invalid, raw.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::diag::MAX_LINE_DIAGNOSTICS;

    fn parse(s: &str) -> Block {
        let mut b = Block::default();
        parse_into(s.as_bytes(), &mut b);
        b
    }

    #[test]
    fn glued_words_lower_case_and_points() {
        let b = parse("g1x10Y-2.5E.4 f1800");
        assert!(b.command.is_g(1));
        assert_eq!(b.get(b'X'), Some(10.0));
        assert_eq!(b.get(b'Y'), Some(-2.5));
        assert_eq!(b.get(b'E'), Some(0.4));
        assert_eq!(b.get(b'F'), Some(1800.0));
        assert!(b.diagnostics.is_empty());
    }

    #[test]
    fn comments_of_both_kinds() {
        let raw = "G1 (move) X1 ; to the left";
        let b = parse(raw);
        assert_eq!(b.get(b'X'), Some(1.0));
        assert_eq!(b.comment_text(raw.as_bytes()), Some(&b" to the left"[..]));
        assert_eq!(parse("G1 (oops X1").diagnostics[0].finding, Finding::UnclosedComment);
    }

    #[test]
    fn line_numbers_and_checksums() {
        let b = parse("N0 M110 N0*125");
        assert_eq!(b.line_number.map(|n| n.0), Some(0));
        assert!(b.command.is_m(110));
        assert!(b.checksum.unwrap().is_valid());
        assert_eq!(b.get(b'N'), Some(0.0));
        let b = parse("N1 G28*18");
        assert!(b.checksum.unwrap().is_valid(), "{:?}", b);
        let b = parse("N1 G28*19");
        assert_eq!(b.diagnostics[0].finding, Finding::ChecksumMismatch { given: 19, computed: 18 });
        assert_eq!(b.diagnostics[0].column, 7);
    }

    #[test]
    fn string_commands_keep_their_text() {
        let raw = "M117 Printing 50% X1 ; done";
        let b = parse(raw);
        assert!(b.command.is_m(117));
        assert_eq!(b.text_of(raw.as_bytes()), Some(&b"Printing 50% X1"[..]));
        assert!(b.words.is_empty());
        let raw = "N5 M23 cube.gcode*57";
        let b = parse(raw);
        assert_eq!(b.text_of(raw.as_bytes()), Some(&b"cube.gcode"[..]));
        assert!(b.checksum.is_some());
    }

    /// Regression (rrf_colon_lists_are_malformed): `gweave mix` writes RepRapFirmware's
    /// `M567 P0 E0.3:0.7`, and `check`, `stats` and a strict `purge-shift` refused its own output
    /// ("unexpected character ':'").
    #[test]
    fn rrf_colon_lists_are_one_word() {
        let raw = "M567 P0 E0:0.1717:0.8283:0 ; mix";
        let b = parse(raw);
        assert!(b.diagnostics.is_empty(), "{:?}", b.diagnostics);
        let e = b.word(b'E').unwrap();
        assert_eq!(e.value, Value::Number(0.0));
        assert_eq!(e.span.of(raw.as_bytes()), b"E0:0.1717:0.8283:0");
        assert!(b.comment.is_some());
        for bad in ["M567 P0 E0.3:", "M567 P0 E0.3:x", "M567 P0 E0.3::0.7"] {
            let b = parse(bad);
            assert_eq!(b.diagnostics.len(), 1, "{bad}: {:?}", b.diagnostics);
            assert!(matches!(b.diagnostics[0].finding, Finding::MalformedNumber { letter: 'E' }), "{bad}");
        }
    }

    #[test]
    fn reprap_strings_and_expressions() {
        let raw = r#"M291 P"Insert ""red"" filament" S2 X{move.axes[0].max - 5}"#;
        let b = parse(raw);
        assert!(b.command.is_m(291));
        match b.word(b'P').unwrap().value {
            Value::Text(s) => assert_eq!(s.of(raw.as_bytes()), br#"Insert ""red"" filament"#),
            v => panic!("{v:?}"),
        }
        assert_eq!(b.get(b'S'), Some(2.0));
        assert!(matches!(b.word(b'X').unwrap().value, Value::Expr(_)));
        assert!(b.diagnostics.is_empty());
    }

    #[test]
    fn klipper_extended_commands() {
        let raw = "EXCLUDE_OBJECT_DEFINE NAME=a POLYGON=[[1,2],[3,4]] ; obj";
        let b = parse(raw);
        assert_eq!(b.command, Command::Extended);
        assert_eq!(b.command_span.of(raw.as_bytes()), b"EXCLUDE_OBJECT_DEFINE");
        assert_eq!(b.text_of(raw.as_bytes()), Some(&b"NAME=a POLYGON=[[1,2],[3,4]]"[..]));
        let b = parse("SET_VELOCITY_LIMIT ACCEL=3000");
        assert_eq!(b.command, Command::Extended);
    }

    #[test]
    fn malformed_words_are_diagnostics() {
        let b = parse("G1 X1..2 Y3");
        assert_eq!(
            b.diagnostics[0],
            Diagnostic { column: 5, finding: Finding::MalformedNumber { letter: 'X' } }
        );
        assert_eq!(b.get(b'Y'), Some(3.0));
        assert_eq!(b.word(b'X').unwrap().value, Value::Invalid);
        let b = parse("G1 XNaN Yinf");
        assert_eq!(b.diagnostics.len(), 2);
        assert_eq!(b.diagnostics[1].finding, Finding::NotFinite { letter: 'Y' });
        let b = parse("G28 X Y");
        assert_eq!(b.word(b'X').unwrap().value, Value::Empty);
        assert!(b.diagnostics.is_empty());
    }

    #[test]
    fn a_line_of_malformed_tokens_keeps_a_few_findings_and_a_count() {
        let b = parse(&"\0 ".repeat(100_000));
        assert_eq!(b.diagnostics.len(), MAX_LINE_DIAGNOSTICS + 1);
        assert_eq!(b.diagnostics[0], Diagnostic::at(0, Finding::UnexpectedByte { byte: 0 }));
        assert_eq!(b.diagnostics[1], Diagnostic::at(2, Finding::UnexpectedByte { byte: 0 }));
        let more = &b.diagnostics[MAX_LINE_DIAGNOSTICS];
        assert_eq!(more.finding, Finding::MoreFindings { count: 100_000 - MAX_LINE_DIAGNOSTICS as u32 });
        assert_eq!(more.finding.to_string(), "99984 more findings on this line");
    }

    /// Regression (check_counts_one_nul_as_7_errors): a NUL in a number (`X1\042.303`, a byte
    /// lost in transfer) was one finding for the NUL and one for each byte after it.
    #[test]
    fn one_nul_in_a_number_is_one_finding() {
        let b = parse("G1 X1\x0042.303 Y2 E.5");
        assert_eq!(b.diagnostics, [Diagnostic::at(5, Finding::UnexpectedByte { byte: 0 })]);
        assert_eq!((b.get(b'X'), b.get(b'Y'), b.get(b'E')), (Some(1.0), Some(2.0), Some(0.5)));
        // A run of stray bytes glued to the next word leaves that word readable.
        let b = parse("G1 X1\0\x01-7Y2");
        assert_eq!(b.diagnostics.len(), 1);
        assert_eq!(b.get(b'Y'), Some(2.0));
    }

    /// Regression (exponent_notation_extrudes_300_mm): `G1 F1e300` was read as `F1 E300` without
    /// a word of it. It still is (as Marlin and Klipper read it), with an error at the word.
    #[test]
    fn exponent_notation_is_read_as_firmware_does_and_reported() {
        let b = parse("G1 F1e300");
        assert_eq!((b.get(b'F'), b.get(b'E')), (Some(1.0), Some(300.0)));
        let finding = Finding::ExponentNotation { word: "F1e300".into() };
        assert_eq!(b.diagnostics, [Diagnostic::at(3, finding.clone())]);
        assert_eq!(finding.severity(), Severity::Error);
        assert_eq!(
            finding.to_string(),
            "'F1e300' is exponent notation, which G-code does not have: read as F1 and E300, \
             as Marlin and Klipper do (RepRapFirmware reads one number)"
        );
        // Python's str(0.00001): a 5 mm retraction on Marlin.
        let b = parse("G1 X1e-05 Y2");
        assert_eq!((b.get(b'X'), b.get(b'E'), b.get(b'Y')), (Some(1.0), Some(-5.0), Some(2.0)));
        assert_eq!(b.diagnostics[0].finding, Finding::ExponentNotation { word: "X1e-05".into() });
        // Words without spaces, one case: maybe meant as two words; a warning.
        for (raw, word) in [("G1X10E5", "X10E5"), ("g1x1.5e+2", "x1.5e+2")] {
            let b = parse(raw);
            let finding = Finding::ExponentNotation { word: word.into() };
            assert_eq!(b.diagnostics.iter().map(|d| &d.finding).collect::<Vec<_>>(), [&finding], "{raw}");
            assert_eq!(finding.severity(), Severity::Warning);
        }
        // An `E` word glued to a number, not followed by digits: no exponent.
        for raw in ["G1 X10E.4", "G1 X-2.5E", "G1 X1 E2"] {
            assert!(
                !parse(raw).diagnostics.iter().any(|d| matches!(d.finding, Finding::ExponentNotation { .. })),
                "{raw}"
            );
        }
    }

    /// Regression (truncated_file_passes_every_command): a word without a number on a move is an
    /// error from the lexer, so strict transforms stop at it, not only `check`.
    #[test]
    fn a_motion_word_without_a_number_is_an_error() {
        for (raw, column, letter) in
            [("G1 X113.115 Y", 13, 'Y'), ("G0 F", 4, 'F'), ("X", 1, 'X'), ("G2 X1 I", 7, 'I')]
        {
            let b = parse(raw);
            assert_eq!(
                b.diagnostics,
                [Diagnostic { column, finding: Finding::MissingValue { letter } }],
                "{raw}"
            );
        }
        // Elsewhere a letter alone names an axis.
        for raw in ["G28 X Y", "M84 E", "G92 E", "M18 X"] {
            assert!(parse(raw).diagnostics.is_empty(), "{raw}");
        }
    }

    /// Regression (truncated_file_passes_every_command): the last line of a file, cut mid-word
    /// and without a line ending, says the file looks truncated; a good last line without one
    /// (as some slicers end) and a malformed line with one do not.
    #[test]
    fn a_malformed_last_line_without_an_ending_looks_truncated() {
        let block_of_last = |text: &str| {
            let mut reader = crate::gcode::reader::LineReader::new(text.as_bytes());
            let mut block = Block::default();
            while let Some(line) = reader.next_line().unwrap() {
                parse_line_lean(&line, &mut block);
            }
            block
        };
        let b = block_of_last("G28\nG1 X113.115 Y");
        let cause = Box::new(Finding::MissingValue { letter: 'Y' });
        assert_eq!(b.diagnostics, [Diagnostic { column: 13, finding: Finding::Truncated { cause } }]);
        assert_eq!(
            b.diagnostics[0].finding.to_string(),
            "the file looks truncated (its last line is malformed and has no line ending): 'Y' has no number"
        );
        assert!(matches!(block_of_last("G1 X1 (a comm").diagnostics[0].finding, Finding::Truncated { .. }));
        assert!(block_of_last("G28\nG1 X113.115 Y2").diagnostics.is_empty());
        assert_eq!(block_of_last("G1 X1 Y\n").diagnostics[0].finding, Finding::MissingValue { letter: 'Y' });
    }

    #[test]
    fn a_utf8_bom_is_skipped() {
        let b = parse("\u{feff}G1 X10 ; first");
        assert!(b.diagnostics.is_empty(), "{:?}", b.diagnostics);
        assert_eq!(
            (b.command, b.get(b'X')),
            (Command::Code { letter: b'G', number: 1, sub: None }, Some(10.0))
        );
    }

    #[test]
    fn subcodes_block_delete_and_tape() {
        let b = parse("/G29.1 S1");
        assert!(b.block_delete);
        assert_eq!(b.command, Command::Code { letter: b'G', number: 29, sub: Some(1) });
        assert!(parse("%").tape_marker);
        assert_eq!(parse("T2").command.tool(), Some(2));
    }

    #[test]
    fn odd_bytes_never_panic() {
        let b = parse("G1 X1 \u{00e9}\u{0000}\u{00ff}");
        assert!(!b.diagnostics.is_empty());
        assert_eq!(b.get(b'X'), Some(1.0));
    }

    /// What the general grammar alone makes of `raw`.
    fn general(raw: &[u8]) -> Block {
        let mut b = Block::default();
        parse_general(raw, &mut b);
        b
    }

    /// The block the fast path read, as the general grammar would give it: its words by letter
    /// ([`PlainMove`]) checked against its words (the last of a letter wins, a letter absent
    /// has no bit), then set aside, since only the fast path fills them.
    fn as_general(fast: &Block) -> String {
        for (i, &letter) in PlainMove::LETTERS.iter().enumerate() {
            let by_letter = (fast.plain.present >> i & 1 != 0).then_some(fast.plain.values[i]);
            assert_eq!(by_letter.map(f64::to_bits), fast.get(letter).map(f64::to_bits), "{}", letter as char);
        }
        let mut b = fast.clone();
        b.plain = PlainMove::default();
        format!("{b:?}")
    }

    #[test]
    fn plain_moves_take_the_fast_path_and_others_do_not() {
        for raw in ["G1 X142.303 Y175.183 E2.43766", "G0  F9000 X1 ", "G1 E-.8 F2100", "G1"] {
            let mut b = Block::default();
            assert!(plain_motion::<true>(raw.as_bytes(), raw.as_bytes(), &mut b), "{raw}");
            assert_eq!(as_general(&b), format!("{:?}", general(raw.as_bytes())), "{raw}");
        }
        for raw in ["G1X1", "G1 x1", "G1 X1 ; c", "G10", "G1 I1", "G1 X1..2", "G1\tX1", " G1 X1", "G1 X"] {
            assert!(!plain_motion::<true>(raw.as_bytes(), raw.as_bytes(), &mut Block::default()), "{raw}");
        }
    }

    /// `G<g>` followed by each word as (letter, number, the gap before it).
    fn motion_line(g: u8, words: &[(String, String, String)]) -> String {
        let mut raw = format!("G{g}");
        for (letter, number, gap) in words {
            raw.push_str(gap);
            raw.push_str(letter);
            raw.push_str(number);
        }
        raw
    }

    proptest::proptest! {
        /// The fast path and the general grammar agree on every line the fast path accepts,
        /// numbers of every length and position in the line included.
        #[test]
        fn plain_motion_agrees_with_the_general_grammar(
            g in 0u8..2,
            words in proptest::collection::vec(("[XYZEFIx]", "-?[0-9]{0,9}(\\.[0-9]{0,9})?[.+-]?", " {1,2}"), 0..6),
        ) {
            let raw = motion_line(g, &words);
            let mut fast = Block::default();
            fast.clear();
            if plain_motion::<true>(raw.as_bytes(), raw.as_bytes(), &mut fast) {
                proptest::prop_assert_eq!(as_general(&fast), format!("{:?}", general(raw.as_bytes())));
            }
        }

        /// A line from the reader is read as the same line alone: digits after its ending (the
        /// next line, in the reader's buffer) never join its last number.
        #[test]
        fn what_follows_a_line_is_not_read(
            g in 0u8..2,
            words in proptest::collection::vec(("[XYZEFIx]", "-?[0-9]{0,9}(\\.[0-9]{0,9})?[.+-]?", " {1,2}"), 0..6),
            eol in "(\r?\n)?",
            next in "[0-9.+-]{0,12}",
        ) {
            let raw = motion_line(g, &words);
            let text = format!("{raw}{eol}{next}");
            let mut reader = crate::gcode::reader::LineReader::new(text.as_bytes());
            let line = reader.next_line().unwrap().unwrap();
            let (mut from_reader, mut alone) = (Block::default(), Block::default());
            parse_line(&line, &mut from_reader);
            parse_into(line.bytes, &mut alone);
            if line.eol.is_empty() {
                mark_truncated(&mut alone);
            }
            proptest::prop_assert_eq!(format!("{from_reader:?}"), format!("{alone:?}"));
        }

        /// Every line of the plain shape does take the fast path (so the test above is not
        /// passed by a fast path that refuses everything), with the general grammar's block.
        #[test]
        fn plain_lines_always_take_the_fast_path(
            g in 0u8..2,
            words in proptest::collection::vec(("[XYZEF]", "-?[0-9]{1,9}(\\.[0-9]{1,6})?", " {1,2}"), 0..6),
        ) {
            let raw = motion_line(g, &words);
            let mut fast = Block::default();
            proptest::prop_assert!(plain_motion::<true>(raw.as_bytes(), raw.as_bytes(), &mut fast), "{}", raw);
            proptest::prop_assert_eq!(fast.words.len(), words.len());
            proptest::prop_assert_eq!(as_general(&fast), format!("{:?}", general(raw.as_bytes())));
        }

        #[test]
        fn never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..200)) {
            let mut b = Block::default();
            parse_into(&bytes, &mut b);
            for w in &b.words {
                proptest::prop_assert!(w.span.end as usize <= bytes.len());
            }
        }
    }
}
