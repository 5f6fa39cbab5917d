//! The two ends of a file, where slicers put their settings: Cura in its header and `;SETTING_3`
//! footer, the PrusaSlicer family in the settings block after the last move. Reading only those
//! keeps a settings lookup (`estimate --machine slicer`, `check`'s bed, the metadata a transform
//! rewrites) bounded whatever the file's size. The text is read through its container
//! ([`container::ends`]), so a `.gcode.gz` or `.bgcode` file is read as the text it holds.

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
