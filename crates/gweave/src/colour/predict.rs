//! What a mix prints, for people and programs: `gweave mix --predict 0.5:0:0.5:0` and
//! `gweave.predict_colour`.
//!
//! ```
//! use gweave::colour::{pigments, predict, MixingModel};
//!
//! let model = MixingModel::new(&pigments::CMYW_FILAMENTS).unwrap();
//! let green = predict::predict(&model, &predict::parse_ratios("1:0:1:0").unwrap()).unwrap();
//! assert_eq!(green.ratios, [0.5, 0.0, 0.5, 0.0]);
//! assert!(green.lab[1] < -20.0); // CIELAB a* < 0: green
//! ```

use serde::Serialize;

use super::mix::{Mix, MixError};
use super::mixing::MixingModel;
use super::srgb::Srgb8;
use super::Lab;

/// One predicted colour.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// The mix, normalised to sum 1, input 0 first.
    pub ratios: Vec<f64>,
    /// `#rrggbb`, the nearest 8-bit sRGB colour.
    pub srgb: String,
    /// CIELAB (D65) `[L, a, b]`, unrounded.
    pub lab: [f64; 3],
}

/// Ratios written `C:M:Y:W` (any scale: `1:0:1:0` is `0.5:0:0.5:0`).
pub fn parse_ratios(s: &str) -> Result<Mix, MixError> {
    let ratios = s
        .split(':')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<Vec<f64>, _>>()
        .map_err(|_| MixError::Syntax(s.to_owned()))?;
    Mix::new(&ratios)
}

/// The model's colour for `mix`.
pub fn predict(model: &MixingModel, mix: &Mix) -> Result<Prediction, MixError> {
    let lab: Lab = model.predict_lab(mix)?;
    Ok(Prediction {
        ratios: mix.ratios().to_vec(),
        srgb: Srgb8::from(lab).to_hex(),
        lab: [lab.l, lab.a, lab.b],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::pigments::CMYW_FILAMENTS;

    #[test]
    fn parses_and_predicts() {
        let model = MixingModel::new(&CMYW_FILAMENTS).unwrap();
        let white = predict(&model, &parse_ratios("0:0:0:2").unwrap()).unwrap();
        assert_eq!(white.srgb, "#f5f5f0");
        assert_eq!(white.ratios, [0.0, 0.0, 0.0, 1.0]);
        assert!((white.lab[0] - 96.4).abs() < 0.1, "{white:?}");
        assert_eq!(parse_ratios("1:x"), Err(MixError::Syntax("1:x".into())));
        assert_eq!(parse_ratios("0:0"), Err(MixError::AllZero));
        let three = parse_ratios("1:1:1").unwrap();
        assert_eq!(predict(&model, &three), Err(MixError::InputCount { expected: 4, found: 3 }));
    }
}
