//! The controller on the twin (`crate::twin`): a simulated board that steps the interrupt on
//! its clock, closes the endstops where the axes' minimum is, and heats a first-order plant.

use std::boxed::Box;
use std::cell::RefCell;
use std::rc::Rc;
use std::string::String;
use std::vec::Vec;

use crate::gcode::words::Words;
use crate::limits::TICKS_PER_S;
use crate::serial::protocol::frame;
use crate::twin::{FirstOrder, Twin};
use crate::{Controller, Settings, StepQueue, Stepper, AXES, HEATERS};

/// The twin with the endstops at 0 steps and the axes some way from them, and the step times
/// of X.
struct Bench {
    t: Twin<'static, FirstOrder>,
    x_times: Rc<RefCell<Vec<u64>>>,
}

impl Bench {
    fn new(settings: Settings) -> Bench {
        let queue: &'static StepQueue = Box::leak(Box::new(StepQueue::new()));
        let mut t = Twin::new(queue, settings, FirstOrder::default());
        t.endstop_steps = [0; 3];
        t.steps = [8000, 8000, 40000, 0];
        let x_times = Rc::new(RefCell::new(Vec::new()));
        let times = Rc::clone(&x_times);
        t.on_step = Some(Box::new(move |axis, tick| {
            if axis == 0 {
                times.borrow_mut().push(tick);
            }
        }));
        Bench { t, x_times }
    }

    /// The same with the hotend already at 200 °C (unheated, it cools slowly), hot enough to
    /// extrude.
    fn hot(settings: Settings) -> Bench {
        let mut b = Bench::new(settings);
        b.t.plant.temp_c[0] = 200.0;
        b.run_ms(200);
        b
    }

    fn send(&mut self, text: &str) {
        self.t.send(text.as_bytes());
    }

    fn run_ms(&mut self, ms: u64) {
        self.t.run_ms(ms);
    }

    fn run_until_ok(&mut self, count: usize, limit_ms: u64) {
        for _ in 0..limit_ms {
            if self.text().matches("ok").count() >= count {
                return;
            }
            self.run_ms(1);
        }
        panic!("no ok within {limit_ms} ms: {}", self.text());
    }

    fn text(&self) -> String {
        String::from_utf8_lossy(&self.t.memory.sent).into_owned()
    }

    fn take(&mut self) -> String {
        let t = self.text();
        self.t.memory.sent.clear();
        t
    }
}

fn framed(n: u32, command: &str) -> String {
    let mut buf = [0u8; 128];
    let len = frame(n, command.as_bytes(), &mut buf);
    String::from_utf8(buf[..len].to_vec()).unwrap() + "\n"
}

#[test]
fn boot_says_start_and_unknown_commands_are_echoed() {
    let mut b = Bench::new(Settings::DEFAULT);
    assert_eq!(b.take(), "start\n");
    b.send("G123\nM115\n");
    b.run_ms(5);
    let t = b.take();
    assert!(t.starts_with("echo:Unknown command: \"G123\"\nok\nFIRMWARE_NAME:gweave-controller"), "{t}");
    assert!(t.contains("Cap:EEPROM:1\n") && t.ends_with("Cap:THERMAL_PROTECTION:1\nok\n"), "{t}");
}

#[test]
fn line_numbers_and_checksums_get_marlins_replies_byte_for_byte() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.take();
    b.send("N0 M110 N0*125\n");
    b.send(&framed(1, "G90"));
    b.run_ms(2);
    b.send(&framed(3, "G90"));
    b.run_ms(2);
    b.send("N2 G90*99\n");
    b.run_ms(2);
    b.send("N2 G90\n");
    b.run_ms(2);
    assert_eq!(
        b.take(),
        "ok\nok\n\
         Error:Line Number is not Last Line Number+1, Last Line: 1\nResend: 2\nok\n\
         Error:checksum mismatch, Last Line: 1\nResend: 2\nok\n\
         Error:No Checksum with line number, Last Line: 1\nResend: 2\nok\n"
    );
    // printcore's first line: the next is N0.
    b.send("N-1 M110 N-1*125\n");
    b.send(&framed(0, "G90"));
    b.run_ms(2);
    assert_eq!(b.take(), "ok\nok\n");
    b.send(&framed(1, "G90"));
    b.send(&framed(2, "G90"));
    b.send("M110 N41\n");
    b.send(&framed(42, "G91"));
    b.run_ms(2);
    assert_eq!(b.take(), "ok\nok\nok\nok\n");
}

#[test]
fn a_kilobyte_line_and_binary_garbage_get_errors_and_the_board_carries_on() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.take();
    let long = String::from("N1 G1 X") + &"1".repeat(1024) + "\n";
    b.send(&long);
    b.run_ms(2);
    assert_eq!(b.take(), "Error:Line too long, Last Line: 0\nResend: 1\nok\n");
    for byte in [0u8, 0xFF, 0x80, 0x1B, b'G', b'1', b' ', b'X', 0xC3, b'\n'] {
        assert!(b.t.controller.receive(byte));
    }
    b.run_ms(2);
    // As Marlin: not a command it knows.
    assert_eq!(b.take(), "echo:Unknown command: \"????G1 X?\"\nok\n");
    b.send("G1 X\u{e9}\n");
    b.run_ms(2);
    assert_eq!(b.take(), "Error:Bad G-code at column 5: \"G1 X??\"\nok\n");
    b.send("\x01\x02\x03\n");
    b.run_ms(2);
    assert_eq!(b.take(), "echo:Unknown command: \"???\"\nok\n");
    b.send("M105\n");
    b.run_ms(2);
    assert!(b.take().starts_with("ok T:"));
}

