//! What a heater remembers of its steps that is not its state: the step response worked out for
//! the last step's length, and the step lengths under which the plant, heater off, is known to
//! stay where it is.
//!
//! **The response.** The firmware loop steps every heater by one sample period, so the response
//! is worked out once and reused until the period or the fan changes. The clock's sample
//! instants are multiples of the period in floating point, so the periods between them differ in
//! their last bits (more so as the clock grows: parts in 1e11 after two days); a step within
//! 1e-9 of the kept one reuses it, an error of that fraction of one step's change of
//! temperature. Which response is kept therefore changes what later steps give, in their last
//! bits, and the rule that moves it ([`Memo::keep`]) is followed even by steps that need no
//! response: a step at rest moves the key only, and the response is worked out when a step uses
//! it.
//!
//! **Stillness.** A plant off for long enough stops moving, to the bit: at ambient, every term
//! of the step is a zero; just above it, a difference of n units in the last place shrinks by
//! less than half a unit a step and rounds back to n (the default hotend's block loses 8.3e-4 of
//! its distance to ambient a 0.1 s step, so it stays up to 600 units, 2e-12 K, above 25 C), and
//! the heat flow stops at the smallest subnormal number. A step that left the plant as it found it
//! records its key here; a step under another key is tried on a copy (`Heater::rest`),
//! and the keys alternate among a few values, so a long rest tries each once. Any step that
//! moves the plant forgets them.

use super::{HeaterConfig, Response};

/// Which step response a step uses: the length it was worked out for, s, and the loss
/// conductance, W/K (the fan's share included).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct StepKey {
    pub(super) t_s: f64,
    pub(super) k_w_k: f64,
}

/// Keys under which the plant is known still, kept at most: the periods between sample instants
/// take two or three values at any clock, so a few cover a whole rest.
const STILL_KEYS: usize = 4;

/// See the module's notes. Not part of the plant's state: two heaters in the same state compare
/// equal whatever they remember.
#[derive(Debug, Clone, Copy)]
pub(super) struct Memo {
    /// The step kept for reuse (before the first step, one no step matches: NaN)...
    key: StepKey,
    /// ...and its response, worked out when a step needs it (`fresh`: a step at rest moves the
    /// key and needs none).
    response: Option<Response>,
    fresh: bool,
    /// The first `still_len` are keys under which a step with the heater off was found to leave
    /// the plant as it is, since it last moved; once all are taken, `next_still` says which
    /// one a new key replaces.
    still: [StepKey; STILL_KEYS],
    still_len: usize,
    next_still: usize,
}

impl Default for Memo {
    fn default() -> Self {
        let none = StepKey { t_s: f64::NAN, k_w_k: f64::NAN };
        Memo {
            key: none,
            response: None,
            fresh: false,
            still: [none; STILL_KEYS],
            still_len: 0,
            next_still: 0,
        }
    }
}

impl PartialEq for Memo {
    fn eq(&self, _other: &Self) -> bool {
        true
    }
}

impl Memo {
    /// Whether a step of `t_s` at loss `k_w_k` reuses the kept response: within 1e-9 of its
    /// length, at the same loss.
    fn reuses(&self, t_s: f64, k_w_k: f64) -> bool {
        (self.key.t_s - t_s).abs() <= 1e-9 * t_s && self.key.k_w_k == k_w_k
    }

    /// The key a step of `t_s` at loss `k_w_k` uses: the kept one if it reuses it, otherwise its
    /// own.
    pub(super) fn key_for(&self, t_s: f64, k_w_k: f64) -> StepKey {
        if self.reuses(t_s, k_w_k) {
            self.key
        } else {
            StepKey { t_s, k_w_k }
        }
    }

    /// Keeps the key of a step of `t_s` at loss `k_w_k` ([`Memo::key_for`]); a new one's response
    /// is to be worked out.
    pub(super) fn keep(&mut self, t_s: f64, k_w_k: f64) -> StepKey {
        if !self.reuses(t_s, k_w_k) {
            self.key = StepKey { t_s, k_w_k };
            self.fresh = false;
        }
        self.key
    }

    /// The response of a step of `t_s` at loss `k_w_k`, its key kept ([`Memo::keep`]); worked
    /// out if it is not yet.
    pub(super) fn response(&mut self, cfg: &HeaterConfig, t_s: f64, k_w_k: f64) -> Response {
        let key = self.keep(t_s, k_w_k);
        match self.response {
            Some(r) if self.fresh => r,
            _ => {
                self.fresh = true;
                *self.response.insert(Response::new(cfg, key.k_w_k, key.t_s))
            }
        }
    }

    /// The step kept for reuse.
    pub(super) fn kept(&self) -> StepKey {
        self.key
    }

    /// A step under `key` left the plant as it was.
    pub(super) fn still(&mut self, key: StepKey) {
        if !self.is_still(key) {
            if self.still_len < STILL_KEYS {
                self.still[self.still_len] = key;
                self.still_len += 1;
            } else {
                self.still[self.next_still % STILL_KEYS] = key;
                self.next_still = self.next_still.wrapping_add(1);
            }
        }
    }

    /// Whether a step under `key` is known to leave the plant as it is.
    pub(super) fn is_still(&self, key: StepKey) -> bool {
        self.still[..self.still_len].contains(&key)
    }

    /// Whether the plant is known still under some key: it did not move at its last step.
    pub(super) fn knows_still(&self) -> bool {
        self.still_len > 0
    }

    /// The plant moved: it is known still under no step.
    pub(super) fn moved(&mut self) {
        self.still_len = 0;
    }
}
