//! Post-processing passes that rewrite a sliced file for a particular machine: for hardware the
//! slicer does not know. Every pass streams through [`crate::pass::Pass`]: lines it does not
//! deliberately change are copied byte for byte, new lines use the configured
//! `crate::gcode::number::NumberFormat` and the file's own line endings.

// purge-shift: move colour changes earlier so the purge prints inside the part.
pub mod purge_shift;

// mix: colours for a mixing hotend (virtual tools, layer schedules, gradients, tool maps,
// purges at each change of mix, built on `crate::colour`), the park-purge-return block
// (state-correct in M82 and M83) and a Z feed-rate cap (split or slow).
pub mod mix;
pub(crate) mod purge_block;
pub mod zcap;

// metadata: the slicer's figures rewritten for the file as written, and the run's header.
pub mod metadata;

// What the transforms warn about, typed.
pub mod warning;
