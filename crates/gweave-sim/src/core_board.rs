//! `[firmware] kind = "gweave"`: the virtual board runs gweave's own controller core
//! (`gweave-controller`, the firmware flashed on the ATmega2560 + RAMPS board), not the Marlin
//! or Klipper model of the rest of this crate. So what the firmware does with a file, the
//! virtual printer does too: the same line reader, parser, planner, stepper and heaters, on the
//! core's twin (`gweave_controller::twin`: a simulated clock, the step interrupt called when its
//! timer says, endstops at the axes' minimum), with this crate's thermal plants behind the
//! thermistor inputs.
//!
//! What the profile gives the core ([`core_settings`]): steps per unit, the axes' speed and
//! acceleration limits, the three accelerations, the junction deviation, the bed's size (the
//! homing travel), the homing speeds, bumps and order, one or two hotends, the hotend PID gains
//! and MAXTEMPs. What the core cannot take is refused by name rather than ignored: Klipper or
//! constant-speed corners, classic jerk, endstops at the maximum, a PID-controlled bed, a
//! thermistor other than Marlin's type 1, inkjet hardware, a mixing hotend of more inputs than
//! the core drives or whose inputs' steps per mm differ from E's, a mixing hotend and a rotary
//! axis together (A turns the E1 socket's motor).
//!
//! A rotary axis (`[rotary]`, `motion.steps.a_per_deg`) runs on the core's axis A
//! (docs/firmware.md, "Rotary"), with its feed convention (`[rotary] feed`); the report gives
//! its step pulses, the Marlin model's `steps.axes[4]`.
//!
//! A mixing hotend (`mixing_inputs`, 2 to 4) runs on the core's mixer (docs/firmware.md,
//! "Mixing"): the report gives each input's step pulses, the Marlin model's `steps.mixing`.
//!
//! Two hotends (two `[[thermal.hotends]]`) are the core's RAMPS "EEB" board: `T1` drives the
//! second extruder on E1's socket, and the report gives each extruder's step pulses, the
//! Marlin model's `steps.tools`.

use std::cell::Cell;

use gweave_controller::limits::MIX_INPUTS;
use gweave_controller::rotary::{Rotary, RotaryFeed, A_MOTOR};
use gweave_controller::twin::{Memory, OwnedTwin, Plant, Twin, TwinError};
use gweave_controller::{Settings, StepQueue, E, HEATERS};
use serde::Serialize;

use crate::interp::Outcome;
use crate::link::serial::Device;
use crate::motion::limits::CornerMode;
use crate::profile::{EndstopSide, MachineProfile};
use crate::thermal::control::ControlConfig;
use crate::thermal::heater::{Heater, HeaterConfig};
use crate::thermal::thermistor::BetaThermistor;

