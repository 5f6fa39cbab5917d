//! A file read while another thread writes it: the transform's scratch file, measured as it
//! grows so that the measure overlaps the transform instead of following it.
//!
//! The writer (the transform, on the caller's thread) writes the file through its own buffer, a
//! 1 MiB write at a time; the reader reads what has reached the file and, at its current end,
//! waits for more until the writer says it is done (then the end is the file's) or failed (then
//! the read fails and the measure is thrown away). Nothing is held but the reader's buffer: the
//! memory does not grow with the file, and the writer never waits for the reader.

use std::fs::File;
use std::io::{self, Read};
use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Duration;

/// How the writer stands, shared with the reader.
#[derive(Debug, Default)]
pub(super) struct Writer(AtomicU8);

const WRITING: u8 = 0;
const DONE: u8 = 1;
const FAILED: u8 = 2;

/// How long the reader sleeps at the file's end before looking again: a transform writes
/// about 1 MiB in 5-10 ms, so a reader that has caught up wakes a few times per write, which
/// costs nothing next to the work either side does.
const WAIT: Duration = Duration::from_millis(2);

impl Writer {
    /// The writer has written and flushed the whole file.
    pub(super) fn done(&self) {
        self.0.store(DONE, Ordering::Release);
    }

    /// The writer failed (or was stopped): the file will not be finished.
    pub(super) fn failed(&self) {
        self.0.store(FAILED, Ordering::Release);
    }

    fn state(&self) -> u8 {
        self.0.load(Ordering::Acquire)
    }
}

/// Reads `file` as `writer` writes it: a read at the file's current end waits for more bytes,
/// ends (returns 0) only once the writer is done, and fails once it has failed.
pub(super) struct Growing<'a> {
    pub(super) file: File,
    pub(super) writer: &'a Writer,
}

impl Read for Growing<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            // The state is read before the file: bytes flushed before `done` are then seen
            // by the read that follows, so the end read after `done` is the file's end.
            let state = self.writer.state();
            let n = self.file.read(buf)?;
            match (n, state) {
                (0, WRITING) => std::thread::sleep(WAIT),
                (_, FAILED) => return Err(io::Error::other("the transform writing the file failed")),
                _ => return Ok(n),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    /// The reader gets every byte in order, across the writer's pauses, and its end only once
    /// the writer is done.
    #[test]
    fn a_growing_file_is_read_whole_behind_its_writer() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scratch");
        let mut out = File::create(&path).unwrap();
        let writer = Writer::default();
        let lines: Vec<String> = (0..2000).map(|i| format!("G1 X{i} Y{}\n", i * 7)).collect();
        let read = std::thread::scope(|s| {
            let reader = s.spawn(|| {
                let mut text = String::new();
                let mut growing = Growing { file: File::open(&path).unwrap(), writer: &writer };
                growing.read_to_string(&mut text).map(|_| text)
            });
            for chunk in lines.chunks(300) {
                out.write_all(chunk.concat().as_bytes()).unwrap();
                std::thread::sleep(Duration::from_millis(5));
            }
            writer.done();
            reader.join().unwrap()
        });
        assert_eq!(read.unwrap(), lines.concat());
    }

    /// A writer that fails ends the read with an error, not with a short file taken as whole.
    #[test]
    fn a_failed_writer_fails_the_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scratch");
        std::fs::write(&path, "G1 X1\n").unwrap();
        let writer = Writer::default();
        let read = std::thread::scope(|s| {
            let reader = s.spawn(|| {
                let mut text = Vec::new();
                Growing { file: File::open(&path).unwrap(), writer: &writer }.read_to_end(&mut text)
            });
            std::thread::sleep(Duration::from_millis(10));
            writer.failed();
            reader.join().unwrap()
        });
        assert!(read.is_err(), "{read:?}");
    }
}
