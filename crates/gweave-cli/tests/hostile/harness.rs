//! Runs the `gweave` binary as a user would, with a wall-clock limit, and measures its peak
//! memory: the high-water mark of its resident set (`VmHWM` in `/proc/PID/status`), read while
//! it runs. `wait4`'s `ru_maxrss` is no use here: Linux carries the resident set the child had
//! before `exec` (a copy of this test process, which may hold large inputs) into it.

use std::collections::BTreeMap;
use std::fs;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// What one run did.
#[derive(Debug)]
pub struct Outcome {
    /// Exit code; `None` when a signal ended the process (see `signal`).
    pub code: Option<i32>,
    pub signal: Option<i32>,
    pub stdout: Vec<u8>,
    pub stderr: String,
    /// Peak resident memory of the process, in MiB.
    pub peak_mib: f64,
    pub elapsed: Duration,
    /// Killed at the time limit.
    pub hung: bool,
}

impl Outcome {
    /// The run ended by itself, without a panic, an abort or a signal, within its time limit.
    #[track_caller]
    pub fn assert_sound(&self) -> &Self {
        assert!(!self.hung, "hang: still running after {:?}", self.elapsed);
        assert!(self.signal.is_none(), "ended by signal {:?}; stderr: {}", self.signal, self.stderr);
        assert_ne!(self.code, Some(101), "panicked: {}", self.stderr);
        assert!(!self.stderr.contains("panicked"), "panicked: {}", self.stderr);
        self
    }

    /// Sound, and refused with exit code 1 and a message containing `needle`.
    #[track_caller]
    pub fn assert_refused(&self, needle: &str) -> &Self {
        self.assert_sound();
        assert_eq!(self.code, Some(1), "expected a refusal; stderr: {}", self.stderr);
        assert!(self.stderr.contains(needle), "expected {needle:?} in the error; stderr: {}", self.stderr);
        self
    }

    /// Sound and successful.
    #[track_caller]
    pub fn assert_ok(&self) -> &Self {
        self.assert_sound();
        assert_eq!(self.code, Some(0), "expected success; stderr: {}", self.stderr);
        self
    }

    /// Peak memory under `mib`.
    #[track_caller]
    pub fn assert_peak_under(&self, mib: f64) -> &Self {
        assert!(self.peak_mib < mib, "peak memory {:.1} MiB, limit {mib} MiB", self.peak_mib);
        self
    }

    pub fn stdout_text(&self) -> String {
        String::from_utf8_lossy(&self.stdout).into_owned()
    }
}

/// A run of `gweave` with arguments, in a working directory, with a time limit.
pub struct Run {
    cmd: Command,
    limit: Duration,
    cpu_limit: Option<Duration>,
    stdout: Option<PathBuf>,
}

/// `gweave ARGS...` run in `dir`, limited to 60 s unless told otherwise.
pub fn gweave<S: AsRef<std::ffi::OsStr>>(dir: &Path, args: &[S]) -> Run {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gweave"));
    cmd.args(args).current_dir(dir).env_remove("COLUMNS");
    Run { cmd, limit: Duration::from_secs(60), cpu_limit: None, stdout: None }
}

impl Run {
    pub fn limit(mut self, limit: Duration) -> Self {
        self.limit = limit;
        self
    }

    /// Also kills the process (then `hung`) once it has used `limit` of CPU time (user and
    /// system). Unlike the wall clock, CPU time hardly grows when other builds load the
    /// machine, so a busy loop is caught with a limit far above a normal run's time.
    pub fn cpu_limit(mut self, limit: Duration) -> Self {
        self.cpu_limit = Some(limit);
        self
    }

    /// Sets the environment variable `key` for the run.
    pub fn env(mut self, key: &str, value: impl AsRef<std::ffi::OsStr>) -> Self {
        self.cmd.env(key, value);
        self
    }

    /// Standard output written to this file (default: captured), e.g. `/dev/full`.
    pub fn stdout_file(mut self, path: &Path) -> Self {
        self.stdout = Some(path.to_path_buf());
        self
    }

    pub fn spawn(mut self) -> Running {
        self.cmd.stdin(Stdio::null());
        match &self.stdout {
            Some(path) => {
                self.cmd.stdout(fs::OpenOptions::new().write(true).open(path).expect("stdout file"))
            }
            None => self.cmd.stdout(Stdio::piped()),
        };
        let mut child = self.cmd.stderr(Stdio::piped()).spawn().expect("gweave runs");
        let stdout = drain(child.stdout.take());
        let stderr = drain(child.stderr.take());
        let (limit, cpu_limit) = (self.limit, self.cpu_limit);
        Running { child, started: Instant::now(), limit, cpu_limit, stdout, stderr }
    }

    /// Runs to the end, or to the time limit (then killed, and `hung`).
    #[track_caller]
    pub fn run(self) -> Outcome {
        self.spawn().wait()
    }
}

/// A started run, for tests that signal it part-way.
pub struct Running {
    child: Child,
    started: Instant,
    limit: Duration,
    cpu_limit: Option<Duration>,
    stdout: thread::JoinHandle<Vec<u8>>,
    stderr: thread::JoinHandle<Vec<u8>>,
}

fn drain<R: Read + Send + 'static>(pipe: Option<R>) -> thread::JoinHandle<Vec<u8>> {
    thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut pipe) = pipe {
            let _ = pipe.read_to_end(&mut bytes);
        }
        bytes
    })
}