/// A profile the core cannot run.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("[firmware] kind = \"gweave\": the controller core has no {0}")]
pub struct Unsupported(pub &'static str);

/// The core's settings for a machine profile.
pub(crate) fn core_settings(p: &MachineProfile) -> Result<Settings, Unsupported> {
    let m = &p.motion;
    let junction_deviation_mm = match &m.corners {
        CornerMode::Marlin { jerk_mm_s: Some(_), .. } => {
            return Err(Unsupported("classic jerk (motion.corners)"))
        }
        CornerMode::Marlin { junction_deviation_mm, .. } => junction_deviation_mm.unwrap_or(0.013),
        _ => return Err(Unsupported("corner mode but Marlin's junction deviation (motion.corners)")),
    };
    let t = &p.thermal;
    let gains = match &t.hotend_control {
        ControlConfig::Pid(pid) => pid.gains,
        ControlConfig::BangBang(_) => return Err(Unsupported("bang-bang hotend (thermal.hotend_control)")),
    };
    if matches!(t.bed_control, ControlConfig::Pid(_)) {
        return Err(Unsupported("PID bed: it switches the bed on and off (thermal.bed_control)"));
    }
    if t.thermistor != BetaThermistor::default() || t.thermistor_table.is_some() {
        return Err(Unsupported("thermistor but Marlin's type 1 (thermal.thermistor)"));
    }
    if [p.endstops.x, p.endstops.y, p.endstops.z].contains(&EndstopSide::Max) {
        return Err(Unsupported("endstop at an axis maximum (endstops)"));
    }
    if p.inkjet.is_some() || t.hotends.len() > 2 {
        return Err(Unsupported("inkjet or third hotend"));
    }
    if p.single_nozzle_tools > 0 {
        return Err(Unsupported("several tools feeding one nozzle (single_nozzle_tools)"));
    }
    if p.rotary.is_some() && p.mixing_inputs > 0 {
        return Err(Unsupported("rotary axis beside a mixing hotend: both need the E1 socket"));
    }
    if p.rotary.is_some() && t.hotends.len() == 2 {
        return Err(Unsupported("rotary axis beside a second hotend: both need the E1 socket"));
    }
    if p.mixing_inputs > 0 && t.hotends.len() == 2 {
        return Err(Unsupported("second hotend beside a mixing hotend: both need the E1 socket"));
    }
    let rotary = match (&p.rotary, m.steps.a_per_deg) {
        (Some(r), Some(steps_per_deg)) => Rotary {
            steps_per_deg: steps_per_deg as f32,
            max_feed_deg_s: m.max_feed_mm_s.a as f32,
            max_accel_deg_s2: m.max_accel_mm_s2.a as f32,
            feed: match r.feed {
                crate::profile::RotaryFeed::Nist => RotaryFeed::Nist,
                crate::profile::RotaryFeed::Combined => RotaryFeed::Combined,
            },
        },
        _ => Rotary::NONE,
    };
    if p.mixing_inputs > MIX_INPUTS {
        return Err(Unsupported("mixing hotend of more than 4 inputs (mixing_inputs)"));
    }
    if m.steps.mixing_e.iter().any(|&s| s != m.steps.e) {
        return Err(Unsupported("mixing input with its own steps per mm (motion.steps.mixing_e)"));
    }
    let axes = |v: [f64; 4]| v.map(|x| x as f32);
    // Axis indices; an index past Z (none given) homes nothing in that place.
    let order = p.homing.axes();
    let order: [u8; 3] = core::array::from_fn(|i| order.get(i).map_or(3, |&a| a as u8));
    let d = Settings::DEFAULT;
    Ok(Settings {
        steps_per_mm: axes([m.steps.x, m.steps.y, m.steps.z, m.steps.e]),
        max_feed_mm_s: axes([m.max_feed_mm_s.x, m.max_feed_mm_s.y, m.max_feed_mm_s.z, m.max_feed_mm_s.e]),
        max_accel_mm_s2: axes([
            m.max_accel_mm_s2.x,
            m.max_accel_mm_s2.y,
            m.max_accel_mm_s2.z,
            m.max_accel_mm_s2.e,
        ]),
        print_accel_mm_s2: m.accel.print_mm_s2 as f32,
        retract_accel_mm_s2: m.accel.retract_mm_s2 as f32,
        travel_accel_mm_s2: m.accel.travel_mm_s2 as f32,
        junction_deviation_mm: junction_deviation_mm as f32,
        travel_mm: axes([p.bed.x_mm, p.bed.y_mm, p.bed.z_mm, 0.0]),
        homing_feed_mm_s: axes([p.homing.feed_mm_s[0], p.homing.feed_mm_s[1], p.homing.feed_mm_s[2], 0.0]),
        homing_order: order,
        homing_bump_mm: axes([p.homing.bump_mm[0], p.homing.bump_mm[1], p.homing.bump_mm[2], 0.0]),
        hotends: t.hotends.len().max(1) as u8,
        // No sensor (0) where no heater is fitted, as the printer files say (the core reads
        // TEMP_1 only with two hotends either way).
        thermistor: [1, u8::from(t.hotends.len() >= 2), u8::from(t.bed.is_some())],
        extrude_min_c: t.extrude_min_c.unwrap_or(0.0) as f32,
        extrude_max_mm: p.firmware.extrude_max_mm as f32,
        hotend_pid: gweave_controller::settings::Pid {
            kp: gains.kp as f32,
            ki: gains.ki as f32,
            kd: gains.kd as f32,
        },
        max_temp_c: [
            t.hotend_protection.max_temp_c as f32,
            t.hotend_protection.max_temp_c as f32,
            t.bed_protection.max_temp_c as f32,
        ],
        mixing_inputs: p.mixing_inputs as u8,
        rotary,
        ..d
    })
}

/// The profile's heaters behind the core's thermistor inputs, read by a 10-bit ADC.
pub(crate) struct SimPlant {
    heaters: [Option<Heater>; HEATERS],
    sensor: BetaThermistor,
}

impl SimPlant {
    /// The plants of `p`'s hotends and bed at ambient temperature.
    pub(crate) fn new(p: &MachineProfile) -> Result<SimPlant, crate::thermal::heater::HeaterError> {
        let t = &p.thermal;
        let plant = |c: Option<&HeaterConfig>| c.map(|c| Heater::new(*c)).transpose();
        Ok(SimPlant {
            heaters: [plant(t.hotends.first())?, plant(t.hotends.get(1))?, plant(t.bed.as_ref())?],
            // The core reads single samples, not Marlin's sums of 16.
            sensor: BetaThermistor { oversample: 1, ..t.thermistor },
        })
    }
}

impl Plant for SimPlant {
    fn adc(&self) -> [u16; HEATERS] {
        let open = self.sensor.raw_max();
        self.heaters
            .each_ref()
            .map(|h| h.as_ref().map_or(open, |h| h.read_adc(&self.sensor)).min(1023) as u16)
    }

    fn advance(&mut self, duty: [u8; HEATERS], dt_s: f32) {
        for (h, duty) in self.heaters.iter_mut().zip(duty) {
            if let Some(h) = h {
                h.step(f64::from(duty) / 255.0, f64::from(dt_s));
            }
        }
    }
}

/// What a file did on the core.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CoreReport {
    /// The profile's name.
    pub machine: String,
    /// Lines sent (comments and blank lines included).
    pub lines: u64,
    /// The board's time at the end, s.
    pub time_s: f64,
    /// Where each motor ends, in steps: X, Y and Z from their endstops (the homed origin), E
    /// from power-on (`M114`'s `Count`, the Marlin model's end position).
    pub end_steps: [i64; 4],
    /// Step pulses of each input of a mixing hotend, E0 first, both directions counted (the
    /// Marlin model's `steps.mixing`); empty without one.
    pub mixing_steps: Vec<u64>,
    /// Step pulses of each extruder of a board with two hotends, E0 then E1 (`T1`), both
    /// directions counted (the Marlin model's `steps.tools`); empty with one.
    pub extruder_steps: Vec<u64>,
    /// Step pulses of X, Y, Z and E (E0), both directions counted (the Marlin model's
    /// `steps.axes[..4]`).
    pub axis_steps: [u64; 4],
    /// Step pulses of the rotary axis A, both directions counted (the Marlin model's
    /// `steps.axes[4]`); `None` without one.
    pub rotary_steps: Option<u64>,
    /// Whether the board halted (a thermal fault or `M112`).
    pub halted: bool,
    /// The board's `Error:` lines.
    pub errors: Vec<String>,
}

