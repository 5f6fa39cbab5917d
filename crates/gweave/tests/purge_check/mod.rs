//! Invariant checks for purge-shift output, independent of how the pass works: both files are
//! replayed through the machine state and compared line by line.

use std::io::Write;

use gweave::gcode::retraction::Retraction;
use gweave::gcode::state::{Move, Path as MovePath, E, X, Y};
use gweave::post::purge_shift::ChangeReport;
use gweave::test_support::read_lenient;
use gweave::{Ctx, Effect, Flow, Pass, PurgeShiftReport, StateOptions, Step};

/// What one line did, in a replay.
#[derive(Debug, Clone)]
pub struct Seen {
    pub text: Vec<u8>,
    /// Positive extrusion of extruding moves before this line, mm.
    pub printed_before_mm: f64,
    pub pos_after: [f64; 7],
    pub mv: Option<Move>,
}

#[derive(Default)]
pub struct Replay {
    pub lines: Vec<Seen>,
    pub printed_mm: f64,
    /// Net filament fed over the whole file, all tools, retractions included.
    pub net_mm: f64,
    /// The same per tool.
    pub tool_net_mm: Vec<f64>,
}

struct Recorder(Replay);

impl Pass for Recorder {
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        let mut text = ctx.line.bytes.to_vec();
        text.extend_from_slice(ctx.line.eol);
        let mv = match ctx.effect {
            Effect::Move(m) => Some(*m),
            _ => None,
        };
        self.0.lines.push(Seen { text, printed_before_mm: self.0.printed_mm, pos_after: ctx.state.pos, mv });
        if let Some(m) = mv.filter(Move::is_extruding) {
            self.0.printed_mm += m.e_mm();
        }
        Ok(Flow::Continue)
    }
}

pub fn replay(bytes: &[u8], options: &StateOptions) -> Replay {
    let mut rec = Recorder(Replay::default());
    let state = read_lenient(bytes, options.clone(), &mut rec, &mut std::io::sink()).unwrap();
    rec.0.net_mm = state.filament_mm.iter().sum();
    rec.0.tool_net_mm = state.filament_mm.clone();
    rec.0
}

/// Filament moved by E-only moves (retractions, unretractions, standing purges), both ways, mm:
/// the E motion a moved change must not add to (a retraction and an unretraction made twice
/// cost E-feed-limited time for nothing).
pub fn e_only_motion_mm(bytes: &[u8], options: &StateOptions) -> f64 {
    let r = replay(bytes, options);
    r.lines.iter().filter_map(|l| l.mv).filter(|m| m.from[..3] == m.to[..3]).map(|m| m.e_mm().abs()).sum()
}

/// Each tool's filament as the tool itself sees it: what left its nozzle and what it has
/// retracted, the retraction of a tool following that tool alone (`G10`/`G11` included).
#[derive(Debug, Default, PartialEq)]
pub struct ToolLedger {
    /// Filament that left each tool's nozzle, mm.
    pub left_mm: Vec<f64>,
    /// Each tool's retraction in force at the end, mm.
    pub retracted_mm: Vec<f64>,
    /// At each change of tool number: the tool put away with its retraction in force, and the
    /// tool taken with its own, mm.
    pub changes: Vec<(u32, f64, u32, f64)>,
}

struct Ledger {
    tool: u32,
    tools: Vec<Retraction>,
    ledger: ToolLedger,
}

impl Ledger {
    fn at(&mut self, tool: u32) -> &mut Retraction {
        let t = tool as usize;
        if self.tools.len() <= t {
            self.tools.resize(t + 1, Retraction::default());
            self.ledger.left_mm.resize(t + 1, 0.0);
        }
        &mut self.tools[t]
    }
}

impl Pass for Ledger {
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
        let tool = ctx.state.tool;
        if tool != self.tool {
            let old = self.at(self.tool).in_force_mm();
            let new = self.at(tool).in_force_mm();
            self.ledger.changes.push((self.tool, old, tool, new));
            self.tool = tool;
        }
        let left = self.at(tool).follow(ctx.effect);
        self.ledger.left_mm[tool as usize] += left;
        Ok(Flow::Continue)
    }
}

/// Replays `bytes` tool by tool.
pub fn ledger(bytes: &[u8], options: &StateOptions) -> ToolLedger {
    let mut l = Ledger { tool: 0, tools: Vec::new(), ledger: ToolLedger::default() };
    l.at(0);
    read_lenient(bytes, options.clone(), &mut l, &mut std::io::sink()).unwrap();
    l.ledger.retracted_mm = l.tools.iter().map(Retraction::in_force_mm).collect();
    l.ledger
}

