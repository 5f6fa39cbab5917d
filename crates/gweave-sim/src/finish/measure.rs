//! Measuring a written file for its metadata: its filament by the `stats` count, its settings,
//! its estimated times (normal and silent mode) and the time at each progress line.
//!
//! The estimate is the costly part: Marlin's step-exact planner, about 1 900 instructions a line
//! (docs/performance.md), twice for a file with silent-mode limits of its own. So the file is
//! read once, by a thread of its own, and handed in chunks to one thread per estimator and to
//! this one, which counts `stats`: the three work on as many cores as there are, at the pace of
//! the slowest. Each estimator is fed every line in file order, as one [`Estimator`] fed line by
//! line, so the figures are the same to the bit as a serial pass's; the channels are bounded, so
//! the memory is a few chunks whatever the file's size, and one time per progress line.

use std::io::{self, Read};
use std::path::Path;
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::Arc;

use gweave::firmware::Firmware;
use gweave::gcode::container;
use gweave::gcode::ends::read_ends;
use gweave::gcode::flavour::flavour_in;
use gweave::gcode::state::StateOptions;
use gweave::pass::{drive_reader, Ctx, Flow, Pass, Reading, Step, Strictness};
use gweave::post::metadata::{is_progress_line, read_setting, Figures};
use gweave::stats::{Stats, StatsPass};

use super::Result;
use crate::motion::estimate::{estimate_modes, ModeEstimate};
use crate::motion::limits::MotionProfile;
use crate::motion::slicer_limits::{slicer_limits, slicer_limits_silent};
use crate::profile::MachineProfile;

/// A chunk of the file, shared by its readers, or the error reading it.
type Shared = io::Result<Arc<[u8]>>;

/// Bytes read at a time and handed to every reader of the file.
const CHUNK: usize = 1 << 20;
/// Chunks in flight to each reader: what bounds the memory (a few MiB).
const CHUNKS_IN_FLIGHT: usize = 4;

/// Measures the written file at `path`.
///
/// The machine limits are the ones the slicer wrote into the file (normal and silent mode), else
/// the default machine's, read from the file's ends, as the flavour.
pub(super) fn measure(path: &Path) -> Result<Figures> {
    let ends = read_ends(path).map_err(|e| gweave::Error::io(path, e))?;
    let flavour = flavour_in(&ends);
    // Read as `stats` reads it (the metadata's filament comes from its pass).
    let firmware = Firmware::resolve(None, flavour.as_deref());
    let base = MachineProfile::default().motion;
    let normal = slicer_limits(&ends, &base).map_or_else(|_| base.clone(), |l| l.profile);
    let silent = slicer_limits_silent(&ends, &base).map_or_else(|_| normal.clone(), |l| l.profile);
    // A second estimate only for a file that shows silent-mode figures (PrusaSlicer's footer is
    // in its last 256 KiB, `M73 Q0 S..` in its first lines) with limits of their own.
    let contains = |needle: &[u8]| ends.windows(needle.len()).any(|w| w == needle);
    let silent =
        (contains(b"(silent mode)") || contains(b"M73 Q")).then_some(silent).filter(|s| *s != normal);
    let options = StateOptions { firmware, ..StateOptions::default() };
    let silent: Vec<MotionProfile> = silent.into_iter().collect();
    let (tally, (normal, silent)) = on_threads(path, options, &normal, &silent, firmware)?;
    // Without a silent mode of its own, the normal mode's figures stand for it.
    let silent = silent.first().unwrap_or(&normal);
    let normal = &normal;
    let first_layer = |t: &ModeEstimate| t.estimate.layer_s.first().copied().unwrap_or(0.0);
    let figures = Figures {
        filament_mm: tally.stats.filament.iter().map(|f| f.extruded_mm).collect(),
        diameter_mm: tally.stats.filament_diameter_mm,
        time_s: [normal.estimate.total_s, silent.estimate.total_s],
        first_layer_s: [first_layer(normal), first_layer(silent)],
        progress_s: normal.progress_s.iter().zip(&silent.progress_s).map(|(&n, &s)| [n, s]).collect(),
        ..tally.figures
    };
    Ok(figures)
}

/// The file read once and measured on threads: `stats` and the settings here, the estimate of
/// every mode on threads of its own ([`estimate_modes`]: one parse side, one plan side a mode).
fn on_threads(
    path: &Path,
    options: StateOptions,
    normal: &MotionProfile,
    others: &[MotionProfile],
    firmware: Firmware,
) -> Result<(Tally, (ModeEstimate, Vec<ModeEstimate>))> {
    let (to_tally, for_tally) = mpsc::sync_channel(CHUNKS_IN_FLIGHT);
    let (to_modes, for_modes) = mpsc::sync_channel(CHUNKS_IN_FLIGHT);
    std::thread::scope(|scope| {
        scope.spawn(move || spread(path, [Some(to_tally), Some(to_modes)]));
        let timed = scope.spawn(move || {
            estimate_modes(Chunks::new(for_modes), normal, others, firmware, is_progress_line)
        });
        let tally = tally(Chunks::new(for_tally), path, options);
        let timed = timed.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        match timed {
            // A fault on a line is the estimate's to report; a read error (no line) is the
            // tally's, with the file's name.
            Err(e) if e.line().is_some() => Err(e.into()),
            timed => {
                let tally = tally?;
                Ok((tally, timed?))
            }
        }
    })
}

