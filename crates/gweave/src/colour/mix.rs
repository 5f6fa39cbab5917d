//! `Mix`: how much of each input filament goes into the nozzle.
//!
//! A mixing hotend with N inputs extrudes filament i at the share `w_i / sum(w)`
//! of the total E (Marlin MIXING_EXTRUDER gives each E step to one input in
//! that proportion), so only ratios matter. A `Mix` is therefore validated once
//! (finite, non-negative, not all zero: an all-zero mix divides by zero in the
//! firmware) and stored normalised to sum 1.

/// Why a set of ratios is not a usable mix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MixError {
    /// A mix with no input.
    #[error("a mix needs at least one input")]
    NoInputs,
    /// A ratio that is NaN or infinite.
    #[error("ratio of input {index} is {value}, not a finite number")]
    NotFinite {
        /// The input (0-based).
        index: usize,
        /// The ratio as given.
        value: f64,
    },
    /// A negative ratio.
    #[error("ratio of input {index} is negative ({value})")]
    Negative {
        /// The input (0-based).
        index: usize,
        /// The ratio as given.
        value: f64,
    },
    /// All ratios are zero.
    #[error("all ratios are zero; the firmware would divide by zero")]
    AllZero,
    /// A mix with another number of inputs than the mixer has.
    #[error("mix has {found} inputs, expected {expected}")]
    InputCount {
        /// The mixer's number of inputs.
        expected: usize,
        /// The mix's number of inputs.
        found: usize,
    },
    /// A value that must be within 0 to 1 is not.
    #[error("{what} must be within [0, 1], got {value}")]
    OutOfUnitRange {
        /// What the value is, for the message.
        what: &'static str,
        /// The value as given.
        value: f64,
    },
    /// Ratios text that is not numbers separated by `:`.
    #[error("ratios {0:?}: write numbers separated by ':', one per input (C:M:Y:W)")]
    Syntax(String),
    /// A filament strength that is not a positive number.
    #[error("strength of input {index} is {value}, not a positive number")]
    Strength {
        /// The input (0-based).
        index: usize,
        /// The strength as given.
        value: f64,
    },
    /// An input index at or past the number of inputs.
    #[error("input {index} does not exist in a {inputs}-input mix")]
    NoSuchInput {
        /// The index as given.
        index: usize,
        /// The mix's number of inputs.
        inputs: usize,
    },
}

/// Ratios per input, each in `[0, 1]`, summing to 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Mix {
    ratios: Vec<f64>,
}

fn check_unit(what: &'static str, value: f64) -> Result<f64, MixError> {
    if (0.0..=1.0).contains(&value) {
        Ok(value)
    } else {
        Err(MixError::OutOfUnitRange { what, value })
    }
}

impl Mix {
    /// Validate and normalise ratios given in any scale (`[60, 40]` equals `[0.6, 0.4]`).
    pub fn new(ratios: &[f64]) -> Result<Self, MixError> {
        if ratios.is_empty() {
            return Err(MixError::NoInputs);
        }
        for (index, &value) in ratios.iter().enumerate() {
            if !value.is_finite() {
                return Err(MixError::NotFinite { index, value });
            }
            if value < 0.0 {
                return Err(MixError::Negative { index, value });
            }
        }
        // Divide by the largest ratio first so that the sum cannot overflow.
        let max = ratios.iter().copied().fold(0.0, f64::max);
        if max == 0.0 {
            return Err(MixError::AllZero);
        }
        let sum: f64 = ratios.iter().map(|r| r / max).sum();
        Ok(Self { ratios: ratios.iter().map(|r| r / max / sum).collect() })
    }

    /// The normalised ratios, one per input, summing to 1.
    pub fn ratios(&self) -> &[f64] {
        &self.ratios
    }

    /// Number of inputs.
    pub fn inputs(&self) -> usize {
        self.ratios.len()
    }

    /// Error unless this mix has `inputs` inputs.
    pub fn expect_inputs(&self, inputs: usize) -> Result<(), MixError> {
        if self.inputs() == inputs {
            Ok(())
        } else {
            Err(MixError::InputCount { expected: inputs, found: self.inputs() })
        }
    }

    /// "Proportion of material 2" (the mixing seed): the input `index` holds a second
    /// material (e.g. soluble PVA or flexible), which gets the share `p`; the
    /// other inputs keep their proportions among themselves, scaled to `1 - p`.
    /// `p = 1` is pure material 2 (support), `p = 0` removes it.
    pub fn with_material2(&self, p: f64, index: usize) -> Result<Self, MixError> {
        let p = check_unit("proportion of material 2", p)?;
        if index >= self.inputs() {
            return Err(MixError::NoSuchInput { index, inputs: self.inputs() });
        }
        let others: f64 = self.ratios.iter().enumerate().filter(|&(i, _)| i != index).map(|(_, r)| r).sum();
        let scale = if others > 0.0 { (1.0 - p) / others } else { 0.0 };
        let ratios: Vec<f64> =
            self.ratios.iter().enumerate().map(|(i, r)| if i == index { p } else { r * scale }).collect();
        Self::new(&ratios)
    }

