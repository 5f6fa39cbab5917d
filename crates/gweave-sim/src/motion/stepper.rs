//! Stepper motors: exact integer step counts per planned block, the Bresenham order in which a
//! block's steps are issued, and E split across the inputs of a mixing hotend.
//!
//! Step counts come from absolute positions: a motor at `n` steps moving to `p` mm goes to
//! `round(p * steps_per_mm)`, so rounding never accumulates over millions of moves (a move of
//! 0.0125 mm at 80 steps/mm is one step; a thousand of them are exactly a thousand). A jump of
//! the logical position between blocks (G92) re-anchors the axis without moving it: the motor
//! keeps its step count and later targets are rounded relative to the new anchor.
//!
//! Within a block all motors step together along a Bresenham line (`gnea/grbl:grbl/stepper.c`;
//! the seed controller `002_*` does the same over X Y Z E): the motor with the most steps
//! ("dominant") steps on every tick; every other motor adds its step count to an error term that
//! starts at half the dominant count and steps whenever the term reaches the dominant count.
//! (The seed compares with "greater than", which loses the only step of a one-step block; with
//! "at least" every motor makes exactly its count.)
//!
//! Mixing: the E steps of a block are shared among the inputs by their mix weights. Each input
//! keeps its cumulative ideal share, and the prefix sums of those shares are rounded, so the
//! inputs' totals always add up to exactly the E motor's total and each is within one step of
//! its ideal. An input with its own steps/mm converts its share of E steps to its own steps from
//! its cumulative total, again without drift.
//!
//! Tools: the E motor's steps are also counted per tool (`T<n>`, a virtual tool on a mixing
//! hotend), for the tool the block was planned under ([`Steppers::select_tool`]), so the
//! per-tool counts add up to the E motor's total.

use crate::motion::kinematics::Pos;
use crate::motion::limits::StepsPerUnit;
use crate::motion::planner::PlannedBlock;
use crate::motion::rounding::round_i64;

/// Accumulated steps taken per motor (absolute: both directions count).
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct StepTotals {
    /// X Y Z E A motor steps, in that order.
    pub axes: [u64; 5],
    /// Steps per mixing input (empty without a mixing hotend).
    pub mixing: Vec<u64>,
    /// E motor steps per tool T0..Tn (both directions count); they add up to `axes[3]`.
    pub tools: Vec<u64>,
}

/// One axis' integer position and its anchor in the logical coordinates.
#[derive(Debug, Clone, Copy, Default)]
struct AxisCounter {
    steps_per_unit: f64,
    /// Motor position, steps.
    steps: i64,
    /// The logical position (mm or deg) and motor steps at the last re-anchor.
    anchor_pos: f64,
    anchor_steps: i64,
    /// The logical position at the end of the last block.
    last_pos: f64,
}

impl AxisCounter {
    /// Steps to reach `end`, starting the block at logical `start`.
    fn advance(&mut self, start: f64, end: f64) -> i64 {
        // An axis the move leaves alone (Z and A on most moves) stays where it is.
        if start == self.last_pos && end == start {
            return 0;
        }
        if start != self.last_pos {
            self.anchor_pos = start;
            self.anchor_steps = self.steps;
        }
        let target = self.anchor_steps + round_i64((end - self.anchor_pos) * self.steps_per_unit);
        let delta = target - self.steps;
        self.steps = target;
        self.last_pos = end;
        delta
    }
}

/// One mixing input: its cumulative ideal share of E steps and what it has been given.
#[derive(Debug, Clone, Copy, Default)]
struct MixInput {
    /// Own steps/mm divided by the E axis' steps/mm.
    scale: f64,
    /// Ideal cumulative share, in E steps.
    ideal_e_steps: f64,
    /// Integer cumulative share, in E steps.
    e_steps: i64,
    /// Own motor position, steps.
    steps: i64,
}

/// All motors of the machine, fed one planned block at a time.
#[derive(Debug, Clone)]
pub struct Steppers {
    axes: [AxisCounter; 5],
    mix: Vec<MixInput>,
    mix_delta: Vec<i64>,
    /// The tool E steps are counted for.
    tool: usize,
    totals: StepTotals,
}

impl Steppers {
    /// Motors for these step rates, all at position 0 (a machine without an A axis gets an A
    /// counter with 1 step/degree that should never move).
    pub fn new(steps: &StepsPerUnit) -> Self {
        let spu = [steps.x, steps.y, steps.z, steps.e, steps.a()];
        let mix: Vec<MixInput> =
            steps.mixing_e.iter().map(|&s| MixInput { scale: s / steps.e, ..MixInput::default() }).collect();
        Self {
            axes: spu.map(|steps_per_unit| AxisCounter { steps_per_unit, ..AxisCounter::default() }),
            mix_delta: vec![0; mix.len()],
            tool: 0,
            totals: StepTotals { axes: [0; 5], mixing: vec![0; mix.len()], tools: vec![0] },
            mix,
        }
    }

