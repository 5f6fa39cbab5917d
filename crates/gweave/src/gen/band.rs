//! A band's inked columns and their fire bits, gathered eight columns at a time.
//!
//! A band is as many image rows as the head has nozzles (12 on the C6602); the bitmap stores
//! them row by row, 64 columns to a word, but a fire command needs them column by column: the
//! `S` word of column `i` has bit `row_to_s_bit[r]` set when row `r` of the band is inked at `i`.
//! Gathering that bit by bit costs a shift, a mask and an or per row and column (about 70
//! instructions a column for 12 rows: most of the raster's time). Instead, eight rows of eight
//! columns are one 64-bit word (byte `r` = row `r`), which three swap steps transpose
//! ([`transpose8`], Hacker's Delight 7-3) into byte `c` = column `c`'s rows; a table of 256
//! entries per group of eight rows turns that byte into its `S` bits (the nozzle map and bit
//! order folded in). About 20 instructions a column. A part's inside is inked on every row: a
//! byte (or a word) of columns inked on all of the band's rows takes the `S` word of all rows
//! without transposing, a few instructions a column.

use super::bitmap::Bitmap;

/// Gathers bands for one nozzle map.
#[derive(Debug, Clone)]
pub(crate) struct BandGather {
    /// Rows in a band: the head's nozzles.
    nozzles: usize,
    /// Per group of eight band rows: the `S` bits of each pattern of those rows.
    s_of_rows: Vec<[u64; 256]>,
}

impl BandGather {
    /// For the map `row_to_s_bit` (row `r` of a band fires `S` bit `row_to_s_bit[r]`, < 64).
    pub(crate) fn new(row_to_s_bit: &[u32]) -> Self {
        let s_of_rows = row_to_s_bit
            .chunks(8)
            .map(|bits| {
                let mut table = [0u64; 256];
                for (pattern, s) in table.iter_mut().enumerate() {
                    for (r, &bit) in bits.iter().enumerate() {
                        if pattern >> r & 1 == 1 {
                            *s |= 1 << bit;
                        }
                    }
                }
                table
            })
            .collect();
        BandGather { nozzles: row_to_s_bit.len(), s_of_rows }
    }

    /// Fills `columns` with the inked columns of the band of `plane` starting at row `j0`, left
    /// to right, each with its `S` word.
    pub(crate) fn collect(&self, plane: &Bitmap, j0: usize, columns: &mut Vec<(usize, u64)>) {
        columns.clear();
        columns.reserve(plane.width());
        let rows = (plane.height() - j0).min(self.nozzles);
        let groups = rows.div_ceil(8);
        // The `S` word of a column inked on every row of the band.
        let solid_s = self.s_of_rows[..groups].iter().enumerate().fold(0, |s, (g, table)| {
            let rows_in_group = (rows - 8 * g).min(8);
            s | table[(1usize << rows_in_group) - 1]
        });
        // The band's words at the current column word, row by row (rows past the band: none).
        let mut band = [0u64; 64];
        for wi in 0..plane.words_per_row() {
            let (mut any, mut all) = (0, u64::MAX);
            for (k, w) in band[..rows].iter_mut().enumerate() {
                *w = plane.row(j0 + k)[wi];
                any |= *w;
                all &= *w;
            }
            if all == u64::MAX {
                // 64 solid columns (a part's inside): no transposing.
                columns.extend((wi * 64..wi * 64 + 64).map(|i| (i, solid_s)));
                continue;
            }
            for byte in 0..8 {
                let inked = (any >> (8 * byte)) as u8;
                if inked == 0 {
                    continue;
                }
                let at = wi * 64 + 8 * byte;
                if (all >> (8 * byte)) as u8 == 0xff {
                    columns.extend((at..at + 8).map(|i| (i, solid_s)));
                    continue;
                }
                // Per group of eight rows, column `c`'s rows in byte `c`.
                let mut by_column = [0u64; 8];
                for (word, rows) in by_column[..groups].iter_mut().zip(band[..8 * groups].chunks_exact(8)) {
                    let x = rows
                        .iter()
                        .enumerate()
                        .fold(0, |x, (r, w)| x | ((w >> (8 * byte)) & 0xff) << (8 * r));
                    *word = transpose8(x);
                }
                let mut left = inked;
                while left != 0 {
                    let c = left.trailing_zeros() as usize;
                    let s = by_column[..groups]
                        .iter()
                        .zip(&self.s_of_rows)
                        .fold(0, |s, (word, table)| s | table[((word >> (8 * c)) & 0xff) as usize]);
                    columns.push((at + c, s));
                    left &= left - 1;
                }
            }
        }
    }
}

/// Transposes the 8 x 8 bit matrix in `x` (bit `8 r + c` to bit `8 c + r`): three steps, each
/// swapping the off-diagonal blocks of 1, 2 and 4 bits (Hacker's Delight, 2nd ed., 7-3).
fn transpose8(mut x: u64) -> u64 {
    let t = (x ^ (x >> 7)) & 0x00aa_00aa_00aa_00aa;
    x ^= t ^ (t << 7);
    let t = (x ^ (x >> 14)) & 0x0000_cccc_0000_cccc;
    x ^= t ^ (t << 14);
    let t = (x ^ (x >> 28)) & 0x0000_0000_f0f0_f0f0;
    x ^ t ^ (t << 28)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The gathering the tables replaced: every row's bit of every inked column.
    fn bit_by_bit(plane: &Bitmap, j0: usize, row_to_s_bit: &[u32]) -> Vec<(usize, u64)> {
        let rows = (plane.height() - j0).min(row_to_s_bit.len());
        (0..plane.width())
            .filter_map(|i| {
                let s =
                    (0..rows).filter(|&r| plane.get(i, j0 + r)).fold(0u64, |s, r| s | 1 << row_to_s_bit[r]);
                (s != 0).then_some((i, s))
            })
            .collect()
    }

    #[test]
    fn transpose8_moves_each_bit_across_the_diagonal() {
        for r in 0..8 {
            for c in 0..8 {
                assert_eq!(transpose8(1 << (8 * r + c)), 1 << (8 * c + r), "row {r} column {c}");
            }
        }
    }

    proptest! {
        /// Any image, band start and nozzle map (a permutation of up to 64 bits): the columns
        /// and `S` words of the bit-by-bit gathering.
        #[test]
        fn bands_are_the_bit_by_bit_gathering(
            (width, height) in (1usize..200, 1usize..40),
            seed in any::<u64>(),
            // Up to 256: every pixel inked (the solid bytes and words).
            ink_per_256 in 0u64..=256,
            map in (1usize..=64).prop_flat_map(|n| Just((0..n as u32).collect::<Vec<_>>()).prop_shuffle()),
            j0_frac in 0.0f64..1.0,
        ) {
            let mut plane = Bitmap::new(width, height);
            let mut state = seed | 1;
            for y in 0..height {
                for x in 0..width {
                    // xorshift: a reproducible pattern of the given density.
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    if state % 256 < ink_per_256 {
                        plane.set(x, y, true);
                    }
                }
            }
            let j0 = ((height as f64 * j0_frac) as usize).min(height - 1);
            let mut columns = Vec::new();
            BandGather::new(&map).collect(&plane, j0, &mut columns);
            prop_assert_eq!(columns, bit_by_bit(&plane, j0, &map));
        }
    }
}
