//! The options of `gweave mix` and `gweave.mix()`, declared once ([`crate::options`]), and how
//! they apply over the profile ([`MixProfile::apply`]).

use std::path::PathBuf;

use super::profile::{GradientSpace, GradientSpec, MixProfile, ScheduleEntry};
use super::MixPassError;
use crate::firmware::MixCommands;
use crate::options::Shape;
use crate::range::PURGE_MM;

crate::word_option!(GradientSpace);
crate::word_option!(MixCommands);

crate::job_options! {
    /// What a mix run is given besides its file: the profile, and what adds to it (lists) or
    /// replaces its values.
    pub struct MixOptions for "mix" {
        /// The hardware profile and job (TOML); with --wizard, where to write it.
        config: Option<PathBuf> = Shape::new("TOML").short('c'),
        /// From this layer (0-based) on, print this mix: `10=Pink`, `0=#ff8800`, `5=Orange@0.3`.
        at_layer: Vec<String> = Shape::new("LAYER=MIX"),
        /// From this height (mm) on, print this mix: `2.5=Blue`.
        at_z: Vec<String> = Shape::new("Z=MIX"),
        /// Slicer tool to mix: `T0=Orange`, `T1=support` (100 % of the material-2 input, E3), or
        /// a material an input holds (`T1=PVA` with a profile that loads PVA, e.g.
        /// examples/mix/pva_support.toml).
        map: Vec<String> = Shape::new("TN=MIX"),
        /// A gradient: `0-50=Cyan..Magenta`, `0-50/2=...` (every 2 layers), `z1-8=...` (heights).
        gradient: Vec<String> = Shape::new("RANGE=MIX..MIX"),
        /// How the gradients blend: `mix` (a straight line between the ratios) or `perceived`
        /// (equal steps of perceived colour).
        gradient_space: GradientSpace = Shape::new("SPACE"),
        /// Firmware dialect: marlin (M163/M164), marlin-direct (M165) or reprapfirmware
        /// (M563/M567; `reprap` still accepted); overrides the profile. Default: the profile's,
        /// else the file's flavour (reprapfirmware for `gcode_flavor = reprapfirmware`), else
        /// marlin.
        dialect: Option<MixCommands> = Shape::new("DIALECT"),
        /// Purge length at each change, mm of filament (0: no purge) [default: the profile's].
        purge_mm: Option<f64> = Shape::new("MM").range(PURGE_MM),
        /// Purge this much (mm of filament) in the first mix before the file's first extrusion,
        /// to clear what the chamber held [default: the profile's `[purge] initial_mm`].
        initial_purge: Option<f64> = Shape::new("MM").range(PURGE_MM),
    }
}

impl MixProfile {
    /// Applies `o` on top of the profile (lists add to its entries, values replace its own),
    /// then validates the result.
    pub fn apply(&mut self, o: &MixOptions) -> Result<(), MixPassError> {
        for s in &o.at_layer {
            self.schedule.push(ScheduleEntry::parse_layer(s)?);
        }
        for s in &o.at_z {
            self.schedule.push(ScheduleEntry::parse_z(s)?);
        }
        for s in &o.gradient {
            self.gradient.push(GradientSpec::parse(s, o.gradient_space)?);
        }
        for s in &o.map {
            self.add_map(s)?;
        }
        if let Some(d) = o.dialect {
            self.hardware.dialect = Some(d);
        }
        if let Some(mm) = o.purge_mm {
            self.purge.set_length_mm(mm);
        }
        if let Some(mm) = o.initial_purge {
            self.purge.initial_mm = mm;
        }
        self.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::{JobOptions, Spelling, Value};

    #[test]
    fn options_add_to_the_profile_and_replace_its_values() {
        let mut p = MixProfile::from_toml_str("[[schedule]]\nlayer = 0\nmix = \"Red\"\n").unwrap();
        let o = MixOptions {
            at_layer: vec!["5=Blue".into()],
            purge_mm: Some(12.0),
            initial_purge: Some(3.0),
            ..MixOptions::default()
        };
        p.apply(&o).unwrap();
        assert_eq!(p.schedule.len(), 2);
        assert_eq!((p.purge.length_mm, p.purge.initial_mm), (12.0, 3.0));
        let bad = MixOptions { map: vec!["X1=Red".into()], ..MixOptions::default() };
        assert!(p.apply(&bad).is_err());
    }

    #[test]
    fn words_are_read_as_the_profile_reads_them_and_written_back_canonical() {
        let mut o = MixOptions::default();
        let space = MixOptions::spec("gradient_space").unwrap();
        assert_eq!((space.default)().as_deref(), Some("mix"));
        o.set(space, Value::Text("perceived".into())).unwrap();
        let err = o.set(space, Value::Text("lab".into())).unwrap_err();
        assert_eq!(
            err.spelled(Spelling::Flag),
            "--gradient-space: unknown variant `lab`, expected `mix` or `perceived`"
        );
        o.set(MixOptions::spec("dialect").unwrap(), Value::Text("reprap".into())).unwrap();
        o.set(
            MixOptions::spec("at_layer").unwrap(),
            Value::Texts(vec!["0=Dark Red".into(), "5=Blue".into()]),
        )
        .unwrap();
        assert_eq!(
            o.header(),
            r#"--at-layer "0=Dark Red" --at-layer 5=Blue --gradient-space perceived --dialect reprapfirmware"#
        );
    }
}
