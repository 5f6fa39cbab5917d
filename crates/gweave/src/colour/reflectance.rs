//! From an sRGB colour to a plausible reflectance spectrum.
//!
//! Many spectra look like one sRGB colour (metamers); pigments have smooth ones. We take the
//! smoothest: S. A. Burns' "least hyperbolic tangent slope squared" (LHTSS) reconstruction
//! (S. A. Burns, "Numerical methods for smoothest reflectance reconstruction", Color Research &
//! Application 45(1), 2020, and scottburns.us/reflectance-curves-from-srgb). Write the
//! reflectance as `R(z) = (tanh z + 1) / 2`, which keeps it strictly inside (0, 1) for any
//! real `z`, and solve
//!
//! ```text
//!   minimise   Σ (z[i+1] - z[i])^2        (smooth in the tanh domain)
//!   such that  T R(z) = rgb               (it shows exactly the wanted linear sRGB)
//! ```
//!
//! with `T` the 3 x 36 reflectance -> linear sRGB map of [`super::spectrum`]. The conditions
//! for a minimum (the Lagrangian's gradient is zero) are 39 equations in `z` and three
//! multipliers `λ`:
//!
//! ```text
//!   D z + diag(R'(z)) Tᵀ λ = 0            D: the tridiagonal second-difference matrix
//!   T R(z) - rgb = 0                       R' = sech^2(z) / 2,  R'' = -sech^2(z) tanh(z)
//! ```
//!
//! solved by Newton's method from `z = 0` (a flat 50 % grey); it converges in 5 to 10 steps.
//! A channel of exactly 0 or 1 has no solution (tanh never reaches ±1), so channels are kept
//! inside `[RGB_MIN, 1 - RGB_MIN]`: at most 1 in a byte near black, invisible elsewhere.

use palette::LinSrgb;

use super::spectrum::{to_linear_rgb_map, Spectrum, BANDS};

/// Linear channels are kept within `[RGB_MIN, 1 - RGB_MIN]` (sRGB byte 3 at the dark end).
pub(crate) const RGB_MIN: f64 = 1e-3;

const UNKNOWNS: usize = BANDS + 3;
const MAX_STEPS: usize = 50;
/// Newton stops when every equation holds to this.
const TOLERANCE: f64 = 1e-11;

/// The smoothest reflectance spectrum (LHTSS) whose colour under D65 is `c`.
pub(crate) fn reflectance(c: LinSrgb<f64>) -> Spectrum {
    let target = [c.red, c.green, c.blue].map(|v| v.clamp(RGB_MIN, 1.0 - RGB_MIN));
    let t = to_linear_rgb_map();
    let mut z = [0.0; BANDS];
    let mut lambda = [0.0; 3];
    for _ in 0..MAX_STEPS {
        let th = z.map(f64::tanh);
        let r = th.map(|x| (x + 1.0) / 2.0);
        let d1 = th.map(|x| (1.0 - x * x) / 2.0);
        let d2: Spectrum = std::array::from_fn(|i| -(1.0 - th[i] * th[i]) * th[i]);
        // Tᵀ λ, per band.
        let tl: Spectrum = std::array::from_fn(|i| (0..3).map(|k| t[k][i] * lambda[k]).sum());
        let mut f = [0.0; UNKNOWNS];
        for i in 0..BANDS {
            f[i] = second_difference(&z, i) + d1[i] * tl[i];
        }
        for k in 0..3 {
            f[BANDS + k] = t[k].iter().zip(&r).map(|(a, b)| a * b).sum::<f64>() - target[k];
        }
        if f.iter().all(|v| v.abs() < TOLERANCE) {
            break;
        }
        let mut j = [[0.0; UNKNOWNS + 1]; UNKNOWNS];
        for i in 0..BANDS {
            let ends = usize::from(i > 0) + usize::from(i + 1 < BANDS);
            j[i][i] = ends as f64 + d2[i] * tl[i];
            if i > 0 {
                j[i][i - 1] = -1.0;
            }
            if i + 1 < BANDS {
                j[i][i + 1] = -1.0;
            }
            for k in 0..3 {
                j[i][BANDS + k] = d1[i] * t[k][i];
                j[BANDS + k][i] = d1[i] * t[k][i];
            }
        }
        for (row, fi) in j.iter_mut().zip(&f) {
            row[UNKNOWNS] = -fi;
        }
        let step = solve_in_place(&mut j);
        for i in 0..BANDS {
            z[i] += step[i];
        }
        for k in 0..3 {
            lambda[k] += step[BANDS + k];
        }
    }
    z.map(|x| (x.tanh() + 1.0) / 2.0)
}