/// The registry (`registry.rs`) is exactly what the controller runs: on machines with and
/// without each piece of hardware, the dispatch runs every G, M and T code from 0 to 1000 that
/// has a row there, and no other (a dispatch arm without a row would never run).
#[test]
fn the_registry_is_exactly_what_the_controller_runs() {
    let machines = [
        Settings::DEFAULT,
        Settings { mixing_inputs: 4, ..Settings::DEFAULT },
        Settings { inkjet_heads: 2, ..Settings::DEFAULT },
        Settings { hotends: 2, thermistor: [1, 1, 1], ..Settings::DEFAULT },
    ];
    let mut rows = Vec::new();
    for settings in machines {
        let mut declared_here = 0;
        for letter in [b'G', b'M', b'T'] {
            for code in 0..=1000u16 {
                let mut b = Bench::new(settings);
                let line = std::format!("{}{code}", char::from(letter));
                let words = Words::parse(line.as_bytes()).unwrap();
                let runs = b.t.controller.dispatch(&mut b.t.memory, &words).is_some();
                let declared =
                    super::registry::row(letter, code, |needs| b.t.controller.has(needs)).is_some();
                assert_eq!(runs, declared, "{line} with {settings:?}");
                declared_here += usize::from(declared);
            }
        }
        rows.push(declared_here);
    }
    // 43 commands everywhere (10 G, 32 M, T0); a mixing hotend adds M163-M165 and the virtual
    // tools T1-T1000 (the mixer refuses those past its 16), inkjet heads M700, two hotends T1.
    assert_eq!(rows, [43, 43 + 3 + 1000, 44, 44]);
}

/// Regression: the ranges were checked before knowing whether the machine has the command, so
/// a mixing command on a printer without a mixing hotend was refused as out of range.
#[test]
fn a_mixing_command_without_a_mixing_hotend_is_unknown_even_out_of_range() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("M163 S0 P2000000\nM700 P0 S99999\n");
    b.run_ms(2);
    assert_eq!(
        b.take(),
        "start\necho:Unknown command: \"M163 S0 P2000000\"\nok\necho:Unknown command: \"M700 P0 S99999\"\nok\n"
    );
}

#[test]
fn a_value_out_of_range_is_refused_and_changes_nothing() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("M104 S200\nM104 S600\nG1 X10 F0\nM105\n");
    b.run_ms(5);
    let t = b.take();
    assert!(
        t.starts_with(
            "start\nok\necho:M104 S = 600.00 is out of range: 0.00 to 500.00\nok\n\
             echo:G1 F = 0.00 is out of range: 0.01 to 100000.00\nok\nok T:"
        ),
        "{t}"
    );
    assert!(t.contains(" /200.00"), "{t}");
    assert_eq!(b.t.controller.position_mm()[0], 0.0);
}

#[test]
fn a_move_makes_exact_step_counts() {
    let mut b = Bench::hot(Settings::DEFAULT);
    let start = b.t.steps;
    b.send("G21\nG91\nG1 X10.0125 Y-3.3 Z0.1 E1.5 F6000\nM400\nM114\n");
    b.run_until_ok(5, 2000);
    // 10.0125 * 80 = 801, -3.3 * 80 = -264, 0.1 * 400 = 40, 1.5 * 93 = 139.5 -> 140.
    let moved: Vec<i64> = (0..AXES).map(|a| b.t.steps[a] - start[a]).collect();
    assert_eq!(moved, [801, -264, 40, 140]);
    assert!(
        b.text().ends_with("X:10.01 Y:-3.30 Z:0.10 E:1.50 Count X:801 Y:-264 Z:40\nok\n"),
        "{}",
        b.text()
    );
}

/// `M114`'s `Count` is where the motors are (the steps the stepper made), as Marlin's, not where
/// the queued moves end: it once printed the planner's position.
#[test]
fn m114_count_is_the_steppers_position_mid_move() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.run_ms(10);
    b.take();
    let start = b.t.steps;
    // 50 mm of X (4000 steps) and 1 mm of Y back, at 50 mm/s: about a second.
    b.send(
        "G1 X50 Y-1 F3000
",
    );
    b.run_until_ok(1, 100);
    b.run_ms(300);
    b.take();
    b.send(
        "M114
",
    );
    b.run_until_ok(1, 100);
    let made = [b.t.steps[0] - start[0], b.t.steps[1] - start[1]];
    let t = b.take();
    // The position where the move ends, then the counts: behind it, at most a millisecond's
    // steps (4 at 4000 steps/s) behind the pulses counted on the twin's pins since.
    assert!(t.starts_with("X:50.00 Y:-1.00 Z:0.00 E:0.00 Count X:"), "{t}");
    let count = |letter: &str| -> i64 {
        let at = t.find("Count ").map(|c| c + t[c..].find(letter).unwrap() + letter.len()).unwrap();
        t[at..].split([' ', '\n']).next().unwrap().parse().unwrap()
    };
    let (x, y) = (count("X:"), count("Y:"));
    assert!(x > 400 && x < 4000 && made[0] - x <= 4 && x <= made[0], "Count X:{x}, made {made:?}: {t}");
    assert!(y <= 0 && y > -80 && y >= made[1] && y - made[1] <= 4, "Count Y:{y}, made {made:?}: {t}");
    // Once the move is done, the counts are the planned position.
    b.send("M400\nM114\n");
    b.run_until_ok(2, 3000);
    assert!(b.take().ends_with("X:50.00 Y:-1.00 Z:0.00 E:0.00 Count X:4000 Y:-80 Z:0\nok\n"));
}

