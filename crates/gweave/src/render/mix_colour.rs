//! The colour a mixing hotend is predicted to print, move by move: the `mix` colouring.
//!
//! The file says the mix: its `T<n>`, `M163`/`M164`/`M165` and `M567` lines are followed with
//! the core's [`MixingState`]. The hardware says the colours: the filaments loaded on each
//! input (a `gweave mix` profile's `[[hardware.inputs]]` with their strengths, or cyan,
//! magenta, yellow, white), and the pigment model [`MixingModel`] (Kubelka-Munk on spectra)
//! predicts what a mix of them looks like, once per distinct mix (see [`MixTracker`]'s cache).
//!
//! Between two mixes the nozzle does not switch at once: the mixing chamber still holds the old
//! mix and is washed out by the new one ([`Washout`], a stirred chamber behind a plug-flow dead
//! volume). After a change, with `V` mm^3 extruded since, the old mix's share of what comes out
//! is `c = residual_fraction(V)`, and the ratios printed are `c * old + (1 - c) * new`. The
//! colour of a move is taken at the middle of its volume. The chamber and the dead volume are
//! linear in what flows through them, so changes that follow each other faster than they wash
//! out add up: what comes out is the first mix plus, for each change `k` at `V_k` from `a` to
//! `b`, `(b - a) * (1 - residual_fraction(V - V_k))` (a gradient on a spiral vase changes the
//! mix every few mm^3, less than the dead volume: restarting the washout at each change from
//! the blend then coming out held the first colour for the whole vase). A change that has
//! washed out is folded into the first mix; at most [`PENDING`] are followed, an older one
//! merged into the next. Every extruding move counts, also the ones a picture leaves out
//! (purges, other layers), since they all wash the chamber. This is what makes a purge-shifted transition visible: the old colour
//! fades into the new one along the part's own path, where `purge-shift` put it. The nozzle is
//! taken to be loaded with the mix the print's first extrusion uses (a printer is loaded and
//! primed with its first colour; the toolpath does not count the start G-code's prime lines),
//! so the first layer shows no transition.

use std::collections::{BTreeMap, HashMap};

use crate::colour::dialect::{MixingState, MixingUpdate, MARLIN_VIRTUAL_TOOLS};
use crate::colour::named_mixes::MixSpec;
use crate::colour::purge::{filament_mm_to_mm3, PurgeError, Washout};
use crate::colour::{Mix, MixError, MixingModel, Srgb8};
use crate::gcode::line::{Block, Command};
use crate::post::mix::profile::MixProfile;

/// Below this old-colour share a transition is over: 1/512 moves no 8-bit channel.
const SETTLED: f64 = 1.0 / 512.0;

/// Changes followed while they wash out: a gradient's every few mm^3 over a dead volume and a
/// chamber of some tens of mm^3 are a few dozen; a file that changes the mix at every move
/// would make the list, and each move's sum, as long as the file.
const PENDING: usize = 64;

