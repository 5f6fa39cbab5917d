//! The options of `gweave purge-shift` and `gweave.purge_shift()`, declared once
//! ([`crate::options`]), and how they apply over the TOML settings file.

use std::path::PathBuf;

use super::config::PurgeShiftConfig;
use crate::options::Shape;
use crate::range::{FILAMENT_DIAMETER_MM, POSITION_MM, PURGE_MM, PURGE_MM3};

crate::job_options! {
    /// What a purge-shift run is given besides its file: the settings file and the values
    /// that override it.
    pub struct PurgeShiftOptions for "purge-shift" {
        /// TOML settings: per-pair table, colours, washout model, rules (the options given
        /// override it).
        config: Option<PathBuf> = Shape::new("TOML").short('c'),
        /// Purge per change, mm of filament; this, purge-mm3 or the config's amounts are needed
        /// [default: the config's].
        purge_mm: Option<f64> = Shape::new("MM").range(PURGE_MM).aliases(&["purge"]).conflicts(&["purge_mm3"]),
        /// Purge per change as a volume, mm^3 (converted with the filament diameter)
        /// [default: the config's].
        purge_mm3: Option<f64> = Shape::new("MM3").range(PURGE_MM3),
        /// Filament diameter, mm [default: the config's, else 1.75].
        filament_diameter: Option<f64> = Shape::new("MM").range(FILAMENT_DIAMETER_MM),
        /// Allow a change to move back into the previous layer.
        cross_layers: bool = Shape::new(""),
        /// Features the change may move through, comma separated [default: all but
        /// outer_wall].
        allow_features: Option<Vec<String>> = Shape::new("LIST"),
        /// Explicit print-proper markers: the comment texts `begin,end` [default: the
        /// slicer's own comments detected].
        markers: Option<[String; 2]> = Shape::new("BEGIN,END"),
        /// Too little room: `partial` (accept the shortfall), `block` (purge the rest in a
        /// purge block, as mix does) or `tower` (purge the rest on a small tower beside the
        /// part) [default: the config's, else partial].
        fallback: Option<String> = Shape::new("NAME"),
        /// The tower's corner `X,Y`, mm [default: beside the print's extent so far].
        tower_at: Option<[f64; 2]> = Shape::new("X,Y").range(POSITION_MM),
    }
}

impl PurgeShiftConfig {
    /// Applies the options given over the settings file's: a purge given replaces the file's
    /// (mm or mm^3).
    pub fn apply(&mut self, o: &PurgeShiftOptions) {
        if let Some(mm) = o.purge_mm {
            (self.purge_mm, self.purge_mm3) = (Some(mm), None);
        }
        if let Some(v) = o.purge_mm3 {
            (self.purge_mm, self.purge_mm3) = (None, Some(v));
        }
        if let Some(d) = o.filament_diameter {
            self.filament_diameter_mm = d;
        }
        self.cross_layers |= o.cross_layers;
        if let Some(list) = &o.allow_features {
            self.allow_features = list.iter().map(|s| s.trim().to_string()).collect();
        }
        if let Some(m) = &o.markers {
            self.markers = Some(m.clone());
        }
        if let Some(f) = &o.fallback {
            self.fallback = f.clone();
        }
        if let Some([x, y]) = o.tower_at {
            (self.tower.x_mm, self.tower.y_mm) = (Some(x), Some(y));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::{JobOptions, Problem, Spelling, Value};

    fn set(o: &mut PurgeShiftOptions, name: &str, value: Value) -> Result<(), crate::options::OptionError> {
        o.set(PurgeShiftOptions::spec(name).unwrap(), value)
    }

    #[test]
    fn the_header_names_every_option_given_in_the_clis_words() {
        let mut o = PurgeShiftOptions::default();
        set(&mut o, "config", Value::Path("a b.toml".into())).unwrap();
        set(&mut o, "purge_mm", Value::Number(2.5)).unwrap();
        set(&mut o, "cross_layers", Value::Flag(true)).unwrap();
        set(&mut o, "allow_features", Value::Texts(vec!["infill".into(), "skirt".into()])).unwrap();
        set(&mut o, "markers", Value::Texts(vec!["B".into(), "E".into()])).unwrap();
        set(&mut o, "tower_at", Value::Numbers(vec![10.0, -20.5])).unwrap();
        assert_eq!(
            o.header(),
            r#"-c "a b.toml" --purge-mm 2.5 --cross-layers --allow-features infill,skirt --markers B,E --tower-at 10,-20.5"#
        );
        assert_eq!(PurgeShiftOptions::default().header(), "");
    }

    #[test]
    fn a_value_out_of_its_range_names_the_option_as_each_front_end_spells_it() {
        let mut o = PurgeShiftOptions::default();
        let err = set(&mut o, "tower_at", Value::Numbers(vec![0.0, 1e6])).unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), "--tower-at 1000000 is out of range: -10000 to 10000 mm");
        assert_eq!(err.spelled(Spelling::Keyword), "tower_at = 1000000 is out of range: -10000 to 10000 mm");
        let err = set(&mut o, "markers", Value::Texts(vec!["only".into()])).unwrap_err();
        assert_eq!(err.problem, Problem::Count { expected: 2, got: 1, value_name: "BEGIN,END" });
        assert_eq!(err.spelled(Spelling::Flag), "--markers: takes 2 values (BEGIN,END), not 1");
        assert_eq!(o, PurgeShiftOptions::default(), "a refused value leaves the option unset");
    }

    #[test]
    fn purge_mm_and_purge_mm3_exclude_each_other() {
        let mut o = PurgeShiftOptions { purge_mm: Some(2.0), purge_mm3: Some(5.0), ..Default::default() };
        let err = o.check_conflicts().unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), "--purge-mm and --purge-mm3: give one of them");
        assert_eq!(err.spelled(Spelling::Keyword), "purge_mm and purge_mm3: give one of them");
        o.purge_mm3 = None;
        assert_eq!(o.check_conflicts(), Ok(()));
    }
}
