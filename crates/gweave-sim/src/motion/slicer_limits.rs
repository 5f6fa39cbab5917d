//! The machine limits a slicer wrote into its G-code, as a motion profile: what
//! `gweave estimate --machine slicer` plans with.
//!
//! - The PrusaSlicer family (PrusaSlicer, SuperSlicer, OrcaSlicer) ends every file with its
//!   settings, one `; key = value` a line. The machine limits are `machine_max_acceleration_x`
//!   (`y`, `z`, `e`), `machine_max_feedrate_*`, `machine_max_jerk_*`,
//!   `machine_max_acceleration_extruding` (M204 P), `_retracting` (R) and `_travel` (T), and
//!   OrcaSlicer's `machine_max_junction_deviation`; each holds the normal mode's value, then the
//!   stealth mode's (`9000,1000`): the first is used, the second by [`slicer_limits_both`]
//!   (for PrusaSlicer's silent-mode estimate; the first if there is no second).
//!   `gcode_flavor = klipper` plans with Klipper's rules, every other flavour with Marlin's.
//! - Cura puts the settings changed from the printer's definition in `;SETTING_3` lines at the
//!   end (`machine_max_feedrate_x`, `machine_max_acceleration_x`, `machine_acceleration`,
//!   `machine_max_jerk_xy`, `machine_max_jerk_z`, `machine_max_jerk_e`) and the flavour in its
//!   `;FLAVOR:` header line.
//!
//! Corners follow the slicer's own estimate: classic jerk from `machine_max_jerk_*` (what
//! PrusaSlicer times with), junction deviation when the file gives one. Values the file does not
//! give keep the base profile's (steps per mm are never in the file).

use std::collections::BTreeMap;

use gweave::gcode::ends::lines_naming;
use thiserror::Error;

use crate::motion::limits::{
    CornerMode, Jerk, KlipperLimits, MotionProfile, ProfileError, MARLIN_JUNCTION_DEVIATION_MM,
};

/// Why a file's own limits cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SlicerLimitsError {
    /// The file has none of the settings above.
    #[error("the file holds no machine limits (PrusaSlicer's `; machine_max_...` settings or Cura's `;SETTING_3` machine_max_... values)")]
    None,
    /// A setting is there but is not a number.
    #[error("slicer setting `{key} = {value}` is not a number")]
    NotANumber {
        /// The setting.
        key: String,
        /// Its text.
        value: String,
    },
    /// The limits make no valid profile (a zero acceleration, say).
    #[error("slicer settings: {0}")]
    Profile(#[from] ProfileError),
}

/// A profile made from a file's settings, and what was taken from where.
#[derive(Debug, Clone, PartialEq)]
pub struct SlicerLimits {
    /// The profile to plan with.
    pub profile: MotionProfile,
    /// `PrusaSlicer` (the family) or `Cura`.
    pub slicer: &'static str,
    /// The flavour the file names, if any.
    pub flavour: Option<String>,
    /// Every setting used, `key = value` as written.
    pub used: Vec<String>,
}

/// Read the limits from `text` (the head and tail of a file are enough: the settings are in the
/// first or the last few hundred KB) onto `base`.
pub fn slicer_limits(text: &[u8], base: &MotionProfile) -> Result<SlicerLimits, SlicerLimitsError> {
    limits_of_mode(&Written::read(text), base, 0)
}

/// The limits of both modes, normal ([`slicer_limits`]) and stealth (silent: the second of each
/// pair of values), with the settings read once (a few million instructions for the 256 KiB
/// ends of a file: a transform's metadata needs both).
pub(crate) fn slicer_limits_both(
    text: &[u8],
    base: &MotionProfile,
) -> [Result<SlicerLimits, SlicerLimitsError>; 2] {
    let written = Written::read(text);
    [0, 1].map(|mode| limits_of_mode(&written, base, mode))
}

