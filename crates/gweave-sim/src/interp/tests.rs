use super::motion::rest_to_rest_s;
use super::*;
use crate::profile::MachineProfile;
use crate::thermal::heater::HeaterId;
use crate::thermal::protection::KILL_LINE;

/// Runs lines, returning the replies and the last outcome.
fn run(m: &mut Machine, text: &str) -> (Vec<String>, Outcome) {
    let mut replies = Vec::new();
    let mut outcome = Outcome::Ok;
    for line in text.lines() {
        let mut out = |_t: f64, l: &str| replies.push(l.to_owned());
        outcome = m.execute(line.as_bytes(), &mut out);
    }
    (replies, outcome)
}

fn machine() -> Machine {
    Machine::new(MachineProfile::default()).unwrap()
}

/// A machine that may extrude cold (no heating in motion tests).
fn warm_machine() -> Machine {
    let mut p = MachineProfile::default();
    p.thermal.extrude_min_c = None;
    Machine::new(p).unwrap()
}

#[test]
fn boot_and_query_replies() {
    let mut m = machine();
    assert_eq!(m.boot_lines()[0], "start");
    let (r, o) = run(&mut m, "M105\nM119\nG123 X5 ; comment\nM114");
    assert_eq!(o, Outcome::Ok);
    assert!(!m.acknowledged(), "M114 leaves the ok to the caller");
    assert_eq!(
        r,
        [
            "ok T:25.00 /0.00 B:25.00 /0.00 @:0 B@:0",
            "Reporting endstop status",
            "x_min: TRIGGERED",
            "y_min: TRIGGERED",
            "z_min: TRIGGERED",
            "echo:Unknown command: \"G123 X5\"",
            "X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0",
        ]
    );
    let (r, _) = run(&mut m, "M105");
    assert!(m.acknowledged());
    assert!(r[0].starts_with("ok T:"));
    let (r, _) = run(&mut m, "?");
    assert_eq!(r, help_lines());
    assert_eq!(m.report().unknown_commands["G123"], 1);
}

/// A file of garbage cannot grow the report without bound: past 255 distinct unknown names the
/// rest are counted together, and a name is kept to 32 characters.
#[test]
fn unknown_commands_are_counted_in_bounded_memory() {
    use super::{UNKNOWN_KINDS, UNKNOWN_OTHERS};
    let mut m = machine();
    let text: String = (0..1000).map(|i| format!("G{}{}\n", 1000 + i, "9".repeat(40))).collect();
    run(&mut m, &text);
    let unknown = m.report().unknown_commands;
    assert_eq!(unknown.len(), UNKNOWN_KINDS);
    assert_eq!(unknown[UNKNOWN_OTHERS], 1000 - (UNKNOWN_KINDS as u64 - 1));
    assert_eq!(unknown.values().sum::<u64>(), 1000);
    assert!(unknown.keys().all(|k| k.chars().count() <= 32), "{:?}", unknown.keys().next());
}

#[test]
fn moves_count_steps_and_m114_reports_them() {
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "G1 X10 Y5.0125 Z0.3 E2 F3000\nG91\nG1 X-2.5 E-0.5\nG90\nM114\nM119");
    assert_eq!(
        r,
        [
            "X:7.50 Y:5.01 Z:0.30 E:1.50 Count X:600 Y:401 Z:1200",
            "Reporting endstop status",
            "x_min: open",
            "y_min: open",
            "z_min: open",
        ]
    );
    let rep = m.report();
    // E: 2 mm out, 0.5 mm back at 500 steps/mm.
    assert_eq!(rep.steps.axes, [1000, 401, 1200, 1250, 0]);
    assert_eq!(rep.filament_mm, vec![1.5]);
    assert!(rep.warnings.is_empty(), "{:?}", rep.warnings);
}

#[test]
fn cold_extrusion_is_refused_with_marlins_line() {
    let mut m = machine();
    let (r, _) = run(&mut m, "G1 X10 E5 F600\nM114");
    assert_eq!(r[0], "echo: cold extrusion prevented");
    // The logical E moved on; the motor did not.
    assert_eq!(r[1], "X:10.00 Y:0.00 Z:0.00 E:5.00 Count X:800 Y:0 Z:0");
    let rep = m.report();
    assert_eq!(rep.steps.axes[3], 0);
    assert_eq!(rep.filament_mm, vec![0.0]);
    assert_eq!(rep.warning_counts["cold_extrusion"], 1);
    assert_eq!(rep.warnings[0].line, 1);
}

