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
    let cura: String = text.lines().filter_map(|l| l.strip_prefix(";SETTING_3 ")).collect();
    let cura = cura.replace("\\\\n", "\n").replace("\\n", "\n");
    let comments = text.lines().filter_map(|l| l.trim().strip_prefix(';'));
    let mut found = BTreeMap::new();
    for line in comments.chain(cura.lines()) {
        let Some((k, v)) = line.split_once('=') else { continue };
        if let Some(key) = keys.iter().find(|key| **key == k.trim()) {
            found.insert(*key, v.trim().trim_end_matches(['"', '}', ',']).trim().to_owned());
        }
    }
    found
}