/// The settings a slicer wrote, by key, which slicer, and the flavour the file names.
struct Written {
    settings: BTreeMap<String, String>,
    slicer: &'static str,
    flavour: Option<String>,
}

impl Written {
    fn read(text: &[u8]) -> Self {
        let text = gweave::gcode::ends::ends_text(text);
        let (settings, slicer) = match prusa_settings(&text) {
            s if !s.is_empty() => (s, "PrusaSlicer"),
            _ => (cura_settings(&text), "Cura"),
        };
        let flavour = settings.get("gcode_flavor").cloned().or_else(|| {
            text.lines().find_map(|l| l.trim().strip_prefix(";FLAVOR:")).map(|f| f.trim().to_owned())
        });
        Written { settings, slicer, flavour }
    }
}

/// The limits of mode `mode` (0 normal, 1 stealth): the value at that place in each list, or
/// the first.
fn limits_of_mode(
    written: &Written,
    base: &MotionProfile,
    mode: usize,
) -> Result<SlicerLimits, SlicerLimitsError> {
    let Written { settings, slicer, flavour } = written;
    let (slicer, flavour) = (*slicer, flavour.clone());
    let mut used = Vec::new();
    let mut get = |key: &str| -> Result<Option<f64>, SlicerLimitsError> {
        let Some(value) = settings.get(key) else {
            return Ok(None);
        };
        // Normal mode first, stealth mode second.
        let first = value.split(',').nth(mode).or(value.split(',').next()).unwrap_or("").trim();
        let v = first
            .parse::<f64>()
            .map_err(|_| SlicerLimitsError::NotANumber { key: key.to_owned(), value: value.clone() })?;
        used.push(format!("{key} = {first}"));
        Ok(Some(v))
    };
    let mut p = base.clone();
    let mut any = false;
    for (axis, slot_feed, slot_accel) in [
        ("x", &mut p.max_feed_mm_s.x, &mut p.max_accel_mm_s2.x),
        ("y", &mut p.max_feed_mm_s.y, &mut p.max_accel_mm_s2.y),
        ("z", &mut p.max_feed_mm_s.z, &mut p.max_accel_mm_s2.z),
        ("e", &mut p.max_feed_mm_s.e, &mut p.max_accel_mm_s2.e),
    ] {
        if let Some(v) = get(&format!("machine_max_feedrate_{axis}"))? {
            (*slot_feed, any) = (v, true);
        }
        if let Some(v) = get(&format!("machine_max_acceleration_{axis}"))? {
            (*slot_accel, any) = (v, true);
        }
    }
    let extruding = get("machine_max_acceleration_extruding")?.or(get("machine_acceleration")?);
    if let Some(a) = extruding {
        any = true;
        p.accel.print_mm_s2 = a;
        p.accel.retract_mm_s2 = get("machine_max_acceleration_retracting")?.filter(|&r| r > 0.0).unwrap_or(a);
        // PrusaSlicer leaves travel at 0 for "as extruding".
        p.accel.travel_mm_s2 = get("machine_max_acceleration_travel")?.filter(|&t| t > 0.0).unwrap_or(a);
    }
    let xy = get("machine_max_jerk_xy")?;
    let jerk = [
        get("machine_max_jerk_x")?.or(xy),
        get("machine_max_jerk_y")?.or(xy),
        get("machine_max_jerk_z")?,
        get("machine_max_jerk_e")?,
    ];
    let jd = get("machine_max_junction_deviation")?.filter(|&j| j > 0.0);
    if !any && jerk.iter().all(Option::is_none) && jd.is_none() {
        return Err(SlicerLimitsError::None);
    }
    let klipper = flavour.as_deref().is_some_and(|f| f.eq_ignore_ascii_case("klipper"));
    p.corners = if klipper {
        CornerMode::Klipper(KlipperLimits {
            max_velocity_mm_s: p.max_feed_mm_s.x.max(p.max_feed_mm_s.y),
            max_accel_mm_s2: p.accel.print_mm_s2,
            ..KlipperLimits::default()
        })
    } else {
        marlin_corners(&base.corners, jerk, jd)
    };
    p.validate()?;
    Ok(SlicerLimits { profile: p, slicer, flavour, used })
}

