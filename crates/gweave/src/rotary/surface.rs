//! `gweave stats` of a rotary program: distances and extents on the mandrel, not in the machine
//! words. A wrapped part turns the mandrel with `A` (degrees) where the flat part moved along
//! `Y`: read as flat G-code its moves along the circumference have no length at all (a
//! 0.4 m print read as 0.2 m, extents `Y 0..0`). A program whose header names its machine
//! ([`RotaryConfig::header_lines`](super::cylinder::RotaryConfig::header_lines), what `rotary
//! wrap` and `rotary tube` write) is read as that machine runs it ([`RotaryReading`]): each
//! move's length is its surface length, `hypot(d_axial, d_radial, r * d_theta)` at the mean
//! radius of its ends (the nozzle's radius, `R0 + Z`), and its time what the firmware takes
//! for its F under the header's feed convention.
//!
//! ```
//! use gweave::rotary::wrap::{wrap_bytes, WrapConfig};
//! use gweave::rotary::cylinder::RotaryConfig;
//! use gweave::rotary::surface::stats_of_program;
//! // A 60 mm mandrel circumference: Y15 is a quarter turn, 15 mm of the surface (Z = 0).
//! let config = WrapConfig::new(RotaryConfig::new(60.0 / std::f64::consts::PI));
//! let wrapped = wrap_bytes(config, b"M104 S200\nG1 Y15 E1 F1200\n").unwrap();
//! let stats = stats_of_program(&wrapped).unwrap();
//! assert!((stats.print_mm - 15.0).abs() < 1e-9, "{}", stats.print_mm);
//! let surface = stats.rotary.unwrap();
//! assert_eq!(surface.angle_deg, Some([0.0, 90.0]));
//! ```

use std::io::Write;

use serde::Serialize;

use super::cylinder::{surface_length_mm, CylPoint};
use super::preview::RotaryReading;
use crate::gcode::layers::ALL_FEATURES;
use crate::gcode::reader::RawLine;
use crate::gcode::state::{Effect, State};
use crate::pass::{Ctx, Pass, PassError, Step};
use crate::stats::{Stats, StatsPass};

/// What a rotary program does on its mandrel ([`Stats::rotary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RotarySurface {
    /// The mandrel the header names, mm.
    pub mandrel_diameter_mm: f64,
    /// Along the mandrel, extruding moves, mm.
    pub axial_mm: Option<[f64; 2]>,
    /// The mandrel's angle, extruding moves, degrees (turns add up: 720 is two).
    pub angle_deg: Option<[f64; 2]>,
    /// The nozzle's distance from the mandrel's axis, extruding moves, mm.
    pub radius_mm: Option<[f64; 2]>,
}

/// [`StatsPass`] on a rotary machine: the flat statistics, with the lengths, times and extents
/// of moves measured on the mandrel ([`StatsPass::into_stats`] then [`Self::into_stats`]).
#[derive(Debug)]
pub struct SurfacePass<P> {
    /// The flat statistics (or the pass that counts malformed lines around them).
    pub inner: P,
    reading: RotaryReading,
    print_mm: f64,
    travel_mm: f64,
    /// Indexed by `Feature as usize`, as [`StatsPass`] keeps it.
    time_by_feature_s: [f64; ALL_FEATURES.len()],
    extents: [[f64; 2]; 3],
}

impl<P: Pass> SurfacePass<P> {
    /// `inner` with the moves read on `reading`'s machine.
    pub fn new(inner: P, reading: RotaryReading) -> Self {
        let empty = [f64::INFINITY, f64::NEG_INFINITY];
        SurfacePass {
            inner,
            reading,
            print_mm: 0.0,
            travel_mm: 0.0,
            time_by_feature_s: [0.0; ALL_FEATURES.len()],
            extents: [empty; 3],
        }
    }

    fn grow(&mut self, p: CylPoint) {
        for (range, v) in self.extents.iter_mut().zip([p.axial_mm, p.theta_deg, p.radius_mm]) {
            *range = [range[0].min(v), range[1].max(v)];
        }
    }

    /// The statistics the inner pass gives (`flat`: [`StatsPass::into_stats`], for one held in
    /// a counting pass too), with what this pass measured on the mandrel in place of the flat
    /// lengths and times.
    pub fn into_stats(self, flat: impl FnOnce(P) -> Stats) -> Stats {
        let mut stats = flat(self.inner);
        let range = |[lo, hi]: [f64; 2]| (lo <= hi).then_some([lo, hi]);
        stats.print_mm = self.print_mm;
        stats.travel_mm = self.travel_mm;
        stats.time_by_feature_s = ALL_FEATURES
            .iter()
            .zip(self.time_by_feature_s)
            .filter(|(_, t)| *t > 0.0)
            .map(|(f, t)| (f.name(), t))
            .collect();
        stats.time_s = self.time_by_feature_s.iter().sum();
        stats.rotary = Some(RotarySurface {
            mandrel_diameter_mm: self.reading.mandrel_diameter_mm(),
            axial_mm: range(self.extents[0]),
            angle_deg: range(self.extents[1]),
            radius_mm: range(self.extents[2]),
        });
        stats
    }
}

