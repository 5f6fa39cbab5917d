//! The job: which colour goes where. A mix as the user names it ([`MixRef`]: a palette name,
//! a colour or a material, with a proportion of material 2), from which layer or height on
//! ([`ScheduleEntry`]), and blends over a range ([`GradientSpec`]), from the profile's TOML or
//! the flags (`--at-layer 10=Pink`, `--gradient 0-50=Cyan..Magenta`).

use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::colour::Srgb8;

use super::MixPassError;

/// A mix as the user names it: palette name, `#RRGGBB` or material, with a proportion of
/// material 2 (`Orange@0.3`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(try_from = "String")]
pub struct MixRef {
    /// The mix: a palette name or a colour.
    pub base: MixBase,
    /// Proportion of material 2, 0..=1.
    pub material2: Option<f64>,
}

/// The mix a [`MixRef`] names, before material 2.
#[derive(Debug, Clone, PartialEq)]
pub enum MixBase {
    /// A palette or user name (`Orange`).
    Name(String),
    /// A colour to solve a mix for (`#ff8000`).
    Colour(Srgb8),
}

impl MixRef {
    /// How the mix is shown in reports and comments.
    pub fn label(&self) -> String {
        let base = match &self.base {
            MixBase::Name(n) => n.clone(),
            MixBase::Colour(c) => c.to_hex(),
        };
        match self.material2 {
            Some(p) => format!("{base}@{p}"),
            None => base,
        }
    }
}

impl FromStr for MixRef {
    type Err = MixPassError;
    fn from_str(s: &str) -> Result<Self, MixPassError> {
        let bad = |why: &str| MixPassError::Config(format!("mix {s:?}: {why}"));
        let (base, material2) = match s.rsplit_once('@') {
            Some((b, p)) => {
                let p: f64 = p.trim().parse().map_err(|_| bad("the proportion after @ is not a number"))?;
                if !(0.0..=1.0).contains(&p) {
                    return Err(bad("the proportion of material 2 must be within 0..1"));
                }
                (b.trim(), Some(p))
            }
            None => (s.trim(), None),
        };
        if base.is_empty() {
            return Err(bad("empty name"));
        }
        let base = if base.starts_with('#') {
            MixBase::Colour(Srgb8::parse_hex(base).map_err(|e| bad(&e.to_string()))?)
        } else {
            MixBase::Name(base.to_owned())
        };
        Ok(MixRef { base, material2 })
    }
}

impl TryFrom<String> for MixRef {
    type Error = MixPassError;
    fn try_from(s: String) -> Result<Self, MixPassError> {
        s.parse()
    }
}

/// Where a schedule entry or gradient starts: a layer index (0 = first) or a height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum At {
    /// A 0-based layer index.
    Layer(u32),
    /// A height, mm.
    Z(f64),
}

/// From this layer (or Z) on, print with this mix.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScheduleEntry {
    /// From this layer (0-based) on.
    pub layer: Option<u32>,
    /// From this height on, mm.
    pub z_mm: Option<f64>,
    /// The mix to print with.
    pub mix: MixRef,
}

impl ScheduleEntry {
    /// Where the entry starts (exactly one of `layer` and `z_mm` must be given).
    pub fn at(&self) -> Result<At, MixPassError> {
        match (self.layer, self.z_mm) {
            (Some(l), None) => Ok(At::Layer(l)),
            (None, Some(z)) if z.is_finite() => Ok(At::Z(z)),
            _ => Err(MixPassError::Config(format!(
                "schedule entry {}: give exactly one of `layer` or `z_mm`",
                self.mix.label()
            ))),
        }
    }

    /// `10=Pink` (a layer) for `--at-layer`.
    pub fn parse_layer(s: &str) -> Result<Self, MixPassError> {
        let (at, mix) = split_eq(s)?;
        let layer = at.parse().map_err(|_| MixPassError::Config(format!("{s:?}: {at:?} is not a layer")))?;
        Ok(ScheduleEntry { layer: Some(layer), z_mm: None, mix: mix.parse()? })
    }

    /// `2.5=Blue` (a height, mm) for `--at-z`.
    pub fn parse_z(s: &str) -> Result<Self, MixPassError> {
        let (at, mix) = split_eq(s)?;
        let z = at.parse().map_err(|_| MixPassError::Config(format!("{s:?}: {at:?} is not a height")))?;
        Ok(ScheduleEntry { layer: None, z_mm: Some(z), mix: mix.parse()? })
    }
}

pub(super) fn split_eq(s: &str) -> Result<(&str, &str), MixPassError> {
    s.split_once('=')
        .map(|(a, b)| (a.trim(), b.trim()))
        .ok_or_else(|| MixPassError::Config(format!("{s:?}: expected <where>=<mix>")))
}

