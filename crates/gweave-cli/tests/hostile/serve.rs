//! `gweave serve` under hostile hosts: abrupt closes, idle hosts holding the board, a pty host
//! that hangs up with replies unread, a line of 20 MB. Each case starts the real server on a
//! loopback port or a pty, talks to it as a host would, and stops it (killed if the test fails).

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;
use std::thread;
use std::time::{Duration, Instant};

use gweave_sim::test_support::{connect, lines_through, reset};

use crate::harness::*;

/// A running `gweave serve`, stopped when dropped (killed, if a failed assertion left it running).
pub(crate) struct Server {
    run: Option<Running>,
}

impl Server {
    fn start(dir: &Path, args: &[&str]) -> Server {
        let mut all = vec!["serve"];
        all.extend_from_slice(args);
        Server { run: Some(gweave(dir, &all).limit(Duration::from_secs(30)).spawn()) }
    }

    /// Serves TCP on a free loopback port; returns once the port answers.
    pub(crate) fn tcp(dir: &Path, extra: &[&str]) -> (Server, SocketAddr) {
        // Port 0 would make the server pick, but then the port must be read from its output;
        // a port that was free a moment ago is simpler.
        let addr = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
        let tcp = addr.to_string();
        let mut args = vec!["--tcp", tcp.as_str()];
        args.extend_from_slice(extra);
        let server = Server::start(dir, &args);
        // The first connection that succeeds is a host: let it hear the boot, close it, and
        // give the server a moment to see it leave.
        let deadline = Instant::now() + Duration::from_secs(10);
        let probe = loop {
            if let Ok(probe) = TcpStream::connect(addr) {
                break probe;
            }
            assert!(Instant::now() < deadline, "the server never listened");
            thread::sleep(Duration::from_millis(20));
        };
        probe.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        lines_through(&mut BufReader::new(probe), "echo:Machine");
        thread::sleep(Duration::from_millis(300));
        (server, addr)
    }

    fn pid(&self) -> i32 {
        self.run.as_ref().unwrap().pid()
    }

    /// Stops the server as Ctrl-C does and returns how its run went.
    pub(crate) fn stop(mut self) -> Outcome {
        let run = self.run.take().unwrap();
        run.signal(libc::SIGTERM);
        run.wait()
    }

    /// CPU time (user + system, in clock ticks of 10 ms) the server uses over one second.
    fn cpu_ticks_over_a_second(&self) -> u64 {
        let ticks = || {
            let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.pid())).unwrap();
            // Fields after the command name (which ends with ')'): utime and stime are 14 and 15.
            let fields: Vec<&str> = stat.rsplit_once(") ").unwrap().1.split(' ').collect();
            fields[11].parse::<u64>().unwrap() + fields[12].parse::<u64>().unwrap()
        };
        let before = ticks();
        thread::sleep(Duration::from_secs(1));
        ticks() - before
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(run) = self.run.take() {
            run.signal(libc::SIGKILL);
            run.wait();
        }
    }
}

/// A breaking session found `gweave serve ... 2>&1 | head -1` killed by SIGPIPE at Ctrl-C (its
/// summary printed to the closed pipe) before it removed its session folder, left in /tmp.
#[test]
fn serve_with_standard_error_closed_leaves_no_session_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let addr = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    /// Killed if an assertion fails before the server stopped.
    struct Child(std::process::Child);
    impl Drop for Child {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_gweave"))
        .args(["serve", "--tcp", &addr.to_string()])
        .env("TMPDIR", tmp.path())
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut child = Child(child);
    // Its first line says it listens; then the reader goes, as `head -1` goes.
    let mut stderr = BufReader::new(child.0.stderr.take().unwrap());
    let mut first = String::new();
    stderr.read_line(&mut first).unwrap();
    assert!(first.contains("listening on"), "{first}");
    // The session folder comes a moment after that line.
    let deadline = Instant::now() + Duration::from_secs(10);
    while std::fs::read_dir(tmp.path()).unwrap().count() == 0 {
        assert!(Instant::now() < deadline, "no session folder in {}", tmp.path().display());
        thread::sleep(Duration::from_millis(20));
    }
    drop(stderr);
    // SAFETY: kill(2) on the child's own pid.
    unsafe { libc::kill(child.0.id() as i32, libc::SIGINT) };
    let deadline = Instant::now() + Duration::from_secs(10);
    while child.0.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "serve did not stop");
        thread::sleep(Duration::from_millis(20));
    }
    let left: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// The boot lines and the answer to one M105, checked.
#[track_caller]
fn assert_fresh_board_answers_m105(got: &[String]) {
    assert_eq!(got.first().map(String::as_str), Some("start"), "{got:?}");
    assert!(got.last().unwrap().starts_with("ok T:25.00"), "{got:?}");
    assert!(!got.iter().any(|l| l.contains("Unknown command")), "{got:?}");
}

