//! Visible spectra: the wavelength grid, the CIE colour-matching functions and the D65
//! illuminant, and the map from a reflectance spectrum to linear sRGB.
//!
//! The grid is 380 to 730 nm in 10 nm bands (36 values), the range and step of most
//! spectrophotometers and of S. A. Burns' reflectance-recovery tables. The tables are the
//! published ones at those wavelengths:
//!
//! - CIE 1931 2-degree standard observer x(λ), y(λ), z(λ): CIE 15:2004 "Colorimetry", Table T.4
//!   (also CIE 018:2019; the 1 nm values as distributed by the CVRL database, cvrl.org).
//! - CIE standard illuminant D65 relative spectral power: CIE 15:2004, Table T.1 (ISO 11664-2).
//!
//! The tristimulus values of a surface of reflectance `R(λ)` lit by D65 are the sums
//! `X = k Σ R(λ) S(λ) x(λ)` (likewise Y, Z) with `k` making `Y = 1` for `R = 1` (CIE 15,
//! section 7.1, summation at a 10 nm interval). Linear sRGB follows by the IEC 61966-2-1 matrix
//! (the `palette` crate's XYZ -> linear sRGB conversion, applied to each band's XYZ weights).
//! Each row of the resulting 3 x 36 map is scaled so that `R = 1` gives exactly (1, 1, 1): the
//! 10 nm sums put the white 0.1 % off the sRGB D65 white, and a perfect white must stay white.

use std::sync::OnceLock;

use palette::convert::FromColorUnclamped;
use palette::white_point::D65;
use palette::{LinSrgb, Xyz};

/// Number of wavelength bands.
pub(crate) const BANDS: usize = 36;

/// A spectrum sampled at [`wavelength_nm`]`(0..BANDS)`.
pub(crate) type Spectrum = [f64; BANDS];

/// Wavelength of band `i`, nm.
pub(crate) fn wavelength_nm(i: usize) -> f64 {
    380.0 + 10.0 * i as f64
}

/// (wavelength nm, [x, y, z] of the CIE 1931 2-degree observer, D65 relative power).
const CIE_TABLE: [(u32, [f64; 3], f64); BANDS] = [
    (380, [0.001368, 0.000039, 0.00645], 49.9755),
    (390, [0.004243, 0.00012, 0.02005], 54.6482),
    (400, [0.01431, 0.000396, 0.06785], 82.7549),
    (410, [0.04351, 0.00121, 0.2074], 91.486),
    (420, [0.13438, 0.004, 0.6456], 93.4318),
    (430, [0.2839, 0.0116, 1.3856], 86.6823),
    (440, [0.34828, 0.023, 1.74706], 104.865),
    (450, [0.3362, 0.038, 1.77211], 117.008),
    (460, [0.2908, 0.06, 1.6692], 117.812),
    (470, [0.19536, 0.09098, 1.28764], 114.861),
    (480, [0.09564, 0.13902, 0.81295], 115.923),
    (490, [0.03201, 0.20802, 0.46518], 108.811),
    (500, [0.0049, 0.323, 0.272], 109.354),
    (510, [0.0093, 0.503, 0.1582], 107.802),
    (520, [0.06327, 0.71, 0.07825], 104.79),
    (530, [0.1655, 0.862, 0.04216], 107.689),
    (540, [0.2904, 0.954, 0.0203], 104.405),
    (550, [0.43345, 0.99495, 0.00875], 104.046),
    (560, [0.5945, 0.995, 0.0039], 100.0),
    (570, [0.7621, 0.952, 0.0021], 96.3342),
    (580, [0.9163, 0.87, 0.00165], 95.788),
    (590, [1.0263, 0.757, 0.0011], 88.6856),
    (600, [1.0622, 0.631, 0.0008], 90.0062),
    (610, [1.0026, 0.503, 0.00034], 89.5991),
    (620, [0.85445, 0.381, 0.00019], 87.6987),
    (630, [0.6424, 0.265, 0.00005], 83.2886),
    (640, [0.4479, 0.175, 0.00002], 83.6992),
    (650, [0.2835, 0.107, 0.0], 80.0268),
    (660, [0.1649, 0.061, 0.0], 80.2146),
    (670, [0.0874, 0.032, 0.0], 82.2778),
    (680, [0.04677, 0.017, 0.0], 78.2842),
    (690, [0.0227, 0.00821, 0.0], 69.7213),
    (700, [0.0113592, 0.004102, 0.0], 71.6091),
    (710, [0.00579035, 0.002091, 0.0], 74.349),
    (720, [0.00289933, 0.001047, 0.0], 61.604),
    (730, [0.00143997, 0.00052, 0.0], 69.8856),
];

