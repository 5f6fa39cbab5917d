//! Moving the serial protocol's bytes: the serve loop shared by the pty ([`crate::link::pty`]) and TCP
//! ([`crate::link::tcp`]) endpoints, real-time pacing and the session log.
//!
//! Each host connection is one power-on of the virtual board, as a USB serial adapter resets an
//! Arduino-based Marlin board when a host opens the port: the loop builds a fresh device, prints
//! its boot lines (`start`), and feeds the host's bytes to a new [`Protocol`]. When the host
//! leaves, the device is dropped. Only one host is served at a time.
//!
//! By default replies go out as fast as the simulation produces them, except the `ok` of a
//! command hosts time by the wall clock (`M400`, [`Device::wall_timed`]), which is held for the
//! command's simulated duration, at most [`MAX_HOLD`]. Paced at speed N
//! ([`ServeOptions::speed`], 1 is real time) each reply waits until its simulated time, measured
//! from the moment the command's bytes arrived, divided by N: at speed 1 `G4 S5` answers `ok`
//! five wall-clock seconds later, with keepalive lines at 2 s and 4 s.
//!
//! The board's own work (an SD print, [`Device::own_work`]) runs while the host is quiet: as fast
//! as it can between looks at the line, or paced as the replies are.
//!
//! Two clocks, one board: while commands come, the board runs on its simulated clock (as fast
//! as it can, or paced); once the host has been quiet for [`QUIET_AFTER`], the board lives in
//! wall time ([`Device::idle`]): heaters heat and cool, `M155` auto-reports go out on time, and
//! the next `M105` reads the temperature of that moment. The simulated clock only ever moves
//! forward, by the wall time the host left the board alone.

use std::io::{self, Write};
use std::os::fd::AsFd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nix::errno::Errno;
use nix::poll::{poll, PollFd, PollFlags};

use crate::link::early::{Early, EarlyLines};
use crate::link::serial::{Device, LinkStats, Protocol, ProtocolConfig};

/// How long one wait for the host lasts before the loop looks at the stop flag again.
pub(crate) const TICK: Duration = Duration::from_millis(100);

/// How long the host must stay silent before the board lives in wall time. A streaming host
/// answers an `ok` within milliseconds; a gap this long means nothing is coming (and draining
/// the planner at a shorter gap would put stops into a print that Marlin, with its buffer of
/// queued moves, would not make).
pub(crate) const QUIET_AFTER: Duration = Duration::from_millis(500);

/// The longest wall-clock hold of a wall-timed `ok` ([`Device::wall_timed`]) when not pacing: a
/// board draining its planner buffer of a print (16 moves) takes well under this.
pub(crate) const MAX_HOLD: Duration = Duration::from_secs(5);

/// How long the board's own work (an SD print) runs before the loop looks at the host again.
const OWN_WORK_SLICE: Duration = Duration::from_millis(20);

/// What a wait on an endpoint brought.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// A host opened the port.
    Connected,
    /// The host sent this many bytes (into the caller's buffer).
    Data(usize),
    /// The host closed the port.
    Disconnected,
    /// Nothing happened within the wait.
    Nothing,
}

