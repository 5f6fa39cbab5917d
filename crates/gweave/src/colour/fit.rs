//! Fitting the pigment model to measured swatches (`gweave mix --fit`).
//!
//! The model has four things per filament: its colour, its strength, its spectral shape and
//! its tinting exponent (see `super::mixing` and `super::shape`). A swatch of one input
//! alone shows that filament's colour directly (the model prints a pure input as its own
//! colour, whatever the rest), so the colours are taken from the pure swatches, and an input
//! without one keeps the colour it had. The rest then decides every blend. They are found by
//! minimising, over the logarithms of the strengths, the bump weights `a` and the tinting
//! exponents `p`,
//!
//! ```text
//!   Σ_swatches ΔE00(measured, predicted)²  +  SHAPE_PENALTY · Σ a²  +  TINT_PENALTY · Σ (p - 1.7)²
//! ```
//!
//! by Levenberg-Marquardt (deterministic; each step evaluates the model 37 times for 4 inputs).
//! The objective is CIEDE2000 itself, the difference the card is judged by. Only the strengths'
//! ratios matter (scaling all of them changes no mix); the damping takes care of that direction.
//!
//! Why the shapes: with the strengths alone (the fit before, three free numbers for four inputs)
//! the fit could only slide each pair's blends along the path the smoothest spectra give them.
//! When that path is off (the smoothest cyan makes dull greens with yellow), the fit bent the
//! strengths to trade one blend's error for another's and predicted blends off the card worse
//! than the plain model (issue 39: mean ΔE00 3.8, max 9.0, against 3.2 and 6.5). A card of 30
//! swatches has 26 blends, 78 numbers; the shapes add 28 unknowns, and the penalty keeps the
//! spectra near the smoothest ones unless the card asks otherwise (2, as for the stored default
//! spectra in `super::pigments`). Measured against FilamentMixer on four sets of non-default
//! filaments in `fit_reference.rs` and `docs/mix.md`.
//!
//! Why the tinting exponents: the shapes and strengths fitted to the card's 1:3, 1:1 and 3:1
//! pairs still missed how far 10 % of one filament tints another (cyan : yellow 9:1 off by
//! 7.5 and 9.0 ΔE00 on two of those sets): the exponent is the model's law of small shares,
//! and it differs between filaments. The card has 9:1 and 1:9 swatches of yellow with cyan
//! and magenta to measure it ([`crate::post::mix::card::card_mixes`]); the penalty keeps each
//! exponent near 1.7, the value fitted once to Mixbox, unless the card asks otherwise.
//!
//! Measurements come as CSV with a header: `id,srgb` (`#rrggbb`, e.g. from a photo white-
//! balanced on a grey card) or `id,L,a,b` (CIELAB D65 from a colorimeter).

use super::mix::{Mix, MixError};
use super::mixing::{MixingModel, TINT_EXPONENT, TINT_EXPONENT_MAX, TINT_EXPONENT_MIN};
use super::shape::{Shape, BUMPS};
use super::srgb::Srgb8;
use super::{Ciede2000, Lab};

/// Why measurements could not be read or fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// A line of the measurements CSV cannot be read.
    #[error("line {line}: {message}")]
    Csv {
        /// The line number, from 1.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A measurement names a swatch the card does not have.
    #[error("swatch {id} is not on the card (1 to {count})")]
    NoSuchSwatch {
        /// The swatch number as written.
        id: u32,
        /// The number of swatches on the card.
        count: usize,
    },
    /// A fitted mix is invalid.
    #[error(transparent)]
    Mix(#[from] MixError),
}

/// One measured swatch.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// The swatch's number on the calibration card, from 1.
    pub id: u32,
    /// The colour measured on the print, CIELAB (D65).
    pub lab: Lab,
}

/// Reads `id,srgb` or `id,L,a,b` CSV (header first; blank lines and `#` comments skipped).
pub fn parse_csv(text: &str) -> Result<Vec<Measurement>, FitError> {
    let mut rows = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((line, header)) = rows.next() else {
        return Err(FitError::Csv {
            line: 1,
            message: "empty: expected a header `id,srgb` or `id,L,a,b`".into(),
        });
    };
    let names: Vec<String> = header.split(',').map(|h| h.trim().to_ascii_lowercase()).collect();
    let lab_columns = match names.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["id", "srgb"] => false,
        ["id", "l", "a", "b"] => true,
        _ => {
            return Err(FitError::Csv {
                line,
                message: format!("header {header:?}: expected `id,srgb` or `id,L,a,b`"),
            })
        }
    };
    rows.map(|(line, row)| {
        let bad = |message: String| FitError::Csv { line, message };
        let cells: Vec<&str> = row.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(bad(format!("{} columns, the header has {}", cells.len(), names.len())));
        }
        let id: u32 =
            cells[0].parse().map_err(|_| bad(format!("swatch id {:?} is not a number", cells[0])))?;
        let lab = if lab_columns {
            let n = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
            match (n(cells[1]), n(cells[2]), n(cells[3])) {
                (Some(l), Some(a), Some(b)) if (0.0..=100.0).contains(&l) => Lab::new(l, a, b),
                _ => return Err(bad(format!("L, a, b {:?}: numbers, L within 0..100", &cells[1..]))),
            }
        } else {
            Lab::from(Srgb8::parse_hex(cells[1]).map_err(|e| bad(e.to_string()))?)
        };
        Ok(Measurement { id, lab })
    })
    .collect()
}

