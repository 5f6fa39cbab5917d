//! The rows of a plain 1-bit greyscale PNG, inflated and unfiltered here rather than by the
//! `png` crate's reader.
//!
//! A layer image of a solid part is mostly long runs of one colour, which PNG encoders often
//! filter with Paeth (PNG spec 9.4): each byte predicted from its left, upper and upper-left
//! neighbours, one byte after the other, about 6 cycles a byte in the `png` crate for one-byte
//! pixels (16 % of a raster's CPU time on the benchmark's sphere, docs/performance.md). Where a
//! row's filtered bytes are zero and the row above does not change (a part's inside, the empty
//! bed around it) every byte is its left neighbour: eight bytes are checked and written at once.
//!
//! Only a file the specification allows is read here: every chunk's CRC right, no critical
//! chunk but `IHDR`, consecutive `IDAT`s and `IEND`, the image data inflating to exactly the
//! rows, filter types 0 to 4. Anything else returns `None` and the `png` crate decodes the file
//! (or says what is wrong with it), so that errors read as before.

/// A byte repeated in every byte of a word.
const BYTES: u64 = 0x0101_0101_0101_0101;

/// The unfiltered rows of `data`, a non-interlaced 1-bit greyscale PNG of `width` x `height` px
/// (its header checked by the caller), each `1 + ceil(width / 8)` bytes: the filter type, then
/// the pixels. `None` when the file is not as described above.
pub(super) fn rows(data: &[u8], width: usize, height: usize) -> Option<Vec<u8>> {
    // Compression and filter method 0 (PNG spec 11.2.2: IHDR's bytes 10 and 11).
    if width == 0 || height == 0 || data.get(26..28)? != [0, 0] {
        return None;
    }
    let stride = 1 + width.div_ceil(8);
    let size = stride.checked_mul(height)?;
    let compressed = image_data(data)?;
    let mut raw = fdeflate::decompress_to_vec_bounded(&compressed, size).ok()?;
    if raw.len() != size {
        return None;
    }
    unfilter(&mut raw, stride)?;
    Some(raw)
}

/// The `IDAT` chunks' data, joined; `None` for a bad CRC, a critical chunk other than `IHDR`
/// (first), `IDAT` and `IEND`, `IDAT`s apart, or no `IEND`.
fn image_data(data: &[u8]) -> Option<Vec<u8>> {
    let (mut at, mut compressed, mut idat_ended) = (8, Vec::new(), false);
    loop {
        let length = u32::from_be_bytes(data.get(at..at + 4)?.try_into().ok()?) as usize;
        let end = (at + 8).checked_add(length)?;
        let chunk = data.get(at + 4..end)?;
        let crc = u32::from_be_bytes(data.get(end..end + 4)?.try_into().ok()?);
        if crc32fast::hash(chunk) != crc {
            return None;
        }
        let (kind, body) = chunk.split_at(4);
        match kind {
            b"IHDR" if at == 8 => {}
            b"IDAT" if !idat_ended => compressed.extend_from_slice(body),
            b"IEND" => return Some(compressed),
            // An ancillary chunk (lower-case first letter) says nothing about the pixels.
            _ if kind[0].is_ascii_lowercase() => idat_ended |= !compressed.is_empty(),
            _ => return None,
        }
        at = end + 4;
    }
}

/// Undoes each row's filter in place (PNG spec 9.2, one byte a pixel: `a` is the byte to the
/// left, `b` the one above, `c` above-left, 0 past the image's edges).
fn unfilter(raw: &mut [u8], stride: usize) -> Option<()> {
    let zeros = vec![0u8; stride - 1];
    for y in 0..raw.len() / stride {
        let (above, rest) = raw.split_at_mut(y * stride);
        let prev = if y == 0 { &zeros[..] } else { &above[above.len() - stride + 1..] };
        let (kind, cur) = rest[..stride].split_first_mut()?;
        match *kind {
            0 => {}
            1 => {
                let mut a = 0u8;
                for x in cur.iter_mut() {
                    *x = x.wrapping_add(a);
                    a = *x;
                }
            }
            2 => cur.iter_mut().zip(prev).for_each(|(x, b)| *x = x.wrapping_add(*b)),
            3 => {
                let mut a = 0u8;
                for (x, &b) in cur.iter_mut().zip(prev) {
                    *x = x.wrapping_add(((u16::from(a) + u16::from(b)) / 2) as u8);
                    a = *x;
                }
            }
            4 => unpaeth(cur, prev),
            _ => return None,
        }
    }
    Some(())
}