/// Why the mix colouring cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum MixColourError {
    #[error(transparent)]
    Mix(#[from] MixError),
    #[error(transparent)]
    Purge(#[from] PurgeError),
}

/// The hardware side of the prediction: filaments, chamber, filament diameter.
#[derive(Debug, Clone)]
pub struct MixColours {
    model: MixingModel,
    washout: Washout,
    filament_diameter_mm: f64,
}

impl MixColours {
    /// The model of the filaments loaded on inputs 0, 1, ...; the chamber's washout; filament
    /// diameter, mm.
    pub fn new(
        model: MixingModel,
        washout: Washout,
        filament_diameter_mm: f64,
    ) -> Result<Self, MixColourError> {
        filament_mm_to_mm3(1.0, filament_diameter_mm)?;
        Ok(MixColours { model, washout, filament_diameter_mm })
    }

    /// The hardware of a `gweave mix` profile (its inputs, `purge.chamber_mm3`/`dead_mm3`).
    pub fn from_profile(profile: &MixProfile) -> Result<Self, MixColourError> {
        let hw = &profile.hardware;
        let washout = Washout::new(profile.purge.chamber_mm3, profile.purge.dead_mm3)?;
        Self::new(hw.mixing_model()?, washout, hw.filament_diameter_mm)
    }

    /// The defaults of a `gweave mix` profile: cyan, magenta, yellow, white on 1.75 mm.
    pub fn cmyw() -> Self {
        Self::from_profile(&MixProfile::default()).expect("the default profile is valid")
    }

    /// The predicted colour of `ratios` (one per input, summing to 1).
    pub fn predict(&self, ratios: &[f64]) -> Result<Srgb8, MixError> {
        self.model.predict(&Mix::new(ratios)?)
    }
}

impl PartialEq for MixColours {
    /// The model follows from the filaments.
    fn eq(&self, o: &Self) -> bool {
        self.model.inputs() == o.model.inputs()
            && self.model.strengths() == o.model.strengths()
            && self.washout == o.washout
            && self.filament_diameter_mm == o.filament_diameter_mm
    }
}

/// Follows a file's mixing lines and extrusion (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct MixTracker {
    colours: MixColours,
    state: MixingState,
    /// The mix the changes that have washed out left: what comes out but for the pending ones.
    base: Vec<f64>,
    /// The changes still washing out, oldest first: where each happened (in `extruded_mm3`)
    /// and what it changed the mix by (new minus old ratios).
    pending: std::collections::VecDeque<(f64, Vec<f64>)>,
    /// The mix the file extrudes now (`base` plus every pending change).
    to: Vec<f64>,
    /// Extruded since the start, mm^3.
    extruded_mm3: f64,
    /// Nothing extruded yet: the nozzle is taken to be loaded with the first mix used.
    loaded: bool,
    /// The colour of each settled mix (quantised ratios), predicted once.
    cache: HashMap<Vec<u16>, Srgb8>,
    /// The colour of `to` once the washout has settled, until the mix changes: most moves
    /// print it, and need neither a ratio vector nor a cache lookup.
    settled: Option<Srgb8>,
    /// A name for each settled mix's colour (see [`mix_name`]).
    names: BTreeMap<[u8; 3], String>,
    /// The names `gweave mix` gave the mixes it defined, by tool: its `; Pink = T1, predicted
    /// #ef4680` comment comes right before the lines that define tool 1, which name it.
    labels: HashMap<u32, String>,
    /// The name of the last such comment and its tool, until the tool is defined.
    pending_label: Option<(u32, String)>,
    /// The tool whose mix prints now (Marlin's virtual tool, or the RepRapFirmware tool).
    printing_tool: u32,
    /// The file has mixing commands (else the colouring has nothing of its own to show).
    pub(crate) mixing: bool,
}

impl MixTracker {
    pub(crate) fn new(colours: MixColours) -> Self {
        let inputs = colours.model.inputs().len();
        // At least one virtual tool: `new` cannot fail.
        let state = MixingState::new(inputs, MARLIN_VIRTUAL_TOOLS).expect("16 virtual tools");
        let to = state.active_mix().ratios().to_vec();
        MixTracker {
            colours,
            state,
            base: to.clone(),
            pending: std::collections::VecDeque::new(),
            to,
            extruded_mm3: 0.0,
            loaded: false,
            cache: HashMap::new(),
            names: BTreeMap::new(),
            settled: None,
            labels: HashMap::new(),
            pending_label: None,
            printing_tool: 0,
            mixing: false,
        }
    }

    /// A `gweave mix` definition comment, `Pink = T1, predicted #ef4680`: the label and tool.
    fn label_comment(raw: &[u8], block: &Block) -> Option<(u32, String)> {
        let text = std::str::from_utf8(block.comment_text(raw)?).ok()?.trim();
        let (label, rest) = text.rsplit_once(" = T")?;
        let (tool, rest) = rest.split_once(", predicted #")?;
        (rest.len() == 6).then_some(())?;
        Some((tool.parse().ok()?, label.to_owned()))
    }

