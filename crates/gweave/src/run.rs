//! The runner: how every command and transform sets up a run of a [`Pass`], in one place.
//!
//! A run reads a [`Source`] (a file of any container, standard input as `-`, or a text in
//! memory), with the machine options its flavour implies, strictly or leniently, and writes to a
//! [`Target`], to memory, or nowhere. A transform that writes `E` words says so
//! ([`Run::writes_e`]) and a file that extrudes with another letter is refused before anything
//! is written. The flavour is read once, from the file's ends, and a transform that needs it
//! before it builds its pass (`mix` chooses its dialect from it) asks [`Run::flavour`] first.
//!
//! ```
//! use gweave::{Identity, Run, Strictness};
//! let text = b"G1 X1\nG1 X1..2\nG1 X3\n";
//! let mut pass = Identity::default();
//! let ran = Run::text(text).to_memory().strictness(Strictness::Lenient).run(&mut pass).unwrap();
//! assert_eq!((ran.output.as_slice(), ran.malformed.first_malformed_line), (&text[..], Some(2)));
//! let err = Run::text(text).to_memory().run(&mut pass).unwrap_err();
//! assert_eq!(err.to_string(), "<input>:2:5: malformed number after 'X'");
//! ```

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::firmware::Firmware;
use crate::gcode::container;
use crate::gcode::flavour::{flavour_in, read_flavour, require_e_extruder};
use crate::gcode::state::{State, StateOptions};
use crate::gcode::writer::{Output, Target};
use crate::malformed::Malformed;
use crate::pass::{drive_reader, scan_ahead, Counting, Pass, Progress, Quiet, Reading, Strictness};

/// The name a text in memory goes by in messages.
pub(crate) const IN_MEMORY: &str = "<input>";

/// What a run reads.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// A file: text, gzip or binary G-code, or standard input as `-` (see [`container::open`]).
    File(&'a Path),
    /// A whole text in memory (tests, Python), named `<input>` in messages.
    Text(&'a [u8]),
}

impl Source<'_> {
    /// The name messages give the input.
    pub fn path(&self) -> &Path {
        match self {
            Source::File(p) => p,
            Source::Text(_) => Path::new(IN_MEMORY),
        }
    }
}

/// Where a run writes.
#[derive(Debug, Clone, Default)]
pub enum Dest {
    /// Nowhere: a pass that only reads.
    #[default]
    Nowhere,
    /// Into [`Ran::output`].
    Memory,
    /// A file, in place, or standard output, committed only if the whole run succeeded.
    Target(Target),
}

/// What a finished run knows: the machine state after the last line, the lines a lenient run
/// read past (none in a strict run, which stops at the first), and the output written to
/// [`Dest::Memory`] (empty otherwise).
#[derive(Debug)]
pub struct Ran {
    /// The machine state after the last line.
    pub state: State,
    /// The lines a lenient run read past.
    pub malformed: Malformed,
    /// What the run wrote to [`Dest::Memory`].
    pub output: Vec<u8>,
}

/// A run's settings, built with the methods below (defaults: strict, no configured firmware so
/// the file's flavour names it, no progress, no `E` requirement).
pub struct Run<'a> {
    source: Source<'a>,
    options: StateOptions,
    /// The machine's firmware, if the caller knows it (a profile's key, a flag).
    firmware: Option<Firmware>,
    strictness: Strictness,
    progress: Option<&'a mut dyn Progress>,
    /// `None`: not read yet.
    flavour: Option<Option<String>>,
    writes_e: bool,
    dest: Dest,
}

impl<'a> Run<'a> {
    /// A run over the file at `path` (`-`: standard input).
    pub fn file(path: &'a Path) -> Self {
        Self::of(Source::File(path))
    }

    /// A run over G-code text in memory.
    pub fn text(text: &'a [u8]) -> Self {
        Self::of(Source::Text(text))
    }

    /// A run over `source`.
    pub fn of(source: Source<'a>) -> Self {
        Run {
            source,
            options: StateOptions::default(),
            firmware: None,
            strictness: Strictness::Strict,
            progress: None,
            flavour: None,
            writes_e: false,
            dest: Dest::Nowhere,
        }
    }

    /// Writes to `target` (see [`Dest::Target`]).
    pub fn to(self, target: &Target) -> Self {
        self.dest(Dest::Target(target.clone()))
    }

    /// Writes into [`Ran::output`].
    pub fn to_memory(self) -> Self {
        self.dest(Dest::Memory)
    }