/// Undoes the Paeth filter of one row: eight bytes at once where they are zero and the row
/// above them equals the byte above-left (each then predicts its left neighbour, PNG spec
/// 9.4: `|b - c| = 0` is the smallest distance), else byte by byte.
fn unpaeth(cur: &mut [u8], prev: &[u8]) {
    let (mut a, mut c) = (0u8, 0u8);
    let mut i = 0;
    while i < cur.len() {
        if let (Some(x), Some(b)) = (cur.get_mut(i..i + 8), prev.get(i..i + 8)) {
            let run = u64::from_ne_bytes((&*x).try_into().unwrap_or_default()) == 0
                && u64::from_ne_bytes(b.try_into().unwrap_or_default()) == u64::from(c) * BYTES;
            if run {
                x.copy_from_slice(&(u64::from(a) * BYTES).to_ne_bytes());
                i += 8;
                continue;
            }
        }
        // Byte by byte until the next eight (a run's check per byte would cost more than it
        // saves where the image changes).
        let end = (i + 8).min(cur.len());
        for (x, &b) in cur[i..end].iter_mut().zip(&prev[i..end]) {
            *x = x.wrapping_add(paeth(a, b, c));
            (a, c) = (*x, b);
        }
        i = end;
    }
}

/// The Paeth predictor (PNG spec 9.4): of `a`, `b` and `c`, the one nearest `a + b - c`, ties
/// in that order.
fn paeth(a: u8, b: u8, c: u8) -> u8 {
    let (a16, b16, c16) = (i16::from(a), i16::from(b), i16::from(c));
    let p = a16 + b16 - c16;
    let (pa, pb, pc) = ((p - a16).abs(), (p - b16).abs(), (p - c16).abs());
    if pa <= pb && pa <= pc {
        a
    } else if pb <= pc {
        b
    } else {
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A 1-bit greyscale PNG of `rows` (packed, MSB first) with every row filtered by `filter`.
    fn encode(width: u32, rows: &[Vec<u8>], filter: png::Filter) -> Vec<u8> {
        let mut out = Vec::new();
        let mut e = png::Encoder::new(&mut out, width, rows.len() as u32);
        e.set_color(png::ColorType::Grayscale);
        e.set_depth(png::BitDepth::One);
        e.set_filter(filter);
        let mut w = e.write_header().unwrap();
        w.write_image_data(&rows.concat()).unwrap();
        w.finish().unwrap();
        out
    }

    /// The `png` crate's reading of the same file, with the filter bytes put back as zeros.
    fn png_crate_rows(data: &[u8]) -> Vec<u8> {
        let mut reader = png::Decoder::new(std::io::Cursor::new(data)).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let line = reader.next_frame(&mut buf).unwrap().line_size;
        buf.chunks(line).flat_map(|row| std::iter::once(0).chain(row.iter().copied())).collect()
    }

    proptest! {
        /// Every filter, images of runs (the fast path) and of noise (byte by byte): the `png`
        /// crate's rows, byte for byte.
        #[test]
        fn rows_are_the_png_crates(
            width in 1usize..150,
            height in 1usize..12,
            seed in any::<u64>(),
            run_per_256 in 0u64..=256,
            filter in prop::sample::select(vec![
                png::Filter::NoFilter, png::Filter::Sub, png::Filter::Up, png::Filter::Avg,
                png::Filter::Paeth, png::Filter::Adaptive,
            ]),
        ) {
            let row_bytes = width.div_ceil(8);
            let mut state = seed | 1;
            let mut next = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state
            };
            // Each byte continues the row's run (0x00 or 0xff) or is noise.
            let image: Vec<Vec<u8>> = (0..height)
                .map(|_| {
                    let mut run = if next() % 2 == 0 { 0u8 } else { 0xff };
                    (0..row_bytes)
                        .map(|_| {
                            let r = next();
                            if r % 256 < run_per_256 { run } else { run = (r >> 8) as u8; run }
                        })
                        .collect()
                })
                .collect();
            let data = encode(width as u32, &image, filter);
            let mut raw = rows(&data, width, height).expect("a valid file is read here");
            for row in raw.chunks_mut(1 + row_bytes) {
                row[0] = 0;
            }
            prop_assert_eq!(raw, png_crate_rows(&data));
        }
    }

    #[test]
    fn a_file_out_of_the_specification_goes_to_the_png_crate() {
        let rows_in = vec![vec![0xff, 0x0f], vec![0x00, 0xf0]];
        let data = encode(16, &rows_in, png::Filter::Paeth);
        // The encoder does filter 1-bit rows (Paeth is type 4), and they come back.
        let raw = rows(&data, 16, 2).unwrap();
        assert_eq!((raw[0], raw[3]), (4, 4));
        assert_eq!((&raw[1..3], &raw[4..6]), (&rows_in[0][..], &rows_in[1][..]));
        // A bad CRC, a truncated file, a missing IEND, too few rows, an unknown critical chunk.
        let mut bad_crc = data.clone();
        let last = bad_crc.len() - 13;
        bad_crc[last] ^= 1;
        assert_eq!(rows(&bad_crc, 16, 2), None);
        assert_eq!(rows(&data[..data.len() - 20], 16, 2), None);
        assert_eq!(rows(&data[..data.len() - 12], 16, 2), None);
        assert_eq!(rows(&data, 16, 3), None);
        let mut critical = data[..33].to_vec();
        critical.extend_from_slice(&[0, 0, 0, 0]);
        critical.extend_from_slice(b"XXXX");
        critical.extend_from_slice(&crc32fast::hash(b"XXXX").to_be_bytes());
        critical.extend_from_slice(&data[33..]);
        assert_eq!(rows(&critical, 16, 2), None);
    }
}
