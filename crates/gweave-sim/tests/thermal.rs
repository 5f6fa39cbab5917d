//! The thermal facade end to end: heat-ups, every protection on a faulty
//! plant, M105 text, M109/M190 waits, cold extrusion, M303 and the series.

use gweave_sim::AutotuneConfig;
use gweave_sim::PidGains;
use gweave_sim::SensorFault;
use gweave_sim::{FaultKind, ThermalFault, KILL_LINE};
use gweave_sim::{HeaterConfig, HeaterFault, HeaterId};
use gweave_sim::{Thermal, ThermalConfig, ThermalError, WaitMode, WaitStatus, COLD_EXTRUSION_LINE};
use proptest::prelude::*;

const T0: HeaterId = HeaterId::Hotend(0);
const BED: HeaterId = HeaterId::Bed;

fn machine() -> Thermal {
    Thermal::new(ThermalConfig::default()).unwrap()
}

/// Step in 0.5 s increments until the wait ends; returns the elapsed time.
fn wait_for(th: &mut Thermal, id: HeaterId, mode: WaitMode, limit_s: f64) -> f64 {
    let start_s = th.now_s();
    let mut wait = th.begin_wait(id, mode).unwrap();
    loop {
        match th.poll_wait(&mut wait) {
            WaitStatus::Reached => return th.now_s() - start_s,
            WaitStatus::Halted => panic!("halted: {:?}", th.halted()),
            WaitStatus::Waiting => {}
        }
        assert!(th.now_s() - start_s < limit_s, "wait on {id:?} timed out");
        assert_eq!(th.step(0.5), None);
    }
}

/// Step until a fault; returns it.
fn run_until_fault(th: &mut Thermal, limit_s: f64) -> ThermalFault {
    let start_s = th.now_s();
    while th.now_s() - start_s < limit_s {
        if let Some(f) = th.step(0.5) {
            return f;
        }
    }
    panic!("no fault within {limit_s} s");
}

/// Worst |reading - target| over `span_s` of stepping.
fn worst_error(th: &mut Thermal, id: HeaterId, span_s: f64) -> f64 {
    let mut worst: f64 = 0.0;
    let end_s = th.now_s() + span_s;
    while th.now_s() < end_s {
        assert_eq!(th.step(0.1), None);
        worst = worst.max((th.temperature(id).unwrap() - th.target(id).unwrap()).abs());
    }
    worst
}

#[test]
fn healthy_heat_up_reaches_targets_without_faults() {
    let mut th = machine();
    th.set_target(BED, 60.0).unwrap();
    th.set_target(T0, 210.0).unwrap();
    let hotend_s = wait_for(&mut th, T0, WaitMode::HeatOnly, 300.0);
    // ~80 s to the window plus 10 s residency.
    assert!((80.0..110.0).contains(&hotend_s), "{hotend_s}");
    let bed_s = wait_for(&mut th, BED, WaitMode::HeatOnly, 600.0);
    assert!(hotend_s + bed_s < 160.0, "{}", hotend_s + bed_s);
    // Ten minutes of holding: PID within 1 C, bang-bang within 1 C, no fault.
    assert!(worst_error(&mut th, T0, 300.0) < 1.0);
    assert!(worst_error(&mut th, BED, 300.0) < 1.0);
    assert_eq!(th.halted(), None);
}

#[test]
fn hot_bed_heat_up_to_100_does_not_trip_the_watch() {
    let mut th = machine();
    th.set_target(BED, 100.0).unwrap();
    let s = wait_for(&mut th, BED, WaitMode::HeatOnly, 1200.0);
    // -400 ln(1 - 75/133.3) = 331 s plus lags and residency.
    assert!((330.0..360.0).contains(&s), "{s}");
}