    /// One line of the file; `tool` is the core state's tool after it (RepRapFirmware mixes
    /// are per tool).
    pub(crate) fn line(&mut self, raw: &[u8], block: &Block, tool: u32) {
        if let Some(label) = Self::label_comment(raw, block) {
            self.pending_label = Some(label);
        }
        // A line the firmware would refuse changes nothing.
        let update = match self.state.follow_line(raw, block) {
            Ok(Some(update)) => update,
            _ => return,
        };
        self.mixing = true;
        // A definition (M164, M165, M567; not a `T` selecting a tool) names the tool's mix
        // when a label comment announced it, and unnames it otherwise (M165 into a named tool).
        let defined = match (&update, &block.command) {
            (_, Command::Code { letter: b'T', .. }) => None,
            (MixingUpdate::Stored { tool, .. }, _) => Some(*tool as u32),
            (MixingUpdate::RrfMix { tool, .. }, _) => Some(*tool),
            _ => None,
        };
        if let Some(t) = defined {
            match self.pending_label.take_if(|(n, _)| *n == t) {
                Some((_, label)) => self.labels.insert(t, label),
                None => self.labels.remove(&t),
            };
        }
        self.printing_tool =
            if self.state.rrf_mix(tool).is_some() { tool } else { self.state.active_tool() as u32 };
        let target = self.active_ratios(tool);
        if target == self.to {
            return;
        }
        self.settled = None;
        if self.loaded {
            let change = target.iter().zip(&self.to).map(|(b, a)| b - a).collect();
            self.pending.push_back((self.extruded_mm3, change));
            if self.pending.len() > PENDING {
                // The oldest taken as happening with the next: its share arrives a little late.
                let (_, oldest) = self.pending.pop_front().expect("more than PENDING");
                let next = &mut self.pending[0].1;
                next.iter_mut().zip(oldest).for_each(|(n, o)| *n += o);
            }
        } else {
            // Not printing yet: the nozzle is loaded with the mix it starts with.
            self.base = target.clone();
        }
        self.to = target;
    }

    /// The ratios the firmware now extrudes: the tool's M567 mix if it has one, else Marlin's
    /// active virtual tool; normalised over the inputs the model knows.
    fn active_ratios(&self, tool: u32) -> Vec<f64> {
        let n = self.colours.model.inputs().len();
        let raw = self.state.rrf_mix(tool).unwrap_or(self.state.active_mix().ratios());
        let mut r: Vec<f64> = (0..n).map(|i| raw.get(i).copied().unwrap_or(0.0).max(0.0)).collect();
        let sum: f64 = r.iter().sum();
        if sum > 0.0 && sum.is_finite() {
            r.iter_mut().for_each(|v| *v /= sum);
            r
        } else {
            self.to.clone()
        }
    }

    /// Folds into `base` the changes washed out when `at_mm3` has been extruded; true when
    /// none is left (then `base` is `to`).
    fn settle(&mut self, at_mm3: f64) -> bool {
        while let Some((v_k, change)) = self.pending.front() {
            if self.colours.washout.residual_fraction(at_mm3 - v_k) >= SETTLED {
                return false;
            }
            self.base.iter_mut().zip(change).for_each(|(b, d)| *b += d);
            self.pending.pop_front();
        }
        // Exactly the mix in force, not its sum of changes.
        self.base.clone_from(&self.to);
        true
    }

    /// Ratios coming out when `at_mm3` has been extruded (see the module notes).
    fn output(&self, at_mm3: f64) -> Vec<f64> {
        let mut out = self.base.clone();
        for (v_k, change) in &self.pending {
            let arrived = 1.0 - self.colours.washout.residual_fraction(at_mm3 - v_k);
            out.iter_mut().zip(change).for_each(|(o, d)| *o += d * arrived);
        }
        out
    }