#[test]
fn homing_drives_to_the_endstops_with_marlins_bump() {
    let mut m = warm_machine();
    run(&mut m, "G1 X50 Y20 F6000\nM400");
    let t0 = m.now_s();
    let (r, _) = run(&mut m, "G28 X\nM114\nM119");
    assert_eq!(r[0], "X:0.00 Y:20.00 Z:0.00 E:0.00 Count X:0 Y:1600 Z:0");
    assert_eq!(&r[2..4], ["x_min: TRIGGERED", "y_min: open"]);
    // 50 mm at 50 mm/s, 5 mm back, 5 mm again at 25 mm/s; a = 3000 mm/s^2.
    let want = (1.0 + 50.0 / 3000.0) + (0.1 + 50.0 / 3000.0) + (0.2 + 25.0 / 3000.0);
    assert!((m.now_s() - t0 - want).abs() < 1e-9, "{}", m.now_s() - t0);
    assert!((m.report().time.homing_s - want).abs() < 1e-12);
    // 50 mm in, 5 out and 5 back in at 80 steps/mm.
    assert_eq!(m.report().steps.axes[0], (50 + 50 + 10) * 80);
    assert!((rest_to_rest_s(0.5, 50.0, 3000.0) - 2.0 * (0.5f64 / 3000.0).sqrt()).abs() < 1e-15);
}

#[test]
fn g92_shifts_the_logical_origin_only() {
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "G1 X100 F6000\nG92 X0\nG1 X-50\nM114\nG28 X\nM114");
    assert_eq!(r[0], "X:-50.00 Y:0.00 Z:0.00 E:0.00 Count X:4000 Y:0 Z:0");
    assert_eq!(r[1], "X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0");
    // X-50 after G92 X0 at 100 is machine X50: inside the bed, no warning.
    assert!(m.report().warnings.is_empty());
}

#[test]
fn out_of_bounds_and_below_bed_are_reported_not_clamped() {
    let mut m = warm_machine();
    let (_, o) = run(&mut m, "G1 X250 F6000\nG1 Z-0.4\nG1 X10\nM114");
    assert_eq!(o, Outcome::Ok);
    let rep = m.report();
    assert_eq!(
        rep.warnings.iter().map(|w| (w.line, w.kind.clone())).collect::<Vec<_>>(),
        [
            (1, WarningKind::OutOfBounds { axis: 'X', value_mm: 250.0, min_mm: 0.0, max_mm: 200.0 }),
            (2, WarningKind::BelowBed { z_mm: -0.4 }),
        ]
    );
    assert_eq!(rep.position[2], -0.4);
    assert_eq!(rep.count[2], -1600);
}

#[test]
fn m109_waits_reporting_every_second() {
    let mut m = machine();
    let mut stamped = Vec::new();
    let mut out = |t: f64, l: &str| stamped.push((t, l.to_owned()));
    assert_eq!(m.execute(b"M109 S200", &mut out), Outcome::Ok);
    let waited = m.now_s();
    // The default 40 W hotend reaches 200 C in about 70 s, then the residency.
    assert!((70.0..100.0).contains(&waited), "{waited}");
    assert!(stamped.iter().all(|(_, l)| l.starts_with(" T:")));
    assert_eq!(stamped.len(), waited.floor() as usize);
    assert!((stamped[0].0 - 1.0).abs() < 1e-9 && (stamped[1].0 - 2.0).abs() < 1e-9);
    // Marlin's ` W:`: `?` until the reading is within TEMP_WINDOW (1 C) of the target, then the
    // residency (10 s) counting down in whole seconds to the end of the wait.
    let w: Vec<&str> = stamped.iter().map(|(_, l)| l.rsplit_once(" W:").unwrap().1).collect();
    let first = w.iter().position(|x| *x != "?").unwrap();
    let counted: Vec<u64> = w[first..].iter().map(|x| x.parse().unwrap()).collect();
    assert_eq!(counted, (0..counted.len() as u64).rev().collect::<Vec<_>>(), "{w:?}");
    assert!((9..=10).contains(&counted.len()), "{w:?}");
    let at_start: f64 = stamped[first].1[3..].split(' ').next().unwrap().parse().unwrap();
    assert!((at_start - 200.0).abs() < 1.0, "{at_start}");
    assert!(waited - stamped[first].0 > 9.0, "{waited}");
    // The residency ends it, overshoot or not: within TEMP_HYSTERESIS (3 C) of the target.
    assert!((m.thermal().temperature(HeaterId::Hotend(0)).unwrap() - 200.0).abs() < 3.0);
    assert_eq!(m.report().time.heating_s, waited);
}

#[test]
fn injected_cartridge_fault_trips_thermal_runaway() {
    let p = MachineProfile {
        faults: vec!["hotend-cartridge-off@100s".parse().unwrap()],
        ..MachineProfile::default()
    };
    let mut m = Machine::new(p).unwrap();
    let mut stamped = Vec::new();
    let mut out = |t: f64, l: &str| stamped.push((t, l.to_owned()));
    assert_eq!(m.execute(b"M109 S200", &mut out), Outcome::Ok);
    assert_eq!(m.execute(b"G4 S120", &mut out), Outcome::Halted);
    let errors: Vec<&(f64, String)> = stamped.iter().filter(|(_, l)| l.starts_with("Error:")).collect();
    assert_eq!(errors[0].1, "Error:Thermal Runaway, system stopped! Heater_ID: 0");
    assert_eq!(errors[1].1, "Error:Printer halted. kill() called!");
    // Runaway: more than 4 C below target for 40 s after the cartridge went at 100 s.
    assert!((140.0..170.0).contains(&errors[0].0), "{}", errors[0].0);
    let (r, o) = run(&mut m, "G1 X10\nM105");
    assert_eq!(o, Outcome::Halted);
    assert_eq!(r[0], STOPPED_LINE);
    assert!(r[1].starts_with("ok T:"), "queries still work: {r:?}");
    assert_eq!(run(&mut m, "M999").1, Outcome::Ok);
    assert_eq!(m.report().thermal_faults.len(), 1);
}

