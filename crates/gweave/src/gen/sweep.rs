//! A sweep: one head across one band, stopping at each inked column to fire.
//!
//! At each column the head is moved onto it, the motion queue drained (`M400`: Marlin's `M700`
//! fires when parsed, not in step with the moves) and the fire command written `density` times;
//! the binder-jet seed's order drains after the fire instead ([`FireOrder::Before`]). This is
//! where a raster spends its time: about 32 bytes of G-code a column, tens of millions of columns
//! a job (88 M for the benchmark's sphere). So no number is formatted here: every text is
//! pre-formatted per head ([`HeadText`]), in slots copied whole (the padding overwritten by what
//! follows, `gcode_text::SlotTable`), and the running figures (the path's length, the drops,
//! the write position) stay in registers through a loop without a branch on the pass's
//! direction (one loop per direction, the same code).

use super::gcode_text::{push_fire, push_num, SlotTable};
use super::printhead::PrintheadProfile;
use super::raster::FireOrder;

/// Slot sizes of the pre-formatted texts: `G1 X-12345.123456789\nM400\n` is 26 bytes (positions
/// are within +-10 m, `POSITION_MM`, plus an image of at most 20 000 pixels), `M700 P9 S4095\n`
/// 14. A fire that does not fit is formatted where it is written.
const MOVE_SLOT: usize = 32;
const FIRE_SLOT: usize = 16;
/// Room for a column's text but its fires: the move (a slot), ` Y<y>` and two short texts.
const COLUMN_BYTES: usize = MOVE_SLOT + 64 + 16;
/// Room for a fire command formatted where it is written: `M<u32> P<usize> S<u64>\n`.
const FIRE_BYTES: usize = 64;
/// Nozzle counts up to this get every fire line pre-formatted (2^12 lines, about 64 KiB).
const FIRE_TABLE_MAX_NOZZLES: u32 = 12;

/// One head's texts: the move onto each column, ended as the fire order wants, and its fires.
#[derive(Debug, Clone)]
pub(crate) struct HeadText {
    /// `G1 X<x>` and the end of a later column's move (`\nM400\n`, or `\n` in the seed's order),
    /// per column, grown with the widest image ...
    moves: SlotTable<MOVE_SLOT>,
    /// ... the carriage X of each (the report's path adds them) ...
    x_mm: Vec<f64>,
    /// ... and `M700 P<h> S<bits>\n` for every `S` below 2^12 (empty for bigger heads).
    fires: SlotTable<FIRE_SLOT>,
}

impl HeadText {
    /// The fire texts of head `head`; the moves come with [`HeadText::extend`].
    pub(crate) fn new(profile: &PrintheadProfile, head: usize) -> Self {
        let mut fires = SlotTable::default();
        if profile.nozzle_count <= FIRE_TABLE_MAX_NOZZLES {
            let mut line = Vec::new();
            for s in 0..1u64 << profile.nozzle_count {
                line.clear();
                push_fire(&mut line, profile.fire_code(), head, s);
                if !fires.push(&line) {
                    // A long fire code or head number: every line formatted where it is written.
                    fires = SlotTable::default();
                    break;
                }
            }
        }
        HeadText { moves: SlotTable::default(), x_mm: Vec::new(), fires }
    }

    /// Pre-formats the moves of columns up to `width`; `x_mm(i)` is column `i`'s carriage X.
    pub(crate) fn extend(
        &mut self,
        width: usize,
        order: FireOrder,
        decimals: u32,
        x_mm: impl Fn(usize) -> f64,
    ) {
        let mut text = Vec::new();
        for i in self.x_mm.len()..width {
            let x = x_mm(i);
            text.clear();
            text.extend_from_slice(b"G1 X");
            push_num(&mut text, x, decimals);
            text.extend_from_slice(later_end(order));
            // A slot holds any position in range at up to 9 decimals (see `MOVE_SLOT`).
            let fits = self.moves.push(&text);
            debug_assert!(fits, "{}", String::from_utf8_lossy(&text));
            self.x_mm.push(x);
        }
    }
}

/// The end of the move onto a column after the pass's first: the seed's order drains after
/// the fire instead.
fn later_end(order: FireOrder) -> &'static [u8] {
    match order {
        FireOrder::After => b"\nM400\n",
        FireOrder::Before => b"\n",
    }
}

/// The drops of each fire in a [`HeadText`]'s table (`S` below 2^12: at most 12).
pub(crate) fn drops_table(profile: &PrintheadProfile) -> Vec<u8> {
    let count = if profile.nozzle_count <= FIRE_TABLE_MAX_NOZZLES { 1u64 << profile.nozzle_count } else { 0 };
    (0..count).map(|s| profile.drops_of_fire(s) as u8).collect()
}

/// One sweep's settings and texts.
pub(crate) struct Sweep<'a> {
    pub(crate) text: &'a HeadText,
    pub(crate) drops_of_s: &'a [u8],
    pub(crate) profile: &'a PrintheadProfile,
    pub(crate) head: usize,
    pub(crate) density: usize,
    pub(crate) order: FireOrder,
}

/// Where a sweep left off.
pub(crate) struct Swept {
    /// The end of the text written.
    pub(crate) end: usize,
    /// The XY path from where the carriage was, mm (the same additions, in the same order, as
    /// one move at a time: the same length to the bit).
    pub(crate) path_mm: f64,
    /// The carriage X at the last column.
    pub(crate) x_mm: f64,
    /// Drops fired, counting one fire per column (times the density for the total).
    pub(crate) drops: u64,
}

