//! What each command does. The line's words are all read and checked first
//! ([`Words::parse`]); then the command's row in the registry (`registry.rs`) says whether this
//! machine runs it and the range of each of its numbers, all checked before anything changes,
//! so a refused line leaves the machine as it was.

use super::homing::Homing;
use super::registry::{self, Needs, Ranges};
use super::{Controller, Wait};
use crate::gcode::words::{Command, WordError, Words};
use crate::math::round_i32;
use crate::planner::Target;
use crate::rotary::{Feed, A_MOTOR};
use crate::serial::out::{line, Reply};
use crate::{Io, AXES, AXIS_LETTERS, BED, E, HOTEND0, HOTEND1};

/// How a command ends.
pub(super) enum Done {
    /// Print `ok` now.
    Ok,
    /// The command printed its own `ok` (`ok T:...` of `M105`) or waits ([`Wait`]).
    Quiet,
}

impl Controller<'_> {
    /// Whether this machine has what a command needs (its row in the registry).
    pub(super) fn has(&self, needs: Needs) -> bool {
        match needs {
            Needs::Nothing => true,
            Needs::Mixing => self.mixer.inputs() > 0,
            #[cfg(feature = "inkjet")]
            Needs::Inkjet => self.settings.inkjet_heads > 0,
            Needs::SecondHotend => crate::heat::Heat::fitted(&self.settings, HOTEND1),
        }
    }

    /// Runs one command line (line number and checksum removed).
    pub(super) fn run_command(&mut self, io: &mut impl Io, body: &[u8]) {
        let words = match Words::parse(body) {
            Ok(w) => w,
            Err(WordError::NoCommand) => return unknown(io, body),
            Err(WordError::BadWord(column)) => {
                Reply::new()
                    .s(b"Error:Bad G-code at column ")
                    .u32(u32::from(column) + 1)
                    .s(b": \"")
                    .escaped(body)
                    .s(b"\"")
                    .send(io);
                return line(io, b"ok");
            }
        };
        let Command { letter: command, code } = words.command;
        let Some(ranges) = registry::row(command, code, |needs| self.has(needs)) else {
            return unknown(io, body);
        };
        if let Some((letter, value, (low, high))) = out_of_range(&words, ranges) {
            // As the virtual printer words it: `echo:M104 S = 600.00 is out of range: 0.00 to
            // 500.00`; the line is not run, the values in force stay. A fire refused is an
            // error (`Error:M700 S = ...`): the print would miss those drops, and a host stops.
            let severity: &[u8] = if (command, code) == (b'M', 700) { b"Error:" } else { b"echo:" };
            let mut r = Reply::new();
            r.s(severity).s(&[command]).u32(u32::from(code)).s(&[b' ', letter]).s(b" = ").f2(value);
            r.s(b" is out of range: ").f2(low).s(b" to ").f2(high).send(io);
            return line(io, b"ok");
        }
        match self.dispatch(io, &words) {
            Some(Done::Ok) => line(io, b"ok"),
            Some(Done::Quiet) => {}
            None => unknown(io, body),
        }
    }

    /// Runs the command of `w` if this controller knows it (its row in the registry is checked
    /// against this: `the_registry_is_exactly_what_the_controller_runs`). Never inlined: in the
    /// main loop's one function, the AVR's jumps over it (`rjmp`, 4 KB either way) no longer
    /// reached, and the image did not link ("relocation truncated to fit: R_AVR_13_PCREL").
    #[inline(never)]
    pub(super) fn dispatch(&mut self, io: &mut impl Io, w: &Words) -> Option<Done> {
        let Command { letter, code } = w.command;
        let now = self.inputs.now_ms;
        let s = &mut self.settings;
        match (letter, code) {
            (b'G', 0 | 1) => self.linear_move(io, w),
            (b'G', 4) => {
                let ms = w.get(b'P').unwrap_or(0.0) + w.get(b'S').unwrap_or(0.0) * 1000.0;
                self.wait = Wait::Moves { then_dwell_ms: ms as u32, then_off: 0 };
                return Some(Done::Quiet);
            }
            (b'G', 28) => {
                self.wait = Wait::Home(Homing::new(w));
                self.steppers_enabled = self.motors(self.all_axes());
                return Some(Done::Quiet);
            }
            // Millimetres, the only unit this machine has.
            (b'G', 21) => {}
            (b'G', 90) => self.relative = 0,
            (b'G', 91) => self.relative = 0b11111,
            // Inverse time (F is one over each move's minutes) and back to units per minute: in
            // a rotary build (the files that use it turn a mandrel; the base image has no room).
            (b'G', 93) if cfg!(feature = "rotary") => {
                self.inverse_time = Some(self.inverse_time.unwrap_or(0.0))
            }
            (b'G', 94) if cfg!(feature = "rotary") => self.inverse_time = None,
            (b'G', 92) => self.set_position(w),
            (b'M', 82) => self.relative &= !(1 << E),
            (b'M', 83) => self.relative |= 1 << E,
            (b'M', 0 | 84 | 18) => {
                if code == 0 {
                    // A program stop: the moves end, then heaters and motors are off.
                    self.heat.all_off();
                    self.fan_duty = 0;
                }
                let then_off = self.motors(axes_given(w).unwrap_or(self.all_axes()));
                self.wait = Wait::Moves { then_dwell_ms: 0, then_off };
                return Some(Done::Quiet);
            }
            // Marlin 2.1's `M211`: `S` switches, silently (`S` without a number is on, as its
            // `value_bool` reads it); alone, it reports.
            (b'M', 211) if w.has(b'S') => self.soft_endstops.set_enabled(w.get(b'S') != Some(0.0)),
            (b'M', 211) => self.soft_endstops.report(io, &self.settings.travel_mm),
            (b'M', 17) => self.steppers_enabled |= self.motors(axes_given(w).unwrap_or(self.all_axes())),
            (b'M', 104 | 109) => {
                // `T` names the hotend; without it, the active extruder's (Marlin's
                // `get_target_extruder_from_command`).
                let heater = match w.get(b'T') {
                    Some(1.0) => HOTEND1,
                    Some(_) => HOTEND0,
                    None => self.hotend(),
                };
                return Some(self.set_temperature(w, heater, code == 109, now));
            }
            (b'M', 140 | 190) => return Some(self.set_temperature(w, BED, code == 190, now)),
            (b'M', 105) => {
                let mut r = Reply::new();
                r.s(b"ok");
                self.heat.report(&self.settings, &mut r);
                r.send(io);
                return Some(Done::Quiet);
            }
            (b'M', 106) => self.fan_duty = w.get(b'S').unwrap_or(255.0) as u8,
            (b'M', 155) => {
                // Marlin's `M155 S<seconds>`: the first report one interval from now.
                if let Some(seconds) = w.get(b'S') {
                    self.auto_report_s = seconds as u8;
                    self.next_report_ms = now.wrapping_add(u32::from(self.auto_report_s) * 1000);
                }
            }
            (b'M', 107) => self.fan_duty = 0,
            (b'M', 110) => {
                if let Some(n) = w.get(b'N') {
                    self.last_line = n as i32;
                }
            }
            (b'M', 112) => self.kill(io, None),
            // Done by the emergency parser as it arrived (a heating wait ended); in its turn,
            // nothing, as in Marlin with `EMERGENCY_PARSER`.
            (b'M', 108) => {}
            // Fault injection (feature `fault-injection`, never in a normal build): the main
            // loop hangs as a bug would, heaters as they are, so a board's test can check that
            // its watchdog resets the chip into a safe state.
            #[cfg(feature = "fault-injection")]
            (b'M', 9999) => loop {
                core::hint::spin_loop();
            },
            (b'M', 114) => self.report_position(io),
            (b'M', 115) => super::report::firmware(io),
            (b'M', 119) => self.report_endstops(io),
            (b'M', 400) => {
                self.wait = Wait::Moves { then_dwell_ms: 0, then_off: 0 };
                return Some(Done::Quiet);
            }
            (b'M', 92) => {
                for (axis, &letter) in AXIS_LETTERS.iter().enumerate() {
                    if let Some(v) = w.get(letter) {
                        self.settings.steps_per_mm[axis] = v;
                        // The same place in the new steps (E: the motor stays and counts the
                        // new steps from here).
                        self.anchor(axis);
                    }
                }
            }
            (b'M', 201) => set_axes(w, &mut s.max_accel_mm_s2),
            (b'M', 203) => set_axes(w, &mut s.max_feed_mm_s),
            (b'M', 204) => {
                if let Some(v) = w.get(b'S') {
                    (s.print_accel_mm_s2, s.travel_accel_mm_s2) = (v, v);
                }
                set(w, b'P', &mut s.print_accel_mm_s2);
                set(w, b'R', &mut s.retract_accel_mm_s2);
                set(w, b'T', &mut s.travel_accel_mm_s2);
            }
            (b'M', 205) => set(w, b'J', &mut s.junction_deviation_mm),
            (b'M', 301) => {
                let pid = &mut s.hotend_pid;
                set(w, b'P', &mut pid.kp);
                set(w, b'I', &mut pid.ki);
                set(w, b'D', &mut pid.kd);
            }
            (b'M', 500) => {
                let crc = self.settings.save(io);
                self.save_tools(io);
                self.report_eeprom(io, b"echo:Settings Stored (", crc);
            }
            (b'M', 501) => match self.settings.load(io) {
                Some(crc) => {
                    self.load_tools(io);
                    self.report_eeprom(io, b"echo:Stored settings retrieved (", crc)
                }
                None => line(io, b"echo:No settings stored in EEPROM: settings unchanged"),
            },
            (b'M', 502) => {
                // The board's own defaults, as Marlin's compiled `Configuration.h`: its printer
                // file (hotends, sensors, directions, travel, the rotary axis), not the core's.
                self.settings = io.build_settings();
                self.mixer.reset_tools();
                line(io, b"echo:Hardcoded Default Settings Loaded");
            }
            (b'M', 503) => {
                self.report_settings(io);
                self.report_tools(io);
            }
            (b'M', 163..=165) | (b'T', _) if self.mixer.inputs() > 0 => {
                return Some(self.mixing_command(io, w))
            }
            #[cfg(feature = "inkjet")]
            (b'M', 700) if self.settings.inkjet_heads > 0 => return Some(self.inkjet_command(io, w)),
            // The extruder of the moves planned from now on (on E0's socket, or E1's), and of
            // the cold-extrusion check. A change waits for the moves planned before it, as
            // Marlin's `tool_change()` synchronises first: the planner joins moves through one
            // E axis, and one extruder must not stop dead while the other starts at speed.
            (b'T', 0 | 1) if code == 0 || crate::heat::Heat::fitted(&self.settings, HOTEND1) => {
                if u16::from(self.planner.extruder) != code {
                    self.planner.extruder = code as u8;
                    self.wait = Wait::Moves { then_dwell_ms: 0, then_off: 0 };
                    return Some(Done::Quiet);
                }
            }
            _ => return None,
        }
        Some(Done::Ok)
    }

    /// `G0`/`G1`: the target in mm (absolute or relative per axis), then in steps, to the
    /// planner. `F` is in mm/min and stays for the next moves.
    ///
    /// Extruding below the settings' minimum hotend temperature is refused as Marlin's
    /// `PREVENT_COLD_EXTRUSION` does: cold plastic does not flow, the extruder would grind the
    /// filament. The move goes without its E part, E counts as moved, and the host hears
    /// `echo: cold extrusion prevented`. The hotend judged is the active extruder's (`T1`).
    /// An extrusion longer than the settings' `extrude_max_mm` is refused the same way, as
    /// Marlin's `PREVENT_LENGTHY_EXTRUDE` (`echo: too long extrusion prevented`): a stray digit
    /// (`E1000` for `E10.00`) would otherwise push half a metre of filament through a nozzle
    /// that cannot pass it, stripping the filament. On a mixing hotend the limit is on the most
    /// loaded input's share, as Marlin's.
    ///
    /// On a rotary machine `A` turns the mandrel (degrees) and F follows `G93`/`G94` and the
    /// machine's feed convention ([`crate::rotary`]).
    fn linear_move(&mut self, io: &mut impl Io, w: &Words) {
        if let Some(f) = w.get(b'F') {
            // (`G93` exists in a rotary build only: elsewhere this is always the second arm.)
            match &mut self.inverse_time {
                Some(moves_per_s) if cfg!(feature = "rotary") => *moves_per_s = f / 60.0,
                _ => self.feed_mm_s = f / 60.0,
            }
        }
        let (from_mm, from_deg) = (self.position_mm, self.position_a_deg);
        for (axis, &letter) in AXIS_LETTERS.iter().enumerate() {
            if let Some(v) = w.get(letter) {
                let relative = self.relative & (1 << axis) != 0;
                self.position_mm[axis] = if relative { self.position_mm[axis] + v } else { v };
            }
        }
        self.soft_endstops.clamp(&mut self.position_mm, &self.settings.travel_mm);
        // Every axis, named on the line or not: a move too short to plan left its steps to
        // this one (MIN_STEPS_PER_SEGMENT), E's included even if this line has no E.
        let target: [i32; AXES] = core::array::from_fn(|axis| self.target_steps(axis));
        let rotary = self.rotary();
        if let (Some(v), true) = (w.get(b'A'), rotary) {
            let relative = self.relative & (1 << AXES) != 0;
            self.position_a_deg = if relative { self.position_a_deg + v } else { v };
        }
        let target_a = self.target_a_steps();
        let cold = self.heat.heaters[self.hotend()].temp_c < self.settings.extrude_min_c;
        let e_steps = target[E].saturating_sub(self.planner.position_steps[E]);
        let max_mm = self.settings.extrude_max_mm;
        let too_long = max_mm > 0.0
            && e_steps.unsigned_abs() as f32 * self.mixer.largest_share()
                > max_mm * self.settings.steps_per_mm[E];
        if e_steps != 0 && (cold || too_long) {
            self.planner.position_steps[E] = target[E];
            line(
                io,
                if cold { b"echo: cold extrusion prevented" } else { b"echo: too long extrusion prevented" },
            );
        }
        self.steppers_enabled |= self.motors(self.all_axes());
        // A `G93` move before any F (LinuxCNC refuses it) runs at the last `G94` feed.
        let feed = match self.inverse_time {
            Some(moves_per_s) if cfg!(feature = "rotary") && moves_per_s > 0.0 => {
                Feed::InverseTime { moves_per_s }
            }
            _ => Feed::PerSecond(self.feed_mm_s),
        };
        // Room was checked before the line was taken.
        // On a rotary machine F is measured over the move as commanded ([`Target::commanded`]).
        let commanded = rotary.then(|| {
            let mut d = [0.0; AXES + 1];
            for (axis, d) in d.iter_mut().enumerate().take(AXES) {
                *d = self.position_mm[axis] - from_mm[axis];
            }
            d[AXES] = self.position_a_deg - from_deg;
            d
        });
        let target = Target { steps: target, a_steps: target_a, feed, commanded };
        self.planner.add_with_a(&target, 0, &self.settings, &mut self.mixer);
    }

    /// The steppers of `axes` (bit `1 << axis`): E's stands for every input of a mixing hotend,
    /// and for both extruders of a board with two hotends.
    pub(super) fn motors(&self, axes: u8) -> u8 {
        let inputs = self.mixer.inputs().max(usize::from(self.settings.hotends)).max(1);
        if axes & (1 << E) != 0 {
            axes | (((1u16 << (AXES - 1 + inputs)) - 1) as u8 & !((1 << E) - 1))
        } else {
            axes
        }
    }

    /// The hotend of the active extruder ([`HOTEND0`], or [`HOTEND1`] after `T1`).
    fn hotend(&self) -> usize {
        usize::from(self.planner.extruder)
    }

    /// Every axis' bit (`1 << axis`), and the rotary axis' (`1 << AXES`, its motor's bit
    /// [`A_MOTOR`] in [`Controller::motors`]) on a rotary machine.
    pub(super) fn all_axes(&self) -> u8 {
        const _: () = assert!(A_MOTOR == AXES, "the A bit of an axis mask is its motor's bit");
        0b1111 | if self.rotary() { 1 << AXES } else { 0 }
    }

    /// Where the rotary axis' motor goes for the angle now, in steps, counted from where the
    /// angle was last named as E's are ([`Controller::target_steps`]); the planner's position
    /// without a rotary axis.
    fn target_a_steps(&self) -> i32 {
        if !self.rotary() {
            return self.planner.position_a_steps;
        }
        let spd = self.settings.rotary.steps_per_deg;
        self.anchor_a_steps + round_i32((self.position_a_deg - self.anchor_a_deg) * spd)
    }

    /// Where `axis`'s motor goes for the logical position now, in steps. E counts from where it
    /// was last named, as the virtual printer's Marlin model does (`gweave-sim`'s
    /// `motion/stepper.rs`), so that rounding never accumulates: a `G92 E0` at every layer, or
    /// the `G92 E<e>` after a purge, loses no fraction of a step, where rounding the named
    /// position itself (`round(e * steps_per_mm)`, Marlin's `set_position_mm`) would shift E's
    /// steps by up to half a step each time, and a mixing hotend's split with them. X, Y and Z
    /// are rounded from their position (named at 0 by homing, where the steps are 0; a `G92`
    /// of them rounds the position named).
    pub(super) fn target_steps(&self, axis: usize) -> i32 {
        let spm = self.settings.steps_per_mm[axis];
        if axis == E {
            self.anchor_e_steps + round_i32((self.position_mm[E] - self.anchor_e_mm) * spm)
        } else {
            round_i32(self.position_mm[axis] * spm)
        }
    }

    /// Names the logical position of `axis` now: E's is where its motor is (the planner's end),
    /// X's, Y's and Z's the position rounded to steps.
    pub(super) fn anchor(&mut self, axis: usize) {
        if axis == E {
            self.anchor_e_mm = self.position_mm[E];
            self.anchor_e_steps = self.planner.position_steps[E];
        } else {
            self.planner.position_steps[axis] = self.target_steps(axis);
        }
    }

    /// `G92`: names the current place of the axes given a number, as Marlin's (`seenval`): a
    /// bare `G92` names nothing (it zeroed every axis here, and moved the software endstops'
    /// range with them, where Marlin and the virtual printer's Marlin model do nothing).
    fn set_position(&mut self, w: &Words) {
        for (axis, &letter) in AXIS_LETTERS.iter().enumerate() {
            if let Some(v) = w.get(letter) {
                self.soft_endstops.renamed(axis, self.position_mm[axis], v);
                self.position_mm[axis] = v;
                self.anchor(axis);
            }
        }
        if let (Some(v), true) = (w.get(b'A'), self.rotary()) {
            // The mandrel stays; its angle is named (a program re-declares it modulo a turn).
            self.position_a_deg = v;
            self.anchor_a_deg = v;
            self.anchor_a_steps = self.planner.position_a_steps;
        }
    }

    /// `M104`/`M109`, `M140`/`M190`: `S` the target (and for the waits, `R` a target to reach
    /// both ways, heating or cooling). As Marlin's `M109`, `S` wins over `R`, and a letter
    /// without a number is not there.
    fn set_temperature(&mut self, w: &Words, heater: usize, wait: bool, now_ms: u32) -> Done {
        let target = w.get(b'S').or(w.get(b'R'));
        if let Some(t) = target {
            self.heat.set_target(&self.settings, heater, t, now_ms);
        }
        if wait && target.is_some() {
            // The first cooling check passes (Marlin starts from 9999 °C), the next a minute on.
            let (cooled_from_c, check_ms) = (f32::INFINITY, self.inputs.now_ms);
            // A heater index is below `HEATERS` (3).
            let heater = heater as u8;
            self.wait = Wait::Heat { heater, both_ways: w.get(b'S').is_none(), cooled_from_c, check_ms };
            // An `M108` heard before the wait began does not end it (Marlin sets
            // `wait_for_heatup` as the wait starts).
            self.continue_heard = false;
            self.next_report_ms = now_ms.wrapping_add(super::HEAT_REPORT_MS);
            return Done::Quiet;
        }
        Done::Ok
    }

    fn report_eeprom(&self, io: &mut impl Io, what: &[u8], crc: u16) {
        Reply::new()
            .s(what)
            .u32(u32::from(crate::settings::EEPROM_BYTES))
            .s(b" bytes; crc ")
            .u32(u32::from(crc))
            .s(b")")
            .send(io);
    }
}

