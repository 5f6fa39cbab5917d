//! From a wanted colour to the ratios that print it.
//!
//! Minimise `CIEDE2000(target, model(w))` over the simplex `w_i >= 0, sum w_i = 1`.
//! The error surface is smooth but not convex (hue wraps, the clamp of the
//! model), so the search is global-then-local, and fully deterministic:
//!
//! 1. **Grid**: every `w` whose entries are multiples of `1/n_div`, with `n_div`
//!    as fine as a budget of about 1000 points allows (16 for 4 inputs).
//! 2. **Refine** the best few grid points by pattern search on the simplex:
//!    try moving a share `step` from input i to input j for every ordered pair,
//!    take the best improving move, and halve `step` when none improves, down
//!    to `1e-6`. Moves never leave the simplex, so the result is always a
//!    valid, normalised mix.
//!
//! The target is *out of gamut* when even the best mix is more than
//! `OUT_OF_GAMUT_DE` away: those filaments cannot print it.

use palette::Mix as _;

use super::mix::{Mix, MixError};
use super::mixing::MixingModel;
use super::srgb::Srgb8;
use super::{Ciede2000, Lab};

/// Above this CIEDE2000 the best mix is flagged `out_of_gamut` (a difference
/// of 5 is obvious side by side; 1 is just noticeable).
pub(crate) const OUT_OF_GAMUT_DE: f64 = 5.0;

/// Grid points evaluated before refinement, at most.
const GRID_BUDGET: usize = 1000;
/// Finest division of the grid (reached with 2 inputs).
const MAX_DIVISIONS: usize = 100;
/// Grid points refined.
const STARTS: usize = 3;
/// Refinement stops when the moved share is below this.
const MIN_STEP: f64 = 1e-6;

/// The best mix found for a target colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The mix closest to the target.
    pub mix: Mix,
    /// The model's colour for `mix`, rounded to 8 bits.
    pub predicted: Srgb8,
    /// The model's colour for `mix`, unrounded.
    pub predicted_lab: Lab,
    /// CIEDE2000 between the target and `predicted_lab`.
    pub delta_e: f64,
    /// `delta_e > OUT_OF_GAMUT_DE`.
    pub out_of_gamut: bool,
}

/// Ratios for `target` with the model's filaments.
pub fn solve(model: &MixingModel, target: Srgb8) -> Solution {
    solve_lab(model, Lab::from(target))
}

/// Ratios for a CIELAB target.
pub(crate) fn solve_lab(model: &MixingModel, target: Lab) -> Solution {
    Search::new(model, target).run().0
}

/// The mix a fraction `t` of the way from `a` to `b` in *perceived* colour:
/// interpolate the two predicted colours in Lab, then solve for that colour.
/// Unlike `Mix::lerp`, equal steps of `t` look like equal steps of colour.
pub(crate) fn lerp_perceived(model: &MixingModel, a: &Mix, b: &Mix, t: f64) -> Result<Solution, MixError> {
    if !(0.0..=1.0).contains(&t) {
        return Err(MixError::OutOfUnitRange { what: "interpolation parameter", value: t });
    }
    let lab_a = model.predict_lab(a)?;
    let lab_b = model.predict_lab(b)?;
    Ok(solve_lab(model, lab_a.mix(lab_b, t)))
}

/// One search: the model, the target and a count of model evaluations.
struct Search<'a> {
    model: &'a MixingModel,
    target: Lab,
    evaluations: usize,
}

impl<'a> Search<'a> {
    fn new(model: &'a MixingModel, target: Lab) -> Self {
        Self { model, target, evaluations: 0 }
    }

    fn error(&mut self, w: &[f64]) -> f64 {
        self.evaluations += 1;
        self.target.difference(self.model.lab_for_weights(w))
    }