/// The fitted filaments and how well they explain the measurements.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The mixing model with the fitted filament colours.
    pub model: MixingModel,
    /// Per measurement, in the order given: the swatch id and CIEDE2000 between measured and
    /// predicted, with the starting model and with the fitted one.
    pub delta_e: Vec<(u32, f64, f64)>,
}

/// Fits `start`'s filaments to `measured`, swatch `id` having the ratios `card[id - 1]`.
pub fn fit(start: &MixingModel, card: &[Mix], measured: &[Measurement]) -> Result<Fitted, FitError> {
    let samples: Vec<(u32, &Mix, Lab)> = measured
        .iter()
        .map(|m| {
            let mix = (m.id as usize).checked_sub(1).and_then(|i| card.get(i));
            mix.map(|mix| (m.id, mix, m.lab)).ok_or(FitError::NoSuchSwatch { id: m.id, count: card.len() })
        })
        .collect::<Result<_, _>>()?;
    let mut colours = start.inputs().to_vec();
    for (_, mix, lab) in &samples {
        mix.expect_inputs(colours.len())?;
        if let Some(i) = mix.ratios().iter().position(|&r| r == 1.0) {
            colours[i] = Srgb8::from(*lab);
        }
    }
    let n = colours.len();
    // A filament measured anew starts from its own default strength and no shape.
    let strengths: Vec<f64> = (0..n)
        .map(|i| {
            if colours[i] == start.inputs()[i] {
                start.strengths()[i]
            } else {
                MixingModel::default_strength(colours[i])
            }
        })
        .collect();
    let shapes: Vec<Shape> = (0..n)
        .map(|i| if colours[i] == start.inputs()[i] { start.shapes()[i] } else { [0.0; BUMPS] })
        .collect();
    let tints: Vec<f64> = (0..n)
        .map(|i| if colours[i] == start.inputs()[i] { start.tint_exponents()[i] } else { TINT_EXPONENT })
        .collect();
    let base = MixingModel::with_shapes(&colours, &strengths, &shapes)?.with_new_tint_exponents(&tints)?;
    let model = levenberg_marquardt(base, &samples)?;
    let delta_e = samples
        .iter()
        .map(|(id, mix, lab)| {
            let before = lab.difference(start.lab_for_weights(mix.ratios()));
            (*id, before, lab.difference(model.lab_for_weights(mix.ratios())))
        })
        .collect();
    Ok(Fitted { model, delta_e })
}

/// Weight of the shapes' penalty: the fit minimises `Σ ΔE00² + SHAPE_PENALTY Σ a²` over the
/// swatches and the bump weights `a`.
const SHAPE_PENALTY: f64 = 2.0;
/// Bump weights stay within ±this (a weight of 3 moves `tanh`'s argument by 3: from a
/// reflectance of 0.5 to 0.998).
const SHAPE_MAX: f64 = 3.0;
/// Weight of the tinting exponents' penalty: `TINT_PENALTY Σ (p - 1.7)²` is added to the sum.
/// Measured on `fit_reference.rs`'s four sets: 30 moves no mean by more than 0.05 ΔE00 and
/// raises the worst max from 5.78 to 5.94; without exponents that max is 6.95.
const TINT_PENALTY: f64 = 10.0;
/// Strengths stay within the profile's range (0.001 to 100).
const STRENGTH_LOG_MIN: f64 = -6.9;
const STRENGTH_LOG_MAX: f64 = 4.6;
/// Step of the finite differences of the Jacobian.
const DIFF_STEP: f64 = 1e-5;
/// The fit stops when a step lowers the sum by less than this share of it: a further 1e-9
/// moves no figure of `fit_reference.rs` by more than 0.03 ΔE00 and takes 3.5 times as long.
const STOP_GAIN: f64 = 1e-5;
/// Levenberg-Marquardt iterations, at most.
const MAX_ITERATIONS: usize = 60;

