//! The Marlin-only parts of the motion profile: classic jerk beside junction deviation as a
//! corner rule, and extruders with their own E limits (`DISTINCT_E_FACTORS`). The profile's
//! fields are in [`crate::motion::limits`]; this is what they hold and how M205 changes them.

use serde::{Deserialize, Serialize};

use gweave::range::{self};
use gweave::settings::{CheckRanges, Table};
use gweave::OutOfRange;

use crate::motion::limits::{
    non_negative, AxisUpdate, CornerMode, MotionProfile, ProfileError, JERK_MM_S,
    MARLIN_JUNCTION_DEVIATION_MM,
};

/// Classic jerk per axis (`CLASSIC_JERK`, M205 X Y Z E), mm/s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jerk {
    /// X.
    pub x: f64,
    /// Y.
    pub y: f64,
    /// Z.
    pub z: f64,
    /// E.
    pub e: f64,
}

impl Jerk {
    /// X Y Z E.
    pub fn to_array(&self) -> [f64; 4] {
        [self.x, self.y, self.z, self.e]
    }
}

impl CheckRanges for Jerk {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        ["x", "y", "z", "e"]
            .into_iter()
            .zip(self.to_array())
            .try_for_each(|(key, v)| t.check(key, v, JERK_MM_S))
    }
}

/// How a Marlin profile takes corners.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MarlinCorners {
    /// Junction deviation, mm.
    JunctionDeviation(f64),
    /// Classic jerk.
    Jerk(Jerk),
}

impl CornerMode {
    /// A Marlin profile's corner rule; `None` in Klipper and constant mode.
    pub fn marlin_corners(&self) -> Option<MarlinCorners> {
        match *self {
            Self::Marlin { jerk_mm_s: Some(j), .. } => Some(MarlinCorners::Jerk(j)),
            Self::Marlin { junction_deviation_mm, .. } => Some(MarlinCorners::JunctionDeviation(
                junction_deviation_mm.unwrap_or(MARLIN_JUNCTION_DEVIATION_MM),
            )),
            Self::Klipper(_) | Self::Constant {} => None,
        }
    }
}

/// Most extruders a Marlin build drives (`EXTRUDERS` in `Configuration.h`, "[0, 1, 2, 3, 4, 5,
/// 6, 7, 8]"): tools `T0` to `T7`. `extruders` in a profile and `M92/M201/M203 T` in an `M503`
/// report are held to it before anything is sized by them.
pub(crate) const MAX_EXTRUDERS: usize = 8;

/// One extruder's own E limits; `None` takes the shared value.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExtruderLimits {
    /// E steps per mm (M92 T E).
    pub steps_per_mm: Option<f64>,
    /// E maximum feed rate, mm/s (M203 T E).
    pub max_feed_mm_s: Option<f64>,
    /// E maximum acceleration, mm/s² (M201 T E).
    pub max_accel_mm_s2: Option<f64>,
}

impl CheckRanges for ExtruderLimits {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check_opt("steps_per_mm", self.steps_per_mm, range::STEPS_PER_UNIT)?;
        t.check_opt("max_feed_mm_s", self.max_feed_mm_s, range::SPEED_MM_S)?;
        t.check_opt("max_accel_mm_s2", self.max_accel_mm_s2, range::ACCEL_MM_S2)
    }
}

impl MotionProfile {
    /// M205 X Y Z E (classic jerk, mm/s) and B (minimum segment time, µs): the values given
    /// change a Marlin profile; jerk values change only a jerk profile (see
    /// [`MotionProfile::set_junction_deviation`]).
    pub fn set_jerk(
        &mut self,
        m205: &AxisUpdate,
        min_segment_time_us: Option<f64>,
    ) -> Result<(), ProfileError> {
        let CornerMode::Marlin { jerk_mm_s, min_segment_time_us: b, .. } = &mut self.corners else {
            return Ok(());
        };
        let mut next = (*jerk_mm_s, *b);
        if let Some(j) = &mut next.0 {
            let slots = [&mut j.x, &mut j.y, &mut j.z, &mut j.e];
            for ((slot, v), name) in
                slots.into_iter().zip(m205.to_array()).zip(["M205 X", "M205 Y", "M205 Z", "M205 E"])
            {
                if let Some(v) = v {
                    non_negative(name, v)?;
                    *slot = v;
                }
            }
        }
        if let Some(us) = min_segment_time_us {
            non_negative("M205 B", us)?;
            next.1 = us;
        }
        (*jerk_mm_s, *b) = next;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marlin_classic_jerk_profile_and_both_corner_rules_is_an_error() {
        let jerk = "[corners]\nmode = \"marlin\"\njerk_mm_s = { x = 10.0, y = 10.0, z = 0.2, e = 2.5 }\n";
        let p = MotionProfile::from_toml_str(jerk).unwrap();
        let want = Jerk { x: 10.0, y: 10.0, z: 0.2, e: 2.5 };
        assert_eq!(p.corners.marlin_corners(), Some(MarlinCorners::Jerk(want)));
        assert!(matches!(p.corners, CornerMode::Marlin { lookahead_blocks: 16, .. }));
        let both = format!("{jerk}junction_deviation_mm = 0.013\n");
        assert_eq!(MotionProfile::from_toml_str(&both), Err(ProfileError::JerkAndJunctionDeviation));
        let neither = MotionProfile::from_toml_str("[corners]\nmode = \"marlin\"\n").unwrap();
        assert_eq!(neither.corners.marlin_corners(), Some(MarlinCorners::JunctionDeviation(0.013)));
        assert_eq!(MotionProfile::from_toml_str(&toml::to_string(&p).unwrap()), Ok(p));
    }

    #[test]
    fn m205_changes_the_corner_rule_the_profile_has() {
        let mut jerk = MotionProfile::from_toml_str(
            "[corners]\nmode = \"marlin\"\njerk_mm_s = { x = 10.0, y = 10.0, z = 0.2, e = 2.5 }\n",
        )
        .unwrap();
        jerk.set_jerk(&AxisUpdate { x: Some(8.0), e: Some(4.5), ..AxisUpdate::default() }, Some(10_000.0))
            .unwrap();
        jerk.set_junction_deviation(0.02).unwrap();
        let want = Jerk { x: 8.0, y: 10.0, z: 0.2, e: 4.5 };
        assert_eq!(jerk.corners.marlin_corners(), Some(MarlinCorners::Jerk(want)));
        assert!(
            matches!(jerk.corners, CornerMode::Marlin { min_segment_time_us, .. } if min_segment_time_us == 1e4)
        );
        // A junction-deviation build ignores M205 X Y Z E.
        let mut jd = MotionProfile::default();
        jd.set_jerk(&AxisUpdate { x: Some(8.0), ..AxisUpdate::default() }, None).unwrap();
        assert_eq!(jd.corners.marlin_corners(), Some(MarlinCorners::JunctionDeviation(0.013)));
        let bad = jd.set_jerk(&AxisUpdate::default(), Some(-1.0));
        assert_eq!(bad, Err(ProfileError::NotPositive { name: "M205 B", value: -1.0 }));
    }
}
