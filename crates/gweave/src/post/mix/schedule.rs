//! The plan: every mix the job needs, resolved for the loaded filaments, given a virtual tool,
//! and the rule that says which mix is wanted at a layer (or height) or for a slicer tool.
//!
//! Schedules follow the mixing post-processor seed (`docs/seeds.md`): an entry holds from its layer until the next entry (Orange from
//! layer 0, Pink from 10, Orange from 25, Blue from 75 to the end). Before the first entry the
//! first entry's mix is used. A gradient over layers `a..=b` every `n` layers has
//! `S = (b - a) / n` steps after its first; layer `L` gets step `s = min((L - a) / n, S)` at
//! `t = s / S` between the two mixes (linearly in ratio space, or in CIELAB and solved back,
//! see `crate::colour::solve::lerp_perceived`). A Z gradient steps every `z_step_mm`.
//!
//! Virtual tools: when every distinct mix fits the firmware's tool count, each gets its own tool,
//! all defined once at the start of the print. Otherwise the fixed mixes (schedule, map, the
//! ends of gradients) keep their tools and the gradient steps take turns on the last two tools:
//! the next step is written into the tool not in use, at the layer start where it is needed,
//! then selected, so a tool is never redefined while it prints.

use std::collections::BTreeMap;

use crate::colour::dialect::{formatted, round_to_units, Decimals};
use crate::colour::named_mixes::{Palette, PaletteConfig};
use crate::colour::solve::{lerp_perceived, solve};
use crate::colour::{Mix, MixingModel, Srgb8};
use crate::options::Said;
use crate::range::{Ceiling, LAYER_NUMBER, MAX_LAYERS, POSITION_MM};

use super::profile::{At, GradientSpace, MixBase, MixProfile, MixRef};
use super::MixPassError;
use crate::post::warning::Warning;

/// Where a mix lives in the firmware.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slot {
    /// Its own virtual tool, defined at the start of the print.
    Fixed(u32),
    /// One of the two shared tools, defined where it is first needed.
    Rotating,
    /// Written with `M165` into the active tool at each change.
    Direct,
}

/// One mix the job uses.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedMix {
    /// The mix's label as the profile names it.
    pub label: String,
    /// The mix, normalised.
    pub mix: Mix,
    /// The ratios as written (units of 10^-decimals, summing to exactly 10^decimals).
    pub units: Vec<u64>,
    /// The colour the mixing model predicts.
    pub predicted: Srgb8,
    /// The colour asked for, when the mix was solved from one.
    pub target: Option<Srgb8>,
    /// CIEDE2000 between target and prediction.
    pub delta_e: Option<f64>,
    /// The target colour is outside what the filaments can mix.
    pub out_of_gamut: bool,
    /// A step inside a gradient (not purged by default).
    pub gradient_step: bool,
    /// Where the mix lives in the firmware.
    pub slot: Slot,
}

#[derive(Debug, Clone)]
enum Kind {
    Solid(usize),
    Gradient { end: At, steps: Vec<usize>, end_mix: usize, every: f64 },
}

#[derive(Debug, Clone)]
struct Segment {
    start: At,
    kind: Kind,
}

/// The resolved job; see the module docs.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Every mix the job uses.
    pub mixes: Vec<PlannedMix>,
    segments: Vec<Segment>,
    tool_map: BTreeMap<u32, usize>,
    /// The two tools gradient steps take turns on (when they do not all fit).
    pub rotating_tools: [u32; 2],
    /// What planning noticed and did anyway.
    pub warnings: Vec<Warning>,
    /// Decimals of the ratios written.
    pub decimals: Decimals,
}

struct Resolver<'a> {
    profile: &'a MixProfile,
    palette: Palette,
    model: MixingModel,
    decimals: Decimals,
    mixes: Vec<PlannedMix>,
    warnings: Vec<Warning>,
}

