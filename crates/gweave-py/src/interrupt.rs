//! Ctrl-C during a long call. Python's own SIGINT handler only notes the signal; the interpreter
//! raises `KeyboardInterrupt` when it next runs Python code, which a call busy in Rust for
//! minutes never does. So every call that may take long runs on a thread of its own under a
//! `gweave::Token`, while the caller's thread waits without the GIL and, every
//! [`POLL`], takes it to ask Python whether a signal came (`Python::check_signals`, which runs
//! the handlers). On `KeyboardInterrupt` (or whatever a handler raised) the token is stopped:
//! the run fails at its next read or write, removes its scratch files and writes no output, and
//! the call raises the handler's exception once the run has unwound.
//!
//! Only the main thread receives Python's signals: a call made on another thread runs to its end,
//! as Python code on that thread would.

use std::sync::mpsc;
use std::time::Duration;

use gweave::run_under;
use gweave::Token;
use pyo3::prelude::*;

/// How often the waiting thread asks Python for signals: a stop within a tenth of a second,
/// for a few microseconds of work each time.
const POLL: Duration = Duration::from_millis(50);

/// Runs `work` (what would be given to `Python::allow_threads`) so that a Ctrl-C stops it: its
/// value, or the exception a signal handler raised (the run then stopped and unwound).
pub fn interruptible<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    let token = Token::new();
    std::thread::scope(|scope| {
        let (done, mut finished) = mpsc::channel::<()>();
        let token_of_run = &token;
        let worker = scope.spawn(move || {
            let value = run_under(token_of_run, work);
            let _ = done.send(());
            value
        });
        loop {
            // Disconnected: the worker ended without sending (it panicked); join says so. (The
            // receiver is moved through: it is not `Sync`, so it cannot be lent.)
            let waited;
            (finished, waited) = py.allow_threads(move || {
                let waited = finished.recv_timeout(POLL);
                (finished, waited)
            });
            if !matches!(waited, Err(mpsc::RecvTimeoutError::Timeout)) {
                break;
            }
            if let Err(raised) = py.check_signals() {
                token.stop();
                let _ = py.allow_threads(|| worker.join());
                return Err(raised);
            }
        }
        let joined = py.allow_threads(|| worker.join());
        Ok(joined.unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
    })
}
