//! The transform jobs as subcommands, derived from the registry
//! ([`gweave_sim::transform::transforms`]): each row is `gweave <command> INPUT -o OUT`, its
//! help the job's [`Transform::HELP`], a flag per option it declares, the groups every
//! transform shares (`-o`/`--in-place`, `--lenient`, `--json`/`--report`/`-q`), and one run
//! ([`run_job`]: progress bar, warnings, report or summary) that `mix` and `rotary wrap`, whose
//! commands are their own, share. A new transform needs nothing here.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::error::ErrorKind;
use clap::{ArgMatches, Args, Command, FromArgMatches, Subcommand};
use gweave::gcode::writer::Target;
use gweave::options::{JobOptions, Value};
use gweave::Strictness;
use gweave::Transformed;
use gweave_sim::transform::{transforms, EachTransform, Job, Outcome, Transform};
use serde::Serialize;

use crate::args::Lenient;
use crate::common::{print_malformed, print_summary, OutputArgs, ReportArgs};
use crate::files::Files;
use crate::options::{failed, Options};

// (No doc comment: the command's help is the job's, set where the subcommand is made.)
#[derive(Args, Debug)]
pub struct TransformArgs<O: JobOptions + Clone + std::fmt::Debug + Send + Sync + 'static> {
    /// The G-code file to read.
    pub input: PathBuf,
    #[command(flatten)]
    pub out: OutputArgs,
    #[command(flatten)]
    pub options: Options<O>,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

/// The derived subcommand called, parsed into the run it asks for.
pub struct Transforms(Box<dyn FnOnce() -> Result<ExitCode>>);

impl Transforms {
    pub fn run(self) -> Result<ExitCode> {
        (self.0)()
    }
}

/// `gweave <command>` of the job `T`: checks its files (the input, the settings file its
/// options name, the output, the report), then runs it.
fn run<T: Transform>(args: TransformArgs<T::Options>) -> Result<ExitCode> {
    let target = args.out.target()?;
    args.report.refuse_json_with_stdout(target.is_stdout())?;
    let (settings_flag, settings) = settings_file(&*args.options);
    Files::new()
        .read("INPUT", Some(&args.input))
        .read(&settings_flag, settings.as_deref())
        .target(&target, &args.input)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let job = |job: Job<'_>| T::run(&args.options, job);
    run_job(&args.report, args.lenient.strictness(), &args.input, &target, job, Shown::of::<T>())
}

/// The settings file a job's options name (the option `config`), and its flag as the CLI
/// spells it (`-c`), for the files checked before the run.
pub(crate) fn settings_file<O: JobOptions>(options: &O) -> (String, Option<PathBuf>) {
    let config = O::SPEC.iter().zip(options.values()).find(|(spec, _)| spec.name == "config");
    match config {
        Some((spec, value)) => {
            let flag = spec.shape.short.map_or_else(|| format!("--{}", spec.flag()), |c| format!("-{c}"));
            let path = match value {
                Some(Value::Path(p)) => Some(p),
                _ => None,
            };
            (flag, path)
        }
        None => ("--config".to_owned(), None),
    }
}

/// What a transform shows after its run besides its report.
pub struct Shown<R> {
    /// Its warnings, one line each after `gweave: `.
    pub warnings: fn(&R) -> Vec<String>,
    /// Its human summary.
    pub summary: fn(&R, &mut dyn Write) -> std::io::Result<()>,
}

impl<R> Shown<R> {
    /// What the registry's job `T` shows: its warnings and its summary.
    pub fn of<T: Transform<Report = R>>() -> Self {
        Shown { warnings: T::warnings, summary: |r, out| write!(out, "{}", T::summary(r)) }
    }
}