/// Regression: the first connection right after an abrupt close (RST) was accepted and closed
/// as if a second host had come while the first was served.
#[test]
fn serve_tcp_a_connection_right_after_a_reset_is_served() {
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = Server::tcp(dir.path(), &[]);
    for _ in 0..5 {
        let (mut host, mut reader) = connect(addr);
        lines_through(&mut reader, "echo:Machine");
        host.write_all(b"M105\n").unwrap();
        drop(reader);
        reset(host);
        let (mut next, mut reader) = connect(addr);
        next.write_all(b"M105\n").unwrap();
        assert_fresh_board_answers_m105(&lines_through(&mut reader, "ok"));
    }
    server.stop().assert_ok();
}

/// Regression: replies to a host that had already closed were written with write(2), and the
/// CLI's default SIGPIPE action killed the server.
#[test]
fn serve_tcp_hosts_that_close_at_once_do_not_kill_the_server() {
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = Server::tcp(dir.path(), &[]);
    for _ in 0..5 {
        drop(TcpStream::connect(addr).unwrap());
        thread::sleep(Duration::from_millis(50));
    }
    let (mut host, mut reader) = connect(addr);
    host.write_all(b"M105\n").unwrap();
    assert_fresh_board_answers_m105(&lines_through(&mut reader, "ok"));
    server.stop().assert_ok();
}

