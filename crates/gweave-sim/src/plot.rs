//! A temperature plot of a run: each heater's reading (solid) and target (thin, lighter) over
//! simulated time, drawn into an RGB image and written as PNG.
//!
//! The axes are fixed: time from 0 to the end of the run on X, 0 C to 10 % above the hottest
//! value on Y, with grid lines every minute (or every 10 / 60 minutes on long runs) and every
//! 50 C. Lines are drawn between consecutive samples with a simple DDA (one pixel per step of
//! the longer axis).

use std::io::Write;
use std::path::Path;

use thiserror::Error;

use crate::heater::HeaterId;
use crate::thermal::TimeSeries;

/// Writing the plot failed.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The PNG encoder failed.
    #[error("writing the temperature plot: {0}")]
    Png(#[from] png::EncodingError),
    /// The file could not be created.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

const WIDTH: usize = 900;
const HEIGHT: usize = 420;
const MARGIN: usize = 30;
const GRID: [u8; 3] = [225, 225, 225];
const AXIS: [u8; 3] = [90, 90, 90];
/// Line colours per heater (hotends in order, the bed last).
const COLOURS: [[u8; 3]; 4] = [[200, 40, 30], [30, 90, 200], [30, 150, 60], [150, 60, 170]];
const BED: [u8; 3] = [230, 140, 20];

/// An RGB image being drawn.
struct Canvas {
    rgb: Vec<u8>,
}

impl Canvas {
    fn new() -> Self {
        Self { rgb: vec![255; WIDTH * HEIGHT * 3] }
    }

    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if (0..WIDTH as i64).contains(&x) && (0..HEIGHT as i64).contains(&y) {
            let i = (y as usize * WIDTH + x as usize) * 3;
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [u8; 3], thick: bool) {
        let n = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let (x, y) = ((x0 + (x1 - x0) * t).round() as i64, (y0 + (y1 - y0) * t).round() as i64);
            self.set(x, y, c);
            if thick {
                self.set(x, y + 1, c);
            }
        }
    }
}

/// Lighter shade of a colour, for targets.
fn light(c: [u8; 3]) -> [u8; 3] {
    c.map(|v| (u16::from(v) + 2 * 255).div_euclid(3) as u8)
}

/// Draws the series and writes a PNG to `out`.
pub fn write_temperature_png<W: Write>(series: &TimeSeries, out: W) -> Result<(), PlotError> {
    let mut heaters: Vec<HeaterId> = Vec::new();
    let mut end_s: f64 = 1.0;
    let mut max_c: f64 = 50.0;
    for s in series.samples() {
        if !heaters.contains(&s.heater) {
            heaters.push(s.heater);
        }
        end_s = end_s.max(s.t_s);
        max_c = max_c.max(s.temp_c).max(s.target_c);
    }
    let top_c = max_c * 1.1;
    let (w, h) = ((WIDTH - 2 * MARGIN) as f64, (HEIGHT - 2 * MARGIN) as f64);
    let px = |t_s: f64, c: f64| (MARGIN as f64 + t_s / end_s * w, MARGIN as f64 + (1.0 - c / top_c) * h);
    let mut canvas = Canvas::new();
    let tick_s = match end_s {
        t if t <= 1800.0 => 60.0,
        t if t <= 6.0 * 3600.0 => 600.0,
        _ => 3600.0,
    };
    let mut t = 0.0;
    while t <= end_s {
        canvas.line(px(t, 0.0), px(t, top_c), GRID, false);
        t += tick_s;
    }
    let mut c = 0.0;
    while c <= top_c {
        canvas.line(px(0.0, c), px(end_s, c), GRID, false);
        c += 50.0;
    }
    canvas.line(px(0.0, 0.0), px(end_s, 0.0), AXIS, false);
    canvas.line(px(0.0, 0.0), px(0.0, top_c), AXIS, false);
    for (k, &id) in heaters.iter().enumerate() {
        let colour = if id == HeaterId::Bed { BED } else { COLOURS[k % COLOURS.len()] };
        let mut last: Option<(f64, f64, f64)> = None;
        for s in series.of(id) {
            if let Some((t0, temp0, target0)) = last {
                canvas.line(px(t0, target0), px(s.t_s, s.target_c), light(colour), false);
                canvas.line(px(t0, temp0), px(s.t_s, s.temp_c), colour, true);
            }
            last = Some((s.t_s, s.temp_c, s.target_c));
        }
    }
    let mut enc = png::Encoder::new(out, WIDTH as u32, HEIGHT as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header()?;
    writer.write_image_data(&canvas.rgb)?;
    writer.finish()?;
    Ok(())
}

/// [`write_temperature_png`] into a file.
pub fn save_temperature_png(series: &TimeSeries, path: &Path) -> Result<(), PlotError> {
    let io = |source| PlotError::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = std::io::BufWriter::new(file);
    write_temperature_png(series, &mut out)?;
    out.flush().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::thermal::{Thermal, ThermalConfig};

    #[test]
    fn plot_draws_the_heating_curve() {
        let mut th = Thermal::new(ThermalConfig::default()).unwrap();
        th.set_target(HeaterId::Hotend(0), 200.0).unwrap();
        for _ in 0..120 {
            th.step(1.0);
        }
        let mut png_bytes = Vec::new();
        write_temperature_png(th.series(), &mut png_bytes).unwrap();
        let decoder = png::Decoder::new(png_bytes.as_slice());
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (WIDTH as u32, HEIGHT as u32));
        // The hotend colour is on the plot, and the curve ends high: at the last sample
        // (x = right margin) the red line is in the upper half.
        let red = COLOURS[0];
        let x = WIDTH - MARGIN;
        let rows: Vec<usize> = (0..HEIGHT)
            .filter(|&y| {
                let i = (y * WIDTH + x) * 3;
                buf[i..i + 3] == red
            })
            .collect();
        assert!(!rows.is_empty() && rows.iter().all(|&y| y < HEIGHT / 2), "{rows:?}");
    }
}
