//! Helpers for tests that talk to the virtual printer over TCP as a host does (this crate's link
//! tests and the hostile tests of `gweave serve`), and a file cut short for the commands that
//! must say so. Built for tests only: `cfg(test)` here, the `test-support` feature in a
//! dev-dependency.

use std::io::{self, BufRead, BufReader};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A TCP host with a 10 s read limit: its stream and a reader of the replies.
pub fn connect(addr: SocketAddr) -> (TcpStream, BufReader<TcpStream>) {
    let stream = TcpStream::connect(addr).unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let reader = BufReader::new(stream.try_clone().unwrap());
    (stream, reader)
}

/// Reply lines up to the first that starts with `last`.
pub fn lines_through(reader: &mut impl BufRead, last: &str) -> Vec<String> {
    read_lines(reader, |got| got.last().is_some_and(|l| l.starts_with(last)))
}

/// Reply lines until `oks` of them are `ok`.
pub fn lines_until_ok(reader: &mut impl BufRead, oks: usize) -> Vec<String> {
    read_lines(reader, |got| got.iter().filter(|l| *l == "ok").count() >= oks)
}

fn read_lines(reader: &mut impl BufRead, done: impl Fn(&[String]) -> bool) -> Vec<String> {
    let mut got = Vec::new();
    while !done(&got) {
        let mut line = String::new();
        assert!(reader.read_line(&mut line).unwrap() > 0, "closed after {got:?}");
        got.push(line.trim_end().to_string());
    }
    got
}

/// Closes `stream` abruptly: with a zero linger time, close sends a reset (RST), not a FIN.
pub fn reset(stream: TcpStream) {
    use nix::libc;
    let linger = libc::linger { l_onoff: 1, l_linger: 0 };
    // SAFETY: setsockopt on a socket we own, with a pointer to a local of the stated size.
    let rc = unsafe {
        libc::setsockopt(
            std::os::fd::AsRawFd::as_raw_fd(&stream),
            libc::SOL_SOCKET,
            libc::SO_LINGER,
            (&linger as *const libc::linger).cast(),
            std::mem::size_of::<libc::linger>() as libc::socklen_t,
        )
    };
    assert_eq!(rc, 0, "{}", io::Error::last_os_error());
}

/// A PrusaSlicer fixture (the two-tool cone) written into `dir` whole and cut short, as a copy
/// or an upload stopped mid-number leaves it: cut halfway, just after a decimal point, so its
/// last line reads (`E1.` of `E1.234`), has no line ending, and the slicer's last line is
/// missing. The paths of the whole file and the cut one, and the line endings the cut keeps.
pub fn cone_cut_short(dir: &Path) -> (PathBuf, PathBuf, u64) {
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/prusaslicer/pr_cone_2tool.gcode");
    let text = std::fs::read(&fixture).unwrap();
    let cut = &text[..text.len() / 2];
    let cut = &cut[..cut.iter().rposition(|&b| b == b'.').unwrap() + 1];
    let (whole, part) = (dir.join("whole.gcode"), dir.join("cut.gcode"));
    std::fs::write(&whole, &text).unwrap();
    std::fs::write(&part, cut).unwrap();
    (whole, part, cut.iter().filter(|&&b| b == b'\n').count() as u64)
}
