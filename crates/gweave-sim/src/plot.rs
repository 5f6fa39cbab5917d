//! Charts of a run, drawn with `plotters` in gweave's embedded font
//! ([`gweave::picture::text::FONT_TTF`]), as PNG (painted by gweave's rasteriser,
//! `crate::chart_canvas`, and written by its PNG writer) or SVG (plotters' SVG backend, the text
//! as text), chosen by the file's extension:
//! - temperature: each heater's reading (solid) and target (thin, lighter) over simulated time,
//!   a legend naming each (`hotend T0`, `hotend T0 target`, `bed`, `bed target`);
//! - speed: the planned toolhead speed over time (the mean of each time slice as a line, its
//!   peak as a light band, from `SpeedTrace`), below it the time of each layer as bars (the
//!   planner's per-layer figures), and on a mixing machine the filament each input fed.
//!
//! Every panel has a title, axes with units and ticks, and a legend in its upper right corner.
//! The axes start at 0; time ends with the run, values leave room above the highest for the
//! legend (`headroom`); plotters picks round ticks.

use std::io::Write;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::register_font;
use thiserror::Error;

use gweave::gcode::writer::write_file;
use gweave::picture::text::FONT_TTF;
use gweave::picture::{encode, Image};

use crate::chart_canvas::ChartCanvas;
use crate::motion::speed_trace::SpeedTrace;
use crate::thermal::heater::HeaterId;
use crate::thermal::TimeSeries;

/// Writing the plot failed.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The PNG encoder failed.
    #[error("writing the plot: {0}")]
    Png(#[from] png::EncodingError),
    /// Drawing the chart failed (plotters' message).
    #[error("drawing the plot: {0}")]
    Draw(String),
    /// Neither `.png` nor `.svg`.
    #[error("a plot is written as PNG or SVG (by its extension), not {0:?}")]
    Format(String),
    /// Writing the bytes failed.
    #[error("writing the plot: {0}")]
    Write(#[from] std::io::Error),
    /// The file could not be created or renamed into place.
    #[error(transparent)]
    Output(#[from] gweave::Error),
}

/// What a chart is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChartFormat {
    /// A bitmap.
    Png,
    /// A vector drawing, the text as text.
    Svg,
}

impl ChartFormat {
    /// From an output file's extension.
    pub fn from_path(path: &Path) -> Result<ChartFormat, PlotError> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "png" => Ok(ChartFormat::Png),
            "svg" => Ok(ChartFormat::Svg),
            _ => Err(PlotError::Format(ext)),
        }
    }
}

/// Size of the temperature chart, px.
pub(crate) const TEMPERATURE_PX: (u32, u32) = (1000, 500);
/// Size of the speed chart, px (a third more with the mixing inputs' panel).
pub(crate) const SPEED_PX: (u32, u32) = (1000, 640);
const MIXING_PANEL_PX: u32 = 220;

/// Line colours per heater (hotends in order, the bed its own).
/// Temperature chart colours of the hotends, in order, and of the bed.
pub(crate) const HOTEND_COLOURS: [RGBColor; 4] =
    [RGBColor(200, 40, 30), RGBColor(30, 90, 200), RGBColor(30, 150, 60), RGBColor(150, 60, 170)];
/// See [`HOTEND_COLOURS`].
pub(crate) const BED_COLOUR: RGBColor = RGBColor(230, 140, 20);
/// Speed chart colours: mean, peak, layer bars, mixing inputs.
pub(crate) const SPEED_MEAN: RGBColor = RGBColor(30, 90, 200);
/// See [`SPEED_MEAN`].
pub(crate) const SPEED_PEAK: RGBColor = RGBColor(170, 195, 240);
/// See [`SPEED_MEAN`].
pub(crate) const LAYER_BAR: RGBColor = RGBColor(230, 140, 20);
/// See [`SPEED_MEAN`].
pub(crate) const INPUT_BAR: RGBColor = RGBColor(60, 150, 110);

/// A panel's mapping from (time or index, value) to pixels, for tests and callers that mark it.
pub(crate) type Axes = Cartesian2d<RangedCoordf64, RangedCoordf64>;

/// Lighter shade of a colour, for targets.
fn light(c: RGBColor) -> RGBColor {
    let l = |v: u8| ((u16::from(v) + 2 * 255) / 3) as u8;
    RGBColor(l(c.0), l(c.1), l(c.2))
}

