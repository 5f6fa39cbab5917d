//! `gweave stats`: what a file will print, from one streaming pass. Filament per tool, extents,
//! layers, distances and a simple feed-rate time by feature (the virtual printer's planner gives
//! the real time), plus the slicer's own figures read from its comments for comparison.

use std::collections::BTreeMap;
use std::io::Write;

use serde::Serialize;

use crate::gcode::ends::{missing_footer, read_ends};
use crate::gcode::flavour::{extrusion_letter, flavour_of_comment};
use crate::gcode::layers::{Region, Slicer, ALL_FEATURES};
use crate::gcode::reader::RawLine;
use crate::gcode::retraction::Retraction;
use crate::gcode::state::{Effect, Motion, Move, Path, Position, State, X, Y, Z};
use crate::gcode::wipe_tower::WipeTower;
use crate::pass::{Ctx, Flow, Pass, Step};

/// Filament used by one tool.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ToolFilament {
    /// The tool number.
    pub tool: u32,
    /// Filament pushed out of the nozzle, mm: extrusions and stationary purges; retractions
    /// and the primes that undo them cancel (see `gcode/retraction.rs`).
    pub extruded_mm: f64,
    /// Volume of that filament, mm^3.
    pub extruded_mm3: f64,
    /// Filament fed forwards on moves along X or Y, mm: what PrusaSlicer counts as "filament
    /// used" (its G-code processor takes every such move for an extrusion). It also counts the
    /// feed that only refills a retraction while moving, and a wipe tower's loading moves,
    /// which push a filament unloaded at an earlier tool change back down to the nozzle: none
    /// of that leaves the nozzle. Stationary purges are not in it.
    pub fed_moving_mm: f64,
    /// Of `extruded_mm`, what the wipe tower's priming block (`; CP PRIMING START` to `; CP
    /// PRIMING END`, PrusaSlicer's "prime all printing extruders") pushed out.
    pub primed_mm: f64,
    /// The filament as PrusaSlicer 2.5 counts its `filament used [mm]`: the same count without
    /// the wipe tower's priming block and without a single-extruder tool change's unloading and
    /// loading moves, which it leaves out (see `gcode/wipe_tower.rs`). Equal to `extruded_mm`
    /// without a tower.
    pub as_prusaslicer_mm: f64,
}

/// What [`StatsPass`] follows per tool.
#[derive(Debug, Clone, Copy, Default)]
struct ToolFeed {
    /// [`ToolFilament::extruded_mm`] so far, and the retraction in force.
    out_mm: f64,
    retraction: Retraction,
    /// [`ToolFilament::fed_moving_mm`] so far.
    fed_moving_mm: f64,
    /// [`ToolFilament::primed_mm`] so far.
    primed_mm: f64,
    /// [`ToolFilament::as_prusaslicer_mm`] so far, and the retraction in force as PrusaSlicer
    /// sees it (it never sees the unloading, so the loading refills nothing).
    as_prusaslicer_mm: f64,
    prusaslicer_retraction: Retraction,
}

/// An axis-aligned box, mm.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Bounds {
    /// Smallest X, Y, Z, mm.
    pub min: [f64; 3],
    /// Largest X, Y, Z, mm.
    pub max: [f64; 3],
}

impl Bounds {
    /// Whether the box holds no point yet ([`Bounds::default`]).
    pub fn is_empty(&self) -> bool {
        self.min[0] > self.max[0]
    }

    /// Grows the box to hold `p`. Plain comparisons rather than f64::min/max (which also
    /// handle NaN, in several instructions): positions come from numbers the lexer has checked
    /// to be finite. Written as selections, they become one min and one max instruction per
    /// axis, no branch.
    #[inline]
    pub fn grow(&mut self, p: [f64; 3]) {
        for (i, v) in p.into_iter().enumerate() {
            self.min[i] = if v < self.min[i] { v } else { self.min[i] };
            self.max[i] = if v > self.max[i] { v } else { self.max[i] };
        }
    }
}

/// The box that holds no point (min above max): growing it by one point gives that point.
impl Default for Bounds {
    fn default() -> Self {
        Bounds { min: [f64::INFINITY; 3], max: [f64::NEG_INFINITY; 3] }
    }
}

/// What the slicer itself wrote about the print, for comparison.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct SlicerFigures {
    /// PrusaSlicer/Slic3r `; filament used [mm] = a, b, c`, Cura's `;Filament used: 1.2m`.
    pub filament_used_mm: Option<Vec<f64>>,
    /// PrusaSlicer `; estimated printing time (normal mode) = 1h 2m 3s`, in seconds.
    pub estimated_time_s: Option<f64>,
    /// `; filament_diameter = 1.75,1.75` (PrusaSlicer family) or Cura's `;FILAMENT_DIAMETER`.
    pub filament_diameter_mm: Option<f64>,
    /// `;FLAVOR:` (Cura) or `; gcode_flavor =` (PrusaSlicer family).
    pub flavour: Option<String>,
}

