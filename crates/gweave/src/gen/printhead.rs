//! Inkjet printhead profile for binder-jet raster printing.
//!
//! The defaults describe the HP C6602 cartridge driven by the `hpc6602` branch of Marlin
//! (`sjkelly/Marlin:Marlin/Marlin_main.cpp`): 12 nozzles in one column at 96 dpi, fired by
//! `M700 P<head> S<bits>` where bit `a` of `S` fires nozzle address `a` (LSB = address 0).
//! RepRapFirmware names the same command `M578 P<head> S<bits>`.
//!
//! Geometry: the nozzles of a head form one row-per-nozzle column along +Y. Nozzle row `r`
//! (0 = the nozzle at the head's reference point) prints the pixel row `r` of the current band.
//! The pitch is `25.4 / dpi` mm exactly (96 dpi = 0.264583.. mm: 25.4 mm per inch).
//! The physical nozzle order of the C6602 is not the address order (PlanB pinout), so the
//! profile carries a nozzle map from address to physical row; `raster::test_pattern` prints a
//! pattern that reveals it.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::recoat::Recoat;
use crate::firmware::Firmware;
use crate::range::{self, OutOfRange, Range};
use crate::settings::{CheckRanges, Table};

/// Largest nozzle count: a band's nozzle mask is one `u64`.
pub const MAX_NOZZLES: u32 = 64;

/// Errors from validating a [`PrintheadProfile`].
#[derive(Debug, Error, PartialEq)]
pub enum PrintheadError {
    /// A number outside its range.
    #[error(transparent)]
    Range(#[from] OutOfRange),
    /// A profile without a head.
    #[error("at least one head is required")]
    NoHeads,
    /// `nozzle_rows` is not a permutation of the rows.
    #[error("nozzle_rows must list each row 0..{count} exactly once (got {rows:?})")]
    NozzleMap {
        /// The number of nozzle rows.
        count: u32,
        /// The rows as written.
        rows: Vec<u32>,
    },
    /// The profile's TOML cannot be read.
    #[error("invalid printhead TOML: {0}")]
    Toml(String),
    /// The `[recoat]` table is invalid.
    #[error("{0}")]
    Recoat(String),
    /// The profile names a firmware without an inkjet fire command.
    #[error("dialect: {0} has no inkjet fire command (marlin: M700, reprapfirmware: M578)")]
    NoFireCommand(Firmware),
}

/// Order of nozzle addresses inside the `S` word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BitOrder {
    /// Address `a` is bit `a` (Marlin hpc6602: LSB = nozzle 0).
    #[default]
    LsbFirst,
    /// Address `a` is bit `nozzle_count - 1 - a`.
    MsbFirst,
}

/// One cartridge on the carriage. Its nozzle row 0 sits at carriage position + offset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct HeadOffset {
    /// Offset of nozzle row 0 from the carriage along X, mm.
    pub offset_x_mm: f64,
    /// Offset of nozzle row 0 from the carriage along Y, mm.
    pub offset_y_mm: f64,
}

/// A printhead profile, loaded from TOML (all keys optional, unknown keys rejected).
///
/// ```toml
/// nozzle_count = 12
/// dpi = 96.0
/// nozzle_rows = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]
/// bit_order = "lsb_first"
/// min_fire_interval_us = 800.0
/// drop_volume_pl = 160.0
/// dialect = "marlin"
/// [recoat]         # optional: the powder recoat between layers (see `super::recoat`)
/// [[heads]]
/// offset_x_mm = 0.0
/// offset_y_mm = 0.0
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PrintheadProfile {
    /// Nozzles per head (C6602: 12).
    pub nozzle_count: u32,
    /// Nozzle pitch as dots per inch (C6602: 96); the pitch is `25.4 / dpi` mm.
    pub dpi: f64,
    /// Heads on the carriage, addressed `P0`, `P1`, ... in this order.
    pub heads: Vec<HeadOffset>,
    /// `nozzle_rows[a]` = physical row (0 = reference nozzle, rows along +Y) fired by
    /// address `a`. Empty means identity (address `a` fires row `a`).
    pub nozzle_rows: Vec<u32>,
    /// Address order inside the `S` word.
    pub bit_order: BitOrder,
    /// Shortest time between two fires of one head (C6602 on Marlin: 800 us).
    pub min_fire_interval_us: f64,
    /// Volume of one drop in picolitres, if known (gives the binder volume in reports).
    pub drop_volume_pl: Option<f64>,
    /// The firmware, for its fire command ([`Firmware::inkjet_fire_code`]).
    pub dialect: Firmware,
    /// The powder recoat between layers, as motion; `None`: the raster job's recoat G-code.
    pub recoat: Option<Recoat>,
}

