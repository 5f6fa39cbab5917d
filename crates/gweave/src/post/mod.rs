//! Post-processors: passes that rewrite a slicer's G-code for hardware the slicer does not know.
//!
//! - [`mix`]: colours for a mixing hotend (virtual tools, layer schedules, gradients, tool maps,
//!   purges at each change of mix), built on [`crate::colour`].
//! - [`purge_block`]: the park-purge-return sequence, state-correct in M82 and M83.
//! - [`zcap`]: a Z feed-rate limit, by splitting or slowing moves.
//!
//! Every pass streams through [`crate::pass::Pass`]: lines it does not deliberately change are
//! copied byte for byte, new lines use the configured [`crate::gcode::number::NumberFormat`] and
//! the file's own line endings.

pub mod mix;
pub mod purge_block;
pub mod zcap;
