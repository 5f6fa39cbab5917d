//! A loopback TCP endpoint: hosts that speak to network printers (Printrun's `host:port`,
//! OctoPrint with a `socket://` serial URL, `nc`) connect to `127.0.0.1:PORT`.
//!
//! Only loopback addresses are accepted: the virtual printer has no authentication and must not
//! be reachable from other machines.
//!
//! One host at a time. A second connection while a host is served is accepted, told
//! [`REFUSAL`] and closed, so that it fails fast with a reason instead of hanging in the backlog.
//! A newcomer is only refused while the current host is known to be there: when the current
//! host's socket also has news in the same wait (bytes, or an abrupt close that follows its last
//! bytes), the newcomer stays in the backlog until the current host's news is read, so a host
//! that connects right after another one reset its connection is served, not refused.

use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsFd;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use nix::poll::{poll, PollFd, PollFlags};

use crate::link::transport::{wait_readable, write_all_nonblocking, Endpoint, Event, TransportError};

/// How long a newcomer waits for news of the current host before it is refused (see
/// [`TcpEndpoint`]'s `wait`): far longer than a loopback packet takes, far shorter than a host's
/// read timeout.
const CLOSE_GRACE: Duration = Duration::from_millis(100);

/// What a host that connects while another is served reads before the server closes it.
pub(crate) const REFUSAL: &str = "echo:busy: another host is connected\n";

/// A loopback TCP listener serving one host at a time.
pub struct TcpEndpoint {
    listener: TcpListener,
    client: Option<TcpStream>,
}

impl TcpEndpoint {
    /// Listens on `addr`, which must be a loopback address (port 0 picks a free port).
    pub fn bind(addr: SocketAddr) -> Result<TcpEndpoint, TransportError> {
        if !addr.ip().is_loopback() {
            return Err(TransportError::NotLoopback(addr));
        }
        let listener = TcpListener::bind(addr).map_err(TransportError::io(format!("listening on {addr}")))?;
        listener.set_nonblocking(true).map_err(TransportError::io("making the listener non-blocking"))?;
        Ok(TcpEndpoint { listener, client: None })
    }

    /// The address actually bound.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }
}

/// Accepts a waiting connection, if any, ready for the serve loop. A connection that died in the
/// backlog (reset before it was accepted) is no connection, not an error of the server.
fn accept(listener: &TcpListener) -> io::Result<Option<TcpStream>> {
    match listener.accept() {
        Ok((stream, _)) => {
            // Replies are single short lines; do not hold them back (Nagle).
            let ready = stream.set_nonblocking(true).and_then(|()| stream.set_nodelay(true));
            Ok(ready.is_ok().then_some(stream))
        }
        Err(e) if gone_before_accept(&e) => Ok(None),
        Err(e) => Err(e),
    }
}

fn gone_before_accept(e: &io::Error) -> bool {
    use io::ErrorKind::{ConnectionAborted, ConnectionReset, Interrupted, WouldBlock};
    matches!(e.kind(), WouldBlock | ConnectionAborted | ConnectionReset | Interrupted)
}

/// Accepts a waiting newcomer and turns it away with [`REFUSAL`].
fn refuse_newcomer(listener: &TcpListener) -> io::Result<()> {
    let Some(stream) = accept(listener)? else { return Ok(()) };
    // Best effort, never blocking: a fresh socket's send buffer has room for one short line.
    let _ = (&stream).write(REFUSAL.as_bytes());
    let _ = stream.shutdown(Shutdown::Write);
    // Closing a socket with unread bytes sends a reset, which may make the newcomer's kernel
    // discard the line before it is read; read what it already sent (a bounded amount) first.
    let mut sink = [0u8; 4096];
    for _ in 0..16 {
        if !matches!((&stream).read(&mut sink), Ok(n) if n > 0) {
            break;
        }
    }
    Ok(())
}

