//! Moves, homing and the position reports of the interpreter.
//!
//! Homing (`G28`) drives each axis in the profile's order to its endstop at the homing speed,
//! backs off by the bump distance and touches again at `feed / bump_divisor`, as Marlin's
//! `homeaxis()` does. Each of the three legs is a single-axis move from rest to rest: with
//! speed `v` and acceleration `a`, a leg of length `d` takes `d / v + v / a` when it is long
//! enough to cruise (`d >= v^2 / a`), and `2 sqrt(d / a)` (a triangle) otherwise. The motors
//! step the legs too, so the step totals include homing.

use gweave::gcode::state::{self};
use gweave::Effect;

use super::{Machine, WarningKind};
use crate::motion::kinematics::{Geometry, Pos};
use crate::motion::limits::CornerMode;
use crate::profile::EndstopSide;
use crate::thermal::COLD_EXTRUSION_LINE;

/// Axis letters X Y Z.
const XYZ: [char; 3] = ['X', 'Y', 'Z'];
/// Longest time one command may hold the simulated clock, s (a week; a 40-hour print is
/// 144 000 s). Heaters are simulated tick by tick through every second of it, so a stray
/// digit in a feed rate or a dwell (`F0.0001`, `G4 S99999999`) would otherwise keep the virtual
/// printer busy for hours; such a command is refused instead.
pub(super) const MAX_COMMAND_S: f64 = 7.0 * 24.0 * 3600.0;
/// Marlin's reply to a move feeding more than `EXTRUDE_MAXLENGTH` (`STR_ERR_LONG_EXTRUDE_STOP`).
pub(super) const LONG_EXTRUSION_LINE: &str = "echo: too long extrusion prevented";
/// Marlin's reply to a `G2`/`G3` without a centre it can find (`STR_ERR_ARC_ARGS`).
const ARC_REFUSED_LINE: &str = "Error:G2/G3 bad parameters";
/// Tolerance of the bounds check, mm: coordinates are written with a few decimals.
const BOUNDS_EPS_MM: f64 = 1e-6;

/// Time of a single-axis move of `d` from rest to rest at speed `v` and acceleration `a`, s.
pub(super) fn rest_to_rest_s(d: f64, v: f64, a: f64) -> f64 {
    if d <= 0.0 {
        0.0
    } else if d >= v * v / a {
        d / v + v / a
    } else {
        2.0 * (d / a).sqrt()
    }
}

