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
#[inline]
pub(crate) fn trunc(x: f64) -> f64 {
    if x.abs() < 4_503_599_627_370_496.0 {
        x as i64 as f64
    } else {
        x
    }
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

    proptest! {
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
