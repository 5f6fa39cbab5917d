//! The printable volume `gweave check` holds moves to: given as `X,Y,Z` (from the origin),
//! `X0,Y0,X1,Y1` or `X0,Y0,X1,Y1,Z` (a bed whose corner is not at 0,0, e.g. Prusa's MK3S bed,
//! which reaches Y = -4 for its purge line), or read from the slicer's own settings in the file:
//!
//! - PrusaSlicer, SuperSlicer, OrcaSlicer and Slic3r end a file with `; bed_shape = 0x-4,250x-4,
//!   250x210,0x210` (the bed outline's corners, mm) and `; max_print_height = 210`;
//! - Cura writes `machine_width`, `machine_depth`, `machine_height` and `machine_center_is_zero`
//!   (the bed's origin at its centre) where they differ from the printer definition, in its
//!   `;SETTING_3` footer, and some start G-code prints them as `;machine_width = 220` lines.
//!
//! ```
//! use gweave::Bed;
//! let bed: Bed = "0,-4,250,210,210".parse().unwrap();
//! assert!(bed.contains(1, -3.0) && !bed.contains(1, -5.0));
//! let bed: Bed = "220,220,250".parse().unwrap();
//! assert_eq!((bed.x_mm, bed.y_mm, bed.z_mm), ([0.0, 220.0], [0.0, 220.0], Some(250.0)));
//! let prusa = "G1 X1\n; bed_shape = 0x-4,250x-4,250x210,0x210\n; max_print_height = 210\n";
//! let found = Bed::from_settings(prusa).unwrap();
//! assert_eq!(found.bed.y_mm, [-4.0, 210.0]);
//! ```

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use crate::range::{BED_SIZE_MM, POSITION_MM};

/// A printable box, mm: X and Y as `[min, max]`, Z from 0 to its height (`None`: not checked).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct Bed {
    /// X from and to, mm.
    pub x_mm: [f64; 2],
    /// Y from and to, mm.
    pub y_mm: [f64; 2],
    /// Height, mm (`None`: Z is not checked).
    pub z_mm: Option<f64>,
}

/// A bed the file's own settings describe, and where it was read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlicerBed {
    /// The bed.
    pub bed: Bed,
    /// The settings used, `key = value` as written.
    pub from: Vec<String>,
}

/// Why a bed text was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BedError {
    /// Not 3, 4 or 5 numbers.
    #[error("expected X,Y,Z or X0,Y0,X1,Y1[,Z] (mm), got {0:?}")]
    Count(String),
    /// A part that is not a number.
    #[error("{0:?} is not a number")]
    NotANumber(String),
    /// A number outside its range.
    #[error("{0}")]
    Range(#[from] crate::range::OutOfRange),
    /// A side whose end is not above its start.
    #[error("the bed is empty: {axis}1 = {hi} is not above {axis}0 = {lo}")]
    Empty {
        /// The axis.
        axis: char,
        /// Its start, mm.
        lo: f64,
        /// Its end, mm.
        hi: f64,
    },
}

impl Bed {
    /// A bed from its corner `[x0, y0]` to `[x1, y1]`, `z` high; the corner before the other.
    pub fn new(lo: [f64; 2], hi: [f64; 2], z_mm: Option<f64>) -> Result<Bed, BedError> {
        for (i, axis) in ['X', 'Y'].into_iter().enumerate() {
            POSITION_MM.check(&format!("{axis}0"), lo[i])?;
            POSITION_MM.check(&format!("{axis}1"), hi[i])?;
            if hi[i] <= lo[i] {
                return Err(BedError::Empty { axis, lo: lo[i], hi: hi[i] });
            }
        }
        if let Some(z) = z_mm {
            BED_SIZE_MM.check("Z", z)?;
        }
        Ok(Bed { x_mm: [lo[0], hi[0]], y_mm: [lo[1], hi[1]], z_mm })
    }