/// The legend name of a heater.
pub(crate) fn heater_name(id: HeaterId) -> String {
    match id {
        HeaterId::Hotend(n) => format!("hotend T{n}"),
        HeaterId::Bed => "bed".to_owned(),
    }
}

/// Registers the embedded font as plotters' "sans-serif" (its default family), once.
fn font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| register_font("sans-serif", FontStyle::Normal, FONT_TTF).is_ok());
    ok.then_some(()).ok_or_else(|| PlotError::Draw("the embedded font did not load".into()))
}

fn draw_err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// A chart, drawn the same on any plotters backend.
trait Chart {
    /// What drawing it tells the caller: the axes of its main panel.
    type Axes;
    fn size_px(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<Self::Axes, PlotError>;
}

/// Draws `chart` and encodes it as `format`.
fn render<C: Chart>(chart: &C, format: ChartFormat) -> Result<(Vec<u8>, C::Axes), PlotError> {
    font()?;
    let (w, h) = chart.size_px();
    match format {
        ChartFormat::Png => {
            let mut image = Image::new(w, h, [255, 255, 255]);
            let axes = {
                let root = ChartCanvas::new(&mut image).into_drawing_area();
                let axes = chart.draw(&root)?;
                root.present().map_err(draw_err)?;
                axes
            };
            Ok((encode(&image)?, axes))
        }
        ChartFormat::Svg => {
            let mut svg = String::new();
            let axes = {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                let axes = chart.draw(&root)?;
                root.present().map_err(draw_err)?;
                axes
            };
            Ok((svg.into_bytes(), axes))
        }
    }
}

/// Writes a chart into a file, PNG or SVG by its extension.
fn save<C: Chart>(chart: &C, path: &Path) -> Result<(), PlotError> {
    let format = ChartFormat::from_path(path)?;
    let (bytes, _) = render(chart, format)?;
    write_file(path, |out| out.write_all(&bytes).map_err(PlotError::from))
}

/// Title, axis title and tick label sizes, px.
const TITLE_PX: u32 = 22;
const AXIS_TITLE_PX: u32 = 16;
const TICK_PX: u32 = 13;

/// A panel with a title, both axes (with their titles and round ticks) and a light grid, over
/// `x` by `y`; returns the chart to draw the series in.
fn panel<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    x: (std::ops::Range<f64>, &str),
    y: (std::ops::Range<f64>, &str),
    x_label: &dyn Fn(&f64) -> String,
) -> Result<ChartContext<'a, DB, Axes>, PlotError> {
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", TITLE_PX))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x.0, y.0)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc(x.1)
        .y_desc(y.1)
        .axis_desc_style(("sans-serif", AXIS_TITLE_PX))
        .label_style(("sans-serif", TICK_PX))
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .x_label_formatter(x_label)
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(draw_err)?;
    Ok(chart)
}

/// How far above the highest value a panel's value axis goes, so that a legend of `entries`
/// lines in the upper right corner stays clear of the data: 10 % plus 8 % a line.
fn headroom(entries: usize) -> f64 {
    1.1 + 0.08 * entries as f64
}

/// The legend box of a panel, in its upper right corner.
fn legend<'a, DB: DrawingBackend + 'a>(chart: &mut ChartContext<'a, DB, Axes>) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", AXIS_TITLE_PX))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(120, 120, 120))
        .draw()
        .map_err(draw_err)
}

/// Minutes with as many decimals as the axis needs.
fn minutes(t_min: &f64) -> String {
    let t = format!("{t_min:.2}");
    t.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// A legend mark: a short line of the series' colour.
fn line_mark(c: RGBColor, width: u32) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(width))
}

/// A legend mark: a small filled square.
fn box_mark(c: RGBColor) -> impl Fn((i32, i32)) -> Rectangle<(i32, i32)> {
    move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], c.filled())
}

/// The temperature chart of a run.
struct Temperatures<'a>(&'a TimeSeries);

