//! A machine profile from a Marlin board's `M503` report (`gweave machine from-m503`).
//!
//! `M503` prints the settings in force as the G-code that would set them, one command a line,
//! each after `echo:` (and after `Recv: ` in an OctoPrint terminal log):
//!
//! ```text
//! echo:  M92 X80.00 Y80.00 Z400.00 E93.00
//! echo:  M203 X500.00 Y500.00 Z5.00 E25.00
//! echo:  M201 X500.00 Y500.00 Z100.00 E5000.00
//! echo:  M204 P500.00 R500.00 T500.00
//! echo:  M205 B20000.00 S0.00 T0.00 J0.08
//! echo:  M301 P21.73 I1.54 D76.55
//! ```
//!
//! Read here: `M92` (steps per mm), `M201`, `M203`, `M204` (`S` as print and travel on old
//! boards), `M205` (`B` the minimum segment time; `J` means a junction-deviation build, `X Y Z
//! E` without `J` a classic-jerk one), `M301` and `M304` (hotend and bed PID); `M92`, `M201`
//! and `M203` with `T1` ... (`DISTINCT_E_FACTORS`) give that extruder its own E values. `M851`
//! (the probe offset) has no place in a machine profile and is returned as a note, so are
//! settings gweave does not model (`M900` linear advance, `M205 S T` minimum feed rates).

use thiserror::Error;

use crate::motion::limits::{AxisUpdate, CornerMode, ExtruderLimits, Jerk, ProfileError, M204};
use crate::motion::marlin_limits::MAX_EXTRUDERS;
use crate::profile::{MachineProfile, MachineProfileError};
use crate::thermal::control::{ControlConfig, PidConfig, PidGains};

/// Why an `M503` report could not be read.
#[derive(Debug, PartialEq, Error)]
pub enum M503Error {
    /// A value is not a finite number (`Yfast`, or `X1e400`, which overflows to infinity).
    #[error("line {line}: `{word}` is not a number")]
    NotANumber {
        /// 1-based line of the report.
        line: usize,
        /// The word.
        word: String,
    },
    /// A value is out of range.
    #[error("line {line}: {source}")]
    Profile {
        /// 1-based line of the report.
        line: usize,
        /// What is wrong.
        source: ProfileError,
    },
    /// `M92`, `M201` or `M203` names an extruder a Marlin build cannot have.
    #[error("line {line}: {command} T{tool}: no such extruder (a Marlin build has at most {max}, T0 to T{last})", max = MAX_EXTRUDERS, last = MAX_EXTRUDERS - 1)]
    Extruder {
        /// 1-based line of the report.
        line: usize,
        /// The command, `M92`, `M201` or `M203`.
        command: String,
        /// The extruder as written (it may be huge or fractional).
        tool: String,
    },
    /// A value the command sets is out of the profile's range (the profile
    /// `gweave estimate` would then refuse, e.g. `M205 J1e60`).
    #[error("line {line}: {source}")]
    Machine {
        /// 1-based line of the report.
        line: usize,
        /// What is wrong, naming the profile key.
        source: MachineProfileError,
    },
    /// No motion setting at all: not an `M503` report.
    #[error("no M92, M201, M203, M204 or M205 line: not an M503 report")]
    Empty,
}

/// The profile made, and what the report held that it could not take.
#[derive(Debug, Clone, PartialEq)]
pub struct FromM503 {
    /// The default machine with the report's settings.
    pub profile: MachineProfile,
    /// The lines taken, as written (without `echo:`).
    pub used: Vec<String>,
    /// What was left out and why.
    pub notes: Vec<String>,
}