impl CoreReport {
    /// What the board `twin` of `machine` has done so far: its time, where its motors are and
    /// the step pulses each made, whether it halted (no line counted, no error read yet).
    fn of<P: gweave_controller::twin::Plant>(machine: &str, twin: &Twin<'_, P>) -> CoreReport {
        let settings = twin.controller.settings();
        // A mixing hotend's inputs, or a second extruder, are the motors after E0's.
        let motors_from_e = |n: usize| twin.pulses[E..E + n.min(MIX_INPUTS)].to_vec();
        CoreReport {
            machine: machine.to_owned(),
            lines: 0,
            time_s: twin.now_ms() as f64 / 1000.0,
            end_steps: twin.steps_from_home(),
            mixing_steps: motors_from_e(usize::from(settings.mixing_inputs)),
            extruder_steps: if settings.hotends == 2 { motors_from_e(2) } else { Vec::new() },
            axis_steps: core::array::from_fn(|a| twin.pulses[a]),
            rotary_steps: twin.controller.position_a().map(|_| twin.pulses[A_MOTOR]),
            halted: twin.controller.is_halted(),
            errors: Vec::new(),
        }
    }
}

/// One command waits at most this long for its `ok` (an hour of board time: a bed heating from
/// cold takes minutes).
const LINE_LIMIT_MS: u64 = 3_600_000;