    /// `M92`: axis `axis` (0..5, X Y Z E A) counts `steps_per_unit` from here on; the motor stays
    /// where it is and the steps taken so far are kept (Marlin recomputes its position from the
    /// step counts the same way).
    pub fn set_steps_per_unit(&mut self, axis: usize, steps_per_unit: f64) {
        if let Some(a) = self.axes.get_mut(axis) {
            a.anchor_pos = a.last_pos;
            a.anchor_steps = a.steps;
            a.steps_per_unit = steps_per_unit;
        }
    }

    /// Set every motor's logical position without stepping (homing, `SET_KINEMATIC_POSITION`).
    pub fn set_position(&mut self, pos: Pos) {
        for (a, p) in self.axes.iter_mut().zip(pos.to_array()) {
            a.last_pos = p;
            a.anchor_pos = p;
            a.anchor_steps = a.steps;
        }
    }

    /// The step counts (signed, X Y Z E A) for a move from `start` to `end`, and the E steps
    /// split across the mixing inputs by `mix_weights` (ignored without a mixing hotend; any
    /// non-negative weights, normalised here; all zero means equal shares). The split is
    /// available from [`Steppers::mix_steps`] until the next call.
    pub fn step_move(&mut self, start: Pos, end: Pos, mix_weights: &[f64]) -> [i64; 5] {
        let (s, e) = (start.to_array(), end.to_array());
        let delta: [i64; 5] = std::array::from_fn(|i| self.axes[i].advance(s[i], e[i]));
        for (t, d) in self.totals.axes.iter_mut().zip(delta) {
            *t += d.unsigned_abs();
        }
        self.totals.tools[self.tool] += delta[3].unsigned_abs();
        self.split_e(delta[3], mix_weights);
        delta
    }

    /// Count the E steps of the following moves for tool `tool` (T0 until called).
    pub fn select_tool(&mut self, tool: usize) {
        if self.totals.tools.len() <= tool {
            self.totals.tools.resize(tool + 1, 0);
        }
        self.tool = tool;
    }

    /// [`Steppers::step_move`] for a planned block.
    pub fn step_block(&mut self, block: &PlannedBlock, mix_weights: &[f64]) -> [i64; 5] {
        self.step_move(block.start, block.end, mix_weights)
    }

    /// The signed steps of each mixing input in the last block.
    pub fn mix_steps(&self) -> &[i64] {
        &self.mix_delta
    }

    /// Steps taken so far per motor.
    pub fn totals(&self) -> &StepTotals {
        &self.totals
    }

    /// Positions of the mixing inputs' motors, steps (empty without a mixing hotend).
    pub fn mix_position_steps(&self) -> impl Iterator<Item = i64> + '_ {
        self.mix.iter().map(|m| m.steps)
    }

    /// Motor positions in steps, X Y Z E A.
    pub fn position_steps(&self) -> [i64; 5] {
        self.axes.map(|a| a.steps)
    }

    fn split_e(&mut self, e_steps: i64, weights: &[f64]) {
        if self.mix.is_empty() {
            return;
        }
        let n = self.mix.len();
        let weight = |k: usize| weights.get(k).copied().filter(|w| w.is_finite() && *w > 0.0).unwrap_or(0.0);
        let sum: f64 = (0..n).map(weight).sum();
        let share = |k: usize| {
            if sum > 0.0 {
                weight(k) / sum
            } else {
                1.0 / n as f64
            }
        };
        // Prefix sums of the ideal cumulative shares, rounded; the last prefix is the E total.
        let total: i64 = self.mix.iter().map(|m| m.e_steps).sum::<i64>() + e_steps;
        let mut prefix_ideal = 0.0;
        let mut prefix_given = 0i64;
        for k in 0..n {
            let m = &mut self.mix[k];
            m.ideal_e_steps += share(k) * e_steps as f64;
            prefix_ideal += m.ideal_e_steps;
            let prefix = if k + 1 == n { total } else { prefix_ideal.round() as i64 };
            let new_e_steps = prefix - prefix_given;
            prefix_given = prefix;
            m.e_steps = new_e_steps;
            let own = (new_e_steps as f64 * m.scale).round() as i64;
            self.mix_delta[k] = own - m.steps;
            self.totals.mixing[k] += self.mix_delta[k].unsigned_abs();
            m.steps = own;
        }
    }
}

/// The Bresenham walk of one block: for each tick of the dominant motor, the bit mask of the
/// motors (indices into the step counts given) that step on that tick. Directions are the signs
/// of the counts. At most 32 motors.
#[derive(Debug, Clone)]
pub struct BresenhamWalk {
    counts: Vec<u64>,
    errors: Vec<u64>,
    dominant: u64,
    tick: u64,
}

impl BresenhamWalk {
    /// A walk over the signed step counts of one block (only the first 32 motors take part).
    pub fn new(steps: &[i64]) -> Self {
        let counts: Vec<u64> = steps.iter().take(32).map(|s| s.unsigned_abs()).collect();
        let dominant = counts.iter().copied().max().unwrap_or(0);
        Self { errors: vec![dominant / 2; counts.len()], counts, dominant, tick: 0 }
    }

    /// Ticks in the walk: the dominant motor's step count.
    pub fn ticks(&self) -> u64 {
        self.dominant
    }
}