/// Each tool's figure in the input (`before_mm`, per tool; at least `tools` of them) as the
/// purges change it: a moved purge goes from the old tool to the new one, a fallback's purge is
/// the new tool's.
fn with_purges(before_mm: &[f64], tools: usize, report: &PurgeShiftReport) -> Vec<f64> {
    let mut expected = before_mm.to_vec();
    expected.resize(tools.max(expected.len()), 0.0);
    for c in report.changes.kept().iter() {
        if c.from_tool != c.to_tool {
            expected[c.from_tool as usize] -= c.moved_mm;
            expected[c.to_tool as usize] += c.moved_mm;
        }
        expected[c.to_tool as usize] += c.fallback_mm;
    }
    expected
}

/// Each tool keeps its own retraction across the moved changes: at every change the tool put
/// away has the retraction it had in the input and the tool taken has its own, at the end every
/// tool has what it had, and what left each nozzle differs from the input by the purge alone
/// (moved from the old tool to the new one, plus the fallback's). A tool-change retraction left
/// to the wrong tool shows as one tool retracting what the other unretracts.
pub fn check_tools(input: &[u8], output: &[u8], report: &PurgeShiftReport, options: &StateOptions) {
    let (a, b) = (ledger(input, options), ledger(output, options));
    assert_eq!(a.changes.len(), b.changes.len(), "changes of tool");
    for (i, (x, y)) in a.changes.iter().zip(&b.changes).enumerate() {
        let same = x.0 == y.0 && x.2 == y.2 && (x.1 - y.1).abs() < 1e-5 && (x.3 - y.3).abs() < 1e-5;
        assert!(
            same,
            "change {i}: (tool, retracted, tool, retracted) {x:?} in the input, {y:?} in the output"
        );
    }
    for (t, (x, y)) in a.retracted_mm.iter().zip(&b.retracted_mm).enumerate() {
        assert!((x - y).abs() < 1e-5, "T{t} ends with {y} mm retracted, {x} in the input");
    }
    let expected = with_purges(&a.left_mm, b.left_mm.len(), report);
    for (t, want) in expected.iter().enumerate() {
        let got = b.left_mm.get(t).copied().unwrap_or(0.0);
        assert!((got - want).abs() < 1e-4, "T{t}: {got} mm left the nozzle, expected {want}");
    }
}

fn is_change_text(t: &[u8]) -> bool {
    let t = t.trim_ascii_start();
    (t.first() == Some(&b'T') && t.get(1).is_some_and(u8::is_ascii_digit))
        || [&b"M163"[..], b"M164", b"M165", b"M567"].iter().any(|m| t.starts_with(m))
}

/// An E-only move, a feed-rate-only `G0`/`G1` or a `G92` of E alone: the lines a moved
/// retraction adds or takes out.
fn feeds_filament_only(l: &Seen) -> bool {
    let text = String::from_utf8_lossy(&l.text);
    let words: Vec<&str> = text.split(';').next().unwrap_or("").split_whitespace().collect();
    let only = |allowed: &[char]| words[1..].iter().all(|w| w.starts_with(allowed));
    match words.first() {
        Some(&"G92") => only(&['E']),
        Some(&"G0") | Some(&"G1") => only(&['E', 'F']),
        _ => false,
    }
}

