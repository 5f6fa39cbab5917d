//! The recorded temperatures and powers of every heater over a run, in bounded memory, for the
//! temperature chart and the report.

use serde::Serialize;

use super::heater::HeaterId;

/// One recorded point of the time series.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sample {
    pub t_s: f64,
    pub heater: HeaterId,
    pub temp_c: f64,
    pub target_c: f64,
    /// `@:` power, 0..=127.
    pub power: u8,
}

/// A recorded time series of every heater, for plotting. Recorded every
/// `period_s`; when it exceeds its size limit, every other record is
/// dropped and the period doubles, so a long run keeps its whole history at
/// bounded size.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TimeSeries {
    period_s: f64,
    max_samples: usize,
    next_s: f64,
    records: Vec<Vec<Sample>>,
}

impl TimeSeries {
    pub(super) fn new(period_s: f64, max_samples: usize) -> Self {
        Self { period_s, max_samples, next_s: 0.0, records: Vec::new() }
    }

    /// Whether a record is due at `now_s`.
    pub(super) fn due(&self, now_s: f64) -> bool {
        now_s + 1e-9 >= self.next_s
    }

    /// Keep `samples` taken at `now_s`, when [`TimeSeries::due`].
    pub(super) fn record(&mut self, now_s: f64, samples: Vec<Sample>) {
        self.records.push(samples);
        self.next_s += self.period_s;
        while self.next_s <= now_s {
            self.next_s += self.period_s;
        }
        if self.records.len() * self.records[0].len().max(1) > self.max_samples {
            let kept = std::mem::take(&mut self.records).into_iter().step_by(2);
            self.records = kept.collect();
            self.period_s *= 2.0;
            // Continue the even spacing from the last kept record.
            let last_s = self.records.last().and_then(|r| r.first()).map_or(0.0, |s| s.t_s);
            self.next_s = last_s + self.period_s;
            while self.next_s <= now_s {
                self.next_s += self.period_s;
            }
        }
    }

    /// Current recording period, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// All samples, in time order, heaters in order within one time.
    pub fn samples(&self) -> impl Iterator<Item = &Sample> {
        self.records.iter().flatten()
    }

    /// The samples of one heater.
    pub fn of(&self, heater: HeaterId) -> impl Iterator<Item = &Sample> {
        self.samples().filter(move |s| s.heater == heater)
    }
}