    /// Whether `v` lies on the bed along axis 0 (X), 1 (Y) or 2 (Z), within a nanometre.
    pub fn contains(&self, axis: usize, v: f64) -> bool {
        const EPS: f64 = 1e-9;
        let [lo, hi] = match axis {
            0 => self.x_mm,
            1 => self.y_mm,
            _ => [0.0, self.z_mm.unwrap_or(f64::INFINITY)],
        };
        v >= lo - EPS && v <= hi + EPS
    }

    /// The bed the slicer's settings at the ends of the file at `path` describe (see
    /// [`read_ends`](crate::gcode::ends::read_ends)).
    pub fn from_file(path: &std::path::Path) -> std::io::Result<Option<SlicerBed>> {
        Ok(Bed::from_settings(&String::from_utf8_lossy(&crate::gcode::ends::read_ends(path)?)))
    }

    /// The bed the slicer's settings in `text` describe (the head and tail of a file hold
    /// them, [`read_ends`](crate::gcode::ends::read_ends), read as UTF-8 once for every
    /// setting a caller looks up), or `None` when they give none.
    pub fn from_settings(text: &str) -> Option<SlicerBed> {
        let s = crate::gcode::ends::settings(text, &BED_KEYS);
        let z =
            |key: &str| s.get(key).and_then(|v| v.parse::<f64>().ok()).filter(|z| BED_SIZE_MM.contains(*z));
        if let Some(shape) = s.get("bed_shape") {
            let points: Option<Vec<[f64; 2]>> = shape
                .split(',')
                .map(|p| {
                    let (x, y) = p.trim().split_once('x')?;
                    Some([x.trim().parse().ok()?, y.trim().parse().ok()?])
                })
                .collect();
            let points = points.filter(|p| p.len() >= 3)?;
            let lo = [0, 1].map(|i| points.iter().map(|p| p[i]).fold(f64::INFINITY, f64::min));
            let hi = [0, 1].map(|i| points.iter().map(|p| p[i]).fold(f64::NEG_INFINITY, f64::max));
            let height = z("max_print_height");
            let bed = Bed::new(lo, hi, height).ok()?;
            let mut from = vec![format!("bed_shape = {shape}")];
            from.extend(height.map(|h| format!("max_print_height = {h}")));
            return Some(SlicerBed { bed, from });
        }
        let (width, depth) = (z("machine_width")?, z("machine_depth")?);
        let centred = s.get("machine_center_is_zero").is_some_and(|v| v.eq_ignore_ascii_case("true"));
        let (lo, hi) = if centred {
            ([-width / 2.0, -depth / 2.0], [width / 2.0, depth / 2.0])
        } else {
            ([0.0, 0.0], [width, depth])
        };
        let height = z("machine_height");
        let bed = Bed::new(lo, hi, height).ok()?;
        let mut from = vec![format!("machine_width = {width}"), format!("machine_depth = {depth}")];
        from.extend(height.map(|h| format!("machine_height = {h}")));
        if centred {
            from.push("machine_center_is_zero = True".into());
        }
        Some(SlicerBed { bed, from })
    }
}

/// The settings a bed is read from.
const BED_KEYS: [&str; 6] = [
    "bed_shape",
    "max_print_height",
    "machine_width",
    "machine_depth",
    "machine_height",
    "machine_center_is_zero",
];

impl FromStr for Bed {
    type Err = BedError;

    /// `X,Y,Z` (from the origin), `X0,Y0,X1,Y1` (Z not checked) or `X0,Y0,X1,Y1,Z`, mm.
    fn from_str(text: &str) -> Result<Bed, BedError> {
        let numbers: Vec<f64> = text
            .split(',')
            .map(|p| p.trim().parse::<f64>().map_err(|_| BedError::NotANumber(p.trim().to_owned())))
            .collect::<Result<_, _>>()?;
        match numbers[..] {
            [x, y, z] => {
                BED_SIZE_MM.check("X", x)?;
                BED_SIZE_MM.check("Y", y)?;
                Bed::new([0.0, 0.0], [x, y], Some(z))
            }
            [x0, y0, x1, y1] => Bed::new([x0, y0], [x1, y1], None),
            [x0, y0, x1, y1, z] => Bed::new([x0, y0], [x1, y1], Some(z)),
            _ => Err(BedError::Count(text.to_owned())),
        }
    }
}

