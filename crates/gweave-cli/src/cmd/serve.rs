//! `gweave serve`: the virtual printer on a serial line, for real hosts.

use std::cell::RefCell;
use std::fs::File;
use std::io::{LineWriter, Write};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::Args;
use gweave::gcode::writer::write_file;
use gweave_sim::CoreDevice;
use gweave_sim::PtyEndpoint;
use gweave_sim::TcpEndpoint;
use gweave_sim::{serve, Endpoint, ServeOptions, ServeSummary};
use gweave_sim::{FirmwareKind, Machine};
use gweave_sim::{ProtocolConfig, DEFAULT_KEEPALIVE_S};

use gweave::Range;

use crate::args::MachineArg;
use crate::common::in_range;

/// `--exit-after-idle`: a tenth of a second to about eleven days.
const IDLE_S: Range<f64> = Range::new(0.1, 1e6, "s");
/// `--speed`: from ten times slower than the machine to a thousand times faster.
const SPEED_FACTOR: Range<f64> = Range::new(0.1, 1000.0, "x real time");
/// `--duplicate-window`: Marlin's own resend buffer is a few lines; a host never has more than a
/// few hundred in flight.
const DUPLICATE_WINDOW: Range<u32> = Range::new(0, 1000, "lines");

/// Run the virtual printer as a Marlin board behind a pty or a loopback TCP port.
///
/// Hosts (Printrun, OctoPrint, Repetier) connect as to a USB printer: `start` at connection,
/// line numbers and checksums with `Resend:` on errors, `ok` after each command,
/// `echo:busy: processing` every 2 s of a long command. Each connection boots a fresh machine.
/// Example: `gweave serve --pty /tmp/gweave0`, then `printcore.py /tmp/gweave0 part.gcode`.
#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Create a pseudo-terminal and link this path to it (removed on exit).
    #[arg(long, value_name = "PATH", required_unless_present = "tcp", conflicts_with = "tcp")]
    pub pty: Option<PathBuf>,
    /// Listen on this loopback address instead (`127.0.0.1:PORT`) [default: --pty].
    #[arg(long, value_name = "ADDR")]
    pub tcp: Option<SocketAddr>,
    #[command(flatten)]
    pub machine: MachineArg,
    /// Pace replies to the simulated clock (default: as fast as the simulation runs); the same
    /// as `--speed-factor 1`.
    #[arg(long, conflicts_with = "speed")]
    pub realtime: bool,
    /// Pace replies to the simulated clock, N times faster than real time (`--speed` is an
    /// older name) [default: unpaced, as fast as the simulation runs].
    #[arg(long = "speed-factor", alias = "speed", value_name = "N", value_parser = in_range(SPEED_FACTOR))]
    pub speed: Option<f64>,
    /// Write the session transcript (received `>` and sent `<` lines, simulated seconds).
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Exit after this many wall-clock seconds without a byte from the host [default: never].
    #[arg(long, value_name = "SECS", value_parser = in_range(IDLE_S))]
    pub exit_after_idle: Option<f64>,
    /// When a host disconnects, write the simulator's report of its session here (JSON, as
    /// `gweave sim --report`; a later session replaces it).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// The virtual SD card's folder (default: a new temporary folder, removed on exit). Used when
    /// the profile's `[firmware]` has `sdcard`.
    #[arg(long, value_name = "DIR")]
    pub sd: Option<PathBuf>,
    /// The virtual EEPROM (`M500` writes it, every power-on and `M501` read it; default: a file
    /// in the session's temporary folder). Used when the profile's `[firmware]` has `eeprom`.
    #[arg(long, value_name = "FILE")]
    pub eeprom: Option<PathBuf>,
    /// Acknowledge a repeat of one of the last N line numbers with `ok` without running it again
    /// (0: answer it with a resend request, as stock Marlin).
    #[arg(long, value_name = "N", default_value_t = ProtocolConfig::default().duplicate_window,
          value_parser = in_range(DUPLICATE_WINDOW))]
    pub duplicate_window: u32,
}

