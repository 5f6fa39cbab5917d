//! The Marlin host protocol, transport-free: bytes from the host go in, reply lines come out.
//!
//! A host (Printrun, OctoPrint, Repetier) talks to a Marlin board one line at a time and waits for
//! `ok` before it sends the next one ("ping-pong"). Lines may carry a line number and a checksum,
//! `N<n> <command>*<checksum>`, so that a byte lost or flipped on the wire is noticed and the line
//! is sent again. This module is that protocol, as Marlin's `GCodeQueue::get_serial_commands`
//! implements it (`MarlinFirmware/Marlin:Marlin/src/gcode/queue.cpp`, strings from
//! `Marlin/src/core/language.h`); the machine behind it is a [`Device`]. The pty and TCP
//! transports only move bytes ([`crate::link::transport`]), so everything here is tested over
//! in-memory buffers.
//!
//! Line assembly ([`crate::link::assembly`]), per byte: `\n` or `\r` ends a line; `;` starts a
//! comment that runs to the end of the line and is dropped before anything else looks at the
//! line; a line keeps at most [`MAX_LINE_BYTES`] bytes (Marlin's `MAX_CMD_SIZE` 96 less the
//! terminating NUL). An empty line or a comment-only line gets no reply at all, as in Marlin.
//!
//! A line whose first non-space byte is `N` is checked, in Marlin's order:
//! 1. the number after `N` (for a line containing `M110`, after the first `N` past its fourth
//!    byte, so `N0 M110 N0` reads 0) must be the last line number + 1, unless the line holds
//!    `M110`;
//! 2. the decimal after the last `*` must equal the XOR of every byte before that `*` (from the
//!    `N` on, comment already removed): `N1 G28*18`;
//! 3. there must be a `*` at all.
//!
//! A failed check replies, exactly as Marlin,
//! `Error:<what>, Last Line: <last>` then `Resend: <last + 1>` then `ok`, and does not execute
//! the line. A passed check makes the line the last line. Unnumbered lines are not checked.
//!
//! Two things differ from stock Marlin on purpose, and both are configurable
//! ([`ProtocolConfig`]):
//! - Duplicate lines. Stock Marlin answers a line number it has already executed with the
//!   line-number error and a resend request, which a host that streams ahead of the `ok`s can
//!   turn into a resend loop (Marlin PR #24972 describes it). Here a line whose number is one of
//!   the last [`ProtocolConfig::duplicate_window`] executed ones, with a valid checksum, is
//!   acknowledged with `ok` and not executed again. A window of 0 is stock Marlin.
//! - Overlong lines. Marlin silently drops the bytes past `MAX_CMD_SIZE` and runs what is left,
//!   which can turn `G1 X10 Y20` into `G1 X10 Y2`. Here an overlong line is never executed: it
//!   gets `Error:Line too long, Last Line: <last>` (plus `Resend:` if it was numbered) and `ok`.
//!
//! Replies carry the simulated time at which the firmware would print them. While one command
//! runs longer than the keepalive interval (2 s, Marlin's `DEFAULT_KEEPALIVE_INTERVAL`, set with
//! `M113 S<s>`), `echo:busy: processing` lines are interleaved at `start + 2 s`, `start + 4 s`,
//! ... strictly before the command's end, by simulated time (Marlin's `host_keepalive`, with
//! `BUSY_WHILE_HEATING` on as in its default configuration, so `M109` and `M190` waits count too).
//! After a command the protocol prints `ok` (unless the device printed its own, as `ok T:...`
//! for `M105`), also while the device is halted, so that the host can still send `M999`.
//!
//! `M110 N<n>` (numbered or not) and `M113 [S<s>]` are about the link, not the machine: their
//! rows in the command registry say so (`Link`, with `M113`'s range), the protocol answers them
//! itself and the device never sees them.
//!
//! A command that waits for the user (`M600`, [`Device::waiting_for_user`]) holds the queue: its
//! `ok` and the lines received after it wait (at most [`MAX_HELD_LINES`]), with
//! `echo:busy: paused for user` every keepalive interval of idle time, while the emergency
//! parser looks at every line at once ([`Device::emergency`]: `M108`, `M876 S<n>`, `M112`); when
//! the wait ends, the command finishes, prints its `ok`, and the held lines run in order.
//!
//! ```
//! use gweave_sim::{frame_line, Device, Outcome, Protocol, ProtocolConfig};
//!
//! /// A machine that does nothing, instantly.
//! struct Idle;
//! impl Device for Idle {
//!     fn boot_lines(&self) -> Vec<String> { vec!["start".into()] }
//!     fn execute(&mut self, _: &[u8], _: &mut dyn FnMut(f64, &str)) -> Outcome { Outcome::Ok }
//!     fn now_s(&self) -> f64 { 0.0 }
//! }
//!
//! let mut link = Protocol::new(Idle, ProtocolConfig::default());
//! let mut replies = Vec::new();
//! let mut out = |_t_s: f64, line: &str| replies.push(line.to_string());
//! link.boot(&mut out);
//! assert_eq!(frame_line(1, "G28"), "N1 G28*18");
//! link.feed(b"N0 M110 N0*125\nN1 G28*18\nN3 G28*16\n", &mut out);
//! assert_eq!(replies, [
//!     "start", "ok", "ok",
//!     "Error:Line Number is not Last Line Number+1, Last Line: 1", "Resend: 2", "ok",
//! ]);
//! ```