/// A place a host connects to.
pub trait Endpoint {
    /// Waits at most `timeout` for the host; reads what it sent into `buf`.
    fn wait(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Event>;
    /// Sends bytes to the connected host, giving up when `stop` is raised.
    fn send(&mut self, bytes: &[u8], stop: &AtomicBool) -> io::Result<()>;
    /// Forgets the current host after a failed send.
    fn hang_up(&mut self);
    /// Whether the host is known to have gone, checked while replies wait for their time (a
    /// paced command can last minutes). By default a hang-up is found by the next send or wait.
    fn host_gone(&mut self) -> bool {
        false
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("{context}")]
    Io {
        context: String,
        #[source]
        source: io::Error,
    },
    #[error("{0} is not a loopback address; the virtual printer listens on 127.0.0.1 or ::1 only")]
    NotLoopback(std::net::SocketAddr),
    #[error("{0} exists and is not a symlink; not replacing it")]
    LinkExists(std::path::PathBuf),
    #[error("building the virtual printer failed")]
    Device(#[source] Box<dyn std::error::Error + Send + Sync>),
}

impl TransportError {
    pub(crate) fn io(context: impl Into<String>) -> impl FnOnce(io::Error) -> TransportError {
        let context = context.into();
        move |source| TransportError::Io { context, source }
    }
}

/// How to serve.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ServeOptions {
    /// The serial protocol's settings.
    pub protocol: ProtocolConfig,
    /// Pace replies to the simulated clock, this many times faster than real time (1: real
    /// time); `None`: as fast as the simulation runs.
    pub speed: Option<f64>,
    /// Stop when the host has sent nothing for this long (wall clock).
    pub exit_after_idle: Option<Duration>,
}

/// What a serve run did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ServeSummary {
    /// Host connections (device boots).
    pub sessions: u64,
    /// Link counts summed over all sessions.
    pub link: LinkStats,
}

impl ServeSummary {
    fn end_session<D: Device>(&mut self, link: Protocol<D>, finished: &mut dyn FnMut(D)) {
        let s = link.stats();
        self.link.lines += s.lines;
        self.link.executed += s.executed;
        self.link.errors += s.errors;
        self.link.duplicates += s.duplicates;
        self.link.busy += s.busy;
        finished(link.into_device());
    }
}

/// Serves hosts on `endpoint` until `stop` is raised or the idle limit passes. `make_device`
/// builds the board afresh for every connection; `finished` gets it back when the session ends
/// (for a report); `log` receives the session transcript.
pub fn serve<D, E>(
    endpoint: &mut dyn Endpoint,
    make_device: &mut dyn FnMut() -> Result<D, E>,
    finished: &mut dyn FnMut(D),
    options: &ServeOptions,
    log: Option<&mut dyn Write>,
    stop: &AtomicBool,
) -> Result<ServeSummary, TransportError>
where
    D: Device,
    E: std::error::Error + Send + Sync + 'static,
{
    let mut summary = ServeSummary::default();
    let mut link: Option<Protocol<D>> = None;
    let mut out = Output::new(options.speed, log, stop);
    let mut received = LineLog::default();
    let mut buf = vec![0u8; 4096];
    let mut last_heard = Instant::now();
    let mut clock = IdleClock::new();
    while !stop.load(Ordering::Relaxed) {
        let working = link.as_ref().is_some_and(Protocol::has_own_work);
        // A board with its own work looks at the host without waiting.
        let wait = if working { Duration::ZERO } else { TICK };
        let event = endpoint.wait(&mut buf, wait).map_err(TransportError::io("waiting for the host"))?;
        match event {
            Event::Connected => {
                let device = make_device().map_err(|e| TransportError::Device(Box::new(e)))?;
                let mut fresh = Protocol::new(device, options.protocol);
                let early = EarlyLines::default();
                fresh.listen(early.clone());
                out.early = Early::new(early);
                summary.sessions += 1;
                out.note(&format!("host connected, session {}", summary.sessions));
                out.rebase(fresh.device().now_s());
                fresh.boot(&mut |t_s, line| out.line(endpoint, t_s, line));
                link = Some(fresh);
                last_heard = Instant::now();
                clock.busy();
            }
            Event::Data(n) => {
                last_heard = Instant::now();
                // Bytes before a connection (a pty buffer from an earlier host) are dropped.
                let Some(p) = link.as_mut() else { continue };
                // The emergency parser sees every byte, in order: a line begun here may end in
                // bytes read ahead while the board is busy (the catching up below may read ahead).
                out.early.follow(&buf[..n]);
                // The quiet time before these bytes, lived first: an M105 reads the present.
                clock.catch_up(p, &mut out, endpoint);
                feed(p, &buf[..n], &mut out, endpoint, &mut received, options.speed, stop);
                clock.busy();
            }
            Event::Disconnected => {
                if let Some(p) = link.take() {
                    out.note("host disconnected");
                    summary.end_session(p, finished);
                }
            }
            Event::Nothing => {
                if let Some(p) = link.as_mut() {
                    if p.has_own_work() {
                        out.rebase(p.device().now_s());
                        own_work(p, &mut out, endpoint);
                        clock.busy();
                    } else {
                        clock.catch_up(p, &mut out, endpoint);
                    }
                }
            }
        }
        // What the host sent while the board was busy, queued now in the order it came (the
        // emergency parser has seen it already: `crate::link::early`).
        if let Some(p) = link.as_mut() {
            loop {
                let early = out.early.take_bytes();
                if early.is_empty() || out.failed.is_some() {
                    break;
                }
                feed(p, &early, &mut out, endpoint, &mut received, options.speed, stop);
                clock.busy();
            }
        }
        if link.as_ref().is_some_and(|p| p.device().link_closed()) {
            out.note("the board closed the link (M0)");
            endpoint.hang_up();
            if let Some(p) = link.take() {
                summary.end_session(p, finished);
            }
        }
        if let Some(e) = out.failed.take() {
            out.note(&format!("send failed ({e}); dropping the host"));
            endpoint.hang_up();
            if let Some(p) = link.take() {
                summary.end_session(p, finished);
            }
        }
        if options.exit_after_idle.is_some_and(|limit| last_heard.elapsed() >= limit) {
            out.note("idle limit reached");
            break;
        }
    }
    if let Some(p) = link.take() {
        summary.end_session(p, finished);
    }
    Ok(summary)
}