#[test]
fn cartridge_off_from_cold_is_heating_failed() {
    let mut th = machine();
    th.heater_mut(T0).unwrap().inject(HeaterFault::CartridgeDisconnected);
    th.set_target(T0, 210.0).unwrap();
    let f = run_until_fault(&mut th, 100.0);
    assert_eq!(f.kind, FaultKind::HeatingFailed);
    // The watch period is 20 s; the first sample at or after it trips.
    assert!((20.0..=20.1).contains(&f.at_s), "{}", f.at_s);
    assert_eq!(
        f.lines(),
        ["Error:Heating failed, system stopped! Heater_ID: 0".to_owned(), KILL_LINE.to_owned()]
    );
    // Halted: heaters off, no new targets, waits end.
    assert_eq!(th.power(T0).unwrap(), 0);
    assert_eq!(th.target(T0).unwrap(), 0.0);
    assert!(matches!(th.set_target(T0, 200.0), Err(ThermalError::Halted(_))));
    let mut w = th.begin_wait(T0, WaitMode::Both).unwrap();
    assert_eq!(th.poll_wait(&mut w), WaitStatus::Halted);
    // The fault is reported once.
    assert_eq!(th.step(1.0), None);
}

#[test]
fn bed_cartridge_off_is_heating_failed_after_60_s() {
    let mut th = machine();
    th.heater_mut(BED).unwrap().inject(HeaterFault::CartridgeDisconnected);
    th.set_target(BED, 60.0).unwrap();
    let f = run_until_fault(&mut th, 200.0);
    assert!((60.0..=60.1).contains(&f.at_s), "{}", f.at_s);
    assert_eq!(f.error_line(), "Error:Heating failed, system stopped! Heater_ID: bed");
}

#[test]
fn cartridge_lost_at_temperature_is_thermal_runaway() {
    let mut th = machine();
    th.set_target(T0, 210.0).unwrap();
    wait_for(&mut th, T0, WaitMode::HeatOnly, 300.0);
    th.step(60.0);
    th.heater_mut(T0).unwrap().inject(HeaterFault::CartridgeDisconnected);
    let lost_s = th.now_s();
    // Find when the reading drops below 210 - 4 C.
    let mut below_s = None;
    let fault = loop {
        if let Some(f) = th.step(0.1) {
            break f;
        }
        if below_s.is_none() && th.temperature(T0).unwrap() < 206.0 {
            below_s = Some(th.now_s());
        }
        assert!(th.now_s() - lost_s < 300.0);
    };
    let below_s = below_s.unwrap();
    assert_eq!(fault.kind, FaultKind::ThermalRunaway);
    // 40 s after the last sample within the hysteresis.
    let after_s = fault.at_s - below_s;
    assert!((39.8..=40.2).contains(&after_s), "{after_s}");
    assert_eq!(fault.error_line(), "Error:Thermal Runaway, system stopped! Heater_ID: 0");
}

#[test]
fn bed_lost_at_temperature_is_thermal_runaway() {
    let mut th = machine();
    th.set_target(BED, 60.0).unwrap();
    wait_for(&mut th, BED, WaitMode::HeatOnly, 600.0);
    th.heater_mut(BED).unwrap().inject(HeaterFault::CartridgeDisconnected);
    let f = run_until_fault(&mut th, 600.0);
    assert_eq!(f.error_line(), "Error:Thermal Runaway, system stopped! Heater_ID: bed");
}

#[test]
fn sensor_faults_trip_min_and_max_temp() {
    let mut th = machine();
    th.heater_mut(T0).unwrap().inject(HeaterFault::Sensor(SensorFault::Open));
    let f = run_until_fault(&mut th, 1.0);
    assert_eq!(f.error_line(), "Error:MINTEMP triggered, system stopped! Heater_ID: 0");

    let mut th = machine();
    th.heater_mut(BED).unwrap().inject(HeaterFault::Sensor(SensorFault::Shorted));
    let f = run_until_fault(&mut th, 1.0);
    assert_eq!(f.error_line(), "Error:MAXTEMP triggered, system stopped! Heater_ID: bed");
}