/// `M155 S<seconds>`: the temperatures every so many seconds unasked, as Marlin's auto-report
/// (OctoPrint stops polling `M105` when `M115` says `AUTOREPORT_TEMP:1`); `S0` stops them.
#[test]
fn m155_reports_the_temperatures_every_interval_until_s0() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.run_ms(10);
    b.take();
    b.send("M115\n");
    b.run_ms(20);
    assert!(b.take().contains("Cap:AUTOREPORT_TEMP:1\n"));
    b.send("M155 S2\n");
    b.run_ms(20);
    assert_eq!(b.take(), "ok\n");
    // Reports at 2 s and 4 s: `M105`'s line without its `ok`.
    b.run_ms(5000);
    let t = b.take();
    let lines: Vec<&str> = t.lines().collect();
    assert_eq!(lines.len(), 2, "{t}");
    for l in lines {
        assert!(l.starts_with(" T:") && l.contains(" /0.00 B:") && l.ends_with(" @:0 B@:0"), "{l:?}");
    }
    b.send("M155 S0\nM155 S61\n");
    b.run_ms(5000);
    assert_eq!(b.take(), "ok\necho:M155 S = 61.00 is out of range: 0.00 to 60.00\nok\n");
}

#[test]
fn a_cold_hotend_does_not_extrude() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.run_ms(200);
    b.take();
    let start = b.t.steps;
    b.send("G1 X1 E5 F600\nG1 X2 E6\nM400\nM114\n");
    b.run_until_ok(4, 5000);
    let t = b.take();
    assert!(t.starts_with("echo: cold extrusion prevented\nok\necho: cold extrusion prevented\nok\n"), "{t}");
    // X moved, E did not, and E counts as moved: hot again, E 7 extrudes 1 mm.
    assert!(t.contains("X:2.00 Y:0.00 Z:0.00 E:6.00"), "{t}");
    assert_eq!((b.t.steps[0] - start[0], b.t.steps[3] - start[3]), (160, 0));
    b.t.plant.temp_c[0] = 200.0;
    b.run_ms(200);
    b.send("G1 E7\nM400\n");
    b.run_until_ok(2, 5000);
    assert_eq!(b.t.steps[3] - start[3], 93);
}

/// Regression (the thirty-second session's breaking session: on a two-hotend board `T1` was
/// accepted but E moves still stepped E0, held to hotend 0's temperature): after `T1` E's
/// steps go to E1's motor, back to E0's after `T0`, E counting on across the changes as
/// Marlin's one E position does; the cold-extrusion check and `M104` without `T` are the
/// active extruder's.
#[test]
fn t1_drives_the_second_extruder_on_a_two_hotend_board() {
    let eeb = Settings { hotends: 2, thermistor: [1, 1, 1], ..Settings::DEFAULT };
    let mut b = Bench::new(eeb);
    b.t.plant.temp_c[0] = 200.0;
    b.run_ms(200);
    b.take();
    let start = b.t.steps;
    // Hotend 1 is cold: its first extrusion is refused, E counting as moved.
    b.send("G1 E2 F600\nT1\nG1 E3\nM400\n");
    b.run_until_ok(4, 5000);
    assert_eq!(b.take(), "ok\nok\necho: cold extrusion prevented\nok\nok\n");
    assert_eq!((b.t.pulses[3], b.t.pulses[4]), (186, 0));
    // `M104` without `T` heats the active extruder's hotend.
    b.send("M104 S215\n");
    b.run_ms(10);
    assert_eq!(b.t.controller.heat.heaters[1].target_c, 215.0);
    assert_eq!(b.t.controller.heat.heaters[0].target_c, 0.0);
    b.t.plant.temp_c[1] = 200.0;
    b.run_ms(200);
    assert_eq!(b.take(), "ok\n");
    b.send("G1 E6\nT0\nG1 E5\nM400\n");
    b.run_until_ok(4, 5000);
    // E1: 3 mm (E 3 to 6); E0: 2 mm forward, then 1 mm back (E 6 to 5).
    assert_eq!((b.t.pulses[3], b.t.pulses[4]), (186 + 93, 279));
    assert_eq!(b.t.steps[3] - start[3], 93);
}

/// Regression (left alone since the thirty-second session: the controller had no
/// `EXTRUDE_MAXLENGTH`, so `E1000` for `E10.00` pushed a metre of filament): an extrusion
/// longer than 200 mm is refused as Marlin's `PREVENT_LENGTHY_EXTRUDE`, E counting as moved;
/// on a mixing hotend only the most loaded input's share counts; `extrude_max_mm = 0` allows
/// any.
#[test]
fn a_lengthy_extrusion_is_refused() {
    let mut b = Bench::hot(Settings::DEFAULT);
    b.take();
    let start = b.t.steps[3];
    b.send("G1 X1 E250 F6000\nG1 E260\nM400\n");
    b.run_until_ok(3, 20_000);
    assert_eq!(b.take(), "echo: too long extrusion prevented\nok\nok\nok\n");
    assert_eq!(b.t.steps[3] - start, 930, "only the 10 mm after it");
    // Four inputs sharing alike: 250 mm of E is 62.5 mm on each.
    let mut b = Bench::hot(Settings { mixing_inputs: 4, ..Settings::DEFAULT });
    b.take();
    b.send("M165 A1 B1 C1 D1\nG1 E250 F6000\nM165 A1\nG1 E500\nM400\n");
    b.run_until_ok(5, 60_000);
    // (A 10 s extrusion: the host hears that the board is busy.)
    let replies = b.take().replace("echo:busy: processing\n", "");
    assert_eq!(replies, "ok\nok\nok\necho: too long extrusion prevented\nok\nok\n");
    assert_eq!(b.t.pulses[3..7], [5813, 5812, 5813, 5812]);
    let mut b = Bench::hot(Settings { extrude_max_mm: 0.0, ..Settings::DEFAULT });
    b.take();
    b.send("G1 E250 F6000\nM400\n");
    b.run_until_ok(2, 60_000);
    assert_eq!((b.take().replace("echo:busy: processing\n", ""), b.t.pulses[3]), ("ok\nok\n".into(), 23250));
}