impl Chart for Temperatures<'_> {
    type Axes = Axes;

    fn size_px(&self) -> (u32, u32) {
        TEMPERATURE_PX
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<Axes, PlotError> {
        let series = self.0;
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
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = panel(
            root,
            "Temperatures: reading and target of each heater",
            (0.0..end_s / 60.0, "time (min)"),
            (0.0..max_c * headroom(2 * heaters.len()), "temperature (°C)"),
            &minutes,
        )?;
        let mut hotends = 0;
        for &id in &heaters {
            let colour = match id {
                HeaterId::Bed => BED_COLOUR,
                HeaterId::Hotend(_) => {
                    hotends += 1;
                    HOTEND_COLOURS[(hotends - 1) % HOTEND_COLOURS.len()]
                }
            };
            let name = heater_name(id);
            let target = series.of(id).map(|s| (s.t_s / 60.0, s.target_c));
            chart
                .draw_series(LineSeries::new(target, light(colour).stroke_width(2)))
                .map_err(draw_err)?
                .label(format!("{name} target"))
                .legend(line_mark(light(colour), 2));
            let reading = series.of(id).map(|s| (s.t_s / 60.0, s.temp_c));
            chart
                .draw_series(LineSeries::new(reading, colour.stroke_width(2)))
                .map_err(draw_err)?
                .label(name)
                .legend(line_mark(colour, 3));
        }
        legend(&mut chart)?;
        Ok(chart.as_coord_spec().clone())
    }
}

/// The temperature chart (see the module docs) as file bytes, with its axes (minutes, °C).
pub fn temperature_chart(series: &TimeSeries, format: ChartFormat) -> Result<(Vec<u8>, Axes), PlotError> {
    render(&Temperatures(series), format)
}

/// [`temperature_chart`] into a file, PNG or SVG by its extension.
pub(crate) fn save_temperature_chart(series: &TimeSeries, path: &Path) -> Result<(), PlotError> {
    save(&Temperatures(series), path)
}

/// The speed chart of a run: speed over time, time per layer, and the mixing inputs' use.
struct Speeds<'a> {
    trace: &'a SpeedTrace,
    layer_s: &'a [f64],
    /// Filament per mixing input, mm (a panel of its own when there are two or more).
    mixing_input_mm: &'a [f64],
}

/// The speed chart's panels' axes: speed (minutes, mm/s) and layer time (layer, s).
pub struct SpeedAxes {
    /// Speed over time: minutes, mm/s.
    pub speed: Axes,
    /// Layer times: layer, s.
    pub layers: Axes,
}

impl Speeds<'_> {
    fn mixing(&self) -> bool {
        self.mixing_input_mm.len() >= 2 && self.mixing_input_mm.iter().any(|&mm| mm > 0.0)
    }
}

impl Chart for Speeds<'_> {
    type Axes = SpeedAxes;

    fn size_px(&self) -> (u32, u32) {
        (SPEED_PX.0, SPEED_PX.1 + if self.mixing() { MIXING_PANEL_PX } else { 0 })
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<SpeedAxes, PlotError> {
        root.fill(&WHITE).map_err(draw_err)?;
        let (top, rest) = root.split_vertically(SPEED_PX.1 / 2);
        let (middle, bottom) = rest.split_vertically(SPEED_PX.1 / 2);
        let trace = self.trace;
        let end_min = trace.end_s().max(1.0) / 60.0;
        let peak = trace.buckets().iter().map(|b| b.max_mm_s).fold(10.0, f64::max);
        let mut chart = panel(
            &top,
            "Toolhead speed as planned",
            (0.0..end_min, "time (min)"),
            (0.0..peak * headroom(2), "speed (mm/s)"),
            &minutes,
        )?;
        let w_min = trace.bucket_s() / 60.0;
        let peaks = trace.buckets().iter().enumerate().map(|(i, b)| {
            let t = i as f64 * w_min;
            Rectangle::new([(t, 0.0), (t + w_min, b.max_mm_s)], SPEED_PEAK.filled())
        });
        chart
            .draw_series(peaks)
            .map_err(draw_err)?
            .label("peak of each time slice")
            .legend(box_mark(SPEED_PEAK));
        let means = (0..trace.buckets().len()).map(|i| ((i as f64 + 0.5) * w_min, trace.mean_mm_s(i)));
        chart
            .draw_series(LineSeries::new(means, SPEED_MEAN.stroke_width(2)))
            .map_err(draw_err)?
            .label("mean of each time slice")
            .legend(line_mark(SPEED_MEAN, 3));
        legend(&mut chart)?;
        let speed = chart.as_coord_spec().clone();

        let layers = self.layer_s.len().max(1) as f64;
        let longest = self.layer_s.iter().copied().fold(1.0, f64::max);
        let mut chart = panel(
            &middle,
            &format!("Time per layer ({} layers)", self.layer_s.len()),
            (0.0..layers, "layer"),
            (0.0..longest * headroom(1), "time (s)"),
            &|k| format!("{k:.0}"),
        )?;
        let bars = self
            .layer_s
            .iter()
            .enumerate()
            .map(|(k, &t)| Rectangle::new([(k as f64, 0.0), ((k + 1) as f64, t)], LAYER_BAR.filled()));
        chart.draw_series(bars).map_err(draw_err)?.label("time per layer").legend(box_mark(LAYER_BAR));
        legend(&mut chart)?;
        let layer_axes = chart.as_coord_spec().clone();

        if self.mixing() {
            let n = self.mixing_input_mm.len();
            let most = self.mixing_input_mm.iter().copied().fold(1.0, f64::max);
            let mut chart = panel(
                &bottom,
                "Filament fed by each mixing input",
                (0.0..n as f64, "mixing input (motor)"),
                (0.0..most * headroom(1), "filament (mm)"),
                &|k| if k.fract() == 0.5 { format!("E{}", k.floor()) } else { String::new() },
            )?;
            let bars = self.mixing_input_mm.iter().enumerate().map(|(k, &mm)| {
                Rectangle::new([(k as f64 + 0.15, 0.0), (k as f64 + 0.85, mm)], INPUT_BAR.filled())
            });
            chart
                .draw_series(bars)
                .map_err(draw_err)?
                .label("filament per input")
                .legend(box_mark(INPUT_BAR));
            legend(&mut chart)?;
        }
        Ok(SpeedAxes { speed, layers: layer_axes })
    }
}

