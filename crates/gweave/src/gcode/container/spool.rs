//! Inputs that can be read only once (standard input as `-`, a pipe, a FIFO, `/dev/stdin`),
//! copied to an unnamed temporary file the first time they are opened, so that a command can
//! read them twice as it reads a file: once for the flavour at the file's ends, once for the
//! pass (`Run`), or twice in a two-pass command.
//!
//! The copy lives on disk, not in memory, and has no name: the system removes it when the
//! process exits, however it exits (a signal included), so it needs none of the clean-up of
//! [`crate::gcode::temp`]. Each later open of the same path reads the copy from its start, with
//! its own position.
//!
//! A stream may have no end (`yes G1 X1 | gweave stats -`, `gweave stats /dev/zero`), so a copy
//! stops at [`DEFAULT_LIMIT`] bytes (or `GWEAVE_SPOOL_LIMIT`, e.g. `512M`, `20G`) with an error
//! saying so, rather than fill the temporary directory. A copy that cannot be written names the
//! temporary directory (`$TMPDIR`), not the input.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// The path that names standard input.
pub(crate) const STDIN: &str = "-";

/// Most bytes copied from one stream: larger than any sliced file (the largest real ones are a
/// few GiB of text), small enough that an endless stream stops before a temporary directory
/// on a small disk is full.
pub(crate) const DEFAULT_LIMIT: u64 = 8 << 30;

/// The environment variable that sets another limit: bytes, or with `K`, `M` or `G` (powers
/// of 1024).
pub(crate) const LIMIT_VAR: &str = "GWEAVE_SPOOL_LIMIT";

/// Copies made so far, by the path that named them.
static SPOOLS: Mutex<Vec<(PathBuf, Arc<File>)>> = Mutex::new(Vec::new());

/// An input opened for reading: a regular file, or the copy of a stream.
pub(crate) enum Raw {
    File(File),
    Spool { file: Arc<File>, pos: u64 },
}

/// Whether `path` names standard input.
pub(crate) fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == STDIN
}

/// Opens `path` (`-`: standard input), copying a stream to a spool the first time.
pub(crate) fn open(path: &Path) -> io::Result<Raw> {
    // Looked up before anything is opened: opening a FIFO again would wait for a new writer.
    let mut spools = SPOOLS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, file)) = spools.iter().find(|(p, _)| p == path) {
        return Ok(Raw::Spool { file: Arc::clone(file), pos: 0 });
    }
    let copy = if is_stdin(path) {
        spool(&mut io::stdin().lock())?
    } else {
        let mut file = File::open(path)?;
        let meta = file.metadata()?;
        if meta.is_file() || meta.is_dir() {
            return Ok(Raw::File(file));
        }
        spool(&mut file)?
    };
    let file = Arc::new(copy);
    spools.push((path.to_path_buf(), Arc::clone(&file)));
    Ok(Raw::Spool { file, pos: 0 })
}

/// The limit in force: [`LIMIT_VAR`] if set (an error if it cannot be read), else
/// [`DEFAULT_LIMIT`].
fn limit() -> io::Result<u64> {
    let Some(text) = std::env::var_os(LIMIT_VAR) else {
        return Ok(DEFAULT_LIMIT);
    };
    let text = text.to_string_lossy();
    let (digits, shift) = match text.trim().to_ascii_uppercase() {
        t if t.ends_with('K') => (t[..t.len() - 1].to_owned(), 10),
        t if t.ends_with('M') => (t[..t.len() - 1].to_owned(), 20),
        t if t.ends_with('G') => (t[..t.len() - 1].to_owned(), 30),
        t => (t, 0),
    };
    digits.parse::<u64>().ok().and_then(|n| n.checked_mul(1 << shift)).ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{LIMIT_VAR}={text}: give a size in bytes, or with K, M or G (e.g. 512M)"),
        )
    })
}

