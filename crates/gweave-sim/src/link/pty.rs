//! A pseudo-terminal endpoint: the virtual printer looks like a USB serial port to any host that
//! opens a device path (Printrun, OctoPrint, `screen`).
//!
//! The pty's slave side gets a random name (`/dev/pts/7`), so a stable symlink (`/tmp/gweave0`)
//! points at it; it is removed when the endpoint is dropped. The line discipline is put in raw
//! mode (no echo, no CR/LF translation, no signals) as a real serial port would be.
//!
//! Connection tracking relies on Linux pty semantics: while no process holds the slave open the
//! master reports `POLLHUP` (reads fail with `EIO`); the first open clears it. So a host opening
//! the path is a [`Event::Connected`] (a board reset), its last close an [`Event::Disconnected`].

use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::poll::PollFlags;
use nix::pty::{grantpt, posix_openpt, ptsname_r, unlockpt, PtyMaster};
use nix::sys::termios::{cfmakeraw, tcflush, tcgetattr, tcsetattr, FlushArg, SetArg};

use crate::link::transport::{wait_readable, write_all_nonblocking, Endpoint, Event, TransportError};

/// A pty with a symlink to its slave side.
pub struct PtyEndpoint {
    master: PtyMaster,
    slave: PathBuf,
    link: PathBuf,
    connected: bool,
}

impl PtyEndpoint {
    /// Opens a pty in raw mode and links `link` to its slave. An existing symlink at `link` (left
    /// by a killed run) is replaced; any other file there is an error.
    pub fn open(link: &Path) -> Result<PtyEndpoint, TransportError> {
        let master = posix_openpt(OFlag::O_RDWR | OFlag::O_NOCTTY)
            .and_then(|m| grantpt(&m).and_then(|()| unlockpt(&m)).map(|()| m))
            .map_err(|e| TransportError::Io { context: "opening a pty".into(), source: e.into() })?;
        let slave = ptsname_r(&master)
            .map(PathBuf::from)
            .map_err(|e| TransportError::Io { context: "naming the pty".into(), source: e.into() })?;
        // Set raw mode through the slave, then close it: with no slave open the master reports
        // a hang-up until a host opens the link.
        drop(open_raw(&slave)?);
        fcntl(&master, FcntlArg::F_SETFL(OFlag::O_NONBLOCK))
            .map_err(|e| TransportError::Io { context: "pty non-blocking".into(), source: e.into() })?;
        match std::fs::symlink_metadata(link) {
            Ok(m) if m.file_type().is_symlink() => std::fs::remove_file(link)
                .map_err(TransportError::io(format!("replacing {}", link.display())))?,
            Ok(_) => return Err(TransportError::LinkExists(link.to_path_buf())),
            Err(_) => {}
        }
        std::os::unix::fs::symlink(&slave, link)
            .map_err(TransportError::io(format!("linking {}", link.display())))?;
        Ok(PtyEndpoint { master, slave, link: link.to_path_buf(), connected: false })
    }

    /// The pty's own device path (`/dev/pts/N`).
    pub fn slave_path(&self) -> &Path {
        &self.slave
    }

    /// The stable symlink hosts open.
    pub fn link_path(&self) -> &Path {
        &self.link
    }
}

/// Opens the slave side (never as the server's controlling terminal) and puts its line discipline
/// in raw mode: no echo, no CR/LF translation, no signals, as a real serial port.
fn open_raw(slave: &Path) -> Result<File, TransportError> {
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags((OFlag::O_NOCTTY | OFlag::O_NONBLOCK).bits())
        .open(slave)
        .map_err(TransportError::io(format!("opening {}", slave.display())))?;
    let raw = tcgetattr(&file).and_then(|mut t| {
        cfmakeraw(&mut t);
        tcsetattr(&file, SetArg::TCSANOW, &t)
    });
    raw.map_err(|e| TransportError::Io { context: "setting raw mode".into(), source: e.into() })?;
    Ok(file)
}

impl PtyEndpoint {
    /// Forgets a host that hung up, as a board reset would: the bytes it sent that were not read
    /// yet (the master's input) and the replies it did not read (the slave's input: up to 4 KiB
    /// in its line discipline plus the pty's queue, which would otherwise greet the next host)
    /// are dropped, and the line is raw again whatever the host set. A flush on the master
    /// cannot reach the slave's line discipline, so the slave is opened for a moment and
    /// flushed from its own side.
    fn discard_session(&mut self) {
        self.connected = false;
        // Best effort: if this fails, the next host sees stale bytes, and nothing worse.
        let _ = tcflush(&self.master, FlushArg::TCIFLUSH);
        if let Ok(slave) = open_raw(&self.slave) {
            let _ = tcflush(&slave, FlushArg::TCIOFLUSH);
        }
    }
}