    /// Where the output goes.
    pub fn dest(mut self, dest: Dest) -> Self {
        self.dest = dest;
        self
    }

    /// The machine options (default: Marlin's). Their `firmware` is replaced by the run's
    /// ([`Run::resolved_firmware`]).
    pub fn options(mut self, options: StateOptions) -> Self {
        self.options = options;
        self
    }

    /// The machine's firmware, when the caller knows it (a profile's key, a flag): it wins over
    /// the one the file's flavour names ([`Firmware::resolve`]). `None` (the default) leaves the
    /// choice to the flavour, then Marlin.
    pub fn firmware(mut self, firmware: Option<Firmware>) -> Self {
        self.firmware = firmware;
        self
    }

    /// How malformed lines are treated (default: strict, the first one stops the run).
    pub fn strictness(mut self, strictness: Strictness) -> Self {
        self.strictness = strictness;
        self
    }

    /// Where progress is reported (the CLI's bar); default none.
    pub fn progress(mut self, progress: &'a mut dyn Progress) -> Self {
        self.progress = Some(progress);
        self
    }

    /// The file's flavour, when the caller has read it already ([`read_flavour`]).
    pub fn known_flavour(mut self, flavour: Option<String>) -> Self {
        self.flavour = Some(flavour);
        self
    }

    /// The run writes `E` words (purges, split moves): a file whose flavour extrudes with
    /// another letter is refused ([`require_e_extruder`]) before anything is written.
    pub fn writes_e(mut self) -> Self {
        self.writes_e = true;
        self
    }