use gweave::gcode::lexer::parse_into;
use gweave::Block;

use crate::interp::{lookup, Link};
use crate::link::assembly::{command_body, urgent_text, Assembler, Scan};
use crate::link::early::EarlyLines;

/// The longest line Marlin keeps: `MAX_CMD_SIZE` (96) less the NUL terminator.
pub(crate) const MAX_LINE_BYTES: usize = 95;

/// Marlin's `DEFAULT_KEEPALIVE_INTERVAL`, seconds.
pub const DEFAULT_KEEPALIVE_S: u8 = 2;

/// Marlin's `M113` limit: `NOMORE(host_keepalive_interval, 60)`.
pub(crate) const MAX_KEEPALIVE_S: u8 = 60;

/// The machine behind the serial line: the interpreter, or a test double.
pub trait Device {
    /// What the firmware prints at power-on, `start` first.
    fn boot_lines(&self) -> Vec<String>;
    /// Runs one accepted command (comment, line number and checksum removed) and calls `out`
    /// with each reply line and the simulated time it is printed at. The final `ok` is the
    /// protocol's, unless [`Device::acknowledged`] says the device printed its own.
    fn execute(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) -> Outcome;
    /// The simulated clock, seconds since boot.
    fn now_s(&self) -> f64;
    /// Whether the last command's replies already included its `ok` (Marlin answers `M105` with
    /// one `ok T:...` line).
    fn acknowledged(&self) -> bool {
        false
    }
    /// Lets `t_s` seconds pass with no command waiting (the host is quiet), calling `out` with
    /// what the board prints meanwhile (auto-reports). By default the clock stands still.
    fn idle(&mut self, _t_s: f64, _out: &mut dyn FnMut(f64, &str)) {}
    /// Whether the last command is one a host times by the wall clock even when the board runs
    /// faster than real time (`M400`: OctoPrint's pause sends `M400` then queues `M114` once the
    /// `M400` is written; an `ok` that comes back before that finds an empty queue and the pause
    /// waits for a communication timeout). See [`Protocol::feed_held`].
    fn wall_timed(&self) -> bool {
        false
    }
    /// Whether the board has closed the serial link (the controller seed's `M0`): the transport
    /// hangs up on the host.
    fn link_closed(&self) -> bool {
        false
    }
    /// Whether the board has work of its own (an SD print) that runs while the host is quiet.
    fn has_own_work(&self) -> bool {
        false
    }
    /// Runs one step of the board's own work (one line of an SD print), with its replies.
    fn own_work(&mut self, _out: &mut dyn FnMut(f64, &str)) {}
    /// Whether the last command waits for the user to answer (`M600`): the protocol holds its
    /// `ok` and the lines after it until [`Device::emergency`] ends the wait.
    fn waiting_for_user(&self) -> bool {
        false
    }
    /// The emergency parser's look at a line the queue does not run now: one received while
    /// the board waits for the user, or one the protocol refused (too long, a broken checksum,
    /// out of order), whose bytes the parser read as they arrived.
    fn emergency(&mut self, _line: &[u8], _out: &mut dyn FnMut(f64, &str)) {}
    /// The rest of the command that waited for the user, once answered.
    fn finish_user_wait(&mut self, _out: &mut dyn FnMut(f64, &str)) {}
    /// Lines the host sends while a command runs will be put in `lines` as they arrive
    /// ([`EarlyLines`]), for the emergency parser to act on before the command ends. By
    /// default nobody listens.
    fn listen(&mut self, _lines: EarlyLines) {}
}

