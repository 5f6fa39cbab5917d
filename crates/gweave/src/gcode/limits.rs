//! Limits on what a line may say, shared by the lexer's diagnostics and the machine state.

/// Tools a file may select: `T<n>` for larger `n` names no tool (firmware answers "Invalid
/// extruder") and leaves the current one selected, so per-tool tables stay small.
pub const MAX_TOOLS: u32 = 256;
