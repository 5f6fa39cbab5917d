//! The `[firmware]` board: capabilities, settings and EEPROM, host commands, the SD card, and the
//! wall-timed `M400`, over the serial protocol where hosts see them.

use super::*;
use crate::link::serial::{frame_line, Protocol, ProtocolConfig};
use crate::profile::build_options::Feature;
use crate::profile::MachineProfile;

fn run(m: &mut Machine, text: &str) -> Vec<String> {
    let mut replies = Vec::new();
    for line in text.lines() {
        m.execute(line.as_bytes(), &mut |_t: f64, l: &str| replies.push(l.to_owned()));
    }
    replies
}

fn profile(firmware: &str) -> MachineProfile {
    let mut p = MachineProfile::from_toml_str(&format!("[firmware]\n{firmware}")).unwrap();
    p.thermal.extrude_min_c = None;
    p
}

/// Feeds numbered, checksummed lines from `from` on, as a host does; the replies.
fn feed(p: &mut Protocol<Machine>, from: i64, commands: &[&str]) -> Vec<String> {
    let mut replies = Vec::new();
    for (i, c) in commands.iter().enumerate() {
        let line = frame_line(from + i as i64, c) + "\n";
        p.feed(line.as_bytes(), &mut |_t, l| replies.push(l.to_owned()));
    }
    replies
}

#[test]
fn m400_ok_is_held_for_its_simulated_time() {
    let mut p = Protocol::new(Machine::new(profile("")).unwrap(), ProtocolConfig::default());
    let mut holds = Vec::new();
    let mut replies = Vec::new();
    for line in ["G1 X100 F600\n", "M400\n", "M105\n"] {
        p.feed_held(line.as_bytes(), &mut |_t, l| replies.push(l.to_owned()), &mut |from, to| {
            holds.push(to - from)
        });
    }
    // Only M400 is held, for the 10 s its queued 100 mm at 10 mm/s take (less the acceleration).
    assert_eq!(holds.len(), 1, "{holds:?}");
    assert!((10.0..10.2).contains(&holds[0]), "{holds:?}");
}

#[test]
fn m115_lists_the_firmware_table_and_what_is_left_out_is_unknown() {
    let mut m = Machine::new(profile(
        "sdcard = false\nlong_filenames = false\nautoreport_sd = false\nadvanced_pause = false\n",
    ))
    .unwrap();
    let out = run(&mut m, "M115\nM21\nM20\nM155 S2\nM600\n");
    assert!(out.contains(&"Cap:SDCARD:0".to_owned()), "{out:?}");
    assert!(out.contains(&"Cap:AUTOREPORT_TEMP:1".to_owned()), "{out:?}");
    let unknown: Vec<&String> = out.iter().filter(|l| l.starts_with("echo:Unknown")).collect();
    assert_eq!(
        unknown,
        ["echo:Unknown command: \"M21\"", "echo:Unknown command: \"M20\"", "echo:Unknown command: \"M600\""]
    );
    let mut m = Machine::new(profile("autoreport_temp = false\n")).unwrap();
    assert_eq!(run(&mut m, "M155 S2"), ["echo:Unknown command: \"M155 S2\""]);
}

#[test]
fn settings_drive_the_planner_and_survive_m500_m502_m501_and_power_on() {
    let dir = tempfile::tempdir().unwrap();
    let eeprom = dir.path().join("eeprom.gcode");
    let mut m = Machine::new(profile("")).unwrap();
    m.attach_eeprom(eeprom.clone());
    // M203 X5: a 100 mm move takes 20 s at least.
    let t0 = m.now_s();
    run(&mut m, "M203 X5\nM92 X100\nM207 S2.5 F1800\nG1 X100 F6000\nM400");
    assert!(m.now_s() - t0 >= 20.0, "{}", m.now_s() - t0);
    let report = run(&mut m, "M503");
    assert!(report.contains(&"echo:  M203 X5.00 Y300.00 Z5.00 E25.00".to_owned()), "{report:?}");
    assert!(report.contains(&"echo:  M92 X100.00 Y80.00 Z4000.00 E500.00".to_owned()), "{report:?}");
    assert!(report.contains(&"echo:  M207 S2.50 W13.00 F1800.00 Z0.00".to_owned()), "{report:?}");
    assert!(report.iter().any(|l| l == "echo:; Max feedrates (units/s):"), "{report:?}");
    // M92 X100 re-counts X from here: M114 counts 100 steps per mm.
    assert!(run(&mut m, "M114")[0].contains("Count X:10000 "), "{:?}", run(&mut m, "M114"));
    assert!(run(&mut m, "M500")[0].starts_with("echo:Settings Stored ("));
    assert_eq!(run(&mut m, "M502"), ["echo:Hardcoded Default Settings Loaded"]);
    assert!(run(&mut m, "M503").contains(&"echo:  M203 X300.00 Y300.00 Z5.00 E25.00".to_owned()));
    assert!(run(&mut m, "M501")[0].starts_with("echo:V86 stored settings retrieved ("));
    assert!(run(&mut m, "M503").contains(&"echo:  M203 X5.00 Y300.00 Z5.00 E25.00".to_owned()));
    // The next power-on reads the EEPROM.
    let mut fresh = Machine::new(profile("")).unwrap();
    fresh.attach_eeprom(eeprom);
    assert!(run(&mut fresh, "M503").contains(&"echo:  M92 X100.00 Y80.00 Z4000.00 E500.00".to_owned()));
    // Without EEPROM_SETTINGS, M500 is unknown, as in such a Marlin.
    let mut bare = Machine::new(profile("eeprom = false\n")).unwrap();
    assert_eq!(run(&mut bare, "M500"), ["echo:Unknown command: \"M500\""]);
}

