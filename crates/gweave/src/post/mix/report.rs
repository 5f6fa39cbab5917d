//! What `gweave mix` did: per mix its virtual tool, the layers it printed and the filament it
//! took; per input the filament used (print plus purges); the purge waste in mm, mm^3 and g; the
//! number of changes; and per layer the dominant mix and its predicted colour, which is what a
//! preview colours the print with ([`MixReport::layer_colours`]).
//!
//! Filament counts every E move of the print proper (retractions subtract, their unretraction
//! adds back) split by the ratios of the mix in force; the start and end G-code are not counted.

use serde::Serialize;

use crate::colour::Srgb8;

use super::profile::Hardware;
use super::schedule::{Plan, Slot};
use crate::firmware::MixCommands;
use crate::post::warning::Warning;

/// One mix of the job and where it went.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MixUse {
    /// The mix's label as the profile names it.
    pub name: String,
    /// Ratios per input as written, summing to 1.
    pub ratios: Vec<f64>,
    /// The colour the mixing model predicts, `#rrggbb`.
    pub predicted: String,
    /// The colour asked for, when solved from one.
    pub target: Option<String>,
    /// CIEDE2000 between target and prediction.
    pub delta_e: Option<f64>,
    /// The target colour is outside what the filaments can mix.
    pub out_of_gamut: bool,
    /// The virtual tool (none for M165 direct mixing); a gradient step shares one of two tools.
    pub tool: Option<u32>,
    /// A step inside a gradient.
    pub gradient_step: bool,
    /// Layer ranges (0-based, inclusive) where this mix extruded.
    pub layers: Vec<[u32; 2]>,
    /// Net filament through the nozzle with this mix, mm.
    pub filament_mm: f64,
}

/// Purge waste.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct PurgeTotals {
    /// Purges written.
    pub count: u32,
    /// Filament purged, mm.
    pub filament_mm: f64,
    /// Plastic purged, mm^3.
    pub volume_mm3: f64,
    /// Plastic purged, g (with each input's density).
    pub mass_g: f64,
    /// Filament purged per input, mm.
    pub per_input_mm: Vec<f64>,
}

/// The dominant mix of one layer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LayerMix {
    /// The layer, 0-based.
    pub layer: u32,
    /// Its height, mm.
    pub z_mm: f64,
    /// Index into [`MixReport::mixes`].
    pub mix: usize,
    /// The mix's predicted colour, `#rrggbb`.
    pub colour: String,
}

/// The report; see the module docs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MixReport {
    /// How the mixes were written to the firmware.
    pub dialect: MixCommands,
    /// The firmware flavour the file names (`gcode_flavor`, Cura's `;FLAVOR:`); a profile that
    /// sets no dialect follows it.
    pub flavour: Option<String>,
    /// Every mix of the job.
    pub mixes: Vec<MixUse>,
    /// Print plus purges, mm, per input.
    pub filament_per_input_mm: Vec<f64>,
    /// Print plus purges, g, per input (with each input's density).
    pub filament_per_input_g: Vec<f64>,
    /// Purge waste.
    pub purge: PurgeTotals,
    /// Changes of mix during the print (the first selection is not one).
    pub changes: u32,
    /// Lines rewritten for the Z feed cap.
    pub z_capped_lines: u64,
    /// Slicer tool-change retractions and unretractions removed.
    pub dropped_retractions: u64,
    /// Hotend temperatures the slicer set for one of its tools, rewritten for the one nozzle:
    /// for the tool printing without its `T` (but `T0`, kept as written), for another tool (a
    /// preheat, a standby) made a comment.
    pub tool_temperatures: u64,
    /// The dominant mix of each layer.
    pub layers: Vec<LayerMix>,
    /// What the run noticed and did anyway.
    pub warnings: Vec<Warning>,
}

impl MixReport {
    /// Predicted colour of each layer's dominant mix, for a preview.
    pub fn layer_colours(&self) -> Vec<(u32, Srgb8)> {
        self.layers.iter().filter_map(|l| l.colour.parse().ok().map(|c| (l.layer, c))).collect()
    }

