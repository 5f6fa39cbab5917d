//! Subtractive (pigment) mixing model: the colour a `Mix` of filaments prints.
//!
//! Model (ours, built from textbook physics): single-constant Kubelka-Munk,
//! applied per channel to linear-light sRGB reflectance.
//!
//! For an opaque layer, Kubelka-Munk theory (P. Kubelka and F. Munk, 1931) ties
//! reflectance `R` to the ratio of absorption `K` to scattering `S`:
//!
//! ```text
//!   K/S = (1 - R)^2 / (2 R)                 R = 1 + K/S - sqrt((K/S)^2 + 2 K/S)
//! ```
//!
//! Assuming all filaments scatter alike (the "single-constant" simplification,
//! reasonable for one polymer with different pigments), the K/S of a blend is
//! the weight-average of its components' K/S. Absorptions add, so the model is
//! subtractive: cyan + yellow keep only what both reflect (green). The inverse
//! is written as `R = 1 / (1 + K/S + sqrt((K/S)^2 + 2 K/S))`, the same value
//! without the cancellation for large K/S.
//!
//! Clamp: `K/S` is infinite at `R = 0`, and one such channel would turn every
//! mix containing that filament black in that channel. Reflectances are clamped
//! to at least `R_MIN = 0.005` (sRGB byte 16): printed plastic never measures
//! darker (black PLA is about 0.011, sRGB 28), and it keeps the K/S finite
//! (<= 99). `R = 1` gives `K/S = 0`, which needs no clamp.
//!
//! Limits (measured in the tests): per-channel mixing cannot know where in
//! the spectrum each filament reflects, so mixes come out darker than real ones.
//! Blue (0,33,133) + yellow (252,211,0) at 0.5 gives a dark green (25,48,25),
//! at CIEDE2000 31.6 from the public reference point (47,141,56) of
//! BambuStudio's MIT-licensed `filament_mixer_model.h` (a fit of Mixbox); the
//! hue is right. We also tried Kubelka-Munk on smooth reflectance spectra
//! (Jakob-Hanika sigmoid upsampling): it gives browner, more realistic
//! three-colour mixes but a teal (hue 175-225 degrees) for that blue + yellow,
//! because any spectrum that looks like (0,33,133) reflects almost nothing at
//! 530-580 nm. `solve` minimises dE against this model, so a better model can
//! replace it without changing any caller.

use super::lab::{Lab, Xyz};
use super::mix::{Mix, MixError};
use super::srgb::{LinearRgb, Srgb8};

/// Smallest reflectance used in the K/S transform (see module docs).
pub const R_MIN: f64 = 0.005;

/// K/S of a reflectance, after clamping it into `[R_MIN, 1]`.
fn k_over_s(r: f64) -> f64 {
    let r = r.clamp(R_MIN, 1.0);
    (1.0 - r) * (1.0 - r) / (2.0 * r)
}

/// Reflectance of an opaque layer with the given K/S.
fn reflectance(ks: f64) -> f64 {
    1.0 / (1.0 + ks + (ks * ks + 2.0 * ks).sqrt())
}

/// The filaments loaded in a mixing hotend, input 0 first, ready to predict colours.
#[derive(Debug, Clone)]
pub struct MixingModel {
    inputs: Vec<Srgb8>,
    /// K/S per input, channels r, g, b.
    k_over_s: Vec<[f64; 3]>,
}

impl MixingModel {
    /// Model for these filament colours (one per input).
    pub fn new(inputs: &[Srgb8]) -> Result<Self, MixError> {
        if inputs.is_empty() {
            return Err(MixError::NoInputs);
        }
        let k_over_s = inputs
            .iter()
            .map(|c| {
                let l = c.to_linear();
                [l.r, l.g, l.b].map(k_over_s)
            })
            .collect();
        Ok(Self { inputs: inputs.to_vec(), k_over_s })
    }

    /// The filament colours, input 0 first.
    pub fn inputs(&self) -> &[Srgb8] {
        &self.inputs
    }

    /// Predicted CIELAB colour of a mix.
    pub fn predict_lab(&self, mix: &Mix) -> Result<Lab, MixError> {
        mix.expect_inputs(self.inputs.len())?;
        Ok(self.lab_for_weights(mix.ratios()))
    }

    /// Predicted colour of a mix, as the nearest 8-bit sRGB colour.
    pub fn predict(&self, mix: &Mix) -> Result<Srgb8, MixError> {
        self.predict_lab(mix).map(Lab::to_srgb8)
    }

