//! The two ends of a file, where slicers put their settings: Cura in its header and `;SETTING_3`
//! footer, the PrusaSlicer family in the settings block after the last move. Reading only those
//! keeps a settings lookup (`estimate --machine slicer`, `check`'s bed, the metadata a transform
//! rewrites) bounded whatever the file's size. The text is read through its container
//! ([`container::ends`]), so a `.gcode.gz` or `.bgcode` file is read as the text it holds.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io;
use std::path::Path;

use crate::gcode::container;

/// Bytes read from the start of a file.
pub const HEAD_BYTES: usize = 64 * 1024;
/// Bytes read from its end.
pub const TAIL_BYTES: usize = 256 * 1024;

/// The first [`HEAD_BYTES`] and the last [`TAIL_BYTES`] of a file's text (all of a smaller
/// one), joined by a newline.
pub fn read_ends(path: &Path) -> io::Result<Vec<u8>> {
    let (mut head, tail) = container::ends(path, HEAD_BYTES, TAIL_BYTES)?;
    if !tail.is_empty() {
        head.push(b'\n');
        head.extend_from_slice(&tail);
    }
    Ok(head)
}

/// A file's ends ([`read_ends`]) as text. They are ASCII but where a cut splits a character, so
/// the fast check comes first: the lossy conversion walks them character by character (about 7
/// instructions a byte, 2 M for a file's ends, read several times per run).
pub fn ends_text(ends: &[u8]) -> Cow<'_, str> {
    match std::str::from_utf8(ends) {
        Ok(text) => Cow::Borrowed(text),
        Err(_) => String::from_utf8_lossy(ends),
    }
}

/// The slicer settings `keys` in `text` (a file's ends, [`read_ends`]): `; key = value` comment
/// lines (the PrusaSlicer family, Cura start G-code) and Cura's `;SETTING_3` document, whose
/// lines are joined and its escaped newlines undone. The last value of a key wins, as the
/// footer comes after the header.
pub(crate) fn settings<'k>(text: &str, keys: &[&'k str]) -> BTreeMap<&'k str, String> {
    // Only the lines that name a key are looked at ([`lines_naming`]).
    settings_in(lines_naming(text, &[";SETTING_3 "]), lines_naming(text, keys), keys)
}

/// The settings `keys` in Cura's `;SETTING_3` lines `cura` and the comment lines `comments`
/// (lines that may hold other things too: each is read for `; key = value`).
fn settings_in<'t, 'k>(
    cura: impl Iterator<Item = &'t str>,
    comments: impl Iterator<Item = &'t str>,
    keys: &[&'k str],
) -> BTreeMap<&'k str, String> {
    let cura: String = cura.filter_map(|l| l.strip_prefix(";SETTING_3 ")).collect();
    let cura = cura.replace("\\\\n", "\n").replace("\\n", "\n");
    let comments = comments.filter_map(|l| l.trim().strip_prefix(';'));
    let mut found = BTreeMap::new();
    for line in comments.chain(cura.lines()) {
        let Some((k, v)) = line.split_once('=') else { continue };
        if let Some(key) = keys.iter().find(|key| **key == k.trim()) {
            found.insert(*key, v.trim().trim_end_matches(['"', '}', ',']).trim().to_owned());
        }
    }
    found
}

/// The lines of `text` (as [`str::lines`] cuts them) that hold one of `needles`, each once, in
/// the file's order: the lines a settings lookup needs, found by a vector search rather than by
/// walking, trimming and splitting every line of a file's ends (some 13 000 lines, about 250
/// instructions each, read a few times a run). Each needle's search skips to the end of the
/// line it found, so the work is one pass of the text per needle.
pub fn lines_naming<'t>(text: &'t str, needles: &[&str]) -> impl Iterator<Item = &'t str> {
    let bytes = text.as_bytes();
    let mut lines = Vec::new();
    for needle in needles {
        let finder = memchr::memmem::Finder::new(needle);
        let mut from = 0;
        while let Some(at) = finder.find(&bytes[from..]).map(|i| from + i) {
            let start = memchr::memrchr(b'\n', &bytes[..at]).map_or(0, |i| i + 1);
            let end = memchr::memchr(b'\n', &bytes[at..]).map_or(bytes.len(), |i| at + i);
            lines.push((start, end));
            from = end;
        }
    }
    lines.sort_unstable();
    lines.dedup();
    lines.into_iter().map(move |(start, end)| {
        // `\r\n` ends a line as `\n` does; a `\r` at the text's very end stays, as in `lines`.
        let end = if end < bytes.len() && end > start && bytes[end - 1] == b'\r' { end - 1 } else { end };
        // Cut at `\n` and `\r` bytes, which are whole characters.
        &text[start..end]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lookup as it was: every line of the ends walked, trimmed and split.
    fn every_line<'k>(text: &str, keys: &[&'k str]) -> BTreeMap<&'k str, String> {
        settings_in(text.lines(), text.lines(), keys)
    }

    /// Regression (issue 35): a settings lookup walked every line of the ends (purge-shift's
    /// wipe-tower check: 6 M instructions a run). Looking only at the lines naming a key gives
    /// what every line gave: lines cut as `str::lines` cuts them (`\r\n`, a last line without
    /// its newline), a key found twice on a line or in another key's value, the last value
    /// winning, Cura's `;SETTING_3` lines joined whole; and every fixture's ends.
    #[test]
    fn the_lines_naming_a_key_give_every_lines_settings() {
        let keys = ["wipe_tower", "bed_shape", "machine_width", "prime_tower_enable"];
        let edges = "; wipe_tower = 0\r\n;wipe_tower=1 ; wipe_tower = 2\n; bed_shape = 0x0,250x0\r\n\
                     G1 X1 ; wipe_tower = 3\n  ;  bed_shape =  1x1 \n; wipe_tower_x = 4\n\
                     ;SETTING_3 {\"global\": \"[values]\\\\nmachine_width = 2\r\n\
                     ;SETTING_3 20\\\\nprime_tower_enable = True\\\\n\"}\n; wipe_tower = 5\r";
        assert_eq!(settings(edges, &keys), every_line(edges, &keys));
        let expected = [("bed_shape", "1x1"), ("machine_width", "220"), ("prime_tower_enable", "True")];
        let found = settings(edges, &keys);
        assert_eq!(found.get("wipe_tower").map(String::as_str), Some("5"), "{found:?}");
        for (key, value) in expected {
            assert_eq!(found.get(key).map(String::as_str), Some(value), "{key}: {found:?}");
        }
        let lines: Vec<&str> = lines_naming("a\r\nb x\r\nx\n\nx y x\r", &["x", "y"]).collect();
        assert_eq!(lines, ["b x", "x", "x y x\r"]);
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
        let mut read = 0;
        for kind in std::fs::read_dir(data).unwrap() {
            for file in std::fs::read_dir(kind.unwrap().path()).into_iter().flatten() {
                let path = file.unwrap().path();
                if path.extension().is_some_and(|e| e == "gcode") {
                    let ends = read_ends(&path).unwrap();
                    let text = ends_text(&ends);
                    let keys = [&keys[..], &["gcode_flavor", "machine_max_feedrate_x", "bed_shape"]].concat();
                    assert_eq!(settings(&text, &keys), every_line(&text, &keys), "{}", path.display());
                    read += usize::from(!settings(&text, &keys).is_empty());
                }
            }
        }
        assert!(read >= 8, "{read} fixtures with settings");
    }
}