/// Regression (left alone since the thirty-second session: a thermal fault halted the machine
/// but the moves the planner still held ran at the end of the run, their time and steps
/// counted): the fault stops the motors as `M112` does (Marlin's `kill()` after
/// `quick_stop()`), so the run ends within a move of the fault, and where its executed moves
/// left the machine.
#[test]
fn a_thermal_fault_drops_the_queued_moves() {
    let p = MachineProfile {
        faults: vec!["hotend-cartridge-off@300s".parse().unwrap()],
        ..MachineProfile::default()
    };
    let mut m = Machine::new(p).unwrap();
    let mut stamped = Vec::new();
    let mut out = |t: f64, l: &str| stamped.push((t, l.to_owned()));
    assert_eq!(m.execute(b"M109 S200", &mut out), Outcome::Ok);
    // Ten-millimetre moves of a second each, for longer than the runaway takes to trip.
    let mut outcome = Outcome::Ok;
    for i in 0..800 {
        let line = format!("G1 X{} F600", if i % 2 == 0 { 20 } else { 10 });
        outcome = m.execute(line.as_bytes(), &mut out);
        if outcome == Outcome::Halted {
            break;
        }
    }
    assert_eq!(outcome, Outcome::Halted);
    m.finish(&mut out);
    let fault_s = stamped.iter().find(|(_, l)| l.starts_with("Error:Thermal Runaway")).expect("a runaway").0;
    // A line's executed moves may end after the fault's time; the queued ones (16 s) never run.
    assert!(m.now_s() - fault_s < 2.0, "halted at {fault_s} s, the run ends at {} s", m.now_s());
    let x = m.position()[0];
    let steps = m.report().steps.axes[0];
    assert!(x == 10.0 || x == 20.0, "X at {x}");
    // Every X step made is of the moves run: 10 mm (800 steps) each, after the first 20.
    assert_eq!((steps - 1600) % 800, 0, "{steps} steps");
}

#[test]
fn m112_halts_until_m999() {
    let mut m = machine();
    let (r, o) = run(&mut m, "M104 S200\nM112");
    assert_eq!((r, o), (vec![KILL_LINE.to_owned()], Outcome::Halted));
    assert_eq!(m.thermal().target(HeaterId::Hotend(0)).unwrap(), 0.0);
    assert_eq!(run(&mut m, "G28").1, Outcome::Halted);
    assert_eq!(run(&mut m, "M999\nG28").1, Outcome::Ok);
}

/// A breaking session found that `M112` let the moves queued before it run: `G1 X200 F60`
/// then `M112` still counted the 200 s move and its steps. The motors stop at once (Marlin's
/// `kill()` after `quick_stop()`): the queued moves add no time and no steps, and the position
/// is where the executed moves left the machine, in the coordinates in force (a `G92` after
/// the dropped move keeps its shift).
#[test]
fn m112_drops_the_queued_moves() {
    let mut m = warm_machine();
    run(&mut m, "G28\nG1 X10 E2 F6000\nM400");
    let (before_s, before_steps) = (m.now_s(), m.report().steps.axes);
    let (r, o) = run(&mut m, "G1 X200 E22 F60\nG92 X0\nM112\nM114");
    assert_eq!(o, Outcome::Halted);
    // `G92 X0` made the queued end X200 the origin: the motor stopped at X10, logical -190.
    assert_eq!(r, [KILL_LINE, "X:-190.00 Y:0.00 Z:0.00 E:2.00 Count X:800 Y:0 Z:0"]);
    assert_eq!(m.now_s(), before_s, "the 190 s move never ran");
    assert_eq!(m.report().steps.axes, before_steps);
    // Nor did its 20 mm of filament leave the nozzle (the review of the thirty-fourth session:
    // counted when queued, it stayed counted).
    assert_eq!(m.report().filament_mm, [2.0]);
}

/// A breaking session found that lines refused while halted still changed the machine: after
/// `M112`, `G91`, `G20` and `G1 X10` each answered the stop line, yet `M999` found relative
/// inches and a logical X moved without its motor; a halted `G1 X1e23` (its range check was
/// skipped) then made `G28` home for millions of simulated seconds, deaf to SIGTERM.
#[test]
fn a_halted_machine_changes_nothing_of_a_refused_line() {
    let mut m = warm_machine();
    run(&mut m, "G28\nG1 X50 Y50 Z10 F3000\nM112");
    let (r, o) = run(&mut m, "G91\nG20\nG1 X10\nG92 Y0\nG1 X99999999999999999999999\nM83");
    assert_eq!((r, o), (vec![STOPPED_LINE.to_owned(); 6], Outcome::Halted));
    let (r, o) = run(&mut m, "M999\nM114\nG1 X60\nG28 X\nM114");
    assert_eq!(o, Outcome::Ok);
    // The move before M112 was still queued: the quick stop dropped it (m112_drops_...).
    assert_eq!(
        r,
        ["X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0", "X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0",]
    );
    assert!(m.now_s() < 60.0, "{} s", m.now_s());
}