#[test]
fn m105_formats_like_marlin() {
    let mut th = machine();
    th.step(0.1);
    assert_eq!(th.m105_report(), "T:25.00 /0.00 B:25.00 /0.00 @:0 B@:0");
    th.set_target(T0, 210.0).unwrap();
    th.set_target(BED, 60.0).unwrap();
    th.step(0.1);
    assert_eq!(th.m105_report(), "T:25.00 /210.00 B:25.00 /60.00 @:127 B@:127");
    wait_for(&mut th, T0, WaitMode::HeatOnly, 300.0);
    th.step(300.0);
    // Holding 210 C takes 18.5 W of 40 W: @ ~ 0.46 * 127 = 59.
    let report = th.m105_report();
    let power: u8 = report.split(" @:").nth(1).and_then(|s| s.split(' ').next()).unwrap().parse().unwrap();
    assert!((50..=68).contains(&power), "{report}");
    assert!(report.starts_with("T:2"), "{report}");

    let two = ThermalConfig { hotends: vec![HeaterConfig::hotend_40w(); 2], ..ThermalConfig::default() };
    let mut th = Thermal::new(two).unwrap();
    th.set_target(HeaterId::Hotend(1), 200.0).unwrap();
    th.set_active_extruder(1).unwrap();
    th.step(0.1);
    assert_eq!(
        th.m105_report(),
        "T:25.00 /200.00 B:25.00 /0.00 T0:25.00 /0.00 T1:25.00 /200.00 @:127 B@:0 @0:0 @1:127"
    );
    // M109 T0 while T1 is active: Marlin's wait line shows the hotend waited for.
    th.set_target(T0, 100.0).unwrap();
    let wait = th.begin_wait(T0, WaitMode::HeatOnly).unwrap();
    th.step(0.1);
    assert_eq!(
        th.wait_status_line(&wait),
        " T:25.00 /100.00 B:25.00 /0.00 T0:25.00 /100.00 T1:25.00 /200.00 @:127 B@:0 @0:127 @1:127 W:?"
    );
    let no_bed = ThermalConfig { bed: None, ..ThermalConfig::default() };
    let th = Thermal::new(no_bed).unwrap();
    assert_eq!(th.m105_report(), "T:25.00 /0.00 @:0");
    assert!(matches!(th.target(BED), Err(ThermalError::UnknownHeater(_))));
}

#[test]
fn m109_s_does_not_wait_for_cooling_but_r_does() {
    let mut th = machine();
    th.set_target(T0, 210.0).unwrap();
    wait_for(&mut th, T0, WaitMode::HeatOnly, 300.0);
    th.set_target(T0, 180.0).unwrap();
    let mut s = th.begin_wait(T0, WaitMode::HeatOnly).unwrap();
    assert_eq!(th.poll_wait(&mut s), WaitStatus::Reached);
    let r_s = wait_for(&mut th, T0, WaitMode::Both, 600.0);
    // Passive cooling 210 -> 181 C takes ~20 s (tau 120 s), then residency.
    assert!(r_s > 25.0, "{r_s}");
    assert!((th.temperature(T0).unwrap() - 180.0).abs() < 3.0);
}

#[test]
fn residency_starts_a_third_late_when_already_at_target() {
    let mut th = machine();
    th.set_target(T0, 210.0).unwrap();
    wait_for(&mut th, T0, WaitMode::HeatOnly, 300.0);
    th.step(120.0);
    // Already within the window at the first poll: 10 s + 10/3 s.
    let s = wait_for(&mut th, T0, WaitMode::Both, 100.0);
    assert!((13.3..14.0).contains(&s), "{s}");
}

#[test]
fn cold_extrusion_is_prevented_below_170() {
    let mut th = machine();
    let err = th.check_extrude(0).unwrap_err();
    assert_eq!(err.min_c, 170.0);
    assert_eq!(COLD_EXTRUSION_LINE, "echo: cold extrusion prevented");
    th.set_target(T0, 210.0).unwrap();
    wait_for(&mut th, T0, WaitMode::HeatOnly, 300.0);
    assert_eq!(th.check_extrude(0), Ok(()));
    let mut cold = machine();
    cold.set_extrude_min(None);
    assert_eq!(cold.check_extrude(0), Ok(()));
}

#[test]
fn targets_are_capped_below_maxtemp() {
    let mut th = machine();
    th.set_target(T0, 300.0).unwrap();
    assert_eq!(th.target(T0).unwrap(), 260.0);
    th.set_target(BED, 200.0).unwrap();
    assert_eq!(th.target(BED).unwrap(), 140.0);
    th.set_target(T0, -5.0).unwrap();
    assert_eq!(th.target(T0).unwrap(), 0.0);
}

