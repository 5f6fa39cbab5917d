//! The one PNG encoder every picture gweave writes goes through ([`write_png`], the `png`
//! crate: the version `image` decodes with, so one `png` in the build), and decoding for tests
//! and checks (`image`).

use std::io::Write;

use super::raster::Image;

/// Pixels for [`write_png`], rows top first.
#[derive(Debug, Clone, Copy)]
pub enum Pixels<'a> {
    /// 8-bit sRGB, 3 bytes a pixel: pictures and charts.
    Rgb(&'a [u8]),
    /// 1-bit grey, rows packed most significant bit first and padded to a byte: layer masks.
    Grey1(&'a [u8]),
}

/// Writes a `width` x `height` PNG. Colour pictures are marked sRGB (so viewers do not
/// colour-manage them twice) and compressed with the fast level, as previews always were (their
/// time is in `make bench`). Layer masks keep the default level they always had (the raster
/// benchmark reads 500 of them).
pub fn write_png(
    out: impl Write,
    width: u32,
    height: u32,
    pixels: Pixels<'_>,
) -> Result<(), png::EncodingError> {
    let mut encoder = png::Encoder::new(out, width, height);
    let data = match pixels {
        Pixels::Rgb(data) => {
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
            encoder.set_compression(png::Compression::Fast);
            data
        }
        Pixels::Grey1(data) => {
            encoder.set_color(png::ColorType::Grayscale);
            encoder.set_depth(png::BitDepth::One);
            data
        }
    };
    let mut writer = encoder.write_header()?;
    writer.write_image_data(data)?;
    writer.finish()
}

/// Encodes an opaque image as an 8-bit RGB PNG ([`write_png`]).
pub fn encode(img: &Image) -> Result<Vec<u8>, png::EncodingError> {
    let rgb: Vec<u8> = img.rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    let mut out = Vec::new();
    write_png(&mut out, img.width, img.height, Pixels::Rgb(&rgb))?;
    Ok(out)
}

/// Decodes a PNG into an RGBA image with the `image` crate (for tests and for checking output).
pub fn decode(bytes: &[u8]) -> Result<Image, image::ImageError> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)?.into_rgba8();
    Ok(Image { width: img.width(), height: img.height(), rgba: img.into_raw() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trips_the_pixels() {
        let mut img = Image::new(30, 20, [250, 250, 245]);
        img.line([2.0, 10.0], [28.0, 10.0], 4.0, [10, 200, 30], 1.0);
        let back = decode(&encode(&img).unwrap()).unwrap();
        assert_eq!(back, img);
        assert_eq!(back.pixel(15, 10), [10, 200, 30, 255]);
        assert_eq!(back.pixel(15, 2), [250, 250, 245, 255]);
    }

    #[test]
    fn masks_are_one_bit_grey() {
        // 10 px wide: two bytes a row, the last 6 bits padding.
        let rows = [0b1010_0000, 0b0100_0000, 0xff, 0xc0];
        let mut bytes = Vec::new();
        write_png(&mut bytes, 10, 2, Pixels::Grey1(&rows)).unwrap();
        let img = decode(&bytes).unwrap();
        assert_eq!((img.width, img.height), (10, 2));
        assert_eq!([0, 1, 2, 9].map(|x| img.pixel(x, 0)[0]), [255, 0, 255, 255]);
        assert!((0..10).all(|x| img.pixel(x, 1)[0] == 255));
    }
}