impl Default for PrintheadProfile {
    /// The HP C6602 on Marlin hpc6602: 12 nozzles, 96 dpi, one head, identity map.
    fn default() -> Self {
        PrintheadProfile {
            nozzle_count: 12,
            dpi: 96.0,
            heads: vec![HeadOffset::default()],
            nozzle_rows: Vec::new(),
            bit_order: BitOrder::LsbFirst,
            min_fire_interval_us: 800.0,
            drop_volume_pl: None,
            dialect: Firmware::Marlin,
            recoat: None,
        }
    }
}

impl PrintheadProfile {
    /// Parses and validates a TOML profile.
    pub fn from_toml(text: &str) -> Result<Self, PrintheadError> {
        let p: PrintheadProfile =
            toml::from_str(text).map_err(|e| PrintheadError::Toml(crate::settings::toml_message(&e)))?;
        p.validate()?;
        Ok(p)
    }

    /// Checks ranges and that the nozzle map is a permutation.
    pub fn validate(&self) -> Result<(), PrintheadError> {
        self.check_ranges(&Table::root())?;
        if self.heads.is_empty() {
            return Err(PrintheadError::NoHeads);
        }
        if self.dialect.inkjet_fire_code().is_none() {
            return Err(PrintheadError::NoFireCommand(self.dialect));
        }
        if let Some(problem) = self.recoat.as_ref().and_then(Recoat::axes_problem) {
            return Err(PrintheadError::Recoat(problem));
        }
        if !self.nozzle_rows.is_empty() {
            let mut seen = vec![false; self.nozzle_count as usize];
            let bad =
                || PrintheadError::NozzleMap { count: self.nozzle_count, rows: self.nozzle_rows.clone() };
            if self.nozzle_rows.len() != seen.len() {
                return Err(bad());
            }
            for &r in &self.nozzle_rows {
                match seen.get_mut(r as usize) {
                    Some(s) if !*s => *s = true,
                    _ => return Err(bad()),
                }
            }
        }
        Ok(())
    }

    /// The M-code number of the fire command: `M700` (Marlin), `M578` (RepRapFirmware). Call
    /// only on a validated profile (its firmware has one); Marlin's otherwise.
    pub fn fire_code(&self) -> u32 {
        self.dialect.inkjet_fire_code().unwrap_or(700)
    }

    /// Nozzle pitch in mm: `25.4 / dpi`.
    pub fn pitch_mm(&self) -> f64 {
        25.4 / self.dpi
    }

    /// The `S` bit that fires nozzle row `row` (after the nozzle map and bit order).
    /// Call only on a validated profile with `row < nozzle_count`.
    pub fn s_bit_of_row(&self, row: u32) -> u32 {
        let address = if self.nozzle_rows.is_empty() {
            row
        } else {
            // The map is a validated permutation, so the row is present.
            self.nozzle_rows.iter().position(|&r| r == row).unwrap_or(0) as u32
        };
        self.s_bit_of_address(address)
    }

    /// The `S` bit of nozzle address `address` under the bit order.
    pub fn s_bit_of_address(&self, address: u32) -> u32 {
        match self.bit_order {
            BitOrder::LsbFirst => address,
            BitOrder::MsbFirst => self.nozzle_count - 1 - address,
        }
    }

    /// Table `row -> S bit` for all rows.
    pub fn row_to_s_bit(&self) -> Vec<u32> {
        (0..self.nozzle_count).map(|r| self.s_bit_of_row(r)).collect()
    }

