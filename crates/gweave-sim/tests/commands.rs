//! The command list of the virtual printer is one source: the `?` reply, the table in
//! `docs/gcode.md` and what the interpreter dispatches all agree with the registry, `gweave_sim::COMMANDS`.

use std::path::{Path, PathBuf};

use gweave_sim::{help_lines, Machine, COMMANDS};
use gweave_sim::{BuildOptions, BuildOptionsError, MachineProfile};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn example_machine(name: &str) -> MachineProfile {
    let text = std::fs::read_to_string(repo().join("examples/machines").join(name)).unwrap();
    MachineProfile::from_toml_str(&text).unwrap()
}

/// Runs one line on a fresh machine; returns its replies.
fn replies(profile: MachineProfile, line: &str) -> Vec<String> {
    let mut m = Machine::new(profile).unwrap();
    let mut out = Vec::new();
    m.execute(line.as_bytes(), &mut |_t, l| out.push(l.to_owned()));
    assert!(m.report().unknown_commands.is_empty(), "{line}: {out:?}");
    out
}

/// The default machine with every build option built in (the defaults have the others).
fn full_firmware() -> MachineProfile {
    let text = "[firmware]\npsu_control = true\nautoreport_pos = true\nprobe = true\nlfn_write = true\nlinear_advance = true\n";
    MachineProfile::from_toml_str(text).unwrap()
}

#[test]
fn help_reply_is_the_command_list() {
    let out = replies(MachineProfile::default(), "?");
    assert_eq!(out, help_lines());
    assert_eq!(out.len(), COMMANDS.len() + 1);
    assert_eq!(out[1], format!("echo:  {:<19}  {}", "G0 G1", COMMANDS[0].what));
}

/// The table of commands in `docs/gcode.md` is the registry's: one row per entry, its codes, the
/// build option it needs (from `needs`, the one list of what an option gates) and what it does.
#[test]
fn docs_gcode_md_lists_the_same_commands() {
    let text = std::fs::read_to_string(repo().join("docs/gcode.md")).unwrap();
    let rows: Vec<&str> = section(&text, "## The virtual printer's commands")
        .lines()
        .filter(|l| l.starts_with("| `"))
        .collect();
    let want: Vec<String> = COMMANDS
        .iter()
        .map(|c| {
            let option = c.needs.key().map(|k| format!("`{k}`")).unwrap_or_default();
            format!("| `{}` | {option} | {} |", c.codes, c.what)
        })
        .collect();
    assert_eq!(rows, want, "the table should be:\n{}", want.join("\n"));
}

/// Each build option a row needs is named by the `[firmware]` key that builds it in: a board
/// built without that key (and what needs it) answers every command of the row `Unknown command`,
/// and one built with it carries them out (`every_listed_command_is_carried_out`).
#[test]
fn every_gated_command_is_unknown_without_the_key_its_row_names() {
    let mut gated = 0;
    for entry in COMMANDS {
        let Some(key) = entry.needs.key() else { continue };
        let mut table = toml::Value::try_from(full_firmware().firmware).unwrap();
        let mut off = key;
        // Switch off the key, then whatever the profile refuses without it (`lfn_write` needs
        // `long_filenames`, which needs `sdcard`).
        loop {
            let value = if off == "mesh" { toml::Value::Array(vec![]) } else { toml::Value::Boolean(false) };
            table.as_table_mut().unwrap().insert(off.to_owned(), value);
            let fw: BuildOptions = table.clone().try_into().unwrap();
            match fw.validate() {
                Err(BuildOptionsError::Needs(dependant, _)) => off = dependant,
                Ok(()) => break,
                Err(e) => panic!("{key}: {e}"),
            }
        }
        let profile = MachineProfile { firmware: table.try_into().unwrap(), ..MachineProfile::default() };
        assert!(!profile.firmware.has(entry.needs), "{key} = false still has {:?}", entry.needs);
        let mut m = Machine::new(profile).unwrap();
        for code in entry.codes.split_whitespace() {
            let mut out = Vec::new();
            m.execute(code.as_bytes(), &mut |_t, l| out.push(l.to_owned()));
            assert_eq!(out, [format!("echo:Unknown command: \"{code}\"")], "{key} = false");
            gated += 1;
        }
    }
    assert!(gated > 20, "{gated} gated codes");
}

/// The section of `text` under `heading`, up to the next heading of its level.
fn section<'a>(text: &'a str, heading: &str) -> &'a str {
    let rest = text.split(heading).nth(1).unwrap_or_else(|| panic!("{heading} in docs/gcode.md"));
    rest.split("\n## ").next().unwrap_or(rest)
}

