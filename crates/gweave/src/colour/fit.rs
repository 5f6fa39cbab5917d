//! Fitting the pigment model to measured swatches (`gweave mix --fit`).
//!
//! The model has two parameters per filament: its colour and its strength (see
//! [`super::mixing`]). A swatch of one input alone shows that filament's colour directly (the
//! model prints a pure input as its own colour), so the colours are taken from the pure
//! swatches, and an input without one keeps the colour it had. The strengths then decide every
//! blend: they are found by minimising the sum of squared CIEDE2000 differences between the
//! measured blends and the model's predictions. Only their ratios matter (scaling all of them
//! changes no mix), and they are searched as logarithms, one input at a time: a step up and down
//! for each, the best kept, the step halved when none improves (a pattern search, deterministic,
//! a few hundred model evaluations).
//!
//! Measurements come as CSV with a header: `id,srgb` (`#rrggbb`, e.g. from a photo white-
//! balanced on a grey card) or `id,L,a,b` (CIELAB D65 from a colorimeter).

use super::mix::{Mix, MixError};
use super::mixing::MixingModel;
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

/// Smallest step of the log-strength search.
const MIN_STEP: f64 = 1e-3;

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
    let base = MixingModel::with_strengths(&colours, start.strengths())?;
    let error = |model: &MixingModel| -> f64 {
        samples.iter().map(|(_, mix, lab)| lab.difference(model.lab_for_weights(mix.ratios())).powi(2)).sum()
    };
    let mut logs: Vec<f64> = start.strengths().iter().map(|s| s.ln()).collect();
    let mut best = error(&base);
    let mut model = base;
    let mut step = 1.0;
    while step >= MIN_STEP {
        let mut improved = None;
        for i in 0..logs.len() {
            for dir in [1.0, -1.0] {
                let mut trial = logs.clone();
                trial[i] = (trial[i] + dir * step).clamp(STRENGTH_LOG_MIN, STRENGTH_LOG_MAX);
                let strengths: Vec<f64> = trial.iter().map(|l| l.exp()).collect();
                let candidate = model.with_new_strengths(&strengths)?;
                let e = error(&candidate);
                if e < improved.as_ref().map_or(best, |(b, _, _)| *b) {
                    improved = Some((e, trial, candidate));
                }
            }
        }
        match improved {
            Some((e, trial, candidate)) => (best, logs, model) = (e, trial, candidate),
            None => step /= 2.0,
        }
    }
    let delta_e = samples
        .iter()
        .map(|(id, mix, lab)| {
            let before = lab.difference(start.lab_for_weights(mix.ratios()));
            (*id, before, lab.difference(model.lab_for_weights(mix.ratios())))
        })
        .collect();
    Ok(Fitted { model, delta_e })
}

/// Strengths stay within the profile's range (0.001 to 100).
const STRENGTH_LOG_MIN: f64 = -6.9;
const STRENGTH_LOG_MAX: f64 = 4.6;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::palette::CMYW_FILAMENTS;
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
        assert_eq!(fitted.delta_e.len(), 26);
        let mean_after = fitted.delta_e.iter().map(|d| d.2).sum::<f64>() / 26.0;
        let mean_before = fitted.delta_e.iter().map(|d| d.1).sum::<f64>() / 26.0;
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
        let m = [Measurement { id: 27, lab: Lab::new(50.0, 0.0, 0.0) }];
        assert_eq!(
            fit(&start, &card_mixes(4), &m).unwrap_err(),
            FitError::NoSuchSwatch { id: 27, count: 26 }
        );
    }
}