    /// Where the drops of a fire command `P<head> S<s_bits>` land, mm, with the carriage at
    /// `carriage_mm` (X, Y): nozzle row `r` of a head sits at carriage + head offset + `r`
    /// pitches along Y. Bits above `nozzle_count` and unknown heads fire nothing, as in the
    /// firmware. Call only on a validated profile.
    pub fn drops_mm(
        &self,
        head: usize,
        s_bits: u64,
        carriage_mm: [f64; 2],
    ) -> impl Iterator<Item = [f64; 2]> {
        // An unknown head fires nothing: no rows, and the offset does not matter.
        let (rows, offset) = match self.heads.get(head) {
            Some(offset) => (self.rows_of_s_bits(s_bits), [offset.offset_x_mm, offset.offset_y_mm]),
            None => (0, [0.0; 2]),
        };
        let (x, y0, pitch) = (carriage_mm[0] + offset[0], carriage_mm[1] + offset[1], self.pitch_mm());
        (0..self.nozzle_count)
            .filter(move |r| rows >> r & 1 == 1)
            .map(move |r| [x, y0 + f64::from(r) * pitch])
    }

    /// How many drops one fire command with `S<s_bits>` puts down: the one drops formula, for
    /// the generator's report and the simulator's count alike. The bit order maps the nozzle
    /// addresses onto `S` bits `0..nozzle_count`, so the drops are the set bits below
    /// `nozzle_count` (the firmware ignores the others). Call only on a validated profile.
    pub fn drops_of_fire(&self, s_bits: u64) -> u32 {
        let mask = u64::MAX >> (64 - self.nozzle_count.clamp(1, 64));
        (s_bits & mask).count_ones()
    }

    /// Binder put down by `drops` drops, µl (`None` without a `drop_volume_pl`).
    pub fn binder_volume_ul(&self, drops: u64) -> Option<f64> {
        self.drop_volume_pl.map(|pl| drops as f64 * pl * 1e-6)
    }

    /// The time `fire_commands` fires take at the shortest interval between two fires, s.
    pub fn fire_time_s(&self, fire_commands: u64) -> f64 {
        fire_commands as f64 * self.min_fire_interval_us * 1e-6
    }

    /// Converts an `S` word into a mask of physical rows (bit `r` = row `r` fires).
    /// Bits above `nozzle_count` are ignored, as the firmware does.
    pub fn rows_of_s_bits(&self, s_bits: u64) -> u64 {
        (0..self.nozzle_count)
            .filter(|&r| s_bits >> self.s_bit_of_row(r) & 1 == 1)
            .fold(0u64, |m, r| m | 1 << r)
    }
}

const NOZZLES: Range = Range::new(1.0, MAX_NOZZLES as f64, "nozzles");
/// Entries of `nozzle_rows`: none (the identity) or one per nozzle.
const NOZZLE_ROWS: Range = Range::new(0.0, MAX_NOZZLES as f64, "rows");
/// Heads on one carriage (each is a `P` address).
const HEADS: Range = Range::new(0.0, 16.0, "heads");
/// Up to a second between two fires.
const FIRE_INTERVAL_US: Range = Range::new(0.0, 1_000_000.0, "µs");
/// Inkjet drops are 1 to a few hundred picolitres.
const DROP_VOLUME_PL: Range = Range::new(0.0, 100_000.0, "pl");