/// Regression (the review of the session that made `T1` drive E1: the planner joined E0's
/// last move to E1's first through its one E axis, at speed, so E0 stopped dead from 20 mm/s
/// and E1 started at it): a change of extruder waits for the moves before it, as Marlin's
/// `tool_change()` synchronises: E0 slows to a stop, then E1 starts from rest.
#[test]
fn a_change_of_extruder_waits_for_the_moves_before_it() {
    let eeb = Settings { hotends: 2, thermistor: [1, 1, 1], ..Settings::DEFAULT };
    let mut b = Bench::new(eeb);
    b.t.plant.temp_c = [200.0, 200.0, 20.0];
    b.run_ms(200);
    let steps: Rc<RefCell<Vec<(usize, u64)>>> = Rc::new(RefCell::new(Vec::new()));
    let sink = Rc::clone(&steps);
    b.t.on_step = Some(Box::new(move |motor, tick| sink.borrow_mut().push((motor, tick))));
    // E0's last move still waits in the planner when `T1` comes.
    b.send("G1 E5 F1200\nG1 E10\nG1 E15\nG1 E20\nT1\nG1 E40\nM400\n");
    b.run_until_ok(7, 20_000);
    let steps = steps.borrow();
    let times = |motor: usize| steps.iter().filter(|s| s.0 == motor).map(|s| s.1).collect::<Vec<u64>>();
    let (e0, e1) = (times(3), times(4));
    assert_eq!((e0.len(), e1.len()), (1860, 1860));
    assert!(e0[e0.len() - 1] < e1[0], "E1 started at {} before E0 ended at {}", e1[0], e0[e0.len() - 1]);
    // Each slows to a stop or starts from rest: their end intervals are longer than the cruise's
    // (1075 ticks at 20 mm/s); joined at speed, they were the cruise's.
    let cruise = e1[931] - e1[930];
    let (e0_last, e1_first) = (e0[e0.len() - 1] - e0[e0.len() - 2], e1[1] - e1[0]);
    assert!(
        e0_last > 3 * cruise / 2 && e1_first > 3 * cruise / 2,
        "{e0_last} and {e1_first} ticks, cruise {cruise}"
    );
}

#[test]
fn a_move_slower_than_the_16_bit_timer_keeps_its_pace() {
    // 0.015 mm of Z at 1 mm/min: 6 steps (the fewest a move plans: MIN_STEPS_PER_SEGMENT)
    // 0.15 s apart (300 000 ticks, several timer periods).
    let mut b = Bench::new(Settings::DEFAULT);
    let start = b.t.steps[2];
    b.send("G91\nG1 Z0.015 F1\nM400\n");
    b.run_until_ok(3, 5000);
    assert_eq!(b.t.steps[2] - start, 6);
    // The whole move takes its 0.9 s (the ramps are negligible at this speed).
    let ms = b.t.now_ms();
    assert!((900..1000).contains(&ms), "{ms} ms");
}

#[test]
fn many_short_moves_add_up_exactly() {
    let mut b = Bench::hot(Settings::DEFAULT);
    let start = b.t.steps;
    // A polygon of 0.5 mm segments with extrusion, as a slicer writes them.
    let mut text = String::from("G92 X0 Y0 E0\n");
    let (mut x, mut y, mut e) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..200 {
        let a = f64::from(i) * 0.05;
        x += 0.5 * a.cos();
        y += 0.5 * a.sin();
        e += 0.02;
        text += &std::format!("G1 X{x:.3} Y{y:.3} E{e:.4} F3600\n");
    }
    text += "M400\n";
    b.send(&text);
    b.run_until_ok(202, 20_000);
    let want = |v: f64, spm: f64| (v * spm).round() as i64;
    assert_eq!(b.t.steps[0] - start[0], want((x * 1000.0).round() / 1000.0, 80.0));
    assert_eq!(b.t.steps[1] - start[1], want((y * 1000.0).round() / 1000.0, 80.0));
    assert_eq!(b.t.steps[3] - start[3], want((e * 10000.0).round() / 10000.0, 93.0));
}

/// Regression (left alone since the thirty-second session: no software endstops, so
/// `G1 X300` on a 200 mm rail drove the carriage into the frame): once homed, a target past the
/// rail's ends is clamped to them, as Marlin's `apply_motion_limits`, the position becomes the
/// clamped one, `G92` renames the ends with the position, and `M211 S0` lets a move past them;
/// an axis not homed is not clamped.
#[test]
fn software_endstops_keep_a_homed_axis_on_its_rail() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.steps = [4000, 2400, 8000, 0];
    b.send("G1 X-20 F6000\nM400\n");
    b.run_until_ok(2, 20_000);
    assert_eq!(b.t.steps[0], 4000 - 1600, "before homing X is not clamped");
    b.send("G28\nG1 X300 Y-5 Z250 F6000\nM400\nM114\n");
    b.run_until_ok(6, 200_000);
    assert_eq!(&b.t.steps[..3], &[16000, 0, 80000], "X and Z at the end of their 200 mm, Y at 0");
    assert!(
        b.text().ends_with("X:200.00 Y:0.00 Z:200.00 E:0.00 Count X:16000 Y:0 Z:80000\nok\n"),
        "{}",
        b.text()
    );
    b.take();
    // Relative moves count from the clamped position.
    b.send("G91\nG1 X-10\nG90\nM400\nM211\n");
    b.run_until_ok(5, 20_000);
    assert_eq!(b.t.steps[0], 15200);
    let report = "  M211 S1 ; ON\n  Min:  X0.00 Y0.00 Z0.00   Max:  X200.00 Y200.00 Z200.00\nok\n";
    assert!(b.take().ends_with(report));
    // `G92 X0` at X 190: the rail runs from X -190 to X 10.
    b.send("G92 X0\nG1 X50\nM400\nM211\n");
    b.run_until_ok(4, 20_000);
    assert_eq!(b.t.steps[0], 16000);
    assert!(b.take().contains("Min:  X-190.00 Y0.00 Z0.00   Max:  X10.00 Y200.00"));
    // Off, silently as Marlin 2.1 switches it: the move goes past the end; `M211 S` (no
    // number) is on again, and the next move is held.
    b.send("M211 S0\nG1 X15\nM400\nM211\n");
    b.run_until_ok(4, 20_000);
    assert_eq!(b.t.steps[0], 16400);
    assert!(b.take().starts_with("ok\nok\nok\n  M211 S0 ; OFF\n  Min:  X-190.00"));
    b.send("M211 S\nG1 X20\nM400\n");
    b.run_until_ok(3, 20_000);
    assert_eq!((b.take().as_str(), b.t.steps[0]), ("ok\nok\nok\n", 16000));
}