impl Iterator for BresenhamWalk {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        if self.tick == self.dominant {
            return None;
        }
        self.tick += 1;
        let mut mask = 0u32;
        for (i, (err, &count)) in self.errors.iter_mut().zip(&self.counts).enumerate() {
            *err += count;
            if *err >= self.dominant {
                *err -= self.dominant;
                mask |= 1 << i;
            }
        }
        Some(mask)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn steps() -> StepsPerUnit {
        StepsPerUnit::default()
    }

    #[test]
    fn hand_computed_walk() {
        // 5 and 2 steps: errors start at 2; Y reaches 5 on ticks 2 and 4.
        let masks: Vec<u32> = BresenhamWalk::new(&[5, -2]).collect();
        assert_eq!(masks, vec![0b01, 0b11, 0b01, 0b11, 0b01]);
        // A one-step block still steps (the seed's ">" would not).
        assert_eq!(BresenhamWalk::new(&[1, 0]).collect::<Vec<_>>(), vec![1]);
        assert_eq!(BresenhamWalk::new(&[0, 0]).count(), 0);
    }

    #[test]
    fn no_drift_over_a_million_tiny_moves() {
        // 0.0125 mm at 80 steps/mm is exactly one step, but 0.0125 is not exact in binary;
        // 0.01 mm is 0.8 steps. A million of each must end on round(total).
        let mut s = Steppers::new(&steps());
        let mut x = 0.0;
        for i in 0..1_000_000 {
            let nx = (i + 1) as f64 * 0.01;
            s.step_move(Pos::xyze(x, 0.0, 0.0, 0.0), Pos::xyze(nx, 0.0, 0.0, 0.0), &[]);
            x = nx;
        }
        assert_eq!(s.position_steps()[0], 800_000);
        assert_eq!(s.totals().axes[0], 800_000);
    }

    #[test]
    fn g92_reanchors_without_moving() {
        let mut s = Steppers::new(&steps());
        s.step_move(Pos::xyze(0.0, 0.0, 0.0, 0.0), Pos::xyze(0.0, 0.0, 0.0, 10.0), &[]);
        // G92 E0, then extrude 1 mm: E motor 5000 -> 5500.
        let d = s.step_move(Pos::xyze(0.0, 0.0, 0.0, 0.0), Pos::xyze(0.0, 0.0, 0.0, 1.0), &[]);
        assert_eq!(d[3], 500);
        assert_eq!(s.position_steps()[3], 5500);
        assert_eq!(s.totals().axes[3], 5500);
    }

    #[test]
    fn mixing_split_is_exact() {
        let mut spu = steps();
        spu.mixing_e = vec![500.0; 3];
        let mut s = Steppers::new(&spu);
        let mut e = 0.0;
        let mut given = [0i64; 3];
        for i in 0..1000 {
            let ne = e + 0.0137 * (1 + i % 7) as f64;
            s.step_move(Pos::xyze(0.0, 0.0, 0.0, e), Pos::xyze(0.0, 0.0, 0.0, ne), &[0.5, 0.3, 0.2]);
            given.iter_mut().zip(s.mix_steps()).for_each(|(g, d)| *g += d);
            assert_eq!(given.iter().sum::<i64>(), s.position_steps()[3], "inputs add up to E at every block");
            e = ne;
        }
        let total = s.position_steps()[3] as f64;
        for (g, w) in given.iter().zip([0.5, 0.3, 0.2]) {
            assert!((*g as f64 - w * total).abs() <= 1.0, "{given:?} of {total}");
        }
    }

    #[test]
    fn mixing_input_with_own_steps_per_mm() {
        let mut spu = steps();
        spu.mixing_e = vec![500.0, 1000.0];
        let mut s = Steppers::new(&spu);
        s.step_move(Pos::default(), Pos::xyze(0.0, 0.0, 0.0, 2.0), &[1.0, 1.0]);
        // 1000 E steps, 500 each; input 1 has twice the resolution.
        assert_eq!(s.mix_steps(), &[500, 1000]);
    }

    proptest! {
        #[test]
        fn walk_makes_exact_counts(counts in proptest::collection::vec(-300i64..300, 1..6)) {
            let walk = BresenhamWalk::new(&counts);
            let ticks = walk.ticks();
            let masks: Vec<u32> = walk.collect();
            prop_assert_eq!(masks.len() as u64, ticks);
            for (i, c) in counts.iter().enumerate() {
                let n = masks.iter().filter(|m| *m & (1 << i) != 0).count() as u64;
                prop_assert_eq!(n, c.unsigned_abs());
            }
        }

        #[test]
        fn steps_follow_absolute_rounding(xs in proptest::collection::vec(-200.0f64..200.0, 1..50)) {
            let mut s = Steppers::new(&steps());
            let mut from = Pos::default();
            for x in xs {
                let to = Pos::xyze(x, 0.0, 0.0, 0.0);
                s.step_move(from, to, &[]);
                prop_assert_eq!(s.position_steps()[0], (x * 80.0).round() as i64);
                from = to;
            }
        }
    }
}
