//! The layers of a rotary program drawn on its cylinder.
//!
//! A wrapped slicer file keeps its layer comments, and they number the layers. A generated
//! program (a tube) has none: its layers are the radii its beads are laid at, numbered from the
//! mandrel outwards, which is known only once the whole file is read. Until then each bead
//! radius gets a provisional key (flagged with [`PROVISIONAL`]) in the order it appears, and
//! [`CylinderLayers::finish`] turns the keys into ranks. Travel takes the layer of the bead
//! before it.

use std::collections::HashMap;
use std::ops::RangeInclusive;

use super::Segment;
use crate::rotary::preview::{micron, RotaryMove};

/// The flag of a provisional layer key (a bead radius not yet ranked).
pub(super) const PROVISIONAL: u32 = 1 << 31;

/// Layer bookkeeping while a rotary program streams by.
#[derive(Debug, Clone, Default)]
pub(super) struct CylinderLayers {
    /// Provisional key of each bead radius (whole microns) met without a layer comment.
    keys: HashMap<i64, u32>,
    /// The radius of each provisional key, whole microns.
    radii_um: Vec<i64>,
    /// Whether any bead had a layer comment: then the comments number the layers.
    commented: bool,
    /// Radius of the first bead of each commented layer, mm (0 where none yet).
    first_radius_mm: Vec<f32>,
    /// The layer (or key) of the last bead.
    last: u32,
}

impl CylinderLayers {
    /// The layer (or provisional key) of move `m` in a layer the slicer numbered `commented`.
    pub(super) fn layer(&mut self, commented: Option<u32>, m: &RotaryMove) -> u32 {
        if !m.is_bead() {
            return commented.unwrap_or(self.last);
        }
        self.last = match commented {
            Some(layer) => {
                self.commented = true;
                let k = layer as usize;
                if self.first_radius_mm.len() <= k {
                    self.first_radius_mm.resize(k + 1, 0.0);
                }
                if self.first_radius_mm[k] == 0.0 {
                    self.first_radius_mm[k] = m.from.radius_mm as f32;
                }
                layer
            }
            None => {
                let next = self.radii_um.len() as u32;
                let um = micron(m.from.radius_mm);
                let key = *self.keys.entry(um).or_insert(next);
                if key == next {
                    self.radii_um.push(um);
                }
                key | PROVISIONAL
            }
        };
        self.last
    }

    /// Gives every segment its final layer, keeps those in `layers`, and returns the radius of
    /// each layer, mm (what a flat file's layer Z is to the preview).
    pub(super) fn finish(
        &self,
        segments: &mut Vec<Segment>,
        layers: Option<&RangeInclusive<u32>>,
    ) -> Vec<f32> {
        let mut sorted = self.radii_um.clone();
        sorted.sort_unstable();
        let rank: Vec<u32> =
            self.radii_um.iter().map(|um| sorted.binary_search(um).unwrap_or(0) as u32).collect();
        for s in segments.iter_mut() {
            if s.layer & PROVISIONAL != 0 {
                // Beads without a comment in a commented file go to layer 0.
                s.layer = if self.commented { 0 } else { rank[(s.layer & !PROVISIONAL) as usize] };
            }
        }
        if let Some(r) = layers {
            segments.retain(|s| r.contains(&s.layer));
        }
        if self.commented {
            self.first_radius_mm.clone()
        } else {
            sorted.iter().map(|&um| um as f32 / 1000.0).collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::layers::Feature;
    use crate::rotary::cylinder::CylPoint;

    fn bead(radius_mm: f64, e_mm: f64) -> RotaryMove {
        let from = CylPoint::new(0.0, 0.0, radius_mm);
        RotaryMove { from, to: CylPoint::new(1.0, 0.0, radius_mm), e_mm, t_s: 0.1, moved: true }
    }

    fn segment(layer: u32) -> Segment {
        Segment {
            start: [0.0; 3],
            end: [1.0, 0.0, 0.0],
            tool: 0,
            feature: Feature::Unknown,
            feed_mm_s: 10.0,
            layer,
            extruding: true,
            mix_rgb: [0; 3],
        }
    }

    #[test]
    fn radii_rank_from_the_mandrel_out_once_all_are_known() {
        let mut c = CylinderLayers::default();
        // The outer radius appears first; a travel takes the layer of the bead before it.
        let keys: Vec<u32> =
            [bead(10.4, 1.0), bead(10.2, 1.0), bead(10.2, 0.0), bead(10.6, 1.0), bead(10.4, 1.0)]
                .iter()
                .map(|m| c.layer(None, m))
                .collect();
        assert!(keys.iter().all(|k| k & PROVISIONAL != 0));
        let mut segments: Vec<Segment> = keys.iter().map(|&k| segment(k)).collect();
        let radii = c.finish(&mut segments, None);
        assert_eq!(segments.iter().map(|s| s.layer).collect::<Vec<_>>(), [1, 0, 0, 2, 1]);
        assert_eq!(radii, [10.2, 10.4, 10.6]);
        // A layer range is applied to the ranks.
        let mut segments: Vec<Segment> = keys.iter().map(|&k| segment(k)).collect();
        c.finish(&mut segments, Some(&(1..=1)));
        assert_eq!(segments.len(), 2);
    }

    #[test]
    fn comments_number_the_layers_when_a_file_has_them() {
        let mut c = CylinderLayers::default();
        assert_eq!(c.layer(Some(0), &bead(10.2, 1.0)), 0);
        assert_eq!(c.layer(Some(1), &bead(10.4, 1.0)), 1);
        assert_eq!(c.layer(Some(1), &bead(10.5, 1.0)), 1);
        let stray = c.layer(None, &bead(12.0, 1.0));
        let mut segments = vec![segment(0), segment(1), segment(stray)];
        let radii = c.finish(&mut segments, None);
        assert_eq!(segments.iter().map(|s| s.layer).collect::<Vec<_>>(), [0, 1, 0]);
        assert_eq!(radii, [10.2, 10.4]);
    }
}