/// A breaking session found `!!! Z5` run as a move (a bare `ok` from `serve`): junk where the
/// command belongs is an unknown command, as Marlin answers it, and nothing moves.
#[test]
fn a_line_that_starts_with_junk_is_an_unknown_command() {
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "G1 X10 F6000\n!!! Z5\n#x X99999\nM114");
    assert_eq!(
        r,
        [
            "echo:Unknown command: \"!!! Z5\"",
            // Not a move out of range: no move at all.
            "echo:Unknown command: \"#x X99999\"",
            "X:10.00 Y:0.00 Z:0.00 E:0.00 Count X:800 Y:0 Z:0",
        ]
    );
    assert_eq!(m.report().warning_counts["unknown_command"], 2);
}

/// A breaking session found arcs never checked against the bed: `G3 X190 Y10 I90 J0` from
/// (10, 10) dips to Y -80 without a warning (two `G1` along the same points warned), and the
/// full circle `G2 X100 Y100 I9999` ran 20 m off a 200 mm bed for 630 s.
#[test]
fn an_arc_is_checked_where_it_goes_not_only_where_it_ends() {
    let mut m = warm_machine();
    let (r, o) = run(&mut m, "G1 X10 Y10 F6000\nG3 X190 Y10 I90 J0\nM400");
    assert_eq!((r, o), (vec![], Outcome::Ok));
    let warnings: Vec<WarningKind> = m.report().warnings.into_iter().map(|w| w.kind).collect();
    assert_eq!(
        warnings,
        [WarningKind::OutOfBounds { axis: 'Y', value_mm: -80.0, min_mm: 0.0, max_mm: 200.0 }]
    );
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "G1 X100 Y100 F6000\nG2 X100 Y100 I9999 J0\nM114");
    // The circle's centre is at X 10 099, its right-most point at 20 098.
    assert_eq!(
        r,
        [
            "echo:X20098.000 is out of reach (0..200 mm): move refused",
            "X:100.00 Y:100.00 Z:0.00 E:0.00 Count X:8000 Y:8000 Z:0",
        ]
    );
}

#[test]
fn mixing_inputs_share_e_by_the_virtual_tool() {
    let mut p = MachineProfile::from_toml_str("mixing_inputs = 4\n").unwrap();
    p.thermal.extrude_min_c = None;
    let mut m = Machine::new(p).unwrap();
    let (r, _) = run(
        &mut m,
        "M163 S0 P0.5\nM163 S1 P0.3\nM163 S2 P0.2\nM163 S3 P0\nM164 S2\nT2\nG1 X10 E100 F600\nT0\nG1 X20 E110\nT99\nM400",
    );
    assert_eq!(r, ["echo:T99 Invalid extruder"]);
    let rep = m.report();
    assert_eq!(rep.mixing_input_mm, vec![60.0, 30.0, 20.0, 0.0]);
    assert_eq!(rep.filament_mm, vec![10.0, 0.0, 100.0]);
    assert_eq!(rep.steps.mixing, vec![30_000, 15_000, 10_000, 0]);
    // E steps by virtual tool: 100 mm under T2, 10 mm under T0; the invalid T99 changed nothing.
    assert_eq!(rep.steps.tools, vec![5_000, 0, 50_000]);
}

#[test]
fn e_steps_and_filament_per_tool_on_two_hotends() {
    let mut p = MachineProfile::default();
    p.thermal.hotends = vec![crate::thermal::heater::HeaterConfig::hotend_40w(); 2];
    p.thermal.extrude_min_c = None;
    let mut m = Machine::new(p).unwrap();
    // Relative E at 500 steps/mm. T0: 2.5 out, 0.8 back, 0.8 out; T1: 1.2 and 0.0031 (the motor
    // goes from 1850 to round(3.7031 * 500) = 1852: 2 steps); T0 again: 1 mm; T2 does not exist.
    let (r, _) = run(
        &mut m,
        "M83
T0
G1 X10 E2.5 F1200
G1 E-0.8
G1 E0.8
T1
G1 X20 E1.2
G1 X30 E0.0031
T2
         T0
G1 X40 E1
M400",
    );
    assert_eq!(r, ["echo:T2 Invalid extruder"]);
    let rep = m.report();
    assert_eq!(rep.steps.tools, vec![1250 + 400 + 400 + 500, 600 + 2]);
    assert_eq!(rep.steps.axes[3], 2550 + 602);
    assert_eq!(rep.count[3], 2352);
    assert!((rep.filament_mm[0] - 3.5).abs() < 1e-12, "{:?}", rep.filament_mm);
    assert!((rep.filament_mm[1] - 1.2031).abs() < 1e-12, "{:?}", rep.filament_mm);
    assert_eq!(rep.filament_mm.len(), 2);
}

