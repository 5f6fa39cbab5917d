//! Checks the powder recoats of a binder-jet machine (the printhead profile's `[recoat]`, see
//! `gweave::gen::recoat`).
//!
//! Between the fires of two layers the machine must recoat: the build piston moves by the
//! layer height (the Z step between the two layers' fires), the feed piston by the powder
//! ratio times that, and the spreader crosses the whole powder bed (the inkjet canvas along its
//! axis) before the next fire. A fire after a piston started moving and before the spreader has
//! crossed the bed is a fire during the recoat: binder on a half-spread layer. Each finding is
//! an [`InkjetWarning`].

use gweave::gen::recoat::Recoat;

use crate::inkjet::InkjetWarning;

/// Axes the virtual printer moves: X, Y, Z and A, in [`Position`] order.
const AXES: [char; 4] = ['X', 'Y', 'Z', 'A'];

/// X, Y, Z, A of the machine, mm (A in its own unit).
pub(crate) type Position = [f64; 4];

/// Piston travel off by more than this is reported, mm (the words' 4 decimals, with margin).
const PISTON_TOLERANCE_MM: f64 = 1e-3;

/// The recoat check of one machine.
#[derive(Debug, Clone)]
pub(crate) struct RecoatCheck {
    recoat: Recoat,
    /// Indices in [`Position`] of the spreader, feed piston and build piston.
    spreader: usize,
    feed: usize,
    build: usize,
    /// The powder bed along the spreader's axis, mm.
    bed_mm: [f64; 2],
    /// Where the pistons were at the last fire, and its Z.
    at_fire: Option<(Position, f64)>,
    /// A piston moved since the last fire.
    started: bool,
    /// The spreader's reach since the recoat started.
    reach_mm: [f64; 2],
}

/// Where a profile axis is in [`Position`], if the virtual printer moves it.
fn index(axis: char) -> Result<usize, String> {
    AXES.iter()
        .position(|&a| a == axis)
        .ok_or_else(|| format!("[recoat] axis `{axis}`: the virtual printer moves X, Y, Z and A"))
}

impl RecoatCheck {
    /// `bed_x_mm`, `bed_y_mm`: the powder bed (the inkjet canvas) along X and Y.
    pub(crate) fn new(recoat: &Recoat, bed_x_mm: [f64; 2], bed_y_mm: [f64; 2]) -> Result<Self, String> {
        let spreader = index(recoat.spreader_axis)?;
        let bed_mm = match spreader {
            0 => bed_x_mm,
            1 => bed_y_mm,
            _ => {
                return Err(format!(
                    "[recoat] spreader_axis `{}` must cross the bed: X or Y",
                    recoat.spreader_axis
                ))
            }
        };
        Ok(RecoatCheck {
            recoat: recoat.clone(),
            spreader,
            feed: index(recoat.feed_piston_axis)?,
            build: index(recoat.build_piston_axis)?,
            bed_mm,
            at_fire: None,
            started: false,
            reach_mm: [f64::INFINITY, f64::NEG_INFINITY],
        })
    }

    /// A move from `from` to `to`.
    pub(crate) fn on_move(&mut self, from: Position, to: Position) {
        if self.at_fire.is_none() {
            return;
        }
        if from[self.feed] != to[self.feed] || from[self.build] != to[self.build] {
            self.started = true;
        }
        if self.started {
            let s = self.spreader;
            self.reach_mm =
                [self.reach_mm[0].min(from[s]).min(to[s]), self.reach_mm[1].max(from[s]).max(to[s])];
        }
    }

    fn spread(&self) -> bool {
        self.reach_mm[0] <= self.bed_mm[0] + 1e-9 && self.reach_mm[1] >= self.bed_mm[1] - 1e-9
    }