#[test]
fn is_at_target_checks_the_window() {
    let mut th = machine();
    th.set_target(T0, 210.0).unwrap();
    assert!(!th.is_at_target(T0, WaitMode::HeatOnly).unwrap());
    wait_for(&mut th, T0, WaitMode::HeatOnly, 300.0);
    // The residency ends the wait within TEMP_HYSTERESIS; a minute later the PID holds the
    // window.
    assert!((th.temperature(T0).unwrap() - 210.0).abs() < 3.0);
    assert_eq!(th.step(60.0), None);
    assert!(th.is_at_target(T0, WaitMode::Both).unwrap());
    th.set_target(T0, 150.0).unwrap();
    assert!(th.is_at_target(T0, WaitMode::HeatOnly).unwrap());
    assert!(!th.is_at_target(T0, WaitMode::Both).unwrap());
}

#[test]
fn autotune_apply_needs_a_pid_heater() {
    let mut th = machine();
    assert!(matches!(
        th.start_autotune(BED, AutotuneConfig::new(60.0), true),
        Err(ThermalError::NotPid(BED))
    ));
    assert!(th.start_autotune(BED, AutotuneConfig::new(60.0), false).is_ok());
}

#[test]
fn m303_through_the_facade_finds_and_applies_gains() {
    let mut th = machine();
    th.set_pid_gains(T0, PidGains::MARLIN_HOTEND).unwrap();
    th.start_autotune(T0, AutotuneConfig::new(210.0), true).unwrap();
    let mut lines = Vec::new();
    while th.autotune_running() {
        assert_eq!(th.step(1.0), None);
        lines.extend(th.take_autotune_lines());
        assert!(th.now_s() < 1000.0);
    }
    let gains = th.take_autotune_result().unwrap().unwrap();
    assert_eq!(lines[0], "PID Autotune start");
    assert_eq!(lines.last().unwrap(), &format!("#define DEFAULT_Kd {:.2}", gains.kd));
    // Same plant, same sampling: the documented default gains.
    let d = PidGains::DEFAULT_HOTEND_40W;
    assert!((gains.kp - d.kp).abs() < 0.005, "{gains:?}");
    assert_eq!(th.pid_gains(T0).unwrap(), gains);
    assert_eq!(th.power(T0).unwrap(), 0);
    // The bed runs bang-bang: no PID gains to set.
    assert!(matches!(th.pid_gains(BED), Err(ThermalError::NotPid(_))));
}

#[test]
fn series_records_every_period_and_decimates() {
    let mut th = machine();
    th.set_target(T0, 210.0).unwrap();
    th.step(100.0);
    let hot: Vec<_> = th.series().of(T0).collect();
    // Samples at 0, 1, ..., 100 s.
    assert_eq!(hot.len(), 101);
    assert_eq!(hot[10].t_s, 10.0);
    assert!(hot[10].temp_c > 25.0 && hot[10].target_c == 210.0 && hot[10].power == 127);
    assert!(hot.windows(2).all(|w| w[1].t_s > w[0].t_s));

    let small = ThermalConfig { record_max_samples: 20, ..ThermalConfig::default() };
    let mut th = Thermal::new(small).unwrap();
    th.step(100.0);
    // Two heaters: at most 10 times kept, the period doubled until it fits.
    let times: Vec<f64> = th.series().of(T0).map(|s| s.t_s).collect();
    assert!(times.len() <= 10, "{times:?}");
    assert_eq!(th.series().period_s(), 16.0);
    assert_eq!(times[0], 0.0);
    assert!(*times.last().unwrap() >= 80.0, "{times:?}");
    // Evenly spaced at the final period.
    assert!(times.windows(2).all(|w| w[1] - w[0] == 16.0), "{times:?}");
}

#[test]
fn config_from_toml_rejects_unknown_keys() {
    let cfg: ThermalConfig = toml::from_str(
        "sample_period_s = 0.2\n[bed_control]\nkind = \"pid\"\ngains = { kp = 300.0, ki = 40.0, kd = 700.0 }\n",
    )
    .unwrap();
    assert_eq!(cfg.sample_period_s, 0.2);
    let th = Thermal::new(cfg).unwrap();
    assert_eq!(th.pid_gains(BED).unwrap().kp, 300.0);
    assert!(toml::from_str::<ThermalConfig>("sample_rate = 3\n").is_err());
    let bad = ThermalConfig { hotends: vec![], ..ThermalConfig::default() };
    let err = Thermal::new(bad).unwrap_err().to_string();
    assert_eq!(err, "[thermal] hotends (count) = 0 is out of range: 1 to 8 hotends");
}

