//! Post-processing passes that rewrite a sliced file for a particular machine.

// purge-shift: move colour changes earlier so the purge prints inside the part.
pub mod purge_shift;