/// How a gradient interpolates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum GradientSpace {
    /// A straight line between the two mixes' ratios (what firmware gradients do).
    #[default]
    Mix,
    /// Equal steps of perceived colour (CIELAB), each solved for the filaments.
    Perceived,
}

/// A blend from one mix to another over a layer range (or Z range), inclusive.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GradientSpec {
    /// First layer of a layer range (0-based).
    pub from_layer: Option<u32>,
    /// Last layer of a layer range, inclusive.
    pub to_layer: Option<u32>,
    /// Bottom of a Z range, mm.
    pub from_z_mm: Option<f64>,
    /// Top of a Z range, mm, inclusive.
    pub to_z_mm: Option<f64>,
    /// The mix at the start.
    pub start: MixRef,
    /// The mix at the end.
    pub end: MixRef,
    /// The colour space the gradient is interpolated in.
    #[serde(default)]
    pub space: GradientSpace,
    /// A new step every this many layers (layer ranges).
    #[serde(default = "one")]
    pub every_layers: u32,
    /// A new step every this many mm (Z ranges).
    #[serde(default = "default_z_step")]
    pub z_step_mm: f64,
}

fn one() -> u32 {
    1
}
fn default_z_step() -> f64 {
    0.2
}

impl GradientSpec {
    /// The range, checked.
    pub fn range(&self) -> Result<(At, At), MixPassError> {
        let bad = |why: &str| {
            MixPassError::Config(format!("gradient {}..{}: {why}", self.start.label(), self.end.label()))
        };
        match (self.from_layer, self.to_layer, self.from_z_mm, self.to_z_mm) {
            (Some(a), Some(b), None, None) if a < b => {
                if self.every_layers == 0 {
                    return Err(bad("every_layers must be at least 1"));
                }
                Ok((At::Layer(a), At::Layer(b)))
            }
            (None, None, Some(a), Some(b)) if a.is_finite() && b.is_finite() && a < b => {
                if !(self.z_step_mm.is_finite() && self.z_step_mm > 0.0) {
                    return Err(bad("z_step_mm must be positive"));
                }
                Ok((At::Z(a), At::Z(b)))
            }
            _ => Err(bad("give from_layer < to_layer, or from_z_mm < to_z_mm")),
        }
    }

    /// `0-50=Cyan..Magenta`, `0-50/2=Cyan..Magenta` (every 2 layers) or `z1-5=Cyan..Magenta`.
    pub fn parse(s: &str, space: GradientSpace) -> Result<Self, MixPassError> {
        let bad = |why: &str| MixPassError::Config(format!("gradient {s:?}: {why}"));
        let (range, mixes) = split_eq(s)?;
        let (start, end) = mixes.split_once("..").ok_or_else(|| bad("expected <from>-<to>=<mix>..<mix>"))?;
        let (range, every) = match range.split_once('/') {
            Some((r, n)) => (r, Some(n.parse::<u32>().map_err(|_| bad("the step after / is not a count"))?)),
            None => (range, None),
        };
        let (is_z, range) = match range.strip_prefix('z').or_else(|| range.strip_prefix('Z')) {
            Some(r) => (true, r),
            None => (false, range),
        };
        let (a, b) = range.split_once('-').ok_or_else(|| bad("expected a range like 0-50"))?;
        let mut spec = GradientSpec {
            from_layer: None,
            to_layer: None,
            from_z_mm: None,
            to_z_mm: None,
            start: start.parse()?,
            end: end.parse()?,
            space,
            every_layers: 1,
            z_step_mm: default_z_step(),
        };
        if is_z {
            spec.from_z_mm = Some(a.parse().map_err(|_| bad("bad start height"))?);
            spec.to_z_mm = Some(b.parse().map_err(|_| bad("bad end height"))?);
            if let Some(n) = every {
                spec.z_step_mm = f64::from(n);
            }
        } else {
            spec.from_layer = Some(a.parse().map_err(|_| bad("bad start layer"))?);
            spec.to_layer = Some(b.parse().map_err(|_| bad("bad end layer"))?);
            spec.every_layers = every.unwrap_or(1);
        }
        spec.range()?;
        Ok(spec)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mix_refs_parse() {
        let r: MixRef = "Orange@0.3".parse().unwrap();
        assert_eq!((r.base, r.material2), (MixBase::Name("Orange".into()), Some(0.3)));
        let r: MixRef = "#FF8800".parse().unwrap();
        assert_eq!(r.base, MixBase::Colour(Srgb8::new(255, 136, 0)));
        assert!("Orange@1.5".parse::<MixRef>().is_err());
        assert!("#12".parse::<MixRef>().is_err());
        assert!("@0.5".parse::<MixRef>().is_err());
    }
}