/// Regression (the review of the session that added the software endstops: a bare `G92`
/// zeroed every axis, so a stray one at X 200 turned the rail into X -200..0, where Marlin and
/// the virtual printer's Marlin model do nothing): `G92` names only the axes given a number.
#[test]
fn a_bare_g92_names_nothing() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("G28\nG1 X50 F6000\nG92\nG92 Y\nG1 X60\nM400\nM114\n");
    b.run_until_ok(7, 60_000);
    assert!(b.text().ends_with("X:60.00 Y:0.00 Z:0.00 E:0.00 Count X:4800 Y:0 Z:0\nok\n"), "{}", b.text());
}

#[test]
fn g28_homes_z_then_y_then_x_to_zero() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.steps = [4000, 2400, 8000, 0];
    b.send("G28\nM114\n");
    b.run_until_ok(2, 60_000);
    assert!(b.text().ends_with("X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0\nok\n"), "{}", b.text());
    // Each axis stopped where its endstop closed (the test bench's 0), give or take the step
    // on which the switch was read.
    for axis in 0..3 {
        assert!(b.t.steps[axis] == 0, "axis {axis} at {}", b.t.steps[axis]);
    }
    // Then a move from home lands where it is asked.
    b.send("G1 X10 Y20 Z5 F6000\nM400\n");
    b.run_until_ok(4, 20_000);
    assert_eq!(&b.t.steps[..3], &[800, 1600, 2000]);
}

#[test]
fn m119_reports_the_endstops_and_g4_waits() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.steps[1] = 0; // Y at its endstop
    b.take();
    b.send("M119\nG4 P250\nM400\n");
    b.run_ms(100);
    assert_eq!(b.take(), "Reporting endstop status\nx_min: open\ny_min: TRIGGERED\nz_min: open\nok\n");
    b.run_ms(200);
    assert_eq!(b.take(), "ok\nok\n");
}

#[test]
fn a_full_planner_holds_the_ok_until_a_block_is_free() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.take();
    // 20 slow moves: the planner holds 16, plus the one being cut; the host gets its oks as
    // room frees up, and the steps come out exact.
    let start = b.t.steps[0];
    for i in 1..=20 {
        b.send(&std::format!("G1 X{i} F600\n"));
    }
    b.run_ms(5);
    let early = b.text().matches("ok").count();
    assert!((16..20).contains(&early), "{early} oks at once");
    b.run_until_ok(20, 10_000);
    b.send("M400\n");
    b.run_until_ok(21, 10_000);
    assert_eq!(b.t.steps[0] - start, 20 * 80);
}

/// The axes in the order they moved during `G28` on a board with `homing_order`.
fn homing_sequence(homing_order: [u8; 3]) -> Vec<usize> {
    let queue = StepQueue::new();
    let moved = Rc::new(RefCell::new(Vec::new()));
    let log = Rc::clone(&moved);
    let mut t = Twin::new(&queue, Settings { homing_order, ..Settings::DEFAULT }, FirstOrder::default());
    t.on_step = Some(Box::new(move |axis, _| {
        let mut m = log.borrow_mut();
        if m.last() != Some(&axis) {
            m.push(axis);
        }
    }));
    t.run_lines(b"G28\n", 60_000).unwrap();
    assert_eq!(t.steps_from_home()[..3], [0, 0, 0]);
    drop(t);
    Rc::try_unwrap(moved).unwrap().into_inner()
}

#[test]
fn g28_homes_in_the_settings_order_z_y_x_by_default() {
    // Each axis: approach, back off, approach again, all on that axis alone.
    assert_eq!(homing_sequence([2, 1, 0]), [2, 1, 0]);
    assert_eq!(homing_sequence([0, 1, 2]), [0, 1, 2]);
}

/// Regression (review of the homing failure: with `homing_bump_mm` 0, which a printer file may
/// set, the second touch had no steps, so no move found the switch and every `G28` halted the
/// board with `Error:Homing Failed`): the first touch is the origin.
#[test]
fn g28_without_a_bump_homes_at_the_first_touch() {
    let mut b = Bench::new(Settings { homing_bump_mm: [0.0; 4], ..Settings::DEFAULT });
    b.t.steps = [4000, 2400, 8000, 0];
    b.take();
    b.send("G28\n");
    b.run_until_ok(1, 60_000);
    assert!(b.take().ends_with("processing\nok\n"));
    assert_eq!(b.t.steps_from_home()[..3], [0, 0, 0]);
}

#[test]
fn g28_with_one_axis_homes_only_it() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.steps = [4000, 2400, 8000, 0];
    b.send("G28 X\n");
    b.run_until_ok(1, 60_000);
    assert_eq!(&b.t.steps[..3], &[0, 2400, 8000]);
}

#[test]
fn m503_reports_as_marlin_and_m500_keeps_settings_over_a_reset() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.take();
    b.send("M503\n");
    b.run_ms(2);
    let t = b.take();
    assert!(t.contains("echo:  M92 X80.00 Y80.00 Z400.00 E93.00\n"), "{t}");
    assert!(t.contains("echo:  M203 X300.00 Y300.00 Z5.00 E25.00\n"), "{t}");
    assert!(t.contains("echo:  M301 P22.20 I1.08 D114.00\n"), "{t}");
    b.send("M92 E415.5\nM500\n");
    b.run_ms(2);
    assert!(b.take().contains("echo:Settings Stored (82 bytes; crc "));
    // A new board with the same EEPROM.
    let eeprom = std::mem::take(&mut b.t.memory.eeprom);
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.memory.eeprom = eeprom;
    b.t.power_on();
    assert_eq!(b.t.controller.settings().steps_per_mm[3], 415.5);
    b.send("M502\nM503\n");
    b.run_ms(2);
    assert!(b.take().contains("echo:  M92 X80.00 Y80.00 Z400.00 E93.00\n"));
}