/// The build options gate the commands through the registry's rows alone (`needs`): on a board
/// built without any, each code of a gated row is unknown, and every code Marlin compiles in with
/// an option is gated (those `knows_g`/`knows_m` listed before the rows said so; a new gated row
/// needs no change here).
#[test]
fn a_board_without_its_build_options_does_not_know_their_commands() {
    let bare = "eeprom = false\nsdcard = false\nlong_filenames = false\nautoreport_temp = false\n\
                autoreport_sd = false\nhost_action_commands = false\nprompt_support = false\n\
                advanced_pause = false\nfw_retract = false\narcs = false\nbuzzer = false\n\
                set_progress = false\npin_control = false\nmesh = []\n";
    let mut gated = Vec::new();
    for spec in COMMANDS.iter().filter(|s| s.needs != Feature::Always) {
        for code in spec.codes.split_whitespace() {
            let mut m = Machine::new(profile(bare)).unwrap();
            assert_eq!(run(&mut m, code), [format!("echo:Unknown command: \"{code}\"")], "{code}");
            gated.push(code);
        }
    }
    let want = "G2 G3 G10 G11 G29 M20 M21 M22 M23 M24 M25 M26 M27 M28 M29 M30 M32 M33 M42 M226 M73 M80 \
                M154 M155 M207 M208 M209 M300 M420 M500 M501 M524 M600 M851 M876 M928";
    for code in want.split_whitespace() {
        assert!(gated.contains(&code), "{code} is gated by a build option");
    }
    let mut m = Machine::new(profile(bare)).unwrap();
    assert_eq!(
        run(&mut m, "M502\nM81\nM31"),
        ["echo:Hardcoded Default Settings Loaded", "echo:Print time: 0s"]
    );
}

#[test]
fn host_commands_answer_as_marlin() {
    let mut m = Machine::new(profile("")).unwrap();
    assert_eq!(run(&mut m, "M118 E1 Hello host"), ["echo:Hello host"]);
    assert_eq!(run(&mut m, "M118 A1 action:cancel"), ["//action:cancel"]);
    assert_eq!(run(&mut m, "M75\nG4 S75\nM31"), ["echo:Print time: 1m 15s"]);
    assert_eq!(run(&mut m, "M77\nM31"), ["echo:Print time: 0s"]);
    assert_eq!(run(&mut m, "M420"), ["echo:Bed Leveling OFF", "echo:Fade Height OFF"]);
    assert_eq!(run(&mut m, "G29"), ["echo:Home XYZ First"]);
    let out = run(&mut m, "G28\nG29");
    assert_eq!(out[0], "Bilinear Leveling Grid:", "{out:?}");
    assert_eq!(run(&mut m, "M420")[0], "echo:Bed Leveling ON");
    assert_eq!(run(&mut m, "M117 Printing part 1"), ["//action:notification Printing part 1"]);
    for line in ["M108", "M410", "M876 S0", "M876 P1", "M300 S440 P100", "M81", "M42 P13 S255", "M73 P50"] {
        assert_eq!(run(&mut m, line), Vec::<String>::new(), "{line}");
    }
}

