//! A [`Drawing`] as a PNG: strokes rasterised in order, then the legend and panel titles.

use super::raster::Image;
use super::view::{Drawing, Stroke};
use super::RenderError;

const INK: [u8; 3] = [0x20, 0x20, 0x20];
const LEGEND_BOX: [u8; 3] = [0xff, 0xff, 0xff];
const TEXT_SCALE: u32 = 2;

/// Rasterises a drawing (strokes, legend, titles). A blank drawing is the background only.
///
/// Strokes hidden under later opaque strokes are skipped: a whole print seen from above is
/// mostly covered by its top layers, and skipping what cannot show makes a picture of a
/// 17-million-segment file several times faster. A reverse pass keeps a mask of the pixels that
/// later opaque strokes cover fully; a stroke is hidden when a grid of samples (finer than 0.7 px)
/// over every pixel square it touches is all in the mask, so every pixel it would change is one
/// that a later stroke overwrites. Then the visible strokes are drawn in order: the picture is
/// the one drawing everything gives.
pub fn rasterise(d: &Drawing) -> Image {
    let mut img = Image::new(d.width_px, d.height_px, d.background);
    let visible = visible_strokes(&d.strokes, d.width_px, d.height_px);
    for (s, _) in d.strokes.iter().zip(&visible).filter(|(_, v)| **v) {
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

/// Which strokes are not fully hidden under later opaque ones (see [`rasterise`]).
fn visible_strokes(strokes: &[Stroke], width: u32, height: u32) -> Vec<bool> {
    let (w, h) = (width as usize, height as usize);
    let mut covered = vec![false; w * h];
    let mut visible = vec![false; strokes.len()];
    let at = |covered: &[bool], x: f32, y: f32| -> bool {
        // Outside the picture counts as covered: nothing there can show.
        !(x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h)
            || covered[y as usize * w + x as usize]
    };
    for (i, s) in strokes.iter().enumerate().rev() {
        let d = [s.to[0] - s.from[0], s.to[1] - s.from[1]];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        // The stroke touches pixels whose centres are within `reach` of the segment; their
        // squares reach a further half diagonal (0.71 px). Sample that whole rounded rectangle
        // on a grid finer than 0.7 px, so every such pixel square holds a sample.
        let reach = s.width_px.max(0.5) / 2.0 + 0.5 + 0.71;
        let unit = if len > 0.0 { [d[0] / len, d[1] / len] } else { [1.0, 0.0] };
        let along = ((len + 2.0 * reach) / 0.7).ceil().max(1.0) as usize;
        let across = (2.0 * reach / 0.7).ceil().max(1.0) as usize;
        let hidden = (0..=along).all(|a| {
            let u = -reach + (len + 2.0 * reach) * a as f32 / along as f32;
            (0..=across).all(|c| {
                let v = -reach + 2.0 * reach * c as f32 / across as f32;
                let x = s.from[0] + unit[0] * u - unit[1] * v;
                let y = s.from[1] + unit[1] * u + unit[0] * v;
                at(&covered, x, y)
            })
        });
        if hidden {
            continue;
        }
        visible[i] = true;
        if s.alpha >= 1.0 && s.width_px >= 2.0 {
            mark_core(&mut covered, w, h, s);
        }
    }
    visible
}

/// Marks the pixels whose centres are at least half a pixel inside the stroke (fully covered).
fn mark_core(covered: &mut [bool], w: usize, h: usize, s: &Stroke) {
    let core = s.width_px / 2.0 - 0.5;
    let x_lo = (s.from[0].min(s.to[0]) - core).floor().max(0.0) as usize;
    let y_lo = (s.from[1].min(s.to[1]) - core).floor().max(0.0) as usize;
    let x_hi = ((s.from[0].max(s.to[0]) + core).ceil().max(0.0) as usize).min(w);
    let y_hi = ((s.from[1].max(s.to[1]) + core).ceil().max(0.0) as usize).min(h);
    let d = [s.to[0] - s.from[0], s.to[1] - s.from[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    for y in y_lo..y_hi {
        let py = y as f32 + 0.5;
        for x in x_lo..x_hi {
            let px = x as f32 + 0.5;
            let t = if len2 > 0.0 {
                (((px - s.from[0]) * d[0] + (py - s.from[1]) * d[1]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (qx, qy) = (s.from[0] + d[0] * t - px, s.from[1] + d[1] * t - py);
            if qx * qx + qy * qy <= core * core {
                covered[y * w + x] = true;
            }
        }
    }
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

    #[test]
    fn hidden_strokes_are_skipped_without_changing_the_picture() {
        let st = |from: [f32; 2], to: [f32; 2], colour: [u8; 3], width_px: f32| Stroke {
            from,
            to,
            colour,
            width_px,
            alpha: 1.0,
        };
        let strokes = vec![
            st([10.0, 20.0], [50.0, 20.0], [255, 0, 0], 3.0), // under the wide blue one: hidden
            st([10.0, 5.0], [50.0, 5.0], [0, 255, 0], 3.0),   // beside it: visible
            st([10.0, 26.0], [50.0, 26.0], [0, 255, 0], 3.0), // partly under its edge: visible
            st([5.0, 21.0], [55.0, 21.0], [0, 0, 255], 12.0),
        ];
        assert_eq!(visible_strokes(&strokes, 60, 40), [false, true, true, true]);
        let d = Drawing {
            width_px: 60,
            height_px: 40,
            background: BACKGROUND,
            strokes,
            legend: vec![],
            panels: vec![],
        };
        let mut all = Image::new(60, 40, BACKGROUND);
        for s in &d.strokes {
            all.line(s.from, s.to, s.width_px, s.colour, s.alpha);
        }
        assert_eq!(rasterise(&d), all);
    }
}