/// Row `i` of `D z`, with `D` the matrix of `Σ (z[i+1] - z[i])^2 / 2`'s gradient.
fn second_difference(z: &Spectrum, i: usize) -> f64 {
    let left = if i > 0 { z[i] - z[i - 1] } else { 0.0 };
    let right = if i + 1 < BANDS { z[i] - z[i + 1] } else { 0.0 };
    left + right
}

/// Solves the augmented system `a` (last column the right-hand side) by Gaussian elimination
/// with partial pivoting. The Newton matrix is symmetric and, away from a solution's
/// degenerate corners, regular; a zero pivot leaves that unknown's step at 0.
fn solve_in_place(a: &mut [[f64; UNKNOWNS + 1]; UNKNOWNS]) -> [f64; UNKNOWNS] {
    for col in 0..UNKNOWNS {
        let pivot =
            (col..UNKNOWNS).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs())).unwrap_or(col);
        a.swap(col, pivot);
        let p = a[col][col];
        if p.abs() < 1e-300 {
            continue;
        }
        let (upper, lower) = a.split_at_mut(col + 1);
        let pivot_row = &upper[col];
        for row in lower.iter_mut() {
            let m = row[col] / p;
            if m != 0.0 {
                for (x, q) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                    *x -= m * q;
                }
            }
        }
    }
    let mut x = [0.0; UNKNOWNS];
    for row in (0..UNKNOWNS).rev() {
        let p = a[row][row];
        if p.abs() < 1e-300 {
            continue;
        }
        let s: f64 = (row + 1..UNKNOWNS).map(|k| a[row][k] * x[k]).sum();
        x[row] = (a[row][UNKNOWNS] - s) / p;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::{linear_rgb, wavelength_nm};
    use crate::colour::Srgb8;

    #[test]
    fn the_spectrum_shows_the_colour_it_came_from() {
        for c in [
            Srgb8::new(0, 33, 133),
            Srgb8::new(252, 211, 0),
            Srgb8::new(0, 160, 224),
            Srgb8::new(224, 0, 122),
            Srgb8::new(245, 245, 240),
            Srgb8::new(128, 128, 128),
            Srgb8::new(255, 0, 0),
        ] {
            let want = LinSrgb::from(c);
            let r = reflectance(want);
            assert!(r.iter().all(|&x| x > 0.0 && x < 1.0), "{c}: {r:?}");
            let back = linear_rgb(&r);
            for (got, want) in [(back.red, want.red), (back.green, want.green), (back.blue, want.blue)] {
                assert!((got - want.clamp(RGB_MIN, 1.0 - RGB_MIN)).abs() < 1e-9, "{c}: {back:?}");
            }
        }
    }

    #[test]
    fn spectra_are_smooth_and_where_the_hue_says() {
        // A grey is flat; yellow reflects the long wavelengths, not the short ones.
        let grey = reflectance(Srgb8::new(128, 128, 128).into());
        assert!(grey.iter().all(|&x| (x - grey[0]).abs() < 1e-6), "{grey:?}");
        let yellow = reflectance(Srgb8::new(255, 224, 0).into());
        let at = |nm: f64| yellow[(0..BANDS).find(|&i| wavelength_nm(i) == nm).unwrap()];
        assert!(at(450.0) < 0.1 && at(600.0) > 0.8, "{yellow:?}");
    }
}