impl CheckRanges for PrintheadProfile {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.count("nozzle_count", self.nozzle_count, NOZZLES)?;
        // A map of a million rows would be listed whole in the message that refuses it.
        t.count("nozzle_rows (count)", self.nozzle_rows.len() as u64, NOZZLE_ROWS)?;
        t.check("dpi", self.dpi, range::DPI)?;
        t.count("heads (count)", self.heads.len() as u64, HEADS)?;
        for (i, h) in self.heads.iter().enumerate() {
            let head = t.sub("heads").item(i);
            head.check("offset_x_mm", h.offset_x_mm, range::POSITION_MM)?;
            head.check("offset_y_mm", h.offset_y_mm, range::POSITION_MM)?;
        }
        t.check("min_fire_interval_us", self.min_fire_interval_us, FIRE_INTERVAL_US)?;
        t.check_opt("drop_volume_pl", self.drop_volume_pl, DROP_VOLUME_PL)?;
        self.recoat.as_ref().map_or(Ok(()), |r| r.check_ranges(&t.sub("recoat")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drops_land_at_offset_plus_row_pitches() {
        let p = PrintheadProfile {
            nozzle_count: 4,
            nozzle_rows: vec![3, 2, 1, 0],
            heads: vec![HeadOffset::default(), HeadOffset { offset_x_mm: 2.0, offset_y_mm: 1.0 }],
            ..PrintheadProfile::default()
        };
        let pitch = 25.4 / 96.0;
        // Address 0 fires row 3 (reversed map); bit 9 is beyond the nozzles.
        let drops = |head, bits, at| p.drops_mm(head, bits, at).collect::<Vec<_>>();
        assert_eq!(drops(1, 1 | 1 << 9, [10.0, 20.0]), vec![[12.0, 21.0 + 3.0 * pitch]]);
        assert_eq!(drops(0, 0b0110, [0.0, 0.0]), vec![[0.0, pitch], [0.0, 2.0 * pitch]]);
        assert!(drops(2, 1, [0.0, 0.0]).is_empty(), "no head 2");
        // The count agrees with the positions, bits past the nozzles included.
        for bits in [0, 1, 0b0110, 1 | 1 << 9, 0xfff, u64::MAX] {
            assert_eq!(p.drops_of_fire(bits) as usize, drops(0, bits, [0.0, 0.0]).len(), "S{bits}");
        }
    }

    #[test]
    fn default_is_hp_c6602() {
        let p = PrintheadProfile::default();
        p.validate().unwrap();
        assert_eq!(p.nozzle_count, 12);
        assert_eq!(p.pitch_mm(), 25.4 / 96.0);
        assert!((p.pitch_mm() - 0.264_583_333).abs() < 1e-9);
        assert_eq!(p.min_fire_interval_us, 800.0);
        assert_eq!(p.fire_code(), 700);
        let rrf = PrintheadProfile { dialect: Firmware::RepRapFirmware, ..p.clone() };
        assert_eq!(rrf.fire_code(), 578);
        let klipper = PrintheadProfile { dialect: Firmware::Klipper, ..p };
        assert_eq!(klipper.validate(), Err(PrintheadError::NoFireCommand(Firmware::Klipper)));
    }

    #[test]
    fn toml_roundtrip_and_unknown_key() {
        let p = PrintheadProfile::from_toml(
            "nozzle_count = 4\ndpi = 300.0\nnozzle_rows = [2, 0, 3, 1]\nbit_order = \"msb_first\"\n\
             dialect = \"rep_rap_firmware\"\n[[heads]]\noffset_x_mm = 1.5\n[[heads]]\noffset_y_mm = -2.0\n",
        )
        .unwrap();
        assert_eq!(p.heads.len(), 2);
        assert_eq!(p.heads[1].offset_y_mm, -2.0);
        assert_eq!(p.dialect, Firmware::RepRapFirmware);
        // row 2 is address 0 -> msb-first bit 3; row 0 is address 1 -> bit 2.
        assert_eq!(p.row_to_s_bit(), vec![2, 0, 3, 1]);
        assert_eq!(p.rows_of_s_bits(0b1000), 0b0100);
        assert_eq!(p.rows_of_s_bits(0xFFF0), 0);
        let text = toml::to_string(&p).unwrap();
        assert_eq!(PrintheadProfile::from_toml(&text).unwrap(), p);
        assert!(matches!(PrintheadProfile::from_toml("nozzles = 12"), Err(PrintheadError::Toml(_))));
    }

    #[test]
    fn rejects_bad_maps_and_ranges() {
        let bad = |t: &str| PrintheadProfile::from_toml(t).unwrap_err();
        assert!(matches!(bad("nozzle_count = 3\nnozzle_rows = [0, 0, 1]"), PrintheadError::NozzleMap { .. }));
        assert!(matches!(bad("nozzle_count = 3\nnozzle_rows = [0, 1, 3]"), PrintheadError::NozzleMap { .. }));
        assert_eq!(
            bad("nozzle_count = 65").to_string(),
            "nozzle_count = 65 is out of range: 1 to 64 nozzles"
        );
        assert_eq!(bad("dpi = 0.0").to_string(), "dpi = 0 is out of range: 10 to 10000 dpi");
        assert_eq!(bad("heads = []"), PrintheadError::NoHeads);
        assert!(matches!(bad("drop_volume_pl = -1.0"), PrintheadError::Range(_)));
    }
}