pub(crate) use crate::interp::Outcome;

/// The protocol's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProtocolConfig {
    /// Seconds between `echo:busy: processing` lines during one long command; 0 turns them off.
    pub keepalive_s: u8,
    /// How many of the most recently executed line numbers are acknowledged without running
    /// again when they arrive a second time (with a valid checksum); 0 behaves as stock Marlin.
    /// The default, 4, is Marlin's command queue length `BUFSIZE`: a host that streams ahead
    /// cannot have more lines in flight than that.
    pub duplicate_window: u32,
}

impl Default for ProtocolConfig {
    fn default() -> Self {
        ProtocolConfig { keepalive_s: DEFAULT_KEEPALIVE_S, duplicate_window: 4 }
    }
}

/// Why a line was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LineError {
    /// `N` is not the last line number + 1.
    LineNumber,
    /// The `*` checksum is not the XOR of the bytes before it.
    ChecksumMismatch,
    /// A numbered line without `*`.
    NoChecksum,
    /// More than [`MAX_LINE_BYTES`] bytes before the comment.
    TooLong,
}

impl LineError {
    /// The text after `Error:` and before the last line number (Marlin's `STR_ERR_*`).
    pub(crate) fn message(self) -> &'static str {
        match self {
            LineError::LineNumber => "Line Number is not Last Line Number+1, Last Line: ",
            LineError::ChecksumMismatch => "checksum mismatch, Last Line: ",
            LineError::NoChecksum => "No Checksum with line number, Last Line: ",
            LineError::TooLong => "Line too long, Last Line: ",
        }
    }
}

/// Counts of what went over the link, for the transport's summary and for tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkStats {
    /// Non-empty lines received.
    pub lines: u64,
    /// Lines the device ran.
    pub executed: u64,
    /// Lines refused with `Resend:` or an error.
    pub errors: u64,
    /// Repeated line numbers acknowledged without running.
    pub duplicates: u64,
    /// `echo:busy: processing` lines printed.
    pub busy: u64,
}

/// What the line-number check decided.
enum Verdict {
    Accept(i64),
    Duplicate,
    Refuse(LineError),
}

/// The protocol state for one connection to one device.
pub struct Protocol<D> {
    device: D,
    config: ProtocolConfig,
    assembler: Assembler,
    /// Marlin's `last_N`: the last line number accepted (or set by M110).
    last_n: i64,
    halted: bool,
    stats: LinkStats,
    block: Block,
    /// A command waits for the user (`M600`) since this simulated time; its `ok` waits too.
    user_wait: Option<f64>,
    next_paused_busy_s: f64,
    /// Lines received while a command waits for the user, at most [`MAX_HELD_LINES`].
    waiting_lines: std::collections::VecDeque<(Vec<u8>, Scan)>,
}