/// Junction deviation when the file gives one, else classic jerk when it gives any jerk (the
/// others from the base, or Marlin's defaults), else the base's rule (Marlin's default on a
/// Klipper or constant-speed base).
fn marlin_corners(base: &CornerMode, jerk: [Option<f64>; 4], jd: Option<f64>) -> CornerMode {
    let (lookahead_blocks, min_segment_time_us, base_jerk) = match *base {
        CornerMode::Marlin { lookahead_blocks, min_segment_time_us, jerk_mm_s, .. } => {
            (lookahead_blocks, min_segment_time_us, jerk_mm_s)
        }
        CornerMode::Klipper(_) | CornerMode::Constant {} => match CornerMode::default() {
            CornerMode::Marlin { lookahead_blocks, min_segment_time_us, .. } => {
                (lookahead_blocks, min_segment_time_us, None)
            }
            CornerMode::Klipper(_) | CornerMode::Constant {} => unreachable!("the default is Marlin"),
        },
    };
    let defaults = base_jerk.unwrap_or(Jerk { x: 10.0, y: 10.0, z: 0.3, e: 5.0 });
    let (junction_deviation_mm, jerk_mm_s) = match (jd, jerk.iter().any(Option::is_some)) {
        (Some(j), _) => (Some(j), None),
        (None, true) => (
            None,
            Some(Jerk {
                x: jerk[0].unwrap_or(defaults.x),
                y: jerk[1].unwrap_or(defaults.y),
                z: jerk[2].unwrap_or(defaults.z),
                e: jerk[3].unwrap_or(defaults.e),
            }),
        ),
        (None, false) => match *base {
            CornerMode::Marlin { junction_deviation_mm, jerk_mm_s, .. } => (junction_deviation_mm, jerk_mm_s),
            CornerMode::Klipper(_) | CornerMode::Constant {} => (Some(MARLIN_JUNCTION_DEVIATION_MM), None),
        },
    };
    CornerMode::Marlin { junction_deviation_mm, jerk_mm_s, lookahead_blocks, min_segment_time_us }
}

/// PrusaSlicer's `; key = value` lines.
fn prusa_settings(text: &str) -> BTreeMap<String, String> {
    // Only the lines that name a key kept are looked at (3.3 M instructions a read of the ends
    // when every line was trimmed and split, twice a transform).
    lines_naming(text, &["machine_", "gcode_flavor"])
        .filter_map(|l| l.trim().strip_prefix(';'))
        .filter_map(|l| l.split_once(" = "))
        // Only the keys kept are copied: a PrusaSlicer file has some 300 settings.
        .filter_map(|(k, v)| {
            let k = k.trim();
            (k.starts_with("machine_") || k == "gcode_flavor").then(|| (k.to_owned(), v.trim().to_owned()))
        })
        .collect()
}