    /// Returns the solution and the number of model evaluations it took.
    fn run(mut self) -> (Solution, usize) {
        let inputs = self.model.inputs().len();
        let divisions = grid_divisions(inputs);
        let mut best: Vec<(f64, Vec<f64>)> = Vec::with_capacity(STARTS + 1);
        let mut units = vec![0usize; inputs];
        for_each_composition(&mut units, 0, divisions, &mut |units| {
            let w: Vec<f64> = units.iter().map(|&u| u as f64 / divisions as f64).collect();
            let e = self.error(&w);
            // Keep the STARTS best, ties to the earlier point (determinism).
            let at = best.partition_point(|(b, _)| *b <= e);
            if at < STARTS {
                best.insert(at, (e, w));
                best.truncate(STARTS);
            }
        });
        let step = 1.0 / divisions as f64;
        let (error, weights) = best
            .into_iter()
            .map(|(e, w)| self.refine(w, e, step))
            .fold(None, |acc: Option<(f64, Vec<f64>)>, cand| match acc {
                Some(a) if a.0 <= cand.0 => Some(a),
                _ => Some(cand),
            })
            .expect("the grid has at least one point");
        let mix = Mix::new(&weights).expect("solver weights stay on the simplex");
        let predicted_lab = self.model.lab_for_weights(mix.ratios());
        let solution = Solution {
            mix,
            predicted: Srgb8::from(predicted_lab),
            predicted_lab,
            delta_e: error,
            out_of_gamut: error > OUT_OF_GAMUT_DE,
        };
        (solution, self.evaluations)
    }

    /// Pattern search on the simplex from `w` (error `e`), see the module docs.
    fn refine(&mut self, mut w: Vec<f64>, mut e: f64, mut step: f64) -> (f64, Vec<f64>) {
        let n = w.len();
        let mut trial = w.clone();
        while step >= MIN_STEP && e > 0.0 {
            let mut best_move: Option<(f64, usize, usize, f64)> = None;
            for from in 0..n {
                let moved = step.min(w[from]);
                if moved <= 0.0 {
                    continue;
                }
                for to in (0..n).filter(|&to| to != from) {
                    trial.copy_from_slice(&w);
                    trial[from] -= moved;
                    trial[to] += moved;
                    let et = self.error(&trial);
                    if et < best_move.map_or(e, |m| m.0) {
                        best_move = Some((et, from, to, moved));
                    }
                }
            }
            match best_move {
                Some((et, from, to, moved)) => {
                    w[from] -= moved;
                    w[to] += moved;
                    e = et;
                }
                None => step /= 2.0,
            }
        }
        (e, w)
    }
}

/// Number of compositions of `divisions` into `parts` non-negative parts,
/// `C(divisions + parts - 1, parts - 1)`, saturating.
fn grid_points(parts: usize, divisions: usize) -> usize {
    (1..parts).fold(1usize, |acc, k| acc.saturating_mul(divisions + k) / k)
}

/// The finest grid within `GRID_BUDGET` points (at least 1 division).
fn grid_divisions(inputs: usize) -> usize {
    (1..=MAX_DIVISIONS).take_while(|&d| d == 1 || grid_points(inputs, d) <= GRID_BUDGET).last().unwrap_or(1)
}