/// Lines a board keeps while its queue is held (Marlin's `BUFSIZE` 4 plus a serial receive
/// buffer of 128 bytes hold fewer); a host that keeps sending past this loses the rest.
pub(crate) const MAX_HELD_LINES: usize = 16;

impl<D: Device> Protocol<D> {
    /// The protocol in front of `device`.
    pub fn new(device: D, config: ProtocolConfig) -> Self {
        Protocol {
            device,
            config,
            assembler: Assembler::new(),
            last_n: 0,
            halted: false,
            stats: LinkStats::default(),
            block: Block::default(),
            user_wait: None,
            next_paused_busy_s: 0.0,
            waiting_lines: std::collections::VecDeque::new(),
        }
    }

    /// Prints the device's boot lines (`start`, ...).
    pub fn boot(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let t_s = self.device.now_s();
        for line in self.device.boot_lines() {
            out(t_s, &line);
        }
    }

    /// Takes bytes from the host, in any chunking, and answers every line they complete.
    pub fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(f64, &str)) {
        self.feed_held(bytes, out, &mut |_, _| {});
    }

    /// [`Protocol::feed`], calling `hold(start_s, end_s)` before the `ok` of a command the host
    /// times by the wall clock ([`Device::wall_timed`]), so that a transport running faster than
    /// real time can hold that `ok` back for the command's simulated duration.
    pub fn feed_held(
        &mut self,
        bytes: &[u8],
        out: &mut dyn FnMut(f64, &str),
        hold: &mut dyn FnMut(f64, f64),
    ) {
        for &b in bytes {
            if self.assembler.push(b) {
                self.end_line(out, hold);
            }
        }
    }

    /// The device behind the protocol.
    pub fn device(&self) -> &D {
        &self.device
    }

    /// Lines the host sends while a command runs reach the device through `lines`
    /// ([`Device::listen`]).
    pub fn listen(&mut self, lines: EarlyLines) {
        self.device.listen(lines);
    }

    /// The host has been quiet for `t_s` seconds: the board lives them ([`Device::idle`]). A
    /// half-received line stays as it is.
    pub fn idle(&mut self, t_s: f64, out: &mut dyn FnMut(f64, &str)) {
        self.device.idle(t_s, out);
        // Marlin's keepalive while a command waits for the user (`PAUSED_FOR_USER`).
        if self.user_wait.is_some() && self.config.keepalive_s > 0 {
            let now_s = self.device.now_s();
            while self.next_paused_busy_s <= now_s {
                out(self.next_paused_busy_s, "echo:busy: paused for user");
                self.stats.busy += 1;
                self.next_paused_busy_s += f64::from(self.config.keepalive_s);
            }
        }
    }

    /// Whether a command holds the queue waiting for the user (`M600`).
    pub fn waiting_for_user(&self) -> bool {
        self.user_wait.is_some()
    }

    /// Whether the board has work of its own to do ([`Device::has_own_work`]).
    pub fn has_own_work(&self) -> bool {
        self.device.has_own_work()
    }

    /// Runs one step of the board's own work ([`Device::own_work`]).
    pub fn own_work(&mut self, out: &mut dyn FnMut(f64, &str)) {
        self.device.own_work(out);
    }

    /// Gives the device back, for a report after the session.
    pub fn into_device(self) -> D {
        self.device
    }

    /// The last accepted line number (Marlin's `last_N`).
    pub fn last_line_number(&self) -> i64 {
        self.last_n
    }

    /// Whether the last command left the device halted.
    pub fn is_halted(&self) -> bool {
        self.halted
    }

    /// What went over the link so far.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// The protocol's settings.
    pub fn config(&self) -> ProtocolConfig {
        self.config
    }

    fn end_line(&mut self, out: &mut dyn FnMut(f64, &str), hold: &mut dyn FnMut(f64, f64)) {
        let scan = self.assembler.scan;
        // A line of nothing but blanks (after its comment is gone) is an empty line.
        if self.assembler.line.iter().all(u8::is_ascii_whitespace) {
            self.assembler.restart();
            return;
        }
        if self.user_wait.is_some() {
            self.during_user_wait(scan, out, hold);
            return;
        }
        let line = std::mem::take(&mut self.assembler.line);
        self.accept(&line, scan, out, hold);
        // Give the buffer back so that assembling lines allocates nothing in the long run.
        self.assembler.line = line;
        self.assembler.restart();
    }

    /// A line that arrives while a command waits for the user (`M600`): the command queue is
    /// held, so the line waits its turn, but the emergency parser sees it at once (`M108` or
    /// `M876` end the wait). Once the wait ends, the command finishes with its `ok` and the held
    /// lines run in order.
    fn during_user_wait(
        &mut self,
        scan: Scan,
        out: &mut dyn FnMut(f64, &str),
        hold: &mut dyn FnMut(f64, f64),
    ) {
        let line = std::mem::take(&mut self.assembler.line);
        self.assembler.restart();
        self.device.emergency(urgent_text(&line), out);
        // A full receive buffer loses what does not fit, as a board's does.
        if self.waiting_lines.len() < MAX_HELD_LINES {
            self.waiting_lines.push_back((line, scan));
        }
        if !self.device.waiting_for_user() {
            self.end_user_wait(out, hold);
        }
    }

    /// The user answered: the waiting command finishes, then the lines held meanwhile run.
    fn end_user_wait(&mut self, out: &mut dyn FnMut(f64, &str), hold: &mut dyn FnMut(f64, f64)) {
        let Some(start_s) = self.user_wait.take() else { return };
        let mut keepalive = Keepalive::new(start_s, self.config.keepalive_s);
        keepalive.next_s = self.device.now_s() + keepalive.interval_s;
        self.device.finish_user_wait(&mut |t_s, text| {
            keepalive.before(t_s, out);
            out(t_s, text);
        });
        out(self.device.now_s(), "ok");
        while self.user_wait.is_none() {
            let Some((line, scan)) = self.waiting_lines.pop_front() else { break };
            self.accept(&line, scan, out, hold);
        }
    }

    /// Checks a complete line and runs it, as Marlin's queue does.
    fn accept(
        &mut self,
        line: &[u8],
        scan: Scan,
        out: &mut dyn FnMut(f64, &str),
        hold: &mut dyn FnMut(f64, f64),
    ) {
        self.stats.lines += 1;
        // Marlin skips leading spaces (only spaces) before it looks for `N`.
        let start = line.iter().position(|&b| b != b' ').unwrap_or(line.len());
        let cmd = &line[start..];
        let numbered = cmd.first() == Some(&b'N');
        // A line the queue refuses was still read by the emergency parser, byte by byte as it
        // arrived, as Marlin's (`e_parser.h`) and gweave's firmware's read them: an `M112` too
        // long for the queue, or with a checksum the line noise broke, stops the board all the
        // same. (An accepted one runs as the command, to the same end.)
        let refused = |this: &mut Self, e: LineError, numbered: bool, out: &mut dyn FnMut(f64, &str)| {
            this.device.emergency(urgent_text(line), out);
            this.refuse(e, numbered, out);
        };
        if scan == Scan::Overflow {
            refused(self, LineError::TooLong, numbered, out);
        } else if !numbered {
            self.run(cmd, out, hold);
        } else {
            match self.check(cmd) {
                Verdict::Accept(n) => {
                    self.last_n = n;
                    self.run(cmd, out, hold);
                }
                Verdict::Duplicate => {
                    self.stats.duplicates += 1;
                    out(self.device.now_s(), "ok");
                }
                Verdict::Refuse(e) => refused(self, e, true, out),
            }
        }
    }

    /// Marlin's checks on a numbered line, in Marlin's order.
    fn check(&self, cmd: &[u8]) -> Verdict {
        let m110 = cmd.windows(4).any(|w| w == b"M110");
        let mut n_at = 0;
        if m110 {
            if let Some(i) = cmd.get(4..).and_then(|rest| rest.iter().position(|&b| b == b'N')) {
                n_at = 4 + i;
            }
        }
        let n = strtol(&cmd[n_at + 1..]);
        let sum = checksum_verdict(cmd);
        if !m110 && n != self.last_n.saturating_add(1) {
            let behind = self.last_n.saturating_sub(n);
            if sum.is_none() && (0..i64::from(self.config.duplicate_window)).contains(&behind) {
                return Verdict::Duplicate;
            }
            return Verdict::Refuse(LineError::LineNumber);
        }
        match sum {
            Some(e) => Verdict::Refuse(e),
            None => Verdict::Accept(n),
        }
    }

    /// `Error:...` then, for a numbered line, `Resend:`; then `ok` (Marlin's `gcode_line_error`).
    fn refuse(&mut self, error: LineError, numbered: bool, out: &mut dyn FnMut(f64, &str)) {
        self.stats.errors += 1;
        let t_s = self.device.now_s();
        out(t_s, &format!("Error:{}{}", error.message(), self.last_n));
        if numbered {
            out(t_s, &format!("Resend: {}", self.last_n.saturating_add(1)));
        }
        out(t_s, "ok");
    }

    /// Runs an accepted line: the link commands here, the rest on the device, with keepalive
    /// lines interleaved by simulated time.
    fn run(&mut self, cmd: &[u8], out: &mut dyn FnMut(f64, &str), hold: &mut dyn FnMut(f64, f64)) {
        parse_into(cmd, &mut self.block);
        // The registry's row says whether the command is the link's own (`Link`).
        let spec = lookup(self.block.command, self.block.command_span.of(cmd));
        match spec.map_or(Link::Machine, |s| s.link) {
            Link::LineNumber => {
                if let Some(n) = self.block.get(b'N') {
                    // The queue already took a numbered M110's number; an unnumbered one sets it
                    // here.
                    self.last_n = n as i64;
                }
                out(self.device.now_s(), "ok");
                return;
            }
            Link::Keepalive => {
                match (self.block.get(b'S'), spec.and_then(|s| s.range_of(b'S'))) {
                    // Marlin caps the interval (`NOMORE`) rather than refuse it: into the row's
                    // range, whole seconds as Marlin's byte holds them.
                    (Some(s), Some(range)) => self.config.keepalive_s = s.clamp(range.min, range.max) as u8,
                    _ => out(self.device.now_s(), &format!("echo:M113 S{}", self.config.keepalive_s)),
                }
                out(self.device.now_s(), "ok");
                return;
            }
            Link::Machine => {}
        }
        self.stats.executed += 1;
        let start_s = self.device.now_s();
        let mut keepalive = Keepalive::new(start_s, self.config.keepalive_s);
        let outcome = self.device.execute(command_body(cmd), &mut |t_s, text| {
            keepalive.before(t_s, out);
            out(t_s, text);
        });
        let end_s = self.device.now_s();
        keepalive.before(end_s, out);
        self.stats.busy += keepalive.printed;
        self.halted = outcome == Outcome::Halted;
        if self.device.waiting_for_user() {
            // The ok comes when the user has answered (see `during_user_wait`).
            self.user_wait = Some(start_s);
            self.next_paused_busy_s = end_s + f64::from(self.config.keepalive_s);
            return;
        }
        if self.device.wall_timed() {
            hold(start_s, end_s);
        }
        if !self.device.acknowledged() {
            out(end_s, "ok");
        }
    }
}

