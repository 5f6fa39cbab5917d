//! 1-bit layer images for raster printing, packed 64 pixels to a `u64` word.
//!
//! Pixel `(x, y)` is bit `x % 64` of word `y * words_per_row + x / 64`; row 0 is the first row
//! of the file (the top of the picture). Bits past the width are always zero, so whole-word
//! operations (OR over a band, popcount) need no masking.
//!
//! Loading decodes a BMP, PNG or TIFF with the `image` crate (grey, grey+alpha, RGB, RGBA,
//! palette, 1 to 16 bits a sample) into one 8-bit channel, then thresholds it: a pixel is "ink"
//! when its value is at least `threshold * 255` (50 % by default), like an SLA mask where lit =
//! solid. `invert` swaps that for images where dark means binder. Transparent pixels count as
//! dark. 1-bit greyscale PNGs (what `slice-raster` and most layer exporters write, and what the
//! raster benchmark reads) take a faster path that moves the packed rows straight into words.

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::picture::{write_png, Pixels};
use crate::range::{self, count, MAX_IMAGE_SIDE_PX};

/// Errors from reading or writing layer images.
#[derive(Debug, Error)]
pub enum BitmapError {
    /// An image file cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// Writing the image file (see [`crate::gcode::writer::write_file`]).
    #[error(transparent)]
    Output(#[from] crate::error::Error),
    /// A PNG cannot be decoded.
    #[error("PNG decode: {0}")]
    PngDecode(#[from] png::DecodingError),
    /// A PNG cannot be encoded.
    #[error("PNG encode: {0}")]
    PngEncode(#[from] png::EncodingError),
    /// Decoding a BMP, PNG or TIFF (the `image` crate; its message names the format's problem).
    #[error("image decode: {0}")]
    Decode(#[from] image::ImageError),
    /// A file that is neither BMP, PNG nor TIFF.
    #[error("unsupported image format (expected BMP, PNG or TIFF)")]
    UnknownFormat,
    /// Resampling would make an image larger than [`MAX_IMAGE_SIDE_PX`] on a side.
    #[error("resampled to the nozzle pitch, the image would be {width} x {height} px, more than the limit of {} px per side", MAX_IMAGE_SIDE_PX)]
    Resampled {
        /// The resampled width, px (text, as it may not fit a number).
        width: String,
        /// The resampled height, px.
        height: String,
    },
    /// An image file whose header gives a size past [`max_side_px`], refused before it is
    /// decoded.
    #[error("the image is {width} x {height} px, more than the limit of {limit} px per side at {pixel_mm} mm a pixel (the largest bed, {bed_mm} mm, and at most {} px)", MAX_IMAGE_SIDE_PX)]
    ImageSize {
        /// The width the header gives, px.
        width: u64,
        /// The height, px.
        height: u64,
        /// The most allowed per side, px.
        limit: u64,
        /// The pixel size the image is printed at, mm (as text, short).
        pixel_mm: String,
        /// The largest bed, mm.
        bed_mm: f64,
    },
    /// An image whose decoded pixels would take more than the `image` crate's allocation limit.
    #[error("the image is {width} x {height} px of {colour}: {mb} MiB decoded, more than the {limit_mb} MiB an image may take; save it as 8-bit greyscale (a byte a pixel) or 1-bit")]
    DecodedSize {
        /// The width, px.
        width: u32,
        /// The height, px.
        height: u32,
        /// The pixel format, as the decoder names it (`Rgb8`).
        colour: String,
        /// What the decoded pixels take, MiB.
        mb: u64,
        /// The most an image may take decoded, MiB.
        limit_mb: u64,
    },
    /// A pixel buffer of the wrong length for its size.
    #[error("pixel buffer has {got} values, expected {expected}")]
    BufferSize {
        /// Values the size needs.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// A pattern that matches no file.
    #[error("no images match {0}")]
    NoImages(PathBuf),
    /// A threshold outside 0 to 1.
    #[error("invalid threshold {0} (expected 0..=1)")]
    Threshold(f64),
    /// A pixel size that is not a positive number of mm.
    #[error("invalid pixel size {0} mm")]
    PixelSize(f64),
}

/// Which channel of a colour image becomes the layer mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Channel {
    /// Rec. 601 luma `(299 R + 587 G + 114 B) / 1000`.
    #[default]
    Luma,
    /// The red channel only.
    Red,
    /// The green channel only.
    Green,
    /// The blue channel only.
    Blue,
}

/// How an 8-bit image becomes 1-bit.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ThresholdOptions {
    /// Fraction of full scale at or above which a pixel is ink (default 0.5).
    pub threshold: f64,
    /// Dark pixels are ink instead of light ones.
    pub invert: bool,
    /// Channel of colour images to use.
    pub channel: Channel,
}

impl Default for ThresholdOptions {
    fn default() -> Self {
        ThresholdOptions { threshold: 0.5, invert: false, channel: Channel::Luma }
    }
}

impl ThresholdOptions {
    /// The smallest 8-bit value counted as lit: `ceil(threshold * 255)`.
    fn cutoff(&self) -> Result<u16, BitmapError> {
        if !(0.0..=1.0).contains(&self.threshold) {
            return Err(BitmapError::Threshold(self.threshold));
        }
        Ok((self.threshold * 255.0).ceil() as u16)
    }
}

/// A packed 1-bit image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Bitmap {
    width: usize,
    height: usize,
    words_per_row: usize,
    words: Vec<u64>,
}

impl Bitmap {
    /// An all-empty image.
    pub fn new(width: usize, height: usize) -> Self {
        let words_per_row = width.div_ceil(64);
        Bitmap { width, height, words_per_row, words: vec![0; words_per_row * height] }
    }

    /// The bytes a `width` x `height` image holds (its rows packed into 64-bit words), before
    /// it is made: what a caller holds an image's size to.
    pub fn bytes_for(width: usize, height: usize) -> u64 {
        width.div_ceil(64) as u64 * 8 * height as u64
    }

    /// Width, px.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height, px.
    pub fn height(&self) -> usize {
        self.height
    }

    /// 64-bit words per row of the packed bits.
    pub fn words_per_row(&self) -> usize {
        self.words_per_row
    }

    /// The packed words of row `y` (bits past the width are zero).
    pub fn row(&self, y: usize) -> &[u64] {
        &self.words[y * self.words_per_row..(y + 1) * self.words_per_row]
    }

    /// Pixel value; outside the image is empty.
    pub fn get(&self, x: usize, y: usize) -> bool {
        x < self.width && y < self.height && self.row(y)[x / 64] >> (x % 64) & 1 == 1
    }

    /// Sets a pixel; outside the image is ignored and returns false.
    pub fn set(&mut self, x: usize, y: usize, on: bool) -> bool {
        if x >= self.width || y >= self.height {
            return false;
        }
        let w = &mut self.words[y * self.words_per_row + x / 64];
        let bit = 1u64 << (x % 64);
        if on {
            *w |= bit;
        } else {
            *w &= !bit;
        }
        true
    }

    /// Clears row `y` (outside the image: nothing).
    pub fn clear_row(&mut self, y: usize) {
        if y < self.height {
            self.words[y * self.words_per_row..(y + 1) * self.words_per_row].fill(0);
        }
    }

    /// Sets pixels `x0..x1` of row `y` (clipped to the image), a word at a time.
    pub fn fill_span(&mut self, y: usize, x0: usize, x1: usize) {
        let x1 = x1.min(self.width);
        if y >= self.height || x0 >= x1 {
            return;
        }
        let row = &mut self.words[y * self.words_per_row..(y + 1) * self.words_per_row];
        let (w0, w1) = (x0 / 64, (x1 - 1) / 64);
        // Mask of bits >= x0 in the first word and bits < x1 in the last word.
        let lo = u64::MAX << (x0 % 64);
        let hi = u64::MAX >> (63 - (x1 - 1) % 64);
        if w0 == w1 {
            row[w0] |= lo & hi;
        } else {
            row[w0] |= lo;
            for w in &mut row[w0 + 1..w1] {
                *w = u64::MAX;
            }
            row[w1] |= hi;
        }
    }

    /// The ink pixels `(x, y)`, row by row, skipping empty words.
    pub fn ones(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.words.iter().enumerate().flat_map(move |(wi, &word)| {
            let (y, x0) = (wi / self.words_per_row, (wi % self.words_per_row) * 64);
            let mut rest = word;
            std::iter::from_fn(move || {
                (rest != 0).then(|| {
                    let bit = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    (x0 + bit, y)
                })
            })
        })
    }

    /// Number of ink pixels.
    pub fn count_ones(&self) -> u64 {
        self.words.iter().map(|w| u64::from(w.count_ones())).sum()
    }

    /// Builds a bitmap from rows of 8-bit levels (`row(y)` has `width` values), ink where
    /// `level >= cutoff` (xor invert). The fast path for greyscale sources.
    fn from_level_rows<'a>(
        width: usize,
        height: usize,
        row: impl Fn(usize) -> &'a [u8],
        cutoff: u16,
        invert: bool,
    ) -> Self {
        let mut b = Bitmap::new(width, height);
        for y in 0..height {
            let words = &mut b.words[y * b.words_per_row..(y + 1) * b.words_per_row];
            for (word, levels) in words.iter_mut().zip(row(y)[..width].chunks(64)) {
                *word = levels
                    .iter()
                    .enumerate()
                    .fold(0u64, |v, (bit, &l)| v | u64::from((u16::from(l) >= cutoff) != invert) << bit);
            }
        }
        b
    }

    /// Thresholds a single-channel 8-bit image (`grey.len() == width * height`).
    pub fn from_grey(
        width: usize,
        height: usize,
        grey: &[u8],
        opts: &ThresholdOptions,
    ) -> Result<Self, BitmapError> {
        if grey.len() != width * height {
            return Err(BitmapError::BufferSize { expected: width * height, got: grey.len() });
        }
        let cutoff = opts.cutoff()?;
        Ok(Self::from_level_rows(width, height, |y| &grey[y * width..(y + 1) * width], cutoff, opts.invert))
    }

    /// Resamples to a new pixel size by nearest neighbour at target pixel centres: target pixel
    /// `i` has its centre at `(i + 1/2) * dst_px_mm` and takes the source pixel containing it.
    /// The target keeps every pixel whose centre lies inside the source extent,
    /// i.e. `round(width * src / dst)` columns.
    pub fn resample(&self, src_px_x_mm: f64, src_px_y_mm: f64, dst_px_mm: f64) -> Result<Self, BitmapError> {
        for v in [src_px_x_mm, src_px_y_mm, dst_px_mm] {
            if !(v.is_finite() && v > 0.0) {
                return Err(BitmapError::PixelSize(v));
            }
        }
        // The new size, checked before anything is allocated (a 1e6 mm source pixel would make
        // a terabyte image).
        let pixels = |n: usize, src: f64| (n as f64 * src / dst_px_mm + 0.5).floor();
        let (w, h) = (pixels(self.width, src_px_x_mm), pixels(self.height, src_px_y_mm));
        if w.max(h) > MAX_IMAGE_SIDE_PX as f64 {
            return Err(BitmapError::Resampled { width: count(w), height: count(h) });
        }
        let map = |n: usize, src: f64| -> Vec<usize> {
            let count = pixels(n, src) as usize;
            (0..count).map(|i| (((i as f64 + 0.5) * dst_px_mm / src) as usize).min(n - 1)).collect()
        };
        if self.width == 0 || self.height == 0 {
            return Ok(Bitmap::new(0, 0));
        }
        let xs = map(self.width, src_px_x_mm);
        let ys = map(self.height, src_px_y_mm);
        let mut out = Bitmap::new(xs.len(), ys.len());
        for (y, &sy) in ys.iter().enumerate() {
            let src = self.row(sy);
            let dst = &mut out.words[y * out.words_per_row..(y + 1) * out.words_per_row];
            for (x, &sx) in xs.iter().enumerate() {
                dst[x / 64] |= (src[sx / 64] >> (sx % 64) & 1) << (x % 64);
            }
        }
        Ok(out)
    }

    /// Flips left-right.
    pub fn mirror_x(&self) -> Self {
        let mut out = Bitmap::new(self.width, self.height);
        for y in 0..self.height {
            for x in 0..self.width {
                if self.get(x, y) {
                    out.set(self.width - 1 - x, y, true);
                }
            }
        }
        out
    }

    /// Flips top-bottom.
    pub fn mirror_y(&self) -> Self {
        let mut out = Bitmap::new(self.width, self.height);
        for y in 0..self.height {
            let (a, b) = (y * self.words_per_row, (self.height - 1 - y) * self.words_per_row);
            out.words[b..b + self.words_per_row].copy_from_slice(&self.words[a..a + self.words_per_row]);
        }
        out
    }

    /// Writes a 1-bit greyscale PNG (ink = white, like an SLA mask).
    pub fn write_png<W: Write>(&self, out: W) -> Result<(), BitmapError> {
        let stride = self.width.div_ceil(8);
        let mut data = vec![0u8; stride * self.height];
        for y in 0..self.height {
            for x in 0..self.width {
                if self.get(x, y) {
                    // PNG packs the leftmost pixel in the most significant bit.
                    data[y * stride + x / 8] |= 0x80 >> (x % 8);
                }
            }
        }
        write_png(out, self.width as u32, self.height as u32, Pixels::Grey1(&data))?;
        Ok(())
    }

    /// Writes a 1-bit PNG file.
    pub fn save_png(&self, path: &Path) -> Result<(), BitmapError> {
        crate::gcode::writer::write_file(path, |out| self.write_png(out))
    }
}

fn io_err(path: &Path, source: std::io::Error) -> BitmapError {
    BitmapError::Io { path: path.to_path_buf(), source }
}

/// Decodes a BMP, PNG or TIFF (recognised by its signature) and thresholds it.
pub fn decode(data: &[u8], opts: &ThresholdOptions, pixel_mm: f64) -> Result<Bitmap, BitmapError> {
    let cutoff = opts.cutoff()?;
    if is_plain_1bit_grey_png(data) {
        // IHDR's width and height (big-endian, PNG spec 11.2.2), before anything is inflated.
        let field =
            |at: usize| u64::from(u32::from_be_bytes([data[at], data[at + 1], data[at + 2], data[at + 3]]));
        check_size(field(16), field(20), pixel_mm)?;
        return decode_png_1bit(data, opts);
    }
    let reader = || {
        image::ImageReader::new(Cursor::new(data)).with_guessed_format().map_err(image::ImageError::IoError)
    };
    if !matches!(
        reader()?.format(),
        Some(image::ImageFormat::Bmp | image::ImageFormat::Png | image::ImageFormat::Tiff)
    ) {
        return Err(BitmapError::UnknownFormat);
    }
    // The header's size (the decoder reads no pixel for it), checked before decoding.
    let (width, height) = reader()?.into_dimensions()?;
    check_size(u64::from(width), u64::from(height), pixel_mm)?;
    // What the decoded pixels take: the `image` crate refuses more than its allocation limit
    // with a bare "Memory limit exceeded"; say the size, its cause and the way out instead.
    let decoder = reader()?.into_decoder()?;
    let (bytes, colour) =
        (image::ImageDecoder::total_bytes(&decoder), image::ImageDecoder::color_type(&decoder));
    let limit = image::Limits::default().max_alloc.unwrap_or(u64::MAX);
    if bytes > limit {
        let mb = |b: u64| b.div_ceil(1 << 20);
        let colour = format!("{colour:?}");
        return Err(BitmapError::DecodedSize { width, height, colour, mb: mb(bytes), limit_mb: mb(limit) });
    }
    drop(decoder);
    let img = reader()?.decode()?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let colour = img.color();
    // One 8-bit level per pixel: grey as it is, colour through the chosen channel, both
    // composited over black by their alpha.
    let levels: Vec<u8> = match (colour.has_color(), colour.has_alpha()) {
        (false, false) => img.into_luma8().into_raw(),
        (false, true) => img.into_luma_alpha8().pixels().map(|p| scale_alpha(p[0], p[1])).collect(),
        (true, false) => img.into_rgb8().pixels().map(|p| pick(opts.channel, p[0], p[1], p[2])).collect(),
        (true, true) => img
            .into_rgba8()
            .pixels()
            .map(|p| scale_alpha(pick(opts.channel, p[0], p[1], p[2]), p[3]))
            .collect(),
    };
    Ok(Bitmap::from_level_rows(w, h, |y| &levels[y * w..(y + 1) * w], cutoff, opts.invert))
}

/// Is this a non-interlaced 1-bit greyscale PNG? IHDR is the first chunk (PNG spec 11.2.2):
/// signature (8), length (4), "IHDR" (4), width (4), height (4), then bit depth at byte 24,
/// colour type at 25 and interlace method at 28.
fn is_plain_1bit_grey_png(data: &[u8]) -> bool {
    data.starts_with(b"\x89PNG")
        && data.len() > 28
        && &data[12..16] == b"IHDR"
        && data[24] == 1
        && data[25] == 0
        && data[28] == 0
}

/// Fast path for 1-bit greyscale PNGs: the packed rows are moved into the bitmap's words without
/// expanding each pixel to a byte (the `image` crate's path, decoding to 8 bits a pixel and
/// thresholding, took 7.3 times as long on 100 of the raster benchmark's 2000 x 2000 layers:
/// 1.95 s against 0.27 s, docs/performance.md). PNG packs pixel `x` into bit `7 - x % 8` of
/// byte `x / 8` (MSB first); the bitmap wants bit `x % 64` of word `x / 64`, so eight bytes are
/// read as a big-endian word whose bits are reversed. A set bit is level 255, a clear
/// one level 0, thresholded as usual.
fn decode_png_1bit(data: &[u8], opts: &ThresholdOptions) -> Result<Bitmap, BitmapError> {
    let cutoff = opts.cutoff()?;
    let mut reader = png::Decoder::new(Cursor::new(data)).read_info()?;
    let (w, h) = (reader.info().width as usize, reader.info().height as usize);
    // None: the frame would not fit in memory's address space.
    let too_large = || {
        image::ImageError::Limits(image::error::LimitError::from_kind(
            image::error::LimitErrorKind::InsufficientMemory,
        ))
    };
    let size = reader.output_buffer_size().ok_or_else(too_large)?;
    let mut buf = vec![0u8; size];
    let stride = reader.next_frame(&mut buf)?.line_size;
    // A set bit is level 255, a clear one level 0: which of them the threshold inks.
    let lit = |level_lit: bool| if level_lit { u64::MAX } else { 0 };
    let (one_lit, zero_lit) = (lit((cutoff <= 255) != opts.invert), lit((cutoff == 0) != opts.invert));
    let inked = |packed: u64| (packed & one_lit) | (!packed & zero_lit);
    let mut b = Bitmap::new(w, h);
    let wpr = b.words_per_row;
    // The last word's bits past the width stay clear.
    let last_mask = u64::MAX >> (64 * wpr - w);
    for y in 0..h {
        let row = &buf[y * stride..y * stride + w.div_ceil(8)];
        let words = &mut b.words[y * wpr..(y + 1) * wpr];
        // Whole words straight from the row (a copy of a variable length per word was a call
        // to `memcpy`), then the row's last bytes padded.
        let (whole, tail) = row.as_chunks::<8>();
        for (word, bytes) in words.iter_mut().zip(whole) {
            // Read big-endian, the first byte's first pixel is the word's top bit: reversing
            // the whole word puts pixel `x` at bit `x` (one reversal of 64 bits, not eight of 8).
            *word = inked(u64::from_be_bytes(*bytes).reverse_bits());
        }
        if !tail.is_empty() {
            let mut bytes = [0u8; 8];
            bytes[..tail.len()].copy_from_slice(tail);
            words[whole.len()] = inked(u64::from_be_bytes(bytes).reverse_bits());
        }
        if let Some(last) = words.last_mut() {
            *last &= last_mask;
        }
    }
    Ok(b)
}

/// Composites over black: transparent pixels are dark.
fn scale_alpha(v: u8, a: u8) -> u8 {
    ((u16::from(v) * u16::from(a) + 127) / 255) as u8
}

fn pick(channel: Channel, r: u8, g: u8, b: u8) -> u8 {
    match channel {
        Channel::Luma => ((299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b) + 500) / 1000) as u8,
        Channel::Red => r,
        Channel::Green => g,
        Channel::Blue => b,
    }
}

