//! A signal during a run (Ctrl-C, SIGTERM, SIGHUP, a closed pipe, `ulimit -f`'s SIGXFSZ, a
//! `kill -USR1`...): remove the temporary files being written (`gweave::gcode::temp`), then end
//! the process by the same signal, with its default action, so the parent sees what it sent
//! (a shell reports 128 + the signal; a core-dumping signal still dumps). Without this, a
//! signal ends the process before any destructor runs and leaves a hidden `.gweave-*.tmp` as
//! large as the output written so far.
//!
//! Every signal whose default action ends the process is guarded, except two kinds:
//! - a signal the process inherited as ignored (`nohup` ignores SIGHUP, a shell starts
//!   background jobs with SIGINT and SIGQUIT ignored): the run must go on through it, as the
//!   one who started it asked (POSIX `nohup`, and "Signals" in the shell's job control);
//! - a signal someone in the process already handles: a program that runs [`crate::run`] inside
//!   itself (an interpreter handling SIGINT as `KeyboardInterrupt`) keeps its own handling.
//!
//! Faults a thread raises against itself (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGTRAP, SIGSYS,
//! SIGABRT) are not guarded: the handler would return into the faulting instruction, and
//! Rust's runtime owns SIGSEGV and SIGBUS for its stack-overflow report.
//!
//! The handler itself only writes the signal number into a pipe (`write` is async-signal-safe);
//! a thread reading the pipe does the work, which needs locks and allocation. The handlers are
//! installed for the length of one run and the previous ones restored after it, so that a
//! program running [`crate::run`] inside itself gets its own handling back once the command
//! returns. (The Python package runs the `gweave` executable instead, as a child process.)

#[cfg(unix)]
mod imp {
    use std::io;
    use std::sync::atomic::{AtomicI32, Ordering};
    use std::thread::JoinHandle;

    use libc::c_int;

    /// The signals guarded: every one whose default action ends the process (signal(7)) and
    /// that comes from outside the thread it interrupts. SIGPIPE too: the command line leaves
    /// it at its default, as Unix tools do, so a reader that stops early
    /// (`gweave mix ... -o - | head`) kills the process, which would leave the scratch file.
    /// SIGXFSZ is the file size limit (`ulimit -f`) a write just passed; SIGXCPU the CPU time
    /// limit (`ulimit -t`).
    fn guarded() -> Vec<c_int> {
        use libc::*;
        let mut signals = vec![
            SIGHUP, SIGINT, SIGQUIT, SIGPIPE, SIGALRM, SIGTERM, SIGUSR1, SIGUSR2, SIGXCPU, SIGXFSZ,
            SIGVTALRM, SIGPROF,
        ];
        // Linux ends the process on these too, and on every real-time signal.
        #[cfg(any(target_os = "linux", target_os = "android"))]
        {
            signals.extend([SIGIO, SIGPWR, SIGSTKFLT]);
            signals.extend(SIGRTMIN()..=SIGRTMAX());
        }
        signals
    }

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
        /// Installs the handlers, or does nothing when another run in this process (another
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
            for signal in guarded() {
                // SAFETY: a zeroed sigaction is valid; the handler is an `extern "C" fn(c_int)`
                // as sa_sigaction expects without SA_SIGINFO; `old` receives the previous one.
                unsafe {
                    let mut now: libc::sigaction = std::mem::zeroed();
                    if libc::sigaction(signal, std::ptr::null(), &mut now) != 0 {
                        continue;
                    }
                    // An inherited ignore (nohup), or the embedding program's own handler.
                    if now.sa_sigaction != libc::SIG_DFL {
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

    /// Waits for a signal number (0: the run ended), then cleans up and ends the process by
    /// that signal.
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
            die_by(c_int::from(byte));
        }
    }

    /// Ends the process by `signal` with its default action, as if no handler had been there:
    /// the parent's `wait` then reports the signal (and a core dump for SIGQUIT or SIGXFSZ),
    /// which an `exit(128 + signal)` would not. Falls back to that exit if the signal did not
    /// end the process (blocked in this thread and pending elsewhere).
    fn die_by(signal: c_int) -> ! {
        // SAFETY: sets the default action, unblocks the signal in this thread and sends it to
        // this thread; no memory of ours is touched.
        unsafe {
            libc::signal(signal, libc::SIG_DFL);
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            libc::sigaddset(&mut set, signal);
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
            libc::raise(signal);
        }
        std::process::exit(128 + signal)
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

        /// A program that runs the CLI inside itself (an interpreter): after a run, its own
        /// handlers must be back (else Ctrl-C or SIGTERM would be swallowed or exit later).
        /// And a signal the process was started with ignored (`nohup` and SIGHUP) stays
        /// ignored during a run.
        #[test]
        fn the_previous_handlers_are_restored_after_a_run() {
            let before = current(libc::SIGHUP);
            // SAFETY: sets SIGUSR2's disposition to "ignore"; no handler code.
            unsafe {
                libc::signal(libc::SIGUSR2, libc::SIG_IGN);
            }
            let guard = Cleanup::install().unwrap().expect("first install");
            assert_eq!(current(libc::SIGHUP), on_signal as extern "C" fn(c_int) as usize);
            assert_eq!(current(libc::SIGUSR2), libc::SIG_IGN);
            // A second run at the same time (another thread) leaves them alone.
            assert!(Cleanup::install().unwrap().is_none());
            drop(guard);
            assert_eq!(current(libc::SIGHUP), before);
            assert_eq!(current(libc::SIGUSR2), libc::SIG_IGN);
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