/// The `echo:busy: processing` schedule of one command: every `interval_s` after its start.
struct Keepalive {
    next_s: f64,
    interval_s: f64,
    printed: u64,
}

impl Keepalive {
    fn new(start_s: f64, interval_s: u8) -> Self {
        let interval_s = f64::from(interval_s);
        Keepalive { next_s: start_s + interval_s, interval_s, printed: 0 }
    }

    /// Prints every keepalive line due strictly before `t_s` (a device line at the same instant
    /// goes first; at the command's end the `ok` makes the keepalive unnecessary).
    fn before(&mut self, t_s: f64, out: &mut dyn FnMut(f64, &str)) {
        if self.interval_s <= 0.0 {
            return;
        }
        while self.next_s < t_s {
            out(self.next_s, "echo:busy: processing");
            self.printed += 1;
            self.next_s += self.interval_s;
        }
    }
}

/// The checksum check of a numbered line: `None` when it passes. The XOR runs over every byte
/// before the last `*`; the number after it is read as C's `strtol` does (Marlin compares that).
fn checksum_verdict(cmd: &[u8]) -> Option<LineError> {
    let Some(star) = cmd.iter().rposition(|&b| b == b'*') else {
        return Some(LineError::NoChecksum);
    };
    let computed = cmd[..star].iter().fold(0u8, |acc, b| acc ^ b);
    (strtol(&cmd[star + 1..]) != i64::from(computed)).then_some(LineError::ChecksumMismatch)
}

