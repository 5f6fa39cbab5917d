//! G-code syntax: numbers ([`number`]) and the words of one line ([`words`]). What the words
//! mean is the [`crate::machine`]'s business.

pub mod number;
pub mod words;