impl Resolver<'_> {
    /// The index of the mix `r` names, adding it if new.
    fn add(&mut self, r: &MixRef) -> Result<usize, MixPassError> {
        let hw = &self.profile.hardware;
        let unit = |i: usize| {
            let mut w = vec![0.0; hw.inputs.len()];
            w[i] = 1.0;
            Mix::new(&w)
        };
        let (mut mix, target, delta_e, out_of_gamut) = match &r.base {
            MixBase::Colour(c) => {
                let s = solve(&self.model, *c);
                (s.mix, Some(*c), Some(s.delta_e), s.out_of_gamut)
            }
            MixBase::Name(name) => match self.palette.get(name) {
                Some(_) => {
                    let res = self
                        .palette
                        .resolve(name, &self.model)
                        .map_err(|e| MixPassError::Config(e.to_string()))?;
                    if let Some(miss) = self.palette.name_out_of_gamut(name, &self.model) {
                        let warning = Warning::NameOutOfGamut {
                            mix: res.name.clone(),
                            meant_hex: miss.meant.to_hex(),
                            predicted_hex: miss.predicted.to_hex(),
                            nearest_hex: miss.nearest.predicted.to_hex(),
                            nearest_ratios: formatted(&miss.nearest.mix, self.decimals).join(":"),
                            delta_e: miss.nearest.delta_e,
                        };
                        if !self.warnings.contains(&warning) {
                            self.warnings.push(warning);
                        }
                    }
                    (res.mix, res.target, res.delta_e, res.out_of_gamut)
                }
                None => {
                    let lower = name.to_lowercase();
                    let input = if lower == "support" || lower == "material2" {
                        Some(hw.material2_index())
                    } else {
                        hw.inputs.iter().position(|i| i.material.to_lowercase() == lower)
                    };
                    let i = input.ok_or_else(|| unknown_name(name, &self.palette, hw))?;
                    (unit(i)?, None, None, false)
                }
            },
        };
        mix.expect_inputs(hw.inputs.len())
            .map_err(|e| MixPassError::Config(format!("{}: {e}", r.label())))?;
        if let Some(p) = r.material2 {
            mix = mix
                .with_material2(p, hw.material2_index())
                .map_err(|e| MixPassError::Config(format!("{}: {e}", r.label())))?;
        }
        if out_of_gamut {
            if let (Some(t), Some(de)) = (target, delta_e) {
                self.warnings.push(Warning::OutOfGamut {
                    mix: r.label(),
                    target_hex: t.to_hex(),
                    delta_e: de,
                });
            }
        }
        self.push(r.label(), mix, target, delta_e, out_of_gamut, false)
    }

    fn push(
        &mut self,
        label: String,
        mix: Mix,
        target: Option<Srgb8>,
        delta_e: Option<f64>,
        out_of_gamut: bool,
        gradient_step: bool,
    ) -> Result<usize, MixPassError> {
        let units = round_to_units(&mix, self.decimals);
        if let Some(i) = self.mixes.iter().position(|m| m.units == units) {
            // The same ratios under another name: one tool. A fixed use wins over a step.
            self.mixes[i].gradient_step &= gradient_step;
            return Ok(i);
        }
        let predicted = self.model.predict(&mix).map_err(|e| MixPassError::Config(e.to_string()))?;
        self.mixes.push(PlannedMix {
            label,
            mix,
            units,
            predicted,
            target,
            delta_e,
            out_of_gamut,
            gradient_step,
            slot: Slot::Direct,
        });
        Ok(self.mixes.len() - 1)
    }
}

/// A layer or height a schedule names, within [`LAYER_NUMBER`] or [`POSITION_MM`] (`--at-z 1e308`
/// and `at = "z1e308"` alike).
fn bounded(at: At, what: &str) -> Result<At, MixPassError> {
    let checked = match at {
        At::Layer(n) => LAYER_NUMBER.check(&format!("{what} layer"), n).map(|_| at),
        At::Z(z) => POSITION_MM.check(&format!("{what} height"), z).map(|_| at),
    };
    checked.map_err(|e| MixPassError::Config(e.to_string()))
}