/// Feeds the host's `bytes` to the protocol, its replies to `out`: paced, or with a wall-timed
/// `ok` held for its command's duration when not pacing.
fn feed<D: Device>(
    p: &mut Protocol<D>,
    bytes: &[u8],
    out: &mut Output<'_, '_>,
    endpoint: &mut dyn Endpoint,
    received: &mut LineLog,
    speed: Option<f64>,
    stop: &AtomicBool,
) {
    received.push(bytes, p.device().now_s(), out);
    out.rebase(p.device().now_s());
    p.feed_held(bytes, &mut |t_s, line| out.line(endpoint, t_s, line), &mut |from_s, to_s| {
        if speed.is_none() {
            hold(to_s - from_s, stop);
        }
    });
}

/// Holds a wall-timed `ok` for `t_s` seconds (at most [`MAX_HOLD`]), in ticks so that a stop
/// request is seen.
fn hold(t_s: f64, stop: &AtomicBool) {
    let due = Instant::now() + Duration::from_secs_f64(t_s.clamp(0.0, MAX_HOLD.as_secs_f64()));
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if now >= due {
            break;
        }
        std::thread::sleep((due - now).min(TICK));
    }
}

/// Runs the board's own work for one slice of wall time: as fast as it goes, or, when pacing, up
/// to the simulated time of this wall-clock instant.
fn own_work<D: Device>(link: &mut Protocol<D>, out: &mut Output<'_, '_>, endpoint: &mut dyn Endpoint) {
    let start = Instant::now();
    while link.has_own_work() && start.elapsed() < OWN_WORK_SLICE && out.failed.is_none() {
        if out.speed.is_some() && out.wall_at(link.device().now_s()) > Instant::now() {
            std::thread::sleep(Duration::from_millis(1));
            continue;
        }
        link.own_work(&mut |t_s, line| out.line(endpoint, t_s, line));
    }
}

/// The board's wall-clock life while its host is quiet.
struct IdleClock {
    /// When the board last heard from the host or finished answering it.
    active: Instant,
    /// The wall-clock instant up to which the board's clock has accounted for idle time.
    accounted: Instant,
}

impl IdleClock {
    fn new() -> Self {
        let now = Instant::now();
        IdleClock { active: now, accounted: now }
    }

    /// The host spoke and was answered: the board's own clock covered that time.
    fn busy(&mut self) {
        *self = IdleClock::new();
    }

