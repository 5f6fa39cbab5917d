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
//!
//! Gradient steps cost what the file prints, not what the profile declares: a gradient over
//! layers 0 to 99 999 on a 28-layer file solves 28 steps. Steps are resolved when a layer first
//! needs one, except when all the gradients' steps together could fit the tools (at most
//! `virtual_tools` of them, 1 000): those are resolved at once, to be defined at the start.
//! Resolving every declared step up front took 72 s for 20 gradients of 100 000 steps on a
//! 28-layer file (each step compared with every mix before it), and a perceived step (a colour
//! solved) takes about 5 ms: 100 000 of them, nine minutes.

use std::collections::{BTreeMap, HashMap};

use crate::colour::dialect::{formatted, round_to_units, Decimals};
use crate::colour::named_mixes::{Palette, PaletteConfig};
use crate::colour::solve::{lerp_perceived, solve};
use crate::colour::{Mix, MixingModel, Srgb8};
use crate::options::Said;
use crate::range::{Ceiling, LAYER_NUMBER, MAX_LAYERS, POSITION_MM};

use super::profile::{At, GradientSpace, GradientSpec, MixBase, MixProfile, MixRef};
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

#[derive(Debug, Clone, Copy)]
enum Kind {
    Solid(usize),
    /// `steps` indexes [`Plan::gradients`].
    Gradient {
        end: At,
        steps: usize,
        every: f64,
    },
}

#[derive(Debug, Clone, Copy)]
struct Segment {
    start: At,
    kind: Kind,
}

/// A gradient's steps: step `s` is the mix at `t = s / count` from `ends[0]` to `ends[1]`.
#[derive(Debug, Clone)]
struct Steps {
    ends: [usize; 2],
    count: u32,
    space: GradientSpace,
    /// `Cyan..Magenta`, for the steps' labels.
    label: String,
    /// The steps resolved so far, with their mixes.
    resolved: BTreeMap<u32, usize>,
}

/// The resolved job; see the module docs.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Every mix the job uses (gradient steps: those resolved so far).
    pub mixes: Vec<PlannedMix>,
    /// Each mix by its ratios as written, so that a new mix is found in one look-up.
    by_units: HashMap<Vec<u64>, usize>,
    model: MixingModel,
    segments: Vec<Segment>,
    gradients: Vec<Steps>,
    tool_map: BTreeMap<u32, usize>,
    /// The two tools gradient steps take turns on (when they do not all fit).
    pub rotating_tools: [u32; 2],
    /// Where a gradient step resolved while the print runs lives (a rotating tool, or written
    /// directly); until the plan is made, where every new mix starts.
    late_slot: Slot,
    /// What planning noticed and did anyway.
    pub warnings: Vec<Warning>,
    /// Decimals of the ratios written.
    pub decimals: Decimals,
}

struct Resolver<'a> {
    profile: &'a MixProfile,
    palette: Palette,
    plan: Plan,
}