impl fmt::Display for Bed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "X {} .. {}, Y {} .. {}", self.x_mm[0], self.x_mm[1], self.y_mm[0], self.y_mm[1])?;
        match self.z_mm {
            Some(z) => write!(f, ", Z 0 .. {z} mm"),
            None => write!(f, " mm"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_numbers_are_a_box_from_the_origin_and_five_give_its_corner() {
        let b: Bed = "200,200,200".parse().unwrap();
        assert_eq!(b, Bed { x_mm: [0.0, 200.0], y_mm: [0.0, 200.0], z_mm: Some(200.0) });
        let b: Bed = "-5, -4, 250, 210, 220".parse().unwrap();
        assert_eq!(b, Bed { x_mm: [-5.0, 250.0], y_mm: [-4.0, 210.0], z_mm: Some(220.0) });
        let b: Bed = "0,-4,250,210".parse().unwrap();
        assert!(b.z_mm.is_none() && b.contains(2, 1e6));
    }

    #[test]
    fn a_bed_text_is_refused_with_what_is_wrong() {
        let err = |t: &str| t.parse::<Bed>().unwrap_err().to_string();
        assert_eq!(err("200,200"), "expected X,Y,Z or X0,Y0,X1,Y1[,Z] (mm), got \"200,200\"");
        assert_eq!(err("200,x,200"), "\"x\" is not a number");
        assert_eq!(err("10,0,5,100"), "the bed is empty: X1 = 5 is not above X0 = 10");
        assert_eq!(err("0,200,200"), "X = 0 is out of range: 1 to 10000 mm");
    }

    proptest::proptest! {
        /// A corner, a size and a height written as `--bed` text read back as that box; any
        /// text is read or refused, never a panic.
        #[test]
        fn a_bed_text_reads_back_as_the_box_it_describes(
            x0 in -5000i32..5000, y0 in -5000i32..5000, w in 1i32..5000, d in 1i32..5000, z in 1i32..5000,
            junk in ".{0,40}",
        ) {
            let (x0, y0) = (f64::from(x0) / 10.0, f64::from(y0) / 10.0);
            let (x1, y1, z) = (x0 + f64::from(w) / 10.0, y0 + f64::from(d) / 10.0, f64::from(z));
            let bed: Bed = format!("{x0},{y0},{x1},{y1},{z}").parse().unwrap();
            proptest::prop_assert_eq!(bed, Bed { x_mm: [x0, x1], y_mm: [y0, y1], z_mm: Some(z) });
            proptest::prop_assert!(bed.contains(0, x0) && bed.contains(1, y1) && !bed.contains(2, z + 1.0));
            let _ = junk.parse::<Bed>();
            let _ = Bed::from_settings(&format!("; bed_shape = {junk}\n;SETTING_3 {junk}"));
        }
    }

    #[test]
    fn cura_settings_footer_with_a_centred_origin() {
        let footer =
            ";SETTING_3 {\"global_quality\": \"[general]\\\\nversion = 4\\\\n[values]\\\\nmachine_ce\n\
            ;SETTING_3 nter_is_zero = True\\\\nmachine_depth = 200\\\\nmachine_width = 300\\\\n\"}\n";
        let found = Bed::from_settings(footer).unwrap();
        assert_eq!(found.bed, Bed { x_mm: [-150.0, 150.0], y_mm: [-100.0, 100.0], z_mm: None });
        assert!(Bed::from_settings(";FLAVOR:Marlin\nG1 X1\n").is_none());
    }
}