/// Loads a BMP, PNG or TIFF file whose pixels are printed `pixel_mm` wide and thresholds it
/// ([`decode`]).
pub fn load_image(path: &Path, opts: &ThresholdOptions, pixel_mm: f64) -> Result<Bitmap, BitmapError> {
    let data = std::fs::read(path).map_err(|e| io_err(path, e))?;
    decode(&data, opts, pixel_mm)
}

/// The most pixels a layer image printed at `pixel_mm` a pixel may have on a side: as many as
/// cover the largest bed ([`range::BED_SIZE_MM`], 10 m), and at most [`MAX_IMAGE_SIDE_PX`]
/// (what decoding and rastering one layer may hold). A 60 000 x 60 000 1-bit PNG is 557 KB on
/// disk but 450 MB decoded and 7 GB of G-code, so its header is checked before anything else.
pub fn max_side_px(pixel_mm: f64) -> u64 {
    let bed_px = (range::BED_SIZE_MM.max / pixel_mm).floor();
    if bed_px.is_finite() && bed_px >= 0.0 {
        MAX_IMAGE_SIDE_PX.min(bed_px as u64)
    } else {
        MAX_IMAGE_SIDE_PX
    }
}

/// `width` x `height` (from an image header) within [`max_side_px`] of `pixel_mm`.
fn check_size(width: u64, height: u64, pixel_mm: f64) -> Result<(), BitmapError> {
    let limit = max_side_px(pixel_mm);
    if width.max(height) <= limit {
        return Ok(());
    }
    let (pixel_mm, bed_mm) = (range::short(pixel_mm), range::BED_SIZE_MM.max);
    Err(BitmapError::ImageSize { width, height, limit, pixel_mm, bed_mm })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> ThresholdOptions {
        ThresholdOptions::default()
    }

    #[test]
    fn one_bit_png_fast_path_equals_the_expanding_decoder() {
        // 70 x 3: a row that ends inside a byte and spans two words.
        let mut src = Bitmap::new(70, 3);
        for (x, y) in [(0, 0), (7, 0), (8, 1), (63, 1), (64, 2), (69, 2), (33, 0)] {
            src.set(x, y, true);
        }
        let mut png_bytes = Vec::new();
        src.write_png(&mut png_bytes).unwrap();
        assert!(is_plain_1bit_grey_png(&png_bytes));
        for o in [
            opts(),
            ThresholdOptions { invert: true, ..opts() },
            ThresholdOptions { threshold: 0.0, ..opts() },
            ThresholdOptions { threshold: 0.0, invert: true, ..opts() },
        ] {
            let fast = decode_png_1bit(&png_bytes, &o).unwrap();
            let reader = image::ImageReader::new(Cursor::new(&png_bytes)).with_guessed_format().unwrap();
            let grey = reader.decode().unwrap().into_luma8();
            let slow = Bitmap::from_grey(70, 3, grey.as_raw(), &o).unwrap();
            assert_eq!(fast, slow, "{o:?}");
        }
        assert_eq!(decode_png_1bit(&png_bytes, &opts()).unwrap(), src);
        assert_eq!(
            decode_png_1bit(&png_bytes, &ThresholdOptions { invert: true, ..opts() }).unwrap().count_ones(),
            70 * 3 - 7
        );
    }

    #[test]
    fn a_cleared_row_is_empty_and_the_others_stay() {
        let mut b = Bitmap::new(70, 3);
        b.fill_span(0, 0, 70);
        b.fill_span(1, 3, 66);
        b.clear_row(1);
        b.clear_row(7);
        assert_eq!((b.count_ones(), b.row(1)), (70, &[0, 0][..]));
        // Two words a row of 70: what `new` holds.
        assert_eq!(Bitmap::bytes_for(70, 3), 48);
        assert_eq!(Bitmap::bytes_for(20_000, 20_000), 50_080_000);
    }

    #[test]
    fn threshold_is_half_scale() {
        let b = Bitmap::from_grey(4, 1, &[0, 127, 128, 255], &opts()).unwrap();
        assert_eq!((0..4).map(|x| b.get(x, 0)).collect::<Vec<_>>(), [false, false, true, true]);
        let inv = ThresholdOptions { invert: true, ..opts() };
        let b = Bitmap::from_grey(4, 1, &[0, 127, 128, 255], &inv).unwrap();
        assert_eq!(b.count_ones(), 2);
        assert!(b.get(0, 0) && b.get(1, 0));
        let bad = ThresholdOptions { threshold: 1.5, ..opts() };
        assert!(matches!(Bitmap::from_grey(1, 1, &[0], &bad), Err(BitmapError::Threshold(_))));
    }

    #[test]
    fn words_are_packed_and_padding_clear() {
        let mut b = Bitmap::new(70, 2);
        assert_eq!(b.words_per_row(), 2);
        assert!(b.set(69, 1, true));
        assert!(!b.set(70, 1, true));
        assert_eq!(b.row(1), &[0, 1 << 5]);
        assert_eq!(b.count_ones(), 1);
        b.set(3, 0, true);
        assert_eq!(b.ones().collect::<Vec<_>>(), [(3, 0), (69, 1)]);
        assert_eq!(b.mirror_x().row(1), &[1, 0]);
        assert_eq!(b.mirror_y().row(0), &[0, 1 << 5]);
        let mut f = Bitmap::new(200, 1);
        f.fill_span(0, 3, 3);
        assert_eq!(f.count_ones(), 0);
        f.fill_span(0, 62, 130);
        f.fill_span(0, 5, 7);
        f.fill_span(0, 190, 999);
        assert_eq!(f.count_ones(), 68 + 2 + 10);
        assert!(!f.get(61, 0) && f.get(62, 0) && f.get(129, 0) && !f.get(130, 0));
        assert!(f.get(5, 0) && f.get(6, 0) && !f.get(7, 0) && f.get(199, 0));
        assert_eq!(f.row(0)[3] >> 8, 0, "padding past the width stays clear");
    }

    /// Regression: `raster --pixel-mm 1e6` aborted on a terabyte image; the resampled size is
    /// checked before anything is allocated.
    #[test]
    fn resampling_past_the_side_limit_is_refused() {
        let b = Bitmap::new(4, 3);
        let err = b.resample(1e6, 1e6, 25.4 / 96.0).unwrap_err();
        assert_eq!(
            err.to_string(),
            "resampled to the nozzle pitch, the image would be 15118110 x 11338583 px, more than the limit of 20000 px per side"
        );
        assert_eq!(b.resample(1.0, 1.0, 0.5).unwrap().width(), 8);
    }

    #[test]
    fn resample_nearest_at_centres() {
        // 0.2 mm source to 0.5 mm target: 10 px * 0.2 = 2 mm -> 4 target px, centres at
        // 0.25, 0.75, 1.25, 1.75 mm -> source px 1, 3, 6, 8.
        let mut b = Bitmap::new(10, 1);
        for x in [1, 6] {
            b.set(x, 0, true);
        }
        let r = b.resample(0.2, 0.2, 0.5).unwrap();
        assert_eq!((r.width(), r.height()), (4, 0));
        let mut b = Bitmap::new(10, 3);
        for x in [1, 6] {
            b.set(x, 2, true);
        }
        let r = b.resample(0.2, 0.4, 0.5).unwrap();
        assert_eq!((r.width(), r.height()), (4, 2));
        // target row 1 centre 0.75 mm -> source row 1 (0.4 mm rows): empty.
        assert_eq!(r.count_ones(), 0);
        let r = b.resample(0.2, 1.0, 0.5).unwrap();
        assert_eq!(r.height(), 6);
        // target rows 4,5 (centres 2.25, 2.75 mm) -> source row 2.
        assert!(r.get(0, 4) && r.get(2, 5) && !r.get(1, 4) && !r.get(3, 5));
        assert_eq!(r.count_ones(), 4);
    }

    #[test]
    fn png_roundtrip_1bit_and_grey_alpha() {
        let mut b = Bitmap::new(13, 3);
        b.set(0, 0, true);
        b.set(12, 2, true);
        b.set(7, 1, true);
        let mut buf = Vec::new();
        b.write_png(&mut buf).unwrap();
        assert_eq!(decode(&buf, &opts(), 0.1).unwrap(), b);

        let mut buf = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut buf, 3, 1);
            enc.set_color(png::ColorType::GrayscaleAlpha);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().unwrap();
            // white opaque, white transparent, white half alpha (255*128/255 = 128 -> lit)
            w.write_image_data(&[255, 255, 255, 0, 255, 128]).unwrap();
        }
        let g = decode(&buf, &opts(), 0.1).unwrap();
        assert_eq!((g.get(0, 0), g.get(1, 0), g.get(2, 0)), (true, false, true));
    }

    #[test]
    fn png_rgb_channels() {
        let mut buf = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut buf, 2, 1);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().unwrap();
            w.write_image_data(&[255, 0, 0, 0, 0, 255]).unwrap();
        }
        let get = |channel| {
            let b = decode(&buf, &ThresholdOptions { channel, ..opts() }, 0.1).unwrap();
            (b.get(0, 0), b.get(1, 0))
        };
        assert_eq!(get(Channel::Red), (true, false));
        assert_eq!(get(Channel::Blue), (false, true));
        assert_eq!(get(Channel::Green), (false, false));
        // luma of pure red = 76, of pure blue = 29: both dark.
        assert_eq!(get(Channel::Luma), (false, false));
    }

    #[test]
    fn png_16_bit_and_palette_and_tiff() {
        // 16-bit grey: 0x9000 is above half scale, 0x7000 below.
        let mut buf = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut buf, 2, 1);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Sixteen);
            enc.write_header().unwrap().write_image_data(&[0x90, 0, 0x70, 0]).unwrap();
        }
        let b = decode(&buf, &opts(), 0.1).unwrap();
        assert_eq!((b.get(0, 0), b.get(1, 0)), (true, false));
        // Palette: index 1 is white, 0 black, 2 pure red (luma 76: dark, red channel: lit).
        let mut buf = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut buf, 3, 1);
            enc.set_color(png::ColorType::Indexed);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_palette(vec![0, 0, 0, 255, 255, 255, 255, 0, 0]);
            enc.write_header().unwrap().write_image_data(&[1, 0, 2]).unwrap();
        }
        let b = decode(&buf, &opts(), 0.1).unwrap();
        assert_eq!((b.get(0, 0), b.get(1, 0), b.get(2, 0)), (true, false, false));
        let red = decode(&buf, &ThresholdOptions { channel: Channel::Red, ..opts() }, 0.1).unwrap();
        assert!(red.get(2, 0));
        // TIFF, 8-bit grey and RGBA.
        let mut tiff = Cursor::new(Vec::new());
        image::GrayImage::from_raw(3, 1, vec![255, 10, 200])
            .unwrap()
            .write_to(&mut tiff, image::ImageFormat::Tiff)
            .unwrap();
        let b = decode(tiff.get_ref(), &opts(), 0.1).unwrap();
        assert_eq!((b.width(), b.get(0, 0), b.get(1, 0), b.get(2, 0)), (3, true, false, true));
        let mut tiff = Cursor::new(Vec::new());
        image::RgbaImage::from_raw(2, 1, vec![255, 255, 255, 255, 255, 255, 255, 0])
            .unwrap()
            .write_to(&mut tiff, image::ImageFormat::Tiff)
            .unwrap();
        let b = decode(tiff.get_ref(), &opts(), 0.1).unwrap();
        assert_eq!((b.get(0, 0), b.get(1, 0)), (true, false), "transparent white is dark");
        // Not an image we read.
        assert!(matches!(decode(b"GIF89a....", &opts(), 0.1), Err(BitmapError::UnknownFormat)));
    }

    /// Builds a BMP file by hand (bottom-up unless `top_down`).
    fn bmp(w: usize, h: usize, bpp: u16, palette: &[[u8; 4]], rows: &[Vec<u8>], top_down: bool) -> Vec<u8> {
        let stride = (w * bpp as usize).div_ceil(32) * 4;
        let off = 54 + 4 * palette.len();
        let mut d = Vec::new();
        d.extend_from_slice(b"BM");
        d.extend_from_slice(&((off + stride * h) as u32).to_le_bytes());
        d.extend_from_slice(&[0; 4]);
        d.extend_from_slice(&(off as u32).to_le_bytes());
        d.extend_from_slice(&40u32.to_le_bytes());
        d.extend_from_slice(&(w as i32).to_le_bytes());
        let hh = if top_down { -(h as i32) } else { h as i32 };
        d.extend_from_slice(&hh.to_le_bytes());
        d.extend_from_slice(&1u16.to_le_bytes());
        d.extend_from_slice(&bpp.to_le_bytes());
        d.extend_from_slice(&[0; 4 * 4]);
        d.extend_from_slice(&(palette.len() as u32).to_le_bytes());
        d.extend_from_slice(&[0; 4]);
        for q in palette {
            d.extend_from_slice(q);
        }
        let order: Vec<usize> = if top_down { (0..h).collect() } else { (0..h).rev().collect() };
        for y in order {
            let mut r = rows[y].clone();
            r.resize(stride, 0);
            d.extend_from_slice(&r);
        }
        d
    }

    #[test]
    fn bmp_1_8_24_bit() {
        // 1-bit, palette 0 = black, 1 = white; row 0 = 1010..., row 1 = 0000...1 (x = 9)
        let pal = [[0, 0, 0, 0], [255, 255, 255, 0]];
        let rows = vec![vec![0b1010_0000, 0], vec![0, 0b0100_0000]];
        let b = decode(&bmp(10, 2, 1, &pal, &rows, false), &opts(), 0.1).unwrap();
        assert_eq!((b.width(), b.height(), b.count_ones()), (10, 2, 3));
        assert!(b.get(0, 0) && b.get(2, 0) && b.get(9, 1));
        // 8-bit grey ramp, top-down
        let pal: Vec<[u8; 4]> = (0..=255u8).map(|v| [v, v, v, 0]).collect();
        let rows = vec![vec![0, 127, 128, 200]];
        let b = decode(&bmp(4, 1, 8, &pal, &rows, true), &opts(), 0.1).unwrap();
        assert_eq!((0..4).map(|x| b.get(x, 0)).collect::<Vec<_>>(), [false, false, true, true]);
        // 24-bit BGR: blue pixel, white pixel
        let rows = vec![vec![255, 0, 0, 255, 255, 255]];
        let blue = ThresholdOptions { channel: Channel::Blue, ..opts() };
        let b = decode(&bmp(2, 1, 24, &[], &rows, false), &blue, 0.1).unwrap();
        assert!(b.get(0, 0) && b.get(1, 0));
        let b = decode(&bmp(2, 1, 24, &[], &rows, false), &opts(), 0.1).unwrap();
        assert!(!b.get(0, 0) && b.get(1, 0));
        assert!(decode(b"BMxx", &opts(), 0.1).is_err());
        assert!(decode(&bmp(2, 1, 24, &[], &rows, false)[..60], &opts(), 0.1).is_err());
    }

    proptest::proptest! {
        /// Word-wise span filling equals setting the pixels one by one.
        #[test]
        fn fill_span_matches_set(w in 1usize..300, a in 0usize..320, len in 0usize..320) {
            let mut fast = Bitmap::new(w, 2);
            fast.fill_span(1, a, a + len);
            let mut slow = Bitmap::new(w, 2);
            for x in a..a + len {
                slow.set(x, 1, true);
            }
            proptest::prop_assert_eq!(fast, slow);
        }
    }
}