/// Runs the lines `next_line` gives on the core, as a host streaming a file does (one line after
/// each `ok`), until the end or a halt, then waits for the moves to end.
pub fn run_on_core(
    profile: &MachineProfile,
    next_line: &mut dyn FnMut() -> Option<Vec<u8>>,
) -> Result<CoreReport, CoreBoardError> {
    let settings = core_settings(profile)?;
    let queue = StepQueue::new();
    let mut twin = Twin::new(&queue, settings, SimPlant::new(profile)?);
    let (mut lines, mut halted) = (0, false);
    let mut replies = Vec::new();
    let mut line = next_line();
    while let Some(text) = line.take() {
        lines += 1;
        let mut framed = text;
        framed.push(b'\n');
        match twin.run_lines(&framed, LINE_LIMIT_MS) {
            Ok(r) => replies.extend(r),
            Err(TwinError::Halted(r)) => {
                replies.extend(r);
                halted = true;
                break;
            }
            Err(TwinError::Timeout(r)) => {
                replies.extend(r);
                replies.extend_from_slice(b"Error:no ok within an hour of board time\n");
                break;
            }
        }
        line = next_line();
    }
    if !halted {
        if let Ok(r) = twin.run_lines(b"M400\n", LINE_LIMIT_MS) {
            replies.extend(r);
        }
    }
    let mut report = CoreReport { lines, ..CoreReport::of(&profile.name, &twin) };
    report.halted |= halted;
    report.errors = String::from_utf8_lossy(&replies)
        .lines()
        .filter(|l| l.starts_with("Error:"))
        .map(str::to_owned)
        .collect();
    Ok(report)
}

/// The core behind `gweave serve`'s serial line, for one host session (a fresh board at each
/// connection). The protocol layer ([`crate::Protocol`]) checks the line numbers and checksums
/// with Marlin's rules, as the core's own reader does, and hands each accepted line to the core;
/// every line the core prints goes back to the host at the board time it was printed, its own
/// `ok` and `echo:busy: processing` lines included (the protocol's keepalive is off for it).
pub struct CoreDevice {
    board: OwnedTwin<SimPlant>,
    /// Bytes of the core's output already handed to the host.
    forwarded: Cell<usize>,
}

impl CoreDevice {
    /// A board powered on with `profile` and the EEPROM bytes a previous session left (none:
    /// erased), which it reads its settings from (it has printed `start`).
    pub fn new(profile: &MachineProfile, eeprom: Vec<u8>) -> Result<CoreDevice, CoreBoardError> {
        let memory = Memory { eeprom, ..Memory::default() };
        let board = OwnedTwin::new(core_settings(profile)?, SimPlant::new(profile)?, memory);
        Ok(CoreDevice { board, forwarded: Cell::new(0) })
    }

    /// The EEPROM as the session leaves it (`M500`), for the next session.
    pub fn eeprom(&self) -> &[u8] {
        &self.board.twin().memory.eeprom
    }

    /// Hands the lines printed since the last call to `out`; returns how many were `ok`s.
    fn forward(&self, out: &mut dyn FnMut(f64, &str)) -> usize {
        let sent = &self.board.twin().memory.sent;
        let new = &sent[self.forwarded.get()..];
        let complete = new.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let t_s = self.now_s();
        let mut oks = 0;
        for line in String::from_utf8_lossy(&new[..complete]).lines() {
            oks += usize::from(line.starts_with("ok"));
            out(t_s, line);
        }
        self.forwarded.set(self.forwarded.get() + complete);
        oks
    }

    /// What the session did, as `gweave sim` reports it.
    pub fn report(&self, machine: &str) -> CoreReport {
        CoreReport::of(machine, self.board.twin())
    }
}

impl Device for CoreDevice {
    fn boot_lines(&self) -> Vec<String> {
        let mut lines = Vec::new();
        self.forward(&mut |_, line| lines.push(line.to_owned()));
        lines
    }

    fn execute(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) -> Outcome {
        self.board.send(line);
        self.board.send(b"\n");
        let deadline_ms = self.board.twin().now_ms() + LINE_LIMIT_MS;
        let mut oks = self.forward(out);
        while oks == 0 && self.board.twin().now_ms() < deadline_ms {
            self.board.run_ms(1);
            oks += self.forward(out);
        }
        if self.board.twin().controller.is_halted() {
            Outcome::Halted
        } else {
            Outcome::Ok
        }
    }

    fn now_s(&self) -> f64 {
        self.board.twin().now_ms() as f64 / 1000.0
    }

    fn acknowledged(&self) -> bool {
        true
    }

    /// A line the protocol layer refused (too long, a broken checksum): the core's emergency
    /// parser heard its bytes all the same, and an urgent command acts at the main loop's next
    /// turn.
    fn emergency(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        self.board.hear(line);
        if self.board.hear(b"\n") {
            self.board.run_ms(1);
            self.forward(out);
        }
    }

