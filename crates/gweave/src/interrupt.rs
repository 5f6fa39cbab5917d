//! Stopping a run from outside it: the Python package's Ctrl-C.
//!
//! The command line stops on a signal by removing its scratch files and ending the process
//! (the CLI's `signals.rs`). Inside a Python interpreter the process must go on: a Ctrl-C has to
//! end the call, remove what it was writing and raise `KeyboardInterrupt`. The binding runs the
//! call on a thread of its own under a [`Token`] ([`run_under`]) and stops the token when
//! Python reports the signal; the run then fails at its next read of the input or write of an
//! output, which every long run does all the time (a 1 MiB read of G-code, a 1 MiB write), and
//! unwinds as from any I/O error: its scratch files are dropped, so no output is written.
//!
//! The token is the current thread's, taken when an input is opened ([`crate::gcode::container`])
//! or a scratch file created ([`crate::gcode::temp`]) and kept by them, so the check also works
//! on the threads a run reads or writes from (the estimator's reader, the binary G-code decoder).
//! Without a token (the command line, tests), nothing is checked.

use std::cell::RefCell;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A run's stop switch, shared by the one who may stop it and the run.
#[derive(Debug, Clone, Default)]
pub struct Token(Arc<AtomicBool>);

impl Token {
    /// A token not stopped.
    pub fn new() -> Token {
        Token::default()
    }

    /// Stops the run at its next check.
    pub fn stop(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether [`Token::stop`] was called.
    pub fn stopped(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// This thread's token, if a run here can be stopped ([`run_under`]).
    pub fn current() -> Option<Token> {
        CURRENT.with(|c| c.borrow().clone())
    }

    /// Fails once stopped, with the error [`is_stopped`] recognises.
    pub fn check(&self) -> io::Result<()> {
        if self.stopped() {
            Err(stopped_error())
        } else {
            Ok(())
        }
    }
}

thread_local! {
    static CURRENT: RefCell<Option<Token>> = const { RefCell::new(None) };
}

/// Runs `work` on this thread under `token`: inputs opened and scratch files created meanwhile
/// check it.
pub fn run_under<T>(token: &Token, work: impl FnOnce() -> T) -> T {
    struct Restore(Option<Token>);
    impl Drop for Restore {
        fn drop(&mut self) {
            CURRENT.with(|c| *c.borrow_mut() = self.0.take());
        }
    }
    let _restore = Restore(CURRENT.with(|c| c.replace(Some(token.clone()))));
    work()
}

/// Whether this thread's run was stopped: for a long loop that neither reads nor writes (a
/// preview's projection and painting), which then ends early, its result to be thrown away.
/// A thread-local read, a few nanoseconds: call it every [`CHECK_EVERY`] items.
pub(crate) fn stopped() -> bool {
    CURRENT.with(|c| c.borrow().as_ref().is_some_and(Token::stopped))
}

/// Items between two [`stopped`] checks in a loop: a few thousand strokes take well under a
/// millisecond even in a debug build.
pub(crate) const CHECK_EVERY: usize = 1 << 12;

/// The error a stopped run fails with.
#[derive(Debug)]
pub(crate) struct Stopped;

impl std::fmt::Display for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("interrupted")
    }
}

impl std::error::Error for Stopped {}

/// The I/O error of a stopped run. Not `ErrorKind::Interrupted`: that one (EINTR) means "try
/// again", and readers do.
pub(crate) fn stopped_error() -> io::Error {
    io::Error::other(Stopped)
}

/// Whether `e` is the error of a stopped run.
pub fn is_stopped(e: &io::Error) -> bool {
    e.get_ref().is_some_and(|inner| inner.is::<Stopped>())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_is_current_only_within_its_run() {
        assert!(Token::current().is_none());
        let token = Token::new();
        run_under(&token, || {
            let seen = Token::current().expect("a current token");
            assert!(seen.check().is_ok() && !stopped());
            token.stop();
            assert!(is_stopped(&seen.check().unwrap_err()) && stopped());
        });
        assert!(Token::current().is_none() && !stopped());
        assert!(!is_stopped(&io::Error::from(io::ErrorKind::Interrupted)));
    }
}
