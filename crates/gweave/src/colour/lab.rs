//! CIE XYZ (D65) and CIELAB.
//!
//! Linear sRGB -> XYZ uses the sRGB primaries and D65 white of IEC 61966-2-1
//! (the matrix below, rows X, Y, Z; Y = 1 for white). XYZ -> L*a*b* is CIE 1976
//! with the exact constants `epsilon = 216/24389` and `kappa = 24389/27` (CIE 15:2004,
//! as tabulated by B. Lindbloom), relative to the D65 white point.

use super::srgb::{LinearRgb, Srgb8};

/// CIE 1931 tristimulus values, white `Y = 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xyz {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// CIELAB: `l` in 0..100, `a` green(-)/red(+), `b` blue(-)/yellow(+).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lab {
    /// Lightness L*, 0 (black) to 100 (white).
    pub l: f64,
    /// Green (negative) to red (positive) axis a*.
    pub a: f64,
    /// Blue (negative) to yellow (positive) axis b*.
    pub b: f64,
}

/// D65 reference white, the XYZ of linear sRGB (1, 1, 1).
pub const D65_WHITE: Xyz = Xyz { x: 0.950_47, y: 1.0, z: 1.088_83 };

const RGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.412_456_4, 0.357_576_1, 0.180_437_5],
    [0.212_672_9, 0.715_152_2, 0.072_175_0],
    [0.019_333_9, 0.119_192_0, 0.950_304_1],
];

pub(crate) const XYZ_TO_RGB: [[f64; 3]; 3] = [
    [3.240_454_2, -1.537_138_5, -0.498_531_4],
    [-0.969_266_0, 1.876_010_8, 0.041_556_0],
    [0.055_643_4, -0.204_025_9, 1.057_225_2],
];

const EPSILON: f64 = 216.0 / 24389.0;
const KAPPA: f64 = 24389.0 / 27.0;

fn mat_mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

impl Xyz {
    pub fn from_linear(c: LinearRgb) -> Self {
        let [x, y, z] = mat_mul(&RGB_TO_XYZ, [c.r, c.g, c.b]);
        Self { x, y, z }
    }

    /// Linear sRGB; may leave `[0, 1]` for colours outside the sRGB gamut.
    pub fn to_linear(self) -> LinearRgb {
        let [r, g, b] = mat_mul(&XYZ_TO_RGB, [self.x, self.y, self.z]);
        LinearRgb { r, g, b }
    }
}

impl Lab {
    /// The CIELAB colour of CIE XYZ `c` under the D65 white point.
    pub fn from_xyz(c: Xyz) -> Self {
        // f(t) is the cube root above epsilon and a straight line below it,
        // so that dark colours stay finite and continuous.
        let f = |t: f64| {
            if t > EPSILON {
                t.cbrt()
            } else {
                (KAPPA * t + 16.0) / 116.0
            }
        };
        let fx = f(c.x / D65_WHITE.x);
        let fy = f(c.y / D65_WHITE.y);
        let fz = f(c.z / D65_WHITE.z);
        Self { l: 116.0 * fy - 16.0, a: 500.0 * (fx - fy), b: 200.0 * (fy - fz) }
    }

    /// The CIE XYZ colour (D65) of this CIELAB colour.
    pub fn to_xyz(self) -> Xyz {
        let fy = (self.l + 16.0) / 116.0;
        let fx = fy + self.a / 500.0;
        let fz = fy - self.b / 200.0;
        let inv = |f: f64| {
            let f3 = f * f * f;
            if f3 > EPSILON {
                f3
            } else {
                (116.0 * f - 16.0) / KAPPA
            }
        };
        let y = if self.l > KAPPA * EPSILON { fy * fy * fy } else { self.l / KAPPA };
        Xyz { x: inv(fx) * D65_WHITE.x, y: y * D65_WHITE.y, z: inv(fz) * D65_WHITE.z }
    }

    /// The CIELAB colour of an 8-bit sRGB colour.
    pub fn from_srgb8(c: Srgb8) -> Self {
        Self::from_xyz(Xyz::from_linear(c.to_linear()))
    }

    /// Nearest 8-bit sRGB colour (clamped when outside the sRGB gamut).
    pub fn to_srgb8(self) -> Srgb8 {
        Srgb8::from_linear(self.to_xyz().to_linear())
    }

    /// Chroma `C*ab = sqrt(a^2 + b^2)`.
    pub fn chroma(self) -> f64 {
        self.a.hypot(self.b)
    }

    /// Hue angle `h_ab` in degrees, `[0, 360)`.
    pub fn hue_deg(self) -> f64 {
        self.b.atan2(self.a).to_degrees().rem_euclid(360.0)
    }

    /// Straight line in Lab: `t = 0` gives `self`, `t = 1` gives `other`.
    pub fn lerp(self, other: Lab, t: f64) -> Lab {
        Lab {
            l: self.l + (other.l - self.l) * t,
            a: self.a + (other.a - self.a) * t,
            b: self.b + (other.b - self.b) * t,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(lab: Lab, l: f64, a: f64, b: f64, tol: f64) {
        assert!(
            (lab.l - l).abs() < tol && (lab.a - a).abs() < tol && (lab.b - b).abs() < tol,
            "{lab:?} != ({l}, {a}, {b})"
        );
    }

    #[test]
    fn known_lab_values() {
        // Reference values: B. Lindbloom's calculator, sRGB, D65, no adaptation.
        close(Lab::from_srgb8(Srgb8::new(255, 255, 255)), 100.0, 0.0, 0.0, 0.01);
        close(Lab::from_srgb8(Srgb8::new(0, 0, 0)), 0.0, 0.0, 0.0, 1e-9);
        close(Lab::from_srgb8(Srgb8::new(255, 0, 0)), 53.2408, 80.0925, 67.2032, 0.01);
        close(Lab::from_srgb8(Srgb8::new(0, 255, 0)), 87.7347, -86.1827, 83.1793, 0.01);
        close(Lab::from_srgb8(Srgb8::new(0, 0, 255)), 32.2970, 79.1875, -107.8602, 0.01);
        close(Lab::from_srgb8(Srgb8::new(128, 128, 128)), 53.5850, 0.0, 0.0, 0.01);
    }

    #[test]
    fn srgb_lab_round_trip_is_exact_on_bytes() {
        for r in (0..=255u8).step_by(15) {
            for g in (0..=255u8).step_by(17) {
                for b in (0..=255u8).step_by(5) {
                    let c = Srgb8::new(r, g, b);
                    assert_eq!(Lab::from_srgb8(c).to_srgb8(), c);
                }
            }
        }
    }

    #[test]
    fn hue_and_chroma() {
        let lab = Lab { l: 50.0, a: 0.0, b: -20.0 };
        assert_eq!(lab.hue_deg(), 270.0);
        assert_eq!(lab.chroma(), 20.0);
        let mid = lab.lerp(Lab { l: 70.0, a: 10.0, b: 0.0 }, 0.25);
        close(mid, 55.0, 2.5, -15.0, 1e-12);
    }
}
