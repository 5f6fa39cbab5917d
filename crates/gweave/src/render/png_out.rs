//! A [`Drawing`] as a PNG: strokes rasterised in order, then the legend and panel titles.

use super::raster::Image;
use super::view::Drawing;
use super::RenderError;

const INK: [u8; 3] = [0x20, 0x20, 0x20];
const LEGEND_BOX: [u8; 3] = [0xff, 0xff, 0xff];
const TEXT_SCALE: u32 = 2;

/// Rasterises a drawing (strokes, legend, titles). A blank drawing is the background only.
pub fn rasterise(d: &Drawing) -> Image {
    let mut img = Image::new(d.width_px, d.height_px, d.background);
    for s in &d.strokes {
        img.line(s.from, s.to, s.width_px, s.colour, s.alpha);
    }
    let line_h = Image::text_height(TEXT_SCALE) + 6;
    for p in &d.panels {
        img.text(p.x_px as i32 + 12, d.height_px as i32 - line_h as i32 - 4, &p.title, TEXT_SCALE, INK);
        if p.x_px > 0 {
            img.rect(p.x_px as i32, 0, 1, d.height_px, INK, 0.3);
        }
    }
    if !d.legend.is_empty() {
        let longest = d.legend.iter().map(|e| e.label.chars().count()).max().unwrap_or(0) as u32;
        let box_w = 12 + line_h + 6 * TEXT_SCALE * longest + 8;
        let box_h = 8 + line_h * d.legend.len() as u32 + 4;
        img.rect(8, 8, box_w, box_h, LEGEND_BOX, 0.85);
        for (i, e) in d.legend.iter().enumerate() {
            let y = 14 + (i as u32 * line_h) as i32;
            let c = [e.colour.r, e.colour.g, e.colour.b];
            img.rect(14, y, line_h - 6, line_h - 6, c, 1.0);
            img.text(14 + line_h as i32, y, &e.label, TEXT_SCALE, INK);
        }
    }
    img
}

/// Encodes an image as an 8-bit RGB PNG marked sRGB.
pub fn encode(img: &Image) -> Result<Vec<u8>, RenderError> {
    let err = |e: png::EncodingError| RenderError::Encode(e.to_string());
    let rgb: Vec<u8> = img.rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, img.width, img.height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder.write_header().map_err(err)?;
    writer.write_image_data(&rgb).map_err(err)?;
    writer.finish().map_err(err)?;
    Ok(out)
}

/// Decodes an 8-bit RGB or RGBA PNG into an image (for tests and for checking output).
pub fn decode(bytes: &[u8]) -> Result<Image, RenderError> {
    let err = |e: png::DecodingError| RenderError::Encode(e.to_string());
    let mut reader = png::Decoder::new(bytes).read_info().map_err(err)?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(err)?;
    buf.truncate(info.buffer_size());
    let rgba = match (info.color_type, info.bit_depth) {
        (png::ColorType::Rgb, png::BitDepth::Eight) => {
            buf.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect()
        }
        (png::ColorType::Rgba, png::BitDepth::Eight) => buf,
        (c, d) => return Err(RenderError::Encode(format!("unsupported PNG {c:?} {d:?}"))),
    };
    Ok(Image { width: info.width, height: info.height, rgba })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::view::{Stroke, BACKGROUND};

    #[test]
    fn png_round_trips_the_pixels() {
        let mut d = Drawing {
            width_px: 30,
            height_px: 20,
            background: BACKGROUND,
            strokes: vec![],
            legend: vec![],
            panels: vec![],
        };
        d.strokes.push(Stroke {
            from: [2.0, 10.0],
            to: [28.0, 10.0],
            colour: [10, 200, 30],
            width_px: 4.0,
            alpha: 1.0,
        });
        let img = rasterise(&d);
        let back = decode(&encode(&img).unwrap()).unwrap();
        assert_eq!(back, img);
        assert_eq!(back.pixel(15, 10), [10, 200, 30, 255]);
        assert_eq!(back.pixel(15, 2), [BACKGROUND[0], BACKGROUND[1], BACKGROUND[2], 255]);
    }
}