/// The table of ranges in `docs/gcode.md` is the registry's: one row per command and group of
/// words sharing a range.
#[test]
fn docs_gcode_md_lists_every_range() {
    let text = std::fs::read_to_string(repo().join("docs/gcode.md")).unwrap();
    let rows: Vec<&str> = section(&text, "## Ranges of the virtual printer's parameters")
        .lines()
        .filter(|l| l.starts_with("| `"))
        .collect();
    let want: Vec<String> = COMMANDS
        .iter()
        .flat_map(|c| {
            c.params.iter().map(|p| {
                let letters: Vec<String> = p.letters.chars().map(String::from).collect();
                format!("| `{}` | `{}` | {} |", c.codes, letters.join(" "), p.range)
            })
        })
        .collect();
    assert_eq!(rows, want, "the table should be:\n{}", want.join("\n"));
}

/// The virtual printer carries out every command the engine's modal state interprets
/// (`gweave::gcode::codes`), so that `stats`, `estimate` and `sim` read the same commands.
#[test]
fn every_code_the_modal_state_interprets_is_in_the_registry() {
    let listed: Vec<&str> = COMMANDS.iter().flat_map(|c| c.codes.split_whitespace()).collect();
    for code in gweave::gcode::codes::modal_codes() {
        assert!(listed.contains(&code), "{code} is read by the modal state but not in the registry");
    }
}

#[test]
fn every_listed_command_is_carried_out() {
    for entry in COMMANDS {
        for code in entry.codes.split_whitespace() {
            let (profile, line) = match code {
                "T<n>" => (MachineProfile::default(), "T0".to_owned()),
                "M578" | "M700" => (example_machine("inkjet-c6602.toml"), format!("{code} P0 S1")),
                "SET_VELOCITY_LIMIT" => (example_machine("klipper.toml"), format!("{code} ACCEL=1000")),
                "SET_KINEMATIC_POSITION" => (example_machine("klipper.toml"), format!("{code} X=0")),
                // A build option a common Marlin build leaves out, as the row says it needs.
                _ if !MachineProfile::default().firmware.has(entry.needs) => {
                    (full_firmware(), code.to_owned())
                }
                _ => (MachineProfile::default(), code.to_owned()),
            };
            let out = replies(profile, &line);
            assert!(out.iter().all(|l| !l.contains("Unknown command")), "{line}: {out:?}");
        }
    }
    // And the check can fail: a command outside the list is unknown.
    let mut m = Machine::new(MachineProfile::default()).unwrap();
    m.execute(b"M302 P1", &mut |_t, _l| {});
    assert_eq!(m.report().unknown_commands["M302"], 1);
}

/// The registry is the only way in: a G- or M-code it does not list is unknown, whatever the
/// firmware was built with (every optional feature on here, so no code is unknown for want of
/// one).
#[test]
fn no_code_is_carried_out_without_being_listed() {
    let listed: Vec<&str> = COMMANDS.iter().flat_map(|c| c.codes.split_whitespace()).collect();
    let text = "[firmware]\npsu_control = true\nautoreport_pos = true\nprobe = true\nlfn_write = true\n\
                pin_control = true\nmesh = [3, 3]\n";
    let mut m = Machine::new(MachineProfile::from_toml_str(text).unwrap()).unwrap();
    let mut unlisted = 0;
    for letter in ['G', 'M'] {
        for number in 0..=1000 {
            let code = format!("{letter}{number}");
            if listed.contains(&code.as_str()) {
                continue;
            }
            let mut out = Vec::new();
            m.execute(code.as_bytes(), &mut |_t, l| out.push(l.to_owned()));
            assert_eq!(out, [format!("echo:Unknown command: \"{code}\"")], "{code}");
            unlisted += 1;
        }
    }
    assert_eq!(unlisted, 2 * 1001 - listed.iter().filter(|c| c.starts_with(['G', 'M'])).count());
}

/// `M900` (Marlin's linear advance) is there on a build with `LIN_ADVANCE`, as Prusa's firmware
/// has (a PrusaSlicer file for the MK3S sets it in its filament's start G-code: the virtual MK3S
/// answered "Unknown command"), refused out of Marlin's 0 to 10, and unknown on Marlin's shipped
/// configuration, as Marlin answers. (RepRapFirmware's `M572` stays unknown to a Marlin board:
/// a file sliced for the wrong firmware is told so, `stats_sim_agree.rs`.)
#[test]
fn linear_advance_is_known_where_the_firmware_has_it() {
    let prusa = example_machine("prusa-mk3.toml");
    assert_eq!(replies(prusa.clone(), "M900 K0.05"), Vec::<String>::new());
    let too_much = replies(prusa, "M900 K11");
    assert!(too_much.iter().any(|l| l.contains('K') && l.contains("0 to 10")), "{too_much:?}");
    let mut marlin = Machine::new(MachineProfile::default()).unwrap();
    let mut out = Vec::new();
    marlin.execute(b"M900 K0.05", &mut |_, l| out.push(l.to_owned()));
    assert_eq!(out, ["echo:Unknown command: \"M900 K0.05\""]);
}