impl Machine {
    /// A line that moves (or a motion command without axis words, which only sets F).
    pub(super) fn motion(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        // The move is changed in place in the modal state's effect (feed and flow overrides, a
        // refused extrusion), where the core reads it: an `Effect` is two 7-axis positions and
        // an arc, and a copy of it right after the state wrote it stalls (docs/performance.md).
        let m = match &mut self.core.state_mut().effect {
            Effect::Move(m) => m,
            Effect::ArcRefused(refusal) => {
                // Marlin's reply to an arc it cannot draw (`STR_ERR_ARC_ARGS`); the machine stays.
                let refusal = *refusal;
                out(self.now_s(), ARC_REFUSED_LINE);
                self.warn(WarningKind::ArcRefused { refusal });
                self.run_core(line, out);
                return;
            }
            _ => {
                self.run_core(line, out);
                return;
            }
        };
        if self.feed_pct != 100.0 {
            m.feed_mm_min *= self.feed_pct / 100.0;
        }
        let too_long = too_long(m);
        let xyza = |p: &state::Position| [p[state::X], p[state::Y], p[state::Z], p[state::A]];
        let (from, to) = (xyza(&m.from), xyza(&m.to));
        let (from_e, to_e) = (m.from[state::E], m.to[state::E]);
        let reach = m.reach();
        if let Some(message) = self.check_bounds(&from, &to, &reach).or(too_long) {
            // The machine stays where it was, as firmware that refuses a move does.
            let s = self.core.state_mut();
            if let Effect::Move(m) = &s.effect {
                s.pos = m.from;
            }
            self.refuse(message, out);
            return;
        }
        let de = to_e - from_e;
        if de != 0.0 {
            let hotend = self.active_hotend();
            let mut fed_to_e = to_e;
            // What the motor would feed, the flow factor (`M221`) applied.
            let fed_mm = de * self.flow_pct / 100.0;
            if let Err(cold) = self.thermal.check_extrude(hotend) {
                // Marlin drops the E part and goes on as if it had extruded.
                out(self.now_s(), COLD_EXTRUSION_LINE);
                self.warn(WarningKind::ColdExtrusion {
                    hotend: cold.hotend,
                    temp_c: cold.temp_c,
                    min_c: cold.min_c,
                });
                fed_to_e = from_e;
            } else if let Some(max_mm) = self.too_long_extrusion(fed_mm) {
                // `PREVENT_LENGTHY_EXTRUDE`: the same, for a feed past `EXTRUDE_MAXLENGTH`.
                out(self.now_s(), LONG_EXTRUSION_LINE);
                self.warn(WarningKind::LongExtrusion { fed_mm, max_mm });
                fed_to_e = from_e;
            } else if self.flow_pct != 100.0 {
                fed_to_e = from_e + fed_mm;
            }
            if fed_to_e != to_e {
                if let Effect::Move(m) = &mut self.core.state_mut().effect {
                    m.to[state::E] = fed_to_e;
                }
            }
            self.feed_filament(fed_to_e - from_e);
        }
        self.thermal.set_moving(true);
        if let Some(check) = &mut self.recoat {
            check.on_move(from, to);
        }
        self.run_core(line, out);
    }

    /// `EXTRUDE_MAXLENGTH` (mm), if feeding `fed_mm` (the flow factor applied) would pass it:
    /// Marlin's planner compares the E steps with the limit's, and on a mixing extruder the
    /// share of the active virtual tool's most loaded input (`Planner::_populate_block`, the
    /// tool's mix through `refresh_collector`), so that a move its inputs could feed runs.
    fn too_long_extrusion(&self, fed_mm: f64) -> Option<f64> {
        let max_mm = f64::from(self.profile.firmware.extrude_max_mm);
        let share =
            self.core.mixing().map_or(1.0, |m| m.active_mix().ratios().iter().fold(0.0, |a, &r| r.max(a)));
        (max_mm > 0.0 && fed_mm.abs() * share > max_mm).then_some(max_mm)
    }

    /// Counts `fed_mm` of filament the active tool's motor fed (negative: retracted), by a move
    /// or by a firmware retraction or recovery (`G10`, `G11`).
    pub(super) fn feed_filament(&mut self, fed_mm: f64) {
        self.filament_mm[self.tool] += fed_mm;
        self.retraction[self.tool].feed(fed_mm);
    }

    /// The hotend that extrudes: the tool's on a multi-hotend machine, the only one otherwise.
    fn active_hotend(&self) -> u8 {
        self.profile.hotend_of_tool(self.tool)
    }