/// The statistics of one file.
#[derive(Debug, Clone, Serialize)]
pub struct Stats {
    /// Size of the file, bytes.
    pub bytes: u64,
    /// Lines in the file.
    pub lines: u64,
    /// The slicer that wrote it.
    pub slicer: Slicer,
    /// Layers printed.
    pub layers: u32,
    /// Z range of extrusion, mm.
    pub z_range_mm: Option<[f64; 2]>,
    /// Bounding box of extruding moves, mm.
    pub extrusion_bounds: Option<Bounds>,
    /// Tool changes (`T<n>` to another tool).
    pub tool_changes: u32,
    /// Filament diameter used for volumes, mm.
    pub filament_diameter_mm: f64,
    /// Filament per tool.
    pub filament: Vec<ToolFilament>,
    /// Length of extruding moves, mm.
    pub print_mm: f64,
    /// Length of travel moves, mm.
    pub travel_mm: f64,
    /// Length over feed rate for every move, by feature type, s (no acceleration).
    pub time_by_feature_s: BTreeMap<&'static str, f64>,
    /// Print time as length over feed rate, s (no acceleration).
    pub time_s: f64,
    /// Lines of start and end G-code detected.
    pub start_lines: u64,
    /// Lines of end G-code detected.
    pub end_lines: u64,
    /// What the slicer's own comments state (time, filament).
    pub slicer_figures: SlicerFigures,
    /// Whether the filament the file states ([`SlicerFigures::filament_used_mm`]) is what it
    /// extrudes, per tool, within the figure's rounding (0.05 mm) or 0.01 %; `None` if it
    /// states none.
    pub filament_matches_slicer: Option<bool>,
    /// What the file does that is worth a look.
    pub warnings: Vec<String>,
    /// A rotary program (its header names the machine): the extents on the mandrel; the
    /// lengths and times above are then measured on its surface ([`crate::rotary::surface`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotary: Option<crate::rotary::surface::RotarySurface>,
    /// The last line has no line ending: a file written by hand, or one cut short
    /// ([`stats_file`] then reads its ends for the slicer's last line, [`missing_footer`]).
    #[serde(skip)]
    pub(crate) unended: bool,
}

/// The pass that gathers [`Stats`].
#[derive(Debug, Default)]
pub struct StatsPass {
    bytes: u64,
    /// The last line read had no line ending: a file written by hand, or one cut short.
    unended: bool,
    /// Lines in each region of the file, indexed by `Region as usize`.
    lines_by_region: [u64; 3],
    /// Per tool: the filament out of its nozzle, its retraction in force, and the filament fed
    /// forwards on moves along X or Y ([`ToolFilament::fed_moving_mm`]).
    feeds: Vec<ToolFeed>,
    /// The wipe tower's parts, for [`ToolFilament::primed_mm`] and
    /// [`ToolFilament::as_prusaslicer_mm`].
    tower: WipeTower,
    /// The box of extruding moves so far: empty (min above max) until the first.
    bounds: Bounds,
    /// The last move extruded and nothing has set the position since: the next move starts
    /// where that one ended, a point the box holds already.
    start_in_bounds: bool,
    tool_changes: u32,
    print_mm: f64,
    travel_mm: f64,
    /// Indexed by `Feature as usize`.
    time_by_feature_s: [f64; ALL_FEATURES.len()],
    figures: SlicerFigures,
    zero_feed_moves: u64,
    /// Filament diameter given by the user, overriding the file's.
    diameter_override_mm: Option<f64>,
}

/// Filament diameter when neither the file nor the user says, mm.
pub(crate) const DEFAULT_FILAMENT_DIAMETER_MM: f64 = 1.75;

impl StatsPass {
    /// Statistics with the filament diameter forced to `diameter_override_mm`, if given.
    pub fn new(diameter_override_mm: Option<f64>) -> Self {
        StatsPass { diameter_override_mm, ..Default::default() }
    }