impl Plan {
    /// Resolves every mix of `profile` and gives each a place in the firmware.
    pub fn new(profile: &MixProfile) -> Result<Plan, MixPassError> {
        profile.validate()?;
        let hw = &profile.hardware;
        let model = hw.mixing_model().map_err(|e| MixPassError::Config(e.to_string()))?;
        let decimals = Decimals::new(hw.ratio_decimals).map_err(|e| MixPassError::Config(e.to_string()))?;
        let palette = Palette::seed().with_config(PaletteConfig { mix: profile.mix.clone() });
        let mut r = Resolver { profile, palette, model, decimals, mixes: Vec::new(), warnings: Vec::new() };

        let mut segments = Vec::new();
        for entry in &profile.schedule {
            let start = bounded(entry.at()?, "a schedule entry's")?;
            segments.push(Segment { start, kind: Kind::Solid(r.add(&entry.mix)?) });
        }
        for g in &profile.gradient {
            let (start, end) = g.range()?;
            let (start, end) = (bounded(start, "a gradient's start")?, bounded(end, "a gradient's end")?);
            let a = r.add(&g.start)?;
            let b = r.add(&g.end)?;
            let (count, every) = match (start, end) {
                (At::Layer(x), At::Layer(y)) => {
                    (f64::from((y - x) / g.every_layers), f64::from(g.every_layers))
                }
                (At::Z(x), At::Z(y)) => (((y - x) / g.z_step_mm - 1e-9).ceil().max(0.0), g.z_step_mm),
                _ => unreachable!("range() gives two ends of one kind"),
            };
            // A step per layer at most: `z0-1e308` must be refused, not allocated.
            let count = Ceiling::new(MAX_LAYERS, "gradient steps")
                .check(count, || format!("the gradient {}..{}", g.start.label(), g.end.label()))
                .map_err(|e| MixPassError::Config(e.to_string()))? as u32;
            let mut steps = Vec::with_capacity(count as usize + 1);
            for s in 0..=count {
                let t = if count == 0 { 0.0 } else { f64::from(s) / f64::from(count) };
                let (ma, mb) = (r.mixes[a].mix.clone(), r.mixes[b].mix.clone());
                let mix = match g.space {
                    GradientSpace::Mix => ma.lerp(&mb, t),
                    GradientSpace::Perceived => lerp_perceived(&r.model, &ma, &mb, t).map(|s| s.mix),
                }
                .map_err(|e| MixPassError::Config(e.to_string()))?;
                let label = format!("{}..{} {}/{}", g.start.label(), g.end.label(), s, count);
                let step = r.push(label, mix, None, None, false, true)?;
                steps.push(step);
            }
            segments.push(Segment { start, kind: Kind::Gradient { end, steps, end_mix: b, every } });
        }
        let layer_kind = |s: &Segment| matches!(s.start, At::Layer(_));
        if segments.iter().any(layer_kind) && !segments.iter().all(layer_kind) {
            return Err(MixPassError::Config(
                "a schedule uses layers or heights, not both (convert one to the other)".into(),
            ));
        }
        segments.sort_by(|x, y| key(x.start).total_cmp(&key(y.start)));

        let mut tool_map = BTreeMap::new();
        for (tool, mix) in profile.tool_map()? {
            tool_map.insert(tool, r.add(&mix)?);
        }
        if segments.is_empty() && tool_map.is_empty() {
            return Err(MixPassError::Needs(
                Said::new("mix profile: nothing to do: give a schedule (")
                    .option("at_layer")
                    .text(", ")
                    .option("at_z")
                    .text(", [[schedule]]), a gradient (")
                    .option("gradient")
                    .text(", [[gradient]]) or a tool map (")
                    .option("map")
                    .text(", [map])"),
            ));
        }

        let mut mixes = r.mixes;
        let tools = hw.virtual_tools as u32;
        let mut rotating_tools = [0, 0];
        if hw.dialect().uses_tools() {
            if mixes.len() as u32 <= tools {
                for (t, m) in (0u32..).zip(mixes.iter_mut()) {
                    m.slot = Slot::Fixed(t);
                }
            } else {
                // More mixes than tools: the last two tools take turns (each redefined just
                // before it is selected, while the other prints); the mixes before them keep
                // a tool each, gradient steps always rotate.
                if tools < 2 {
                    return Err(MixPassError::Config(format!(
                        "{} mixes need {} virtual tools, or 2 to take turns; the firmware has {tools}",
                        mixes.len(),
                        mixes.len()
                    )));
                }
                let mut t = 0;
                for m in &mut mixes {
                    m.slot = if m.gradient_step || t + 2 >= tools {
                        Slot::Rotating
                    } else {
                        t += 1;
                        Slot::Fixed(t - 1)
                    };
                }
                rotating_tools = [tools - 2, tools - 1];
            }
        }
        Ok(Plan { mixes, segments, tool_map, rotating_tools, warnings: r.warnings, decimals })
    }

    /// Whether slicer tools are mapped (multi-tool input) rather than scheduled by layer.
    pub(crate) fn maps_tools(&self) -> bool {
        !self.tool_map.is_empty()
    }

    /// The mix for slicer tool `tool`.
    pub(crate) fn for_tool(&self, tool: u32) -> Result<usize, MixPassError> {
        self.tool_map.get(&tool).copied().ok_or_else(|| {
            MixPassError::Needs(
                Said::new(format!("the file selects T{tool}, which has no mix: add "))
                    .option("map")
                    .text(format!(" T{tool}=<mix>")),
            )
        })
    }

