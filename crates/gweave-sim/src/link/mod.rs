//! Link: the board's serial line to a host, as Marlin's `gcode/queue.cpp` and
//! `core/serial.h` speak it (line numbers, checksums, `ok`, `Resend:`, `busy:` keepalives).
//!
//! The protocol itself ([`serial`]) is transport-free: bytes in, timed reply lines out, tested
//! over in-memory pipes. [`transport`] runs it in real time over an endpoint: a pseudo-terminal
//! ([`pty`]) that looks like a USB serial port, or a loopback TCP socket ([`tcp`]) as network
//! printers and OctoPrint's `socket://` URLs use.
pub(crate) mod assembly;
pub(crate) mod early;
pub(crate) mod pty;
pub(crate) mod serial;
pub(crate) mod tcp;
pub(crate) mod transport;
