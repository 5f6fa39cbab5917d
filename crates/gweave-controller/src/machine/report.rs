//! The reports a host reads: `M114` position, `M119` endstops, `M115` firmware and
//! capabilities, `M503` settings, in Marlin's words (`Marlin/src/gcode/host/M114.cpp`,
//! `M115.cpp`, `M119.cpp`, `module/settings.cpp`).

use super::Controller;
use crate::serial::out::{line, Reply};
use crate::{Io, AXES, AXIS_LETTERS};

/// `M115`: the firmware line, then the capabilities a host looks for. Hosts read `Cap:` lines
/// to decide what to send (OctoPrint: `AUTOREPORT_TEMP`, `EMERGENCY_PARSER`); this core has the
/// emergency parser (`M112` acts at once), EEPROM, thermal protection and the temperature
/// auto-report (`M155`: OctoPrint then stops polling `M105`), and no SD card.
pub(super) fn firmware(io: &mut impl Io) {
    line(io, b"FIRMWARE_NAME:gweave-controller PROTOCOL_VERSION:1.0 MACHINE_TYPE:RAMPS 1.4 EXTRUDER_COUNT:1");
    for cap in [
        &b"Cap:SERIAL_XON_XOFF:0"[..],
        b"Cap:BINARY_FILE_TRANSFER:0",
        b"Cap:EEPROM:1",
        b"Cap:AUTOREPORT_TEMP:1",
        b"Cap:EMERGENCY_PARSER:1",
        b"Cap:SDCARD:0",
        b"Cap:THERMAL_PROTECTION:1",
    ] {
        line(io, cap);
    }
}

impl Controller<'_> {
    /// `M114`: `X:10.00 Y:0.00 Z:0.00 E:0.00 Count X:800 Y:0 Z:0`, as Marlin's: the position
    /// where the queued moves end (mm), then the steps the motors have made (the stepper's
    /// counts, behind the planned position while moves run). On a rotary machine `A:` follows E
    /// and Z, as the virtual printer prints it; A's count is the planner's.
    pub(super) fn report_position(&self, io: &mut impl Io) {
        let mut r = Reply::new();
        for (axis, (&letter, &mm)) in AXIS_LETTERS.iter().zip(&self.position_mm).enumerate() {
            if axis > 0 {
                r.s(b" ");
            }
            r.s(&[letter, b':']).f2(mm);
        }
        let a = self.position_a();
        if let Some((deg, _)) = a {
            r.s(b" A:").f2(deg);
        }
        r.s(b" Count");
        // While nothing moves the motors are where the planner's moves end, in the coordinates
        // a `G92` of this very turn may just have named.
        let counted = if self.moving() { self.queue.counted_steps() } else { self.counted_when_idle() };
        for (&letter, &steps) in AXIS_LETTERS.iter().zip(&counted) {
            r.s(&[b' ', letter, b':']).i32(steps);
        }
        if let Some((_, steps)) = a {
            r.s(b" A:").i32(steps);
        }
        r.send(io);
    }

    /// `M119`: each endstop, `open` or `TRIGGERED`.
    pub(super) fn report_endstops(&self, io: &mut impl Io) {
        line(io, b"Reporting endstop status");
        for (axis, name) in [&b"x_min: "[..], b"y_min: ", b"z_min: "].into_iter().enumerate() {
            let level = self.inputs.endstops >> axis & 1;
            let triggered = level ^ (self.settings.endstop_inverting >> axis & 1) == 1;
            Reply::new().s(name).s(if triggered { b"TRIGGERED" } else { b"open" }).send(io);
        }
    }

    /// `M503`: the settings as the commands that set them, each after `echo:`.
    pub(super) fn report_settings(&self, io: &mut impl Io) {
        let s = &self.settings;
        let axes = |r: &mut Reply, values: &[f32; AXES]| {
            for (&letter, &value) in AXIS_LETTERS.iter().zip(values) {
                r.s(&[b' ', letter]).f2(value);
            }
        };
        line(io, b"echo:; Steps per unit:");
        let mut r = Reply::new();
        r.s(b"echo:  M92");
        axes(&mut r, &s.steps_per_mm);
        r.send(io);
        line(io, b"echo:; Maximum feedrates (units/s):");
        r.s(b"echo:  M203");
        axes(&mut r, &s.max_feed_mm_s);
        r.send(io);
        line(io, b"echo:; Maximum Acceleration (units/s2):");
        r.s(b"echo:  M201");
        axes(&mut r, &s.max_accel_mm_s2);
        r.send(io);
        line(io, b"echo:; Acceleration (units/s2): P<print_accel> R<retract_accel> T<travel_accel>");
        r.s(b"echo:  M204 P").f2(s.print_accel_mm_s2).s(b" R").f2(s.retract_accel_mm_s2);
        r.s(b" T").f2(s.travel_accel_mm_s2).send(io);
        line(io, b"echo:; Advanced: J<junc_dev>");
        r.s(b"echo:  M205 J").f2(s.junction_deviation_mm).send(io);
        line(io, b"echo:; Hotend PID:");
        let p = &s.hotend_pid;
        r.s(b"echo:  M301 P").f2(p.kp).s(b" I").f2(p.ki).s(b" D").f2(p.kd).send(io);
    }
}