proptest! {
    /// Any sequence of targets, fan and step sizes: no panic, every reading
    /// stays between ambient and the full-power equilibrium (25 + 40/0.1 C;
    /// 25 + 200/1.5 C for the bed), and a fault switches everything off.
    /// (Faults can be legitimate here: re-targeting a 40 W hotend to 255 C
    /// with the fan on, just after it was off, leaves ~12 W of headroom and
    /// a reading that still falls behind the block, so the +2 C / 20 s
    /// watch trips, as it does on real printers.)
    #[test]
    fn facade_stays_physical(
        ops in proptest::collection::vec(
            (0.0f64..300.0, 0.0f64..130.0, 0.0f64..1.0, 0.01f64..30.0),
            1..30,
        )
    ) {
        let mut th = machine();
        for (hot_c, bed_c, fan, dt_s) in ops {
            if th.halted().is_none() {
                th.set_target(T0, hot_c).unwrap();
                th.set_target(BED, bed_c).unwrap();
            }
            th.set_fan(fan);
            if th.step(dt_s).is_some() {
                prop_assert_eq!(th.power(T0).unwrap(), 0);
                prop_assert_eq!(th.power(BED).unwrap(), 0);
                prop_assert_eq!(th.target(T0).unwrap(), 0.0);
            }
            let t = th.temperature(T0).unwrap();
            let b = th.temperature(BED).unwrap();
            prop_assert!((24.9..=425.0).contains(&t), "{}", t);
            prop_assert!((24.9..=158.4).contains(&b), "{}", b);
            prop_assert!(th.power(T0).unwrap() <= 127);
        }
    }
}

/// The plants are integrated from sample to sample whatever the caller's steps: a print's
/// moves of a few milliseconds, or half seconds, give the same samples, temperatures and
/// powers, with a fan change between samples.
#[test]
fn move_sized_steps_give_the_same_history_as_sample_steps() {
    let run = |steps: &[f64]| {
        let mut th = machine();
        th.set_target(T0, 210.0).unwrap();
        th.set_target(BED, 60.0).unwrap();
        let mut fan_on = false;
        let mut k = 0;
        while th.now_s() < 300.0 - 1e-6 {
            if !fan_on && th.now_s() >= 150.0 - 1e-6 {
                th.set_fan(0.7);
                fan_on = true;
            }
            assert_eq!(th.step(steps[k % steps.len()]), None);
            k += 1;
        }
        let history: Vec<(i64, u8, i64)> = th
            .series()
            .samples()
            .map(|s| ((s.t_s * 1e3).round() as i64, s.power, (s.temp_c * 1e6).round() as i64))
            .collect();
        (history, th.heater_mut(T0).unwrap().block_c())
    };
    let (coarse, coarse_c) = run(&[0.5]);
    let (fine, fine_c) = run(&[0.02, 0.03, 0.05, 0.013, 0.087]);
    // One record a second for each heater, from 0 s to 300 s.
    assert_eq!(coarse.len(), 2 * 301);
    assert_eq!(coarse, fine);
    assert!((coarse_c - fine_c).abs() < 1e-9, "{coarse_c} {fine_c}");
}

/// A step of 1e300 s (a dwell of `G4 S1e300`, a move across a bed of 1e308 mm) used to run
/// 1e301 firmware loops: it now runs `MAX_SAMPLES_PER_STEP` of them and integrates the rest.
#[test]
fn a_step_of_1e300_s_ends() {
    let mut th = Thermal::new(ThermalConfig::default()).unwrap();
    th.set_target(T0, 200.0).unwrap();
    let start = std::time::Instant::now();
    assert!(th.step(1e300).is_none());
    assert_eq!(th.now_s(), 1e300);
    assert!(start.elapsed().as_secs() < 20, "{:?}", start.elapsed());
    let t = th.temperature(T0).unwrap();
    assert!((195.0..205.0).contains(&t), "settled at the target: {t}");
    // A step to an infinite clock changes nothing.
    assert!(th.step(f64::INFINITY).is_none());
    assert_eq!(th.now_s(), 1e300);
}
