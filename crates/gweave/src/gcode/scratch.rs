//! A scratch file: a transform's output held beside the output the user named until the
//! finishing step has measured it and copied it there with true metadata, read by another
//! thread while it grows.
//!
//! The finishing step (gweave-sim's `finish`) makes a [`ScratchFile`] and hands its
//! [`Target::Scratch`] to the transform, which opens an [`Output`](super::writer::Output) on it
//! as on any target. That output writes straight into the file: no second temporary file and
//! rename (the scratch file is itself a [`TempFile`], removed when dropped and on a signal), and
//! no container (the finishing copy compresses). After each write the scratch file counts the
//! bytes that reached it and wakes its reader ([`ScratchFile::follow`]), which sleeps at the
//! file's end until then: it reads each write as soon as it is made and spends nothing looking
//! for more. The writer never waits for the reader, and nothing is held but the reader's
//! buffer, whatever the file's size.

use std::fmt;
use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

use super::temp::TempFile;
use super::writer::Target;
use crate::interrupt::Token;

/// A scratch file and its reader's side: made by the one who reads it back (the finishing
/// step), removed when dropped.
pub struct ScratchFile {
    /// Kept for its removal on drop (and on a signal, by the registry).
    file: TempFile,
    scratch: Scratch,
}

/// The writer's side of a [`ScratchFile`], which [`Target::Scratch`] carries (a clone is the
/// same file).
#[derive(Clone)]
pub struct Scratch(Arc<Shared>);

struct Shared {
    path: PathBuf,
    /// The name errors in writing the file show: the output it stands for, which the user
    /// named (they know nothing of the scratch file).
    shown: PathBuf,
    /// A handle of the temporary file: writes go through it at the file's one offset.
    file: File,
    /// The creating thread's run, checked before every write as a [`TempFile`] does.
    stop: Option<Token>,
    growth: Mutex<Growth>,
    /// Signalled on every change of `growth`.
    grown: Condvar,
}

/// What the writer has done so far.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Growth {
    /// Bytes written into the file (a count that only rises: the reader waits for it to move).
    written_bytes: u64,
    end: End,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum End {
    Writing,
    /// The whole file is written: its end is the file's.
    Done,
    /// The writer failed or was stopped: the file will not be finished.
    Failed,
}

impl ScratchFile {
    /// Makes a scratch file in `dir` standing for `output` (the name errors show; `None`:
    /// standard output or a device, shown as the scratch file's own name).
    pub fn new_in(dir: &Path, output: Option<&Path>) -> io::Result<ScratchFile> {
        let file = TempFile::new_in(dir)?;
        let path = file.path().to_path_buf();
        let shared = Shared {
            shown: output.unwrap_or(&path).to_path_buf(),
            path,
            file: file.as_file().try_clone()?,
            stop: crate::interrupt::Token::current(),
            growth: Mutex::new(Growth { written_bytes: 0, end: End::Writing }),
            grown: Condvar::new(),
        };
        Ok(ScratchFile { file, scratch: Scratch(Arc::new(shared)) })
    }

    /// The target a transform writes the file through.
    pub fn target(&self) -> Target {
        Target::Scratch(self.scratch.clone())
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        self.file.path()
    }

    /// A reader of the file from its start, following it as it is written: a read at the
    /// file's current end sleeps until the writer writes more, ends (returns 0) only once the
    /// writer is done, and fails once it has failed. Call [`ScratchFile::writing`] around the
    /// write.
    pub fn follow(&self) -> io::Result<Growing> {
        Ok(Growing {
            file: File::open(self.path())?,
            scratch: self.scratch.clone(),
            #[cfg(test)]
            empty_reads: 0,
        })
    }

    /// Says how the write ends: [`Writing::end`], or failed if dropped without it (an error
    /// returned early, a panic), so that a reader following the file never waits for bytes
    /// that will not come.
    pub fn writing(&self) -> Writing<'_> {
        Writing { scratch: &self.scratch, ended: false }
    }
}