/// Copies `stream` into a new unnamed file in the temporary directory, at most [`limit`] bytes.
fn spool(stream: &mut dyn Read) -> io::Result<File> {
    let limit = limit()?;
    let dir = std::env::temp_dir();
    // A failed write is the temporary directory's problem (full, read-only, gone): say which.
    let in_dir = |e: io::Error| {
        io::Error::new(e.kind(), format!("copying the stream to a file in {} ($TMPDIR): {e}", dir.display()))
    };
    let mut copy = tempfile::tempfile().map_err(in_dir)?;
    let mut buf = vec![0u8; 1 << 16];
    let mut copied: u64 = 0;
    loop {
        let n = match stream.read(&mut buf) {
            Ok(0) => return Ok(copy),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        copied += n as u64;
        if copied > limit {
            return Err(io::Error::other(format!(
                "the stream is longer than the limit of {} copied to the temporary directory \
                     ({LIMIT_VAR} sets another)",
                size_text(limit)
            )));
        }
        copy.write_all(&buf[..n]).map_err(in_dir)?;
    }
}

/// `bytes` as the limit is written: `8 GiB`, `512 MiB`, `1000 bytes`.
fn size_text(bytes: u64) -> String {
    match bytes {
        b if b >= 1 << 30 && b % (1 << 30) == 0 => format!("{} GiB", b >> 30),
        b if b >= 1 << 20 && b % (1 << 20) == 0 => format!("{} MiB", b >> 20),
        b if b >= 1 << 10 && b % (1 << 10) == 0 => format!("{} KiB", b >> 10),
        b => format!("{b} bytes"),
    }
}

impl Raw {
    /// The input's length in bytes.
    pub(crate) fn size(&self) -> io::Result<u64> {
        match self {
            Raw::File(f) => Ok(f.metadata()?.len()),
            Raw::Spool { file, .. } => Ok(file.metadata()?.len()),
        }
    }
}

impl Read for Raw {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Raw::File(f) => f.read(buf),
            Raw::Spool { file, pos } => {
                let n = read_at(file, buf, *pos)?;
                *pos += n as u64;
                Ok(n)
            }
        }
    }
}

impl Seek for Raw {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        match self {
            Raw::File(f) => f.seek(to),
            Raw::Spool { file, pos } => {
                let len = file.metadata()?.len();
                let target = match to {
                    SeekFrom::Start(n) => Some(n),
                    SeekFrom::Current(d) => pos.checked_add_signed(d),
                    SeekFrom::End(d) => len.checked_add_signed(d),
                };
                *pos = target
                    .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "seek before the start"))?;
                Ok(*pos)
            }
        }
    }
}

#[cfg(unix)]
fn read_at(file: &File, buf: &mut [u8], pos: u64) -> io::Result<usize> {
    std::os::unix::fs::FileExt::read_at(file, buf, pos)
}

#[cfg(windows)]
fn read_at(file: &File, buf: &mut [u8], pos: u64) -> io::Result<usize> {
    std::os::windows::fs::FileExt::seek_read(file, buf, pos)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A FIFO is copied once; every open reads the whole copy with its own position.
    #[cfg(unix)]
    #[test]
    fn a_fifo_is_read_once_and_opened_twice() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("in.gcode");
        let c_path = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo reads a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c_path.as_ptr(), 0o600) }, 0);
        let writer = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::write(fifo, b"G1 X1\nG1 X2\n").unwrap())
        };
        let mut a = open(&fifo).unwrap();
        writer.join().unwrap();
        let mut b = open(&fifo).unwrap();
        let mut head = [0u8; 6];
        a.read_exact(&mut head).unwrap();
        let mut all = Vec::new();
        b.read_to_end(&mut all).unwrap();
        assert_eq!((&head, all.as_slice()), (b"G1 X1\n", b"G1 X1\nG1 X2\n".as_slice()));
        a.seek(SeekFrom::End(-6)).unwrap();
        let mut rest = String::new();
        a.read_to_string(&mut rest).unwrap();
        assert_eq!(rest, "G1 X2\n");
        assert_eq!(a.size().unwrap(), 12);
    }
}