impl Resolver<'_> {
    /// The index of the mix `r` names, adding it if new.
    fn add(&mut self, r: &MixRef) -> Result<usize, MixPassError> {
        let hw = &self.profile.hardware;
        let model = &self.plan.model;
        let unit = |i: usize| {
            let mut w = vec![0.0; hw.inputs.len()];
            w[i] = 1.0;
            Mix::new(&w)
        };
        let (mut mix, target, delta_e, out_of_gamut) = match &r.base {
            MixBase::Colour(c) => {
                let s = solve(model, *c);
                (s.mix, Some(*c), Some(s.delta_e), s.out_of_gamut)
            }
            MixBase::Name(name) => match self.palette.get(name) {
                Some(_) => {
                    let res =
                        self.palette.resolve(name, model).map_err(|e| MixPassError::Config(e.to_string()))?;
                    if let Some(miss) = self.palette.name_out_of_gamut(name, model) {
                        let warning = Warning::NameOutOfGamut {
                            mix: res.name.clone(),
                            meant_hex: miss.meant.to_hex(),
                            predicted_hex: miss.predicted.to_hex(),
                            nearest_hex: miss.nearest.predicted.to_hex(),
                            nearest_ratios: formatted(&miss.nearest.mix, self.plan.decimals).join(":"),
                            delta_e: miss.nearest.delta_e,
                        };
                        if !self.plan.warnings.contains(&warning) {
                            self.plan.warnings.push(warning);
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
                self.plan.warnings.push(Warning::OutOfGamut {
                    mix: r.label(),
                    target_hex: t.to_hex(),
                    delta_e: de,
                });
            }
        }
        self.plan.push(r.label(), mix, target, delta_e, out_of_gamut, false)
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
    /// Resolves every mix of `profile` and gives each a place in the firmware; gradient steps
    /// are resolved as the layers that print them ask for them, unless they could all fit the
    /// tools (see the module docs).
    pub fn new(profile: &MixProfile) -> Result<Plan, MixPassError> {
        profile.validate()?;
        let hw = &profile.hardware;
        let model = hw.mixing_model().map_err(|e| MixPassError::Config(e.to_string()))?;
        let decimals = Decimals::new(hw.ratio_decimals).map_err(|e| MixPassError::Config(e.to_string()))?;
        let palette = Palette::seed().with_config(PaletteConfig { mix: profile.mix.clone() });
        let plan = Plan {
            mixes: Vec::new(),
            by_units: HashMap::new(),
            model,
            segments: Vec::new(),
            gradients: Vec::new(),
            tool_map: BTreeMap::new(),
            rotating_tools: [0, 0],
            late_slot: Slot::Direct,
            warnings: Vec::new(),
            decimals,
        };
        let mut r = Resolver { profile, palette, plan };

        for entry in &profile.schedule {
            let start = bounded(entry.at()?, "a schedule entry's")?;
            let kind = Kind::Solid(r.add(&entry.mix)?);
            r.plan.segments.push(Segment { start, kind });
        }
        let spans: Vec<(At, At, u32, f64)> = profile.gradient.iter().map(span).collect::<Result<_, _>>()?;
        let declared: u64 = spans.iter().map(|&(.., count, _)| u64::from(count) + 1).sum();
        let eager = declared <= hw.virtual_tools as u64;
        for (g, (start, end, count, every)) in profile.gradient.iter().zip(spans) {
            let ends = [r.add(&g.start)?, r.add(&g.end)?];
            let label = format!("{}..{}", g.start.label(), g.end.label());
            let steps = r.plan.gradients.len();
            r.plan.gradients.push(Steps { ends, count, space: g.space, label, resolved: BTreeMap::new() });
            if eager {
                for s in 0..=count {
                    r.plan.step(steps, s)?;
                }
            }
            r.plan.segments.push(Segment { start, kind: Kind::Gradient { end, steps, every } });
        }
        let layer_kind = |s: &Segment| matches!(s.start, At::Layer(_));
        if r.plan.segments.iter().any(layer_kind) && !r.plan.segments.iter().all(layer_kind) {
            return Err(MixPassError::Config(
                "a schedule uses layers or heights, not both (convert one to the other)".into(),
            ));
        }
        r.plan.segments.sort_by(|x, y| key(x.start).total_cmp(&key(y.start)));

        for (tool, mix) in profile.tool_map()? {
            let i = r.add(&mix)?;
            r.plan.tool_map.insert(tool, i);
        }
        let mut plan = r.plan;
        if plan.segments.is_empty() && plan.tool_map.is_empty() {
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

        let tools = hw.virtual_tools as u32;
        if hw.dialect().uses_tools() {
            // Steps left to resolve while the print runs are more than the tools (that is why
            // they were left): they take turns, as resolved steps that do not fit do.
            if eager && plan.mixes.len() as u32 <= tools {
                for (t, m) in (0u32..).zip(plan.mixes.iter_mut()) {
                    m.slot = Slot::Fixed(t);
                }
            } else {
                // More mixes than tools: the last two tools take turns (each redefined just
                // before it is selected, while the other prints); the mixes before them keep
                // a tool each, gradient steps always rotate.
                if tools < 2 {
                    let n = plan.mixes.len();
                    let need = if eager {
                        format!("{n} mixes need {n} virtual tools")
                    } else {
                        format!("{n} mixes and {declared} gradient steps need a virtual tool each")
                    };
                    return Err(MixPassError::Config(format!(
                        "{need}, or 2 to take turns; the firmware has {tools}"
                    )));
                }
                let mut t = 0;
                for m in &mut plan.mixes {
                    m.slot = if m.gradient_step || t + 2 >= tools {
                        Slot::Rotating
                    } else {
                        t += 1;
                        Slot::Fixed(t - 1)
                    };
                }
                plan.rotating_tools = [tools - 2, tools - 1];
                plan.late_slot = Slot::Rotating;
            }
        }
        Ok(plan)
    }

    /// The index of `mix`, added if no mix has its ratios as written (the same ratios under
    /// another name are one tool; a fixed use wins over a step).
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
        if let Some(&i) = self.by_units.get(&units) {
            self.mixes[i].gradient_step &= gradient_step;
            return Ok(i);
        }
        let predicted = self.model.predict(&mix).map_err(|e| MixPassError::Config(e.to_string()))?;
        self.by_units.insert(units.clone(), self.mixes.len());
        self.mixes.push(PlannedMix {
            label,
            mix,
            units,
            predicted,
            target,
            delta_e,
            out_of_gamut,
            gradient_step,
            slot: self.late_slot,
        });
        Ok(self.mixes.len() - 1)
    }

    /// The mix of step `s` of gradient `g`, resolved the first time it is asked for.
    fn step(&mut self, g: usize, s: u32) -> Result<usize, MixPassError> {
        let steps = &self.gradients[g];
        if let Some(&i) = steps.resolved.get(&s) {
            return Ok(i);
        }
        let count = steps.count;
        let t = if count == 0 { 0.0 } else { f64::from(s) / f64::from(count) };
        let (ma, mb) = (&self.mixes[steps.ends[0]].mix, &self.mixes[steps.ends[1]].mix);
        let mix = match steps.space {
            GradientSpace::Mix => ma.lerp(mb, t),
            GradientSpace::Perceived => lerp_perceived(&self.model, ma, mb, t).map(|s| s.mix),
        }
        .map_err(|e| MixPassError::Config(e.to_string()))?;
        let label = format!("{} {s}/{count}", steps.label);
        let i = self.push(label, mix, None, None, false, true)?;
        self.gradients[g].resolved.insert(s, i);
        Ok(i)
    }

    /// Whether some gradient steps are still to be resolved (as layers ask for them).
    pub(crate) fn steps_to_come(&self) -> bool {
        self.gradients.iter().any(|g| g.resolved.len() <= g.count as usize)
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

    /// The mix wanted at `layer` (0-based) printed at `z_mm` (a gradient's step is resolved
    /// here the first time a layer needs it).
    pub(crate) fn mix_at(&mut self, layer: u32, z_mm: f64) -> Result<Option<usize>, MixPassError> {
        let Some(first) = self.segments.first() else { return Ok(None) };
        let k = match first.start {
            At::Layer(_) => f64::from(layer),
            At::Z(_) => z_mm,
        };
        let seg = *self.segments.iter().rev().find(|s| key(s.start) <= k + 1e-9).unwrap_or(first);
        match seg.kind {
            Kind::Solid(i) => Ok(Some(i)),
            Kind::Gradient { end, steps, .. } if k > key(end) + 1e-9 => {
                Ok(Some(self.gradients[steps].ends[1]))
            }
            Kind::Gradient { steps, every, .. } => {
                // Within 0..=count, so the cast is exact.
                let s = ((k - key(seg.start)) / every + 1e-9)
                    .floor()
                    .clamp(0.0, f64::from(self.gradients[steps].count));
                self.step(steps, s as u32).map(Some)
            }
        }
    }

    /// The mix to select when the print starts.
    pub fn initial(&mut self, slicer_tool: u32) -> Result<usize, MixPassError> {
        if self.maps_tools() {
            self.for_tool(slicer_tool)
        } else {
            // Layer 0, or the lowest height of a Z schedule.
            Ok(self.mix_at(0, f64::NEG_INFINITY)?.unwrap_or(0))
        }
    }
}

/// Where a gradient starts and ends, its steps after the first, and the layers or mm between
/// steps. A step per layer at most: `z0-1e308` must be refused, not stepped.
fn span(g: &GradientSpec) -> Result<(At, At, u32, f64), MixPassError> {
    let (start, end) = g.range()?;
    let (start, end) = (bounded(start, "a gradient's start")?, bounded(end, "a gradient's end")?);
    let (count, every) = match (start, end) {
        (At::Layer(x), At::Layer(y)) => (f64::from((y - x) / g.every_layers), f64::from(g.every_layers)),
        (At::Z(x), At::Z(y)) => (((y - x) / g.z_step_mm - 1e-9).ceil().max(0.0), g.z_step_mm),
        _ => unreachable!("range() gives two ends of one kind"),
    };
    let count = Ceiling::new(MAX_LAYERS, "gradient steps")
        .check(count, || format!("the gradient {}..{}", g.start.label(), g.end.label()))
        .map_err(|e| MixPassError::Config(e.to_string()))?;
    Ok((start, end, count as u32, every))
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
        let mut plan = Plan::new(&seed_schedule()).unwrap();
        let mut label = |l| {
            let i = plan.mix_at(l, 0.0).unwrap().unwrap();
            plan.mixes[i].label.clone()
        };
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
        let mut plan = Plan::new(&p).unwrap();
        // 41 steps (ends included) on 16 tools: the ends have tools of their own, and a step is
        // resolved when a layer first needs it.
        assert_eq!(plan.mixes.len(), 2);
        assert_eq!(plan.rotating_tools, [14, 15]);
        let mut step = |l| {
            let i = plan.mix_at(l, 0.0).unwrap().unwrap();
            plan.mixes[i].clone()
        };
        assert_eq!(step(0).slot, Slot::Fixed(0));
        assert_eq!(step(40).slot, Slot::Fixed(1));
        assert_eq!(step(20).slot, Slot::Rotating);
        assert_eq!(step(20).units, [5000, 5000, 0, 0]);
        assert_eq!(step(10).units, [7500, 2500, 0, 0]);
        assert_eq!(step(99).units, [0, 10000, 0, 0]);
        for l in 0..=40 {
            step(l);
        }
        // Deduplicated with the two fixed ends.
        assert_eq!(plan.mixes.len(), 41);
    }

    /// A gradient whose steps fit the tools with the fixed mixes: every step resolved at once,
    /// each with a tool of its own defined at the start, in the order the profile gives them.
    #[test]
    fn gradient_steps_that_fit_get_tools_of_their_own() {
        let mut p = MixProfile::default();
        for g in ["0-2=Cyan..Magenta", "3-5=Orange..Yellow"] {
            p.gradient.push(GradientSpec::parse(g, GradientSpace::Mix).unwrap());
        }
        let plan = Plan::new(&p).unwrap();
        let labels: Vec<&str> = plan.mixes.iter().map(|m| m.label.as_str()).collect();
        assert_eq!(
            labels,
            ["Cyan", "Magenta", "Cyan..Magenta 1/2", "Orange", "Yellow", "Orange..Yellow 1/2"]
        );
        let slots: Vec<Slot> = plan.mixes.iter().map(|m| m.slot).collect();
        assert_eq!(slots, (0..6).map(Slot::Fixed).collect::<Vec<_>>());
    }

    /// Regression (B4): each gradient was held to 100 000 steps but not their total, and every
    /// declared step was resolved before the first line, each compared with every mix before
    /// it: 20 gradients over layers 0 to 99 999 took 72 s on a 28-layer file, 3 500 of them
    /// hours. The plan now resolves the ends, and a step when a layer first asks for it: the
    /// layers printed cost a step each, whatever span the profile declares.
    #[test]
    fn b4_gradient_steps_cost_the_layers_printed_not_the_layers_declared() {
        let mut p = MixProfile::default();
        for space in [GradientSpace::Mix; 19].into_iter().chain([GradientSpace::Perceived]) {
            p.gradient.push(GradientSpec::parse("0-99999=Cyan..Magenta", space).unwrap());
        }
        let mut plan = Plan::new(&p).unwrap();
        assert_eq!(plan.mixes.len(), 2);
        assert!(plan.gradients.iter().all(|g| g.resolved.is_empty()));
        // The last gradient given is the one in force (they all start at layer 0).
        for layer in 0..28 {
            plan.mix_at(layer, 0.0).unwrap();
            plan.mix_at(layer, 0.0).unwrap();
        }
        let resolved: Vec<usize> = plan.gradients.iter().map(|g| g.resolved.len()).collect();
        assert_eq!(resolved, [[0; 19].as_slice(), &[28]].concat());
        // Past the declared span, the end.
        assert_eq!(plan.mix_at(100_000, 0.0).unwrap(), Some(1));
        // The total is not refused: the file's layers bound the work.
        let declared: u64 = p.gradient.iter().map(|g| u64::from(span(g).unwrap().2) + 1).sum();
        assert_eq!(declared, 2_000_000);
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