/// Row r of the map from reflectance to linear sRGB: `rgb[r] = Σ RGB[r][i] R(i)`.
pub(crate) fn to_linear_rgb_map() -> &'static [Spectrum; 3] {
    static MAP: OnceLock<[Spectrum; 3]> = OnceLock::new();
    MAP.get_or_init(|| {
        let y_white: f64 = CIE_TABLE.iter().map(|(_, cmf, d65)| cmf[1] * d65).sum();
        let mut map = [[0.0; BANDS]; 3];
        for (i, (_, cmf, d65)) in CIE_TABLE.iter().enumerate() {
            // The map is linear in R, so band i's column is the linear sRGB of its XYZ weights.
            let [x, y, z] = cmf.map(|c| c * d65 / y_white);
            let rgb = LinSrgb::<f64>::from_color_unclamped(Xyz::<D65, f64>::new(x, y, z));
            for (row, v) in map.iter_mut().zip([rgb.red, rgb.green, rgb.blue]) {
                row[i] = v;
            }
        }
        for row in &mut map {
            let white: f64 = row.iter().sum();
            row.iter_mut().for_each(|v| *v /= white);
        }
        map
    })
}

/// The linear sRGB colour of a surface with reflectance `r` under D65.
pub(crate) fn linear_rgb(r: &Spectrum) -> LinSrgb<f64> {
    let [red, green, blue] =
        to_linear_rgb_map().each_ref().map(|row| row.iter().zip(r).map(|(m, x)| m * x).sum());
    LinSrgb::new(red, green, blue)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tables_are_on_the_grid_and_peak_where_published() {
        for (i, (nm, _, _)) in CIE_TABLE.iter().enumerate() {
            assert_eq!(f64::from(*nm), wavelength_nm(i));
        }
        // y(λ) peaks at 555 nm: 0.995 at 550 and 560; D65 is 100 at 560 nm by definition.
        assert_eq!(CIE_TABLE[18], (560, [0.5945, 0.995, 0.0039], 100.0));
        // Equal-energy sums of the observer: x and z within 1 % of y (CIE 15 normalisation).
        let sums = [0, 1, 2].map(|k| CIE_TABLE.iter().map(|(_, c, _)| c[k]).sum::<f64>());
        assert!((sums[0] / sums[1] - 1.0).abs() < 0.01 && (sums[2] / sums[1] - 1.0).abs() < 0.01, "{sums:?}");
    }

    #[test]
    fn white_is_white_and_grey_is_grey() {
        let white = linear_rgb(&[1.0; BANDS]);
        for c in [white.red, white.green, white.blue] {
            assert!((c - 1.0).abs() < 1e-12, "{white:?}");
        }
        let grey = linear_rgb(&[0.2; BANDS]);
        assert!((grey.red - 0.2).abs() < 1e-12 && (grey.blue - 0.2).abs() < 1e-12);
        // A reflectance only in the long wavelengths is red; only in the short ones, blue.
        let red = linear_rgb(&std::array::from_fn(|i| if wavelength_nm(i) >= 600.0 { 1.0 } else { 0.0 }));
        assert!(red.red > 0.5 && red.green < 0.15 && red.blue < 0.05, "{red:?}");
        let blue = linear_rgb(&std::array::from_fn(|i| if wavelength_nm(i) <= 480.0 { 1.0 } else { 0.0 }));
        assert!(blue.blue > 0.7 && blue.red < 0.1, "{blue:?}");
    }
}