#[test]
fn m109_heats_to_its_target_reporting_then_holds_it() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.take();
    b.send("M109 S210\n");
    b.run_until_ok(1, 300_000);
    let t = b.take();
    assert!(t.contains(" T:"), "{t}");
    assert!(t.contains("echo:busy: processing\n"), "{t}");
    assert!(b.t.plant.temp_c[0] >= 209.0, "{}", b.t.plant.temp_c[0]);
    let (mut low, mut high) = (f32::MAX, 0.0f32);
    for _ in 0..120 {
        b.run_ms(500);
        low = low.min(b.t.plant.temp_c[0]);
        high = high.max(b.t.plant.temp_c[0]);
    }
    assert!(low > 208.0 && high < 213.0, "held within {low}..{high}");
    assert!(b.t.memory.watchdog_feeds > 1000);
}

#[test]
fn m190_heats_the_bed() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("M190 S60\nM105\n");
    b.run_until_ok(2, 600_000);
    assert!(b.t.controller.heat().heaters[crate::BED].temp_c >= 59.0, "{}", b.text());
    assert!(b.text().contains("B:"));
}

fn assert_halted(b: &mut Bench, error: &str) {
    let t = b.take();
    assert!(t.contains(&(String::from(error) + "\nError:Printer halted. kill() called!\n")), "{t}");
    assert!(b.t.controller.is_halted());
    let out = b.t.controller.outputs();
    assert_eq!((out.heater_duty, out.fan_duty, out.steppers_enabled), ([0; HEATERS], 0, 0));
    b.send("G28\n");
    b.run_ms(2);
    assert_eq!(b.take(), "Error:Printer halted. kill() called!\nok\n");
}

#[test]
fn an_open_thermistor_halts_with_mintemp() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.plant.adc_override[0] = Some(1023);
    b.send("M104 S200\n");
    b.run_ms(300);
    assert_halted(&mut b, "Error:MINTEMP triggered, system stopped! Heater_ID: 0");
}

#[test]
fn a_heater_that_cannot_heat_halts_with_heating_failed() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.plant.heating = [false; HEATERS];
    b.send("M104 S200\n");
    b.run_ms(21_000);
    assert_halted(&mut b, "Error:Heating failed, system stopped! Heater_ID: 0");
}

#[test]
fn a_heater_that_fails_at_temperature_halts_with_thermal_runaway() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("M190 S60\n");
    b.run_until_ok(1, 600_000);
    // The wait ends within a degree; the runaway watch starts once the target is reached.
    b.run_ms(30_000);
    b.t.plant.heating = [false; HEATERS];
    b.run_ms(60_000);
    assert_halted(&mut b, "Error:Thermal Runaway, system stopped! Heater_ID: bed");
}

#[test]
fn a_shorted_thermistor_halts_with_maxtemp_even_unheated() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.t.plant.adc_override[crate::BED] = Some(3);
    b.run_ms(300);
    assert_halted(&mut b, "Error:MAXTEMP triggered, system stopped! Heater_ID: bed");
}

#[test]
fn m112_stops_everything_at_once() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("M104 S200\nG1 X100 F600\n");
    b.run_ms(500);
    let before = b.t.steps[0];
    // Queued behind a dwell and a full line queue, M112 still acts at once: the receive
    // interrupt's emergency parser hears every byte as it arrives, its line queued or lost.
    for &byte in b"G4 S10\nG4 S1\nG4 S1\nG4 S1\nG4 S1\nM112\n" {
        let _ = b.t.arrive(byte);
    }
    b.run_ms(1);
    let t = b.take();
    assert!(t.ends_with("Error:Printer halted. kill() called!\n"), "{t}");
    b.run_ms(100);
    assert!(b.t.steps[0] - before < 20, "steps after M112: {}", b.t.steps[0] - before);
    let out = b.t.controller.outputs();
    assert_eq!((out.heater_duty, out.steppers_enabled), ([0; HEATERS], 0));
}

#[test]
fn acceleration_follows_the_setting() {
    let mut b =
        Bench::new(Settings { print_accel_mm_s2: 1000.0, travel_accel_mm_s2: 1000.0, ..Settings::DEFAULT });
    b.send("G91\nG1 X40 F6000\nM400\n");
    b.run_until_ok(3, 10_000);
    // From the X step times: speed between steps 80 apart (1 mm), and the acceleration from
    // speeds 10 mm apart in the ramp (v² = v0² + 2 a d). The ramp to 100 mm/s is 5 mm.
    let t = b.x_times.borrow();
    assert_eq!(t.len(), 3200);
    let secs = |ticks: u64| ticks as f64 / f64::from(TICKS_PER_S);
    // The mean speed over 1 mm, and the time in the middle of it: under constant acceleration
    // the mean speed over a time is the speed at its middle.
    let speed = |i: usize| (1.0 / secs(t[i + 80] - t[i]), secs(t[i + 80] + t[i]) / 2.0);
    let ((v1, t1), (v2, t2)) = (speed(40), speed(280));
    let a = (v2 - v1) / (t2 - t1);
    assert!((a - 1000.0).abs() < 10.0, "acceleration {a} mm/s²");
    let cruise = speed(1600).0;
    assert!((cruise - 100.0).abs() < 0.5, "cruise {cruise} mm/s");
    let total_s = (t[3199] - t[0]) as f64 / f64::from(TICKS_PER_S);
    // 40 mm: 0.1 s up, 30 mm at 100 mm/s, 0.1 s down, less the 5 ms to the first step
    // (1/80 mm from rest: t = sqrt(2 d / a)).
    assert!((total_s - 0.495).abs() < 0.0002, "{total_s} s");
}

