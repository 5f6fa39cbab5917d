//! The two ends of a file, where slicers put their settings: Cura in its header and `;SETTING_3`
//! footer, the PrusaSlicer family in the settings block after the last move. Reading only those
//! keeps a settings lookup (`estimate --machine slicer`, `check`'s bed) bounded whatever the
//! file's size.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;

/// Bytes read from the start of a file.
pub const HEAD_BYTES: u64 = 64 * 1024;
/// Bytes read from its end.
pub const TAIL_BYTES: u64 = 256 * 1024;

/// The first [`HEAD_BYTES`] and the last [`TAIL_BYTES`] of a file (all of a smaller one),
/// joined by a newline.
pub fn read_ends(path: &Path) -> io::Result<Vec<u8>> {
    let mut file = File::open(path)?;
    let len = file.metadata()?.len();
    let mut buf = Vec::new();
    (&mut file).take(HEAD_BYTES).read_to_end(&mut buf)?;
    let tail_start = len.saturating_sub(TAIL_BYTES).max(buf.len() as u64);
    if tail_start < len {
        buf.push(b'\n');
        file.seek(SeekFrom::Start(tail_start))?;
        file.take(TAIL_BYTES).read_to_end(&mut buf)?;
    }
    Ok(buf)
}