    /// Lab for non-negative weights, one per input, summing to 1. The solver
    /// calls this in its inner loop with unvalidated candidates of that shape.
    pub(crate) fn lab_for_weights(&self, weights: &[f64]) -> Lab {
        let mut ks = [0.0; 3];
        for (input, w) in self.k_over_s.iter().zip(weights) {
            for (acc, k) in ks.iter_mut().zip(input) {
                *acc += w * k;
            }
        }
        let [r, g, b] = ks.map(reflectance);
        Lab::from_xyz(Xyz::from_linear(LinearRgb { r, g, b }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::delta_e::ciede2000;

    const CYAN: Srgb8 = Srgb8::new(0, 160, 224);
    const MAGENTA: Srgb8 = Srgb8::new(224, 0, 122);
    const YELLOW: Srgb8 = Srgb8::new(255, 224, 0);

    fn predict(model: &MixingModel, ratios: &[f64]) -> Lab {
        model.predict_lab(&Mix::new(ratios).unwrap()).unwrap()
    }

    #[test]
    fn kubelka_munk_transform_inverts() {
        for r in [R_MIN, 0.01, 0.3, 0.5, 0.99, 1.0] {
            assert!((reflectance(k_over_s(r)) - r).abs() < 1e-12, "{r}");
        }
        assert_eq!(k_over_s(0.0), k_over_s(R_MIN));
        assert!((k_over_s(0.5) - 0.25).abs() < 1e-15);
    }

    #[test]
    fn a_single_input_prints_its_own_colour() {
        let orange = Srgb8::new(255, 136, 16);
        let model = MixingModel::new(&[CYAN, orange]).unwrap();
        assert_eq!(model.predict(&Mix::new(&[0.0, 1.0]).unwrap()), Ok(orange));
        // Channels darker than R_MIN (byte 16) are lifted to it.
        assert_eq!(model.predict(&Mix::new(&[1.0, 0.0]).unwrap()), Ok(Srgb8::new(16, 160, 224)));
    }

    #[test]
    fn blue_and_yellow_make_green() {
        let model = MixingModel::new(&[Srgb8::new(0, 33, 133), Srgb8::new(252, 211, 0)]).unwrap();
        let lab = predict(&model, &[0.5, 0.5]);
        assert_eq!(lab.to_srgb8(), Srgb8::new(25, 48, 25));
        // Green: the hue is nearer sRGB green's (136 deg) than yellow's (102) or cyan's (196).
        let hue = lab.hue_deg();
        assert!((119.0..166.0).contains(&hue), "h={hue}");
        assert!(lab.chroma() > 15.0, "C={}", lab.chroma());
        // How far from the public reference point: too dark, hue close.
        let reference = Lab::from_srgb8(Srgb8::new(47, 141, 56));
        let de = ciede2000(lab, reference);
        assert!((31.0..32.5).contains(&de), "dE {de}");
        assert!((hue - reference.hue_deg()).abs() < 10.0, "h={hue}");
    }

    #[test]
    fn zonestar_reference_mixes_have_the_right_hue() {
        // Zonestar's WCMY chart: C50/M50 blue, M83/Y17 red, M50/Y50 orange, C50/Y50 green.
        let model = MixingModel::new(&[CYAN, MAGENTA, YELLOW]).unwrap();
        let cases: [([f64; 3], std::ops::Range<f64>); 4] = [
            ([0.5, 0.5, 0.0], 260.0..320.0),
            ([0.0, 0.83, 0.17], 0.0..45.0),
            ([0.0, 0.5, 0.5], 35.0..75.0),
            ([0.5, 0.0, 0.5], 120.0..200.0),
        ];
        for (w, hues) in cases {
            let lab = predict(&model, &w);
            assert!(hues.contains(&lab.hue_deg()), "{w:?}: {} h={}", lab.to_srgb8(), lab.hue_deg());
        }
    }

    #[test]
    fn equal_cmy_is_dark_brown_grey() {
        let model = MixingModel::new(&[CYAN, MAGENTA, YELLOW]).unwrap();
        let lab = predict(&model, &[1.0, 1.0, 1.0]);
        // Dark but not black, and nearly neutral.
        assert!(lab.l < 20.0 && lab.l > 8.0, "{} L={}", lab.to_srgb8(), lab.l);
        assert!(lab.chroma() < 3.0, "{} C={}", lab.to_srgb8(), lab.chroma());
    }

    #[test]
    fn more_black_is_darker_and_order_does_not_matter() {
        let white = Srgb8::new(245, 245, 240);
        let black = Srgb8::new(28, 28, 28);
        let model = MixingModel::new(&[white, black]).unwrap();
        let swapped = MixingModel::new(&[black, white]).unwrap();
        let mut last_l = f64::INFINITY;
        for k in [0.0, 0.05, 0.2, 0.5, 0.8, 1.0] {
            let lab = predict(&model, &[1.0 - k, k]);
            assert!(lab.l < last_l, "L not falling at black share {k}");
            last_l = lab.l;
            let other = predict(&swapped, &[k, 1.0 - k]);
            assert!(ciede2000(lab, other) < 1e-9);
        }
    }

    #[test]
    fn input_count_is_checked() {
        let model = MixingModel::new(&[CYAN, MAGENTA]).unwrap();
        let mix = Mix::new(&[1.0, 1.0, 1.0]).unwrap();
        assert_eq!(model.predict(&mix), Err(MixError::InputCount { expected: 2, found: 3 }));
        assert!(matches!(MixingModel::new(&[]), Err(MixError::NoInputs)));
    }
}
