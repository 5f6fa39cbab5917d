//! The heaters at rest (issue B5: `sim` ran every firmware loop of every simulated second, 0.27 s
//! of CPU a simulated day, so 200 lines of `G4 S86400` took 54 s): while every heater is off and
//! its plant still to the bit, the loops are passed over, and every temperature, power, record
//! and plant ends as running each loop in full leaves it.

use gweave_sim::{HeaterId, Thermal, ThermalConfig};

const T0: HeaterId = HeaterId::Hotend(0);
const BED: HeaterId = HeaterId::Bed;

/// What a script does to the heaters.
#[derive(Clone, Copy)]
enum Op {
    /// Let this many days pass, a day a step, whatever the run's steps.
    Days(u32),
    /// Let this long pass, s, in the run's steps.
    Hold(f64),
    Target(HeaterId, f64),
    Fan(f64),
}

/// Runs `script` on the default heaters (a PID hotend and a bang-bang bed), each hold in steps
/// of `step_s` at most.
fn run(script: &[Op], step_s: f64) -> Thermal {
    let mut th = Thermal::new(ThermalConfig::default()).unwrap();
    for op in script {
        match *op {
            Op::Days(days) => {
                for _ in 0..days {
                    assert_eq!(th.step(86_400.0), None);
                }
            }
            Op::Hold(t_s) => {
                let end_s = th.now_s() + t_s;
                while th.now_s() < end_s {
                    assert_eq!(th.step(step_s.min(end_s - th.now_s())), None);
                }
            }
            Op::Target(id, c) => th.set_target(id, c).unwrap(),
            Op::Fan(f) => th.set_fan(f),
        }
    }
    th
}

/// Everything a run of the heaters leaves that a report or a later step reads.
fn assert_same_heaters(a: &Thermal, b: &Thermal) {
    assert_eq!(a.now_s().to_bits(), b.now_s().to_bits());
    assert_eq!(a.series(), b.series());
    for id in [T0, BED] {
        assert_eq!(a.temperature(id).unwrap().to_bits(), b.temperature(id).unwrap().to_bits(), "{id:?}");
        assert_eq!(a.power(id).unwrap(), b.power(id).unwrap(), "{id:?}");
        assert_eq!(a.heater(id).unwrap(), b.heater(id).unwrap(), "{id:?}");
    }
}

/// A cold hour, a heat-up, five and a half hours of cooling (the plants come to rest above
/// ambient, within rounding of it), an hour with the fan on, and a second heat-up: in steps of
/// a whole phase (the loops at rest passed over) and of 0.05 s (no step holds two loops, so each
/// runs in full), the heaters end alike to the bit, the controllers and the step responses
/// they keep included (the second heat-up reads both).
#[test]
fn resting_heaters_end_as_every_loop_run_in_full() {
    let script = [
        Op::Hold(3600.0),
        Op::Target(T0, 200.0),
        Op::Target(BED, 60.0),
        Op::Hold(600.0),
        Op::Target(T0, 0.0),
        Op::Target(BED, 0.0),
        Op::Hold(20_000.0),
        Op::Fan(1.0),
        Op::Hold(3600.0),
        Op::Target(T0, 150.0),
        Op::Hold(300.0),
    ];
    let passed = run(&script, 1e9);
    let ran = run(&script, 0.05);
    assert_same_heaters(&passed, &ran);
    let loops = (28_100.0 / 0.1) as u64;
    assert!(ran.loops_run() > loops, "{}", ran.loops_run());
    // The cold hour, and the cooled plants for most of the rest: all but the heat-ups and the
    // cooling's first hours.
    assert!(passed.loops_run() < loops / 2, "{} of {loops}", passed.loops_run());
}

/// Past a few days of clock the periods between the loops' instants differ by more than the
/// 1e-9 within which a plant reuses its step response, so the response a plant keeps changes
/// during a rest: passing over an hour of loops there keeps the one running them would, which
/// the heat-up after it reuses.
#[test]
fn resting_heaters_at_a_clock_of_ten_days_end_as_every_loop_run_in_full() {
    let script =
        [Op::Days(10), Op::Hold(3600.0), Op::Target(T0, 200.0), Op::Target(BED, 60.0), Op::Hold(60.0)];
    let passed = run(&script, 1e9);
    let ran = run(&script, 0.1);
    assert_same_heaters(&passed, &ran);
}

#[test]
fn a_day_of_dwell_with_every_heater_off_runs_three_firmware_loops() {
    let mut th = Thermal::new(ThermalConfig::default()).unwrap();
    assert_eq!(th.step(86_400.0), None);
    // The first two (the plants are known still once a step has left them so) and the last,
    // which stamps the controllers with its time; 864 001 before.
    assert_eq!(th.loops_run(), 3);
    assert_eq!(th.now_s(), 86_400.0);
    // One record a second for two heaters, halved whenever past 100 000 samples.
    assert_eq!(th.series().period_s(), 2.0);
    assert_eq!(th.temperature(T0).unwrap(), 25.0);
    // A heater on is simulated loop by loop: what a file's time limit bounds (sim.md).
    th.set_target(T0, 200.0).unwrap();
    assert_eq!(th.step(3600.0), None);
    assert_eq!(th.loops_run(), 3 + 36_000);
}
