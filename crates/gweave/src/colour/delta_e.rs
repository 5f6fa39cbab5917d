//! CIEDE2000 colour difference.
//!
//! Follows the formulation and the implementation notes of G. Sharma, W. Wu and
//! E. N. Dalal, "The CIEDE2000 color-difference formula: implementation notes,
//! supplementary test data, and mathematical observations", Color Research &
//! Application 30(1), 2005. Parametric factors kL = kC = kH = 1 (reference
//! conditions). A difference of about 1 is just noticeable side by side; 2-3 is
//! visible at a glance.
//!
//! Outline (primes denote the a*-rescaled quantities):
//! 1. Rescale a* by `1 + G`, with `G = 0.5 (1 - sqrt(Cbar^7 / (Cbar^7 + 25^7)))`,
//!    which stretches near-neutral colours where the eye is more hue-sensitive.
//! 2. Differences in lightness, chroma and hue (`dH = 2 sqrt(C1 C2) sin(dh/2)`).
//! 3. Weight them by `S_L`, `S_C`, `S_H` (which grow away from mid-grey and with
//!    chroma) and add the rotation term `R_T` that corrects the blue region.

use super::lab::Lab;

const POW25_7: f64 = 6_103_515_625.0; // 25^7

/// Hue angle in degrees `[0, 360)`; 0 for a neutral colour, as the paper specifies.
fn hue_deg(b: f64, a_prime: f64) -> f64 {
    if b == 0.0 && a_prime == 0.0 {
        0.0
    } else {
        b.atan2(a_prime).to_degrees().rem_euclid(360.0)
    }
}

/// `sqrt(c^7 / (c^7 + 25^7))`, the chroma weight shared by `G` and `R_C`.
fn chroma_weight(c: f64) -> f64 {
    let c7 = c.powi(7);
    (c7 / (c7 + POW25_7)).sqrt()
}

