//! The G-code core: syntax (lexer, line), streaming I/O (reader, writer), and meaning (state,
//! layers, arc). Syntax and meaning are kept apart: the lexer records what was written, with
//! spans; the state is a layer above it.

pub mod arc;
pub mod axes;
pub mod codes;
pub mod container;
pub mod diag;
pub mod effect;
pub(crate) mod encoding;
pub mod ends;
pub mod flavour;
pub mod layers;
pub mod lexed;
pub mod lexer;
pub(crate) mod limits;
pub mod line;
pub(crate) mod number;
pub mod reader;
// The retraction in force, followed alike by `stats` and the passes that insert purges.
pub mod retraction;
pub mod scratch;
pub mod state;
pub mod temp;
pub(crate) mod wipe_tower;
pub mod writer;
