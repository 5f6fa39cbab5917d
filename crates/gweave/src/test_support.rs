//! Fixtures the tests of this crate and of the crates above share, so that each is written once.
//! Built for tests only: `cfg(test)` here, the `test-support` feature in a dev-dependency.

use std::io::{Read, Write};
use std::path::Path;

use crate::gen::recoat::Recoat;
use crate::pass::{drive_reader, Reading};
use crate::run::IN_MEMORY;
use crate::{Pass, Result, State, StateOptions, Strictness};

/// A binder-jet recoat: the spreader on Y from -20 mm over 260 mm, the feed piston on A, the
/// build piston on Z, 1.5 times the layer's powder, half a second of settling.
pub fn recoat() -> Recoat {
    Recoat {
        spreader_axis: 'Y',
        spreader_start_mm: -20.0,
        spreader_stroke_mm: 260.0,
        spread_feed_mm_min: 300.0,
        return_feed_mm_min: 3000.0,
        piston_feed_mm_min: 120.0,
        feed_piston_axis: 'A',
        build_piston_axis: 'Z',
        powder_ratio: 1.5,
        dwell_s: 0.5,
    }
}

/// `input` read leniently through `pass` into `out`, with the machine `options` as given: the
/// entry of the fuzz harness and of the tests that hand the reader something [`crate::Run`] does
/// not read (bytes a few at a time, a reader that fails). Every other caller runs a pass through
/// [`crate::Run`], which opens the file, resolves its firmware and counts what it read past.
pub fn read_lenient<P: Pass + ?Sized>(
    input: impl Read,
    options: StateOptions,
    pass: &mut P,
    out: &mut dyn Write,
) -> Result<State> {
    let reading = Reading { options, strictness: Strictness::Lenient, ..Reading::new(Path::new(IN_MEMORY)) };
    drive_reader(input, reading, pass, out)
}
