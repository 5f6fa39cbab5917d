//! Decoding on a thread of its own, ahead of the reader: a binary G-code file's blocks are
//! decompressed and decoded while the line reader parses the text of the previous ones, so
//! reading a `.bgcode` costs about the time of the slower of the two rather than their sum (two
//! cores). At most `DEPTH` decoded chunks wait in the channel: memory stays bounded.
//!
//! The decoder appends its text to the chunk it hands over ([`Text::text_into`]), and the
//! reader hands emptied chunks back to be filled again: a byte of text is written once by the
//! decoder and copied once, into the reader's buffer. (Read through [`Read`], each byte was
//! copied once more, into a chunk allocated and zeroed for each hand-over.)

use std::io::{self, Read};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Mutex;
use std::thread;

/// Chunks decoded ahead of the reader.
const DEPTH: usize = 4;
/// Emptied chunks waiting to be filled again.
const SPARE: usize = 2;
/// Text a chunk holds before it is handed over (a block's text more at most).
const CHUNK: usize = 1 << 18;

/// A source of text decoded a piece at a time.
pub(crate) trait Text {
    /// Appends the next piece of text to `out`; returns its length, 0 at the end.
    fn text_into(&mut self, out: &mut Vec<u8>) -> io::Result<usize>;
}

/// A reader fed by a decoding thread.
pub(crate) struct Ahead {
    /// In mutexes only to be `Sync` (Python's reader object must be); never contended.
    chunks: Mutex<Receiver<io::Result<Vec<u8>>>>,
    /// Emptied chunks, back to the decoding thread.
    spare: Mutex<SyncSender<Vec<u8>>>,
    chunk: Vec<u8>,
    pos: usize,
    done: bool,
}

impl Ahead {
    /// Decodes `source` on a new thread. The thread ends at the end of the source, at its first
    /// error (passed on to the reader), or when the reader is dropped.
    pub(crate) fn new<T: Text + Send + 'static>(mut source: T) -> Ahead {
        let (tx, rx) = sync_channel(DEPTH);
        // Chunks alive: DEPTH in the channel, one being filled, one being read, SPARE back.
        let (spare_tx, spare_rx) = sync_channel::<Vec<u8>>(SPARE);
        thread::spawn(move || loop {
            let mut chunk = spare_rx.try_recv().unwrap_or_else(|_| Vec::with_capacity(CHUNK));
            chunk.clear();
            let (ended, error) = loop {
                match source.text_into(&mut chunk) {
                    Ok(0) => break (true, None),
                    Ok(_) if chunk.len() >= CHUNK => break (false, None),
                    Ok(_) => {}
                    Err(e) => break (true, Some(e)),
                }
            };
            // The text before an error is passed on first.
            if !chunk.is_empty() && tx.send(Ok(chunk)).is_err() {
                break;
            }
            if let Some(e) = error {
                let _ = tx.send(Err(e));
            }
            if ended {
                break;
            }
        });
        Ahead { chunks: Mutex::new(rx), spare: Mutex::new(spare_tx), chunk: Vec::new(), pos: 0, done: false }
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
                    let used = std::mem::replace(&mut self.chunk, chunk?);
                    // Refused when the spares are full or the thread has ended: then dropped.
                    let _ = self.spare.get_mut().unwrap_or_else(|e| e.into_inner()).try_send(used);
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

    /// A reader's bytes, in pieces of at most 100 000.
    struct Pieces<R>(R);
    impl<R: Read> Text for Pieces<R> {
        fn text_into(&mut self, out: &mut Vec<u8>) -> io::Result<usize> {
            (&mut self.0).take(100_000).read_to_end(out)
        }
    }

    #[test]
    fn passes_every_byte_then_the_error() {
        let bytes: Vec<u8> = (0..3_000_000u32).map(|i| (i % 251) as u8).collect();
        let mut all = Vec::new();
        Ahead::new(Pieces(io::Cursor::new(bytes.clone()))).read_to_end(&mut all).unwrap();
        assert!(all == bytes);
        let failing = io::Cursor::new(vec![1u8; 10]).chain(Failing);
        let mut ahead = Ahead::new(Pieces(failing));
        let mut first = Vec::new();
        let err = ahead.read_to_end(&mut first).unwrap_err();
        assert_eq!(err.to_string(), "block 3: checksum mismatch");
        // The text before the error is passed on first.
        assert_eq!(first, vec![1u8; 10]);
    }

    struct Failing;
    impl Read for Failing {
        fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
            Err(io::Error::new(io::ErrorKind::InvalidData, "block 3: checksum mismatch"))
        }
    }
}
