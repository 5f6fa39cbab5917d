//! Moves on the emulated board: STEP pulses counted on the pins, per axis.

use gweave_board::Wiring;

/// Sockets X, Y, Z, E0, E1, E2, E3.
const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;

#[test]
fn a_g1_move_gives_exactly_its_steps_on_every_axis() {
    let mut board = crate::common::booted(Wiring::default());
    // From the start position (the origin until homed), relative.
    for line in ["G91", "G1 X10 Y-5 Z0.5 F3000", "G1 X-2.5 F1200", "M400"] {
        assert_eq!(board.command(line, 30.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    // 7.5 mm * 80, -5 mm * 80, 0.5 mm * 400 (the default printer's steps/mm).
    assert_eq!(board.net_steps(), [600, -400, 200, 0, 0, 0, 0]);
    assert_eq!(board.axis(X).steps_plus, 800);
    assert_eq!(board.axis(X).steps_minus, 200);
    for socket in [X, Y, Z] {
        assert_eq!(board.axis(socket).steps_while_disabled, 0, "socket {socket}");
        // Drivers need a STEP pulse of at least 1.9 us (the DRV8825; the A4988 1 us): 31 cycles.
        let pulse = board.axis(socket).min_pulse_cycles.unwrap();
        assert!(pulse >= 31, "socket {socket}: {pulse} cycles");
    }
}

#[test]
fn g28_homes_z_then_y_then_x_against_the_endstops() {
    let mut board = crate::common::booted(Wiring { record_steps: true, ..Wiring::default() });
    let lines = board.command("G28", 120.0).unwrap();
    assert_eq!(lines.last().unwrap(), "ok", "{lines:?}");
    // Each axis stops on the step that closes its switch (position 0).
    for socket in [X, Y, Z] {
        assert_eq!(board.axis(socket).position, 0, "socket {socket}");
    }
    // Z moves first and is done before Y starts; Y is done before X starts.
    let span = |socket: usize| {
        let log = &board.axis(socket).step_log;
        (log.first().unwrap().0, log.last().unwrap().0)
    };
    let (z, y, x) = (span(Z), span(Y), span(X));
    assert!(z.1 < y.0 && y.1 < x.0, "Z {z:?} Y {y:?} X {x:?}");
    let report = board.command("M114", 1.0).unwrap();
    assert!(report[0].starts_with("X:0.00 Y:0.00 Z:0.00"), "{report:?}");
}

/// Software endstops on the board: once homed, `G1 X300 Z-3` on the default printer's 200 mm
/// rails stops X at its end (16 000 steps from the switch) and Z on its switch, and `M211 S0`
/// lets the next move past.
#[test]
fn a_homed_axis_stops_at_the_end_of_its_rail() {
    let mut board = crate::common::booted(Wiring::default());
    for line in ["G28", "G1 X300 Z-3 F6000", "M400"] {
        assert_eq!(board.command(line, 120.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    assert_eq!((board.axis(X).position, board.axis(Z).position), (16000, 0));
    let report = board.command("M114", 1.0).unwrap();
    assert!(report[0].starts_with("X:200.00 Y:0.00 Z:0.00"), "{report:?}");
    for line in ["M211 S0", "G1 X201", "M400"] {
        assert_eq!(board.command(line, 10.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    assert_eq!(board.axis(X).position, 16080);
}

/// `M114` while a long move runs (no `M400` before it): `Count` is where the motors are, the
/// steps made, behind the planned position, as Marlin's `count_position` (it once printed the
/// planner's position, where the queued moves end).
#[test]
fn m114_mid_move_counts_the_steps_made_so_far() {
    let mut board = crate::common::booted(Wiring::default());
    // 100 mm of X at 50 mm/s: 8000 steps in about 2 s.
    assert_eq!(board.command("G1 X100 F3000", 5.0).unwrap().last().unwrap(), "ok");
    board.run_for(0.5).unwrap();
    let reply = board.command("M114", 1.0).unwrap();
    let made = board.net_steps()[X];
    let report = reply.iter().find(|l| l.contains(" Count ")).unwrap();
    assert!(report.starts_with("X:100.00 Y:0.00 Z:0.00 E:0.00 Count X:"), "{report}");
    let count = crate::common::field(report, "Count X:") as i64;
    // Behind the plan, and at most the few steps made while the reply went out (4000
    // steps/s: 4 a millisecond) behind the pulses counted on the pins by then.
    assert!((1000..8000).contains(&count), "Count X:{count}");
    assert!((0..=20).contains(&(made - count)), "Count X:{count}, {made} steps on the pins");
    let reply = board.command("M400", 5.0).and_then(|_| board.command("M114", 1.0)).unwrap();
    assert!(reply[0].ends_with("Count X:8000 Y:0 Z:0"), "{reply:?}");
    assert_eq!(board.net_steps()[X], 8000);
}

/// On the chip, where preparing a segment costs board time, the ramp first measured about 2400
/// mm/s²: the step interrupt waited about a millisecond between segments (fixed in the core).
#[test]
fn the_pins_accelerate_at_the_configured_rate() {
    let mut board = crate::common::booted(Wiring { record_steps: true, ..Wiring::default() });
    // 100 mm/s on X with the default 3000 mm/s²: 1.67 mm (133 steps) of acceleration.
    for line in ["G91", "G1 X20 F6000", "M400"] {
        assert_eq!(board.command(line, 10.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    let log = &board.axis(X).step_log;
    assert_eq!(log.len(), 1600);
    // The speed of each step (1/80 mm over its interval) against time: a least-squares line
    // through the ramp (the 2nd to the 120th step; it ends at the 133rd) has the acceleration
    // for slope, whatever speed the move starts at.
    let hz = f64::from(gweave_board::CPU_HZ);
    let points: Vec<(f64, f64)> = log[1..120]
        .windows(2)
        .map(|w| ((w[0].0 + w[1].0) as f64 / 2.0 / hz, hz / 80.0 / (w[1].0 - w[0].0) as f64))
        .collect();
    let n = points.len() as f64;
    let (st, sv) = points.iter().fold((0.0, 0.0), |(a, b), (t, v)| (a + t, b + v));
    let (mt, mv) = (st / n, sv / n);
    let cov: f64 = points.iter().map(|(t, v)| (t - mt) * (v - mv)).sum();
    let var: f64 = points.iter().map(|(t, _)| (t - mt) * (t - mt)).sum();
    let accel_mm_s2 = cov / var;
    assert!((accel_mm_s2 / 3000.0 - 1.0).abs() <= 0.01, "accelerated at {accel_mm_s2:.0} mm/s²");
    // The cruise: 100 mm/s is 8000 steps/s, 2000 cycles a step.
    let mid = &log[700..900];
    let cruise_hz =
        (mid.len() - 1) as f64 * f64::from(gweave_board::CPU_HZ) / (mid[mid.len() - 1].0 - mid[0].0) as f64;
    assert!((cruise_hz / 8000.0 - 1.0).abs() <= 0.01, "cruised at {cruise_hz:.0} steps/s");
}

/// Streaming short segments as a host does (one line after each `ok`, 250000 baud): reading
/// and planning a line must take the chip less time than the line's motion, or the planner
/// runs dry and the head stops between lines. It did (gaps of 2.9 ms) while the step interrupt
/// took 1100 cycles a step, then (2.87 ms) while the float arithmetic was `compiler_builtins`'
/// portable code: 17 ms of main loop a line for 8.3 ms of motion (fixed: avr-libc's, linked by
/// `firmware/ramps/build.rs`).
#[test]
fn half_millimetre_segments_at_60_mm_s_never_run_dry() {
    streamed_segments_never_run_dry(0.5, 60.0);
}

/// The same with 1 mm segments at 100 mm/s (10 ms of motion a line, 8000 steps/s on X).
#[test]
fn millimetre_segments_at_100_mm_s_never_run_dry() {
    streamed_segments_never_run_dry(1.0, 100.0);
}

/// How late a step may come when interrupts meet (the step interrupt that takes a new block
/// runs up to 1650 cycles, `bench/firmware.sh`): 1667 cycles, half a step at 60 mm/s, the
/// slack this test first had. Measured: 4532 cycles between steps at 60 mm/s (3333 a step),
/// 3158 at 100 mm/s (2000 a step).
const LATE_STEP_CYCLES: f64 = 1667.0;

/// 200 lines of `segment_mm` along X at `speed_mm_s`, each sent after the last one's `ok`: the
/// X steps of the run's middle come without a gap longer than a step and
/// [`LATE_STEP_CYCLES`].
fn streamed_segments_never_run_dry(segment_mm: f64, speed_mm_s: f64) {
    const LINES: u32 = 200;
    let mut board = crate::common::booted(Wiring { record_steps: true, ..Wiring::default() });
    // From X 0: 200 lines of 1 mm end at the 200 mm rail's end (past it, the software
    // endstops would hold X there).
    for line in ["G28", "G90", "G1 X0 Y10 F3600", "M400"] {
        assert_eq!(board.command(line, 60.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    let first = board.axis(X).step_log.len();
    for i in 1..=LINES {
        let x = segment_mm * f64::from(i);
        board.command(&format!("G1 X{x:.1} F{:.0}", speed_mm_s * 60.0), 5.0).unwrap();
    }
    board.command("M400", 10.0).unwrap();
    let log = &board.axis(X).step_log[first..];
    // 80 steps/mm (the default printer).
    assert_eq!(log.len() as f64, f64::from(LINES) * segment_mm * 80.0);
    // Away from the ramps at either end: a step is due every CPU_HZ / (80 v) cycles (3333 at
    // 60 mm/s); a longer gap than a step and a late step's slack is the head slowing for want
    // of moves (a dry planner stopped it for 45 000 cycles).
    let step_cycles = f64::from(gweave_board::CPU_HZ) / (80.0 * speed_mm_s);
    let middle = &log[log.len() / 10..log.len() * 9 / 10];
    let longest = middle.windows(2).map(|w| w[1].0 - w[0].0).max().unwrap();
    assert!(
        (longest as f64) < step_cycles + LATE_STEP_CYCLES,
        "a gap of {longest} cycles between steps ({step_cycles:.0} a step)"
    );
}
