//! One vocabulary (docs/pipeline.md): every argument of every command shows its default in
//! `--help`, and one flag name means one thing (one value name, one unit) in every command.

use std::collections::BTreeMap;

use clap::Command;

/// Every subcommand, nested ones included, with its path (`rotary wrap`).
fn walk(cmd: &Command, path: &str, out: &mut Vec<(String, Command)>) {
    for sub in cmd.get_subcommands() {
        let name = format!("{path} {}", sub.get_name()).trim().to_owned();
        out.push((name.clone(), sub.clone()));
        walk(sub, &name, out);
    }
}

fn commands() -> Vec<(String, Command)> {
    let mut all = Vec::new();
    walk(&gweave_cli::command(), "", &mut all);
    all
}

/// Value names of arguments that name a file or folder: absent, the file is not read or
/// written, which is no default to state.
const PATHS: [&str; 10] =
    ["FILE", "PNG", "TOML", "OUT", "OUT.gcode", "DIR", "PROFILE.toml", "B", "PATH", "CSV"];

#[test]
fn every_default_is_shown_in_help() {
    let mut missing = Vec::new();
    for (name, cmd) in commands() {
        for arg in cmd.get_arguments() {
            let takes_value =
                arg.get_num_args().is_some_and(|n| n.takes_values()) || arg.get_action().takes_values();
            if arg.is_positional() || !takes_value || arg.is_required_set() || arg.is_hide_set() {
                continue;
            }
            let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
            let shown = if arg.get_default_values().is_empty() {
                let help = help.to_lowercase();
                help.contains("[default:") || help.contains("default:") || help.contains("(default")
            } else {
                !arg.is_hide_default_value_set()
            };
            let value_name =
                arg.get_value_names().and_then(|v| v.first()).map(|v| v.to_string()).unwrap_or_default();
            let is_path = PATHS.iter().any(|p| value_name == *p || value_name.starts_with(&format!("{p}|")));
            let repeatable = matches!(arg.get_action(), clap::ArgAction::Append);
            if !shown && !is_path && !repeatable {
                missing.push(format!("gweave {name} --{}", arg.get_long().unwrap_or("?")));
            }
        }
    }
    assert!(missing.is_empty(), "arguments whose default --help does not show:\n  {}", missing.join("\n  "));
}

#[test]
fn one_flag_name_has_one_value_name_in_every_command() {
    let mut seen: BTreeMap<String, BTreeMap<String, Vec<String>>> = BTreeMap::new();
    for (name, cmd) in commands() {
        for arg in cmd.get_arguments() {
            let (Some(long), Some(values)) = (arg.get_long(), arg.get_value_names()) else { continue };
            // `-o` names where each command writes, a file or a folder as the command needs.
            if long == "output" {
                continue;
            }
            // `TOML|slicer`: a profile file, or a word for a built-in one.
            let value = values
                .iter()
                .map(|v| v.as_str().split('|').next().unwrap_or("").to_owned())
                .collect::<Vec<_>>()
                .join(" ");
            seen.entry(long.to_owned()).or_default().entry(value).or_default().push(name.clone());
        }
    }
    let clashes: Vec<String> = seen
        .iter()
        .filter(|(_, by_value)| by_value.len() > 1)
        .map(|(long, by_value)| format!("--{long}: {by_value:?}"))
        .collect();
    assert!(clashes.is_empty(), "one flag, several meanings:\n  {}", clashes.join("\n  "));
}

#[test]
fn us_spellings_and_older_names_are_accepted() {
    let cli = gweave_cli::command();
    let find = |path: &[&str], long: &str| {
        let mut cmd = &cli;
        for p in path {
            cmd = cmd.find_subcommand(p).unwrap();
        }
        cmd.get_arguments()
            .find(|a| a.get_long() == Some(long) || a.get_all_aliases().is_some_and(|al| al.contains(&long)))
            .and_then(|a| a.get_long())
            .map(str::to_owned)
    };
    assert_eq!(find(&["preview"], "color-by").as_deref(), Some("colour-by"));
    assert_eq!(find(&["preview"], "tool-colors").as_deref(), Some("tool-colours"));
    assert_eq!(find(&["purge-shift"], "purge").as_deref(), Some("purge-mm"));
    assert_eq!(find(&["rotary", "wrap"], "feed").as_deref(), Some("feed-convention"));
    assert_eq!(find(&["rotary", "tube"], "feed").as_deref(), Some("feed-convention"));
}

#[test]
fn quiet_means_one_thing_in_every_command_that_prints_a_summary() {
    let mut without = Vec::new();
    for (name, cmd) in commands() {
        let has_summary = cmd.get_arguments().any(|a| a.get_long() == Some("json"));
        let quiet = cmd.get_arguments().find(|a| a.get_long() == Some("quiet"));
        match quiet {
            Some(q) => assert_eq!(
                q.get_help().map(|h| h.to_string()).as_deref(),
                Some("No progress bar and no human summary; errors, warnings and findings still print, and --json and --report still write"),
                "gweave {name} -q"
            ),
            None if has_summary => without.push(name),
            None => {}
        }
    }
    assert!(without.is_empty(), "commands with a summary but no -q: {without:?}");
}

#[test]
fn every_colour_flag_takes_the_us_spelling_too() {
    let mut missing = Vec::new();
    for (name, cmd) in commands() {
        for arg in cmd.get_arguments() {
            let Some(long) = arg.get_long().filter(|l| l.contains("colour")) else { continue };
            let us = long.replace("colour", "color");
            if !arg.get_all_aliases().is_some_and(|a| a.contains(&us.as_str())) {
                missing.push(format!("gweave {name} --{long} (no --{us})"));
            }
        }
    }
    assert!(missing.is_empty(), "{missing:?}");
}