/// Distance of `p` from the path of `mv` in XY, and whether it lies within the move.
fn off_path_mm(mv: &Move, p: [f64; 2]) -> (f64, bool) {
    match &mv.path {
        MovePath::Line => {
            let (a, b) = ([mv.from[X], mv.from[Y]], [mv.to[X], mv.to[Y]]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let t = ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2;
            let q = [a[0] + t * d[0], a[1] + t * d[1]];
            ((p[0] - q[0]).hypot(p[1] - q[1]), (-1e-9..=1.0 + 1e-9).contains(&t))
        }
        MovePath::Arc(arc) => {
            let r = (p[0] - arc.center[0]).hypot(p[1] - arc.center[1]);
            let ang = (p[1] - arc.center[1]).atan2(p[0] - arc.center[0]);
            let mut swept = (ang - arc.start_rad) * arc.sweep_rad.signum();
            swept = swept.rem_euclid(std::f64::consts::TAU);
            ((r - arc.radius_mm).abs(), swept <= arc.sweep_rad.abs() + 1e-9)
        }
    }
}

/// Lines a moved retraction put right before the change lines, right after them (the new
/// tool's unretraction, before a fallback's lines), and where the change was.
fn before_lines(c: &ChangeReport) -> u64 {
    c.retraction.as_ref().map_or(0, |r| r.lines_before)
}
fn after_lines(c: &ChangeReport) -> u64 {
    c.retraction.as_ref().map_or(0, |r| r.lines_after)
}

/// The printed extrusion before each output line, and in all, without the fallbacks' lines.
fn printed_without_fallbacks(b: &Replay, report: &PurgeShiftReport) -> (Vec<f64>, f64) {
    let mut inserted = std::collections::BTreeSet::new();
    for c in report.changes.kept().iter() {
        let first = (c.output_line - 1 + after_lines(c)) as usize + c.change_lines.len();
        inserted.extend(first..first + c.fallback_lines as usize);
    }
    let mut printed_before = Vec::with_capacity(b.lines.len());
    let mut printed = 0.0;
    for (i, l) in b.lines.iter().enumerate() {
        printed_before.push(printed);
        if let Some(m) = l.mv.filter(|m| m.is_extruding() && !inserted.contains(&i)) {
            printed += m.e_mm();
        }
    }
    (printed_before, printed)
}

/// Checks every invariant; panics with a description on the first failure. Returns the
/// per-change purge measured from the files themselves (the moved part).
///
/// A fallback's lines must come right after the change lines, start and end at the same
/// position (XYZ exactly, E to the 1e-6 mm the lines are written with), and feed exactly the
/// reported `fallback_mm`: the file's net extrusion grows by their sum, nothing else changes.
pub fn check(input: &[u8], output: &[u8], report: &PurgeShiftReport, options: &StateOptions) -> Vec<f64> {
    // Every change is checked, so every change must be in memory (test files are small).
    assert_eq!(report.changes.spilled(), 0, "the checker sees only the changes kept in memory");
    let a = replay(input, options);
    let b = replay(output, options);
    let (b_printed_before, b_printed) = printed_without_fallbacks(&b, report);
    let fallback_mm: f64 = report.changes.kept().iter().map(|c| c.fallback_mm).sum();
    assert!((fallback_mm - report.fallback_mm).abs() < 1e-9, "fallback total {}", report.fallback_mm);
    // Extrusion over the whole file is unchanged, printed and net, but for the fallback purges.
    assert!((a.printed_mm - b_printed).abs() < 1e-6, "printed {} -> {}", a.printed_mm, b_printed);
    assert!(
        (a.net_mm + fallback_mm - b.net_mm).abs() < 1e-5,
        "net {} + fallback {fallback_mm} -> {}",
        a.net_mm,
        b.net_mm
    );
    // Each tool's net feed (retractions included) changes by the purge alone: the moved purge
    // goes from the old tool to the new one, a fallback's purge is the new tool's. A tool-change
    // retraction left to the wrong tool shows here as its length lost by one tool and gained by
    // the other.
    let expected = with_purges(&a.tool_net_mm, b.tool_net_mm.len(), report);
    for (t, want) in expected.iter().enumerate() {
        let got = b.tool_net_mm.get(t).copied().unwrap_or(0.0);
        assert!(
            (got - want).abs() < 1e-4,
            "T{t} fed {got} mm net, expected {want} (input {:?})",
            a.tool_net_mm
        );
    }
    check_tools(input, output, report, options);
    // The number of change lines is unchanged.
    let count = |r: &Replay| r.lines.iter().filter(|l| is_change_text(&l.text)).count();
    assert_eq!(count(&a), count(&b), "change lines");
    // Lines that were not touched are byte-identical, in order.
    let mut removed_in = std::collections::BTreeSet::new();
    let mut removed_out = std::collections::BTreeSet::new();
    let mut measured = Vec::new();
    for c in report.changes.kept().iter() {
        let n = c.change_lines.len() as u64;
        let k = c.fallback_lines;
        let (lb, la) = (before_lines(c), after_lines(c));
        removed_in.extend(c.change_lines.iter().copied());
        removed_out.extend(c.output_line - lb..c.output_line + n + la + k);
        if let Some(r) = &c.retraction {
            let settle = c.output_line + r.settle_offset;
            removed_out.extend(settle..settle + r.settle_lines);
            // Net, the moved retractions feed nothing: each tool's is moved, not changed (what is
            // inserted is what is taken out of the file's own retraction and unretraction).
            let net_mm = r.old_mm + r.new_mm + r.settle_mm + r.dropped_mm - r.absorbed_mm;
            assert!(net_mm.abs() < 1e-9, "{r:?}");
            // They only feed filament: the nozzle stays where it is.
            let bracket = (c.output_line - lb..c.output_line)
                .chain(c.output_line + n..c.output_line + n + la)
                .chain(settle..settle + r.settle_lines);
            for i in bracket {
                let mv = b.lines[(i - 1) as usize].mv;
                assert!(mv.is_none_or(|m| m.from[..3] == m.to[..3]), "inserted line {i} moves: {mv:?}");
            }
        }
        if k > 0 {
            // The fallback returns to where it started.
            let (start, end) = (
                b.lines[(c.output_line + n + la - 2) as usize].pos_after,
                b.lines[(c.output_line + n + la + k - 2) as usize].pos_after,
            );
            assert_eq!(start[..3], end[..3], "fallback of {c:?} does not return");
            assert!(
                (start[E] - end[E]).abs() < 2e-6,
                "E {} after the fallback vs {} before",
                end[E],
                start[E]
            );
            let fed: f64 = (0..k)
                .map(|j| b.lines[(c.output_line + n + la - 1 + j) as usize].mv.map_or(0.0, |m| m.e_mm()))
                .sum();
            assert!((fed - c.fallback_mm).abs() < 1e-5, "fallback fed {fed} vs {}", c.fallback_mm);
        }
        for (k, &l) in c.change_lines.iter().enumerate() {
            assert_eq!(
                b.lines[(c.output_line - 1) as usize + k].text,
                a.lines[(l - 1) as usize].text,
                "moved line"
            );
        }
        assert!(
            c.shortfall_mm >= 0.0
                && (c.achieved_mm + c.shortfall_mm - c.requested_mm).abs() < 1e-9
                && (c.moved_mm + c.fallback_mm - c.achieved_mm).abs() < 1e-9,
            "{c:?}"
        );
        // The old colour's extrusion between the new and the old position of the change.
        let got = a.lines[(c.change_lines[0] - 1) as usize].printed_before_mm
            - b_printed_before[(c.output_line - 1) as usize];
        assert!((got - c.moved_mm).abs() < 1e-5, "measured {got} vs reported {} for {c:?}", c.moved_mm);
        if c.fallback_mm == 0.0 && c.shortfall_mm == 0.0 {
            assert!((got - c.requested_mm).abs() < 1e-5, "measured {got} vs requested for {c:?}");
        }
        measured.push(got);
        if let Some(s) = &c.split {
            removed_in.insert(s.line);
            removed_out.insert(c.output_line - lb - 1);
            removed_out.insert(c.output_line + n + la + k);
            // The split point (where the output is when the change runs) lies on the original move.
            let mv = a.lines[(s.line - 1) as usize].mv.expect("split line is a move");
            let first = &b.lines[(c.output_line - lb - 2) as usize];
            let p = first.pos_after;
            let (off, within) = off_path_mm(&mv, [p[X], p[Y]]);
            assert!(off < 2e-5 && within, "split point {p:?} off the move {mv:?} by {off}");
            // The first half feeds the move's E up to the split. Its E feed, not its E
            // coordinate: a tool's retraction carried with a change across a `G92 E0` (relative
            // E) shifts the counter after the reset, not the filament (what each tool feeds is
            // held to the input by `check_tools` and the per-tool sums above).
            let t = s.fraction;
            let half = first.mv.expect("the first half of the split is a move");
            let (fed, e_at) = (half.to[E] - half.from[E], t * (mv.to[E] - mv.from[E]));
            assert!((fed - e_at).abs() < 2e-6, "E to the split {fed} vs {e_at}");
            // The second half ends where the original move ended.
            let end = b.lines[(c.output_line + n + la + k - 1) as usize].pos_after;
            for axis in 0..3 {
                assert!((end[axis] - mv.to[axis]).abs() < 1e-9, "end {end:?} vs {:?}", mv.to);
            }
        }
    }
    // A moved change takes the file's E-only tool-change retraction and unretraction out where
    // it was (replaced by a `G92 E` in absolute E, or by the feed rate alone in relative E):
    // those lines are the tools' filament, held to the input by `check_tools` above, and left
    // out here on both sides; every other line must be the input's.
    let kept = |r: &Replay, removed: &std::collections::BTreeSet<u64>| -> Vec<Vec<u8>> {
        r.lines
            .iter()
            .enumerate()
            .filter(|(i, _)| !removed.contains(&(*i as u64 + 1)))
            .filter(|(_, l)| !feeds_filament_only(l))
            .map(|(_, l)| l.text.clone())
            .collect()
    };
    let (ka, kb) = (kept(&a, &removed_in), kept(&b, &removed_out));
    assert_eq!(ka.len(), kb.len(), "untouched line count");
    if let Some(i) = (0..ka.len()).find(|&i| ka[i] != kb[i]) {
        panic!(
            "untouched line {i} differs: {:?} vs {:?}",
            String::from_utf8_lossy(&ka[i]),
            String::from_utf8_lossy(&kb[i])
        );
    }
    measured
}
