//! The little arithmetic `core` lacks without a math library: square root and rounding.
//!
//! `f32::sqrt` and `f32::round` live in `std` (they call the platform's libm); a `no_std` crate
//! writes its own. Both are exact enough for motion planning (a few units in the last place).

/// Square root of `x`, 0 for `x <= 0` (and for NaN).
///
/// Newton's iteration `r <- (r + x/r) / 2` doubles the correct bits at each step; the start is
/// halving the float's exponent through its bit pattern (the IEEE-754 layout stores
/// `log2(x)` roughly in the top bits), which is within 4 % of the answer, so three iterations
/// reach full `f32` precision.
pub fn sqrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return x;
    }
    let mut r = f32::from_bits((x.to_bits() >> 1) + 0x1FBD_1DF5);
    for _ in 0..3 {
        r = 0.5 * (r + x / r);
    }
    r
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
        for &x in &[1e-6f32, 0.01, 0.5, 1.0, 2.0, 3.0, 9.0, 1234.5, 1e6, 3.3e9] {
            let want = (x as f64).sqrt() as f32;
            let got = sqrt(x);
            assert!(((got - want) / want).abs() < 2e-7, "sqrt({x}) = {got}, want {want}");
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
