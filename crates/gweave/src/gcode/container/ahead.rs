//! Decoding on a thread of its own, ahead of the reader: a binary G-code file's blocks are
//! decompressed and decoded while the line reader parses the text of the previous ones, so
//! reading a `.bgcode` costs about the time of the slower of the two rather than their sum (two
//! cores). At most `DEPTH` decoded chunks wait in the channel: memory stays bounded.

use std::io::{self, Read};
use std::sync::mpsc::{sync_channel, Receiver};
use std::sync::Mutex;
use std::thread;

/// Chunks decoded ahead of the reader.
const DEPTH: usize = 4;
/// Bytes read from the decoder per chunk.
const CHUNK: usize = 1 << 18;

/// A reader fed by a decoding thread.
pub(crate) struct Ahead {
    /// In a mutex only to be `Sync` (Python's reader object must be); never contended.
    chunks: Mutex<Receiver<io::Result<Vec<u8>>>>,
    chunk: Vec<u8>,
    pos: usize,
    done: bool,
}

impl Ahead {
    /// Reads `source` on a new thread. The thread ends at the end of the source, at its first
    /// error (passed on to the reader), or when the reader is dropped.
    pub(crate) fn new<R: Read + Send + 'static>(mut source: R) -> Ahead {
        let (tx, rx) = sync_channel(DEPTH);
        thread::spawn(move || loop {
            let mut chunk = Vec::with_capacity(CHUNK);
            match (&mut source).take(CHUNK as u64).read_to_end(&mut chunk) {
                Ok(0) => break,
                Ok(_) => {
                    if tx.send(Ok(chunk)).is_err() {
                        break;
                    }
                }
                Err(e) => {
                    let _ = tx.send(Err(e));
                    break;
                }
            }
        });
        Ahead { chunks: Mutex::new(rx), chunk: Vec::new(), pos: 0, done: false }
    }
}

impl Read for Ahead {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        while self.pos == self.chunk.len() {
            if self.done {
                return Ok(0);
            }
            let next = self.chunks.get_mut().unwrap_or_else(|e| e.into_inner()).recv();
            match next {
                Ok(chunk) => {
                    self.chunk = chunk?;
                    self.pos = 0;
                }
                // The thread has ended: the end of the source.
                Err(_) => self.done = true,
            }
        }
        let n = out.len().min(self.chunk.len() - self.pos);
        out[..n].copy_from_slice(&self.chunk[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_every_byte_then_the_error() {
        let bytes: Vec<u8> = (0..3_000_000u32).map(|i| (i % 251) as u8).collect();
        let mut all = Vec::new();
        Ahead::new(io::Cursor::new(bytes.clone())).read_to_end(&mut all).unwrap();
        assert!(all == bytes);
        let failing = io::Cursor::new(vec![1u8; 10]).chain(Failing);
        let err = Ahead::new(failing).read_to_end(&mut Vec::new()).unwrap_err();
        assert_eq!(err.to_string(), "block 3: checksum mismatch");
    }

    struct Failing;
    impl Read for Failing {
        fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
            Err(io::Error::new(io::ErrorKind::InvalidData, "block 3: checksum mismatch"))
        }
    }
}