/// Runs a transform job on `input` into `target` with a progress bar, prints its warnings (with
/// -q too: docs/pipeline.md), then emits its report (`--json`, `--report`) or prints its summary
/// with the malformed lines read past, on standard error when the G-code goes to standard
/// output.
pub fn run_job<R: Serialize>(
    report_args: &ReportArgs,
    strictness: Strictness,
    input: &Path,
    target: &Target,
    job: impl FnOnce(Job<'_>) -> Outcome<R>,
    shown: Shown<R>,
) -> Result<ExitCode> {
    let mut bar = report_args.quiet.bar();
    let (report, malformed) =
        job(Job { strictness, progress: Some(&mut bar), ..Job::new(input, target) }).map_err(failed)?;
    drop(bar);
    for line in (shown.warnings)(&report) {
        eprintln!("gweave: {line}");
    }
    if report_args.emit(&Transformed::new(&report, malformed, strictness))? {
        let summary = |out: &mut dyn Write| {
            (shown.summary)(&report, out)?;
            print_malformed(out, &malformed)
        };
        // Keep standard output clean when the G-code goes there.
        if target.is_stdout() {
            summary(&mut std::io::stderr().lock())?;
        } else {
            print_summary(summary)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A help text written as a doc comment is (paragraphs between blank lines, lines of a
/// paragraph joined) as clap's derive makes it: the first paragraph without its full stop for
/// `-h`, the whole for `--help` when there is more than one paragraph.
fn help(text: &str) -> (String, Option<String>) {
    let mut paragraphs: Vec<String> = Vec::new();
    let mut open = false;
    for line in text.lines().map(str::trim) {
        match (line.is_empty(), open) {
            (true, _) => open = false,
            (false, true) => {
                if let Some(last) = paragraphs.last_mut() {
                    last.push(' ');
                    last.push_str(line);
                }
            }
            (false, false) => {
                paragraphs.push(line.to_owned());
                open = true;
            }
        }
    }
    let first = paragraphs.first().cloned().unwrap_or_default();
    let short = match first.strip_suffix('.') {
        Some(s) if !first.ends_with("..") => s.to_owned(),
        _ => first,
    };
    let long = (paragraphs.len() > 1).then(|| paragraphs.join("\n\n"));
    (short, long)
}

/// The subcommand of the job `T`.
fn command<T: Transform>() -> Command {
    let (about, long_about) = help(T::HELP);
    let cmd = TransformArgs::<T::Options>::augment_args(Command::new(T::Options::COMMAND)).about(about);
    match long_about {
        Some(long) => cmd.long_about(long),
        None => cmd,
    }
}

impl Subcommand for Transforms {
    fn augment_subcommands(cmd: Command) -> Command {
        struct Add(Option<Command>);
        impl EachTransform for Add {
            fn transform<T: Transform>(&mut self) {
                if !T::OWN_COMMAND {
                    self.0 = self.0.take().map(|cmd| cmd.subcommand(command::<T>()));
                }
            }
        }
        let mut add = Add(Some(cmd));
        transforms(&mut add);
        add.0.unwrap_or_else(|| Command::new("gweave"))
    }

    fn augment_subcommands_for_update(cmd: Command) -> Command {
        Self::augment_subcommands(cmd)
    }

    fn has_subcommand(name: &str) -> bool {
        struct Has<'a>(&'a str, bool);
        impl EachTransform for Has<'_> {
            fn transform<T: Transform>(&mut self) {
                self.1 |= !T::OWN_COMMAND && T::Options::COMMAND == self.0;
            }
        }
        let mut has = Has(name, false);
        transforms(&mut has);
        has.1
    }
}

impl FromArgMatches for Transforms {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        struct Find<'a> {
            name: &'a str,
            matches: &'a ArgMatches,
            found: Option<Result<Transforms, clap::Error>>,
        }
        impl EachTransform for Find<'_> {
            fn transform<T: Transform>(&mut self) {
                if !T::OWN_COMMAND && T::Options::COMMAND == self.name {
                    let args = TransformArgs::<T::Options>::from_arg_matches(self.matches);
                    self.found = Some(args.map(|args| Transforms(Box::new(move || run::<T>(args)))));
                }
            }
        }
        let Some((name, matches)) = m.subcommand() else {
            return Err(clap::Error::raw(ErrorKind::MissingSubcommand, "a transform's command is required"));
        };
        let mut find = Find { name, matches, found: None };
        transforms(&mut find);
        find.found.unwrap_or_else(|| {
            Err(clap::Error::raw(ErrorKind::InvalidSubcommand, format!("no transform {name}")))
        })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn help_is_made_as_clap_makes_it_from_a_doc_comment() {
        let (short, long) = help("\n    One line\n    goes on.\n\n    Two.\n    ");
        assert_eq!(short, "One line goes on");
        assert_eq!(long.as_deref(), Some("One line goes on.\n\nTwo."));
        assert_eq!(help("Only one..."), ("Only one...".to_owned(), None));
    }

    /// Every row of the registry is a subcommand of `gweave`, its help the job's, its flags its
    /// options' (a row whose command is its own, `mix`, too).
    #[test]
    fn every_transform_of_the_registry_is_a_command_with_its_help_and_flags() {
        struct Check(Command, Vec<&'static str>);
        impl EachTransform for Check {
            fn transform<T: Transform>(&mut self) {
                let name = T::Options::COMMAND;
                let sub = self.0.find_subcommand(name).unwrap_or_else(|| panic!("no `gweave {name}`"));
                let about = sub.get_about().map(ToString::to_string);
                assert_eq!(about, Some(help(T::HELP).0), "{name}");
                for spec in T::Options::SPEC {
                    assert!(
                        sub.get_arguments().any(|a| a.get_long() == Some(&spec.flag())),
                        "{name} --{}",
                        spec.flag()
                    );
                }
                self.1.push(name);
            }
        }
        // clap's own checks first: a row named as another command would be a second `gweave
        // <command>`, refused here.
        crate::command().debug_assert();
        let mut check = Check(crate::command(), Vec::new());
        transforms(&mut check);
        assert!(check.1.contains(&"purge-shift") && check.1.contains(&"mix"), "{:?}", check.1);
    }
}