#[test]
fn sd_upload_through_the_protocol_then_print_it_to_done() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = Machine::new(profile("")).unwrap();
    m.attach_sd(dir.path().to_owned());
    let mut p = Protocol::new(m, ProtocolConfig::default());
    let up = feed(&mut p, 1, &["M21", "M28 /part.gco", "G28", "G1 X10 Y5 F3000", "G1 X20", "M29", "M20 L"]);
    assert_eq!(
        up,
        [
            "echo:SD card ok",
            "ok",
            "Writing to file: part.gco",
            "ok",
            "ok",
            "ok",
            "ok",
            "Done saving file.",
            "ok",
            "Begin file list",
            "PART.GCO 27 PART.GCO",
            "End file list",
            "ok"
        ]
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("PART.GCO")).unwrap(),
        "G28\nG1 X10 Y5 F3000\nG1 X20\n"
    );
    // Nothing moved while uploading.
    assert_eq!(p.device().position()[0], 0.0);
    let sel = feed(&mut p, 8, &["M23 part.gco", "M24", "M27"]);
    assert_eq!(
        sel,
        [
            "File opened: PART.GCO Size: 27",
            "File selected",
            "ok",
            "//action:prompt_end",
            "//action:prompt_begin Resuming SD",
            "//action:prompt_button Dismiss",
            "//action:prompt_show",
            "ok",
            "SD printing byte 0/27",
            "ok"
        ]
    );
    let mut printed = Vec::new();
    while p.has_own_work() {
        p.own_work(&mut |_t, l| printed.push(l.to_owned()));
    }
    assert_eq!(printed.last().map(String::as_str), Some("Done printing file"), "{printed:?}");
    assert_eq!(p.device().position()[..2], [20.0, 5.0]);
    assert_eq!(feed(&mut p, 11, &["M27"]), ["Not SD printing", "ok"]);
}

#[test]
fn sd_print_pauses_reports_and_aborts() {
    let dir = tempfile::tempdir().unwrap();
    let body: String = (0..100).map(|i| format!("G1 X{} F600\n", i % 20)).collect();
    std::fs::write(dir.path().join("Long name part.gcode"), &body).unwrap();
    let mut m = Machine::new(profile("")).unwrap();
    m.attach_sd(dir.path().to_owned());
    let size = body.len();
    assert_eq!(run(&mut m, "M20 L")[1], format!("LONGNA~1.GCO {size} Long name part.gcode"));
    assert_eq!(run(&mut m, "M33 LONGNA~1.GCO"), ["Long name part.gcode"]);
    run(&mut m, "M23 LONGNA~1.GCO\nM27 S1\nM24");
    let mut reports = Vec::new();
    for _ in 0..60 {
        m.sd_step(&mut |_t, l| reports.push(l.to_owned()));
    }
    assert!(reports.iter().any(|l| l.starts_with("SD printing byte ")), "{reports:?}");
    // M25 asks the host whether to resume (Marlin's "Pause SD" prompt); M876 answers it.
    assert_eq!(
        run(&mut m, "M25"),
        [
            "//action:prompt_end",
            "//action:prompt_begin Pause SD",
            "//action:prompt_button Resume",
            "//action:prompt_show"
        ]
    );
    assert!(!m.sd_printing());
    assert_eq!(run(&mut m, "M876 S0"), Vec::<String>::new());
    assert!(m.sd_printing());
    run(&mut m, "M25");
    assert!(!m.sd_printing());
    let pos = run(&mut m, "M27");
    assert!(pos[0].starts_with("SD printing byte ") && pos[0].ends_with(&format!("/{size}")), "{pos:?}");
    assert_eq!(run(&mut m, "M524"), ["echo:Print Aborted"]);
    assert_eq!(run(&mut m, "M27"), ["Not SD printing"]);
    assert_eq!(run(&mut m, "M30 LONGNA~1.GCO"), ["File deleted:LONGNA~1.GCO"]);
    assert_eq!(run(&mut m, "M23 nothere.gco"), ["echo:open failed, File: nothere.gco."]);
}