/// C's `strtol(s, NULL, 10)`: leading white space, an optional sign, then digits; 0 when there
/// are none; saturating instead of overflowing.
fn strtol(s: &[u8]) -> i64 {
    let mut i = s.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(s.len());
    let negative = s.get(i) == Some(&b'-');
    if matches!(s.get(i), Some(b'-' | b'+')) {
        i += 1;
    }
    let magnitude = s[i..]
        .iter()
        .take_while(|b| b.is_ascii_digit())
        .fold(0i64, |n, b| n.saturating_mul(10).saturating_add(i64::from(b - b'0')));
    if negative {
        -magnitude
    } else {
        magnitude
    }
}

/// A host's framing of one command: `N<n> <command>*<XOR of everything before the *>`.
pub fn frame_line(n: i64, command: &str) -> String {
    let body = format!("N{n} {command}");
    let sum = body.bytes().fold(0u8, |acc, b| acc ^ b);
    format!("{body}*{sum}")
}

/// The interpreter is the device behind `gweave serve`.
impl Device for crate::interp::Machine {
    fn boot_lines(&self) -> Vec<String> {
        crate::interp::Machine::boot_lines(self)
    }

    fn execute(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) -> Outcome {
        crate::interp::Machine::execute(self, line, out)
    }

    fn link_closed(&self) -> bool {
        self.program_ended()
    }