    /// The mix wanted at `layer` (0-based) printed at `z_mm`.
    pub(crate) fn mix_at(&self, layer: u32, z_mm: f64) -> Option<usize> {
        let first = self.segments.first()?;
        let k = match first.start {
            At::Layer(_) => f64::from(layer),
            At::Z(_) => z_mm,
        };
        let seg = self.segments.iter().rev().find(|s| key(s.start) <= k + 1e-9).unwrap_or(first);
        Some(match &seg.kind {
            Kind::Solid(i) => *i,
            Kind::Gradient { end, steps, end_mix, every } => {
                if k > key(*end) + 1e-9 {
                    *end_mix
                } else {
                    let s = ((k - key(seg.start)) / every + 1e-9).floor().max(0.0) as usize;
                    steps[s.min(steps.len() - 1)]
                }
            }
        })
    }

    /// The mix to select when the print starts.
    pub fn initial(&self, slicer_tool: u32) -> Result<usize, MixPassError> {
        if self.maps_tools() {
            self.for_tool(slicer_tool)
        } else {
            // Layer 0, or the lowest height of a Z schedule.
            Ok(self.mix_at(0, f64::NEG_INFINITY).unwrap_or(0))
        }
    }
}

fn key(at: At) -> f64 {
    match at {
        At::Layer(l) => f64::from(l),
        At::Z(z) => z,
    }
}