impl<P: Pass> Pass for SurfacePass<P> {
    fn reads_words(&self) -> bool {
        self.inner.reads_words()
    }

    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        let flow = self.inner.line(ctx, out)?;
        let feature = ctx.state.structure.feature as usize;
        match ctx.effect {
            Effect::Move(m) => {
                let mv = self.reading.read(m);
                let len_mm = surface_length_mm(mv.from, mv.to);
                if mv.e_mm > 0.0 && len_mm > 0.0 {
                    self.print_mm += len_mm;
                    self.grow(mv.from);
                    self.grow(mv.to);
                } else {
                    self.travel_mm += len_mm;
                }
                self.time_by_feature_s[feature] += mv.t_s;
            }
            // A pause takes as long on any machine.
            Effect::Dwell { t_s } => self.time_by_feature_s[feature] += t_s,
            _ => {}
        }
        Ok(flow)
    }

    fn long_line(&mut self, piece: &RawLine<'_>, out: &mut dyn Write) -> Result<(), PassError> {
        self.inner.long_line(piece, out)
    }

    fn finish(&mut self, state: &State, out: &mut dyn Write) -> Result<(), PassError> {
        self.inner.finish(state, out)
    }
}

/// The statistics of a rotary program in memory, on the machine its header names (`None`
/// without one): what `gweave stats` reports for such a file.
pub fn stats_of_program(text: &[u8]) -> Option<Stats> {
    let machine = super::cylinder::RotaryConfig::from_header(&String::from_utf8_lossy(text))?;
    let reading = RotaryReading::new(&machine).ok()?;
    let mut pass = SurfacePass::new(StatsPass::new(None), reading);
    let reading = crate::pass::Reading::new("program.gcode".as_ref());
    let state = crate::pass::drive_reader(text, reading, &mut pass, &mut std::io::sink()).ok()?;
    Some(pass.into_stats(|inner| inner.into_stats(&state)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotary::cylinder::RotaryConfig;
    use crate::rotary::wrap::{wrap_bytes, WrapConfig};

    /// Regression (stats_of_a_rotary_wrap_ignores_a): `stats` of a wrapped part read its `A`
    /// turns as no move at all: extents Y 0..0, a print of 0.2 m against 0.4 m flat. A half turn
    /// at 0.2 mm above a mandrel of 60 mm circumference is 30 mm at the mandrel's surface and
    /// 30 (R0 + 0.2) / R0 mm where the nozzle runs.
    #[test]
    fn stats_of_a_rotary_wrap_ignores_a() {
        let r0 = 30.0 / std::f64::consts::PI;
        let flat = b"M104 S200\nG1 Z0.2 F600\nG1 X10 Y0 F1200\nG1 X10 Y30 E1\nG1 X40 Y30 E2\nG4 S2\n";
        let wrapped = wrap_bytes(WrapConfig::new(RotaryConfig::new(2.0 * r0)), flat).unwrap();
        let stats = stats_of_program(&wrapped).unwrap();
        let half_turn_mm = 30.0 * (r0 + 0.2) / r0;
        assert!((stats.print_mm - (half_turn_mm + 30.0)).abs() < 1e-6, "{}", stats.print_mm);
        let surface = stats.rotary.clone().unwrap();
        assert_eq!(surface.mandrel_diameter_mm, 2.0 * r0);
        assert_eq!(surface.axial_mm, Some([10.0, 40.0]));
        let [t0, t1] = surface.angle_deg.unwrap();
        assert!(t0.abs() < 1e-3 && (t1 - 180.0).abs() < 1e-3, "{t0} .. {t1}");
        let [rl, rh] = surface.radius_mm.unwrap();
        assert!((rl - (r0 + 0.2)).abs() < 1e-9 && (rh - rl).abs() < 1e-9, "{rl} .. {rh}");
        // The wrap runs each bead at the flat file's surface speed, 20 mm/s, and feeds the
        // half turn's filament in proportion to its length there; the travel to X10 (0.5 s at
        // 20 mm/s), the 0.2 mm lift (0.02 s at 10 mm/s) and the 2 s dwell are as flat.
        let expected_s = (half_turn_mm + 30.0) / 20.0 + 0.5 + 0.02 + 2.0;
        assert!((stats.time_s - expected_s).abs() < 1e-3, "{} s against {expected_s} s", stats.time_s);
        let expected_mm = half_turn_mm / 30.0 + 1.0;
        assert!((stats.filament[0].extruded_mm - expected_mm).abs() < 1e-4, "{:?}", stats.filament);
    }
}