    /// Turns what was gathered into the report, given the state after the last line.
    pub fn into_stats(self, state: &State) -> Stats {
        let diameter = self
            .diameter_override_mm
            .or(self.figures.filament_diameter_mm)
            .unwrap_or(DEFAULT_FILAMENT_DIAMETER_MM);
        let area_mm2 = std::f64::consts::PI * diameter * diameter / 4.0;
        let filament = self
            .feeds
            .iter()
            .enumerate()
            .map(|(tool, f)| ToolFilament {
                tool: tool as u32,
                extruded_mm: f.out_mm,
                extruded_mm3: f.out_mm * area_mm2,
                fed_moving_mm: f.fed_moving_mm,
                primed_mm: f.primed_mm,
                as_prusaslicer_mm: f.as_prusaslicer_mm,
            })
            .collect();
        let mut warnings = Vec::new();
        if self.zero_feed_moves > 0 {
            warnings.push(format!("{} moves had no feed rate and were not timed", self.zero_feed_moves));
        }
        if let Some(flavour) = &self.figures.flavour {
            let letter = extrusion_letter(flavour);
            if letter != state.options().firmware.extrusion_letter() {
                // The flavour is looked for at both ends of the file before the moves are read
                // (standard input is spooled to be read the same way): only a flavour named
                // in the middle of the file is seen too late.
                warnings.push(format!(
                    "the file's flavour ({flavour}) extrudes with {}, but it was read with {}: the flavour is named in the middle of the file, past where gweave looks for it (slicers name it at the start or the end)",
                    char::from(letter),
                    char::from(state.options().firmware.extrusion_letter())
                ));
            }
        }
        if state.structure.region != Region::End {
            warnings.push("no end G-code detected (the print proper runs to the end of the file)".into());
        }
        let extrusion_bounds = (!self.bounds.is_empty()).then_some(self.bounds);
        let matches = |ours: &dyn Fn(usize) -> f64| {
            self.figures.filament_used_mm.as_ref().map(|theirs| {
                (0..theirs.len().max(self.feeds.len())).all(|i| {
                    let theirs = theirs.get(i).copied().unwrap_or(0.0);
                    (ours(i) - theirs).abs() <= (theirs * 1e-4).max(0.05)
                })
            })
        };
        let filament_matches_slicer = matches(&|i| self.feeds.get(i).map_or(0.0, |f| f.out_mm));
        if filament_matches_slicer == Some(false) {
            if matches(&|i| self.feeds.get(i).map_or(0.0, |f| f.fed_moving_mm)) == Some(true) {
                warnings.push(refills_counted(&self.feeds));
            } else if matches(&|i| self.feeds.get(i).map_or(0.0, |f| f.as_prusaslicer_mm)) == Some(true) {
                warnings.push(tower_left_out(&self.feeds));
            } else if let Some(theirs) = &self.figures.filament_used_mm {
                warnings.push(figures_differ(&self.feeds, theirs));
            }
        }
        Stats {
            bytes: self.bytes,
            lines: self.lines_by_region.iter().sum(),
            slicer: state.structure.slicer,
            layers: state.structure.layer.map_or(0, |l| l + 1),
            z_range_mm: extrusion_bounds.map(|b| [b.min[2], b.max[2]]),
            extrusion_bounds,
            tool_changes: self.tool_changes,
            filament_diameter_mm: diameter,
            filament,
            print_mm: self.print_mm,
            travel_mm: self.travel_mm,
            time_s: self.time_by_feature_s.iter().sum(),
            time_by_feature_s: ALL_FEATURES
                .iter()
                .zip(self.time_by_feature_s)
                .filter(|(_, t)| *t > 0.0)
                .map(|(f, t)| (f.name(), t))
                .collect(),
            start_lines: self.lines_by_region[Region::Start as usize],
            end_lines: self.lines_by_region[Region::End as usize],
            slicer_figures: self.figures,
            filament_matches_slicer,
            warnings,
            rotary: None,
            unended: self.unended,
        }
    }

    /// `fed_mm` of filament fed (negative: retracted) by the active tool, on a move along X or
    /// Y if `moves_xy`; returns that tool's feeds.
    #[inline(always)]
    fn feed(&mut self, tool: u32, fed_mm: f64, moves_xy: bool) -> &mut ToolFeed {
        let tool = tool as usize;
        if self.feeds.len() <= tool {
            self.feeds.resize(tool + 1, Default::default());
        }
        let prusaslicer_counts = self.tower.feed(fed_mm, moves_xy);
        let f = &mut self.feeds[tool];
        let out_mm = f.retraction.feed(fed_mm);
        f.out_mm += out_mm;
        if prusaslicer_counts {
            f.as_prusaslicer_mm += f.prusaslicer_retraction.feed(fed_mm);
        } else if self.tower.priming() {
            f.primed_mm += out_mm;
        }
        f
    }

    #[cold]
    #[inline(never)]
    fn read_figures(&mut self, comment: &[u8]) {
        let c = comment.trim_ascii();
        if c.starts_with(b"CP ") {
            self.tower.comment(c);
        } else if let Some(v) = c.strip_prefix(b"filament used [mm] =") {
            self.figures.filament_used_mm = list(v);
        } else if let Some(v) = c.strip_prefix(b"filament used =") {
            // Slic3r: one line per extruder, `; filament used = 607.8mm (1.5cm3)`.
            let mm = v.split(|&b| b == b'm').next().and_then(list).and_then(|l| l.first().copied());
            if let Some(mm) = mm {
                self.figures.filament_used_mm.get_or_insert_with(Vec::new).push(mm);
            }
        } else if let Some(v) = c.strip_prefix(b"Filament used:") {
            // Cura: `;Filament used: 1.2m, 0.5m`. Its command line writes `0m` as a
            // placeholder (the front end fills it in): no figure at all.
            let m =
                v.split(|&b| b == b',').map(|x| list(x.trim_ascii().strip_suffix(b"m")?)?.first().copied());
            let mm: Option<Vec<f64>> = m.map(|x| x.map(|m| m * 1000.0)).collect();
            self.figures.filament_used_mm = mm.filter(|l| l.iter().any(|&x| x != 0.0));
        } else if let Some(v) = c.strip_prefix(b"estimated printing time (normal mode) =") {
            self.figures.estimated_time_s = duration_s(v);
        } else if let Some(v) =
            c.strip_prefix(b"filament_diameter =").or_else(|| c.strip_prefix(b"FILAMENT_DIAMETER:"))
        {
            self.figures.filament_diameter_mm = list(v).and_then(|l| l.first().copied());
        } else if let Some(v) = flavour_of_comment(c) {
            self.figures.flavour = Some(String::from_utf8_lossy(v).into_owned());
        }
    }
}