impl Sweep<'_> {
    /// Writes the sweep over `columns` (column, `S` bits; at least one, left to right) into
    /// `buf` from `pos`, in the pass's direction: the move onto the first column comes `from`
    /// the carriage's position (none before the first move, or after a recoat that moved it),
    /// with `y_text` (` Y<y>`, empty when Y has not changed) and the band's `y_mm`. `buf` grows
    /// as needed: past the text, the room it keeps is written over (`RasterWriter::filled`).
    pub(crate) fn write(
        &self,
        columns: &[(usize, u64)],
        forward: bool,
        buf: &mut Vec<u8>,
        pos: usize,
        from: Option<(f64, f64)>,
        (y_mm, y_text): (f64, &[u8]),
    ) -> Swept {
        let column_bytes = COLUMN_BYTES + self.density * FIRE_BYTES;
        let (first, rest) = match (forward, columns) {
            (true, [first, rest @ ..]) | (false, [rest @ .., first]) => (*first, rest),
            (_, []) => return Swept { end: pos, path_mm: 0.0, x_mm: 0.0, drops: 0 },
        };
        // The move onto the band: Y if it changed, the queue drained whatever the order, and
        // its length (a square root only here).
        let (i, s) = first;
        let x_mm = self.text.x_mm[i];
        let path_mm = match from {
            Some((px, py)) if py == y_mm => (x_mm - px).abs(),
            Some((px, py)) => ((x_mm - px).powi(2) + (y_mm - py).powi(2)).sqrt(),
            None => 0.0,
        };
        make_room(buf, pos, column_bytes);
        let column = &mut buf[pos..];
        let n = self.text.moves.put(i, column) - later_end(self.order).len();
        column[n..n + y_text.len()].copy_from_slice(y_text);
        let mut n = n + y_text.len();
        n += END_DRAIN.put(&mut column[n..]);
        let (fired, drops) = self.fires(s, &mut column[n..]);
        let mut swept = Swept { end: pos + n + fired, path_mm, x_mm, drops };
        // The columns along the band: the same loop each way.
        if forward {
            self.columns(rest.iter(), buf, column_bytes, &mut swept);
        } else {
            self.columns(rest.iter().rev(), buf, column_bytes, &mut swept);
        }
        swept
    }

    /// Writes the columns after a sweep's first, each with its move, its fires and (the seed's
    /// order) the drain after them.
    #[inline(always)]
    fn columns<'c>(
        &self,
        columns: impl Iterator<Item = &'c (usize, u64)>,
        buf: &mut Vec<u8>,
        column_bytes: usize,
        swept: &mut Swept,
    ) {
        // In locals, not through `swept`: a sum kept in memory is a store and a load per column
        // on the path's chain of additions.
        let (mut pos, mut path_mm, mut last_x_mm, mut drops) =
            (swept.end, swept.path_mm, swept.x_mm, swept.drops);
        for &(i, s) in columns {
            make_room(buf, pos, column_bytes);
            let column = &mut buf[pos..];
            let x_mm = self.text.x_mm[i];
            path_mm += (x_mm - last_x_mm).abs();
            last_x_mm = x_mm;
            let n = self.text.moves.put(i, column);
            let (fired, d) = self.fires(s, &mut column[n..]);
            pos += n + fired;
            drops += d;
        }
        *swept = Swept { end: pos, path_mm, x_mm: last_x_mm, drops };
    }

    /// Writes a column's fires (and, in the seed's order, the drain after them) at the start of
    /// `out`; returns their length and the drops of one fire.
    #[inline(always)]
    fn fires(&self, s: u64, out: &mut [u8]) -> (usize, u64) {
        let mut n = 0;
        let drops = if (s as usize) < self.text.fires.len() {
            for _ in 0..self.density {
                n += self.text.fires.put(s as usize, &mut out[n..]);
            }
            u64::from(self.drops_of_s[s as usize])
        } else {
            // Past the table (a head of more than 12 nozzles, a long fire code): formatted here.
            let mut fire = Vec::with_capacity(FIRE_BYTES);
            push_fire(&mut fire, self.profile.fire_code(), self.head, s);
            for _ in 0..self.density {
                out[n..n + fire.len()].copy_from_slice(&fire);
                n += fire.len();
            }
            u64::from(self.profile.drops_of_fire(s))
        };
        if self.order == FireOrder::Before {
            n += DRAIN.put(&mut out[n..]);
        }
        (n, drops)
    }
}

/// Makes room for a column's text at `pos`: 64 columns at once, zero-filled when made.
#[inline(always)]
fn make_room(buf: &mut Vec<u8>, pos: usize, column_bytes: usize) {
    if buf.len() < pos + column_bytes {
        buf.resize(pos + 64 * column_bytes, 0);
    }
}

/// A text of at most 8 bytes, zero-padded, and its length: one 8-byte copy writes it (a copy of
/// its own length is a call to `memcpy`).
struct Short([u8; 8], usize);

impl Short {
    const fn new(text: &[u8]) -> Short {
        let mut padded = [0; 8];
        let mut i = 0;
        while i < text.len() {
            padded[i] = text[i];
            i += 1;
        }
        Short(padded, text.len())
    }

    /// Copies the text to the start of `out` (which must hold 8 bytes); returns its length.
    #[inline]
    fn put(&self, out: &mut [u8]) -> usize {
        out[..8].copy_from_slice(&self.0);
        self.1
    }
}

/// The end of the move onto a pass's first column, with the `M400` that drains the queue before
/// its fire; the drain after a fire in the seed's order.
const END_DRAIN: Short = Short::new(b"\nM400\n");
const DRAIN: Short = Short::new(b"M400\n");