    /// A fire at `pos`, the carriage at Z `z_mm`: what was wrong since the last fire.
    pub(crate) fn on_fire(&mut self, pos: Position, z_mm: f64, out: &mut Vec<InkjetWarning>) {
        let Some((before, z_before)) = self.at_fire else {
            self.at_fire = Some((pos, z_mm));
            return;
        };
        let new_layer = (z_mm - z_before).abs() > 1e-6;
        let [x_mm, y_mm] = [pos[0], pos[1]];
        if self.started && !self.spread() {
            // Binder on a layer the spreader has not covered (once per recoat: the fires after
            // it start the next check).
            out.push(InkjetWarning::FireDuringRecoat { x_mm, y_mm });
            if self.reach_mm[1] > self.reach_mm[0] {
                out.push(InkjetWarning::SpreaderShort { reach_mm: self.reach_mm, bed_mm: self.bed_mm });
            }
        } else if new_layer && !self.started {
            out.push(InkjetWarning::NoRecoat { z_mm });
        } else if self.started {
            let layer_mm = z_mm - z_before;
            let moved = |i: usize| pos[i] - before[i];
            let checks = [
                (self.recoat.build_piston_axis, moved(self.build), layer_mm),
                (self.recoat.feed_piston_axis, moved(self.feed), self.recoat.powder_ratio * layer_mm),
            ];
            for (axis, moved_mm, expected_mm) in checks {
                if (moved_mm - expected_mm).abs() > PISTON_TOLERANCE_MM {
                    out.push(InkjetWarning::PistonTravel { axis, moved_mm, expected_mm });
                }
            }
        }
        self.at_fire = Some((pos, z_mm));
        self.started = false;
        self.reach_mm = [f64::INFINITY, f64::NEG_INFINITY];
    }

    /// The recoat under way at the end of the job, if its spreader never crossed the bed.
    pub(crate) fn finish(&self, out: &mut Vec<InkjetWarning>) {
        if self.started && !self.spread() {
            let reach_mm = if self.reach_mm[0] <= self.reach_mm[1] { self.reach_mm } else { [0.0; 2] };
            out.push(InkjetWarning::SpreaderShort { reach_mm, bed_mm: self.bed_mm });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shared recoat, its spreader from 0 over 100 mm, no settling.
    fn recoat() -> Recoat {
        Recoat {
            spreader_start_mm: 0.0,
            spreader_stroke_mm: 100.0,
            dwell_s: 0.0,
            ..gweave::test_support::recoat()
        }
    }

    /// Fires at layer 1, a recoat with the given feed piston end and spreader end, a fire.
    fn run(feed_to: f64, spread_to: f64, fire_mid: bool) -> Vec<InkjetWarning> {
        let mut c = RecoatCheck::new(&recoat(), [0.0, 50.0], [10.0, 90.0]).unwrap();
        let mut w = Vec::new();
        c.on_fire([20.0, 20.0, 0.1, 0.0], 0.1, &mut w);
        c.on_move([20.0, 20.0, 0.1, 0.0], [20.0, 20.0, 0.2, 0.0]);
        c.on_move([20.0, 20.0, 0.2, 0.0], [20.0, 20.0, 0.2, feed_to]);
        if fire_mid {
            c.on_fire([20.0, 20.0, 0.2, feed_to], 0.2, &mut w);
        }
        c.on_move([20.0, 20.0, 0.2, feed_to], [20.0, spread_to, 0.2, feed_to]);
        c.on_move([20.0, spread_to, 0.2, feed_to], [20.0, 0.0, 0.2, feed_to]);
        c.on_fire([20.0, 20.0, 0.2, feed_to], 0.2, &mut w);
        c.finish(&mut w);
        w
    }

    #[test]
    fn a_full_recoat_passes() {
        assert_eq!(run(0.15, 100.0, false), vec![]);
    }

    #[test]
    fn each_fault_is_named() {
        let short_feed = run(0.1, 100.0, false);
        assert!(
            matches!(short_feed[..], [InkjetWarning::PistonTravel { axis: 'A', moved_mm, expected_mm }]
                if (moved_mm - 0.1).abs() < 1e-12 && (expected_mm - 0.15).abs() < 1e-12),
            "{short_feed:?}"
        );
        // The spreader stops short of the bed's far edge (90): the next fire is mid-recoat.
        assert_eq!(
            run(0.15, 80.0, false),
            vec![
                InkjetWarning::FireDuringRecoat { x_mm: 20.0, y_mm: 20.0 },
                InkjetWarning::SpreaderShort { reach_mm: [0.0, 80.0], bed_mm: [10.0, 90.0] },
            ]
        );
        assert_eq!(run(0.15, 100.0, true)[0], InkjetWarning::FireDuringRecoat { x_mm: 20.0, y_mm: 20.0 });
        let mut c = RecoatCheck::new(&recoat(), [0.0, 50.0], [10.0, 90.0]).unwrap();
        let mut w = Vec::new();
        c.on_fire([0.0; 4], 0.1, &mut w);
        c.on_fire([0.0, 0.0, 0.2, 0.0], 0.2, &mut w);
        assert_eq!(w, vec![InkjetWarning::NoRecoat { z_mm: 0.2 }]);
        let u = Recoat { spreader_axis: 'U', ..recoat() };
        assert!(RecoatCheck::new(&u, [0.0; 2], [0.0; 2]).unwrap_err().contains("moves X, Y, Z and A"));
    }
}