    /// Warns about a target outside the build volume (below the bed separately), or a point an
    /// arc passes (`reach`, [`Move::reach`](gweave::gcode::effect::Move::reach): the lowest and
    /// highest the move reaches on each axis). Only the axes the move changes are checked, so
    /// one excursion is reported once; an arc changes X and Y even when it ends where it started.
    ///
    /// Returns why the target cannot be driven at all, if it is more than the machine's own
    /// travel outside it on some axis (a coordinate with stray digits, `X999999999`): such a move
    /// would run for days of simulated time, every heater tick of it simulated. A smaller
    /// excursion is only reported, and carried out.
    fn check_bounds(&mut self, from: &[f64; 4], to: &[f64; 4], reach: &[[f64; 2]; 3]) -> Option<String> {
        let ranges = self.profile.bed.ranges();
        let mut out_of_reach = None;
        for (i, &(min_mm, max_mm)) in ranges.iter().enumerate() {
            let [lo, hi] = reach[i].map(|v| v + self.shift_mm[i]);
            if lo == hi && to[i] == from[i] {
                continue;
            }
            // The end of a line; for an arc, the side it passes farthest out (if any is out).
            let value_mm = if lo < min_mm - BOUNDS_EPS_MM { lo } else { hi };
            if i == state::Z && value_mm < -BOUNDS_EPS_MM {
                self.warn(WarningKind::BelowBed { z_mm: value_mm });
            } else if value_mm < min_mm - BOUNDS_EPS_MM || value_mm > max_mm + BOUNDS_EPS_MM {
                self.warn(WarningKind::OutOfBounds { axis: XYZ[i], value_mm, min_mm, max_mm });
            } else {
                continue;
            }
            let span = max_mm - min_mm;
            if out_of_reach.is_none() && (value_mm < min_mm - span || value_mm > max_mm + span) {
                out_of_reach = Some(unreachable(XYZ[i], value_mm, min_mm, max_mm));
            }
        }
        out_of_reach
    }

    /// `G28 [X] [Y] [Z]`.
    pub(super) fn home(&mut self, line: &[u8], before: &state::Position, out: &mut dyn FnMut(f64, &str)) {
        let Effect::Home { axes } = self.core.state().effect else {
            return;
        };
        // Drains the planner.
        self.run_core(line, out);
        self.thermal.set_moving(true);
        let ranges = self.profile.bed.ranges();
        let sides = self.profile.endstops.to_array();
        let homing = self.profile.homing.clone();
        let mut logical = *before;
        let mut t_s = 0.0;
        for axis in homing.axes() {
            if axes & (1 << axis) == 0 {
                continue;
            }
            let (min_mm, max_mm) = ranges[axis];
            let (stop_mm, away) = match sides[axis] {
                EndstopSide::Min => (min_mm, 1.0),
                EndstopSide::Max => (max_mm, -1.0),
            };
            let accel = self.homing_accel(axis);
            let feed = homing.feed_mm_s[axis];
            let bump = homing.bump_mm[axis];
            let start = logical[axis];
            let at_stop = stop_mm - self.shift_mm[axis];
            let physical = start + self.shift_mm[axis];
            t_s += rest_to_rest_s((physical - stop_mm).abs(), feed, accel)
                + rest_to_rest_s(bump, feed, accel)
                + rest_to_rest_s(bump, feed / homing.bump_divisor[axis], accel);
            for (from, to) in
                [(start, at_stop), (at_stop, at_stop + away * bump), (at_stop + away * bump, at_stop)]
            {
                let mut a = logical;
                a[axis] = from;
                let mut b = logical;
                b[axis] = to;
                self.core.steppers_mut().step_move(pos(&a), pos(&b), &[]);
            }
            // At the endstop the logical and physical positions agree again.
            self.shift_mm[axis] = 0.0;
            logical[axis] = stop_mm;
            self.core.state_mut().pos[axis] = stop_mm;
            self.homed[axis] = true;
        }
        self.core.homed(axes);
        self.core.idle(t_s);
        self.homing_s += t_s;
    }

    /// The acceleration homing moves use on `axis`: the axis limit, capped by Marlin's travel
    /// acceleration or Klipper's toolhead limit; none in constant mode (an infinite
    /// acceleration: each stroke takes its distance over its feed).
    fn homing_accel(&self, axis: usize) -> f64 {
        let p = self.core.profile();
        let axis_max = p.max_accel_mm_s2.to_array()[axis];
        match &p.corners {
            CornerMode::Marlin { .. } => axis_max.min(p.accel.travel_mm_s2),
            CornerMode::Klipper(k) => match (axis, k.max_z_accel_mm_s2) {
                (state::Z, Some(z)) => z,
                _ => k.max_accel_mm_s2,
            },
            CornerMode::Constant {} => f64::INFINITY,
        }
    }