#[test]
fn the_core_fits_the_ram_budget() {
    // On the host, references are 8 bytes instead of an AVR's 2 and alignment pads more: an
    // upper bound of the board's figure (1680 + 264 + 64 bytes when written). The budget of the
    // whole firmware is 4 KB of static RAM, the core's constants (about 1.8 KB of strings and
    // tables, which an AVR copies into RAM) included.
    //
    // A mixing hotend's state comes on top, counted exactly: the mixer (tools, collector,
    // shares), and a step count per extra input in every planner block, step block and in the
    // stepper's Bresenham counters.
    use crate::limits::{MIX_INPUTS, PLANNER_BLOCKS, STEP_BLOCKS};
    let mixing = core::mem::size_of::<crate::mixing::Mixer>()
        + (PLANNER_BLOCKS + STEP_BLOCKS + 2) * 4 * (MIX_INPUTS - 1);
    // An inkjet build's refill times (`M700`) come on top too, and their alignment.
    #[cfg(feature = "inkjet")]
    let mixing = mixing + core::mem::size_of::<crate::inkjet::Heads>() + 4;
    // So does the rotary axis': its settings, the angle and its anchor, G93's F, the planner's
    // A position and A's place in the junction direction, and their alignment (4 bytes: the
    // controller's fields padded anew once M114's step counts joined them).
    let mixing = mixing
        + core::mem::size_of::<crate::rotary::Rotary>()
        + 3 * 4
        + core::mem::size_of::<Option<f32>>()
        + 2 * 4
        + 4;
    // And the software endstops (the homed axes, where each rail starts) and the active
    // extruder of a two-hotend board, with the planner's alignment on the host (8 bytes).
    let mixing = mixing + core::mem::size_of::<super::soft_endstops::SoftEndstops>() + 8;
    let size = core::mem::size_of::<Controller>() + core::mem::size_of::<StepQueue>();
    assert!(
        size + core::mem::size_of::<Stepper>() <= 2048 + mixing,
        "{size} bytes, {mixing} of them mixing, inkjet and rotary, stepper {}",
        core::mem::size_of::<Stepper>()
    );
}

#[test]
fn thirty_thousand_steps_a_second_come_four_per_interrupt_on_the_profiles_time() {
    // 100 mm of X at 375 mm/s (30 000 steps/s at 80 steps/mm), 3000 mm/s²: ramps of 0.125 s
    // and 23.4375 mm each, 53.125 mm of cruise in 0.141667 s.
    let mut s = Settings::DEFAULT;
    s.max_feed_mm_s[0] = 400.0;
    let mut b = Bench::new(s);
    b.send("G91\nG1 X100 F22500\nM400\n");
    b.run_until_ok(3, 10_000);
    let t = b.x_times.borrow();
    assert_eq!(t.len(), 8000);
    // At cruise the step interval is 66.7 ticks, under MULTISTEP_TICKS: 4 events an interrupt,
    // an interrupt every 266.7 ticks (133 us: 7500 interrupts a second).
    let cruise = &t[3900..4100];
    let mut groups: Vec<u64> = cruise.to_vec();
    groups.dedup();
    // (51 when the 200 steps begin and end inside a group.)
    assert!((50..=51).contains(&groups.len()), "{} interrupts for 200 steps", groups.len());
    for w in groups.windows(2) {
        // Four intervals of 66 or 67 ticks (the fraction is carried from segment to segment).
        assert!((264..=268).contains(&(w[1] - w[0])), "interrupts {} ticks apart", w[1] - w[0]);
    }
    // The move still takes its profile's time, less the time to its first step (1/80 mm from
    // rest: sqrt(2 d / a) = 2.887 ms), and the last step lands on the profile's end.
    let total_s = (t[7999] - t[0]) as f64 / f64::from(TICKS_PER_S);
    let planned_s = 2.0 * 0.125 + 53.125 / 375.0 - (2.0 * 0.0125f64 / 3000.0).sqrt();
    assert!((total_s - planned_s).abs() < 0.0002, "{total_s} s, planned {planned_s} s");
}

/// Regression (a breaking session: `M502` on a two-hotend board loaded the core's one-hotend
/// defaults; hotend 1's heater kept its last duty with no rule watching it, 408 °C after six
/// minutes): `M502` restores the board's own build (its printer file: here two hotends and
/// 100 steps/mm on X), so `M104 T1 S0` still switches the second hotend off.
#[test]
fn m502_restores_the_boards_build_and_every_heater_stays_watched() {
    let mut steps_per_mm = Settings::DEFAULT.steps_per_mm;
    steps_per_mm[0] = 100.0;
    let eeb = Settings { hotends: 2, thermistor: [1, 1, 1], steps_per_mm, ..Settings::DEFAULT };
    let mut b = Bench::new(eeb);
    b.send("M104 T1 S240\nM92 X80\n");
    b.run_ms(20_000);
    assert_eq!(b.t.controller.outputs().heater_duty[1], 255);
    b.send("M502\nM104 T1 S0\nM104 S0\nM105\n");
    b.run_ms(1000);
    assert_eq!(*b.t.controller.settings(), eeb);
    let t = b.take();
    assert!(t.contains(" T1:"), "M105 lists the second hotend: {t}");
    assert_eq!(b.t.controller.outputs().heater_duty, [0; HEATERS]);
}