/// The fitted parameters of a model: the logarithms of the strengths, the shapes, then the
/// tinting exponents.
fn parameters(model: &MixingModel) -> Vec<f64> {
    let logs = model.strengths().iter().map(|s| s.ln());
    logs.chain(model.shapes().iter().flatten().copied())
        .chain(model.tint_exponents().iter().copied())
        .collect()
}

/// The model with parameters `p` (see [`parameters`]), clamped to their ranges; only the
/// spectra of inputs whose shape changed are recomputed.
fn with_parameters(model: &MixingModel, p: &[f64]) -> Result<MixingModel, MixError> {
    let n = model.inputs().len();
    let strengths: Vec<f64> =
        p[..n].iter().map(|l| l.clamp(STRENGTH_LOG_MIN, STRENGTH_LOG_MAX).exp()).collect();
    let mut out = model.with_new_strengths(&strengths)?;
    for i in 0..n {
        let shape: Shape = std::array::from_fn(|k| p[n + i * BUMPS + k].clamp(-SHAPE_MAX, SHAPE_MAX));
        if shape != model.shapes()[i] {
            out = out.with_new_shape(i, shape);
        }
    }
    let tints: Vec<f64> =
        p[n + n * BUMPS..].iter().map(|t| t.clamp(TINT_EXPONENT_MIN, TINT_EXPONENT_MAX)).collect();
    out.with_new_tint_exponents(&tints)
}

/// The residuals whose sum of squares the fit minimises: each swatch's CIEDE2000, each bump
/// weight times `sqrt(SHAPE_PENALTY)`, then each tinting exponent's distance from 1.7 times
/// `sqrt(TINT_PENALTY)`.
fn residuals(model: &MixingModel, samples: &[(u32, &Mix, Lab)]) -> Vec<f64> {
    let (shape_weight, tint_weight) = (SHAPE_PENALTY.sqrt(), TINT_PENALTY.sqrt());
    samples
        .iter()
        .map(|(_, mix, lab)| lab.difference(model.lab_for_weights(mix.ratios())))
        .chain(model.shapes().iter().flatten().map(|a| shape_weight * a))
        .chain(model.tint_exponents().iter().map(|p| tint_weight * (p - TINT_EXPONENT)))
        .collect()
}

