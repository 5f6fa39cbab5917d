//! Rounding to the integers a machine counts in (motor steps, ADC counts).

/// `x.round() as i64` (half away from zero, saturating, NaN to 0) without a call: on the
/// baseline x86-64 target `f64::round` is a library routine, and the simulator rounds on every
/// axis of every move (motor steps) and at every heater sample (ADC counts). Truncation is one
/// instruction, and the part it cut off (exact for any float) says whether to go one further.
#[inline]
pub(crate) fn round_i64(x: f64) -> i64 {
    // From 2^52 on every float is a whole number (and NaN goes to 0 either way).
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        return x as i64;
    }
    let whole = x as i64;
    let cut = x - whole as f64;
    if cut >= 0.5 {
        whole + 1
    } else if cut <= -0.5 {
        whole - 1
    } else {
        whole
    }
}

/// `x.trunc()` without a call (see [`round_i64`]); every float from 2^52 on is whole already.
/// Below 2^52 the conversion to `i64` cannot overflow, so it is the one `cvttsd2si` without
/// the compares and moves of Rust's saturating `as` (seven instructions for one; the Marlin
/// planner rounds some ten rates and step counts a block).
#[inline]
pub(crate) fn trunc(x: f64) -> f64 {
    if x.abs() < 4_503_599_627_370_496.0 {
        // SAFETY: `x` is finite (NaN fails the test) and |x| < 2^52 < 2^63, so its truncation
        // is an `i64`.
        unsafe { x.to_int_unchecked::<i64>() as f64 }
    } else {
        x
    }
}

/// `round_i64(f64::from(x)) as f64` for a single-precision `x` (Marlin's step positions), in
/// three instructions and no branch: add a half with `x`'s sign and truncate. For a float of
/// magnitude 2^-29 or more the sum is exact in double precision (the float's 24 significant
/// bits and the half together span at most 53 bits), so truncating it rounds half away from
/// zero; below 2^-29 the sum is under 1 and truncates to 0, the rounding of so small a number.
/// NaN goes to 0 and the largest floats saturate, as in [`round_i64`]; the tests compare the
/// two on random bit patterns and at the halves.
#[inline(always)]
pub(crate) fn round_f32(x: f32) -> f64 {
    let x = f64::from(x);
    (x + 0.5f64.copysign(x)) as i64 as f64
}

/// `x.ceil()` without a call (a negative fraction rounds to +0, not -0).
#[inline]
pub(crate) fn ceil(x: f64) -> f64 {
    let t = trunc(x);
    if t < x {
        t + 1.0
    } else {
        t
    }
}

/// `x.floor()` without a call (a positive fraction rounds to +0).
#[inline]
pub(crate) fn floor(x: f64) -> f64 {
    let t = trunc(x);
    if t > x {
        t - 1.0
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn rounding_matches_the_library_at_the_edges() {
        let edges = [0.5, 1.5, 2.5, 0.49999999999999994, 4_503_599_627_370_495.5, 4_503_599_627_370_496.0];
        for x in edges.into_iter().flat_map(|x| [x, -x]).chain([f64::NAN, f64::INFINITY, -1e300, 9.3e18]) {
            assert_eq!(round_i64(x), x.round() as i64, "{x}");
        }
    }

    #[test]
    fn single_precision_rounding_matches_at_the_edges() {
        let halves = [0.5f32, 1.5, 2.5, 8_388_607.5, 0.499_999_97, 0.500_000_06, 1e-30, 16_777_215.0, 1e30];
        for x in
            halves.into_iter().flat_map(|x| [x, -x]).chain([0.0, -0.0, f32::NAN, f32::INFINITY, f32::MAX])
        {
            assert_eq!(round_f32(x), round_i64(f64::from(x)) as f64, "{x}");
        }
    }

    proptest! {
        /// Every single-precision value, by its bits: the same rounding as [`round_i64`].
        #[test]
        fn single_precision_rounding_matches(bits in any::<u32>()) {
            let x = f32::from_bits(bits);
            prop_assert_eq!(round_f32(x).to_bits(), (round_i64(f64::from(x)) as f64).to_bits(), "{}", x);
        }

        #[test]
        fn rounding_matches_the_library(x in proptest::num::f64::ANY) {
            prop_assert_eq!(round_i64(x), x.round() as i64);
            // Equal as numbers (-0 == +0), and NaN stays NaN.
            for (fast, lib) in [(trunc(x), x.trunc()), (ceil(x), x.ceil()), (floor(x), x.floor())] {
                prop_assert!(fast == lib || (fast.is_nan() && lib.is_nan()), "{x}: {fast} {lib}");
            }
        }
    }
}