    /// Once the host has been quiet for [`QUIET_AFTER`], lets the board live the wall time since
    /// the last account (all of the quiet time, the first time), sending what it prints.
    fn catch_up<D: Device>(
        &mut self,
        link: &mut Protocol<D>,
        out: &mut Output<'_, '_>,
        endpoint: &mut dyn Endpoint,
    ) {
        let now = Instant::now();
        if now.duration_since(self.active) < QUIET_AFTER {
            return;
        }
        let quiet_s = now.duration_since(self.accounted).as_secs_f64();
        self.accounted = now;
        link.idle(quiet_s, &mut |t_s, line| out.line(endpoint, t_s, line));
    }
}

/// Where replies go: paced, logged, sent; the first send error is kept for the loop.
struct Output<'a, 's> {
    speed: Option<f64>,
    /// Wall-clock instant and simulated time that correspond.
    anchor: (Instant, f64),
    log: Option<&'a mut dyn Write>,
    stop: &'s AtomicBool,
    failed: Option<io::Error>,
    bytes: Vec<u8>,
    /// What the host sends while replies wait for their time, and a buffer to read it into.
    early: Early,
    received: Vec<u8>,
}

impl<'a, 's> Output<'a, 's> {
    fn new(speed: Option<f64>, log: Option<&'a mut dyn Write>, stop: &'s AtomicBool) -> Self {
        Output {
            speed,
            anchor: (Instant::now(), 0.0),
            log,
            stop,
            failed: None,
            bytes: Vec::new(),
            early: Early::default(),
            received: vec![0u8; 4096],
        }
    }

    /// New bytes arrived with the device at `sim_s`: if the pacing has fallen behind the wall
    /// clock (the host was quiet, the simulated clock stood still), the next command starts now.
    fn rebase(&mut self, sim_s: f64) {
        let now = Instant::now();
        if self.wall_at(sim_s) < now {
            self.anchor = (now, sim_s);
        }
    }

    fn wall_at(&self, sim_s: f64) -> Instant {
        let ahead_s = (sim_s - self.anchor.1).max(0.0) / self.speed.unwrap_or(1.0);
        self.anchor.0 + Duration::from_secs_f64(ahead_s.min(1e9))
    }

    fn line(&mut self, endpoint: &mut dyn Endpoint, t_s: f64, text: &str) {
        if self.failed.is_some() {
            return;
        }
        if self.speed.is_some() {
            let due = self.wall_at(t_s);
            // Sleep in ticks so that a stop request and a hang-up are seen.
            while !self.stop.load(Ordering::Relaxed) {
                let now = Instant::now();
                if now >= due {
                    break;
                }
                if endpoint.host_gone() {
                    self.failed = Some(io::Error::from(io::ErrorKind::BrokenPipe));
                    return;
                }
                self.read_ahead(endpoint, (due - now).min(TICK));
                if self.failed.is_some() {
                    return;
                }
            }
        }
        self.write_log(&format!("{t_s:>12.3} < {text}"));
        // Marlin ends every line with a bare newline.
        self.bytes.clear();
        self.bytes.extend_from_slice(text.as_bytes());
        self.bytes.push(b'\n');
        if let Err(e) = endpoint.send(&self.bytes, self.stop) {
            self.failed = Some(e);
        }
    }

    /// Waits at most `wait` for the host while a reply waits for its time, keeping what it
    /// sends for the board's emergency parser and, later, its queue ([`Early`]); once the
    /// read-ahead is full, only waits.
    fn read_ahead(&mut self, endpoint: &mut dyn Endpoint, wait: Duration) {
        let room = self.early.room().min(self.received.len());
        if room == 0 {
            std::thread::sleep(wait);
            return;
        }
        match endpoint.wait(&mut self.received[..room], wait) {
            Ok(Event::Data(n)) => self.early.receive(&self.received[..n]),
            Ok(Event::Disconnected) => self.failed = Some(io::Error::from(io::ErrorKind::BrokenPipe)),
            Ok(Event::Connected | Event::Nothing) => {}
            Err(e) => self.failed = Some(e),
        }
    }