    /// What the run reads.
    pub fn source(&self) -> Source<'a> {
        self.source
    }

    /// Where the run writes.
    pub fn destination(&self) -> &Dest {
        &self.dest
    }

    /// The file's flavour (read from its ends the first time: the PrusaSlicer family names it
    /// only in the settings block after the last move), checked against [`Run::writes_e`].
    pub fn flavour(&mut self) -> Result<Option<&str>> {
        let flavour = match self.flavour.take() {
            Some(known) => known,
            None => match self.source {
                Source::File(path) => read_flavour(path).map_err(|e| Error::io(path, e))?,
                Source::Text(text) => flavour_in(text),
            },
        };
        if self.writes_e {
            let firmware = Firmware::resolve(self.firmware, flavour.as_deref());
            require_e_extruder(self.source.path(), firmware, flavour.as_deref())?;
        }
        Ok(self.flavour.insert(flavour).as_deref())
    }

    /// The firmware the file is read as: the configured one ([`Run::firmware`]), else the one
    /// its flavour names, else Marlin ([`Firmware::resolve`], the one rule).
    pub fn resolved_firmware(&mut self) -> Result<Firmware> {
        let configured = self.firmware;
        Ok(Firmware::resolve(configured, self.flavour()?))
    }

    /// Streams the input through `pass` once more without output or progress, with the same
    /// settings, before the run proper (a transform that needs a figure of the whole file
    /// first, as `rotary wrap` the part's width).
    pub fn prescan<P: Pass + ?Sized>(&mut self, pass: &mut P) -> Result<State> {
        let flavour = self.flavour()?.map(str::to_owned);
        let again = Run {
            source: self.source,
            options: self.options.clone(),
            firmware: self.firmware,
            strictness: self.strictness,
            progress: None,
            flavour: Some(flavour),
            writes_e: false,
            dest: Dest::Nowhere,
        };
        again.scan(pass)
    }

    /// Streams the input through `pass` without output. Returns the final state. A file is
    /// read and lexed on a second thread.
    pub fn scan<P: Pass + ?Sized>(self, pass: &mut P) -> Result<State> {
        self.drive(pass, &mut io::sink(), None, true)
    }

    /// Streams the input through `pass` to the run's [`Dest`].
    pub fn run<P: Pass + ?Sized>(mut self, pass: &mut P) -> Result<Ran> {
        match std::mem::take(&mut self.dest) {
            Dest::Nowhere => self.counted(pass, &mut io::sink(), None),
            Dest::Memory => {
                let len = match self.source {
                    Source::Text(t) => t.len(),
                    Source::File(_) => 0,
                };
                let mut out = Vec::with_capacity(len + len / 8);
                let ran = self.counted(pass, &mut out, Some(Path::new("<output>")))?;
                Ok(Ran { output: out, ..ran })
            }
            Dest::Target(target) => {
                let input = match self.source {
                    Source::File(p) => Some(p.to_path_buf()),
                    Source::Text(_) => None,
                };
                let mut out = Output::create(&target, input.as_deref())?;
                // Write errors name the file being written (not its temporary file, nor the
                // input).
                let out_name = out.dest().map_or_else(|| PathBuf::from("<stdout>"), Path::to_path_buf);
                let ran = self.counted(pass, &mut out, Some(&out_name))?;
                out.commit()?;
                Ok(ran)
            }
        }
    }

    /// A lenient run counts the lines it reads past.
    fn counted<P: Pass + ?Sized>(
        self,
        pass: &mut P,
        out: &mut dyn Write,
        out_name: Option<&Path>,
    ) -> Result<Ran> {
        if self.strictness == Strictness::Strict {
            let state = self.drive(pass, out, out_name, false)?;
            return Ok(Ran { state, malformed: Malformed::default(), output: Vec::new() });
        }
        let mut counting = Counting::new(pass);
        let state = self.drive(&mut counting, out, out_name, false)?;
        Ok(Ran { state, malformed: counting.malformed, output: Vec::new() })
    }

    /// `ahead`: a file is read and lexed on a second thread (for a run without output).
    fn drive<P: Pass + ?Sized>(
        mut self,
        pass: &mut P,
        out: &mut dyn Write,
        out_name: Option<&Path>,
        ahead: bool,
    ) -> Result<State> {
        let options = StateOptions { firmware: self.resolved_firmware()?, ..self.options };
        let mut quiet = Quiet;
        let progress = self.progress.unwrap_or(&mut quiet);
        let strictness = self.strictness;
        match self.source {
            Source::File(path) => {
                let input = container::open(path).map_err(|e| Error::io(path, e))?;
                if let Some(len) = input.text_len {
                    progress.set_len(len);
                }
                if ahead {
                    return scan_ahead(input, path, options, strictness, progress, pass);
                }
                let reading =
                    Reading { path, output: out_name, options, strictness, progress: Some(progress) };
                drive_reader(input, reading, pass, out)
            }
            // Write errors of an in-memory text name `<input> (output)`, whatever the output.
            Source::Text(text) => {
                let reading = Reading {
                    options,
                    strictness,
                    progress: Some(progress),
                    ..Reading::new(Path::new(IN_MEMORY))
                };
                drive_reader(text, reading, pass, out)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pass::Identity;

    /// Regression (for_flavour_overrode_the_configured_firmware): the runner let the file's
    /// flavour override the firmware it was given, the reverse of [`Firmware::resolve`]. A file
    /// sliced with Klipper's flavour, run on a machine configured for RepRapFirmware, reads as
    /// RepRapFirmware: under `M82`, `G91` leaves E absolute (1 mm fed, not Klipper's 3).
    #[test]
    fn the_configured_firmware_wins_over_the_files_flavour() {
        let text = b";FLAVOR:Klipper\nM82\nG1 E1\nG91\nG1 E1\nG1 E1\n";
        let read = |firmware| Run::text(text).firmware(firmware).run(&mut Identity::default()).unwrap().state;
        let flavoured = read(None);
        assert_eq!((flavoured.options().firmware, flavoured.filament_mm[0]), (Firmware::Klipper, 3.0));
        let configured = read(Some(Firmware::RepRapFirmware));
        assert_eq!(
            (configured.options().firmware, configured.filament_mm[0]),
            (Firmware::RepRapFirmware, 1.0)
        );
    }

    /// A transform that writes `E` refuses a file read as a LinuxCNC machine's (extruding with
    /// `A`), whether its flavour says so or its machine is configured so, and accepts a `mach3`
    /// file on a machine configured for Marlin.
    #[test]
    fn writing_e_follows_the_resolved_firmware() {
        let mach3 = b"; gcode_flavor = mach3\nG1 X1 A1\n";
        let refused = Run::text(mach3).writes_e().run(&mut Identity::default()).unwrap_err();
        assert!(matches!(refused, Error::ForeignExtruder { letter: b'A', .. }), "{refused}");
        let marlin =
            Run::text(mach3).writes_e().firmware(Some(Firmware::Marlin)).run(&mut Identity::default());
        assert_eq!(marlin.unwrap().state.options().firmware, Firmware::Marlin);
        let plain = b"G1 X1 E1\n";
        let linuxcnc =
            Run::text(plain).writes_e().firmware(Some(Firmware::LinuxCnc)).run(&mut Identity::default());
        assert!(matches!(linuxcnc, Err(Error::ForeignExtruder { letter: b'A', .. })));
    }
}