/// CIEDE2000 difference between two CIELAB colours (symmetric, >= 0).
pub fn ciede2000(lab1: Lab, lab2: Lab) -> f64 {
    let c_bar = 0.5 * (lab1.chroma() + lab2.chroma());
    let g = 0.5 * (1.0 - chroma_weight(c_bar));
    let a1 = (1.0 + g) * lab1.a;
    let a2 = (1.0 + g) * lab2.a;
    let c1 = a1.hypot(lab1.b);
    let c2 = a2.hypot(lab2.b);
    let h1 = hue_deg(lab1.b, a1);
    let h2 = hue_deg(lab2.b, a2);

    let dl = lab2.l - lab1.l;
    let dc = c2 - c1;
    let neutral = c1 * c2 == 0.0;
    let dh_deg = if neutral {
        0.0
    } else {
        let d = h2 - h1;
        if d > 180.0 {
            d - 360.0
        } else if d < -180.0 {
            d + 360.0
        } else {
            d
        }
    };
    let d_big_h = 2.0 * (c1 * c2).sqrt() * (dh_deg.to_radians() / 2.0).sin();

    let l_bar = 0.5 * (lab1.l + lab2.l);
    let c_bar_p = 0.5 * (c1 + c2);
    let h_bar = if neutral {
        h1 + h2
    } else if (h1 - h2).abs() <= 180.0 {
        0.5 * (h1 + h2)
    } else if h1 + h2 < 360.0 {
        0.5 * (h1 + h2 + 360.0)
    } else {
        0.5 * (h1 + h2 - 360.0)
    };

    let cos_deg = |d: f64| d.to_radians().cos();
    let t =
        1.0 - 0.17 * cos_deg(h_bar - 30.0) + 0.24 * cos_deg(2.0 * h_bar) + 0.32 * cos_deg(3.0 * h_bar + 6.0)
            - 0.20 * cos_deg(4.0 * h_bar - 63.0);
    let d_theta = 30.0 * (-((h_bar - 275.0) / 25.0).powi(2)).exp();
    let r_c = 2.0 * chroma_weight(c_bar_p);
    let l50 = (l_bar - 50.0).powi(2);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * c_bar_p;
    let s_h = 1.0 + 0.015 * c_bar_p * t;
    let r_t = -(2.0 * d_theta).to_radians().sin() * r_c;

    let tl = dl / s_l;
    let tc = dc / s_c;
    let th = d_big_h / s_h;
    (tl * tl + tc * tc + th * th + r_t * tc * th).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sharma, Wu & Dalal (2005), table 1: all 34 pairs, `(L1 a1 b1, L2 a2 b2, dE00)`.
    const SHARMA: [[f64; 7]; 34] = [
        [50.0, 2.6772, -79.7751, 50.0, 0.0, -82.7485, 2.0425],
        [50.0, 3.1571, -77.2803, 50.0, 0.0, -82.7485, 2.8615],
        [50.0, 2.8361, -74.0200, 50.0, 0.0, -82.7485, 3.4412],
        [50.0, -1.3802, -84.2814, 50.0, 0.0, -82.7485, 1.0000],
        [50.0, -1.1848, -84.8006, 50.0, 0.0, -82.7485, 1.0000],
        [50.0, -0.9009, -85.5211, 50.0, 0.0, -82.7485, 1.0000],
        [50.0, 0.0, 0.0, 50.0, -1.0, 2.0, 2.3669],
        [50.0, -1.0, 2.0, 50.0, 0.0, 0.0, 2.3669],
        [50.0, 2.49, -0.001, 50.0, -2.49, 0.0009, 7.1792],
        [50.0, 2.49, -0.001, 50.0, -2.49, 0.0010, 7.1792],
        [50.0, 2.49, -0.001, 50.0, -2.49, 0.0011, 7.2195],
        [50.0, 2.49, -0.001, 50.0, -2.49, 0.0012, 7.2195],
        [50.0, -0.001, 2.49, 50.0, 0.0009, -2.49, 4.8045],
        [50.0, -0.001, 2.49, 50.0, 0.0010, -2.49, 4.8045],
        [50.0, -0.001, 2.49, 50.0, 0.0011, -2.49, 4.7461],
        [50.0, 2.5, 0.0, 50.0, 0.0, -2.5, 4.3065],
        [50.0, 2.5, 0.0, 73.0, 25.0, -18.0, 27.1492],
        [50.0, 2.5, 0.0, 61.0, -5.0, 29.0, 22.8977],
        [50.0, 2.5, 0.0, 56.0, -27.0, -3.0, 31.9030],
        [50.0, 2.5, 0.0, 58.0, 24.0, 15.0, 19.4535],
        [50.0, 2.5, 0.0, 50.0, 3.1736, 0.5854, 1.0000],
        [50.0, 2.5, 0.0, 50.0, 3.2972, 0.0, 1.0000],
        [50.0, 2.5, 0.0, 50.0, 1.8634, 0.5757, 1.0000],
        [50.0, 2.5, 0.0, 50.0, 3.2592, 0.3350, 1.0000],
        [60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644],
        [63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630],
        [61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731],
        [35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645],
        [22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373],
        [36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146],
        [90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441],
        [90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381],
        [6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377],
        [2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082],
    ];

    fn lab(l: f64, a: f64, b: f64) -> Lab {
        Lab { l, a, b }
    }

    #[test]
    fn matches_sharma_wu_dalal_table() {
        for (i, p) in SHARMA.iter().enumerate() {
            let x = lab(p[0], p[1], p[2]);
            let y = lab(p[3], p[4], p[5]);
            let de = ciede2000(x, y);
            // The table is printed to 4 decimals: agree to within half a unit.
            assert!((de - p[6]).abs() < 5e-5, "pair {}: {de} != {}", i + 1, p[6]);
            assert!((ciede2000(y, x) - de).abs() < 1e-12, "pair {} asymmetric", i + 1);
        }
    }

    #[test]
    fn identical_colours_have_zero_difference() {
        let c = lab(42.0, -13.0, 27.5);
        assert_eq!(ciede2000(c, c), 0.0);
        assert_eq!(ciede2000(lab(0.0, 0.0, 0.0), lab(0.0, 0.0, 0.0)), 0.0);
    }
}