    /// An extruding move of `e_mm` filament (retractions, `e_mm <= 0`, wash nothing): its
    /// predicted colour.
    pub(crate) fn extrude(&mut self, e_mm: f64) -> Srgb8 {
        self.loaded = true;
        let v_mm3 = filament_mm_to_mm3(e_mm.max(0.0), self.colours.filament_diameter_mm).unwrap_or(0.0);
        let mid_mm3 = self.extruded_mm3 + v_mm3 / 2.0;
        self.extruded_mm3 += v_mm3;
        let settled = self.pending.is_empty() || self.settle(mid_mm3);
        if let (true, Some(c)) = (settled, self.settled) {
            return c;
        }
        let c = self.colour_of(&self.output(mid_mm3));
        if settled {
            self.settled = Some(c);
            let label = self.labels.get(&self.printing_tool);
            self.names
                .entry([c.r, c.g, c.b])
                .or_insert_with(|| label.cloned().unwrap_or_else(|| mix_name(&self.to)));
        }
        c
    }

    /// The names of the settled mixes' colours, for legends.
    pub(crate) fn into_names(self) -> BTreeMap<[u8; 3], String> {
        self.names
    }

    /// The predicted colour of `ratios`, through the cache.
    fn colour_of(&mut self, ratios: &[f64]) -> Srgb8 {
        // 1/4096 steps: finer than any colour difference the model can show in 8 bits.
        let key: Vec<u16> = ratios.iter().map(|r| (r * 4096.0).round() as u16).collect();
        if let Some(&c) = self.cache.get(&key) {
            return c;
        }
        let c = self.colours.predict(ratios).unwrap_or(Srgb8::new(0x80, 0x80, 0x80));
        if self.cache.len() < 1 << 16 {
            self.cache.insert(key, c);
        }
        c
    }
}