/// Cura's `;SETTING_3` lines: one serialised document cut into lines, whose `[values]`
/// sections hold `key = value` separated by escaped newlines (`\\\\n` in the file).
fn cura_settings(text: &str) -> BTreeMap<String, String> {
    let joined: String = text.lines().filter_map(|l| l.strip_prefix(";SETTING_3 ")).collect();
    joined
        .replace("\\\\n", "\n")
        .replace("\\n", "\n")
        .lines()
        .filter_map(|l| l.split_once(" = "))
        .map(|(k, v)| (k.trim().to_owned(), v.trim().trim_end_matches(['"', '}', ',']).to_owned()))
        .filter(|(k, _)| k.starts_with("machine_"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::limits::MarlinCorners;

    const PRUSA_TAIL: &str = "G1 X1 E1\n; filament used [mm] = 1.0\n; gcode_flavor = marlin2\n\
        ; machine_limits_usage = time_estimate_only\n\
        ; machine_max_acceleration_e = 10000,5000\n; machine_max_acceleration_extruding = 1500,1250\n\
        ; machine_max_acceleration_retracting = 1500,1250\n; machine_max_acceleration_travel = 0,0\n\
        ; machine_max_acceleration_x = 9000,1000\n; machine_max_acceleration_y = 9000,1000\n\
        ; machine_max_acceleration_z = 500,200\n; machine_max_feedrate_e = 120,120\n\
        ; machine_max_feedrate_x = 500,200\n; machine_max_feedrate_y = 500,200\n\
        ; machine_max_feedrate_z = 12,12\n; machine_max_jerk_e = 2.5,2.5\n; machine_max_jerk_x = 10,10\n\
        ; machine_max_jerk_y = 10,10\n; machine_max_jerk_z = 0.2,0.4\n";

    /// PrusaSlicer's silent-mode estimate plans with the second of each pair.
    #[test]
    fn prusaslicer_silent_mode_limits() {
        let l = {
            let [_, silent] = slicer_limits_both(PRUSA_TAIL.as_bytes(), &MotionProfile::default());
            silent.unwrap()
        };
        let p = &l.profile;
        assert_eq!(p.max_accel_mm_s2.to_array()[..4], [1000.0, 1000.0, 200.0, 5000.0]);
        assert_eq!(p.max_feed_mm_s.to_array()[..4], [200.0, 200.0, 12.0, 120.0]);
        assert_eq!((p.accel.print_mm_s2, p.accel.retract_mm_s2), (1250.0, 1250.0));
        let jerk = Jerk { x: 10.0, y: 10.0, z: 0.4, e: 2.5 };
        assert_eq!(p.corners.marlin_corners(), Some(MarlinCorners::Jerk(jerk)));
        // One value: the same in both modes.
        let one = "; machine_max_acceleration_x = 700\n";
        let l = {
            let [_, silent] = slicer_limits_both(one.as_bytes(), &MotionProfile::default());
            silent.unwrap()
        };
        assert_eq!(l.profile.max_accel_mm_s2.x, 700.0);
    }

    #[test]
    fn prusaslicer_normal_mode_limits_and_classic_jerk() {
        let l = slicer_limits(PRUSA_TAIL.as_bytes(), &MotionProfile::default()).unwrap();
        let p = &l.profile;
        assert_eq!((l.slicer, l.flavour.as_deref()), ("PrusaSlicer", Some("marlin2")));
        assert_eq!(p.max_accel_mm_s2.to_array()[..4], [9000.0, 9000.0, 500.0, 10000.0]);
        assert_eq!(p.max_feed_mm_s.to_array()[..4], [500.0, 500.0, 12.0, 120.0]);
        assert_eq!(
            (p.accel.print_mm_s2, p.accel.retract_mm_s2, p.accel.travel_mm_s2),
            (1500.0, 1500.0, 1500.0)
        );
        let jerk = Jerk { x: 10.0, y: 10.0, z: 0.2, e: 2.5 };
        assert_eq!(p.corners.marlin_corners(), Some(MarlinCorners::Jerk(jerk)));
        assert_eq!(p.steps, MotionProfile::default().steps, "steps per mm are never in the file");
        assert!(l.used.contains(&"machine_max_acceleration_x = 9000".to_owned()), "{:?}", l.used);
        assert_eq!(l.used.len(), 15);
    }

    #[test]
    fn klipper_flavour_plans_with_klipper_rules() {
        let text = PRUSA_TAIL.replace("marlin2", "klipper");
        let p = slicer_limits(text.as_bytes(), &MotionProfile::default()).unwrap().profile;
        let CornerMode::Klipper(k) = p.corners else { panic!("{:?}", p.corners) };
        assert_eq!((k.max_velocity_mm_s, k.max_accel_mm_s2), (500.0, 1500.0));
    }

    #[test]
    fn cura_setting_3_values() {
        let text = ";FLAVOR:Marlin\nG1 X1\n;SETTING_3 {\"global_quality\": \"[general]\\\\nversion = 4\\\\n[values]\\\\nmachine_\n\
            ;SETTING_3 max_feedrate_x = 250\\\\nmachine_acceleration = 800\\\\nmachine_max_jerk_xy = 8\\\\n\"}\n";
        let l = slicer_limits(text.as_bytes(), &MotionProfile::default()).unwrap();
        assert_eq!((l.slicer, l.flavour.as_deref()), ("Cura", Some("Marlin")));
        assert_eq!((l.profile.max_feed_mm_s.x, l.profile.accel.travel_mm_s2), (250.0, 800.0));
        let jerk = Jerk { x: 8.0, y: 8.0, z: 0.3, e: 5.0 };
        assert_eq!(l.profile.corners.marlin_corners(), Some(MarlinCorners::Jerk(jerk)));
    }

    #[test]
    fn no_limits_and_bad_numbers_are_errors() {
        assert_eq!(
            slicer_limits(b";FLAVOR:Marlin\nG1 X1\n", &MotionProfile::default()),
            Err(SlicerLimitsError::None)
        );
        let bad = slicer_limits(b"; machine_max_feedrate_x = fast\n", &MotionProfile::default());
        assert!(matches!(bad, Err(SlicerLimitsError::NotANumber { .. })), "{bad:?}");
        let zero = slicer_limits(b"; machine_max_feedrate_x = 0,0\n", &MotionProfile::default());
        assert!(matches!(zero, Err(SlicerLimitsError::Profile(_))), "{zero:?}");
    }

    /// Regression (issue 35): the settings are read only from lines that can hold a key kept
    /// (the ends were trimmed and split line by line, 3-4 M instructions a read). The lines
    /// looked at give what every line gave: on every fixture's ends, and on lines spaced, cut
    /// or named to sit at the edge of the filter.
    #[test]
    fn the_settings_read_from_the_lines_that_can_hold_them_are_every_lines() {
        fn every_line(text: &str) -> BTreeMap<String, String> {
            text.lines()
                .filter_map(|l| l.trim().strip_prefix(';'))
                .filter_map(|l| l.split_once(" = "))
                .filter_map(|(k, v)| {
                    let k = k.trim();
                    (k.starts_with("machine_") || k == "gcode_flavor")
                        .then(|| (k.to_owned(), v.trim().to_owned()))
                })
                .collect()
        }
        let edges = "; machine_max_feedrate_x =\n; machine_max_jerk_y = 3 ; gcode_flavor machine_\r\n  ;  machine_max_jerk_x = 1 \n;machine_a = 2\n\
                     ; gcode_flavor = marlin2\n; gcode_flavorx = 1\nmachine_b = 3\n;\u{a0}machine_c = 4\n\
                     ; machine_d=5\n; machine_e = 6 = 7\n\t; machine_f = 8\t\n; = machine_g\n;\nmachine_";
        assert_eq!(prusa_settings(edges), every_line(edges));
        assert_eq!(prusa_settings(edges).len(), 7, "{:?}", prusa_settings(edges));
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
        let mut read = 0;
        for kind in std::fs::read_dir(data).unwrap() {
            for file in std::fs::read_dir(kind.unwrap().path()).into_iter().flatten() {
                let path = file.unwrap().path();
                if path.extension().is_some_and(|e| e == "gcode") {
                    let ends = gweave::gcode::ends::read_ends(&path).unwrap();
                    let text = gweave::gcode::ends::ends_text(&ends);
                    assert_eq!(prusa_settings(&text), every_line(&text), "{}", path.display());
                    read += usize::from(!prusa_settings(&text).is_empty());
                }
            }
        }
        assert!(read >= 5, "{read} fixtures with settings");
    }
}
