//! The CLI's side of finishing a generated output that has no options type yet (`mix
//! --calibration-card`; every job with one writes its header from its options value,
//! `gweave_sim::transform::command_line`): the header names the run by its command line as
//! typed, canonicalised by the command's own clap definitions, which only the CLI has.

use std::path::{Path, PathBuf};

use anyhow::Result;
use gweave::Target;

/// Runs `write` into a scratch file, then writes that file to `target` with this run's header
/// and its metadata recomputed (`gweave_sim::with_metadata`).
pub fn with_metadata<R>(
    input: Option<&Path>,
    target: &Target,
    write: impl FnOnce(&Target) -> Result<R>,
) -> Result<(R, Option<PathBuf>)> {
    gweave_sim::with_metadata(input, target, &command_line(input), write)
}

/// Flags that say where the G-code comes from and goes, or how the run reports, not what it
/// does to the file; with a value, and alone.
const IO_FLAGS_WITH_VALUE: &[&str] =
    &["-o", "--output", "--format", "--report", "--preview", "--palette-png"];
const IO_FLAGS: &[&str] = &["--in-place", "--no-backup", "--force", "-q", "--quiet", "--json"];

/// The command and the options that shape its output, as typed, without the program, the
/// input and output files and the reporting flags: `mix -c mix.toml --purge-mm 20`. So the
/// same run from a file, a pipe or in place writes the same header.
/// The arguments `run` was given (the program name first): the process's own when the binary
/// runs, the list `gweave.main([...])` passes when Python runs the CLI in its process (where
/// `std::env::args()` is Python's own command line).
static ARGS: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

/// Keeps the arguments of this run for its header; each run replaces the last's.
pub fn remember_args(args: &[std::ffi::OsString]) {
    let args = args.iter().map(|a| a.to_string_lossy().into_owned()).collect();
    *ARGS.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = args;
}

fn command_line(input: Option<&Path>) -> String {
    let args = ARGS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone();
    transform_args(args.into_iter().skip(1), input)
}

fn transform_args(args: impl Iterator<Item = String>, input: Option<&Path>) -> String {
    let quote =
        |a: String| if a.is_empty() || a.contains([' ', '\t', '\'', '"']) { format!("{a:?}") } else { a };
    let mut kept = Vec::new();
    let mut skip_value = false;
    for arg in args {
        let flag = arg.split_once('=').map_or(arg.as_str(), |(f, _)| f);
        if std::mem::take(&mut skip_value)
            || IO_FLAGS.contains(&arg.as_str())
            || input == Some(Path::new(&arg))
        {
            continue;
        }
        if IO_FLAGS_WITH_VALUE.contains(&flag) {
            skip_value = flag == arg;
            continue;
        }
        kept.push(quote(canonical(&kept, arg)));
    }
    kept.join(" ")
}

/// A flag as the command's help names it: an older name or a US spelling (`--purge`,
/// `--color-by`) is written as its canonical name, so the header of a run does not depend on
/// which alias was typed. `kept[0]` is the subcommand (with `rotary`, `kept[1]` too).
fn canonical(kept: &[String], arg: String) -> String {
    let Some(long) = arg.strip_prefix("--") else { return arg };
    let (name, value) = long.split_once('=').map_or((long, None), |(n, v)| (n, Some(v)));
    let mut cmd = crate::command();
    for sub in kept.iter().take(2) {
        match cmd.find_subcommand(sub) {
            Some(found) => cmd = found.clone(),
            None => break,
        }
    }
    let found = cmd
        .get_arguments()
        .find(|a| a.get_long() == Some(name) || a.get_all_aliases().is_some_and(|all| all.contains(&name)));
    match (found.and_then(|a| a.get_long()), value) {
        (Some(long), Some(v)) => format!("--{long}={v}"),
        (Some(long), None) => format!("--{long}"),
        (None, _) => arg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_keeps_the_options_that_shape_the_output() {
        let args = |line: &str, input: Option<&str>| {
            transform_args(line.split(' ').map(str::to_owned), input.map(Path::new))
        };
        assert_eq!(
            args("purge-shift a.gcode --purge 2.5 -o b.gcode -q --report=r.json", Some("a.gcode")),
            "purge-shift --purge-mm 2.5"
        );
        assert_eq!(args("mix -c m.toml --in-place --no-backup a.gcode", Some("a.gcode")), "mix -c m.toml");
        assert_eq!(
            args("rotary tube --output=t.gcode --mandrel-diameter 20 --preview t.png --json", None),
            "rotary tube --mandrel-diameter 20"
        );
        let spaced =
            transform_args(["mix".into(), "--at-layer".into(), "0=Dark Red".into()].into_iter(), None);
        assert_eq!(spaced, r#"mix --at-layer "0=Dark Red""#);
    }

    #[test]
    fn a_header_names_the_canonical_flag_whatever_alias_was_typed() {
        let args = |line: &str| transform_args(line.split(' ').map(str::to_owned), None);
        assert_eq!(args("purge-shift --purge 2.5"), args("purge-shift --purge-mm 2.5"));
        assert_eq!(args("rotary wrap --feed=nist"), "rotary wrap --feed-convention=nist");
        assert_eq!(args("rotary tube --layers 4"), "rotary tube --layer-count 4");
    }
}