/// The write of a [`ScratchFile`] under way ([`ScratchFile::writing`]).
pub struct Writing<'a> {
    scratch: &'a Scratch,
    ended: bool,
}

impl Writing<'_> {
    /// The write has ended: `whole` if the writer wrote and flushed the whole file, else it
    /// failed.
    pub fn end(mut self, whole: bool) {
        self.scratch.end(if whole { End::Done } else { End::Failed });
        self.ended = true;
    }
}

impl Drop for Writing<'_> {
    fn drop(&mut self) {
        if !self.ended {
            self.scratch.end(End::Failed);
        }
    }
}

impl Scratch {
    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.0.path
    }

    /// The name errors in writing it show: the output it stands for.
    pub fn shown(&self) -> &Path {
        &self.0.shown
    }

    fn growth(&self) -> MutexGuard<'_, Growth> {
        // A count and a state stay valid whatever a panicking holder did.
        self.0.growth.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn end(&self, end: End) {
        let mut growth = self.growth();
        growth.end = end;
        self.0.grown.notify_all();
    }

    /// Sleeps until the writer has written past `written_bytes` or ended.
    fn wait_past(&self, written_bytes: u64) {
        let growth = self.growth();
        let still = |g: &mut Growth| g.end == End::Writing && g.written_bytes <= written_bytes;
        drop(self.0.grown.wait_while(growth, still).unwrap_or_else(|e| e.into_inner()));
    }
}

impl Write for Scratch {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if let Some(stop) = &self.0.stop {
            stop.check()?;
        }
        let n = (&self.0.file).write(buf)?;
        let mut growth = self.growth();
        growth.written_bytes += n as u64;
        self.0.grown.notify_all();
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// Two handles of one scratch file are equal (a target compares as the file it writes).
impl PartialEq for Scratch {
    fn eq(&self, other: &Scratch) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Eq for Scratch {}

impl fmt::Debug for Scratch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Scratch").field("path", &self.0.path).field("shown", &self.0.shown).finish()
    }
}

/// A [`ScratchFile`] read as it is written ([`ScratchFile::follow`]).
pub struct Growing {
    file: File,
    scratch: Scratch,
    /// Reads that found the file's end while the writer was still writing: each is followed
    /// by one sleep until the next write, so a reader that is woken makes one per write, and
    /// one that polls makes one per poll (the tests hold it to the first).
    #[cfg(test)]
    empty_reads: u64,
}

impl Read for Growing {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            // The writer's state is taken before the file is read: bytes written before `Done`
            // are then seen by this read, so an empty read after `Done` is the file's end.
            let growth = *self.scratch.growth();
            if growth.end == End::Failed {
                return Err(io::Error::other("the transform writing the file failed"));
            }
            let n = self.file.read(buf)?;
            if n > 0 || growth.end == End::Done {
                return Ok(n);
            }
            #[cfg(test)]
            {
                self.empty_reads += 1;
            }
            // At the end of what was written when the state was taken: sleep until the
            // writer writes more (or ends). Waiting on the count, not on this reader's
            // offset, never misses a write and never spins.
            self.scratch.wait_past(growth.written_bytes);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::mpsc;
    use std::time::Duration;

    use super::*;

    fn writer_of(scratch: &ScratchFile) -> Scratch {
        match scratch.target() {
            Target::Scratch(s) => s,
            t => unreachable!("{t:?}"),
        }
    }

