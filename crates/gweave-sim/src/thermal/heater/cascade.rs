//! The exact step of the heater's three first-order stages in series (heat flow behind the
//! power, block, sensor behind the block) for power held over the step.
//!
//! Each stage `y' = r (x - y)` relaxes toward its input at rate `r`. Measured from where the
//! whole chain settles for the held power, the first stage decays alone, `e(t) = e0 g(a)`
//! with `g(x) = exp(-x t)`; a stage fed by a decaying input picks up a convolution, and
//! `integral_0^t exp(-q (t - s)) exp(-p s) ds = -g[p, q]`, the first divided difference of
//! `g`; a third stage picks up `g[p, q, r]`, the second one. So the chain is solved exactly
//! by divided differences of one exponential, whatever the step: splitting a step in two
//! gives the same temperatures, which lets the firmware loop integrate the plant once per
//! sample instead of once per move.
//!
//! Equal or close rates (a sensor lag equal to the heater lag, say) make the textbook formulas
//! `0 / 0`; the divided differences below stay accurate there (`expm1` for close pairs, the
//! Taylor limit `t^2/2 g(mean)` for three rates within a hair of each other).

/// A stage's rate (1/s) with its decay over the step, `exp(-rate t)`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Decay {
    pub rate: f64,
    pub factor: f64,
}

impl Decay {
    pub(super) fn new(rate: f64, t_s: f64) -> Self {
        Self { rate, factor: (-rate * t_s).exp() }
    }
}

/// `g[p, q] = (g(p) - g(q)) / (p - q)` for `g(x) = exp(-x t)`; `-t g(p)` when `p = q`.
pub(super) fn divided2(p: Decay, q: Decay, t_s: f64) -> f64 {
    let d = (q.rate - p.rate) * t_s;
    if d.abs() > 0.5 {
        (p.factor - q.factor) / (p.rate - q.rate)
    } else if d == 0.0 {
        -t_s * p.factor
    } else {
        // g(q) = g(p) exp(-d), so the difference is g(p) (1 - exp(-d)); expm1 keeps its digits.
        t_s * p.factor * (-d).exp_m1() / d
    }
}

/// `g[p, q, r]`, symmetric in its rates; `t^2/2 g(p)` when all three are equal.
pub(super) fn divided3(p: Decay, q: Decay, r: Decay, t_s: f64) -> f64 {
    let mut s = [p, q, r];
    s.sort_by(|x, y| x.rate.total_cmp(&y.rate));
    let [lo, mid, hi] = s;
    let spread = hi.rate - lo.rate;
    if spread * t_s < 1e-4 {
        // g'' / 2 at the mean; the error is of the order of (spread t)^2, below 1e-8 here.
        let mean = (lo.rate + mid.rate + hi.rate) / 3.0;
        0.5 * t_s * t_s * (-mean * t_s).exp()
    } else {
        (divided2(mid, hi, t_s) - divided2(lo, mid, t_s)) / spread
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dd2(p: f64, q: f64, t: f64) -> f64 {
        divided2(Decay::new(p, t), Decay::new(q, t), t)
    }

    fn dd3(p: f64, q: f64, r: f64, t: f64) -> f64 {
        divided3(Decay::new(p, t), Decay::new(q, t), Decay::new(r, t), t)
    }

    /// The convolution integral by Simpson's rule on a fine grid.
    fn convolution(p: f64, q: f64, t: f64) -> f64 {
        let n = 20_000;
        let h = t / n as f64;
        let f = |s: f64| (-q * (t - s)).exp() * (-p * s).exp();
        let inner: f64 = (1..n).map(|i| f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 }).sum();
        (f(0.0) + inner + f(t)) * h / 3.0
    }

    #[test]
    fn first_difference_is_the_convolution() {
        for (p, q, t) in [(0.5, 1.0 / 120.0, 0.1), (0.5, 0.5, 3.0), (0.5, 0.5 + 1e-9, 3.0), (2.0, 0.1, 7.0)] {
            let want = convolution(p, q, t);
            assert!((-dd2(p, q, t) - want).abs() < 1e-10 * want.max(1.0), "{p} {q} {t}");
        }
    }

    #[test]
    fn second_difference_is_continuous_through_equal_rates() {
        let t = 2.5;
        let exact = |a: f64, b: f64, c: f64| {
            let g = |x: f64| (-x * t).exp();
            g(a) / ((a - b) * (a - c)) + g(b) / ((b - a) * (b - c)) + g(c) / ((c - a) * (c - b))
        };
        // Well separated: the partial-fraction form.
        let want = exact(0.5, 1.0 / 120.0, 1.0 / 3.0);
        assert!((dd3(0.5, 1.0 / 120.0, 1.0 / 3.0, t) - want).abs() < 1e-12);
        // Two equal, then all three equal: the limits t g(a) terms and t^2/2 g(a).
        let a = 0.4;
        let limit3 = 0.5 * t * t * (-a * t).exp();
        assert!((dd3(a, a, a, t) - limit3).abs() < 1e-15);
        assert!((dd3(a, a + 1e-7, a - 1e-7, t) - limit3).abs() < 1e-9);
        let near = dd3(a, a, 0.1, t);
        assert!((near - dd3(a, a + 1e-6, 0.1, t)).abs() < 2e-6, "{near}");
        assert!((near - exact(a + 1e-4, a - 1e-4, 0.1)).abs() < 1e-7);
    }
}