pub fn run(args: ServeArgs) -> Result<ExitCode> {
    crate::files::Files::new()
        .read("--machine", args.machine.path.as_deref())
        .read("--eeprom", args.eeprom.as_deref())
        .write("--pty", args.pty.as_deref())
        .write("--log", args.log.as_deref())
        .write("--report", args.report.as_deref())
        .check()?;
    // The report is written when a host disconnects: find out now that it cannot be.
    if let Some(report) = &args.report {
        crate::files::check_writable("--report", report)?;
    }
    let profile = args.machine.load()?;
    let core = profile.firmware.kind == FirmwareKind::Gweave;
    // Build one machine now so that a bad profile fails before any host connects.
    if core {
        CoreDevice::new(&profile, Vec::new()).context("building the virtual printer")?;
    } else {
        Machine::new(profile.clone()).context("building the virtual printer")?;
    }
    let options = ServeOptions {
        protocol: ProtocolConfig {
            // The controller core prints its own keepalive lines.
            keepalive_s: if core { 0 } else { DEFAULT_KEEPALIVE_S },
            duplicate_window: args.duplicate_window,
        },
        // `--realtime` is `--speed 1`.
        speed: args.speed.or(args.realtime.then_some(1.0)),
        exit_after_idle: args.exit_after_idle.map(Duration::from_secs_f64),
    };
    let mut log = match &args.log {
        Some(path) => {
            let file = File::create(path).with_context(|| format!("creating {}", path.display()))?;
            Some(SaysWhenItFails { inner: LineWriter::new(file), path: path.clone() })
        }
        None => None,
    };
    // Ctrl-C and SIGTERM raise the flag; the serve loop sees it within a tick and returns, so the
    // pty link is removed by its endpoint's Drop.
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop)).context("installing the signal handler")?;
    }
    let mut endpoint: Box<dyn Endpoint> = match (&args.pty, args.tcp) {
        (Some(link), _) => {
            let pty = PtyEndpoint::open(link)?;
            eprintln!("gweave serve: {} -> {} (Ctrl-C to stop)", link.display(), pty.slave_path().display());
            Box::new(pty)
        }
        (None, Some(addr)) => {
            let tcp = TcpEndpoint::bind(addr)?;
            eprintln!("gweave serve: listening on {} (Ctrl-C to stop)", tcp.local_addr()?);
            Box::new(tcp)
        }
        (None, None) => bail!("say where to serve: --pty PATH or --tcp 127.0.0.1:PORT"),
    };
    // The session's own folder: the default SD card and EEPROM live there and go with it.
    let session_dir =
        tempfile::Builder::new().prefix("gweave-serve-").tempdir().context("creating the session folder")?;
    let sd_dir = match &args.sd {
        Some(dir) if !dir.is_dir() => bail!("--sd {}: not a folder", dir.display()),
        Some(dir) => dir.clone(),
        None => {
            let dir = session_dir.path().join("sd");
            std::fs::create_dir(&dir).with_context(|| format!("creating {}", dir.display()))?;
            dir
        }
    };
    let eeprom = args.eeprom.clone().unwrap_or_else(|| session_dir.path().join("eeprom.gcode"));
    let mut report_error = None;
    // A session's report, whichever board served it, as JSON.
    let mut write_report = |json: serde_json::Result<String>| {
        if let Some(path) = &args.report {
            let written = json
                .map_err(anyhow::Error::from)
                .and_then(|text| write_file(path, |out| -> Result<()> { Ok(writeln!(out, "{text}")?) }));
            if let Err(e) = written {
                report_error = Some(e.context(format!("writing {}", path.display())));
            }
        }
    };
    let log = log.as_mut().map(|w| w as &mut dyn Write);
    let summary = if core {
        // One board for the whole run: what a session keeps in EEPROM (M500), the next reads.
        let eeprom = RefCell::new(Vec::new());
        let mut make = || CoreDevice::new(&profile, eeprom.take());
        let mut finished = |device: CoreDevice| {
            eeprom.replace(device.eeprom().to_vec());
            write_report(serde_json::to_string_pretty(&device.report(&profile.name)));
        };
        serve(endpoint.as_mut(), &mut make, &mut finished, &options, log, &stop)?
    } else {
        let mut make = || {
            Machine::new(profile.clone()).map(|mut m| {
                m.attach_sd(sd_dir.clone());
                m.attach_eeprom(eeprom.clone());
                m
            })
        };
        let mut finished = |mut machine: Machine| {
            if args.report.is_some() {
                machine.finish(&mut |_, _| {});
                write_report(serde_json::to_string_pretty(&machine.report()));
            }
        };
        serve(endpoint.as_mut(), &mut make, &mut finished, &options, log, &stop)?
    };
    drop(endpoint);
    // The session folder goes before the summary is printed: with standard error a closed
    // pipe (`gweave serve ... 2>&1 | head -1`), that print ends the process (SIGPIPE, as Unix
    // tools end), which left the folder behind.
    drop(session_dir);
    print_summary(&summary);
    match report_error {
        Some(e) => Err(e),
        None => Ok(ExitCode::SUCCESS),
    }
}

/// The session log, which says on standard error when it can no longer be written (a full
/// disk): the printer goes on without it, as a board goes on without its SD card log, but the
/// user learns why the log ends there.
struct SaysWhenItFails<W> {
    inner: W,
    path: PathBuf,
}

impl<W: Write> SaysWhenItFails<W> {
    fn said<T>(&self, result: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &result {
            eprintln!(
                "gweave serve: --log {}: {e}; the log stops here, the printer goes on",
                self.path.display()
            );
        }
        result
    }
}

impl<W: Write> Write for SaysWhenItFails<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let result = self.inner.write(buf);
        self.said(result)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let result = self.inner.flush();
        self.said(result)
    }
}

fn print_summary(s: &ServeSummary) {
    let l = &s.link;
    eprintln!(
        "gweave serve: {} session(s), {} lines, {} executed, {} refused with a resend or error, {} duplicates, {} busy",
        s.sessions, l.lines, l.executed, l.errors, l.duplicates, l.busy
    );
}
