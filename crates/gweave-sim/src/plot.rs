//! Plots of a run, drawn into an RGB image and written as PNG:
//! - temperature: each heater's reading (solid) and target (thin, lighter) over simulated time;
//! - speed: the planned toolhead speed over time (the mean of each time slice solid, its peak
//!   light, from [`SpeedTrace`]) above the time of each layer as bars (the planner's per-layer
//!   figures), grid lines every 50 mm/s and every minute (10 / 60 minutes on long runs).
//!
//! The axes are fixed: time from 0 to the end of the run on X, from 0 to 10 % above the highest
//! value on Y, with labelled grid lines every minute (or every 10 / 60 minutes on long runs)
//! and every 50 C or 50 mm/s. Both charts are drawn with gweave's rasteriser
//! ([`gweave::render::raster::Image`]) and written by its PNG encoder.

use std::io::Write;
use std::path::Path;

use thiserror::Error;

use gweave::gcode::writer::write_file;
use gweave::render::png_out::encode as encode_image;
use gweave::render::raster::Image;

use crate::heater::HeaterId;
use crate::speed_trace::SpeedTrace;
use crate::thermal::TimeSeries;

/// Writing the plot failed.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The PNG encoder failed.
    #[error("writing the plot: {0}")]
    Png(#[from] png::EncodingError),
    /// The chart could not be encoded.
    #[error(transparent)]
    Render(#[from] gweave::render::RenderError),
    /// Writing the bytes failed.
    #[error("writing the plot: {0}")]
    Write(#[from] std::io::Error),
    /// The file could not be created or renamed into place.
    #[error(transparent)]
    Output(#[from] gweave::Error),
}

const WIDTH: usize = 900;
const HEIGHT: usize = 420;
const MARGIN: usize = 30;
const GRID: [u8; 3] = [225, 225, 225];
const AXIS: [u8; 3] = [90, 90, 90];
/// Line colours per heater (hotends in order, the bed last).
const COLOURS: [[u8; 3]; 4] = [[200, 40, 30], [30, 90, 200], [30, 150, 60], [150, 60, 170]];
const BED: [u8; 3] = [230, 140, 20];

/// Lighter shade of a colour, for targets.
fn light(c: [u8; 3]) -> [u8; 3] {
    c.map(|v| (u16::from(v) + 2 * 255).div_euclid(3) as u8)
}

/// Time between vertical grid lines for a run of `end_s`.
fn time_tick_s(end_s: f64) -> f64 {
    match end_s {
        t if t <= 1800.0 => 60.0,
        t if t <= 6.0 * 3600.0 => 600.0,
        _ => 3600.0,
    }
}

/// Grid lines with their labels, and the two axes, for a chart whose point at time `t_s` and
/// value `v` is drawn at `px(t_s, v)`; the values run from 0 to `top`, the time to `end_s`.
fn grid(img: &mut Image, px: &dyn Fn(f64, f64) -> [f32; 2], end_s: f64, top: f64) {
    let mut t = 0.0;
    let tick_s = time_tick_s(end_s);
    while t <= end_s {
        img.line(px(t, 0.0), px(t, top), 1.0, GRID, 1.0);
        let [x, y] = px(t, 0.0);
        img.text(x as i32 + 2, y as i32 + 3, &format!("{}", (t / 60.0).round()), 1, AXIS);
        t += tick_s;
    }
    let mut v = 0.0;
    while v <= top {
        img.line(px(0.0, v), px(end_s, v), 1.0, GRID, 1.0);
        let [x, y] = px(0.0, v);
        img.text(x as i32 - 24, y as i32 - 3, &format!("{v:>3.0}"), 1, AXIS);
        v += 50.0;
    }
    img.line(px(0.0, 0.0), px(end_s, 0.0), 1.0, AXIS, 1.0);
    img.line(px(0.0, 0.0), px(0.0, top), 1.0, AXIS, 1.0);
}

/// Speed chart colours: mean, peak, layer bars.
const SPEED_MEAN: [u8; 3] = [30, 90, 200];
const SPEED_PEAK: [u8; 3] = [170, 195, 240];
const LAYER_BAR: [u8; 3] = [230, 140, 20];
/// Height of each of the two panels of the speed chart, px.
const SPEED_PANEL_H: usize = HEIGHT / 2;

/// Height of the longest layer's bar, px (the lower panel, below a margin).
const LAYER_BAR_MAX_H: usize = SPEED_PANEL_H - 2 * MARGIN;

/// Where (x, y) of the speed panel a speed `v` at time `t_s` is drawn, for a run of `end_s` and
/// an axis up to `top_mm_s`.
pub fn speed_px(t_s: f64, v_mm_s: f64, end_s: f64, top_mm_s: f64) -> (f64, f64) {
    let (w, h) = ((WIDTH - 2 * MARGIN) as f64, (SPEED_PANEL_H - MARGIN) as f64);
    (MARGIN as f64 + t_s / end_s * w, MARGIN as f64 + (1.0 - v_mm_s / top_mm_s) * h)
}

/// The speed chart (see the module docs): speed over time above, the time of each layer below
/// (`layer_s[k]`, s, left to right), with axis labels. Returns the speed axis top, mm/s.
pub fn write_speed_png<W: Write>(trace: &SpeedTrace, layer_s: &[f64], mut out: W) -> Result<f64, PlotError> {
    let end_s = trace.end_s().max(1.0);
    let peak = trace.buckets().iter().map(|b| b.max_mm_s).fold(10.0, f64::max);
    let top = peak * 1.1;
    let px = |t_s: f64, v: f64| {
        let (x, y) = speed_px(t_s, v, end_s, top);
        [x as f32, y as f32]
    };
    let mut img = Image::new(WIDTH as u32, HEIGHT as u32, [255; 3]);
    grid(&mut img, &px, end_s, top);
    let w = trace.bucket_s();
    for (i, b) in trace.buckets().iter().enumerate() {
        let t = (i as f64 + 0.5) * w;
        img.line(px(t, 0.0), px(t, b.max_mm_s), 1.0, SPEED_PEAK, 1.0);
    }
    let mut last: Option<[f32; 2]> = None;
    for i in 0..trace.buckets().len() {
        let p = px((i as f64 + 0.5) * w, trace.mean_mm_s(i));
        img.line(last.unwrap_or(p), p, 2.0, SPEED_MEAN, 1.0);
        last = Some(p);
    }
    img.text(MARGIN as i32 + 6, 8, "SPEED MM/S: MEAN (DARK), PEAK (LIGHT), TIME IN MIN", 1, AXIS);
    // Layers: one bar each, as tall as its time is long against the longest.
    let y0 = (HEIGHT - MARGIN) as i32;
    let (x0, x1) = (MARGIN as f64, (WIDTH - MARGIN) as f64);
    let longest = layer_s.iter().copied().fold(0.0, f64::max);
    if longest > 0.0 {
        let bar_w = (x1 - x0) / layer_s.len() as f64;
        for (k, &t) in layer_s.iter().enumerate() {
            let h = (t / longest * LAYER_BAR_MAX_H as f64).round() as i32;
            let a = (x0 + k as f64 * bar_w).round() as i32;
            let b = ((x0 + (k + 1) as f64 * bar_w).round() as i32 - 1).max(a + 1);
            img.rect(a, y0 - h, (b - a) as u32, h as u32, LAYER_BAR, 1.0);
        }
        let label = format!("TIME PER LAYER, {} LAYERS, LONGEST {longest:.0} S", layer_s.len());
        img.text(MARGIN as i32 + 6, (SPEED_PANEL_H + MARGIN / 2) as i32 - 4, &label, 1, AXIS);
    }
    img.line([x0 as f32, y0 as f32], [x1 as f32, y0 as f32], 1.0, AXIS, 1.0);
    out.write_all(&encode_image(&img)?)?;
    Ok(top)
}

/// [`write_speed_png`] into a file.
pub fn save_speed_png(trace: &SpeedTrace, layer_s: &[f64], path: &Path) -> Result<(), PlotError> {
    write_file(path, |out| write_speed_png(trace, layer_s, out).map(drop))
}

/// Draws the series and writes a PNG to `out`.
pub fn write_temperature_png<W: Write>(series: &TimeSeries, mut out: W) -> Result<(), PlotError> {
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
    let px = |t_s: f64, c: f64| {
        [(MARGIN as f64 + t_s / end_s * w) as f32, (MARGIN as f64 + (1.0 - c / top_c) * h) as f32]
    };
    let mut img = Image::new(WIDTH as u32, HEIGHT as u32, [255; 3]);
    grid(&mut img, &px, end_s, top_c);
    img.text(MARGIN as i32 + 6, 8, "TEMPERATURE C: READING (DARK), TARGET (LIGHT), TIME IN MIN", 1, AXIS);
    for (k, &id) in heaters.iter().enumerate() {
        let colour = if id == HeaterId::Bed { BED } else { COLOURS[k % COLOURS.len()] };
        let mut last: Option<(f64, f64, f64)> = None;
        for s in series.of(id) {
            if let Some((t0, temp0, target0)) = last {
                img.line(px(t0, target0), px(s.t_s, s.target_c), 1.0, light(colour), 1.0);
                img.line(px(t0, temp0), px(s.t_s, s.temp_c), 2.0, colour, 1.0);
            }
            last = Some((s.t_s, s.temp_c, s.target_c));
        }
    }
    out.write_all(&encode_image(&img)?)?;
    Ok(())
}

/// [`write_temperature_png`] into a file.
pub fn save_temperature_png(series: &TimeSeries, path: &Path) -> Result<(), PlotError> {
    write_file(path, |out| write_temperature_png(series, out))
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

    fn decode(png_bytes: &[u8]) -> Vec<u8> {
        let mut reader = png::Decoder::new(png_bytes).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        reader.next_frame(&mut buf).unwrap();
        buf
    }

    fn rows_of(buf: &[u8], x: usize, c: [u8; 3]) -> Vec<usize> {
        (0..HEIGHT).filter(|&y| buf[(y * WIDTH + x) * 3..][..3] == c).collect()
    }

    #[test]
    fn speed_chart_draws_the_cruise_speed_and_layer_bars() {
        use crate::kinematics::{MoveKind, Pos};
        use crate::planner::{PlannedBlock, Trapezoid};
        // 1000 mm at 80 mm/s (12.5 s), starting after 10 s of standing still.
        let block = PlannedBlock {
            tag: 0,
            start: Pos::default(),
            end: Pos::default(),
            len: 1000.0,
            accel_mm_s2: 1000.0,
            kind: MoveKind::Kinematic,
            trapezoid: Trapezoid::from_v2(1000.0, 1000.0, 0.0, 6400.0, 0.0),
        };
        let mut trace = SpeedTrace::default();
        trace.add(10.0, &block);
        let mut bytes = Vec::new();
        let top = write_speed_png(&trace, &[10.0, 5.0], &mut bytes).unwrap();
        assert!((top - 88.0).abs() < 1e-9);
        let buf = decode(&bytes);
        let end_s = trace.end_s();
        // Mid-cruise: the mean line sits at 80 mm/s.
        let (x, y) = speed_px(16.0, 80.0, end_s, top);
        let rows = rows_of(&buf, x.round() as usize, SPEED_MEAN);
        assert!(rows.iter().any(|&r| (r as f64 - y).abs() <= 1.0), "{rows:?} vs {y}");
        // Standing still: the mean is on the zero line.
        let (x, y0) = speed_px(5.0, 0.0, end_s, top);
        let rows = rows_of(&buf, x.round() as usize, SPEED_MEAN);
        assert!(rows.iter().all(|&r| (r as f64 - y0).abs() <= 1.0) && !rows.is_empty(), "{rows:?}");
        // Layer bars: the second half as tall as the first.
        let bar_h = |x: usize| rows_of(&buf, x, LAYER_BAR).len() as f64;
        let (h0, h1) = (bar_h(WIDTH / 4), bar_h(3 * WIDTH / 4));
        assert!((h0 - LAYER_BAR_MAX_H as f64).abs() <= 1.0, "{h0}");
        assert!((h1 / h0 - 0.5).abs() < 0.02, "{h1} / {h0}");
    }
}