impl Endpoint for PtyEndpoint {
    fn wait(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Event> {
        let ready = wait_readable(&self.master, timeout)?;
        // POLLHUP on the master means no process holds the slave open now, even if the host's last
        // bytes are still unread (POLLIN): the host has gone, and so has its session.
        if ready.contains(PollFlags::POLLHUP) {
            if self.connected {
                self.discard_session();
                return Ok(Event::Disconnected);
            }
            // No host: poll returns at once, so wait out the tick here.
            std::thread::sleep(timeout);
            return Ok(Event::Nothing);
        }
        if !self.connected {
            self.connected = true;
            return Ok(Event::Connected);
        }
        if !ready.contains(PollFlags::POLLIN) {
            return Ok(Event::Nothing);
        }
        match self.master.read(buf) {
            Ok(n) => Ok(Event::Data(n)),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(Event::Nothing),
            // EIO: the host closed the slave between the poll and the read.
            Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => {
                self.discard_session();
                Ok(Event::Disconnected)
            }
            Err(e) => Err(e),
        }
    }

    fn send(&mut self, bytes: &[u8], stop: &AtomicBool) -> io::Result<()> {
        // Writing to a master whose slave is closed succeeds while the pty has room: the bytes
        // would wait there for the next host. Refuse instead, so the session ends now.
        if self.host_gone() {
            return Err(io::Error::from(io::ErrorKind::BrokenPipe));
        }
        write_all_nonblocking(&self.master, bytes, stop)
    }

    fn hang_up(&mut self) {
        self.discard_session();
    }

    fn host_gone(&mut self) -> bool {
        wait_readable(&self.master, Duration::ZERO).is_ok_and(|r| r.contains(PollFlags::POLLHUP))
    }
}

impl Drop for PtyEndpoint {
    fn drop(&mut self) {
        // Remove the link only if it is still ours.
        if std::fs::read_link(&self.link).is_ok_and(|target| target == self.slave) {
            let _ = std::fs::remove_file(&self.link);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::fs::File;
    use std::io::Write;
    use std::time::Instant;

    use nix::sys::termios::{cfsetspeed, BaudRate};

    use super::*;
    use crate::link::serial::tests::Scripted;
    use crate::link::transport::{serving, ServeOptions};

    fn open_host(link: &Path) -> File {
        OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags((OFlag::O_NOCTTY | OFlag::O_NONBLOCK).bits())
            .open(link)
            .unwrap()
    }

    /// Reads reply lines until `oks` of them are `ok`, failing after 10 s.
    fn lines_until_ok(host: &mut File, oks: usize) -> Vec<String> {
        lines_until(host, |text| text.lines().filter(|l| *l == "ok").count() >= oks)
    }

    /// Reads reply lines until `done` holds for all that came, failing after 10 s.
    fn lines_until(host: &mut File, done: impl Fn(&str) -> bool) -> Vec<String> {
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut text = String::new();
        let mut buf = [0u8; 256];
        while !done(&text) {
            assert!(Instant::now() < deadline, "timed out after {text:?}");
            wait_readable(&*host, Duration::from_millis(100)).unwrap();
            match host.read(&mut buf) {
                Ok(n) => text.push_str(std::str::from_utf8(&buf[..n]).unwrap()),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                Err(e) => panic!("{e}"),
            }
        }
        text.lines().map(str::to_string).collect()
    }

    #[test]
    fn serves_a_host_through_the_link_and_removes_it() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("gweave0");
        let mut endpoint = PtyEndpoint::open(&link).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), endpoint.slave_path());
        let make = || Ok::<_, io::Error>(Scripted::default());
        let (summary, _, ()) = serving(&mut endpoint, make, &ServeOptions::default(), None, || {
            let mut host = open_host(&link);
            // Raw mode: CR is not turned into LF, nothing is echoed back.
            host.write_all(b"N1 G28*18\r\nN2 G28*19\nG4 S5\n").unwrap();
            let got = lines_until_ok(&mut host, 3);
            assert_eq!(
                got,
                [
                    "start",
                    "echo:Marlin test double",
                    "ok",
                    "Error:checksum mismatch, Last Line: 1",
                    "Resend: 2",
                    "ok",
                    "echo:busy: processing",
                    "echo:busy: processing",
                    "ok"
                ]
            );
            drop(host);
            // Reopening the port reboots the board (the hang-up is seen within a tick; a host
            // that closes and reopens faster than that keeps its session).
            std::thread::sleep(3 * crate::link::transport::TICK);
            let mut host = open_host(&link);
            host.write_all(b"G28\n").unwrap();
            assert_eq!(lines_until_ok(&mut host, 1), ["start", "echo:Marlin test double", "ok"]);
        });
        let summary = summary.unwrap();
        assert_eq!(summary.sessions, 2);
        assert_eq!(summary.link.busy, 2);
        drop(endpoint);
        assert!(std::fs::symlink_metadata(&link).is_err(), "the link is removed");
    }

