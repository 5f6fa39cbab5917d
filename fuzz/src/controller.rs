//! The controller core's targets: any bytes, as a host (or line noise) may send them to the
//! board's serial port.
//! - `controller_reader`: the line reader, the line-number and checksum checks and the word
//!   parser. Every line is kept within its bound, then checked and parsed or refused; every
//!   number read is finite.
//! - `controller`: the whole controller on a bench that polls it and steps its interrupt for a
//!   bounded time. Never a panic; every reply is a whole line of printable ASCII within the
//!   reply buffer's size.

use gweave_controller::gcode::words::Words;
use gweave_controller::limits::MAX_LINE;
use gweave_controller::serial::out::MAX_REPLY;
use gweave_controller::serial::protocol;
use gweave_controller::serial::reader::LineReader;
use gweave_controller::{Controller, Inputs, Io, Settings, StepQueue, Stepper};

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

/// The replies of the board.
struct Board(Vec<u8>);

impl Io for Board {
    fn send(&mut self, bytes: &[u8]) {
        self.0.extend_from_slice(bytes);
    }
}

/// Room temperature on a type 1 thermistor.
const ADC_20_C: u16 = 986;

/// Feeds `bytes` to a controller, polling it every millisecond of board time and stepping its
/// interrupt meanwhile, for at most 2 s of board time after the last byte (every endstop reads
/// triggered, so homing ends at once).
pub fn controller(bytes: &[u8]) {
    let queue = StepQueue::new();
    let mut c = Controller::new(&queue, Settings::DEFAULT);
    let mut stepper = Stepper::new(&queue);
    let mut board = Board(Vec::new());
    let mut now_ms = 0;
    let inputs = |now_ms| Inputs { now_ms, adc: [ADC_20_C; 3], endstops: 0b111 };
    c.boot(&mut board, &inputs(0));
    let mut turn = |c: &mut Controller, board: &mut Board, now_ms: &mut u32| {
        *now_ms += 1;
        c.poll(board, &inputs(*now_ms));
        // About a millisecond of steps.
        let mut ticks = 0u32;
        while ticks < 2000 {
            ticks += u32::from(stepper.tick(0b111).interval_ticks).max(1);
        }
    };
    for &b in bytes {
        while !c.receive(b) {
            turn(&mut c, &mut board, &mut now_ms);
        }
    }
    for _ in 0..2000 {
        turn(&mut c, &mut board, &mut now_ms);
    }
    let replies = board.0;
    assert!(replies.is_empty() || replies.ends_with(b"\n"), "a reply left unterminated");
    for reply in replies.split(|&b| b == b'\n') {
        assert!(reply.len() <= MAX_REPLY, "a reply past its buffer");
        assert!(
            reply.iter().all(|b| (0x20..0x7F).contains(b)),
            "a reply with a byte not printable: {reply:?}"
        );
    }
}