/// Regression (a breaking session: any `M104` cleared the runaway watch, re-armed only once the
/// reading was back at target; a slicer's `M104 S210` every layer let a thermistor that slipped
/// out read 190 °C and creep up while the heater ran at full power until MAXTEMP, the block at
/// 363 °C): the same target again keeps the runaway watch, as Marlin restarts it only when the
/// target changes, and the fault comes 40 s after the reading fell away.
#[test]
fn the_same_target_again_keeps_the_runaway_watch() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("M109 S210\n");
    b.run_until_ok(1, 400_000);
    b.run_ms(30_000);
    let mut reading_c = 190.0;
    for second in 1..=60 {
        b.t.plant.adc_override[0] = Some(crate::twin::type_1_adc(reading_c));
        if second % 10 == 0 {
            b.send("M104 S210\n");
        }
        b.run_ms(1000);
        reading_c += 3.0 / 20.0;
        if b.t.controller.is_halted() {
            assert!((40..=42).contains(&second), "halted after {second} s");
            return assert_halted(&mut b, "Error:Thermal Runaway, system stopped! Heater_ID: 0");
        }
    }
    panic!("no runaway after 60 s: {}", b.take());
}

/// Regression (a breaking session: `G1 Z` drove Z to 0 and `M104 S` switched the hotend off):
/// a letter without a number changes nothing, as Marlin reads it.
#[test]
fn a_letter_without_a_number_changes_nothing() {
    let mut b = Bench::hot(Settings::DEFAULT);
    b.send("M104 S200\nG1 X10 Z10 F3000\nG1 Z\nM104 S\n");
    b.run_ms(10_000);
    assert_eq!(b.t.controller.position_mm()[2], 10.0);
    assert_eq!(b.t.controller.heat().heaters[0].target_c, 200.0);
}

/// Regression (a breaking session: `M108` sent during `M109 S250` waited its turn in the queue
/// while the heater went on heating, though `M115` says `EMERGENCY_PARSER`): the emergency
/// parser hears it at once and the wait ends with its `ok`, the target kept; an `M108` heard
/// before a wait does not end it.
#[test]
fn m108_ends_a_heating_wait_at_once() {
    let mut b = Bench::new(Settings::DEFAULT);
    b.send("M108\nM109 S250\n");
    b.run_ms(5_000);
    // M108's own `ok` in its turn (a command that does nothing then); the wait goes on.
    assert_eq!(b.take().matches("ok\n").count(), 1);
    b.send("M108\n");
    b.run_ms(2);
    let t = b.take();
    assert!(t.ends_with("ok\nok\n") && !t.contains("Unknown"), "{t}");
    assert_eq!(b.t.controller.heat().heaters[0].target_c, 250.0);
    assert!(b.t.plant.temp_c[0] < 100.0);
}

/// Regression (a breaking session: `M109 R10` and `M190 R20`, targets below the room's, waited
/// for ever): a wait to cool down gives up once the temperature fell less than 1.5 °C in a
/// minute (Marlin's `MIN_COOLING_SLOPE_DEG` / `_TIME`), with its `ok`.
#[test]
fn a_wait_to_cool_below_the_room_gives_up_after_a_minute() {
    for command in ["M109 R10\n", "M190 R15\n"] {
        let mut b = Bench::new(Settings::DEFAULT);
        b.take();
        b.send(command);
        b.run_ms(59_000);
        assert!(!b.text().contains("ok\n"), "{command}: gave up too early");
        b.run_ms(2_000);
        assert!(b.take().ends_with("ok\n"), "{command}: still waiting after 61 s");
    }
    // A heater that cools as it should is waited for: from 200 °C down to 150 °C.
    let mut b = Bench::hot(Settings::DEFAULT);
    b.send("M109 R150\n");
    b.run_until_ok(1, 600_000);
    assert!(b.t.plant.temp_c[0] < 151.0, "{}", b.t.plant.temp_c[0]);
}

/// Regression (review of the cooling wait: `M109 R S150` waited to cool, for the `R` without a
/// number, and `M109 R100 S150` took `R`): as Marlin's `M109`, `S` is the target and the wait
/// only heats; `R` without a number is not there. At 200 °C both answer at once.
#[test]
fn m109_with_s_only_heats_whatever_r_says() {
    for command in ["M109 R S150\n", "M109 R100 S150\n"] {
        let mut b = Bench::hot(Settings::DEFAULT);
        b.take();
        b.send(command);
        b.run_ms(1_500);
        assert!(b.take().ends_with("ok\n"), "{command}: waited to cool");
        assert!(b.t.plant.temp_c[0] > 195.0, "{command}: {}", b.t.plant.temp_c[0]);
    }
}

/// Regression (a breaking session: `G28 X` answered `ok` and called the axis 0 with the
/// carriage 195 mm from an endstop that never closed): a move towards the endstop that ends
/// without it is `Error:Homing Failed` and a halt, as Marlin's `validate_homing_move`.
#[test]
fn homing_that_never_meets_its_endstop_halts() {
    let mut b = Bench::new(Settings::DEFAULT);
    // The X switch is farther than 1.5 times the travel: the approach ends without it.
    b.t.endstop_steps[0] = -1_000_000;
    b.take();
    b.send("G28 X\n");
    b.run_ms(60_000);
    assert_halted(&mut b, "Error:Homing Failed");
}

/// Regression (a breaking session: `M84` switched the drivers off at once, while the moves
/// before it still ran: on the board the X driver was off in 1286 of 2000 samples of the next
/// second while X stepped): the drivers let go once the moves have ended, as Marlin's `M84`
/// waits for them.
#[test]
fn m84_switches_the_motors_off_after_the_moves() {
    let mut b = Bench::new(Settings::DEFAULT);
    let start = b.t.steps[0];
    b.send("G1 X20 F600\nM84\n");
    b.run_ms(1000);
    assert_ne!(b.t.controller.outputs().steppers_enabled & 1, 0, "X let go mid-move");
    b.run_ms(3000);
    assert_eq!(b.t.steps[0] - start, 20 * 80, "the whole move");
    assert_eq!(b.t.controller.outputs().steppers_enabled, 0);
    assert!(b.take().ends_with("ok\n"));
}
