//! PrusaSlicer's wipe tower, as the comments it writes mark its parts, and which of its moves
//! PrusaSlicer (2.5) counts in its `; filament used [mm]`.
//!
//! PrusaSlicer does not count that figure from the G-code: it adds what its G-code writer fed
//! outside the tower (net of retractions) to what the tower generator recorded while it laid
//! the tower out (`WipeTower.cpp`: only `extrude()` and `ram()` record their length). So the
//! figure leaves out, per tool:
//! - the priming block (`; CP PRIMING START` .. `; CP PRIMING END`, "prime all printing
//!   extruders"): `Print::_make_wipe_tower` primes the tools first, then `generate()` resets the
//!   tower's count;
//! - at each tool change of a single-extruder multi-material printer, the unloading (the
//!   filament pulled back to its parking position and the cooling moves that push it to and
//!   fro in the cooling tube: from the first filament-only backwards feed after `; CP
//!   TOOLCHANGE UNLOAD`, which ends the ramming) and the loading of the next filament (`; CP
//!   TOOLCHANGE LOAD` .. `; CP TOOLCHANGE WIPE`). The ramming and the wipe count.

/// Where in the wipe tower's tool change the file is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
enum Part {
    /// Not in a tool change's unloading or loading (printing, ramming, wiping).
    #[default]
    Counted,
    /// After `; CP TOOLCHANGE UNLOAD`: ramming, until the first filament-only backwards feed.
    Ramming,
    /// Pulling the filament back to its parking position and cooling it.
    Unloading,
    /// `; CP TOOLCHANGE LOAD` .. `; CP TOOLCHANGE WIPE`: pushing the next filament down.
    Loading,
}

/// Follows the wipe tower's parts over a file's comments and moves.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct WipeTower {
    priming: bool,
    part: Part,
}

impl WipeTower {
    /// Follows a comment's text (trimmed, without the `;`).
    pub(crate) fn comment(&mut self, text: &[u8]) {
        match text {
            b"CP PRIMING START" => self.priming = true,
            b"CP PRIMING END" => {
                self.priming = false;
                self.part = Part::Counted;
            }
            b"CP TOOLCHANGE UNLOAD" => self.part = Part::Ramming,
            b"CP TOOLCHANGE LOAD" => self.part = Part::Loading,
            b"CP TOOLCHANGE WIPE" | b"CP TOOLCHANGE END" => self.part = Part::Counted,
            _ => {}
        }
    }

    /// Follows a move feeding `e_mm` of filament (negative: backwards), `moves_xy` whether it
    /// also moves along X or Y. Returns whether PrusaSlicer counts the feed in its figure.
    #[inline]
    pub(crate) fn feed(&mut self, e_mm: f64, moves_xy: bool) -> bool {
        if self.part == Part::Ramming && e_mm < 0.0 && !moves_xy {
            self.part = Part::Unloading;
        }
        !self.priming && matches!(self.part, Part::Counted | Part::Ramming)
    }

    /// Whether the file is inside the tower's priming block.
    pub(crate) fn priming(&self) -> bool {
        self.priming
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A single-extruder tool change as PrusaSlicer 2.5 writes it: ramming along X counts, the
    /// unloading retraction and the cooling moves after it do not, nor the loading; the wipe
    /// counts again.
    #[test]
    fn ramming_and_wiping_count_unloading_and_loading_do_not() {
        let mut tower = WipeTower::default();
        tower.comment(b"CP TOOLCHANGE START");
        assert!(tower.feed(-0.8, false), "a retraction before the tower is the writer's");
        tower.comment(b"CP TOOLCHANGE UNLOAD");
        assert!(tower.feed(0.7, true), "ramming");
        assert!(!tower.feed(-15.0, false), "unloading");
        assert!(!tower.feed(5.0, true), "cooling");
        tower.comment(b"CP TOOLCHANGE LOAD");
        assert!(!tower.feed(63.0, true), "loading");
        tower.comment(b"CP TOOLCHANGE WIPE");
        assert!(tower.feed(3.2, true), "wiping");
        tower.comment(b"CP PRIMING START");
        assert!(tower.priming() && !tower.feed(3.2, true), "priming");
        tower.comment(b"CP PRIMING END");
        assert!(!tower.priming() && tower.feed(3.2, true));
    }
}
