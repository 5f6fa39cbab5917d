//! Previews (`gweave preview`) and the toolpath as columns for the notebook viewer.

use crate::interrupt::interruptible;
use std::path::PathBuf;

use gweave::pass::Quiet;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::{in_range, os_error, LayersArg};
use crate::{err, strictness, to_json};
use gweave::colour::Srgb8;
use gweave::gcode::layers::ALL_FEATURES;
use gweave::render::layer_range;
use gweave::render::{
    self, ColourBy, Format, PreviewOptions, Toolpath, ToolpathOptions, ViewKind, ViewOptions,
};
use pyo3::types::PyBytes;

// ---- preview (render) ----

/// A picture or viewer page of a file as bytes (`format`: png, svg or html) and the report of
/// what it shows as JSON; see `gweave preview`.
#[pyfunction]
#[pyo3(signature = (path, *, format, layer=None, layers=None, view=None, colour_by="tool", size=(1200, 900), compare=None, tool_colours=None, travel=false, mix_profile=None, mandrel_diameter=None, head=None, min_len=None, lenient=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn preview_json(
    py: Python<'_>,
    path: PathBuf,
    format: &str,
    layer: Option<u32>,
    layers: Option<LayersArg>,
    view: Option<&str>,
    colour_by: &str,
    size: (i64, i64),
    compare: Option<PathBuf>,
    tool_colours: Option<Vec<String>>,
    travel: bool,
    mix_profile: Option<PathBuf>,
    mandrel_diameter: Option<f64>,
    head: Option<PathBuf>,
    min_len: Option<f32>,
    lenient: bool,
) -> PyResult<(Py<PyBytes>, String)> {
    let read = |p: &PathBuf| gweave::settings::read_text(p).map_err(|e| os_error(p, &e));
    let layer = in_range("layer", layer, gweave::range::LAYER_NUMBER)?;
    // Read as any Python int, then held to the range under the keyword's name: as `(u32, u32)`,
    // `size=(-1, 5)` was an OverflowError that did not say which argument.
    let side = |name: &str, v: i64| -> PyResult<u32> {
        let r = render::PICTURE_SIDE_PX;
        let range = gweave::range::Range::new(i64::from(r.min), i64::from(r.max), r.unit);
        range.check(name, v).map(|v| v as u32).map_err(|e| PyValueError::new_err(e.to_string()))
    };
    let size = (side("size[0]", size.0)?, side("size[1]", size.1)?);
    let mandrel_diameter =
        in_range("mandrel_diameter", mandrel_diameter, gweave::rotary::cylinder::MANDREL_DIAMETER_MM)?;
    let printhead = match head {
        Some(p) => Some(
            gweave::gen::printhead::PrintheadProfile::from_toml(&read(&p)?)
                .map_err(|e| PyValueError::new_err(e.to_string()))?,
        ),
        None => None,
    };
    let mix = match mix_profile {
        Some(p) => {
            let text = read(&p)?;
            let profile = gweave::post::mix::profile::MixProfile::from_toml_str(&text)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            Some(
                render::MixColours::from_profile(&profile)
                    .map_err(|e| PyValueError::new_err(e.to_string()))?,
            )
        }
        None => None,
    };
    let format = Format::from_path(std::path::Path::new(&format!("x.{format}")))
        .map_err(|e| PyValueError::new_err(format!("output: {e}")))?;
    let tool_colours = tool_colours
        .unwrap_or_default()
        .iter()
        .map(|c| c.parse::<Srgb8>().map_err(|e| PyValueError::new_err(e.to_string())))
        .collect::<PyResult<Vec<_>>>()?;
    let options = PreviewOptions {
        view: ViewOptions {
            kind: match view {
                Some(v) => v.parse::<ViewKind>().map_err(PyValueError::new_err)?,
                None => format.default_view(),
            },
            layers: match (layer, layers) {
                (Some(l), _) => Some(layer_range(l, l).map_err(PyValueError::new_err)?),
                (None, Some(range)) => Some(range.range()?),
                (None, None) => None,
            },
            width_px: size.0,
            height_px: size.1,
            colour_by: colour_by.parse::<ColourBy>().map_err(PyValueError::new_err)?,
            tool_colours,
            travel,
            ..ViewOptions::default()
        },
        mix,
        rotary: mandrel_diameter.map(gweave::rotary::cylinder::RotaryConfig::new),
        printhead,
        min_len_mm: min_len,
        strictness: strictness(lenient),
    };
    let preview = interruptible(py, || {
        render::preview_with_progress(&path, compare.as_deref(), format, &options, &mut Quiet)
    })?
    .map_err(render_err)?;
    Ok((PyBytes::new(py, &preview.bytes).unbind(), to_json(&preview.report)?))
}

fn render_err(e: render::RenderError) -> PyErr {
    match e {
        render::RenderError::Gcode(e) => err(e),
        other => PyValueError::new_err(other.to_string()),
    }
}

/// A file's toolpath as little-endian column bytes: (segment count, {name: bytes}) with start
/// and end (f32 x 3 each), tool (u16), feature (u8, index into `feature_names`), feed_mm_s (f32),
/// layer (u32), extruding (u8 0/1). `gweave.toolpath` turns them into NumPy arrays. A rotary
/// program (its header names the machine, or `mandrel_diameter` is given) comes out in 3D on its
/// cylinder, mandrel along X, with `on_cylinder` true.
#[pyfunction]
#[pyo3(signature = (path, *, travel=true, min_len=0.0, mandrel_diameter=None))]
pub(crate) fn toolpath_columns(
    py: Python<'_>,
    path: PathBuf,
    travel: bool,
    min_len: f32,
    mandrel_diameter: Option<f64>,
) -> PyResult<(usize, Py<PyDict>)> {
    let machine = mandrel_diameter.map(gweave::rotary::cylinder::RotaryConfig::new);
    let rotary = gweave::rotary::preview::RotaryReading::for_file(&path, machine.as_ref())
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let options = ToolpathOptions { travel, min_len_mm: min_len, rotary, ..ToolpathOptions::default() };
    let tp = interruptible(py, || Toolpath::from_file(&path, options))?.map_err(err)?;
    let n = tp.segments.len();
    let mut cols: [(&str, Vec<u8>); 7] = [
        ("start", Vec::with_capacity(n * 12)),
        ("end", Vec::with_capacity(n * 12)),
        ("tool", Vec::with_capacity(n * 2)),
        ("feature", Vec::with_capacity(n)),
        ("feed_mm_s", Vec::with_capacity(n * 4)),
        ("layer", Vec::with_capacity(n * 4)),
        ("extruding", Vec::with_capacity(n)),
    ];
    for s in &tp.segments {
        cols[0].1.extend(s.start.iter().flat_map(|v| v.to_le_bytes()));
        cols[1].1.extend(s.end.iter().flat_map(|v| v.to_le_bytes()));
        cols[2].1.extend(s.tool.to_le_bytes());
        cols[3].1.push(s.feature as u8);
        cols[4].1.extend(s.feed_mm_s.to_le_bytes());
        cols[5].1.extend(s.layer.to_le_bytes());
        cols[6].1.push(u8::from(s.extruding));
    }
    let dict = PyDict::new(py);
    for (name, bytes) in cols {
        dict.set_item(name, PyBytes::new(py, &bytes))?;
    }
    let names: Vec<&str> = ALL_FEATURES.iter().map(|f| f.name()).collect();
    dict.set_item("feature_names", names)?;
    dict.set_item("layer_z", tp.layer_z_mm.clone())?;
    dict.set_item("on_cylinder", tp.on_cylinder)?;
    Ok((n, dict.unbind()))
}
