//! Step timing on the pins at the goal rates: 30 000 steps/s on one axis, 20 000 on
//! X, Y and E together. Each pulse is compared with the same core run on its host twin (where
//! the step interrupt costs no time, so its step times are the plan's), and the acceleration
//! is measured from the pulses themselves.

use gweave_board::{Wiring, CPU_HZ};
use gweave_controller::limits::TICKS_PER_S;
use gweave_controller::twin::{FirstOrder, Twin};
use gweave_controller::{Settings, StepQueue, AXES};

/// Board cycles per step timer tick (16 MHz over 2 MHz).
const CYCLES_PER_TICK: u64 = (CPU_HZ / TICKS_PER_S) as u64;

/// A hotend hot enough to extrude (the core drops E below 170 °C), unheated: it cools by
/// a fraction of a degree in the second a test takes.
const HOT_C: f32 = 210.0;

/// The lines of one test, from a freshly booted board (and twin): the speed limits raised
/// out of the way, relative moves.
fn setup(lines: &[&str]) -> Vec<String> {
    let mut all: Vec<String> =
        ["M203 X400 Y400 E400", "M201 X3000 Y3000 E3000", "G91"].map(String::from).to_vec();
    all.extend(lines.iter().map(|l| l.to_string()));
    all.push("M400".into());
    all
}

/// The twin's step times of each motor, in board cycles.
fn twin_times(lines: &[String]) -> Vec<Vec<u64>> {
    let queue = StepQueue::new();
    let mut twin = Twin::new(&queue, Settings::DEFAULT, FirstOrder::default());
    twin.plant.temp_c[0] = HOT_C;
    twin.run_ms(300);
    let times = std::rc::Rc::new(std::cell::RefCell::new(vec![Vec::new(); AXES]));
    let sink = std::rc::Rc::clone(&times);
    twin.on_step = Some(Box::new(move |motor, tick| {
        if motor < AXES {
            sink.borrow_mut()[motor].push(tick * CYCLES_PER_TICK);
        }
    }));
    let text: String = lines.iter().map(|l| format!("{l}\n")).collect();
    twin.run_lines(text.as_bytes(), 60_000).unwrap();
    drop(twin);
    std::rc::Rc::try_unwrap(times).unwrap().into_inner()
}

/// Runs `lines` on a fresh board and on the twin; for each of `sockets`, checks that every
/// pulse (times from the axis' first) is within one interrupt period of the twin's, and
/// returns the board's step times of the first socket.
fn on_time(lines: &[&str], sockets: &[usize], steps: usize) -> Vec<u64> {
    let lines = setup(lines);
    let mut board = crate::common::booted(Wiring { record_steps: true, ..Wiring::default() });
    board.shield_mut().plants[0].heater.set_temperature(f64::from(HOT_C));
    board.run_for(0.3).unwrap();
    for line in &lines {
        assert_eq!(board.command(line, 10.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    let twin = twin_times(&lines);
    for &socket in sockets {
        let pins: Vec<u64> = board.axis(socket).step_log.iter().map(|s| s.0).collect();
        let plan = &twin[socket];
        assert_eq!((pins.len(), plan.len()), (steps, steps), "socket {socket}");
        for i in 1..steps {
            // One interrupt period here: from the twin's interrupt before this step's to the
            // one after (several steps share an interrupt at these rates).
            let before = plan[..i].iter().rev().find(|&&t| t < plan[i]).unwrap_or(&plan[0]);
            let after = plan[i..].iter().find(|&&t| t > plan[i]).unwrap_or(&plan[i]);
            let period = (after - before).max(plan[i] - before);
            let (pin, planned) = (pins[i] - pins[0], plan[i] - plan[0]);
            assert!(
                pin.abs_diff(planned) <= period,
                "socket {socket} step {i}: {pin} cycles after the first, planned {planned} (period {period})"
            );
        }
    }
    board.axis(sockets[0]).step_log.iter().map(|s| s.0).collect()
}

/// The acceleration of a ramp from its step times, mm/s²: a least-squares parabola
/// `s = s0 + v0 t + a t² / 2` through the positions (one step of `mm_per_step` each), which
/// several steps to an interrupt do not bias as intervals between pulses would.
fn fitted_accel_mm_s2(times: &[u64], mm_per_step: f64) -> f64 {
    let t0 = times[0];
    let pts: Vec<(f64, f64)> = times
        .iter()
        .enumerate()
        .map(|(i, &c)| ((c - t0) as f64 / f64::from(CPU_HZ), i as f64 * mm_per_step))
        .collect();
    // Normal equations of s = c0 + c1 t + c2 t², solved by Cramer's rule.
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    for &(t, s) in &pts {
        let basis = [1.0, t, t * t];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += basis[i] * basis[j];
            }
            r[i] += basis[i] * s;
        }
    }
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let mut m2 = m;
    for i in 0..3 {
        m2[i][2] = r[i];
    }
    2.0 * det(&m2) / det(&m)
}

#[test]
fn thirty_thousand_steps_a_second_on_x_are_on_time() {
    // 100 mm at 375 mm/s (30 000 steps/s at 80 steps/mm), 3000 mm/s²: 23.4 mm (1875 steps)
    // of ramp at each end.
    let times = on_time(&["G1 X100 F22500"], &[0], 8000);
    let accel = fitted_accel_mm_s2(&times[20..1800], 1.0 / 80.0);
    assert!((accel / 3000.0 - 1.0).abs() <= 0.01, "accelerated at {accel:.0} mm/s²");
    let mid = &times[3000..5000];
    let cruise_hz = (mid.len() - 1) as f64 * f64::from(CPU_HZ) / (mid[mid.len() - 1] - mid[0]) as f64;
    assert!((cruise_hz / 30_000.0 - 1.0).abs() <= 0.01, "cruised at {cruise_hz:.0} steps/s");
}

#[test]
fn twenty_thousand_steps_a_second_on_x_y_and_e_are_on_time() {
    // 50 mm of X and Y at 250 mm/s each (353.6 mm/s along the path) and 43.01 mm of E: 4000
    // steps on each, at 20 000 steps/s (E at 93 steps/mm).
    let times = on_time(&["G1 X50 Y50 E43.0108 F21213.2"], &[0, 1, 3], 4000);
    let accel = fitted_accel_mm_s2(&times[20..1150], 1.0 / 80.0);
    // Along X: the path's 3000 mm/s² times cos 45°.
    let want = 3000.0 / 2f64.sqrt();
    assert!((accel / want - 1.0).abs() <= 0.01, "X accelerated at {accel:.0} mm/s², planned {want:.0}");
}