    /// Straight line in mix space: `t = 0` is `self`, `t = 1` is `other`.
    /// This is what the firmware's own gradients (Marlin M166) do; the
    /// perceived colour does not change evenly along it (see `solve::lerp_perceived`).
    pub fn lerp(&self, other: &Mix, t: f64) -> Result<Self, MixError> {
        other.expect_inputs(self.inputs())?;
        let t = check_unit("interpolation parameter", t)?;
        let ratios: Vec<f64> = self.ratios.iter().zip(&other.ratios).map(|(a, b)| a + (b - a) * t).collect();
        Self::new(&ratios)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_ratios(mix: &Mix, expected: &[f64]) {
        assert_eq!(mix.inputs(), expected.len());
        for (got, want) in mix.ratios().iter().zip(expected) {
            assert!((got - want).abs() < 1e-12, "{:?} != {expected:?}", mix.ratios());
        }
    }

    #[test]
    fn normalises_any_scale() {
        assert_ratios(&Mix::new(&[60.0, 40.0]).unwrap(), &[0.6, 0.4]);
        assert_ratios(&Mix::new(&[0.0, 0.17, 0.82, 0.0]).unwrap(), &[0.0, 17.0 / 99.0, 82.0 / 99.0, 0.0]);
        assert_ratios(&Mix::new(&[f64::MAX, f64::MAX]).unwrap(), &[0.5, 0.5]);
        assert_ratios(&Mix::new(&[5e-324, 0.0]).unwrap(), &[1.0, 0.0]);
    }

    #[test]
    fn rejects_bad_ratios() {
        assert_eq!(Mix::new(&[]), Err(MixError::NoInputs));
        assert_eq!(Mix::new(&[0.0, 0.0]), Err(MixError::AllZero));
        assert_eq!(Mix::new(&[0.5, -0.1]), Err(MixError::Negative { index: 1, value: -0.1 }));
        assert!(matches!(Mix::new(&[1.0, f64::NAN]), Err(MixError::NotFinite { index: 1, .. })));
        assert!(matches!(Mix::new(&[f64::INFINITY]), Err(MixError::NotFinite { index: 0, .. })));
    }

    #[test]
    fn material2_scales_pigment_shares() {
        // Seed: Orange (0, 0.17, 0.82, 0) with 30 % material 2 on E3.
        let orange = Mix::new(&[0.0, 0.17, 0.82, 0.0]).unwrap();
        let m = orange.with_material2(0.3, 3).unwrap();
        assert_ratios(&m, &[0.0, 0.7 * 17.0 / 99.0, 0.7 * 82.0 / 99.0, 0.3]);
        // Supports: 100 % material 2.
        assert_ratios(&orange.with_material2(1.0, 3).unwrap(), &[0.0, 0.0, 0.0, 1.0]);
        // An existing share on the material-2 input is replaced, not added to.
        let pink = Mix::new(&[0.0, 0.6, 0.1, 0.3]).unwrap();
        assert_ratios(&pink.with_material2(0.5, 3).unwrap(), &[0.0, 0.5 * 6.0 / 7.0, 0.5 / 7.0, 0.5]);
    }

    #[test]
    fn material2_errors() {
        let key = Mix::new(&[0.0, 0.0, 0.0, 1.0]).unwrap();
        // Nothing left but material 2, and it was asked to be 0.
        assert_eq!(key.with_material2(0.0, 3), Err(MixError::AllZero));
        assert_eq!(key.with_material2(0.5, 4), Err(MixError::NoSuchInput { index: 4, inputs: 4 }));
        assert!(matches!(
            key.with_material2(1.5, 3),
            Err(MixError::OutOfUnitRange { value, .. }) if value == 1.5
        ));
    }

    #[test]
    fn lerp_in_mix_space() {
        let a = Mix::new(&[1.0, 0.0, 0.0]).unwrap();
        let b = Mix::new(&[0.0, 0.5, 0.5]).unwrap();
        assert_ratios(&a.lerp(&b, 0.25).unwrap(), &[0.75, 0.125, 0.125]);
        assert_ratios(&a.lerp(&b, 1.0).unwrap(), &[0.0, 0.5, 0.5]);
        assert_eq!(
            a.lerp(&Mix::new(&[1.0]).unwrap(), 0.5),
            Err(MixError::InputCount { expected: 3, found: 1 })
        );
        assert!(a.lerp(&b, -0.1).is_err());
    }
}