/// Read an `M503` report onto the default machine.
pub fn from_m503(report: &str) -> Result<FromM503, M503Error> {
    let mut p = MachineProfile::default();
    let (mut used, mut notes) = (Vec::new(), Vec::new());
    for (i, raw) in report.lines().enumerate() {
        let line = i + 1;
        let text = raw.trim().trim_start_matches("Recv:").trim().trim_start_matches("echo:").trim();
        let text = text.split(';').next().unwrap_or("").trim();
        let mut words = text.split_whitespace();
        let Some(command) = words.next() else { continue };
        let mut values = Vec::new();
        for w in words {
            let (letter, number) = w.split_at(w.chars().next().map_or(0, char::len_utf8));
            let not_a_number = || M503Error::NotANumber { line, word: w.to_owned() };
            let v = number.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(not_a_number)?;
            values.push((letter.to_ascii_uppercase(), v));
        }
        let get = |l: &str| values.iter().find(|(k, _)| k == l).map(|(_, v)| *v);
        let command = command.to_ascii_uppercase();
        // `T` is the extruder in M92, M201 and M203 (M204's T is travel, M205's the minimum
        // travel feed rate): another extruder's E (`DISTINCT_E_FACTORS`).
        let per_tool = matches!(command.as_str(), "M92" | "M201" | "M203");
        if let (true, Some(t), Some(e)) = (per_tool, get("T").filter(|&t| t >= 1.0), get("E")) {
            // The tool sizes the list of extruders: held to the build's ceiling first.
            if !(t.fract() == 0.0 && t < MAX_EXTRUDERS as f64) {
                let tool = if t.fract() == 0.0 { gweave::range::count(t) } else { gweave::range::short(t) };
                return Err(M503Error::Extruder { line, command, tool });
            }
            let tool = t as usize;
            let extruders = &mut p.motion.extruders;
            if extruders.len() <= tool {
                extruders.resize(tool + 1, ExtruderLimits::default());
            }
            let slot = match command.as_str() {
                "M92" => &mut extruders[tool].steps_per_mm,
                "M201" => &mut extruders[tool].max_accel_mm_s2,
                _ => &mut extruders[tool].max_feed_mm_s,
            };
            *slot = Some(e);
            p.motion.validate().map_err(|source| M503Error::Profile { line, source })?;
            used.push(text.to_owned());
            continue;
        }
        let axes = || AxisUpdate { x: get("X"), y: get("Y"), z: get("Z"), e: get("E"), a: None };
        let m = &mut p.motion;
        let result = match command.as_str() {
            "M92" => {
                let s = &mut m.steps;
                for (slot, v) in
                    [(&mut s.x, get("X")), (&mut s.y, get("Y")), (&mut s.z, get("Z")), (&mut s.e, get("E"))]
                {
                    *slot = v.unwrap_or(*slot);
                }
                m.validate()
            }
            "M201" => m.set_max_accel(&axes()),
            "M203" => m.set_max_feed(&axes()),
            "M204" => m.set_accel(&M204 { s: get("S"), p: get("P"), r: get("R"), t: get("T") }),
            "M205" => {
                set_corners(&mut m.corners, get("J"), axes());
                if get("S").is_some_and(|s| s > 0.0) || get("T").is_some_and(|t| t > 0.0) {
                    notes.push(format!("{text}: minimum feed rates (S, T) are not modelled"));
                }
                m.set_jerk(&AxisUpdate::default(), get("B"))
            }
            "M301" | "M304" => {
                let gains = PidGains {
                    kp: get("P").unwrap_or(0.0),
                    ki: get("I").unwrap_or(0.0),
                    kd: get("D").unwrap_or(0.0),
                };
                let pid = ControlConfig::Pid(PidConfig { gains, ..pid_defaults() });
                if command == "M301" {
                    p.thermal.hotend_control = pid;
                } else {
                    p.thermal.bed_control = pid;
                }
                Ok(())
            }
            "M851" => {
                notes.push(format!("{text}: the probe offset has no place in a machine profile"));
                continue;
            }
            _ => {
                if command.starts_with(['M', 'm']) {
                    notes.push(format!("{text}: not used"));
                }
                continue;
            }
        };
        result.map_err(|source| M503Error::Profile { line, source })?;
        // Every key the line set, in the machine's ranges: a value `estimate` and `sim` would
        // refuse is refused here, at its line.
        p.validate().map_err(|source| M503Error::Machine { line, source })?;
        used.push(text.to_owned());
    }
    if !used.iter().any(|u| ["M92", "M201", "M203", "M204", "M205"].iter().any(|c| u.starts_with(c))) {
        return Err(M503Error::Empty);
    }
    p.name = "from M503".to_owned();
    Ok(FromM503 { profile: p, used, notes })
}

/// `M205 J` (junction deviation) or `M205 X Y Z E` (classic jerk): the build's corner rule.
fn set_corners(corners: &mut CornerMode, j: Option<f64>, jerk: AxisUpdate) {
    let CornerMode::Marlin { junction_deviation_mm, jerk_mm_s, .. } = corners else { return };
    if let Some(j) = j {
        (*junction_deviation_mm, *jerk_mm_s) = (Some(j), None);
    } else if jerk.x.is_some() || jerk.y.is_some() {
        let d = jerk_mm_s.unwrap_or(Jerk { x: 10.0, y: 10.0, z: 0.3, e: 5.0 });
        let j = Jerk {
            x: jerk.x.unwrap_or(d.x),
            y: jerk.y.unwrap_or(d.y),
            z: jerk.z.unwrap_or(d.z),
            e: jerk.e.unwrap_or(d.e),
        };
        (*junction_deviation_mm, *jerk_mm_s) = (None, Some(j));
    }
}