#[test]
fn feed_and_flow_percentages() {
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "M221 S50\nG1 X100 E10 F6000\nM220 S50\nM220\nM400");
    assert_eq!(r, ["echo:FR:50%"]);
    assert_eq!(m.report().filament_mm, vec![5.0]);
    // 100 mm at 100 mm/s with a = 3000, in Marlin's steps (80/mm): 8000 steps/s and 240000
    // steps/s², from and to 120 steps/s: 134 steps up, 133 down, 7733 cruising.
    let want = 534.0 / 8120.0 + 7733.0 / 8000.0;
    assert!((m.now_s() - want).abs() < 1e-9, "{}", m.now_s());
}

/// A parameter outside its range is refused with the registry's uniform reply, and the value
/// in force stays (before the registry, `M220 S0` and `M155 S-1` were dropped in silence).
#[test]
fn out_of_range_parameters_are_refused_uniformly() {
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "M220 S50\nM220 S0\nM221 S20000\nM220\nM155 S-1");
    assert_eq!(
        r,
        [
            "echo:M220 S = 0 is out of range: 1 to 10000 %",
            "echo:M221 S = 20000 is out of range: 1 to 10000 %",
            "echo:FR:50%",
            "echo:M155 S = -1 is out of range: 0 to 86400 s",
        ]
    );
    assert_eq!(m.report().warning_counts.get("refused"), Some(&3));
}

/// Regression (a new user's trial of `serve`: an `M105` sent just after `M112` said `@:127`,
/// the heater's power of the last sample): `kill()` switches the heaters' outputs off at once,
/// as Marlin's `disable_all_heaters` does, and `M81` too.
#[test]
fn m112_and_m81_switch_the_heaters_outputs_off_at_once() {
    for off in ["M112", "M81"] {
        let mut m = machine();
        run(&mut m, "M104 S200\nM140 S60\nG4 S5");
        assert!(m.thermal().power(HeaterId::Hotend(0)).unwrap() > 0);
        run(&mut m, off);
        for id in [HeaterId::Hotend(0), HeaterId::Bed] {
            assert_eq!(m.thermal().power(id).unwrap(), 0, "{off}: {id:?}");
            assert_eq!(m.thermal().target(id).unwrap(), 0.0, "{off}: {id:?}");
        }
    }
}

/// Regression (review of the emergency parser during paced waits: `M108` ended only the first
/// heater's wait of an `M116`, which went on to wait for the bed): the command ends, and the
/// targets stay.
#[test]
fn m108_ends_the_whole_m116_wait() {
    let mut m = machine();
    run(&mut m, "M104 S200\nM140 S60");
    let early = crate::link::early::EarlyLines::default();
    m.listen(early.clone());
    let mut host = crate::link::early::Early::new(early);
    host.receive(b"M108\n");
    let before_s = m.now_s();
    run(&mut m, "M116");
    assert!(m.now_s() - before_s < 1.0, "waited {} s", m.now_s() - before_s);
    assert_eq!(m.thermal().target(HeaterId::Hotend(0)).unwrap(), 200.0);
    assert_eq!(m.thermal().target(HeaterId::Bed).unwrap(), 60.0);
}

#[test]
fn rrf_tool_temperature_and_m116() {
    let mut m = machine();
    let (r, _) = run(&mut m, "G10 P0 S200\nM116\nG1 X10 E1 F600\nG10\nM400");
    assert!(r.iter().all(|l| l.starts_with(" T:")), "{r:?}");
    assert!((m.thermal().temperature(HeaterId::Hotend(0)).unwrap() - 200.0).abs() < 3.0);
    // G10 without words is still a firmware retraction (1 mm by default).
    // The motor is back where it started: nothing fed, net, and 1 mm stays retracted
    // (`a_firmware_retraction_is_filament_fed_back`).
    assert_eq!(m.report().count[3], 0);
    assert_eq!(m.report().filament_mm, vec![0.0]);
    assert_eq!(m.report().retracted_at_end_mm, vec![1.0]);
}

/// A target with stray digits, far beyond the machine, is refused and the machine stays put
/// (simulating the move would take days of heater ticks); a near miss is carried out. Past
/// 10 m (the G1 row's range, which `estimate` refuses by too) the word itself is refused;
/// within it, a target more than the machine's travel off its bed.
#[test]
fn moves_out_of_reach_are_refused() {
    let mut m = machine();
    let text = "G28\nG1 X10 F6000\nG1 X999999999999 Y5\nG1 X9999 Y5\nG1 X20\nG1 X250\nM400";
    let (r, _) = run(&mut m, text);
    let refusals: Vec<_> = r.iter().filter(|l| l.starts_with("echo:")).collect();
    assert_eq!(
        refusals,
        [
            "echo:G1 X = 9.99999999999e11 is out of range: -10000 to 10000 mm",
            "echo:X9999.000 is out of reach (0..200 mm): move refused"
        ],
        "{r:?}"
    );
    let report = m.report();
    assert_eq!(report.warning_counts.get("refused"), Some(&2), "{:?}", report.warning_counts);
    assert_eq!(report.warning_counts.get("out_of_bounds"), Some(&2), "{:?}", report.warning_counts);
    // X went 10 -> 20 -> 250; the refused move changed nothing.
    assert_eq!(m.report().position[0], 250.0);
    assert!(m.now_s() < 60.0, "{}", m.now_s());
}

