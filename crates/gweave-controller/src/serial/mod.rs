//! The serial line: the commands that act at once ([`emergency`]), bytes into lines
//! ([`reader`]), Marlin's line numbers and checksums ([`protocol`]), and reply lines with numbers
//! written by hand ([`out`]).

pub mod emergency;
pub mod out;
pub mod protocol;
pub mod reader;
