//! Heating on the emulated board: the firmware's PID on the heater MOSFET against the project's
//! thermal plant, read back through the thermistor divider on the ADC.

use gweave_board::Wiring;
use gweave_sim::SensorFault;

#[test]
fn m109_s210_reaches_its_target_then_holds_within_a_degree() {
    let mut board = crate::common::booted(Wiring::default());
    board.send_line("M109 S210");
    let mut peak_c = f64::MIN;
    let mut reached_s = None;
    while reached_s.is_none() {
        board.run_for(0.1).unwrap();
        peak_c = peak_c.max(board.plant(0).heater.sensor_c());
        if board.lines().iter().any(|l| l == "ok") {
            reached_s = Some(board.now_s());
        }
        assert!(board.now_s() < 300.0, "M109 still waiting at {} C", board.plant(0).heater.sensor_c());
    }
    // Hold for half a minute, from 10 s after M109 returned (Marlin's TEMP_RESIDENCY_TIME: the
    // time it waits itself before calling the target reached).
    let mut low_c = f64::MAX;
    let settled_s = board.now_s() + 10.0;
    while board.now_s() < settled_s + 30.0 {
        board.run_for(0.1).unwrap();
        let t = board.plant(0).heater.sensor_c();
        peak_c = peak_c.max(t);
        if board.now_s() >= settled_s {
            low_c = low_c.min(t);
        }
    }
    assert!(peak_c <= 213.0, "overshoot to {peak_c} C");
    assert!(low_c >= 209.0 && peak_c <= 213.0, "held between {low_c} and {peak_c} C");
    assert!((board.plant(0).heater.sensor_c() - 210.0).abs() <= 1.0);
}

#[test]
fn an_open_thermistor_halts_with_the_heaters_off() {
    let mut board = crate::common::booted(Wiring::default());
    assert_eq!(board.command("M104 S200", 1.0).unwrap().last().unwrap(), "ok");
    board.run_for(10.0).unwrap();
    assert!(board.plant(0).heater.last_power_w() > 0.0, "heating before the fault");
    board.shield_mut().fail_thermistor(0, SensorFault::Open);
    // An open thermistor reads full scale: the coldest the table knows, below MINTEMP.
    let lines = board.run_until_line(|l| l.contains("kill() called"), 5.0).unwrap();
    assert!(lines.iter().any(|l| l.starts_with("Error:") && l.contains("MINTEMP")), "{lines:?}");
    board.run_for(1.0).unwrap();
    for i in 0..3 {
        assert_eq!(board.plant(i).heater.last_power_w(), 0.0, "heater {i} still on");
    }
    // Halted, and still halted after the watchdog's timeout (1 s): a move is refused.
    board.run_for(2.0).unwrap();
    let reply = board.command("G1 X10 F3000", 1.0).unwrap();
    assert_eq!(reply, ["Error:Printer halted. kill() called!", "ok"]);
    board.run_for(1.0).unwrap();
    assert_eq!(board.net_steps(), [0; 7]);
}

#[test]
fn m190_s60_heats_the_bed_then_holds_it() {
    let mut board = crate::common::booted(Wiring::default());
    // A bed still warm from the last print (45 °C): the same path through D8 and A14 as from
    // cold, in a third of the board time.
    board.shield_mut().plants[1].heater.set_temperature(45.0);
    board.send_line("M190 S60");
    let mut peak_c = f64::MIN;
    loop {
        board.run_for(0.1).unwrap();
        peak_c = peak_c.max(board.plant(1).heater.sensor_c());
        if board.lines().iter().any(|l| l == "ok") {
            break;
        }
        assert!(board.now_s() < 200.0, "M190 still waiting at {} C", board.plant(1).heater.sensor_c());
    }
    let (mut low_c, settled_s) = (f64::MAX, board.now_s() + 10.0);
    while board.now_s() < settled_s + 30.0 {
        board.run_for(0.1).unwrap();
        let t = board.plant(1).heater.sensor_c();
        peak_c = peak_c.max(t);
        if board.now_s() >= settled_s {
            low_c = low_c.min(t);
        }
    }
    assert!(peak_c <= 63.0, "overshoot to {peak_c} C");
    assert!(low_c >= 59.0 && peak_c <= 61.0, "held between {low_c} and {peak_c} C");
}

/// RAMPS "EEB": `M104 T1` heats the second hotend through D9, read back on TEMP_1 (A15), and
/// `M105` reports both hotends as Marlin does with two (`T0:` `T1:`, `@0:` `@1:`); the first
/// hotend stays cold.
#[test]
fn m104_t1_heats_the_second_hotend_on_an_eeb_board() {
    let mut board = crate::common::eeb_board(Wiring::default());
    assert_eq!(board.command("M104 T1 S200", 1.0).unwrap(), ["ok"]);
    board.run_for(20.0).unwrap();
    let t1_c = board.plant(2).heater.sensor_c();
    assert!(t1_c > 60.0, "hotend 1 at {t1_c} C after 20 s");
    assert!((board.plant(0).heater.sensor_c() - 25.0).abs() < 1.0, "hotend 0 heated");
    let report = board.command("M105", 1.0).unwrap();
    let r = &report[0];
    assert!(r.starts_with("ok T:") && r.contains(" /200.00 @:") && r.contains(" @1:"), "{r}");
    assert!((crate::common::field(r, "T0:") - 25.0).abs() <= 1.0, "{r}");
    assert!((crate::common::field(r, "T1:") - t1_c).abs() <= 2.0, "{r}");
    assert!(crate::common::field(r, "@1:") > 0.0 && crate::common::field(r, "@0:") == 0.0, "{r}");
}

/// The thermal protection watches each hotend: an open thermistor on hotend 1 while it heats
/// halts the EEB board with Marlin's words for heater 1, every heater off.
#[test]
fn an_open_thermistor_on_the_second_hotend_halts_the_eeb_board() {
    let mut board = crate::common::eeb_board(Wiring::default());
    assert_eq!(board.command("M104 T1 S200", 1.0).unwrap(), ["ok"]);
    board.run_for(5.0).unwrap();
    assert!(board.plant(2).heater.last_power_w() > 0.0, "hotend 1 heating before the fault");
    board.shield_mut().fail_thermistor(2, SensorFault::Open);
    let lines = board.run_until_line(|l| l.contains("kill() called"), 5.0).unwrap();
    assert!(lines.iter().any(|l| l == "Error:MINTEMP triggered, system stopped! Heater_ID: 1"), "{lines:?}");
    board.run_for(1.0).unwrap();
    for i in 0..3 {
        assert_eq!(board.plant(i).heater.last_power_w(), 0.0, "heater {i} still on");
    }
}
