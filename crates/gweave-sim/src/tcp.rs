//! A loopback TCP endpoint: hosts that speak to network printers (Printrun's `host:port`,
//! OctoPrint with a `socket://` serial URL, `nc`) connect to `127.0.0.1:PORT`.
//!
//! Only loopback addresses are accepted: the virtual printer has no authentication and must not
//! be reachable from other machines. One host at a time; a second connection while one is served
//! is accepted and closed at once, so that it fails fast instead of hanging in the backlog.

use std::io::{self, Read};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsFd;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use nix::poll::{poll, PollFd, PollFlags};

use crate::transport::{wait_readable, write_all_fd, Endpoint, Event, TransportError};

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

/// Accepts a waiting connection, if any, ready for the serve loop.
fn accept(listener: &TcpListener) -> io::Result<Option<TcpStream>> {
    match listener.accept() {
        Ok((stream, _)) => {
            stream.set_nonblocking(true)?;
            // Replies are single short lines; do not hold them back (Nagle).
            stream.set_nodelay(true)?;
            Ok(Some(stream))
        }
        Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(None),
        Err(e) => Err(e),
    }
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
        let client_ready = !fds[0].revents().unwrap_or(PollFlags::empty()).is_empty();
        let newcomer = fds[1].revents().unwrap_or(PollFlags::empty()).contains(PollFlags::POLLIN);
        let event = if client_ready {
            match client.read(buf) {
                Ok(0) => None,
                Ok(n) => Some(Event::Data(n)),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => Some(Event::Nothing),
                Err(e) if e.kind() == io::ErrorKind::ConnectionReset => None,
                Err(e) => return Err(e),
            }
        } else {
            Some(Event::Nothing)
        };
        let Some(event) = event else {
            // The host left; a newcomer waiting in the backlog is accepted on the next wait.
            self.client = None;
            return Ok(Event::Disconnected);
        };
        if newcomer {
            // Dropping the stream closes it: one host at a time.
            drop(accept(&self.listener)?);
        }
        Ok(event)
    }

    fn send(&mut self, bytes: &[u8], stop: &AtomicBool) -> io::Result<()> {
        match self.client.as_ref() {
            Some(client) => write_all_fd(client, bytes, stop),
            None => Err(io::Error::from(io::ErrorKind::NotConnected)),
        }
    }

    fn hang_up(&mut self) {
        self.client = None;
    }
}

#[cfg(test)]
mod tests {
    use std::io::{BufRead, BufReader, Write};
    use std::sync::atomic::Ordering;
    use std::time::Instant;

    use super::*;
    use crate::serial::tests::Scripted;
    use crate::transport::{serve, ServeOptions, StopOnDrop};

    fn lines_until_ok(reader: &mut BufReader<TcpStream>, oks: usize) -> Vec<String> {
        let mut got = Vec::new();
        while got.iter().filter(|l: &&String| *l == "ok").count() < oks {
            let mut line = String::new();
            assert!(reader.read_line(&mut line).unwrap() > 0, "closed after {got:?}");
            got.push(line.trim_end().to_string());
        }
        got
    }

    fn connect(addr: SocketAddr) -> (TcpStream, BufReader<TcpStream>) {
        let stream = TcpStream::connect(addr).unwrap();
        stream.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let reader = BufReader::new(stream.try_clone().unwrap());
        (stream, reader)
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
        let stop = AtomicBool::new(false);
        let options = ServeOptions { realtime: true, ..ServeOptions::default() };
        let mut transcript = Vec::new();
        std::thread::scope(|s| {
            // A failed assertion must still stop the server, or the scope never ends.
            let _stop = StopOnDrop(&stop);
            let server = s.spawn(|| {
                let mut make = || Ok::<_, io::Error>(Scripted::default());
                let mut ended = Vec::new();
                let mut finished = |d: Scripted| ended.push(d.ran);
                let summary =
                    serve(&mut endpoint, &mut make, &mut finished, &options, Some(&mut transcript), &stop);
                (summary, ended)
            });
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
            // A second host is turned away while the first is served.
            let (_other, mut other_reader) = connect(addr);
            let mut line = String::new();
            assert_eq!(other_reader.read_line(&mut line).unwrap(), 0);
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
            stop.store(true, Ordering::Relaxed);
            let (summary, ended) = server.join().unwrap();
            let summary = summary.unwrap();
            // Each session's machine comes back when it ends, with what it ran.
            assert_eq!(ended, [vec!["G28", "G4 S0.6"], vec!["G28"]]);
            assert_eq!(summary.sessions, 2);
            assert_eq!(summary.link.executed, 3);
            assert_eq!(summary.link.errors, 1);
        });
        let transcript = String::from_utf8(transcript).unwrap();
        assert!(transcript.contains("       0.000 > N3 G28*16\n"), "{transcript}");
        assert!(transcript.contains("       0.600 < ok\n"), "{transcript}");
    }
}