/// Minimises the sum of squared [`residuals`] over the strengths and shapes by
/// Levenberg-Marquardt (K. Levenberg, 1944; D. W. Marquardt, 1963): at `p`, with `J` the
/// Jacobian of the residuals `r` (forward differences), step by `δ` solving
/// `(JᵀJ + λ diag(JᵀJ) + λ I) δ = -Jᵀr`; a step that lowers the sum is taken and `λ` divided
/// by 3, one that does not is retried with `λ` times 4. Gauss-Newton near the minimum,
/// gradient descent far from it; deterministic.
fn levenberg_marquardt(start: MixingModel, samples: &[(u32, &Mix, Lab)]) -> Result<MixingModel, MixError> {
    let mut model = start;
    let mut p = parameters(&model);
    let mut r = residuals(&model, samples);
    let mut cost: f64 = r.iter().map(|x| x * x).sum();
    let mut lambda = 1e-3;
    for _ in 0..MAX_ITERATIONS {
        let columns: Vec<Vec<f64>> = (0..p.len())
            .map(|j| {
                let mut q = p.clone();
                q[j] += DIFF_STEP;
                let rj = residuals(&with_parameters(&model, &q)?, samples);
                Ok(rj.iter().zip(&r).map(|(a, b)| (a - b) / DIFF_STEP).collect())
            })
            .collect::<Result<_, MixError>>()?;
        let m = p.len();
        let jtj: Vec<Vec<f64>> = (0..m)
            .map(|a| (0..m).map(|b| columns[a].iter().zip(&columns[b]).map(|(x, y)| x * y).sum()).collect())
            .collect();
        let jtr: Vec<f64> = columns.iter().map(|c| c.iter().zip(&r).map(|(x, y)| x * y).sum()).collect();
        let mut improved = false;
        while lambda < 1e10 {
            let mut a = jtj.clone();
            for (k, row) in a.iter_mut().enumerate() {
                row[k] += lambda * (row[k] + 1.0);
            }
            let step = solve_linear(a, jtr.iter().map(|g| -g).collect());
            let q: Vec<f64> = p.iter().zip(&step).map(|(x, d)| x + d).collect();
            let trial = with_parameters(&model, &q)?;
            let rq = residuals(&trial, samples);
            let c: f64 = rq.iter().map(|x| x * x).sum();
            if c < cost {
                improved = cost - c > STOP_GAIN * cost;
                (p, model, r, cost) = (parameters(&trial), trial, rq, c);
                lambda /= 3.0;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    Ok(model)
}

/// Solves `a x = b` by Gaussian elimination with partial pivoting; a zero pivot leaves that
/// unknown's step at 0 (the damping keeps `a` regular).
fn solve_linear(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs())).unwrap_or(col);
        a.swap(col, pivot);
        b.swap(col, pivot);
        let p = a[col][col];
        if p.abs() < 1e-300 {
            continue;
        }
        let (upper, lower) = a.split_at_mut(col + 1);
        let (pivot_row, pivot_b) = (&upper[col], b[col]);
        for (row, b_row) in lower.iter_mut().zip(&mut b[col + 1..]) {
            let f = row[col] / p;
            if f != 0.0 {
                for (x, q) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                    *x -= f * q;
                }
                *b_row -= f * pivot_b;
            }
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let p = a[row][row];
        if p.abs() >= 1e-300 {
            let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
            x[row] = (b[row] - s) / p;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::pigments::CMYW_FILAMENTS;
    use crate::post::mix::card::card_mixes;

    #[test]
    fn reads_both_csv_forms_and_refuses_bad_rows() {
        let m = parse_csv("id,srgb\n1,#00a0e0\n\n# white\n4, #f5f5f0\n").unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!((m[1].id, Srgb8::from(m[1].lab)), (4, Srgb8::new(0xf5, 0xf5, 0xf0)));
        let m = parse_csv("ID,L,a,b\n2,50,10,-20\n").unwrap();
        assert_eq!(m[0].lab, Lab::new(50.0, 10.0, -20.0));
        for (text, want) in [
            ("", "line 1: empty"),
            ("id,rgb\n", "line 1: header"),
            ("id,srgb\n1,#00a0e0,3\n", "line 2: 3 columns"),
            ("id,srgb\nx,#00a0e0\n", "line 2: swatch id"),
            ("id,srgb\n1,#00a0e\n", "line 2:"),
            ("id,L,a,b\n1,150,0,0\n", "line 2: L, a, b"),
        ] {
            let err = parse_csv(text).unwrap_err().to_string();
            assert!(err.starts_with(want), "{text:?}: {err}");
        }
    }

    #[test]
    fn a_fit_to_a_known_model_predicts_blends_off_the_card() {
        // The "real" filaments: other colours and strengths than the defaults.
        let truth = MixingModel::with_strengths(
            &[
                Srgb8::new(20, 150, 210),
                Srgb8::new(200, 20, 110),
                Srgb8::new(250, 210, 30),
                Srgb8::new(240, 238, 230),
            ],
            &[0.9, 0.15, 1.5, 0.6],
        )
        .unwrap();
        let card = card_mixes(4);
        // Measured as 8-bit colours, as from a photo.
        let measured: Vec<Measurement> = (1..)
            .zip(&card)
            .map(|(id, mix)| Measurement { id, lab: Lab::from(truth.predict(mix).unwrap()) })
            .collect();
        let start = MixingModel::new(&CMYW_FILAMENTS).unwrap();
        let fitted = fit(&start, &card, &measured).unwrap();
        assert_eq!(fitted.delta_e.len(), 30);
        let mean_after = fitted.delta_e.iter().map(|d| d.2).sum::<f64>() / 30.0;
        let mean_before = fitted.delta_e.iter().map(|d| d.1).sum::<f64>() / 30.0;
        assert!(mean_after < 1.0 && mean_before > 5.0, "{mean_before} -> {mean_after}");
        // Blends not on the card.
        let off_card = [
            [0.6, 0.2, 0.2, 0.0],
            [0.1, 0.1, 0.1, 0.7],
            [0.2, 0.5, 0.0, 0.3],
            [0.0, 0.3, 0.6, 0.1],
            [0.4, 0.0, 0.4, 0.2],
            [0.25, 0.25, 0.25, 0.25],
            [0.05, 0.0, 0.0, 0.95],
            [0.7, 0.0, 0.1, 0.2],
        ];
        let errors: Vec<f64> = off_card
            .iter()
            .map(|w| truth.lab_for_weights(w).difference(fitted.model.lab_for_weights(w)))
            .collect();
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        assert!(mean <= 3.0, "{errors:?}");
        let unfitted = off_card.iter().map(|w| truth.lab_for_weights(w).difference(start.lab_for_weights(w)));
        assert!(unfitted.sum::<f64>() / 8.0 > 5.0);
    }

    #[test]
    fn unknown_swatches_are_refused() {
        let start = MixingModel::new(&CMYW_FILAMENTS).unwrap();
        let m = [Measurement { id: 31, lab: Lab::new(50.0, 0.0, 0.0) }];
        assert_eq!(
            fit(&start, &card_mixes(4), &m).unwrap_err(),
            FitError::NoSuchSwatch { id: 31, count: 30 }
        );
    }
}