/// The reading thread: the file in chunks to every reader, until the end or an error (passed
/// to each). A reader that stopped (on an error of its own) is left out.
fn spread<const N: usize>(path: &Path, mut readers: [Option<SyncSender<Shared>>; N]) {
    let mut send = |chunk: Shared| {
        for reader in &mut readers {
            let sent = match (reader.as_ref(), &chunk) {
                (None, _) => continue,
                (Some(r), Ok(c)) => r.send(Ok(Arc::clone(c))),
                (Some(r), Err(e)) => r.send(Err(io::Error::new(e.kind(), e.to_string()))),
            };
            if sent.is_err() {
                *reader = None;
            }
        }
        chunk.is_ok() && readers.iter().any(Option::is_some)
    };
    let mut input = match container::open(path) {
        Ok(input) => input,
        Err(e) => {
            send(Err(e));
            return;
        }
    };
    loop {
        // A short read makes a short chunk: the readers take the stream in any pieces.
        let mut buf = vec![0; CHUNK];
        match input.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => {
                buf.truncate(n);
                if !send(Ok(buf.into())) {
                    return;
                }
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => {
                send(Err(e));
                return;
            }
        }
    }
}

/// The chunks one reader receives, read as a stream.
struct Chunks {
    from: Receiver<Shared>,
    chunk: Arc<[u8]>,
    at: usize,
}

impl Chunks {
    fn new(from: Receiver<Shared>) -> Self {
        Chunks { from, chunk: Arc::from(&[][..]), at: 0 }
    }
}

impl Read for Chunks {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        while self.at == self.chunk.len() {
            match self.from.recv() {
                Ok(chunk) => (self.chunk, self.at) = (chunk?, 0),
                // The reading thread is done: the end of the file.
                Err(_) => return Ok(0),
            }
        }
        let n = buf.len().min(self.chunk.len() - self.at);
        buf[..n].copy_from_slice(&self.chunk[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// What this thread counts: `stats` and the settings the metadata needs.
struct Tally {
    stats: Stats,
    figures: Figures,
}

fn tally(input: impl Read, path: &Path, options: StateOptions) -> Result<Tally> {
    let mut pass = TallyPass { stats: StatsPass::new(None), figures: Figures::default() };
    let reading = Reading { options, strictness: Strictness::Lenient, ..Reading::new(path) };
    let state = drive_reader(input, reading, &mut pass, &mut io::sink())?;
    Ok(Tally { stats: pass.stats.into_stats(&state), figures: pass.figures })
}

/// The `stats` count and the settings ([`read_setting`]).
struct TallyPass {
    stats: StatsPass,
    figures: Figures,
}

impl Pass for TallyPass {
    fn reads_words(&self) -> bool {
        false
    }

    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn io::Write) -> Step {
        self.stats.line(ctx, out)?;
        if let Some(c) = ctx.block.comment_text(ctx.line.bytes) {
            read_setting(c, &mut self.figures);
        }
        Ok(Flow::Continue)
    }
}

#[cfg(test)]
mod tests {
    use gweave::gcode::reader::{LineReader, Part};

    use super::*;
    use crate::motion::estimate::Estimator;

    /// The serial pass the threads replaced: one estimator per mode fed every whole line, the
    /// clock read after each progress line.
    fn serial(text: &[u8], profile: &MotionProfile) -> ([f64; 2], Vec<f64>) {
        let mut est = Estimator::timing_only(profile).unwrap();
        est.read_as(Firmware::Marlin);
        let (mut reader, mut progress_s) = (LineReader::new(text), Vec::new());
        while let Some(line) = reader.next_line().unwrap() {
            if line.part == Part::Whole {
                est.line(line.bytes).unwrap();
                if is_progress_line(line.bytes) {
                    progress_s.push(est.now_s());
                }
            }
        }
        let est = est.finish();
        ([est.total_s, est.layer_s[0]], progress_s)
    }

    /// Regression: the metadata was measured by a serial pass after the transform (purge-shift
    /// 17x `cat`); the threads must give its figures to the bit, both modes.
    #[test]
    fn the_threaded_measure_gives_the_serial_figures_to_the_bit() {
        let fixture =
            format!("{}/../../tests/data/prusaslicer/pr_bunny_3tool_rel.gcode", env!("CARGO_MANIFEST_DIR"));
        let whole = std::fs::read_to_string(fixture).unwrap();
        let lines: Vec<&str> = whole.lines().collect();
        // Its first 6000 lines with progress lines in both modes every 500, and its settings
        // block (the silent mode's own limits).
        let mut text = String::new();
        for (i, line) in lines[..6000].iter().chain(&lines[lines.len() - 350..]).enumerate() {
            if i % 500 == 0 {
                text.push_str("M73 P0 R0\nM73 Q0 S0\n");
            }
            text.push_str(line);
            text.push('\n');
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m73.gcode");
        std::fs::write(&path, &text).unwrap();
        let figures = measure(&path).unwrap();
        let ends = read_ends(&path).unwrap();
        let base = MachineProfile::default().motion;
        let normal = slicer_limits(&ends, &base).unwrap().profile;
        let silent = slicer_limits_silent(&ends, &base).unwrap().profile;
        assert_ne!(normal, silent);
        let (normal_s, normal_progress) = serial(text.as_bytes(), &normal);
        let (silent_s, silent_progress) = serial(text.as_bytes(), &silent);
        assert_eq!(figures.time_s.map(f64::to_bits), [normal_s[0].to_bits(), silent_s[0].to_bits()]);
        assert_eq!(figures.first_layer_s.map(f64::to_bits), [normal_s[1].to_bits(), silent_s[1].to_bits()]);
        let expected: Vec<[f64; 2]> =
            normal_progress.into_iter().zip(silent_progress).map(|(n, s)| [n, s]).collect();
        assert_eq!(figures.progress_s.len(), 2 * 13);
        assert_eq!(figures.progress_s, expected);
        assert!(figures.filament_mm.iter().sum::<f64>() > 100.0, "{figures:?}");
    }
}