/// A stray digit in a feed rate or a dwell would hold the simulated clock for years: refused,
/// as the simulated heaters would need hours to step through it (a feed below 1 mm/min or a
/// dwell over a day by their ranges; a move whose length makes it last over a week at a sane
/// feed by its time). A long but sane dwell runs.
#[test]
fn commands_longer_than_a_week_are_refused() {
    let mut m = machine();
    let (r, _) =
        run(&mut m, "G28\nG1 X100 F0.0001\nG4 S99999999\nG1 E1000000 F1\nG4 S600\nG1 X50 F6000\nM400");
    let refusals: Vec<_> = r.iter().filter(|l| l.starts_with("echo:")).collect();
    assert_eq!(
        refusals,
        [
            "echo:G1 F = 0.0001 is out of range: 1 to 100000 mm/min",
            "echo:G4 S = 99999999 is out of range: 0 to 86400 s",
            "echo:a 1000000.000 mm move at F1 would take 60000000 s: move refused",
        ],
        "{r:?}"
    );
    // The slow move did not happen: X went from 0 to 50 in one move, after the 600 s dwell.
    assert_eq!(m.report().position[0], 50.0);
    assert!(m.now_s() > 600.0 && m.now_s() < 700.0, "{}", m.now_s());
}

/// A clock past the machine's limit (a run of a file's: 30 days) stops it: the heaters are
/// simulated up to the limit and no further, loop by loop while one is on (the count of their
/// loops says so), an `Error:` line and a `time_limit` warning say why, and the commands after
/// it are refused as on a halt; a heating wait under way ends there.
#[test]
fn a_clock_past_its_limit_halts_the_machine() {
    let mut m = machine();
    m.limit_clock(3600.0);
    let (r, o) = run(&mut m, "M104 S200\nG4 S3000\nG4 S3000\nG4 S3000");
    assert_eq!(o, Outcome::Halted);
    let stop = "Error:gweave-sim: the run reached its limit of 0.0416667 days of simulated time: stopped";
    assert_eq!(r, [stop, STOPPED_LINE]);
    assert_eq!(m.thermal().now_s(), 3600.0);
    assert_eq!(m.thermal().loops_run(), 36_001);
    assert_eq!(m.thermal().target(HeaterId::Hotend(0)).unwrap(), 0.0, "heaters off");
    let report = m.report();
    assert!(report.halted);
    assert_eq!(report.warning_counts["time_limit"], 1);
    assert_eq!(report.warnings[0].kind.to_string(), stop["Error:gweave-sim: ".len()..]);
    let mut m = machine();
    m.limit_clock(60.0);
    let (r, o) = run(&mut m, "M109 S200");
    assert_eq!((o, m.thermal().now_s()), (Outcome::Halted, 60.0));
    assert_eq!(r.last().map(String::as_str), Some(stop.replace("0.0416667", "0.000694444").as_str()));
}

/// Marlin's `G10 S1` (the swap retraction before a tool change on a multi-extruder machine)
/// retracts; it does not set the hotend to 1 °C, which would refuse the next extrusion as cold.
#[test]
fn marlin_swap_retraction_is_not_a_temperature() {
    let mut m = machine();
    let (r, _) = run(&mut m, "M104 S200\nM109 S200\nG1 X10 E1 F600\nG10 S1\nG11\nG1 X20 E2\nM400");
    assert!(r.iter().all(|l| l.starts_with("ok") || l.starts_with(" T:")), "{r:?}");
    assert_eq!(m.thermal().target(HeaterId::Hotend(0)).unwrap(), 200.0);
    let report = m.report();
    assert!(report.warning_counts.is_empty(), "{:?}", report.warning_counts);
    assert_eq!(report.filament_mm, vec![2.0]);
}

/// A breaking session found `G10` missing from `sim`'s filament: `G1 X10 E5` then `G10` said
/// 5 mm fed and nothing retracted, while the E motor stood 4 mm on (`G1 E4` said 4 and 1).
#[test]
fn a_firmware_retraction_is_filament_fed_back() {
    let mut m = warm_machine();
    run(&mut m, "M207 S1.5\nG1 X10 E5 F1200\nG10\nM400");
    let report = m.report();
    assert_eq!(report.filament_mm, vec![3.5]);
    assert_eq!(report.retracted_at_end_mm, vec![1.5]);
    assert_eq!(report.count[3], 1750);
    run(&mut m, "G11\nM400");
    let report = m.report();
    assert_eq!((report.filament_mm, report.retracted_at_end_mm), (vec![5.0], vec![0.0]));
}

