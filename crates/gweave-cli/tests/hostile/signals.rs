//! Signals during a run, as real parents send them: `nohup` and a shell's background jobs start
//! gweave with SIGHUP, SIGINT and SIGQUIT ignored, and the run must go on through them; every
//! signal whose default action ends the process (a `kill -USR1`, `ulimit -f`'s SIGXFSZ, an
//! alarm, SIGTERM...) removes the scratch file and ends the run by that same signal, so the
//! parent sees what it sent.

use std::fs;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use crate::outputs::temp_files;

/// `big.gcode` in `dir`: `lines` plain moves of 21 bytes (a debug build copies about 5 MB/s).
fn moves(dir: &Path, lines: usize) -> PathBuf {
    let path = dir.join("big.gcode");
    fs::write(&path, b"G1 X1.5 Y2.25 E0.125\n".repeat(lines)).unwrap();
    path
}

/// No scratch file left in `dir` (by name: reading the big input back would cost seconds).
#[track_caller]
fn assert_no_scratch_left(dir: &Path) {
    assert_eq!(temp_files(dir), Vec::<PathBuf>::new(), "scratch files left");
}

/// `gweave cat big.gcode -o out.gcode -q` in `dir`, with `setup` run in the child before it
/// executes gweave (to set signal dispositions and limits as a parent would).
fn start_copy(dir: &Path, setup: fn() -> std::io::Result<()>) -> Child {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gweave"));
    cmd.args(["cat", "big.gcode", "-o", "out.gcode", "-q"])
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    // SAFETY: `setup` only calls async-signal-safe functions (signal, setrlimit).
    unsafe {
        cmd.pre_exec(move || {
            // No core files from the signals whose default dumps one (SIGQUIT, SIGXFSZ, SIGXCPU).
            let none = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
            libc::setrlimit(libc::RLIMIT_CORE, &none);
            setup()
        });
    }
    cmd.spawn().expect("gweave runs")
}

/// Waits until the run's scratch file exists (the run is writing), then a little longer.
fn wait_for_scratch(dir: &Path) {
    let start = Instant::now();
    while temp_files(dir).is_empty() {
        assert!(start.elapsed() < Duration::from_secs(30), "no scratch file appeared");
        thread::sleep(Duration::from_millis(2));
    }
    thread::sleep(Duration::from_millis(30));
}

/// The run's end, killing it after 60 s (a hang).
fn finish(mut child: Child) -> ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("hang: still running after 60 s");
        }
        thread::sleep(Duration::from_millis(5));
    }
}

fn send(child: &Child, signal: i32) {
    // SAFETY: kill(2) on our own child's pid; no memory is touched.
    unsafe {
        libc::kill(child.id() as i32, signal);
    }
}

/// Regression: the handlers were installed over an inherited "ignore", so
/// `nohup gweave ... &` died on SIGHUP (exit 129, no output) and a background job of a script
/// (started with SIGINT and SIGQUIT ignored) died on Ctrl-C in the terminal.
#[test]
fn nohup_and_background_jobs_survive_the_signals_they_ignore() {
    let dir = tempfile::tempdir().unwrap();
    let input = moves(dir.path(), 1_000_000);
    let child = start_copy(dir.path(), || {
        for signal in [libc::SIGHUP, libc::SIGINT, libc::SIGQUIT] {
            // SAFETY: sets a disposition to "ignore", as nohup and a shell do before exec.
            unsafe {
                libc::signal(signal, libc::SIG_IGN);
            }
        }
        Ok(())
    });
    wait_for_scratch(dir.path());
    for signal in [libc::SIGHUP, libc::SIGINT, libc::SIGQUIT] {
        send(&child, signal);
    }
    let status = finish(child);
    assert!(status.success(), "{status:?}");
    assert_eq!(fs::read(dir.path().join("out.gcode")).unwrap(), fs::read(&input).unwrap());
    assert_no_scratch_left(dir.path());
}

/// Regression: only SIGINT, SIGTERM, SIGHUP and SIGPIPE were caught; a `kill -USR1` (or
/// USR2, an alarm, a profiling timer...) ended the run at once and left its scratch file of
/// 20-116 MB. Each now removes it, and the run ends by the signal itself (not an exit code
/// of 128 + the signal), as if no handler had been there.
#[test]
fn every_fatal_signal_removes_the_scratch_file_and_ends_the_run_by_it() {
    let dir = tempfile::tempdir().unwrap();
    moves(dir.path(), 5_000_000);
    let signals = [
        libc::SIGTERM,
        libc::SIGINT,
        libc::SIGHUP,
        libc::SIGQUIT,
        libc::SIGUSR1,
        libc::SIGUSR2,
        libc::SIGALRM,
        libc::SIGVTALRM,
        libc::SIGPROF,
        libc::SIGXCPU,
        libc::SIGXFSZ,
        libc::SIGRTMIN(),
    ];
    let mut caught = 0;
    for signal in signals {
        let child = start_copy(dir.path(), || Ok(()));
        wait_for_scratch(dir.path());
        send(&child, signal);
        let status = finish(child);
        assert_no_scratch_left(dir.path());
        let out = dir.path().join("out.gcode");
        if status.success() {
            println!("signal {signal}: the run had finished");
            fs::remove_file(out).unwrap();
            continue;
        }
        caught += 1;
        assert_eq!(status.signal(), Some(signal), "signal {signal}: {status:?}");
        assert!(!out.exists(), "signal {signal}: a partial output");
    }
    assert!(caught >= signals.len() - 2, "only {caught} runs were still running at the signal");
}

/// Regression: past the file size limit (`ulimit -f`), the kernel's SIGXFSZ ended the run
/// with its scratch file left at the limit's size.
#[test]
fn a_file_size_limit_leaves_no_scratch_file() {
    let dir = tempfile::tempdir().unwrap();
    moves(dir.path(), 500_000);
    let child = start_copy(dir.path(), || {
        let limit = libc::rlimit { rlim_cur: 4 << 20, rlim_max: 4 << 20 };
        // SAFETY: setrlimit reads a local.
        if unsafe { libc::setrlimit(libc::RLIMIT_FSIZE, &limit) } != 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(())
    });
    let status = finish(child);
    assert_eq!(status.signal(), Some(libc::SIGXFSZ), "{status:?}");
    assert!(!dir.path().join("out.gcode").exists());
    assert_no_scratch_left(dir.path());
}