impl Running {
    pub fn pid(&self) -> i32 {
        self.child.id() as i32
    }

    /// Sends `signal` to the process.
    pub fn signal(&self, signal: i32) {
        // SAFETY: kill(2) on our own child's pid; no memory is touched.
        unsafe {
            libc::kill(self.pid(), signal);
        }
    }

    /// Waits for the end, killing the process at the time limit (then `hung`).
    pub fn wait(self) -> Outcome {
        let pid = self.pid();
        let mut hung = false;
        let mut peak_kib = 0;
        loop {
            // The mark only rises while the process lives; the last read is its peak to within
            // one poll.
            peak_kib = high_water_kib(pid).unwrap_or(peak_kib).max(peak_kib);
            let mut status = 0;
            // SAFETY: waitpid on our own child with a valid pointer to a local.
            let done = unsafe { libc::waitpid(pid, &mut status, libc::WNOHANG) };
            if done == pid {
                let elapsed = self.started.elapsed();
                let stdout = self.stdout.join().unwrap_or_default();
                let stderr = String::from_utf8_lossy(&self.stderr.join().unwrap_or_default()).into_owned();
                let (code, signal) = if libc::WIFEXITED(status) {
                    (Some(libc::WEXITSTATUS(status)), None)
                } else {
                    (None, Some(libc::WTERMSIG(status)))
                };
                let peak_mib = peak_kib as f64 / 1024.0;
                return Outcome { code, signal, stdout, stderr, peak_mib, elapsed, hung };
            }
            let over_cpu = self.cpu_limit.is_some_and(|l| cpu_time(pid).is_some_and(|t| t > l));
            if !hung && (self.started.elapsed() > self.limit || over_cpu) {
                hung = true;
                self.signal(libc::SIGKILL);
            }
            thread::sleep(Duration::from_millis(2));
        }
    }
}

/// CPU time (user and system) of a running process; `None` once it has exited.
fn cpu_time(pid: i32) -> Option<Duration> {
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the command name (which may hold spaces, in parentheses): state is the
    // first, utime and stime the 12th and 13th (proc(5)), in clock ticks.
    let mut fields = stat.rsplit_once(')')?.1.split_whitespace().skip(11);
    let ticks: u64 = fields.next()?.parse::<u64>().ok()? + fields.next()?.parse::<u64>().ok()?;
    // SAFETY: sysconf reads a constant of the system; no memory is touched.
    let per_s = unsafe { libc::sysconf(libc::_SC_CLK_TCK) }.max(1) as f64;
    Some(Duration::from_secs_f64(ticks as f64 / per_s))
}

/// `VmHWM` of a running process, KiB; `None` once it has exited, and before it is `gweave`:
/// between the spawn and the `exec` the child is still this test process, whose memory (every
/// hostile input, 130 MiB) it reports (a sweep failed on "zeros: gweave sim: peak memory 133
/// MiB", where `gweave sim` itself takes 16 MiB).
fn high_water_kib(pid: i32) -> Option<u64> {
    let status = fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let name = status.lines().find_map(|l| l.strip_prefix("Name:"))?.trim();
    if name != "gweave" {
        return None;
    }
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Every file below `dir` with its bytes' length and a hash, to prove inputs unchanged.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, (u64, u64)> {
    use std::hash::{Hash, Hasher};
    let mut files = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for entry in fs::read_dir(&d).expect("readable dir").flatten() {
            let path = entry.path();
            if path.is_dir() {
                todo.push(path);
            } else if let Ok(bytes) = fs::read(&path) {
                let mut h = std::collections::hash_map::DefaultHasher::new();
                bytes.hash(&mut h);
                files.insert(path, (bytes.len() as u64, h.finish()));
            }
        }
    }
    files
}

/// No temporary file of gweave's is left below `dir`.
#[track_caller]
pub fn assert_no_temp_left(dir: &Path) {
    let left: Vec<_> = snapshot(dir).into_keys().filter(|p| is_temp(p)).collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

fn is_temp(path: &Path) -> bool {
    path.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with(".gweave-"))
}

/// A fresh directory holding a copy of a real fixture under `name`.
pub fn dir_with_fixture(fixture: &str, name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join(name);
    fs::copy(fixture_path(fixture), &path).expect("fixture copies");
    (dir, path)
}

/// A real slicer file from `tests/data` (e.g. `cura/cura_torus.gcode`).
pub fn fixture_path(fixture: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(fixture)
}

/// A flag out of range is a command-line error (clap's exit code 2, as for an unknown flag)
/// that names the flag and the allowed range; nothing is read or written.
#[track_caller]
pub fn assert_flag_refused(dir: &Path, args: &[&str], flag: &str, range: &str) {
    let before = snapshot(dir);
    let out = gweave(dir, args).limit(Duration::from_secs(20)).run();
    out.assert_sound().assert_peak_under(64.0);
    assert_eq!(out.code, Some(2), "expected a usage error for {args:?}; stderr: {}", out.stderr);
    assert!(out.stderr.contains(flag), "{flag} not named: {}", out.stderr);
    assert!(out.stderr.contains(range), "range not given: {}", out.stderr);
    assert_eq!(snapshot(dir), before, "{args:?} changed the directory");
}