    /// The reader gets every byte in order, across the writer's pauses, and its end only once
    /// the writer is done.
    #[test]
    fn a_growing_file_is_read_whole_behind_its_writer() {
        let dir = tempfile::tempdir().unwrap();
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let lines: Vec<String> = (0..2000).map(|i| format!("G1 X{i} Y{}\n", i * 7)).collect();
        let mut growing = scratch.follow().unwrap();
        let read = std::thread::scope(|s| {
            let reader = s.spawn(move || {
                let mut text = String::new();
                growing.read_to_string(&mut text).map(|_| text)
            });
            let (mut out, writing) = (writer_of(&scratch), scratch.writing());
            for chunk in lines.chunks(300) {
                out.write_all(chunk.concat().as_bytes()).unwrap();
                std::thread::sleep(Duration::from_millis(5));
            }
            writing.end(true);
            reader.join().unwrap()
        });
        assert_eq!(read.unwrap(), lines.concat());
    }

    /// Regression (issue 35): the reader polled the file's end every 2 ms. Woken by the
    /// writer, it reads each write before the next is made, and finds the file's end at most
    /// once per write: the writer here waits for the reader to have read a piece, then pauses
    /// 20 ms before writing the next, in which a reader polling every 2 ms would read the
    /// file's end about ten times (a reader that is never woken fails after 10 s).
    #[test]
    fn the_reader_is_woken_by_each_write() {
        const PIECES: u64 = 20;
        let dir = tempfile::tempdir().unwrap();
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let mut growing = scratch.follow().unwrap();
        let (read_tx, read_rx) = mpsc::channel();
        let empty_reads = std::thread::scope(|s| {
            let reader = s.spawn(move || {
                let mut buf = [0u8; 64];
                while let Ok(n @ 1..) = growing.read(&mut buf) {
                    read_tx.send(buf[..n].to_vec()).unwrap();
                }
                growing.empty_reads
            });
            let (mut out, writing) = (writer_of(&scratch), scratch.writing());
            for i in 0..PIECES {
                std::thread::sleep(Duration::from_millis(20));
                let piece = format!("G1 X{i}\n");
                out.write_all(piece.as_bytes()).unwrap();
                let got = read_rx.recv_timeout(Duration::from_secs(10));
                assert_eq!(got.as_deref(), Ok(piece.as_bytes()), "piece {i}");
            }
            writing.end(true);
            reader.join().unwrap()
        });
        // At most one empty read before each piece and one before the end: 21, where polling
        // makes about 200.
        assert!(empty_reads <= PIECES + 1, "{empty_reads} empty reads for {PIECES} writes");
    }

    /// A writer that fails (or unwinds: the write ends as failed when dropped) ends the read
    /// with an error, not with a short file taken as whole.
    #[test]
    fn a_failed_writer_fails_the_read() {
        let dir = tempfile::tempdir().unwrap();
        for explicit in [true, false] {
            let scratch = ScratchFile::new_in(dir.path(), Some(Path::new("out.gcode"))).unwrap();
            writer_of(&scratch).write_all(b"G1 X1\n").unwrap();
            let mut growing = scratch.follow().unwrap();
            let read = std::thread::scope(|s| {
                let reader = s.spawn(move || growing.read_to_end(&mut Vec::new()));
                let writing = scratch.writing();
                std::thread::sleep(Duration::from_millis(10));
                match explicit {
                    true => writing.end(false),
                    false => drop(writing),
                }
                reader.join().unwrap()
            });
            assert!(read.is_err(), "{read:?}");
        }
    }

    /// The file is removed with its owner, whatever handles of its writer are left.
    #[test]
    fn the_file_goes_with_its_owner() {
        let dir = tempfile::tempdir().unwrap();
        let scratch = ScratchFile::new_in(dir.path(), Some(Path::new("out.gcode"))).unwrap();
        let target = scratch.target();
        let Target::Scratch(writer) = &target else { unreachable!() };
        assert_eq!((writer.path(), writer.shown()), (scratch.path(), Path::new("out.gcode")));
        assert_eq!(target, scratch.target());
        drop(scratch);
        assert_eq!(fs_entries(dir.path()), 0);
    }

    fn fs_entries(dir: &Path) -> usize {
        std::fs::read_dir(dir).unwrap().count()
    }
}