/// Calls `f` with every way of writing `left` as the sum of `units[at..]`.
fn for_each_composition(units: &mut [usize], at: usize, left: usize, f: &mut impl FnMut(&[usize])) {
    if at + 1 == units.len() {
        units[at] = left;
        f(units);
        return;
    }
    for u in 0..=left {
        units[at] = u;
        for_each_composition(units, at + 1, left - u, f);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const CYAN: Srgb8 = Srgb8::new(0, 160, 224);
    const MAGENTA: Srgb8 = Srgb8::new(224, 0, 122);
    const YELLOW: Srgb8 = Srgb8::new(255, 224, 0);
    const WHITE: Srgb8 = Srgb8::new(245, 245, 240);

    fn cmyw() -> MixingModel {
        MixingModel::new(&[CYAN, MAGENTA, YELLOW, WHITE]).unwrap()
    }

    #[test]
    fn grid_sizes() {
        assert_eq!(grid_points(4, 16), 969);
        assert_eq!(grid_divisions(4), 16);
        assert_eq!(grid_divisions(2), 100);
        assert_eq!(grid_divisions(1), 100);
        assert_eq!(grid_divisions(12), 3);
        let mut count = 0;
        let mut sums_ok = true;
        for_each_composition(&mut [0; 4], 0, 16, &mut |u| {
            count += 1;
            sums_ok &= u.iter().sum::<usize>() == 16;
        });
        assert_eq!((count, sums_ok), (969, true));
    }

    #[test]
    fn finds_an_input_colour_exactly() {
        let s = solve(&cmyw(), WHITE);
        assert_eq!(s.mix.ratios(), &[0.0, 0.0, 0.0, 1.0]);
        assert_eq!(s.predicted, WHITE);
        assert!(s.delta_e < 1e-9 && !s.out_of_gamut);
    }

    #[test]
    fn recovers_known_ratios() {
        let model = cmyw();
        let known = Mix::new(&[0.2, 0.1, 0.3, 0.4]).unwrap();
        let colour = model.predict(&known).unwrap();
        let (s, evaluations) = Search::new(&model, Lab::from(colour)).run();
        assert!(s.delta_e < 0.05, "dE {}", s.delta_e);
        assert!(!s.out_of_gamut);
        for (got, want) in s.mix.ratios().iter().zip(known.ratios()) {
            assert!((got - want).abs() < 0.01, "{:?}", s.mix.ratios());
        }
        assert!(evaluations < 5000, "{evaluations} evaluations");
    }

    #[test]
    fn flags_colours_the_filaments_cannot_make() {
        // Pure sRGB blue is far more saturated than cyan + magenta filament.
        let s = solve(&cmyw(), Srgb8::new(0, 0, 255));
        assert!(s.out_of_gamut && s.delta_e > OUT_OF_GAMUT_DE, "{s:?}");
        // It still returns the nearest mix: cyan and magenta, no yellow.
        let w = s.mix.ratios();
        assert!(w[0] > 0.05 && w[1] > 0.05 && w[2] == 0.0, "{s:?}");
    }

    #[test]
    fn solves_fast_enough() {
        let model = cmyw();
        let start = std::time::Instant::now();
        for hex in ["#ff88aa", "#336699", "#a0522d", "#7fff00"] {
            solve(&model, Srgb8::parse_hex(hex).unwrap());
        }
        let per_solve = start.elapsed() / 4;
        // 20 ms in a release build; unoptimised test builds are ~10x slower.
        let limit_ms = if cfg!(debug_assertions) { 200 } else { 20 };
        assert!(per_solve.as_millis() < limit_ms, "{per_solve:?} per solve");
    }

    #[test]
    fn perceived_gradient_is_even_in_lab() {
        let model = cmyw();
        let a = Mix::new(&[1.0, 0.0, 0.0, 0.0]).unwrap();
        let b = Mix::new(&[0.0, 0.0, 1.0, 0.0]).unwrap();
        let lab_a = model.predict_lab(&a).unwrap();
        let lab_b = model.predict_lab(&b).unwrap();
        let mid = lerp_perceived(&model, &a, &b, 0.5).unwrap();
        assert!(mid.predicted_lab.difference(lab_a.mix(lab_b, 0.5)) < 1.0, "{mid:?}");
        assert!(lerp_perceived(&model, &a, &b, 1.5).is_err());
        let three = Mix::new(&[1.0, 1.0, 1.0]).unwrap();
        assert!(matches!(lerp_perceived(&model, &a, &three, 0.5), Err(MixError::InputCount { .. })));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn solutions_are_normalised_mixes(r in any::<u8>(), g in any::<u8>(), b in any::<u8>()) {
            let s = solve(&cmyw(), Srgb8::new(r, g, b));
            let sum: f64 = s.mix.ratios().iter().sum();
            prop_assert!((sum - 1.0).abs() < 1e-9);
            prop_assert!(s.mix.ratios().iter().all(|&w| w >= 0.0));
            prop_assert!(s.mix.ratios().iter().any(|&w| w > 0.0));
            prop_assert_eq!(s.out_of_gamut, s.delta_e > OUT_OF_GAMUT_DE);
        }

        #[test]
        fn predicted_colours_are_found_again(
            w in prop::collection::vec(0.0f64..1.0, 4).prop_filter("not all zero", |w| w.iter().sum::<f64>() > 0.05)
        ) {
            let model = cmyw();
            let colour = model.predict(&Mix::new(&w).unwrap()).unwrap();
            let s = solve(&model, colour);
            prop_assert!(s.delta_e < 1.0, "{} -> dE {}", colour, s.delta_e);
        }
    }
}
