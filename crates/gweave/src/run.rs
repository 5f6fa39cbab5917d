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
//! use gweave::pass::{Identity, Strictness};
//! use gweave::run::Run;
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
use crate::gcode::container;
use crate::gcode::flavour::{flavour_in, read_flavour, require_e_extruder};
use crate::gcode::state::{State, StateOptions};
use crate::gcode::writer::{Output, Target};
use crate::malformed::Malformed;
use crate::pass::{drive_reader, scan_ahead, Counting, Pass, Progress, Quiet, Strictness};

/// The name a text in memory goes by in messages.
pub const IN_MEMORY: &str = "<input>";

/// What a run reads.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// A file: text, gzip or binary G-code, or standard input as `-` (see [`container::open`]).
    File(&'a Path),
    /// A whole text in memory (tests, Python), named [`IN_MEMORY`] in messages.
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

/// A run's settings, built with the methods below (defaults: strict, Marlin options adjusted for
/// the file's flavour, no progress, no `E` requirement).
pub struct Run<'a> {
    source: Source<'a>,
    options: StateOptions,
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

    /// The machine options before the flavour adjusts them (default: Marlin's).
    pub fn options(mut self, options: StateOptions) -> Self {
        self.options = options;
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
            require_e_extruder(self.source.path(), flavour.as_deref())?;
        }
        Ok(self.flavour.insert(flavour).as_deref())
    }

    /// Streams the input through `pass` once more without output or progress, with the same
    /// settings, before the run proper (a transform that needs a figure of the whole file
    /// first, as `rotary wrap` the part's width).
    pub fn prescan<P: Pass + ?Sized>(&mut self, pass: &mut P) -> Result<State> {
        let flavour = self.flavour()?.map(str::to_owned);
        let again = Run {
            source: self.source,
            options: self.options.clone(),
            strictness: self.strictness,
            progress: None,
            flavour: Some(flavour),
            writes_e: false,
            dest: Dest::Nowhere,
        };
        again.scan(pass)
    }

    /// Streams the input through `pass` without output. Returns the final state. A file is
    /// read and lexed on a second thread ([`scan_ahead`]).
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
        let flavour = self.flavour()?.map(str::to_owned);
        let options = self.options.for_flavour(flavour.as_deref());
        let mut quiet = Quiet;
        let progress = self.progress.unwrap_or(&mut quiet);
        match self.source {
            Source::File(path) => {
                let input = container::open(path).map_err(|e| Error::io(path, e))?;
                if let Some(len) = input.text_len {
                    progress.set_len(len);
                }
                if ahead {
                    return scan_ahead(input, path, options, self.strictness, progress, pass);
                }
                drive_reader(input, path, out_name, options, self.strictness, progress, pass, out)
            }
            // Write errors of an in-memory text name `<input> (output)`, whatever the output.
            Source::Text(text) => {
                drive_reader(text, Path::new(IN_MEMORY), None, options, self.strictness, progress, pass, out)
            }
        }
    }
}