    /// A short human summary (what the CLI prints): each mix with its tool, ratios, predicted
    /// colour, layers and filament; the changes, the purge waste and each input's filament.
    pub fn summary(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = match &self.flavour {
            Some(f) => writeln!(s, "mixes ({:?}; the file's flavour: {f})", self.dialect),
            None => writeln!(s, "mixes ({:?})", self.dialect),
        };
        for m in &self.mixes {
            let tool = m.tool.map_or("-".to_owned(), |t| format!("T{t}"));
            let ratios: Vec<String> = m.ratios.iter().map(|x| format!("{x:.4}")).collect();
            let de = match (m.target.as_deref(), m.delta_e) {
                (Some(t), Some(d)) => {
                    format!("  target {t} dE {d:.1}{}", if m.out_of_gamut { " (out of gamut)" } else { "" })
                }
                _ => String::new(),
            };
            let layers: Vec<String> = m
                .layers
                .iter()
                .map(|[a, b]| if a == b { a.to_string() } else { format!("{a}-{b}") })
                .collect();
            let _ = writeln!(
                s,
                "  {tool:<4} {:<22} {:<32} {}  layers {}  {:.1} mm{de}",
                m.name,
                ratios.join(":"),
                m.predicted,
                if layers.is_empty() { "none".to_owned() } else { layers.join(",") },
                m.filament_mm
            );
        }
        let _ = writeln!(s, "changes         {}", self.changes);
        let p = &self.purge;
        let _ = writeln!(
            s,
            "purge           {} x, {:.1} mm, {:.0} mm3, {:.2} g",
            p.count, p.filament_mm, p.volume_mm3, p.mass_g
        );
        let per: Vec<String> = self
            .filament_per_input_mm
            .iter()
            .zip(&self.filament_per_input_g)
            .enumerate()
            .map(|(i, (mm, g))| format!("E{i} {mm:.1} mm ({g:.2} g)"))
            .collect();
        let _ = writeln!(s, "filament        {}", per.join(", "));
        let _ = writeln!(s, "z-capped lines  {}", self.z_capped_lines);
        if self.dropped_retractions > 0 {
            let _ = writeln!(s, "dropped slicer tool-change retractions {}", self.dropped_retractions);
        }
        if self.tool_temperatures > 0 {
            let _ = writeln!(
                s,
                "slicer tool temperatures rewritten {} (one nozzle: the printing tool's kept, others made comments)",
                self.tool_temperatures
            );
        }
        s
    }
}

/// A layer being printed: index, Z, and filament per mix in it.
type OpenLayer = (u32, f64, Vec<(usize, f64)>);

/// Collects the figures while the pass runs.
#[derive(Debug, Clone)]
pub(crate) struct Accounting {
    area_mm2: f64,
    /// Ratio units in a whole (10^ratio_decimals).
    scale: f64,
    pub mixes: Vec<MixUse>,
    /// Each mix's ratios, one mix after the other (`per_input_mm.len()` numbers each).
    ratios: Vec<f64>,
    pub per_input_mm: Vec<f64>,
    pub purge: PurgeTotals,
    pub changes: u32,
    pub z_capped_lines: u64,
    pub dropped_retractions: u64,
    pub tool_temperatures: u64,
    layers: Vec<LayerMix>,
    /// The layer being printed.
    current: Option<OpenLayer>,
    pub warnings: Vec<Warning>,
}

impl Accounting {
    pub(crate) fn new(plan: &Plan, hw: &Hardware) -> Self {
        let d = hw.filament_diameter_mm;
        let mut acc = Accounting {
            area_mm2: std::f64::consts::PI * d * d / 4.0,
            scale: 10f64.powi(hw.ratio_decimals as i32),
            mixes: Vec::new(),
            ratios: Vec::new(),
            per_input_mm: vec![0.0; hw.inputs.len()],
            purge: PurgeTotals { per_input_mm: vec![0.0; hw.inputs.len()], ..PurgeTotals::default() },
            changes: 0,
            z_capped_lines: 0,
            dropped_retractions: 0,
            tool_temperatures: 0,
            layers: Vec::new(),
            current: None,
            warnings: plan.warnings.clone(),
        };
        acc.learn(plan);
        acc
    }

