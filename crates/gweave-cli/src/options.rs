//! A job's options type ([`gweave::options`]) as the subcommand's flags: each option declared
//! in the engine is a flag named, helped, bounded and defaulted as declared there
//! (`purge_mm` is `--purge-mm MM`, refused out of its range before anything is read), so a new
//! option needs nothing here. A subcommand takes them with
//! `#[command(flatten)] options: Options<PurgeShiftOptions>`.

use std::ops::Deref;

use clap::error::ErrorKind;
use clap::{Arg, ArgAction, ArgMatches, Args, Command, FromArgMatches};
use gweave::options::{Kind, Spelling, Value};
use gweave::{JobFailure, JobOptions, OptionSpec};

/// The options `T` as read from the command line.
#[derive(Debug, Clone, Default)]
pub struct Options<T>(pub T);

impl<T> Deref for Options<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

/// The flag of one option.
fn arg<T: JobOptions>(spec: &'static OptionSpec) -> Arg {
    let mut arg = Arg::new(spec.name).long(spec.flag()).help(spec.help()).aliases(spec.shape.aliases);
    if let Some(letter) = spec.shape.short {
        arg = arg.short(letter);
    }
    arg = spec.shape.conflicts.iter().fold(arg, |arg, other| arg.conflicts_with(*other));
    if spec.kind == Kind::Flag {
        return arg.action(ArgAction::SetTrue);
    }
    // Read and checked as the engine reads it, so an option the job would refuse is refused
    // here, before anything is read, with clap's message naming the flag.
    let parse = move |text: &str| -> Result<Value, String> {
        let value = spec.parse(text).map_err(|e| e.reason())?;
        T::default().set(spec, value.clone()).map_err(|e| e.reason())?;
        Ok(value)
    };
    // A value may be a negative number (`--seam-rotation -7.5`), or a list starting with one
    // (`--origin -10,20`): clap otherwise takes `-7.5` or `-10,20` for a short flag and refuses
    // it. A list of numbers takes any value starting with a hyphen, which `parse` then refuses
    // if it is no list of numbers.
    arg = arg.value_name(spec.shape.value_name).value_parser(parse).allow_negative_numbers(true);
    if matches!(spec.kind, Kind::Numbers(_)) {
        arg = arg.allow_hyphen_values(true);
    }
    if let Some(default) = (spec.default)() {
        arg = arg.default_value(default);
    }
    match spec.kind {
        Kind::Repeated => arg.action(ArgAction::Append),
        _ => arg.action(ArgAction::Set),
    }
}

impl<T: JobOptions + Send + Sync + 'static> Args for Options<T> {
    fn augment_args(cmd: Command) -> Command {
        T::SPEC.iter().fold(cmd, |cmd, spec| cmd.arg(arg::<T>(spec)))
    }
    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

