//! Settings given as flags (`gweave mix --at-layer 10=Pink`) or Python keywords
//! (`gweave.mix(..., at_layer=["10=Pink"])`), applied over the profile by [`MixProfile::apply`]:
//! the CLI and Python share it, so the two cannot read the same option differently.

use super::profile::{GradientSpace, GradientSpec, MixProfile, ScheduleEntry};
use super::MixPassError;
use crate::firmware::MixCommands;

/// What the command line or Python adds to a profile. Lists add to the profile's own entries;
/// a value replaces the profile's.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// `LAYER=MIX` schedule entries (`10=Pink`).
    pub at_layer: Vec<String>,
    /// `Z=MIX` schedule entries (`2.5=Blue`), mm.
    pub at_z: Vec<String>,
    /// `TN=MIX` tool maps (`T1=PVA`).
    pub map: Vec<String>,
    /// `RANGE=MIX..MIX` gradients (`0-50=Cyan..Magenta`).
    pub gradient: Vec<String>,
    /// How the gradients above blend.
    pub gradient_space: GradientSpace,
    /// How the mixes are written (`--dialect`).
    pub dialect: Option<MixCommands>,
    /// Purge length at each change, mm of filament.
    pub purge_mm: Option<f64>,
    /// Purge before the first extrusion, mm of filament (`[purge] initial_mm`).
    pub initial_purge_mm: Option<f64>,
}

impl MixProfile {
    /// Applies `o` on top of the profile, then validates the result.
    pub fn apply(&mut self, o: &Overrides) -> Result<(), MixPassError> {
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
        if let Some(mm) = o.initial_purge_mm {
            self.purge.initial_mm = mm;
        }
        self.validate()
    }
}

/// A gradient space by its name, `mix` or `perceived` (as `--gradient-space` spells it).
pub fn gradient_space(name: &str) -> Result<GradientSpace, MixPassError> {
    match name {
        "mix" => Ok(GradientSpace::Mix),
        "perceived" => Ok(GradientSpace::Perceived),
        other => Err(MixPassError::Input(format!("gradient_space: 'mix' or 'perceived', not {other:?}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_add_to_the_profile_and_replace_its_values() {
        let mut p = MixProfile::from_toml_str("[[schedule]]\nlayer = 0\nmix = \"Red\"\n").unwrap();
        let o = Overrides {
            at_layer: vec!["5=Blue".into()],
            purge_mm: Some(12.0),
            initial_purge_mm: Some(3.0),
            ..Overrides::default()
        };
        p.apply(&o).unwrap();
        assert_eq!(p.schedule.len(), 2);
        assert_eq!((p.purge.length_mm, p.purge.initial_mm), (12.0, 3.0));
        let bad = Overrides { map: vec!["X1=Red".into()], ..Overrides::default() };
        assert!(p.apply(&bad).is_err());
        assert_eq!(gradient_space("perceived").unwrap(), GradientSpace::Perceived);
        assert_eq!(
            gradient_space("lab").unwrap_err().to_string(),
            "gradient_space: 'mix' or 'perceived', not \"lab\""
        );
    }
}