impl Pass for StatsPass {
    fn reads_words(&self) -> bool {
        false
    }

    #[inline(always)]
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        self.count_line(&ctx.line, ctx.state);
        if let Some(c) = ctx.block.comment_text(ctx.line.bytes) {
            if c.len() > 8 {
                self.read_figures(c);
            }
        }
        match ctx.effect {
            Effect::Move(m) => self.count_move(m, ctx.state),
            Effect::FirmwareRetract { e_mm } => {
                self.feed(ctx.state.tool, *e_mm, false);
            }
            Effect::ToolChange { from, to } if from != to => self.tool_changes += 1,
            Effect::Dwell { t_s } => {
                self.time_by_feature_s[ctx.state.structure.feature as usize] += t_s;
            }
            // The logical position changed without a move.
            Effect::SetPosition | Effect::Home { .. } => self.start_in_bounds = false,
            _ => {}
        }
        Ok(Flow::Continue)
    }
}

impl StatsPass {
    /// [`Pass::line`] for a plain move read without a [`Block`](crate::Block)
    /// ([`read_plain_move`](crate::gcode::lexer::read_plain_move), then
    /// [`State::apply_plain`]), which says what it did by the position before it (`from`), the
    /// state after it and whether it moved (`moved`, what `apply_plain` returned): the same
    /// count, to the bit, as the line through the lexer and [`State::apply`].
    #[inline(always)]
    pub fn plain_move(&mut self, line: &RawLine<'_>, from: &Position, moved: bool, state: &State) {
        self.count_line(line, state);
        // A plain move has no comment to read; if it moved, `State::apply` would have made
        // this move its effect.
        if moved {
            let m = Move {
                from: *from,
                to: state.pos,
                path: Path::Line,
                rapid: state.motion == Motion::Rapid,
                feed_mm_min: state.feed_mm_min,
            };
            self.count_move(&m, state);
        }
    }

    /// Counts the line `line` (its bytes, its region in `state`, whether it ends).
    #[inline(always)]
    fn count_line(&mut self, line: &RawLine<'_>, state: &State) {
        self.bytes += (line.bytes.len() + line.eol.len()) as u64;
        self.unended = line.eol.is_empty();
        self.lines_by_region[state.structure.region as usize] += 1;
    }

    /// Counts the move `m`, by the tool and the feature of `state` (the state after it).
    #[inline(always)]
    fn count_move(&mut self, m: &Move, state: &State) {
        let len_mm = m.len_mm();
        let e_mm = m.e_mm();
        if e_mm != 0.0 {
            let moves_xy = m.to[X] != m.from[X] || m.to[Y] != m.from[Y];
            let f = self.feed(state.tool, e_mm, moves_xy);
            if e_mm > 0.0 && moves_xy {
                f.fed_moving_mm += e_mm;
            }
        }
        // A print move extrudes while moving (any of X, Y, Z).
        if e_mm > 0.0 && len_mm > 0.0 {
            self.print_mm += len_mm;
            // Extrusions come in runs, each starting where the last ended: the start
            // is needed only after a travel (a test the processor guesses right).
            if !self.start_in_bounds {
                self.bounds.grow([m.from[X], m.from[Y], m.from[Z]]);
            }
            self.bounds.grow([m.to[X], m.to[Y], m.to[Z]]);
            self.start_in_bounds = true;
            // An arc bulges past its end points (its Z stays between theirs).
            if let Path::Arc(arc) = &m.path {
                let [min, max] = arc.bounds();
                self.bounds.grow([min[0], min[1], m.to[Z]]);
                self.bounds.grow([max[0], max[1], m.to[Z]]);
            }
        } else {
            self.travel_mm += len_mm;
            self.start_in_bounds = false;
        }
        let dist_mm = if len_mm > 0.0 { len_mm } else { e_mm.abs() };
        if m.feed_mm_min > 0.0 {
            self.time_by_feature_s[state.structure.feature as usize] += dist_mm * 60.0 / m.feed_mm_min;
        } else if dist_mm > 0.0 {
            self.zero_feed_moves += 1;
        }
    }
}

