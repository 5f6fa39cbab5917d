//! Link.
pub mod pty;
pub mod serial;
pub mod tcp;
pub mod transport;