    /// Writes as much of `bytes` as the pty takes until it stays full for 0.3 s; how much it took.
    fn write_until_full(host: &mut File, bytes: &[u8]) -> usize {
        let mut sent = 0;
        let mut last_progress = Instant::now();
        while sent < bytes.len() && last_progress.elapsed() < Duration::from_millis(300) {
            match host.write(&bytes[sent..]) {
                Ok(n) => {
                    sent += n;
                    last_progress = Instant::now();
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(5))
                }
                Err(e) => panic!("{e}"),
            }
        }
        sent
    }

    /// Serves `Scripted` boards on a fresh link for the body; each ended session's commands.
    fn with_server(
        options: ServeOptions,
        body: impl FnOnce(&Path),
    ) -> (crate::link::transport::ServeSummary, Vec<Vec<String>>) {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("gweave0");
        let mut endpoint = PtyEndpoint::open(&link).unwrap();
        let make = || Ok::<_, io::Error>(Scripted::default());
        let (summary, ended, ()) = serving(&mut endpoint, make, &options, None, || body(&link));
        (summary.unwrap(), ended.into_iter().map(|d| d.ran).collect())
    }

    /// After a hang-up, the next host to open the port gets a fresh power-on: no stale replies,
    /// no fragment glued to its first command.
    fn assert_next_host_gets_a_fresh_board(link: &Path) {
        std::thread::sleep(3 * crate::link::transport::TICK);
        let mut host = open_host(link);
        host.write_all(b"M105\n").unwrap();
        let got = lines_until(&mut host, |text| text.contains("ok T:"));
        assert_eq!(got, ["start", "echo:Marlin test double", "ok T:20.00 /0.00"]);
    }

    #[test]
    fn pty_a_host_that_hangs_up_with_replies_unread_leaves_a_fresh_board() {
        let (summary, ended) = with_server(ServeOptions::default(), |link| {
            let mut host = open_host(link);
            // The replies that nobody reads fill the pty, then the server waits to write and
            // stops reading, and the host's commands fill the pty the other way.
            let burst = b"M105\n".repeat(20_000);
            let sent = write_until_full(&mut host, &burst);
            assert!(sent < burst.len(), "the pty took all of it: {sent} bytes");
            drop(host);
            assert_next_host_gets_a_fresh_board(link);
        });
        assert_eq!(summary.sessions, 2);
        assert_eq!(ended[1], ["M105"]);
        assert!(ended[0].iter().all(|c| c == "M105"), "the fragment never ran");
    }

    #[test]
    fn pty_a_hang_up_during_a_paced_command_is_seen_at_once() {
        let started = Instant::now();
        let options = ServeOptions { speed: Some(1.0), ..ServeOptions::default() };
        let (summary, ended) = with_server(options, |link| {
            let mut host = open_host(link);
            // Thirty seconds of replies paced to the wall clock; the host leaves after the boot.
            host.write_all(b"G4 S30\n").unwrap();
            // The first keepalive (2 s into the dwell) proves the board is running the command
            // (on a loaded machine the banner alone can come before the line is read).
            lines_until(&mut host, |text| text.contains("echo:busy: processing\n"));
            drop(host);
            assert_next_host_gets_a_fresh_board(link);
        });
        assert!(started.elapsed() < Duration::from_secs(5), "{:?}", started.elapsed());
        assert_eq!(summary.sessions, 2);
        assert_eq!(ended[0], ["G4 S30"]);
    }

    #[test]
    fn pty_a_host_may_toggle_dtr_through_termios() {
        with_server(ServeOptions::default(), |link| {
            let mut host = open_host(link);
            // A host drops and raises DTR by setting the speed to 0 and back (termios(3)).
            let mut t = tcgetattr(&host).unwrap();
            for speed in [BaudRate::B0, BaudRate::B115200] {
                cfsetspeed(&mut t, speed).unwrap();
                tcsetattr(&host, SetArg::TCSANOW, &t).unwrap();
            }
            host.write_all(b"M105\n").unwrap();
            let got = lines_until(&mut host, |text| text.contains("ok T:"));
            assert_eq!(got, ["start", "echo:Marlin test double", "ok T:20.00 /0.00"]);
        });
    }

    #[test]
    fn replaces_a_stale_link_but_not_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("gweave0");
        std::os::unix::fs::symlink("/nonexistent", &link).unwrap();
        let endpoint = PtyEndpoint::open(&link).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), endpoint.slave_path());
        let file = dir.path().join("plain");
        std::fs::write(&file, "keep").unwrap();
        assert!(matches!(PtyEndpoint::open(&file), Err(TransportError::LinkExists(_))));
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep");
    }
}