    /// `M114`: `X:10.00 Y:0.00 Z:0.00 E:0.00 Count X:800 Y:0 Z:0` (and `A:` on a rotary
    /// machine).
    pub(super) fn m114_text(&self) -> String {
        let [x, y, z, e, a] = self.position();
        let count = self.core.steppers().position_steps();
        let rotary = self.profile.rotary.is_some();
        let a_pos = if rotary { format!(" A:{a:.2}") } else { String::new() };
        let a_count = if rotary { format!(" A:{}", count[4]) } else { String::new() };
        format!(
            "X:{x:.2} Y:{y:.2} Z:{z:.2}{a_pos} E:{e:.2} Count X:{} Y:{} Z:{}{a_count}",
            count[0], count[1], count[2]
        )
    }

    /// `M119`: `Reporting endstop status`, then `x_min: open` or `x_min: TRIGGERED` per
    /// endstop. An endstop is triggered when the carriage is within half a step of it, or past.
    pub(super) fn m119_lines(&self) -> Vec<String> {
        let ranges = self.profile.bed.ranges();
        let steps = &self.profile.motion.steps;
        let spu = [steps.x, steps.y, steps.z];
        let physical = self.physical_xyz();
        let mut lines = vec!["Reporting endstop status".to_owned()];
        for (i, side) in self.profile.endstops.to_array().into_iter().enumerate() {
            let half_step = 0.5 / spu[i];
            let (name, hit) = match side {
                EndstopSide::Min => ("min", physical[i] <= ranges[i].0 + half_step),
                EndstopSide::Max => ("max", physical[i] >= ranges[i].1 - half_step),
            };
            let state = if hit { "TRIGGERED" } else { "open" };
            let axis = XYZ[i].to_ascii_lowercase();
            lines.push(format!("{axis}_{name}: {state}"));
        }
        lines
    }
}

/// Why a target on `axis` cannot be driven (see [`Machine::check_bounds`]).
#[cold]
#[inline(never)]
fn unreachable(axis: char, value_mm: f64, min_mm: f64, max_mm: f64) -> String {
    format!("{axis}{value_mm:.3} is out of reach ({min_mm:.0}..{max_mm:.0} mm): move refused")
}

/// Why a move would hold the simulated clock for more than [`MAX_COMMAND_S`] at its own feed
/// rate (acceleration and the machine's limits only make it longer), if it would.
fn too_long(m: &state::Move) -> Option<String> {
    // First a bound that costs no square root: no path is longer than the sum of its axes'
    // travels (plus the arc, for G2/G3), so most moves are cleared here.
    let travel: f64 = [state::X, state::Y, state::Z, state::E, state::A]
        .iter()
        .map(|&i| (m.to[i] - m.from[i]).abs())
        .sum::<f64>()
        + match &m.path {
            state::Path::Arc(arc) => arc.xy_len_mm(),
            state::Path::Line => 0.0,
        };
    if travel * 60.0 <= MAX_COMMAND_S * m.feed_mm_min {
        return None;
    }
    too_long_exactly(m)
}

/// [`too_long`] with the move's real length, for the few moves the quick bound leaves.
#[cold]
#[inline(never)]
fn too_long_exactly(m: &state::Move) -> Option<String> {
    let len = m.len_mm().max(Geometry::between(pos(&m.from), pos(&m.to)).len);
    let t_s = len / (m.feed_mm_min / 60.0);
    (m.feed_mm_min > 0.0 && t_s > MAX_COMMAND_S)
        .then(|| format!("a {len:.3} mm move at F{} would take {t_s:.0} s: move refused", m.feed_mm_min))
}

fn pos(p: &state::Position) -> Pos {
    Pos { x_mm: p[state::X], y_mm: p[state::Y], z_mm: p[state::Z], e_mm: p[state::E], a_deg: p[state::A] }
}
