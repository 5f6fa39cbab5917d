//! The controller core's targets: any bytes, as a host (or line noise) may send them to the
//! board's serial port.
//! - `controller_reader`: the line reader, the line-number and checksum checks and the word
//!   parser. Every line is kept within its bound, then checked and parsed or refused; every
//!   number read is finite.
//! - `controller`: the whole controller on its twin (`gweave_controller::twin`), polled and
//!   stepped for a bounded time. Never a panic; every reply is a whole line of printable ASCII within the
//!   reply buffer's size.

use gweave_controller::gcode::words::Words;
use gweave_controller::limits::MAX_LINE;
use gweave_controller::serial::out::MAX_REPLY;
use gweave_controller::serial::protocol;
use gweave_controller::serial::reader::LineReader;
use gweave_controller::twin::{FirstOrder, Twin};
use gweave_controller::{Settings, StepQueue};

/// Reads `bytes` into lines, checks and parses each.
pub fn controller_reader(bytes: &[u8]) {
    let mut reader = LineReader::new();
    let mut last = 0;
    let mut take = |reader: &mut LineReader| {
        while let Some(line) = reader.pop() {
            assert!(line.bytes().len() <= MAX_LINE, "a line past its bound");
            if let Ok(checked) = protocol::check(line.bytes(), last) {
                last = checked.number.unwrap_or(last);
                if let Ok(words) = Words::parse(checked.body) {
                    for letter in b'A'..=b'Z' {
                        if let Some(value) = words.get(letter) {
                            assert!(value.is_finite(), "{} not finite", letter as char);
                        }
                    }
                }
            }
        }
    };
    for &b in bytes.iter().chain(b"\n") {
        while !reader.push(b) {
            take(&mut reader);
        }
    }
    take(&mut reader);
}

/// Feeds `bytes` to a controller on the twin (every endstop triggered where the axes start, so
/// homing ends at once), then runs it for 2 s of board time.
pub fn controller(bytes: &[u8]) {
    let queue = StepQueue::new();
    let mut twin = Twin::new(&queue, Settings::DEFAULT, FirstOrder::default());
    twin.endstop_steps = [0; 3];
    twin.send(bytes);
    twin.run_ms(2000);
    let replies = &twin.memory.sent;
    assert!(replies.is_empty() || replies.ends_with(b"\n"), "a reply left unterminated");
    for reply in replies.split(|&b| b == b'\n') {
        assert!(reply.len() <= MAX_REPLY, "a reply past its buffer");
        assert!(
            reply.iter().all(|b| (0x20..0x7F).contains(b)),
            "a reply with a byte not printable: {reply:?}"
        );
    }
}