impl<T: JobOptions> FromArgMatches for Options<T> {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let mut options = T::default();
        for spec in T::SPEC {
            let value = match spec.kind {
                // `--no-interweave` sets `interweave` false.
                Kind::Flag => m.get_flag(spec.name).then_some(Value::Flag(!spec.shape.negated)),
                Kind::Repeated => m.get_many::<Value>(spec.name).map(|each| {
                    Value::Texts(
                        each.flat_map(|v| match v {
                            Value::Texts(t) => t.clone(),
                            _ => Vec::new(),
                        })
                        .collect(),
                    )
                }),
                _ => m.get_one::<Value>(spec.name).cloned(),
            };
            if let Some(value) = value {
                options
                    .set(spec, value)
                    .map_err(|e| clap::Error::raw(ErrorKind::ValueValidation, e.spelled(Spelling::Flag)))?;
            }
        }
        Ok(Options(options))
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

/// A job's failure as the CLI says it, for every job: the options it names spelled as flags;
/// an error that names none kept whole, its causes and its I/O kind (a closed pipe, a stop) for
/// `crate::run` to read.
pub fn failed<E: JobFailure + Send + Sync>(e: E) -> anyhow::Error {
    let spelled = e.spelled(Spelling::Flag);
    if spelled == e.to_string() {
        e.into()
    } else {
        anyhow::anyhow!(spelled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gweave::rotary::cylinder::FeedConvention;
    use gweave::MixOptions;
    use gweave::PurgeShiftOptions;
    use gweave::{PreviewOptions, RasterOptions, TubeOptions, WrapOptions};

    #[derive(clap::Parser, Debug)]
    struct Cli<T: JobOptions + Send + Sync + 'static> {
        #[command(flatten)]
        options: Options<T>,
    }

    fn parse<T: JobOptions + Send + Sync + 'static>(args: &[&str]) -> Result<T, String> {
        use clap::Parser;
        let all = std::iter::once("gweave").chain(args.iter().copied());
        Cli::<T>::try_parse_from(all).map(|c| c.options.0).map_err(|e| e.to_string())
    }

    /// Every job the engine lists (`gweave_sim::transform::jobs`, the one list) is a subcommand
    /// with a flag per option, named, helped, lettered and aliased as declared (issue 40: the
    /// jobs were listed by hand in each front end and in this test).
    #[test]
    fn every_job_of_the_engine_is_a_subcommand_with_its_declared_flags() {
        let cli = crate::command();
        let jobs = gweave_sim::transform::jobs();
        // The list holds at least the jobs the engine had when this was written (a new job needs
        // no edit here: the loop below holds it to its subcommand).
        let mut names: Vec<&str> = jobs.iter().map(|(command, _)| *command).collect();
        let listed = names.len();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), listed, "a job listed twice: {names:?}");
        for job in
            ["purge-shift", "mix", "rotary wrap", "rotary tube", "sim", "estimate", "preview", "raster"]
        {
            assert!(names.contains(&job), "{job} is not in the engine's jobs: {names:?}");
        }
        for (command, specs) in jobs {
            let mut cmd = &cli;
            for word in command.split(' ') {
                cmd = cmd.find_subcommand(word).unwrap_or_else(|| panic!("no subcommand {command}"));
            }
            for spec in specs {
                let flag = spec.flag();
                let arg = cmd.get_arguments().find(|a| a.get_long() == Some(flag.as_str()));
                let arg = arg.unwrap_or_else(|| panic!("{command}: no --{flag}"));
                assert_eq!(arg.get_help().map(ToString::to_string), Some(spec.help()), "{command} --{flag}");
                assert_eq!(arg.get_short(), spec.shape.short, "{command} --{flag}");
                assert_eq!(
                    arg.get_all_aliases().unwrap_or_default(),
                    spec.shape.aliases,
                    "{command} --{flag}"
                );
            }
        }
    }

    #[test]
    fn raster_keeps_its_flags_defaults_and_conflicts() {
        let o: RasterOptions =
            parse(&["--dialect", "reprap", "--fire-order", "before", "--origin", "10,20", "--heads", "2"])
                .unwrap();
        assert_eq!((o.threshold, o.density, o.pattern_columns), (0.5, 1, 4), "the defaults");
        assert_eq!((o.origin, o.heads), (Some([10.0, 20.0]), Some(2)));
        assert_eq!(
            o.header(),
            "--fire-order before --origin 10,20 --heads 2 --dialect reprapfirmware",
            "the defaults left out, the dialect by its name"
        );
        let err = parse::<RasterOptions>(&["--head", "h.toml", "--machine", "binder-jet"]).unwrap_err();
        assert!(err.contains("'--head <PROFILE.toml>' cannot be used with '--machine <TOML|NAME>'"), "{err}");
        let err = parse::<RasterOptions>(&["--dialect", "klipper"]).unwrap_err();
        assert!(err.contains("klipper has no inkjet fire command"), "{err}");
        let err = parse::<RasterOptions>(&["--heads", "1.5"]).unwrap_err();
        assert!(err.contains("for '--heads <N>': 1.5 is not a whole number"), "{err}");
    }

    #[test]
    fn rotary_flags_keep_their_spellings_and_aliases() {
        let w: WrapOptions = parse(&[
            "--seam-rotation",
            "7.5",
            "--feed",
            "combined",
            "--axes",
            "x,y,z",
            "--rotary-unit",
            "deg",
        ])
        .unwrap();
        assert_eq!(w.machine.feed_convention, Some(FeedConvention::Combined));
        assert_eq!((w.machine.axes, w.seam_rotation), (Some(['X', 'Y', 'Z']), Some(7.5)));
        // The machine's options first, each in its own name: the header of any spelling.
        assert_eq!(
            w.header(),
            "--feed-convention combined --rotary-unit degrees --axes X,Y,Z --seam-rotation 7.5"
        );
        let t: TubeOptions =
            parse(&["--layers", "3", "--no-interweave", "--mandrel-diameter", "20"]).unwrap();
        assert_eq!(
            (t.layer_count, t.interweave, t.machine.mandrel_diameter),
            (Some(3), Some(false), Some(20.0))
        );
        assert_eq!(t.header(), "--mandrel-diameter 20 --layer-count 3 --no-interweave");
        assert_eq!(parse::<TubeOptions>(&[]).unwrap().interweave, None, "no flag: the settings' own");
        let err = parse::<TubeOptions>(&["--layer-count", "2.5"]).unwrap_err();
        assert!(err.contains("for '--layer-count <N>': 2.5 is not a whole number"), "{err}");
        let err = parse::<WrapOptions>(&["--helical", "--seam-rotation", "5"]).unwrap_err();
        assert!(err.contains("'--helical' cannot be used with '--seam-rotation <DEG>'"), "{err}");
    }

    #[test]
    fn preview_keeps_its_flags_spellings_defaults_and_conflicts() {
        let o: PreviewOptions = parse(&[
            "--color-by",
            "feature",
            "--size",
            "640x480",
            "--layers",
            "3-5",
            "--tool-colors",
            "#ff0000,#00ff00",
        ])
        .unwrap();
        assert_eq!(o.colour_by, gweave::render::ColourBy::Feature);
        assert_eq!((o.size.width_px, o.size.height_px), (640, 480));
        assert_eq!(o.layers, Some(3..=5));
        assert_eq!(
            o.header(),
            "--layers 3-5 --colour-by feature --size 640x480 --tool-colours #ff0000,#00ff00"
        );
        let d: PreviewOptions = parse(&[]).unwrap();
        assert_eq!(
            (d.size.width_px, d.size.height_px, d.colour_by),
            (1200, 900, gweave::render::ColourBy::Tool)
        );
        let err = parse::<PreviewOptions>(&["--layer", "2", "--layers", "3-4"]).unwrap_err();
        assert!(err.contains("'--layer <N>' cannot be used with '--layers <A-B>'"), "{err}");
        let err = parse::<PreviewOptions>(&["--size", "8x900"]).unwrap_err();
        assert!(err.contains("for '--size <WIDTHxHEIGHT>': out of range: 16 to 16384 px"), "{err}");
        let err = parse::<PreviewOptions>(&["--view", "side"]).unwrap_err();
        assert!(err.contains(r#"unknown view "side" (top or iso)"#), "{err}");
    }

    #[test]
    fn flags_read_into_the_options_value() {
        let o: PurgeShiftOptions =
            parse(&["--purge", "2.5", "--tower-at", "10,20", "--cross-layers", "-c", "p.toml"]).unwrap();
        assert_eq!(o.purge_mm, Some(2.5));
        assert_eq!(o.tower_at, Some([10.0, 20.0]));
        assert!(o.cross_layers);
        assert_eq!(o.header(), "-c p.toml --purge-mm 2.5 --cross-layers --tower-at 10,20");
        let m: MixOptions =
            parse(&["--at-layer", "0=Red", "--at-layer", "5=Blue", "--dialect", "reprap"]).unwrap();
        assert_eq!(m.at_layer, ["0=Red", "5=Blue"]);
        assert_eq!(m.header(), "--at-layer 0=Red --at-layer 5=Blue --dialect reprapfirmware");
        assert_eq!(parse::<MixOptions>(&[]).unwrap(), MixOptions::default());
    }

    /// `--seam-rotation -7.5` was refused as an unknown flag `-7` (found by a new-user trial):
    /// only `--seam-rotation=-7.5` got through.
    #[test]
    fn a_negative_number_is_a_value_not_a_flag() {
        let w: WrapOptions = parse(&["--seam-rotation", "-7.5"]).unwrap();
        assert_eq!(w.seam_rotation, Some(-7.5));
        let w: WrapOptions = parse(&["--seam-rotation", "-7.5e0"]).unwrap();
        assert_eq!(w.seam_rotation, Some(-7.5));
        // A list starting with a negative number (a review found `--origin -10,20` refused).
        let r: RasterOptions = parse(&["--origin", "-10,20"]).unwrap();
        assert_eq!(r.origin, Some([-10.0, 20.0]));
        let p: PurgeShiftOptions = parse(&["--tower-at", "-5,10"]).unwrap();
        assert_eq!(p.tower_at, Some([-5.0, 10.0]));
    }

    #[test]
    fn a_refused_value_is_named_by_its_flag() {
        let err = parse::<PurgeShiftOptions>(&["--purge-mm", "2000"]).unwrap_err();
        assert!(
            err.contains("invalid value '2000' for '--purge-mm <MM>': out of range: 0 to 1000 mm"),
            "{err}"
        );
        let err = parse::<PurgeShiftOptions>(&["--purge-mm", "2", "--purge-mm3", "3"]).unwrap_err();
        assert!(err.contains("'--purge-mm <MM>' cannot be used with '--purge-mm3 <MM3>'"), "{err}");
        let err = parse::<PurgeShiftOptions>(&["--tower-at", "1"]).unwrap_err();
        assert!(err.contains("takes 2 values (X,Y), not 1"), "{err}");
        let err = parse::<MixOptions>(&["--dialect", "klipper"]).unwrap_err();
        assert!(err.contains("for '--dialect <DIALECT>': unknown variant `klipper`"), "{err}");
    }
}