/// `echo:Unknown command: "G123"` then `ok`, as Marlin.
fn unknown(io: &mut impl Io, body: &[u8]) {
    Reply::new().s(b"echo:Unknown command: \"").escaped(body).s(b"\"").send(io);
    line(io, b"ok");
}

/// The axes named on the line (bits), if any.
/// (`A`: bit `1 << AXES`, the rotary axis).
fn axes_given(w: &Words) -> Option<u8> {
    let mut mask = (0..AXES).filter(|&a| w.has(AXIS_LETTERS[a])).fold(0u8, |m, a| m | 1 << a);
    if w.has(b'A') {
        mask |= 1 << AXES;
    }
    (mask != 0).then_some(mask)
}

fn set(w: &Words, letter: u8, value: &mut f32) {
    if let Some(v) = w.get(letter) {
        *value = v;
    }
}

fn set_axes(w: &Words, values: &mut [f32; AXES]) {
    for (value, &letter) in values.iter_mut().zip(&AXIS_LETTERS) {
        set(w, letter, value);
    }
}

/// The first letter whose value is outside its command's range (`ranges`, from the command's
/// row in the registry), if any: the letter, the value and the range.
fn out_of_range(w: &Words, ranges: Ranges) -> Option<(u8, f32, (f32, f32))> {
    for &(letters, (low, high)) in ranges {
        for &l in letters {
            if let Some(v) = w.get(l) {
                if !(v >= low && v <= high) {
                    return Some((l, v, (low, high)));
                }
            }
        }
    }
    None
}
