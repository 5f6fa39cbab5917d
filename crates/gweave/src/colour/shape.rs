//! A filament's spectral shape: how its reflectance spectrum departs from the smoothest one,
//! keeping its colour (what `gweave mix --fit` measures besides the strengths).
//!
//! Many spectra show one sRGB colour (metamers), and they mix differently: a cyan whose
//! reflectance stays high into the green makes bright greens with yellow, one that falls off
//! early makes dull ones. A pure swatch shows only the colour; the blends on a calibration card
//! show which metamer the filament is. The shape has [`BUMPS`] numbers per filament: the
//! weights `a_k` of smooth bumps in the `tanh` domain of the reflectance (as in
//! [`super::reflectance`], `R = (tanh z + 1) / 2`), centred every 50 nm from 400 to 700 nm,
//! each a Gaussian of standard deviation [`BUMP_WIDTH_NM`]:
//!
//! ```text
//!   z(λ) = z₀(λ) + Σ_k a_k exp(-((λ - c_k) / σ)² / 2) + Σ_m μ_m T_m(λ)
//! ```
//!
//! with `z₀` the filament's spectrum without a shape ([`super::pigments::spectrum`]: the
//! smoothest one, or the fitted spectrum of a default filament), and `μ` three numbers solved so
//! that the spectrum still shows exactly the filament's colour (`T R(z) = rgb`, `T` the 3 x 36
//! reflectance -> linear sRGB map; Newton's method on the 3 x 3 system
//! `J = T diag(R'(z)) Tᵀ`, from `μ = 0`, converging in a few steps): the bumps move light from one
//! part of the spectrum to another, never the colour. The same parametrisation as the stored
//! default spectra ([`super::pigments`]), so a zero shape is the filament as before.

use super::pigments::spectrum;
use super::reflectance::RGB_MIN;
use super::spectrum::{to_linear_rgb_map, wavelength_nm, Spectrum, BANDS};
use super::srgb::Srgb8;

/// Bumps per filament.
pub(crate) const BUMPS: usize = 7;

/// Standard deviation of a bump, nm: wide enough that neighbours (50 nm apart) overlap and the
/// spectrum stays smooth.
pub(crate) const BUMP_WIDTH_NM: f64 = 35.0;

/// A filament's shape: the bump weights at 400, 450, .. 700 nm, in the `tanh` domain.
pub(crate) type Shape = [f64; BUMPS];

/// Centre of bump `k`, nm.
fn centre_nm(k: usize) -> f64 {
    400.0 + 50.0 * k as f64
}

const NEWTON_STEPS: usize = 30;
/// Newton stops when every channel is within this of the colour.
const TOLERANCE: f64 = 1e-12;

/// The reflectance spectrum of a filament of colour `c` with shape `shape` (see the module
/// docs); a zero shape gives [`spectrum`]`(c)` exactly.
pub(crate) fn shaped_spectrum(c: Srgb8, shape: &Shape) -> Spectrum {
    let base = spectrum(c);
    if shape.iter().all(|&a| a == 0.0) {
        return base;
    }
    let t = to_linear_rgb_map();
    let linear = palette::LinSrgb::<f64>::from(c);
    let target = [linear.red, linear.green, linear.blue].map(|v| v.clamp(RGB_MIN, 1.0 - RGB_MIN));
    // z₀ plus the bumps; the reflectance stays inside (0, 1), so atanh is finite.
    let bumped: Spectrum = std::array::from_fn(|i| {
        let nm = wavelength_nm(i);
        let bumps: f64 = shape
            .iter()
            .enumerate()
            .map(|(k, a)| a * (-0.5 * ((nm - centre_nm(k)) / BUMP_WIDTH_NM).powi(2)).exp())
            .sum();
        (2.0 * base[i] - 1.0).atanh() + bumps
    });
    let mut mu = [0.0; 3];
    let mut r = base;
    for _ in 0..NEWTON_STEPS {
        let z: Spectrum = std::array::from_fn(|i| bumped[i] + (0..3).map(|m| mu[m] * t[m][i]).sum::<f64>());
        let th = z.map(f64::tanh);
        r = th.map(|x| (x + 1.0) / 2.0);
        let slope = th.map(|x| (1.0 - x * x) / 2.0);
        let f: [f64; 3] =
            std::array::from_fn(|k| t[k].iter().zip(&r).map(|(a, b)| a * b).sum::<f64>() - target[k]);
        if f.iter().all(|v| v.abs() < TOLERANCE) {
            break;
        }
        let j: [[f64; 3]; 3] = std::array::from_fn(|k| {
            std::array::from_fn(|m| (0..BANDS).map(|i| t[k][i] * slope[i] * t[m][i]).sum())
        });
        let step = solve3(j, f.map(|v| -v));
        for (m, s) in mu.iter_mut().zip(step) {
            *m += s;
        }
    }
    r
}

/// Solves the 3 x 3 system `a x = b` by Cramer's rule (`a` is symmetric positive definite here:
/// `T diag(R') Tᵀ` with `R' > 0`); a singular `a` gives no step.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> [f64; 3] {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&a);
    if d.abs() < 1e-300 {
        return [0.0; 3];
    }
    std::array::from_fn(|col| {
        let mut m = a;
        for (row, v) in m.iter_mut().zip(b) {
            row[col] = v;
        }
        det(&m) / d
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::linear_rgb;

    #[test]
    fn a_shape_moves_light_but_keeps_the_colour() {
        let cyan = Srgb8::new(20, 150, 210);
        assert_eq!(shaped_spectrum(cyan, &[0.0; BUMPS]), spectrum(cyan));
        // A bump up at 500 nm and down at 650 nm: the spectrum changes (the three `μ` take back
        // only what would change the colour), the colour does not.
        let shaped = shaped_spectrum(cyan, &[0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0]);
        let moved = shaped.iter().zip(&spectrum(cyan)).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(moved > 0.05, "{moved}");
        let (got, want) = (linear_rgb(&shaped), palette::LinSrgb::<f64>::from(cyan));
        for (g, w) in [(got.red, want.red), (got.green, want.green), (got.blue, want.blue)] {
            assert!((g - w).abs() < 1e-10, "{got:?} {want:?}");
        }
    }
}