    fn now_s(&self) -> f64 {
        crate::interp::Machine::now_s(self)
    }

    fn acknowledged(&self) -> bool {
        crate::interp::Machine::acknowledged(self)
    }

    fn idle(&mut self, t_s: f64, out: &mut dyn FnMut(f64, &str)) {
        crate::interp::Machine::idle(self, t_s, out)
    }

    fn wall_timed(&self) -> bool {
        crate::interp::Machine::wall_timed(self)
    }

    fn has_own_work(&self) -> bool {
        crate::interp::Machine::sd_printing(self)
    }

    fn own_work(&mut self, out: &mut dyn FnMut(f64, &str)) {
        crate::interp::Machine::sd_step(self, out)
    }

    fn waiting_for_user(&self) -> bool {
        crate::interp::Machine::waiting_for_user(self)
    }

    fn emergency(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        crate::interp::Machine::emergency(self, line, out);
    }

    fn finish_user_wait(&mut self, out: &mut dyn FnMut(f64, &str)) {
        crate::interp::Machine::finish_user_wait(self, out)
    }

    fn listen(&mut self, lines: EarlyLines) {
        crate::interp::Machine::listen(self, lines)
    }
}

#[cfg(test)]
#[path = "serial_tests.rs"]
pub(crate) mod tests;
