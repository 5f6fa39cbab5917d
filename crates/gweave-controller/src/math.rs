//! The little arithmetic `core` lacks without a math library: square root and rounding.
//!
//! `f32::sqrt` and `f32::round` live in `std` (they call the platform's libm); a `no_std` crate
//! writes its own. Both are exact enough for motion planning (a few units in the last place).

/// Square root of `x`, 0 for `x <= 0` (and for NaN).
///
/// Computed as `x / sqrt(x)` from the inverse square root, whose Newton iteration
/// `y <- y (3 - x y²) / 2` has no division: on an 8-bit AVR a float division costs several times
/// a multiplication, and the segment maker takes a square root for every few milliseconds of
/// motion. The start is the float's bit pattern shifted, which halves and negates its exponent
/// (the IEEE-754 layout stores about `log2(x)` in the top bits; the constant is Lomont's, 2003),
/// within 3.5 % of the answer; each iteration squares the error.
pub fn sqrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return x;
    }
    let mut y = f32::from_bits(0x5F37_5A86 - (x.to_bits() >> 1));
    for _ in 0..2 {
        y *= 1.5 - 0.5 * x * y * y;
    }
    // `r = x y` is within a few millionths; one step of Newton's iteration for `r² = x`, with
    // `1 / (2r)` taken as `y / 2`, corrects it to the last bit (exact for perfect squares).
    let r = x * y;
    r + 0.5 * y * (x - r * r)
}

/// `x` rounded to the nearest integer, halves away from zero (C's `lround`, as Marlin turns
/// millimetres into steps), saturated to the `i32` range.
pub fn round_i32(x: f32) -> i32 {
    if x >= 0.0 {
        (x + 0.5) as i32
    } else {
        (x - 0.5) as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sqrt_is_exact_to_a_few_ulps() {
        for &x in &[1e-6f32, 0.01, 0.5, 1.0, 2.0, 3.0, 9.0, 100.0, 1234.5, 1e6, 3.3e9] {
            let want = (x as f64).sqrt() as f32;
            let got = sqrt(x);
            assert!(((got - want) / want).abs() < 2e-7, "sqrt({x}) = {got}, want {want}");
        }
        for n in 1..=3000 {
            let n = n as f32;
            assert_eq!(sqrt(n * n), n, "perfect squares are exact");
        }
        assert_eq!(sqrt(0.0), 0.0);
        assert_eq!(sqrt(-4.0), 0.0);
        assert_eq!(sqrt(f32::NAN), 0.0);
    }

    #[test]
    fn rounding_halves_away_from_zero() {
        assert_eq!(round_i32(2.5), 3);
        assert_eq!(round_i32(-2.5), -3);
        assert_eq!(round_i32(0.49), 0);
        assert_eq!(round_i32(799.9999), 800);
        assert_eq!(round_i32(1e12), i32::MAX);
    }
}