/// A `--map`/schedule name that is neither a palette colour nor an input's material. A user who
/// writes `T1=PVA` on a profile whose inputs are all PLA wants the soluble-support setup: say
/// how to get it (`support`, 100 % of material 2, or a profile with a PVA input).
fn unknown_name(name: &str, palette: &Palette, hw: &super::profile::Hardware) -> MixPassError {
    let colours: Vec<&str> = palette.entries().iter().map(|e| e.name.as_str()).collect();
    let materials: Vec<&str> = hw.inputs.iter().map(|i| i.material.as_str()).collect();
    MixPassError::Config(format!(
        "no colour or material named {name:?} (palette: {}; materials: {}). For 100 % of \
         material 2 (input E{}) write `support` (e.g. --map T1=support); for a PVA input, start \
         from examples/mix/pva_support.toml (-c)",
        colours.join(", "),
        materials.join(", "),
        hw.material2_index()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::post::mix::profile::{GradientSpec, ScheduleEntry};

    fn seed_schedule() -> MixProfile {
        let mut p = MixProfile::default();
        for s in ["0=Orange", "10=Pink", "25=Orange", "75=Blue"] {
            p.schedule.push(ScheduleEntry::parse_layer(s).unwrap());
        }
        p.mix.insert(
            "Pink".into(),
            toml::from_str::<BTreeMap<String, crate::colour::named_mixes::MixSpec>>(
                "p = { ratios = [0, 0.6, 0.1, 0.3] }",
            )
            .unwrap()
            .remove("p")
            .unwrap(),
        );
        p
    }

    #[test]
    fn the_seeds_schedule() {
        let plan = Plan::new(&seed_schedule()).unwrap();
        let label = |l| plan.mixes[plan.mix_at(l, 0.0).unwrap()].label.clone();
        assert_eq!(
            [label(0), label(9), label(10), label(24), label(25), label(74), label(75), label(500)],
            ["Orange", "Orange", "Pink", "Pink", "Orange", "Orange", "Blue", "Blue"]
        );
        // Orange once, then Pink and Blue: three tools, as the seed's T0..T2.
        assert_eq!(plan.mixes.len(), 3);
        assert_eq!(
            plan.mixes.iter().map(|m| m.slot).collect::<Vec<_>>(),
            [Slot::Fixed(0), Slot::Fixed(1), Slot::Fixed(2)]
        );
        // The seed's Orange 0 : 0.17 : 0.82 : 0, normalised (sum 0.99), 4 decimals.
        assert_eq!(plan.mixes[0].units, [0, 1717, 8283, 0]);
    }

    #[test]
    fn map_t1_pva_on_the_default_profile_points_to_support() {
        // The README's `--map T1=PVA` on the default (all-PLA) profile said only "materials:
        // PLA, PLA, PLA, PLA"; it now says what to write instead.
        let mut p = MixProfile::default();
        p.add_map("T1=PVA").unwrap();
        let err = Plan::new(&p).unwrap_err().to_string();
        assert!(err.contains("no colour or material named \"PVA\""), "{err}");
        assert!(err.contains("materials: PLA, PLA, PLA, PLA). For 100 % of material 2 (input E3) write `support` (e.g. --map T1=support); for a PVA input, start from examples/mix/pva_support.toml"), "{err}");
        let mut support = MixProfile::default();
        support.add_map("T1=support").unwrap();
        assert_eq!(Plan::new(&support).unwrap().mixes[0].units, [0, 0, 0, 10000]);
    }

    #[test]
    fn palette_blue_out_of_gamut_is_in_the_warnings() {
        // Issue 39: the seed's schedule printed "Blue" purple (#74419f) and said nothing. Blue is
        // named twice (layers 75 and 80): one warning.
        let mut p = seed_schedule();
        p.schedule.push(ScheduleEntry::parse_layer("80=blue").unwrap());
        let plan = Plan::new(&p).unwrap();
        let said: Vec<String> = plan.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(
            said,
            ["Blue: out of these filaments' gamut: its ratios print #74419f, and the nearest to blue (#1f4e9c) they print is #6165ae at 0.6709:0.2894:0.0397:0, dE2000 11.8"]
        );
    }

    #[test]
    fn all_17_palette_colours_fit_16_tools_by_taking_turns() {
        // Refused before with "17 fixed mixes and gradient steps need 19 virtual tools".
        let mut p = MixProfile::default();
        for (t, (name, _)) in crate::colour::named_mixes::SEED_PALETTE.iter().enumerate() {
            p.add_map(&format!("T{t}={name}")).unwrap();
        }
        let plan = Plan::new(&p).unwrap();
        let slots: Vec<Slot> = plan.mixes.iter().map(|m| m.slot).collect();
        assert_eq!(slots[..14], (0..14).map(Slot::Fixed).collect::<Vec<_>>()[..]);
        assert_eq!(slots[14..], [Slot::Rotating; 3]);
        assert_eq!(plan.rotating_tools, [14, 15]);
        p.hardware.virtual_tools = 1;
        let err = Plan::new(&p).unwrap_err().to_string();
        assert_eq!(
            err,
            "mix profile: 17 mixes need 17 virtual tools, or 2 to take turns; the firmware has 1"
        );
    }

    #[test]
    fn gradient_steps_share_two_tools_when_they_do_not_fit() {
        let mut p = MixProfile::default();
        p.gradient.push(GradientSpec::parse("0-40=Cyan..Magenta", GradientSpace::Mix).unwrap());
        let plan = Plan::new(&p).unwrap();
        // 41 steps (ends included, deduplicated with the two fixed ends) on 16 tools.
        assert_eq!(plan.mixes.len(), 41);
        assert_eq!(plan.rotating_tools, [14, 15]);
        let step = |l| &plan.mixes[plan.mix_at(l, 0.0).unwrap()];
        assert_eq!(step(0).slot, Slot::Fixed(0));
        assert_eq!(step(40).slot, Slot::Fixed(1));
        assert_eq!(step(20).slot, Slot::Rotating);
        assert_eq!(step(20).units, [5000, 5000, 0, 0]);
        assert_eq!(step(10).units, [7500, 2500, 0, 0]);
        assert_eq!(step(99).units, [0, 10000, 0, 0]);
    }

    #[test]
    fn every_seed_colour_is_written_with_the_seeds_ratios() {
        let mut p = MixProfile::default();
        for (t, (name, _)) in crate::colour::named_mixes::SEED_PALETTE.iter().enumerate() {
            p.add_map(&format!("T{t}={name}")).unwrap();
        }
        p.hardware.virtual_tools = 17;
        let plan = Plan::new(&p).unwrap();
        for (t, (name, ratios)) in crate::colour::named_mixes::SEED_PALETTE.iter().enumerate() {
            let m = &plan.mixes[plan.for_tool(t as u32).unwrap()];
            let sum: f64 = ratios.iter().sum();
            for (u, r) in m.units.iter().zip(ratios) {
                // Written to 4 decimals by largest remainder: within one unit of the seed's ratio
                // over its sum (Brown's three 0.3333.. become 0.3334, 0.3333, 0.3333).
                assert!((*u as f64 / 1e4 - r / sum).abs() < 1e-4, "{name}: {:?}", m.units);
            }
            assert_eq!(m.units.iter().sum::<u64>(), 10000, "{name}");
        }
    }

    #[test]
    fn materials_and_support() {
        let mut p = MixProfile::default();
        p.hardware.inputs[3].material = "PVA".into();
        p.add_map("T0=Orange").unwrap();
        p.add_map("T1=PVA").unwrap();
        p.add_map("T2=Red@0.5").unwrap();
        let plan = Plan::new(&p).unwrap();
        assert_eq!(plan.mixes[plan.for_tool(1).unwrap()].units, [0, 0, 0, 10000]);
        assert_eq!(plan.mixes[plan.for_tool(2).unwrap()].units, [0, 2500, 2500, 5000]);
        assert!(plan.for_tool(3).is_err());
        p.add_map("T3=Unobtainium").unwrap();
        assert!(Plan::new(&p).is_err());
    }
}