/// Why the slicer's filament figures are above the count, when they are what the file feeds
/// forwards while moving ([`ToolFilament::fed_moving_mm`]): per tool, the difference.
#[cold]
fn refills_counted(feeds: &[ToolFeed]) -> String {
    let more: Vec<String> =
        feeds.iter().enumerate().map(|(t, f)| format!("T{t} {:.2} mm", f.fed_moving_mm - f.out_mm)).collect();
    format!(
        "the slicer's filament figures are what the file feeds forwards while moving ({}); that includes the moves that only load back filament retracted or unloaded before (a wipe tower's loading moves at each tool change), which leaves no nozzle and takes no more from the spool: the count above is the filament out of each nozzle",
        more.join(", ")
    )
}

/// Why the slicer's filament figures are below the count, when they are the count as
/// PrusaSlicer makes it ([`ToolFilament::as_prusaslicer_mm`]): per tool, the difference.
#[cold]
fn tower_left_out(feeds: &[ToolFeed]) -> String {
    let by: Vec<String> = feeds
        .iter()
        .enumerate()
        .map(|(t, f)| format!("T{t} {:.2} mm", f.out_mm - f.as_prusaslicer_mm))
        .collect();
    format!(
        "the slicer's filament figures are the count above less {} (the JSON's as_prusaslicer_mm): PrusaSlicer counts its wipe tower as it lays it out, without the priming block and without a single-extruder tool change's unloading and loading moves; the count above follows every E the file feeds",
        by.join(", ")
    )
}

/// The slicer's filament figures differ from the count and no rule known here explains it:
/// per tool, by how much, so that the summary's "see the warnings" finds a warning.
#[cold]
fn figures_differ(feeds: &[ToolFeed], theirs: &[f64]) -> String {
    let by: Vec<String> = (0..theirs.len().max(feeds.len()))
        .map(|t| {
            let ours = feeds.get(t).map_or(0.0, |f| f.out_mm);
            let theirs = theirs.get(t).copied().unwrap_or(0.0);
            let percent = if theirs > 0.0 {
                format!(" ({:+.2} %)", (ours / theirs - 1.0) * 100.0)
            } else {
                String::new()
            };
            format!("T{t} {:+.2} mm{percent}", ours - theirs)
        })
        .collect();
    format!(
        "the count above differs from the slicer's filament figures by {} (the count minus the slicer's), and not as the slicer's own rule for a wipe tower's loading moves would: the count is the net E of every move, retractions undone by their primes",
        by.join(", ")
    )
}

/// `1.75, 2.85` -> [1.75, 2.85].
fn list(v: &[u8]) -> Option<Vec<f64>> {
    std::str::from_utf8(v).ok()?.split([',', ';']).map(|s| s.trim().parse().ok()).collect()
}

/// `1d 2h 3m 4s` -> seconds.
fn duration_s(v: &[u8]) -> Option<f64> {
    let text = std::str::from_utf8(v).ok()?;
    let mut total = 0.0;
    for part in text.split_whitespace() {
        let (num, unit) = part.split_at(part.len().checked_sub(1)?);
        let n: f64 = num.parse().ok()?;
        total += n * match unit {
            "d" => 86400.0,
            "h" => 3600.0,
            "m" => 60.0,
            "s" => 1.0,
            _ => return None,
        };
    }
    Some(total)
}