    fn idle(&mut self, t_s: f64, out: &mut dyn FnMut(f64, &str)) {
        // The board lives the host's silence (heaters heat, moves end), at most an hour at once.
        let ms = (t_s * 1000.0).clamp(0.0, LINE_LIMIT_MS as f64) as u64;
        for _ in 0..ms {
            self.board.run_ms(1);
            self.forward(out);
        }
    }
}

/// Why the core could not run a file.
#[derive(Debug, thiserror::Error)]
pub enum CoreBoardError {
    /// The profile asks for what the core has not.
    #[error(transparent)]
    Unsupported(#[from] Unsupported),
    /// A heater of the profile cannot be built.
    #[error(transparent)]
    Heater(#[from] crate::thermal::heater::HeaterError),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &'static str) -> impl FnMut() -> Option<Vec<u8>> {
        let mut it = text.lines();
        move || it.next().map(|l| l.as_bytes().to_vec())
    }

    #[test]
    fn the_default_profile_runs_on_the_core_with_exact_steps() {
        let p = MachineProfile::default();
        let text = "G28\nG1 X10 Y5 Z0.2 F3000\nM109 S200\nG1 E2.5 F1800\nG1 X12.5 E3\nM104 S0\n";
        let r = run_on_core(&p, &mut lines(text)).unwrap();
        assert!(!r.halted && r.errors.is_empty(), "{r:?}");
        let st = &p.motion.steps;
        let want = [12.5 * st.x, 5.0 * st.y, 0.2 * st.z, 3.0 * st.e];
        assert_eq!(r.end_steps, want.map(|v: f64| v.round() as i64));
    }

    #[test]
    fn m109_heats_the_profiles_hotend() {
        let p = MachineProfile::default();
        let r = run_on_core(&p, &mut lines("M109 S200\nM105\n")).unwrap();
        assert!(!r.halted && r.time_s > 30.0, "{r:?}");
    }

    #[test]
    fn the_core_answers_behind_the_serial_protocol() {
        let device = CoreDevice::new(&MachineProfile::default(), Vec::new()).unwrap();
        let mut link =
            crate::Protocol::new(device, crate::ProtocolConfig { keepalive_s: 0, duplicate_window: 0 });
        let mut replies = Vec::new();
        let mut out = |_t_s: f64, line: &str| replies.push(line.to_owned());
        link.boot(&mut out);
        link.feed(b"N0 M110 N0*125\nN1 G28*18\nN3 G28*16\nM114\nM105\n", &mut out);
        // Homing takes seconds: the core's own keepalive lines come meanwhile.
        let busy = replies.iter().filter(|l| *l == "echo:busy: processing").count();
        assert!(busy >= 2, "{replies:?}");
        replies.retain(|l| l != "echo:busy: processing");
        assert_eq!(
            replies[..7],
            [
                "start",
                "ok",
                "ok",
                "Error:Line Number is not Last Line Number+1, Last Line: 1",
                "Resend: 2",
                "ok",
                "X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0",
            ]
        );
        assert_eq!(replies[7], "ok");
        assert!(replies[8].starts_with("ok T:"), "{replies:?}");
        assert_eq!(replies.len(), 9, "{replies:?}");
        assert!(link.device().now_s() > 10.0, "homing takes board time");
    }

    /// One options type for the firmware's settings: the virtual printer's profiles of the
    /// gweave boards (`--machine gweave-*`) give the core exactly the settings the firmware's
    /// printer files build into the images (read by the core's own reader, as the build does).
    #[test]
    fn the_gweave_machine_profiles_are_the_firmwares_printer_files() {
        let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        for (machine, printer) in [
            ("gweave-ramps", "printer.toml"),
            ("gweave-ramps-eeb", "printer-eeb.toml"),
            ("gweave-mixing", "printer-mixing.toml"),
            ("gweave-rotary", "printer-rotary.toml"),
        ] {
            let profile =
                MachineProfile::from_file(&repo.join(format!("examples/machines/{machine}.toml"))).unwrap();
            let text = std::fs::read_to_string(repo.join("firmware").join(printer)).unwrap();
            let file = gweave_controller::printer_file::read(&text).unwrap();
            assert_eq!(
                core_settings(&profile).unwrap(),
                file.settings,
                "{machine} against firmware/{printer}"
            );
        }
    }

    #[test]
    fn a_profile_the_core_cannot_run_is_refused_by_name() {
        let mut p = MachineProfile::default();
        p.endstops.z = EndstopSide::Max;
        assert_eq!(core_settings(&p), Err(Unsupported("endstop at an axis maximum (endstops)")));
    }
}