/// Regression: a second host was closed without a word while an idle one held the board.
/// Design: one host at a time; a newcomer is told why and closed, and is served once the board
/// is free.
#[test]
fn serve_tcp_a_second_host_is_refused_while_an_idle_one_is_connected() {
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = Server::tcp(dir.path(), &[]);
    let (idle, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    thread::sleep(Duration::from_millis(500));
    let (mut other, _) = connect(addr);
    let mut said = String::new();
    other.read_to_string(&mut said).unwrap();
    assert_eq!(said, "echo:busy: another host is connected\n");
    drop((idle, reader));
    thread::sleep(Duration::from_millis(300));
    let (mut next, mut reader) = connect(addr);
    next.write_all(b"M105\n").unwrap();
    assert_fresh_board_answers_m105(&lines_through(&mut reader, "ok"));
    server.stop().assert_ok();
}

/// Opens the pty as a host does, non-blocking.
fn open_pty(link: &Path) -> File {
    OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
        .open(link)
        .unwrap()
}

/// Reads from a non-blocking pty host until `done` holds for the text, failing after 10 s.
fn read_pty_until(host: &mut File, done: impl Fn(&str) -> bool) -> String {
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut bytes = Vec::new();
    let mut buf = [0u8; 4096];
    while !done(&String::from_utf8_lossy(&bytes)) {
        assert!(Instant::now() < deadline, "timed out after {:?}", String::from_utf8_lossy(&bytes));
        match host.read(&mut buf) {
            Ok(n) => bytes.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => thread::sleep(Duration::from_millis(10)),
            Err(e) => panic!("{e}"),
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Regression (#20): a pty host that wrote 3 000 x M105 and closed without reading left the
/// server spinning at 65 % of a core; the next host got no `start`, stale `ok T:` lines and
/// its first command glued to a fragment (`Unknown command: "M10M105"`).
#[test]
fn serve_pty_a_host_that_hangs_up_with_replies_unread_leaves_a_fresh_board() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("gweave0");
    let server = Server::start(dir.path(), &["--pty", link.to_str().unwrap()]);
    let deadline = Instant::now() + Duration::from_secs(10);
    while !link.exists() {
        assert!(Instant::now() < deadline, "no pty link");
        thread::sleep(Duration::from_millis(20));
    }
    let mut host = open_pty(&link);
    let burst = b"M105\n".repeat(3000);
    let mut sent = 0;
    let stalled = Instant::now() + Duration::from_secs(5);
    while sent < burst.len() && Instant::now() < stalled {
        match host.write(&burst[sent..]) {
            Ok(n) => sent += n,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => thread::sleep(Duration::from_millis(5)),
            Err(e) => panic!("{e}"),
        }
    }
    thread::sleep(Duration::from_millis(200));
    drop(host);
    thread::sleep(Duration::from_millis(300));
    // Nobody is connected: the server waits, it does not spin.
    let ticks = server.cpu_ticks_over_a_second();
    assert!(ticks <= 5, "{ticks} ticks of CPU in 1 s with no host");
    let mut host = open_pty(&link);
    host.write_all(b"M105\n").unwrap();
    let text = read_pty_until(&mut host, |t| t.contains("ok T:"));
    let got: Vec<String> = text.lines().map(str::to_string).collect();
    assert_fresh_board_answers_m105(&got);
    drop(host);
    server.stop().assert_ok();
}

/// A 20 MB line from the host (with `--log`): the server stays small, refuses the line as
/// Marlin's buffer would, answers the next command, and logs the line's head and length only.
#[test]
fn serve_a_20_mb_line_keeps_memory_and_log_small() {
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = Server::tcp(dir.path(), &["--log", "session.log"]);
    let (mut host, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    let chunk = vec![b'X'; 1 << 20];
    for _ in 0..20 {
        host.write_all(&chunk).unwrap();
    }
    host.write_all(b"\nM105\n").unwrap();
    let got = lines_through(&mut reader, "ok T:");
    assert_eq!(got[..2], ["Error:Line too long, Last Line: 0", "ok"]);
    drop((host, reader));
    let outcome = server.stop();
    outcome.assert_ok().assert_peak_under(64.0);
    let log = std::fs::read_to_string(dir.path().join("session.log")).unwrap();
    assert!(log.len() < 4096, "log of {} bytes", log.len());
    assert!(log.contains("... (20971520 bytes, cut at 256)\n"), "{log}");
}

/// Every line a TCP host receives within `limit` (the host stays quiet meanwhile).
fn lines_within(reader: &mut BufReader<TcpStream>, limit: Duration) -> Vec<String> {
    let deadline = Instant::now() + limit;
    let mut got = Vec::new();
    let mut line = String::new();
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        reader.get_ref().set_read_timeout(Some(left.max(Duration::from_millis(1)))).unwrap();
        match reader.read_line(&mut line) {
            Ok(0) => break,
            Ok(_) if line.ends_with('\n') => got.push(std::mem::take(&mut line).trim_end().to_string()),
            Ok(_) => {}
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {}
            Err(e) => panic!("{e}"),
        }
    }
    got
}

/// Regression (#20 item 1): the board's clock stood still while the host was idle, so the
/// `M155` auto-reports that M115 promises never came and OctoPrint declared the printer dead.
#[test]
fn serve_an_idle_host_receives_m155_auto_reports() {
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = Server::tcp(dir.path(), &[]);
    let (mut host, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    host.write_all(b"M155 S1\n").unwrap();
    assert_eq!(lines_through(&mut reader, "ok"), ["ok"]);
    let got = lines_within(&mut reader, Duration::from_millis(2500));
    let reports = got.iter().filter(|l| l.starts_with(" T:25.00 /0.00 B:25.00")).count();
    assert!(reports >= 2, "{got:?}");
    drop((host, reader));
    server.stop().assert_ok();
}

/// Regression (#20 item 1): a target set while the host was idle never heated (M105 still read
/// `T:25.00 /200.00` after 10 s).
#[test]
fn serve_a_target_set_while_idle_heats() {
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = Server::tcp(dir.path(), &[]);
    let (mut host, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    host.write_all(b"M104 S200\n").unwrap();
    lines_through(&mut reader, "ok");
    thread::sleep(Duration::from_secs(3));
    host.write_all(b"M105\n").unwrap();
    let got = lines_through(&mut reader, "ok T:");
    let reading: f64 = got.last().unwrap()["ok T:".len()..].split(' ').next().unwrap().parse().unwrap();
    assert!(reading > 25.0, "{got:?}");
    drop((host, reader));
    server.stop().assert_ok();
}

/// A host that sends values out of range (a temperature past any hotend, a negative one, a fan
/// past 255, a word that is not a number, a dwell of days) gets the uniform refusal for each
/// and an `ok`, and the board keeps what was in force (the target set before).
#[test]
fn serve_values_out_of_range_are_refused_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = Server::tcp(dir.path(), &[]);
    let (mut host, mut reader) = connect(addr);
    lines_through(&mut reader, "echo:Machine");
    host.write_all(b"M104 S200\n").unwrap();
    assert_eq!(lines_through(&mut reader, "ok"), ["ok"]);
    for (line, refusal) in [
        ("M104 S600", "echo:M104 S = 600 is out of range: 0 to 500 °C"),
        ("M104 S-5", "echo:M104 S = -5 is out of range: 0 to 500 °C"),
        ("M104 Snan", "echo:M104 S = nan is out of range: 0 to 500 °C"),
        ("M106 S300", "echo:M106 S = 300 is out of range: 0 to 255"),
        ("G4 S999999", "echo:G4 S = 999999 is out of range: 0 to 86400 s"),
    ] {
        host.write_all(format!("{line}\n").as_bytes()).unwrap();
        assert_eq!(lines_through(&mut reader, "ok"), [refusal, "ok"], "{line}");
    }
    host.write_all(b"M105\n").unwrap();
    let got = lines_through(&mut reader, "ok T:");
    assert!(got.last().unwrap().contains(" /200.00 "), "{got:?}");
    drop((host, reader));
    server.stop().assert_ok();
}