/// `M568` (RepRapFirmware 3.3+, and what `gweave mix` writes for its RRF tools) heats like
/// `G10 P S`; on a mixing hotend every tool's temperature is the one nozzle's.
#[test]
fn rrf_m568_heats_the_tools_nozzle() {
    let mut m = machine();
    let (r, _) = run(&mut m, "M568 P0 S200 R150\nM116\nG1 X10 E1 F600\nM400");
    assert!(r.iter().all(|l| l.starts_with(" T:")), "{r:?}");
    assert!((m.thermal().temperature(HeaterId::Hotend(0)).unwrap() - 200.0).abs() < 3.0);
    assert_eq!(m.report().filament_mm, vec![1.0]);
    let mut mixing = Machine::new(MachineProfile::from_toml_str("mixing_inputs = 4\n").unwrap()).unwrap();
    let (r, _) = run(&mut mixing, "M563 P1 D0:1:2:3 H1\nM568 P1 S210 R210\nT1\nM116\nG1 X10 E1 F600\nM400");
    assert!(r.iter().all(|l| l.starts_with(" T:")), "{r:?}");
    assert!((mixing.thermal().temperature(HeaterId::Hotend(0)).unwrap() - 210.0).abs() < 3.0);
    let report = mixing.report();
    assert!(report.warning_counts.is_empty(), "{:?}", report.warning_counts);
    assert_eq!(report.filament_mm, vec![0.0, 1.0]);
}

/// A breaking session found `M155 S0.000001` flooding the host with a report every simulated
/// microsecond (16.7 MB in 3 s): Marlin reads the period in whole seconds, so it is 0, off, and
/// `S2.9` reports every 2 s.
#[test]
fn an_auto_report_period_is_whole_seconds() {
    let mut m = machine();
    run(&mut m, "M155 S0.000001\nM154 S0.5");
    let mut stamped = Vec::new();
    m.idle(3.0, &mut |t, l| stamped.push((t, l.to_owned())));
    assert_eq!(stamped, []);
    run(&mut m, "M155 S2.9");
    m.idle(4.5, &mut |t, _| stamped.push((t, String::new())));
    assert_eq!(stamped.iter().map(|(t, _)| *t).collect::<Vec<f64>>(), [5.0, 7.0]);
}

#[test]
fn idle_time_heats_and_auto_reports_on_the_clock() {
    let mut m = machine();
    run(&mut m, "M155 S1\nM104 S200");
    let mut stamped = Vec::new();
    m.idle(2.5, &mut |t, l| stamped.push((t, l.to_owned())));
    let times: Vec<f64> = stamped.iter().map(|(t, _)| *t).collect();
    assert_eq!(times, [1.0, 2.0]);
    assert!(stamped.iter().all(|(_, l)| l.starts_with(" T:") && l.contains("/200.00")), "{stamped:?}");
    // A target set while idle heats, and M105 reads the present.
    m.idle(0.5, &mut |_, _| {});
    let (r, _) = run(&mut m, "M105");
    let now_c: f64 = r[0]["ok T:".len()..].split(' ').next().unwrap().parse().unwrap();
    assert!(now_c > 25.5, "{r:?}");
    assert_eq!(m.now_s(), 3.0);
    let t = m.report().time;
    assert_eq!(t.idle_s, 3.0);
    assert_eq!(t.total_s, t.motion_s + t.dwell_s + t.heating_s + t.homing_s + t.overhead_s + t.idle_s);
}

#[test]
fn idle_never_runs_the_clock_backwards() {
    let mut m = machine();
    for t_s in [-1.0, 0.0, f64::NAN, f64::INFINITY] {
        m.idle(t_s, &mut |_, l| panic!("{l}"));
    }
    assert_eq!(m.now_s(), 0.0);
}

#[test]
fn idle_runs_queued_moves_to_a_stop_first() {
    let mut m = warm_machine();
    run(&mut m, "G28\nG1 X100 F6000");
    let before_s = m.now_s();
    m.idle(1.0, &mut |_, _| {});
    let report = m.report();
    assert!(report.time.motion_s > 0.5, "{:?}", report.time);
    assert!(m.now_s() > before_s + 1.5, "the move and then the idle second");
    assert_eq!(report.count[0], 100 * 80);
}

/// A new user's trial found `G1 X10 Y10 E1000000` run as a million millimetres of filament
/// (11 hours, no warning). Marlin's `PREVENT_LENGTHY_EXTRUDE` (on in its shipped
/// configuration, `EXTRUDE_MAXLENGTH` 200) runs such a move without its E part and says so; a
/// feed within the limit runs, and a board built without it (`extrude_max_mm = 0`) feeds all.
#[test]
fn a_move_feeding_past_extrude_maxlength_runs_without_its_e() {
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "G1 X10 Y10 E1000000 F3000\nG92 E0\nG1 X20 E200\nM114");
    assert_eq!(r[0], super::motion::LONG_EXTRUSION_LINE);
    assert_eq!(r[1], "X:20.00 Y:10.00 Z:0.00 E:200.00 Count X:1600 Y:800 Z:0");
    assert_eq!(m.report().filament_mm, [200.0]);
    assert_eq!(m.report().warning_counts["long_extrusion"], 1);
    assert!(m.now_s() < 10.0, "{} s", m.now_s());
    let mut p = MachineProfile::default();
    p.thermal.extrude_min_c = None;
    p.firmware.extrude_max_mm = 0;
    let mut m = Machine::new(p).unwrap();
    let (r, _) = run(&mut m, "G1 E500 F6000");
    assert!(r.is_empty(), "{r:?}");
    assert_eq!(m.report().filament_mm, [500.0]);
}