/// The PID settings other than the gains, as a profile's default PID has them.
fn pid_defaults() -> PidConfig {
    match crate::thermal::ThermalConfig::default().hotend_control {
        ControlConfig::Pid(c) => c,
        ControlConfig::BangBang(_) => unreachable!("the default hotend control is a PID"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::limits::MarlinCorners;

    const ENDER3: &str = "Recv: echo:; Steps per unit:\nRecv: echo:  M92 X80.00 Y80.00 Z400.00 E93.00\n\
        echo:; Maximum feedrates (units/s):\necho:  M203 X500.00 Y500.00 Z5.00 E25.00\n\
        echo:  M201 X500.00 Y500.00 Z100.00 E5000.00\necho:  M204 P500.00 R500.00 T1000.00\n\
        echo:  M205 B20000.00 S0.00 T0.00 X10.00 Y10.00 Z0.30 E5.00\necho:  M301 P21.73 I1.54 D76.55\n\
        echo:  M304 P462.10 I85.47 D624.59\necho:  M851 X-40.00 Y-10.00 Z-1.50\necho:  M900 K0.00\nok\n";

    #[test]
    fn ender3_report_makes_a_classic_jerk_profile() {
        let r = from_m503(ENDER3).unwrap();
        let m = &r.profile.motion;
        assert_eq!((m.steps.x, m.steps.z, m.steps.e), (80.0, 400.0, 93.0));
        assert_eq!(m.max_feed_mm_s.to_array()[..4], [500.0, 500.0, 5.0, 25.0]);
        assert_eq!(m.max_accel_mm_s2.to_array()[..4], [500.0, 500.0, 100.0, 5000.0]);
        assert_eq!((m.accel.print_mm_s2, m.accel.travel_mm_s2), (500.0, 1000.0));
        let jerk = Jerk { x: 10.0, y: 10.0, z: 0.3, e: 5.0 };
        assert_eq!(m.corners.marlin_corners(), Some(MarlinCorners::Jerk(jerk)));
        let ControlConfig::Pid(hotend) = r.profile.thermal.hotend_control else { panic!() };
        assert_eq!(hotend.gains, PidGains { kp: 21.73, ki: 1.54, kd: 76.55 });
        assert!(matches!(r.profile.thermal.bed_control, ControlConfig::Pid(c) if c.gains.kp == 462.1));
        assert_eq!(r.used.len(), 7);
        assert_eq!(r.notes.len(), 2, "{:?}", r.notes);
        assert!(r.notes[0].starts_with("M851 X-40.00"), "{:?}", r.notes);
        // The profile written out reads back the same.
        let again = MachineProfile::from_toml_str(&toml::to_string(&r.profile).unwrap()).unwrap();
        assert_eq!(again, r.profile);
    }

    #[test]
    fn junction_deviation_build_and_bad_reports() {
        let r = from_m503("echo:  M205 B20000.00 S0.00 T0.00 J0.02\necho:  M203 T1 E12.00\n").unwrap();
        assert_eq!(r.profile.motion.corners.marlin_corners(), Some(MarlinCorners::JunctionDeviation(0.02)));
        assert_eq!(r.profile.motion.extruders[1].max_feed_mm_s, Some(12.0));
        assert_eq!(r.profile.motion.extruders[0], ExtruderLimits::default());
        assert_eq!(from_m503("ok\nT:210 /210\n"), Err(M503Error::Empty));
        let bad = from_m503("echo:  M203 X500.00 Yfast\n");
        assert_eq!(bad, Err(M503Error::NotANumber { line: 1, word: "Yfast".to_owned() }));
        // Regression: `X1e400` was reported as `x = inf is out of range`, a value the user never wrote.
        let huge = from_m503("echo:  M92 X1e400 Y80.00\n");
        assert_eq!(huge, Err(M503Error::NotANumber { line: 1, word: "X1e400".to_owned() }));
        let zero = from_m503("echo:  M201 X0\n");
        assert!(matches!(zero, Err(M503Error::Profile { line: 1, .. })), "{zero:?}");
    }
}