/// The statistics of the file at `path` (`diameter_mm` overrides the file's filament
/// diameter); a lenient read goes past malformed lines and counts them. A strict read runs the
/// bare pass, the hot loop as it was: no malformed line ever reaches it.
pub fn stats_file(
    path: &std::path::Path,
    diameter_mm: Option<f64>,
    strictness: crate::pass::Strictness,
    progress: &mut dyn crate::pass::Progress,
) -> crate::Result<crate::malformed::WithMalformed<Stats>> {
    use crate::malformed::{Malformed, WithMalformed};
    use crate::pass::Counting;
    use crate::rotary::{preview::RotaryReading, surface::SurfacePass};
    // A program whose header names a rotary machine is measured on its mandrel.
    let rotary = RotaryReading::for_file(path, None).ok().flatten();
    let run = crate::run::Run::file(path).progress(progress).strictness(strictness);
    let malformed = Malformed::default();
    let mut stats = match (strictness, rotary) {
        (crate::pass::Strictness::Strict, None) => {
            let mut pass = StatsPass::new(diameter_mm);
            let state = run.scan(&mut pass)?;
            WithMalformed { report: pass.into_stats(&state), malformed }
        }
        (crate::pass::Strictness::Strict, Some(reading)) => {
            let mut pass = SurfacePass::new(StatsPass::new(diameter_mm), reading);
            let state = run.scan(&mut pass)?;
            WithMalformed { report: pass.into_stats(|flat| flat.into_stats(&state)), malformed }
        }
        (crate::pass::Strictness::Lenient, None) => {
            let mut pass = Counting::new(StatsPass::new(diameter_mm));
            let state = run.scan(&mut pass)?;
            WithMalformed { report: pass.pass.into_stats(&state), malformed: pass.malformed }
        }
        (crate::pass::Strictness::Lenient, Some(reading)) => {
            let mut pass = SurfacePass::new(Counting::new(StatsPass::new(diameter_mm)), reading);
            let state = run.scan(&mut pass)?;
            let malformed = pass.inner.malformed;
            WithMalformed { report: pass.into_stats(|c| c.pass.into_stats(&state)), malformed }
        }
    };
    // A file cut short is counted to its cut: said first, in `check`'s words. The ends are read
    // (again) only when its last line has no ending.
    if let Some(footer) =
        stats.report.unended.then(|| read_ends(path).ok().and_then(|e| missing_footer(&e))).flatten()
    {
        stats.report.warnings.insert(0, crate::gcode::diag::Finding::NoFooter { footer }.to_string());
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io;

    #[test]
    fn reads_prusaslicer_duration() {
        assert_eq!(duration_s(b" 5h 31m 58s"), Some(5.0 * 3600.0 + 31.0 * 60.0 + 58.0));
        assert_eq!(duration_s(b"1d 0h 0m 1s"), Some(86401.0));
        assert_eq!(list(b" 10979.45, 20959.92, 1594.45"), Some(vec![10979.45, 20959.92, 1594.45]));
    }

    /// A mach3-flavour file read as a stream (its flavour unknown until its last line) counts
    /// no filament, and says why; read with its flavour it counts the A moves.
    use crate::gcode::state::StateOptions;

    fn stats_of(text: &[u8], options: StateOptions) -> Stats {
        use crate::pass::{drive_reader, Reading};
        let mut pass = StatsPass::new(None);
        let reading = Reading { options, ..Reading::new("t.gcode".as_ref()) };
        let state = drive_reader(text, reading, &mut pass, &mut io::sink()).unwrap();
        pass.into_stats(&state)
    }

    /// The box holds where every extrusion starts, also when the one before did not end there:
    /// after a travel, and after G92 moved the logical origin under the nozzle.
    #[test]
    fn the_box_holds_every_extrusion_start() {
        let text = b"M104 S200\nG1 X0 Y0 F600\nG1 X10 E1\nG0 X-20\nG1 X-15 E2\nG92 X-50\nG1 X-45 Y1 E3\nG1 X-44 E4\n";
        let stats = stats_of(text, StateOptions::default());
        let bounds = stats.extrusion_bounds.unwrap();
        assert_eq!((bounds.min, bounds.max), ([-50.0, 0.0, 0.0], [10.0, 1.0, 0.0]));
        let text = b"M104 S200\nG1 X0 Y0 F600\nG1 X10 E1\nG0 X-20\nG1 X-15 E2\n";
        assert_eq!(stats_of(text, StateOptions::default()).extrusion_bounds.unwrap().min[0], -20.0);
    }

    #[test]
    fn a_stream_read_with_the_wrong_extrusion_word_is_a_warning() {
        let text = b"M104 P200\nG1 X10 A1 F600\nG1 X20 A2\n; gcode_flavor = mach3\n";
        let run = |options: StateOptions| stats_of(text, options);
        let blind = run(StateOptions::default());
        assert!(blind.filament.iter().all(|t| t.extruded_mm == 0.0), "{:?}", blind.filament);
        // Nothing extruded: no box, not the empty box's infinities.
        assert_eq!((blind.extrusion_bounds, blind.z_range_mm), (None, None));
        let warning = "the file's flavour (mach3) extrudes with A, but it was read with E: the flavour is named in the middle of the file, past where gweave looks for it (slicers name it at the start or the end)";
        assert!(blind.warnings.iter().any(|w| w == warning), "{:?}", blind.warnings);
        let seen = run(StateOptions::default().resolved(None, Some("mach3")));
        assert_eq!(seen.filament[0].extruded_mm, 2.0);
        let bounds = seen.extrusion_bounds.unwrap();
        assert_eq!((bounds.min, bounds.max), ([0.0; 3], [20.0, 0.0, 0.0]));
        assert!(!seen.warnings.iter().any(|w| w.contains("flavour")), "{:?}", seen.warnings);
    }

    /// Issue 21: a 25 mm stationary purge counts; a retraction and the prime that undoes it
    /// cancel (27 mm, not the 2 mm of the moving extrusions alone).
    #[test]
    fn stationary_extrusion_counts() {
        let text = b"M104 S200\nM109 S200\nG92 E0\nG1 X10 Y10 F3000\nG1 E25 F200\nG1 X20 Y10 E26\nG92 E0\nG1 E-1\nG1 E0\nG1 X30 E1\n";
        let stats = stats_of(text, StateOptions::default());
        assert_eq!(stats.filament[0].extruded_mm, 27.0);
        // Firmware retraction and its recovery cancel too; a retraction while wiping along XY
        // is undone by the stationary prime after it.
        let text = b"M104 S200\nM83\nG1 X10 Y10 F3000\nG1 X20 E2\nG10\nG11\nG1 X25 E-0.8\nG1 E0.8\nG1 E3\n";
        assert_eq!(stats_of(text, StateOptions::default()).filament[0].extruded_mm, 5.0);
    }

    /// Issue 39: on a PrusaSlicer single-extruder multi-material file with a wipe tower,
    /// `stats` counted 1.5-1.7 % less filament per tool than the slicer's figure (T0 37 491 vs
    /// 38 131 mm) without a word. PrusaSlicer counts every forward feed along X or Y, also the
    /// tower's loading moves that push an unloaded filament back down; the count is what leaves
    /// the nozzle, and the difference is said.
    #[test]
    fn a_wipe_tower_s_loading_moves_are_the_slicer_s_extra_filament() {
        // T0 prints 5, is unloaded 20 while moving and 10 standing; T1 is loaded 30 while
        // moving (its first load: it leaves the nozzle), prints 5 and is unloaded 30; T0 is
        // loaded back 30 while moving (a refill, nothing out), prints 5. PrusaSlicer's
        // figures: T0 5 + 30 + 5 = 40, T1 30 + 5 = 35.
        let text = b"; generated by PrusaSlicer 2.7.1\nM104 S200\nM83\nT0\nG1 X10 Y10 F3000\nG1 X20 E5\nG1 X40 E-20\nG1 E-10\nT1\nG1 X10 E30\nG1 X20 E5\nG1 X40 E-30\nT0\nG1 X10 E30\nG1 X20 E5\n; filament used [mm] = 40.00, 35.00\n";
        let stats = stats_of(text, StateOptions::default());
        let got: Vec<[f64; 2]> = stats.filament.iter().map(|f| [f.extruded_mm, f.fed_moving_mm]).collect();
        assert_eq!(got, [[10.0, 40.0], [35.0, 35.0]]);
        assert_eq!(stats.filament_matches_slicer, Some(false));
        let said = stats.warnings.iter().find(|w| w.starts_with("the slicer's filament figures")).unwrap();
        assert!(said.contains("(T0 30.00 mm, T1 0.00 mm)"), "{said}");
        // Figures that match the count need no word.
        let text = b"M104 S200\nM83\nG1 X10 Y10 F3000\nG1 X20 E5\n; filament used [mm] = 5.00\n";
        let stats = stats_of(text, StateOptions::default());
        assert_eq!(stats.filament_matches_slicer, Some(true));
        assert!(!stats.warnings.iter().any(|w| w.contains("slicer's filament")), "{:?}", stats.warnings);
    }

    /// The statistics of a fixture in tests/data, read as `gweave stats` reads it.
    fn stats_of_fixture(name: &str) -> Stats {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name);
        let mut progress = crate::pass::Quiet;
        stats_file(&path, None, crate::pass::Strictness::Strict, &mut progress).unwrap().report
    }

    /// Regression: `check` and `sim` said a file cut short (a last line that reads, no line
    /// ending, no slicer's last line) looks truncated; `stats` counted it to the cut and said
    /// only that no end G-code was seen. It now says so first, in `check`'s words; the whole
    /// file gets no such word.
    #[test]
    fn a_file_cut_short_is_said_truncated_by_stats() {
        let dir = tempfile::tempdir().unwrap();
        let fixture = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/prusaslicer/pr_cone_2tool.gcode");
        let text = std::fs::read(&fixture).unwrap();
        let cut = &text[..text.len() / 2];
        // Cut just after a decimal point: the last line reads (`E1.` of `E1.234`).
        let cut = &cut[..cut.iter().rposition(|&b| b == b'.').unwrap() + 1];
        let path = dir.path().join("cut.gcode");
        std::fs::write(&path, cut).unwrap();
        let mut progress = crate::pass::Quiet;
        let stats = stats_file(&path, None, crate::pass::Strictness::Strict, &mut progress).unwrap().report;
        assert_eq!(
            stats.warnings[0],
            "the file looks truncated: its last line has no line ending, and the file lacks the line \
             PrusaSlicer ends its files with ('; prusaslicer_config = end')"
        );
        let whole = stats_of_fixture("prusaslicer/pr_cone_2tool.gcode");
        assert!(!whole.warnings.iter().any(|w| w.contains("truncated")), "{:?}", whole.warnings);
    }

    /// Per tool, [extruded, as PrusaSlicer counts, primed], to 0.01 mm.
    fn figures(stats: &Stats) -> Vec<[String; 3]> {
        let mm = |v: f64| format!("{v:.2}");
        stats.filament.iter().map(|f| [mm(f.extruded_mm), mm(f.as_prusaslicer_mm), mm(f.primed_mm)]).collect()
    }

    fn strings<const N: usize, const M: usize>(rows: [[&str; M]; N]) -> Vec<[String; M]> {
        rows.iter().map(|r| r.map(String::from)).collect()
    }

    /// Issue 39 point 3 (a new user's trial): on PrusaSlicer 2.5's three-tool box with a wipe
    /// tower the count was 3.98 % (T1) and 0.75 % (T2) above the slicer's figures with no known
    /// rule. The difference is exactly what the tower's priming block pushes out, which
    /// PrusaSlicer leaves out.
    #[test]
    fn a_wipe_tower_s_priming_is_left_out_of_the_slicer_s_figures() {
        let stats = stats_of_fixture("prusaslicer/pr_box_3tool_tower.gcode");
        let want =
            [["0.00", "0.00", "0.00"], ["1540.97", "1482.02", "58.95"], ["1487.30", "1476.20", "11.10"]];
        assert_eq!(figures(&stats), strings(want));
        assert_eq!(stats.slicer_figures.filament_used_mm, Some(vec![0.0, 1482.01, 1476.19]));
        assert_eq!(stats.filament_matches_slicer, Some(false));
        let said = stats
            .warnings
            .iter()
            .find(|w| w.starts_with("the slicer's filament figures are the count above less"))
            .unwrap();
        assert!(said.contains("less T0 0.00 mm, T1 58.95 mm, T2 11.10 mm ("), "{said}");
        assert!(
            !stats.warnings.iter().any(|w| w.starts_with("the count above differs")),
            "{:?}",
            stats.warnings
        );
    }

    /// Issue 39 point 3: on PrusaSlicer 2.5's single-extruder multi-material cylinder with a
    /// wipe tower the count was 1.50 % (T0) and 0.64 % (T1) above the slicer's figures. The
    /// slicer leaves out the priming and each tool change's unloading and loading moves: as it
    /// counts, the figures are its own.
    #[test]
    fn a_single_extruder_tower_s_unloading_and_loading_are_left_out_of_the_slicer_s_figures() {
        let stats = stats_of_fixture("prusaslicer/pr_cyl_semm_tower.gcode");
        assert_eq!(
            figures(&stats),
            strings([["4524.35", "4457.40", "148.95"], ["4053.18", "4027.52", "109.66"]])
        );
        assert_eq!(stats.slicer_figures.filament_used_mm, Some(vec![4457.36, 4027.48]));
        let said = stats
            .warnings
            .iter()
            .find(|w| w.starts_with("the slicer's filament figures are the count above less"))
            .unwrap();
        assert!(said.contains("less T0 66.95 mm, T1 25.66 mm ("), "{said}");
        assert!(
            !stats.warnings.iter().any(|w| w.starts_with("the count above differs")),
            "{:?}",
            stats.warnings
        );
    }

    /// Without a tower the three figures agree with the slicer's (PrusaSlicer 2.5, two tools).
    #[test]
    fn without_a_tower_the_count_is_the_slicer_s() {
        let stats = stats_of_fixture("prusaslicer/pr_cone_2tool.gcode");
        assert_eq!(figures(&stats), strings([["506.51", "506.51", "0.00"], ["577.33", "577.33", "0.00"]]));
        assert_eq!(stats.slicer_figures.filament_used_mm, Some(vec![506.51, 577.33]));
        assert_eq!(stats.filament_matches_slicer, Some(true));
        assert!(stats.warnings.is_empty(), "{:?}", stats.warnings);
    }

    /// Issue 39 (the closing trial): on a PrusaSlicer 2.5 file sliced with a wipe tower
    /// (`--wipe-tower --use-relative-e-distances`, two or three tools) the count was 0.6 to
    /// 4 % above the slicer's figures, the summary said "differ from the count above (see the
    /// warnings)" and no warning followed. Any difference is now said, per tool.
    #[test]
    fn slicer_figures_that_differ_without_a_known_rule_are_a_warning() {
        let text = b"; generated by PrusaSlicer 2.5.0\nM104 S200\nM83\nT0\nG1 X10 Y10 F3000\nG1 X20 E5\nT1\nG1 X30 E4\n; filament used [mm] = 4.00, 4.00\n";
        let stats = stats_of(text, StateOptions::default());
        assert_eq!(stats.filament_matches_slicer, Some(false));
        let said = stats.warnings.iter().find(|w| w.starts_with("the count above differs")).unwrap();
        assert!(said.contains("by T0 +1.00 mm (+25.00 %), T1 +0.00 mm (+0.00 %)"), "{said}");
        assert!(
            !stats.warnings.iter().any(|w| w.starts_with("the slicer's filament figures")),
            "{:?}",
            stats.warnings
        );
    }

    /// The extrusion box holds the whole of an arc, not only its end points.
    #[test]
    fn extents_hold_arcs() {
        let mut pass = StatsPass::new(None);
        let text = b"G1 X5 Y5 Z0.2 F600
G2 X5 Y5 I10 J0 E5
G3 X25 Y5 I10 J0 E6
";
        let reading = crate::pass::Reading::new("t.gcode".as_ref());
        let state = crate::pass::drive_reader(&text[..], reading, &mut pass, &mut io::sink()).unwrap();
        let b = pass.into_stats(&state).extrusion_bounds.unwrap();
        // The full circle around (15, 5), then the lower half of it, counter-clockwise.
        assert_eq!((b.min, b.max), ([5.0, -5.0, 0.2], [25.0, 15.0, 0.2]));
    }
}