/// The speed chart (see the module docs) as file bytes, with its panels' axes. `layer_s[k]` is
/// the time of layer `k`, s; `mixing_input_mm` the filament each mixing input fed (a panel of
/// its own on a machine with two or more).
pub fn speed_chart(
    trace: &SpeedTrace,
    layer_s: &[f64],
    mixing_input_mm: &[f64],
    format: ChartFormat,
) -> Result<(Vec<u8>, SpeedAxes), PlotError> {
    render(&Speeds { trace, layer_s, mixing_input_mm }, format)
}

/// [`speed_chart`] into a file, PNG or SVG by its extension.
pub(crate) fn save_speed_chart(
    trace: &SpeedTrace,
    layer_s: &[f64],
    mixing_input_mm: &[f64],
    path: &Path,
) -> Result<(), PlotError> {
    save(&Speeds { trace, layer_s, mixing_input_mm }, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::kinematics::{MoveKind, Pos};
    use crate::motion::planner::{PlannedBlock, Trapezoid};
    use crate::thermal::{Thermal, ThermalConfig};
    use gweave::picture::decode;
    use gweave::picture::Image;

    /// Is a pixel within 3 px of `at` within 24 levels of `c`?
    fn near(img: &Image, at: (i32, i32), c: RGBColor) -> bool {
        (-3..=3).any(|dy| {
            (-3..=3).any(|dx| {
                let (x, y) = (at.0 + dx, at.1 + dy);
                let inside = x >= 0 && y >= 0 && (x as u32) < img.width && (y as u32) < img.height;
                inside && {
                    let p = img.pixel(x as u32, y as u32);
                    [c.0, c.1, c.2].iter().zip(p).all(|(a, b)| a.abs_diff(b) <= 24)
                }
            })
        })
    }

    /// Two minutes of a hotend heating to 200 C and a bed to 60 C.
    fn heating() -> Thermal {
        let mut th = Thermal::new(ThermalConfig::default()).unwrap();
        th.set_target(HeaterId::Hotend(0), 200.0).unwrap();
        th.set_target(HeaterId::Bed, 60.0).unwrap();
        for _ in 0..120 {
            th.step(1.0);
        }
        th
    }

    #[test]
    fn temperature_chart_draws_each_heater_and_its_target_where_the_values_are() {
        let th = heating();
        let (bytes, axes) = temperature_chart(th.series(), ChartFormat::Png).unwrap();
        let img = decode(&bytes).unwrap();
        assert_eq!((img.width, img.height), TEMPERATURE_PX);
        let last = |id| *th.series().of(id).last().unwrap();
        for (id, colour) in [(HeaterId::Hotend(0), HOTEND_COLOURS[0]), (HeaterId::Bed, BED_COLOUR)] {
            let s = last(id);
            let t_min = s.t_s / 60.0 - 0.02;
            assert!(near(&img, axes.translate(&(t_min, s.temp_c)), colour), "{id:?} reading at {}", s.temp_c);
            // The target where the reading is far below it (at the end the reading, drawn over
            // it, is on it).
            let heating = th.series().of(id).find(|s| s.target_c - s.temp_c > 20.0 && s.t_s > 6.0).unwrap();
            let at = axes.translate(&(heating.t_s / 60.0, heating.target_c));
            assert!(near(&img, at, light(colour)), "{id:?} target at {} s", heating.t_s);
        }
        // The hotend's reading is far from the bed's: no hotend colour where the bed line is.
        let bed = last(HeaterId::Bed);
        assert!(!near(&img, axes.translate(&(1.0, bed.target_c)), HOTEND_COLOURS[0]));
    }

    #[test]
    fn temperature_chart_svg_names_every_series_and_axis() {
        let (bytes, _) = temperature_chart(heating().series(), ChartFormat::Svg).unwrap();
        let svg = String::from_utf8(bytes).unwrap();
        for text in ["hotend T0", "hotend T0 target", "bed", "bed target", "time (min)", "temperature (°C)"]
        {
            assert!(svg.contains(&format!(">\n{text}\n<")), "{text} missing");
        }
        assert!(svg.starts_with("<svg"));
    }

    /// 1000 mm at 80 mm/s (12.5 s), starting after 10 s of standing still.
    fn cruise() -> SpeedTrace {
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
        trace
    }

    #[test]
    fn speed_chart_draws_the_cruise_speed_and_layer_bars() {
        let (bytes, axes) = speed_chart(&cruise(), &[10.0, 5.0], &[], ChartFormat::Png).unwrap();
        let img = decode(&bytes).unwrap();
        assert_eq!((img.width, img.height), SPEED_PX, "no mixing panel");
        // Mid-cruise the mean line is at 80 mm/s; standing still, on the zero line.
        assert!(near(&img, axes.speed.translate(&(16.0 / 60.0, 80.0)), SPEED_MEAN));
        assert!(!near(&img, axes.speed.translate(&(16.0 / 60.0, 40.0)), SPEED_MEAN));
        assert!(near(&img, axes.speed.translate(&(5.0 / 60.0, 0.0)), SPEED_MEAN));
        // Layer bars: the first 10 s tall, the second 5 s.
        let bar = |k: f64, t: f64| near(&img, axes.layers.translate(&(k, t)), LAYER_BAR);
        assert!(bar(0.5, 9.0) && bar(1.5, 4.0));
        assert!(!bar(1.5, 7.0), "the second bar ends at 5 s");
    }

    #[test]
    fn speed_chart_svg_has_titles_axes_and_legend_and_the_mixing_panel_on_mixing_machines() {
        let svg = |inputs: &[f64]| {
            String::from_utf8(speed_chart(&cruise(), &[10.0, 5.0], inputs, ChartFormat::Svg).unwrap().0)
                .unwrap()
        };
        let plain = svg(&[]);
        for text in [
            "Toolhead speed as planned",
            "speed (mm/s)",
            "time (min)",
            "mean of each time slice",
            "peak of each time slice",
            "Time per layer (2 layers)",
            "time (s)",
            "layer",
            "time per layer",
        ] {
            assert!(plain.contains(&format!(">\n{text}\n<")), "{text} missing");
        }
        assert!(!plain.contains("mixing input"));
        let mixing = svg(&[120.0, 40.0, 0.0]);
        for text in ["Filament fed by each mixing input", "filament (mm)", "E0", "E2", "filament per input"] {
            assert!(mixing.contains(&format!(">\n{text}\n<")), "{text} missing");
        }
    }

    #[test]
    fn chart_format_is_the_extension() {
        assert_eq!(ChartFormat::from_path(Path::new("t.SVG")).unwrap(), ChartFormat::Svg);
        assert_eq!(ChartFormat::from_path(Path::new("t.png")).unwrap(), ChartFormat::Png);
        assert!(
            matches!(ChartFormat::from_path(Path::new("t.jpg")), Err(PlotError::Format(e)) if e == "jpg")
        );
    }
}