    fn note(&mut self, text: &str) {
        self.write_log(&format!("# {text}"));
    }

    fn write_log(&mut self, entry: &str) {
        if let Some(log) = self.log.as_mut() {
            // A log that cannot be written must not stop the printer; the first failure ends it.
            if writeln!(log, "{entry}").is_err() {
                self.log = None;
            }
        }
    }
}

/// The most bytes of one received line the log keeps: a line longer than that (a host gone wrong
/// can send megabytes without a newline) is logged as its first bytes and its length, so the log
/// and the server's memory stay small whatever the host sends. Marlin keeps 95 bytes of a line,
/// so any line a host means seriously is logged whole.
pub(crate) const LOG_LINE_BYTES: usize = 256;

/// Splits received bytes into lines for the log.
#[derive(Default)]
struct LineLog {
    /// The line's first bytes, at most [`LOG_LINE_BYTES`].
    head: Vec<u8>,
    /// The line's whole length so far.
    len: u64,
}

impl LineLog {
    fn push(&mut self, bytes: &[u8], t_s: f64, out: &mut Output<'_, '_>) {
        if out.log.is_none() {
            return;
        }
        for &b in bytes {
            if b == b'\n' || b == b'\r' {
                if self.len > 0 {
                    let text = String::from_utf8_lossy(&self.head);
                    if self.len > LOG_LINE_BYTES as u64 {
                        out.write_log(&format!(
                            "{t_s:>12.3} > {text}... ({} bytes, cut at {LOG_LINE_BYTES})",
                            self.len
                        ));
                    } else {
                        out.write_log(&format!("{t_s:>12.3} > {text}"));
                    }
                    self.head.clear();
                    self.len = 0;
                }
            } else {
                if self.head.len() < LOG_LINE_BYTES {
                    self.head.push(b);
                }
                self.len += 1;
            }
        }
    }
}