/// On a mixing extruder Marlin holds each input to the limit: 400 mm of an even four-way mix
/// is 100 mm an input and runs; the same 400 mm through one input is refused. The mix is the
/// active virtual tool's, not the `M163` factors not yet stored.
#[test]
fn a_mixing_extruder_holds_each_input_to_extrude_maxlength() {
    let mut p = MachineProfile { mixing_inputs: 4, ..MachineProfile::default() };
    p.thermal.extrude_min_c = None;
    let mut m = Machine::new(p).unwrap();
    let even = "M163 S0 P1\nM163 S1 P1\nM163 S2 P1\nM163 S3 P1\nM164 S1\nT1\n";
    let (r, _) = run(&mut m, &format!("{even}M163 S0 P1\nM163 S1 P0\nM163 S2 P0\nM163 S3 P0\nG1 E400 F6000"));
    assert!(!r.iter().any(|l| l == super::motion::LONG_EXTRUSION_LINE), "{r:?}");
    assert_eq!(m.report().filament_mm, [0.0, 400.0]);
    let (r, _) = run(&mut m, "M164 S2\nT2\nG1 E800");
    assert!(r.iter().any(|l| l == super::motion::LONG_EXTRUSION_LINE), "{r:?}");
    assert_eq!(m.report().filament_mm, [0.0, 400.0, 0.0]);
}

/// A new user's trial: `--fault hotend-cartridge-off@4000s` on a print of 334 s exited 0 with
/// no word of the fault. A fault the run never reached is a warning at its end.
#[test]
fn a_fault_past_the_runs_end_is_said() {
    let faults =
        vec!["hotend-cartridge-off@4000s".parse().unwrap(), "bed-thermistor-open@1s".parse().unwrap()];
    let mut m = Machine::new(MachineProfile { faults, ..MachineProfile::default() }).unwrap();
    let mut out = |_t: f64, _l: &str| {};
    m.execute(b"G4 S5", &mut out);
    m.finish(&mut out);
    let report = m.report();
    assert_eq!(report.warning_counts.get("fault_not_injected"), Some(&1));
    let said: Vec<String> = report.warnings.iter().map(|w| w.kind.to_string()).collect();
    assert!(
        said.contains(&"fault hotend-cartridge-off@4000s never injected: the run ended at 5 s".to_owned()),
        "{said:?}"
    );
}

/// Regression (a G2/G3 Marlin refuses ran as a straight move): `Error:G2/G3 bad parameters`, an
/// `arc_refused` warning, and the motors do not turn; an R too short for its chord is half a
/// circle, as Marlin draws it.
#[test]
fn an_arc_without_a_centre_is_refused_and_the_machine_stays() {
    let mut m = warm_machine();
    let (r, _) = run(&mut m, "G1 X10 Y10 F3000\nG2 X30 Y10 E5\nM114");
    assert!(r.iter().any(|l| l == "Error:G2/G3 bad parameters"), "{r:?}");
    assert!(r.iter().any(|l| l.starts_with("X:10.00 Y:10.00 Z:0.00 E:0.00 Count X:800 Y:800 ")), "{r:?}");
    let report = m.report();
    assert_eq!(report.warning_counts.get("arc_refused"), Some(&1));
    assert_eq!(
        report.warnings[0].kind.to_string(),
        "arc refused, the machine did not move: an arc needs R or a non-zero I or J"
    );
    // R1 between ends 20 mm apart: half a circle of radius 10 round (20, 195), clockwise from
    // the left over the top, where it leaves the 200 mm bed by 5 mm.
    let (r, _) = run(&mut m, "G1 X10 Y195\nG2 X30 Y195 R1\nM114");
    assert!(r.iter().any(|l| l.starts_with("X:30.00 Y:195.00 ")), "{r:?}");
    let report = m.report();
    assert_eq!(report.warning_counts.get("arc_refused"), Some(&1));
    let out = WarningKind::OutOfBounds { axis: 'Y', value_mm: 205.0, min_mm: 0.0, max_mm: 200.0 };
    assert!(report.warnings.iter().any(|w| w.kind == out), "{:?}", report.warnings);
}

/// `M211` as Marlin 2.1 (`M211_report`) and gweave's firmware word it: alone, the state as the
/// line that sets it and the bed's limits; with `S`, silent (the review of the session that
/// gave the firmware its software endstops: both printed Marlin 2.0's
/// `echo:Soft endstops: On  Min: ...` at every `M211`).
#[test]
fn m211_reports_alone_and_switches_silently() {
    let mut m = machine();
    let (r, _) = run(&mut m, "M211\nM211 S0\nM211");
    let limits = "  Min:  X0.00 Y0.00 Z0.00   Max:  X200.00 Y200.00 Z200.00";
    assert_eq!(r, ["  M211 S1 ; ON", limits, "  M211 S0 ; OFF", limits]);
    assert_eq!(run(&mut m, "M211 S\nM211").0, ["  M211 S1 ; ON", limits]);
}