    /// Takes in the mixes the plan resolved since the last call (gradient steps, as the layers
    /// that print them come).
    pub(crate) fn learn(&mut self, plan: &Plan) {
        for m in &plan.mixes[self.mixes.len()..] {
            let ratios: Vec<f64> = m.units.iter().map(|&u| u as f64 / self.scale).collect();
            self.ratios.extend_from_slice(&ratios);
            self.mixes.push(MixUse {
                name: m.label.clone(),
                ratios,
                predicted: m.predicted.to_hex(),
                target: m.target.map(Srgb8::to_hex),
                delta_e: m.delta_e,
                out_of_gamut: m.out_of_gamut,
                tool: match m.slot {
                    Slot::Fixed(t) => Some(t),
                    Slot::Rotating | Slot::Direct => None,
                },
                gradient_step: m.gradient_step,
                layers: Vec::new(),
                filament_mm: 0.0,
            });
        }
    }

    /// A rotating tool now holds `mix`.
    pub(crate) fn set_tool(&mut self, mix: usize, tool: u32) {
        self.mixes[mix].tool = Some(tool);
    }

    /// `e_mm` of filament through the nozzle with `mix`; `printed` gives the layer and Z of a
    /// move that deposits it (not a retraction or unretraction).
    #[inline]
    pub(crate) fn filament(&mut self, mix: usize, e_mm: f64, printed: Option<(u32, f64)>) {
        let n = self.per_input_mm.len();
        for (acc, r) in self.per_input_mm.iter_mut().zip(&self.ratios[mix * n..][..n]) {
            *acc += e_mm * r;
        }
        self.mixes[mix].filament_mm += e_mm;
        let Some((layer, z_mm)) = printed else { return };
        // Most moves: a mix already printing on the layer being printed, whose range of layers
        // took this layer when it first printed on it (a move on another layer closes it).
        if let Some(cur) = self.current.as_mut().filter(|c| c.0 == layer) {
            if let Some((_, e)) = cur.2.iter_mut().find(|(m, _)| *m == mix) {
                *e += e_mm;
                return;
            }
        }
        let ranges = &mut self.mixes[mix].layers;
        match ranges.last_mut() {
            Some([_, b]) if *b == layer => {}
            Some([_, b]) if *b + 1 == layer => *b = layer,
            _ => ranges.push([layer, layer]),
        }
        if self.current.as_ref().is_some_and(|c| c.0 != layer) {
            self.close_layer();
        }
        let cur = self.current.get_or_insert((layer, z_mm, Vec::new()));
        match cur.2.iter_mut().find(|(m, _)| *m == mix) {
            Some((_, e)) => *e += e_mm,
            None => cur.2.push((mix, e_mm)),
        }
    }

    fn close_layer(&mut self) {
        if let Some((layer, z_mm, per_mix)) = self.current.take() {
            if let Some(&(mix, _)) = per_mix.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
                let colour = self.mixes[mix].predicted.clone();
                self.layers.push(LayerMix { layer, z_mm, mix, colour });
            }
        }
    }

    /// A purge of `mm` with `mix`.
    pub(crate) fn purge(&mut self, mix: usize, mm: f64) {
        self.purge.count += 1;
        self.purge.filament_mm += mm;
        self.purge.volume_mm3 += mm * self.area_mm2;
        let n = self.per_input_mm.len();
        let ratios = &self.ratios[mix * n..][..n];
        for ((acc, total), r) in self.purge.per_input_mm.iter_mut().zip(&mut self.per_input_mm).zip(ratios) {
            *acc += mm * r;
            *total += mm * r;
        }
    }

    pub(crate) fn finish(mut self, hw: &Hardware) -> MixReport {
        self.close_layer();
        let grams = |mm: &[f64]| -> Vec<f64> {
            mm.iter().zip(&hw.inputs).map(|(l, i)| l * self.area_mm2 / 1000.0 * i.density_g_cm3).collect()
        };
        self.purge.mass_g = grams(&self.purge.per_input_mm).iter().sum();
        MixReport {
            dialect: hw.dialect(),
            flavour: None,
            filament_per_input_g: grams(&self.per_input_mm),
            mixes: self.mixes,
            filament_per_input_mm: self.per_input_mm,
            purge: self.purge,
            changes: self.changes,
            z_capped_lines: self.z_capped_lines,
            dropped_retractions: self.dropped_retractions,
            tool_temperatures: self.tool_temperatures,
            layers: self.layers,
            warnings: self.warnings,
        }
    }
}