/// Writes all of `bytes` to a non-blocking writer, waiting for room in ticks and giving up with
/// `Interrupted` when `stop` is raised. A hang-up while waiting (`POLLHUP`/`POLLERR`: a pty host
/// that closed with replies unread, a reset socket) is `BrokenPipe` at once: such a descriptor
/// never becomes writable, and polling it again would return at once, for ever (a busy loop).
/// Sockets must be written through `TcpStream` (which sends with `MSG_NOSIGNAL`), not `write(2)`:
/// the CLI restores the default SIGPIPE action, which would kill the server on a reset peer.
pub(crate) fn write_all_nonblocking<W: Write + AsFd>(
    mut w: W,
    mut bytes: &[u8],
    stop: &AtomicBool,
) -> io::Result<()> {
    while !bytes.is_empty() {
        match w.write(bytes) {
            Ok(0) => return Err(io::Error::from(io::ErrorKind::WriteZero)),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if stop.load(Ordering::Relaxed) {
                    return Err(io::Error::from(io::ErrorKind::Interrupted));
                }
                let mut fds = [PollFd::new(w.as_fd(), PollFlags::POLLOUT)];
                match poll(&mut fds, tick_ms()) {
                    Ok(_) | Err(Errno::EINTR) => {}
                    Err(e) => return Err(e.into()),
                }
                let gone = PollFlags::POLLHUP | PollFlags::POLLERR;
                if fds[0].revents().is_some_and(|r| r.intersects(gone)) {
                    return Err(io::Error::from(io::ErrorKind::BrokenPipe));
                }
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Waits for `fd` to become readable (or hang up) for at most `timeout`: the revents, if any.
pub(crate) fn wait_readable(fd: impl AsFd, timeout: Duration) -> io::Result<PollFlags> {
    let ms = u16::try_from(timeout.as_millis()).unwrap_or(u16::MAX);
    let mut fds = [PollFd::new(fd.as_fd(), PollFlags::POLLIN)];
    match poll(&mut fds, ms) {
        Ok(_) => Ok(fds[0].revents().unwrap_or(PollFlags::empty())),
        Err(Errno::EINTR) => Ok(PollFlags::empty()),
        Err(e) => Err(e.into()),
    }
}

fn tick_ms() -> u16 {
    u16::try_from(TICK.as_millis()).unwrap_or(u16::MAX)
}

/// Runs [`serve`] on `endpoint` in a thread while `body` runs, then stops it: what the server
/// returned, the devices of the sessions as they ended, and what `body` returned. A failed
/// assertion in `body` stops the server too, or the scope would never end.
#[cfg(test)]
pub(crate) fn serving<D, E, T>(
    endpoint: &mut (dyn Endpoint + Send),
    mut make_device: impl FnMut() -> Result<D, E> + Send,
    options: &ServeOptions,
    log: Option<&mut (dyn Write + Send)>,
    body: impl FnOnce() -> T,
) -> (Result<ServeSummary, TransportError>, Vec<D>, T)
where
    D: Device + Send,
    E: std::error::Error + Send + Sync + 'static,
{
    struct StopOnDrop<'a>(&'a AtomicBool);
    impl Drop for StopOnDrop<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Relaxed);
        }
    }
    let stop = AtomicBool::new(false);
    std::thread::scope(|s| {
        let _stop = StopOnDrop(&stop);
        let server = s.spawn(|| {
            let mut ended = Vec::new();
            let log = log.map(|l| l as &mut dyn Write);
            let summary = serve(endpoint, &mut make_device, &mut |d| ended.push(d), options, log, &stop);
            (summary, ended)
        });
        let out = body();
        stop.store(true, Ordering::Relaxed);
        let (summary, ended) = server.join().unwrap();
        (summary, ended, out)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A host that always has more to send.
    struct Flood {
        asked: usize,
    }

    impl Endpoint for Flood {
        fn wait(&mut self, buf: &mut [u8], _: Duration) -> io::Result<Event> {
            self.asked += buf.len();
            buf.fill(b'X');
            Ok(Event::Data(buf.len()))
        }

        fn send(&mut self, _: &[u8], _: &AtomicBool) -> io::Result<()> {
            Ok(())
        }

        fn hang_up(&mut self) {}
    }

    /// A host that streams while a reply waits for its time is read up to the bound and then
    /// left waiting in its own buffer: memory stays small whatever it sends.
    #[test]
    fn reading_ahead_stops_at_its_bound() {
        let stop = AtomicBool::new(false);
        let mut out = Output::new(Some(1.0), None, &stop);
        let mut host = Flood { asked: 0 };
        for _ in 0..100 {
            out.read_ahead(&mut host, Duration::ZERO);
        }
        assert_eq!(host.asked, crate::link::early::MAX_EARLY_BYTES);
        assert_eq!(out.early.take_bytes().len(), crate::link::early::MAX_EARLY_BYTES);
        // Once the board has taken them, reading goes on.
        out.read_ahead(&mut host, Duration::ZERO);
        assert_eq!(host.asked, crate::link::early::MAX_EARLY_BYTES + 4096);
    }

    #[test]
    fn log_a_150_mb_line_is_cut_to_its_head_and_length() {
        let stop = AtomicBool::new(false);
        let mut log = Vec::new();
        let mut out = Output::new(None, Some(&mut log), &stop);
        let mut lines = LineLog::default();
        let chunk = vec![b'G'; 1 << 20];
        for _ in 0..150 {
            lines.push(&chunk, 1.5, &mut out);
        }
        assert!(lines.head.capacity() <= 2 * LOG_LINE_BYTES, "the head stays small");
        lines.push(b"\nM105\r\n", 2.0, &mut out);
        let expected = format!(
            "       2.000 > {}... (157286400 bytes, cut at 256)\n       2.000 > M105\n",
            "G".repeat(LOG_LINE_BYTES)
        );
        assert_eq!(String::from_utf8(log).unwrap(), expected);
    }
}
