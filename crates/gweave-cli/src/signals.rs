//! Ctrl-C, SIGTERM, SIGHUP and a closed pipe (SIGPIPE) during a run: remove the temporary files being written
//! (`gweave::gcode::temp`), then exit with 128 + the signal number, as a shell reports a
//! process the signal killed. Without this, a signal ends the process before any destructor
//! runs and leaves a hidden `.gweave-*.tmp` as large as the output written so far.
//!
//! The handler itself only writes the signal number into a pipe (`write` is async-signal-safe);
//! a thread reading the pipe does the work, which needs locks and allocation. The handlers are
//! installed for the length of one run and the previous ones restored after it, because the
//! Python package runs the CLI inside the interpreter, whose own Ctrl-C handling must come
//! back once the command returns.

#[cfg(unix)]
mod imp {
    use std::io;
    use std::sync::atomic::{AtomicI32, Ordering};
    use std::thread::JoinHandle;

    use libc::c_int;

    /// SIGPIPE too: the command line leaves it at its default, as Unix tools do, so a reader
    /// that stops early (`gweave mix ... -o - | head`) kills the process, which would leave the
    /// scratch file behind. It is guarded only where it is fatal: Python ignores it, and a
    /// closed pipe is then an error the run unwinds from.
    const SIGNALS: [c_int; 4] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGPIPE];

    /// The pipe's write end while a run is guarded, else -1.
    static WAKE_FD: AtomicI32 = AtomicI32::new(-1);

    /// The guard of one run: handlers installed until dropped.
    pub struct Cleanup {
        previous: Vec<(c_int, libc::sigaction)>,
        fds: [c_int; 2],
        thread: Option<JoinHandle<()>>,
    }

    extern "C" fn on_signal(signal: c_int) {
        let fd = WAKE_FD.load(Ordering::Relaxed);
        if fd >= 0 {
            // SAFETY: errno is thread-local; write(2) is async-signal-safe and reads one byte of
            // a local. errno is restored so the interrupted code sees its own.
            unsafe {
                let errno = *libc::__errno_location();
                let byte = signal as u8;
                libc::write(fd, (&byte as *const u8).cast(), 1);
                *libc::__errno_location() = errno;
            }
        }
    }

    impl Cleanup {
        /// Installs the handlers, or does nothing when another run in this process (a Python
        /// thread) already has them.
        pub fn install() -> io::Result<Option<Cleanup>> {
            let mut fds = [-1; 2];
            // SAFETY: pipe2 fills a two-element array.
            if unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) } != 0 {
                return Err(io::Error::last_os_error());
            }
            if WAKE_FD.compare_exchange(-1, fds[1], Ordering::SeqCst, Ordering::SeqCst).is_err() {
                close(fds);
                return Ok(None);
            }
            let read_fd = fds[0];
            let thread =
                std::thread::Builder::new().name("gweave-signals".into()).spawn(move || watch(read_fd));
            let mut guard = Cleanup { previous: Vec::new(), fds, thread: None };
            guard.thread = Some(thread?);
            for signal in SIGNALS {
                // SAFETY: a zeroed sigaction is valid; the handler is an `extern "C" fn(c_int)`
                // as sa_sigaction expects without SA_SIGINFO; `old` receives the previous one.
                unsafe {
                    let mut now: libc::sigaction = std::mem::zeroed();
                    libc::sigaction(signal, std::ptr::null(), &mut now);
                    if signal == libc::SIGPIPE && now.sa_sigaction != libc::SIG_DFL {
                        continue;
                    }
                    let mut action: libc::sigaction = std::mem::zeroed();
                    action.sa_sigaction = on_signal as extern "C" fn(c_int) as usize;
                    action.sa_flags = libc::SA_RESTART;
                    libc::sigemptyset(&mut action.sa_mask);
                    let mut old: libc::sigaction = std::mem::zeroed();
                    if libc::sigaction(signal, &action, &mut old) != 0 {
                        return Err(io::Error::last_os_error());
                    }
                    guard.previous.push((signal, old));
                }
            }
            Ok(Some(guard))
        }
    }

    /// Waits for a signal number (0: the run ended), then cleans up and exits.
    fn watch(read_fd: c_int) {
        loop {
            let mut byte = 0u8;
            // SAFETY: reads one byte into a local.
            let n = unsafe { libc::read(read_fd, (&mut byte as *mut u8).cast(), 1) };
            if n < 0 && io::Error::last_os_error().kind() == io::ErrorKind::Interrupted {
                continue;
            }
            if n != 1 || byte == 0 {
                return;
            }
            gweave::gcode::temp::remove_all();
            std::process::exit(128 + c_int::from(byte));
        }
    }

    impl Drop for Cleanup {
        fn drop(&mut self) {
            for (signal, old) in &self.previous {
                // SAFETY: restores an action sigaction gave us.
                unsafe {
                    libc::sigaction(*signal, old, std::ptr::null_mut());
                }
            }
            WAKE_FD.store(-1, Ordering::SeqCst);
            let stop = 0u8;
            // SAFETY: writes one byte of a local to our own pipe.
            unsafe {
                libc::write(self.fds[1], (&stop as *const u8).cast(), 1);
            }
            if let Some(thread) = self.thread.take() {
                let _ = thread.join();
            }
            close(self.fds);
        }
    }

    fn close(fds: [c_int; 2]) {
        for fd in fds {
            // SAFETY: closes descriptors this module opened and no one else holds.
            unsafe {
                libc::close(fd);
            }
        }
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        fn current(signal: c_int) -> usize {
            // SAFETY: queries the action into a zeroed local.
            unsafe {
                let mut action: libc::sigaction = std::mem::zeroed();
                libc::sigaction(signal, std::ptr::null(), &mut action);
                action.sa_sigaction
            }
        }

        /// The Python package runs the CLI inside the interpreter: after a run, its own
        /// handlers must be back (else Ctrl-C or SIGTERM would be swallowed or exit later).
        #[test]
        fn the_previous_handlers_are_restored_after_a_run() {
            let before = current(libc::SIGHUP);
            let guard = Cleanup::install().unwrap().expect("first install");
            assert_eq!(current(libc::SIGHUP), on_signal as extern "C" fn(c_int) as usize);
            // A second run at the same time (another Python thread) leaves them alone.
            assert!(Cleanup::install().unwrap().is_none());
            drop(guard);
            assert_eq!(current(libc::SIGHUP), before);
            assert_eq!(WAKE_FD.load(Ordering::SeqCst), -1);
        }
    }
}

#[cfg(unix)]
pub use imp::Cleanup;

/// Without Unix signals, nothing to install.
#[cfg(not(unix))]
pub struct Cleanup;

#[cfg(not(unix))]
impl Cleanup {
    pub fn install() -> std::io::Result<Option<Cleanup>> {
        Ok(None)
    }
}