/// The seed palette's name of `ratios` (to 0.005 on each input; 4 inputs), else the ratios as
/// `0.25:0.25:0.5:0`.
fn mix_name(ratios: &[f64]) -> String {
    let named = crate::colour::named_mixes::Palette::seed().entries().iter().find_map(|e| match &e.spec {
        MixSpec::Ratios(m)
            if m.inputs() == ratios.len()
                && m.ratios().iter().zip(ratios).all(|(a, b)| (a - b).abs() < 0.005) =>
        {
            Some(e.name.clone())
        }
        _ => None,
    });
    named.unwrap_or_else(|| {
        let parts: Vec<String> =
            ratios.iter().map(|r| format!("{}", (r * 1000.0).round() / 1000.0)).collect();
        parts.join(":")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::lexer::parse_into;

    fn feed(t: &mut MixTracker, text: &str) {
        let mut block = Block::default();
        parse_into(text.as_bytes(), &mut block);
        t.line(text.as_bytes(), &block, 0);
    }

    #[test]
    fn a_change_fades_in_with_the_washout() {
        let cyan = Srgb8::new(0, 160, 224);
        let yellow = Srgb8::new(255, 224, 0);
        let washout = Washout::new(40.0, 10.0).unwrap();
        let colours = MixColours::new(MixingModel::new(&[cyan, yellow]).unwrap(), washout, 1.75).unwrap();
        let mut t = MixTracker::new(colours.clone());
        feed(&mut t, "T1");
        feed(&mut t, "T0");
        let pure0 = colours.predict(&[1.0, 0.0]).unwrap();
        let pure1 = colours.predict(&[0.0, 1.0]).unwrap();
        assert_eq!(t.extrude(1.0), pure0, "T0 is input 0 at reset");
        feed(&mut t, "T1");
        // 1 mm of 1.75 mm filament is 2.405 mm^3: its middle is still in the dead volume.
        assert_eq!(t.extrude(1.0), pure0);
        // 30 mm more: the middle at 2.405 + 36.08 = 38.49 mm^3, 28.49 past the dead volume.
        let c = (-(2.405_281_5 + 15.0 * 2.405_281_5 - 10.0) / 40.0_f64).exp();
        let mid = colours.predict(&[c, 1.0 - c]).unwrap();
        assert_eq!(t.extrude(30.0), mid);
        assert_ne!(mid, pure0);
        assert_ne!(mid, pure1);
        t.extrude(200.0);
        assert_eq!(t.extrude(1.0), pure1, "washed out");
        // Settled colours are named by their ratios (no palette entry has 2 inputs).
        let names = t.into_names();
        assert_eq!(names.get(&[pure1.r, pure1.g, pure1.b]).map(String::as_str), Some("0:1"));
        assert_eq!(mix_name(&[0.5, 0.0, 0.5, 0.0]), "Green");
        assert_eq!(mix_name(&[0.25, 0.0, 0.75, 0.0]), "0.25:0:0.75:0");
    }

    /// A new user's trial: a gradient on a spiral vase (a mix change every 6.7 mm^3, less than
    /// the 10 mm^3 dead volume) previewed in its first colour from bottom to top, each change
    /// restarting the washout from the blend then coming out, still the first mix. Changes that
    /// follow each other add up, each washing in from where it happened.
    #[test]
    fn changes_faster_than_the_washout_add_up() {
        let cyan = Srgb8::new(0, 160, 224);
        let yellow = Srgb8::new(255, 224, 0);
        let washout = Washout::new(40.0, 10.0).unwrap();
        let colours = MixColours::new(MixingModel::new(&[cyan, yellow]).unwrap(), washout, 1.75).unwrap();
        let mut t = MixTracker::new(colours.clone());
        for line in ["M163 S0 P0.5", "M163 S1 P0.5", "M164 S2", "T0"] {
            feed(&mut t, line);
        }
        let mm3 = 2.405_281_5; // a millimetre of 1.75 mm filament
        t.extrude(10.0);
        feed(&mut t, "T2"); // at 10 mm: half of each
        t.extrude(1.0);
        feed(&mut t, "T1"); // at 11 mm, the first change still in the dead volume
        let r = |since_mm3: f64| (-(since_mm3 - 10.0).max(0.0) / 40.0).exp();
        // The middle of the next 20 mm: 10 mm past the second change, 11 past the first.
        let (first, second) = (1.0 - r(11.0 * mm3), 1.0 - r(10.0 * mm3));
        let yellow_share = 0.5 * first + 0.5 * second;
        let want = colours.predict(&[1.0 - yellow_share, yellow_share]).unwrap();
        assert_eq!(t.extrude(20.0), want);
        assert!(yellow_share > 0.3, "both changes show: {yellow_share}");
        t.extrude(400.0);
        assert_eq!(t.extrude(1.0), colours.predict(&[0.0, 1.0]).unwrap(), "washed out");
        assert!(t.pending.is_empty());
    }

    /// A file that changes the mix at every move keeps at most PENDING changes in hand.
    #[test]
    fn the_changes_followed_are_bounded() {
        let mut t = MixTracker::new(MixColours::cmyw());
        t.extrude(1.0);
        for i in 0..10_000 {
            feed(&mut t, if i % 2 == 0 { "T1" } else { "T0" });
            t.extrude(0.01);
        }
        assert_eq!(t.pending.len(), PENDING);
        t.extrude(1000.0);
        assert!(t.pending.is_empty());
    }

    #[test]
    fn marlin_mixes_are_followed_and_refused_lines_ignored() {
        let mut t = MixTracker::new(MixColours::cmyw());
        feed(&mut t, "M163 S0 P0.5");
        feed(&mut t, "M163 S2 P0.5");
        feed(&mut t, "M164 S3");
        feed(&mut t, "T3");
        feed(&mut t, "M163 S9 P1"); // no input 9: refused
        t.extrude(1000.0);
        let green = MixColours::cmyw().predict(&[0.5, 0.0, 0.5, 0.0]).unwrap();
        assert_eq!(t.extrude(1.0), green);
        assert!(green.g > green.r, "cyan and yellow print green: {green}");
    }
}