impl Endpoint for TcpEndpoint {
    fn wait(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Event> {
        let Some(client) = self.client.as_mut() else {
            if wait_readable(&self.listener, timeout)?.contains(PollFlags::POLLIN) {
                if let Some(stream) = accept(&self.listener)? {
                    self.client = Some(stream);
                    return Ok(Event::Connected);
                }
            }
            return Ok(Event::Nothing);
        };
        let ms = u16::try_from(timeout.as_millis()).unwrap_or(u16::MAX);
        let mut fds = [
            PollFd::new(client.as_fd(), PollFlags::POLLIN),
            PollFd::new(self.listener.as_fd(), PollFlags::POLLIN),
        ];
        match poll(&mut fds, ms) {
            Ok(_) | Err(nix::errno::Errno::EINTR) => {}
            Err(e) => return Err(e.into()),
        }
        let mut client_ready = !fds[0].revents().unwrap_or(PollFlags::empty()).is_empty();
        let newcomer = fds[1].revents().unwrap_or(PollFlags::empty()).contains(PollFlags::POLLIN);
        if !client_ready && newcomer {
            // The host's close may still be on its way: loopback packets of two sockets can be
            // handled out of order when the sender moved to another CPU between its close and
            // the newcomer's connect. Give it a moment before turning the newcomer away.
            client_ready = !wait_readable(&*client, CLOSE_GRACE)?.is_empty();
        }
        if !client_ready {
            // A socket that was closed or reset always polls ready, so the host is still there.
            if newcomer {
                refuse_newcomer(&self.listener)?;
            }
            return Ok(Event::Nothing);
        }
        // A newcomer waits in the backlog: the host's news may be that it has gone.
        match client.read(buf) {
            Ok(0) => {}
            Ok(n) => return Ok(Event::Data(n)),
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => {
                return Ok(Event::Nothing)
            }
            // Reset, timed out...: whatever the error, this host's connection is over.
            Err(_) => {}
        }
        self.client = None;
        Ok(Event::Disconnected)
    }

    fn send(&mut self, bytes: &[u8], stop: &AtomicBool) -> io::Result<()> {
        match self.client.as_ref() {
            Some(client) => write_all_nonblocking(client, bytes, stop),
            None => Err(io::Error::from(io::ErrorKind::NotConnected)),
        }
    }

    fn hang_up(&mut self) {
        self.client = None;
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write;
    use std::time::Instant;

    use super::*;
    use crate::link::serial::tests::Scripted;
    use crate::link::transport::{serving, ServeOptions};
    use crate::test_support::{connect, lines_through, lines_until_ok, reset};

    /// Connects while another host is served: everything the server says before it closes.
    fn turned_away(addr: SocketAddr) -> String {
        let (mut other, _) = connect(addr);
        // A newcomer that talks at once must still read the reason.
        other.write_all(b"M105\n").unwrap();
        let mut said = String::new();
        other.read_to_string(&mut said).unwrap();
        said
    }

    /// Runs a server of `Scripted` boards on a free loopback port for the body; the boards of
    /// the sessions, as they ended.
    fn with_server(options: ServeOptions, body: impl FnOnce(SocketAddr)) -> Vec<Scripted> {
        let mut endpoint = TcpEndpoint::bind("127.0.0.1:0".parse().unwrap()).unwrap();
        let addr = endpoint.local_addr().unwrap();
        let make = || Ok::<_, io::Error>(Scripted::default());
        let (summary, ended, ()) = serving(&mut endpoint, make, &options, None, || body(addr));
        summary.unwrap();
        ended
    }

    /// Runs a server of virtual printers (the default profile) paced at `speed` times real
    /// time on a free loopback port for the body; the boards of the sessions, as they ended.
    fn with_virtual_printers(speed: f64, body: impl FnOnce(SocketAddr)) -> Vec<crate::interp::Machine> {
        let mut endpoint = TcpEndpoint::bind("127.0.0.1:0".parse().unwrap()).unwrap();
        let addr = endpoint.local_addr().unwrap();
        let options = ServeOptions { speed: Some(speed), ..ServeOptions::default() };
        let make = || crate::interp::Machine::new(crate::profile::MachineProfile::default());
        let (summary, ended, ()) = serving(&mut endpoint, make, &options, None, || body(addr));
        summary.unwrap();
        ended
    }

    #[test]
    fn tcp_a_connection_right_after_an_abrupt_close_is_served() {
        with_server(ServeOptions::default(), |addr| {
            // The reset follows the host's last bytes; the newcomer arrives in the same instant.
            for _ in 0..5 {
                let (mut host, mut reader) = connect(addr);
                lines_through(&mut reader, "echo:Marlin");
                host.write_all(b"M105\n").unwrap();
                drop(reader);
                reset(host);
                let (mut next, mut reader) = connect(addr);
                next.write_all(b"M105\n").unwrap();
                let got = lines_through(&mut reader, "ok");
                assert_eq!(got, ["start", "echo:Marlin test double", "ok T:20.00 /0.00"]);
            }
        });
    }

    #[test]
    fn tcp_a_second_host_is_refused_while_an_idle_one_is_connected() {
        with_server(ServeOptions::default(), |addr| {
            let (mut idle, mut reader) = connect(addr);
            assert_eq!(lines_through(&mut reader, "echo:Marlin"), ["start", "echo:Marlin test double"]);
            std::thread::sleep(Duration::from_millis(300));
            assert_eq!(turned_away(addr), REFUSAL);
            // The idle host keeps its board; once it leaves, the next host is served.
            idle.write_all(b"M105\n").unwrap();
            assert_eq!(lines_through(&mut reader, "ok"), ["ok T:20.00 /0.00"]);
            drop((idle, reader));
            let (mut next, mut reader) = connect(addr);
            next.write_all(b"M105\n").unwrap();
            assert_eq!(
                lines_through(&mut reader, "ok"),
                ["start", "echo:Marlin test double", "ok T:20.00 /0.00"]
            );
        });
    }

    #[test]
    fn tcp_a_quiet_host_leaves_the_board_living_in_wall_time() {
        let started = Instant::now();
        let ended = with_server(ServeOptions::default(), |addr| {
            let (mut host, mut reader) = connect(addr);
            host.write_all(b"G4 S100\n").unwrap();
            lines_through(&mut reader, "ok");
            // Short gaps (a streaming host) are not idle time; a long one is, as it passes.
            host.write_all(b"G1\n").unwrap();
            lines_through(&mut reader, "ok");
            std::thread::sleep(crate::link::transport::QUIET_AFTER + Duration::from_millis(700));
            host.write_all(b"M105\n").unwrap();
            lines_through(&mut reader, "ok T:");
        });
        let board = &ended[0];
        let wall_s = started.elapsed().as_secs_f64();
        assert!(board.idle_s >= 1.1 && board.idle_s <= wall_s, "{} of {wall_s}", board.idle_s);
        // The simulated clock ran its own commands (100.5 s) and then the quiet wall time.
        assert!((board.t_s - (100.5 + board.idle_s)).abs() < 1e-9, "{}", board.t_s);
    }

    /// Regression (the emergency parser did not act during a paced wait: `M108` and `M112`
    /// sent during `M109` acted when its 84 s of heating had been paced out): at 20 times real
    /// time the wait is 4.2 s of wall time; `M108` sent once it has begun ends it at once, with
    /// its `ok`, and `M112` kills the board, heaters off, as soon as it arrives.
    #[test]
    fn tcp_the_emergency_parser_acts_during_a_paced_heating_wait() {
        let ended = with_virtual_printers(20.0, |addr| {
            for urgent in ["M108", "M112"] {
                let (mut host, mut reader) = connect(addr);
                lines_through(&mut reader, "echo:Machine:");
                host.write_all(b"M109 S200\n").unwrap();
                lines_through(&mut reader, " T:");
                let sent = Instant::now();
                host.write_all(format!("{urgent}\n").as_bytes()).unwrap();
                let last = if urgent == "M108" { "ok" } else { "Error:Printer halted" };
                let got = lines_through(&mut reader, last);
                let waited = sent.elapsed();
                assert!(waited < Duration::from_millis(1500), "{urgent}: {waited:?} for {got:?}");
                if urgent == "M108" {
                    // The wait ended, not the heating: the target stays.
                    host.write_all(b"M105\n").unwrap();
                    let report = lines_through(&mut reader, "ok T:");
                    assert!(report.last().unwrap().contains(" /200.00 "), "{report:?}");
                }
            }
        });
        // Each board heated a few seconds of its 84, and the second was killed.
        assert_eq!(ended.len(), 2);
        for board in &ended {
            assert!(board.now_s() < 30.0, "{}", board.now_s());
        }
        let killed = ended[1].report();
        assert!(killed.halted);
        assert!(killed.heaters.iter().all(|h| h.target_c == 0.0), "{:?}", killed.heaters);
    }

    /// Regression (review of the emergency parser during paced waits): a line whose start was
    /// read ahead during a paced dwell and whose end the board read itself, once free, left the
    /// early assembler inside a comment, and the `M108` sent during the next heating wait was
    /// skipped as part of it: the wait ran its whole 4.2 s of wall time.
    #[test]
    fn tcp_a_line_cut_across_a_paced_reply_leaves_the_emergency_parser_listening() {
        with_virtual_printers(20.0, |addr| {
            let (mut host, mut reader) = connect(addr);
            lines_through(&mut reader, "echo:Machine:");
            // A 6 s dwell is 0.3 s of wall time: the half line arrives while its `ok` waits.
            host.write_all(b"G4 S6\n").unwrap();
            std::thread::sleep(Duration::from_millis(100));
            host.write_all(b"M117 cut ; a comment").unwrap();
            lines_through(&mut reader, "ok");
            std::thread::sleep(Duration::from_millis(100));
            host.write_all(b" that ends here\n").unwrap();
            lines_through(&mut reader, "ok");
            host.write_all(b"M109 S200\n").unwrap();
            lines_through(&mut reader, " T:");
            let sent = Instant::now();
            host.write_all(b"M108\n").unwrap();
            let got = lines_through(&mut reader, "ok");
            let waited = sent.elapsed();
            assert!(waited < Duration::from_millis(1500), "{waited:?} for {got:?}");
        });
    }

    #[test]
    fn refuses_non_loopback() {
        let addr: SocketAddr = "0.0.0.0:0".parse().unwrap();
        assert!(matches!(TcpEndpoint::bind(addr), Err(TransportError::NotLoopback(_))));
    }

    #[test]
    fn serves_one_host_at_a_time_and_reboots_per_connection() {
        let mut endpoint = TcpEndpoint::bind("127.0.0.1:0".parse().unwrap()).unwrap();
        let addr = endpoint.local_addr().unwrap();
        let options = ServeOptions { speed: Some(1.0), ..ServeOptions::default() };
        let mut transcript = Vec::new();
        let make = || Ok::<_, io::Error>(Scripted::default());
        let (summary, ended, ()) = serving(&mut endpoint, make, &options, Some(&mut transcript), || {
            let (mut host, mut reader) = connect(addr);
            host.write_all(b"N1 G28*18\nN3 G28*16\n").unwrap();
            let got = lines_until_ok(&mut reader, 2);
            assert_eq!(
                got,
                [
                    "start",
                    "echo:Marlin test double",
                    "ok",
                    "Error:Line Number is not Last Line Number+1, Last Line: 1",
                    "Resend: 2",
                    "ok"
                ]
            );
            // A second host is turned away, with a reason, while the first is served.
            assert_eq!(turned_away(addr), REFUSAL);
            // Real time: a 0.6 s dwell answers after 0.6 s of wall clock, not at once.
            let sent = Instant::now();
            host.write_all(b"G4 S0.6\n").unwrap();
            assert_eq!(lines_until_ok(&mut reader, 1), ["ok"]);
            assert!(sent.elapsed() >= Duration::from_millis(550), "{:?}", sent.elapsed());
            drop((host, reader));
            // The next host finds a freshly booted board.
            let (mut host, mut reader) = connect(addr);
            host.write_all(b"N1 G28*18\n").unwrap();
            assert_eq!(lines_until_ok(&mut reader, 1), ["start", "echo:Marlin test double", "ok"]);
        });
        let summary = summary.unwrap();
        // Each session's machine comes back when it ends, with what it ran.
        let ran: Vec<_> = ended.into_iter().map(|d| d.ran).collect();
        assert_eq!(ran, [vec!["G28", "G4 S0.6"], vec!["G28"]]);
        assert_eq!(summary.sessions, 2);
        assert_eq!(summary.link.executed, 3);
        assert_eq!(summary.link.errors, 1);
        let transcript = String::from_utf8(transcript).unwrap();
        assert!(transcript.contains("       0.000 > N3 G28*16\n"), "{transcript}");
        assert!(transcript.contains("       0.600 < ok\n"), "{transcript}");
    }

    /// Runs a server of default virtual printers (with an SD card in `sd`) for the body.
    fn with_machines(options: ServeOptions, sd: &std::path::Path, body: impl FnOnce(SocketAddr)) {
        use crate::interp::Machine;
        let mut endpoint = TcpEndpoint::bind("127.0.0.1:0".parse().unwrap()).unwrap();
        let addr = endpoint.local_addr().unwrap();
        let make = || {
            Machine::new(Default::default()).map(|mut m| {
                m.attach_sd(sd.to_owned());
                m
            })
        };
        serving(&mut endpoint, make, &options, None, || body(addr)).0.unwrap();
    }

    /// Issue #20: OctoPrint's pause waited 3 s for a timeout because the fast board answered
    /// M400 before OctoPrint had queued its M114; the ok now takes the moves' time.
    #[test]
    fn tcp_fast_board_holds_the_m400_ok_for_the_queued_moves() {
        let sd = tempfile::tempdir().unwrap();
        with_machines(ServeOptions::default(), sd.path(), |addr| {
            let (mut host, mut reader) = connect(addr);
            lines_through(&mut reader, "echo:Machine");
            // 10 mm at 10 mm/s: about a second; the move itself is acknowledged at once.
            let sent = Instant::now();
            host.write_all(b"G1 X10 F600\n").unwrap();
            lines_through(&mut reader, "ok");
            assert!(sent.elapsed() < Duration::from_millis(300), "{:?}", sent.elapsed());
            host.write_all(b"M400\n").unwrap();
            lines_through(&mut reader, "ok");
            let took = sent.elapsed();
            assert!(took >= Duration::from_millis(950) && took < Duration::from_secs(3), "{took:?}");
        });
    }

    #[test]
    fn tcp_speed_n_paces_n_times_faster_than_real_time() {
        let sd = tempfile::tempdir().unwrap();
        with_machines(ServeOptions { speed: Some(4.0), ..ServeOptions::default() }, sd.path(), |addr| {
            let (mut host, mut reader) = connect(addr);
            lines_through(&mut reader, "echo:Machine");
            let sent = Instant::now();
            host.write_all(b"G4 S2\n").unwrap();
            lines_through(&mut reader, "ok");
            let took = sent.elapsed();
            assert!(took >= Duration::from_millis(450) && took < Duration::from_millis(1500), "{took:?}");
        });
    }

    #[test]
    fn tcp_sd_print_runs_while_the_host_is_quiet_and_answers_it_meanwhile() {
        let sd = tempfile::tempdir().unwrap();
        let body: String = (0..200).map(|i| format!("G1 X{} Y{} F12000\n", i % 50, i % 7)).collect();
        std::fs::write(sd.path().join("part.gco"), format!("G28\n{body}G1 X42 Y7\n")).unwrap();
        with_machines(ServeOptions::default(), sd.path(), |addr| {
            let (mut host, mut reader) = connect(addr);
            lines_through(&mut reader, "echo:Machine");
            host.write_all(b"M23 part.gco\nM24\n").unwrap();
            lines_through(&mut reader, "File selected");
            lines_through(&mut reader, "ok");
            lines_through(&mut reader, "ok");
            // The board prints on its own; the host only listens.
            let got = lines_through(&mut reader, "Done printing file");
            assert!(!got.iter().any(|l| l == "ok"), "no ok for the card's lines: {got:?}");
            host.write_all(b"M114\n").unwrap();
            let got = lines_through(&mut reader, "ok");
            assert!(got[0].starts_with("X:42.00 Y:7.00 "), "{got:?}");
        });
    }
}