#[test]
fn m600_prompts_the_host_and_holds_the_queue_until_m876() {
    let mut p = Protocol::new(Machine::new(profile("")).unwrap(), ProtocolConfig::default());
    let out = feed(&mut p, 1, &["M600"]);
    let prompts: Vec<&String> =
        out.iter().filter(|l| l.starts_with("//action:") || l.starts_with("echo:Insert")).collect();
    assert_eq!(
        prompts,
        [
            "//action:prompt_end",
            "//action:prompt_begin Pause",
            "//action:prompt_button Dismiss",
            "//action:prompt_show",
            "echo:Insert filament and send M108",
            "//action:prompt_end",
            "//action:prompt_begin Nozzle Parked",
            "//action:prompt_button Continue",
            "//action:prompt_show",
        ]
    );
    assert!(!out.contains(&"ok".to_owned()), "no ok while the user is asked: {out:?}");
    assert!(p.waiting_for_user());
    // A host that goes on is held; the board keeps telling it so while the wall clock runs.
    assert!(feed(&mut p, 2, &["M105"]).is_empty());
    // OctoPrint's `M876 P1` (it supports prompts) answers nothing.
    assert!(feed(&mut p, 3, &["M876 P1"]).is_empty());
    assert!(p.waiting_for_user());
    let mut busy = Vec::new();
    p.idle(5.0, &mut |_t, l| busy.push(l.to_owned()));
    assert_eq!(busy, ["echo:busy: paused for user"; 2]);
    // The emergency parser takes M876 S0 at once: M600 finishes, then the held lines run.
    let out = feed(&mut p, 4, &["M876 S0"]);
    let tail: Vec<&str> = out.iter().map(String::as_str).filter(|l| !l.starts_with("echo:busy")).collect();
    assert_eq!(
        tail[..5],
        [
            "//action:prompt_end",
            "//action:prompt_begin Paused",
            "//action:prompt_button PurgeMore",
            "//action:prompt_button Continue",
            "//action:prompt_show"
        ]
    );
    assert_eq!(tail[5], "//action:prompt_end");
    assert_eq!(tail[6], "ok", "{tail:?}");
    assert!(tail[7].starts_with("ok T:"), "{tail:?}");
    assert_eq!(tail[8..], ["ok", "ok"]);
    assert!(!p.waiting_for_user());
}

/// The emergency parser's commands were a `match` of their own beside the registry (issue 40):
/// now the rows that say `urgent` are the ones it acts on, at once, while `M600` holds the queue.
#[test]
fn the_emergency_parser_acts_on_the_rows_that_say_urgent() {
    let urgent: Vec<&str> =
        super::commands::COMMANDS.iter().filter(|c| c.urgent.is_some()).map(|c| c.codes).collect();
    assert_eq!(urgent, ["M108 M410", "M112", "M876"]);
    let waiting = |firmware: &str| {
        let mut p = Protocol::new(Machine::new(profile(firmware)).unwrap(), ProtocolConfig::default());
        feed(&mut p, 1, &["M600"]);
        assert!(p.waiting_for_user());
        p
    };
    let mut p = waiting("");
    feed(&mut p, 2, &["M410"]);
    assert!(p.waiting_for_user(), "a quick stop ends no wait");
    feed(&mut p, 3, &["M108"]);
    assert!(!p.waiting_for_user(), "M108 ends the wait at once");
    // Regression (review of the emergency parser: a line with a comment was not looked at):
    // the parser reads the command before the comment, as Marlin's does.
    let mut p = waiting("");
    p.feed(b"  M108 ; the filament is in\n", &mut |_, _| {});
    assert!(!p.waiting_for_user(), "M108 with a comment ends the wait");
    // Built without the parser, `M108` waits its turn behind the `M600` it was to end.
    let mut p = waiting("emergency_parser = false\n");
    feed(&mut p, 2, &["M108"]);
    assert!(p.waiting_for_user());
    // Without prompt support, `M876 S0` is no answer.
    let mut p = waiting("prompt_support = false\n");
    feed(&mut p, 2, &["M876 S0"]);
    assert!(p.waiting_for_user());
    let mut p = waiting("");
    let out = feed(&mut p, 2, &["M112"]);
    assert!(out.iter().any(|l| l == crate::thermal::protection::KILL_LINE), "{out:?}");
    assert!(!p.waiting_for_user());
}

#[test]
fn m600_without_advanced_pause_is_unknown_and_a_file_run_does_not_wait() {
    let mut m = Machine::new(profile("advanced_pause = false\n")).unwrap();
    assert_eq!(run(&mut m, "M600"), ["echo:Unknown command: \"M600\""]);
    // `gweave sim`: nobody answers; the next command continues the print.
    let mut m = Machine::new(profile("")).unwrap();
    run(&mut m, "M600");
    assert!(m.waiting_for_user());
    let out = run(&mut m, "M114");
    assert!(!m.waiting_for_user());
    assert!(out.last().unwrap().starts_with("X:0.00"), "{out:?}");
}
