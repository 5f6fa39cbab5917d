//! The two rotary jobs end to end, for the command line and Python alike: write the program,
//! read it back as the machine runs it ([`super::preview::ProgramPass`]), in the same read draw
//! it if asked (the toolpath pass and the isometric view of `gweave preview`), and report what it
//! does (serialisable, the `--json` documents).
//!
//! - [`wrap_file`]: a flat G-code file wrapped onto the mandrel; per layer the radius, the
//!   angles the beads sweep and where the weld line (flat y = 0) lies.
//! - [`tube_file`]: a helical tube; per layer the radius, handedness, turns, spindle speed and
//!   where the layer starts and ends (the next one starts there: there is no seam).
//!
//! The commands' flags and Python's keywords reach the settings through
//! [`super::overrides`]; the settings of custom helical paths (`gweave.write_helical_paths`)
//! come as one JSON document merged over a TOML file ([`merged_settings`]).

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::Serialize;

use super::cylinder::{FeedConvention, RotaryConfig, RotaryUnit};
use super::helix::{Handedness, ProgramSummary, TubeParams};
use super::preview::{LayerSummary, Program, ProgramPass, RotaryReading};
use super::wrap::{wrap, WrapConfig};
use super::{Result, RotaryError};
use crate::gcode::writer::{write_file, Output, Target};
use crate::malformed::Malformed;
use crate::pass::Strictness;
use crate::render::toolpath::{ToolpathOptions, ToolpathPass};
use crate::render::{png_out, view, Both, ColourBy, ViewKind, ViewOptions, MAX_SEGMENTS};
use crate::run::{Dest, Run};

/// Bead width drawn in the preview of a wrapped part, mm: 0, thin (2 px) toolpaths, so that
/// the infill, the layers below and the weld line stay visible through a solid skin.
pub const WRAP_PREVIEW_BEAD_MM: f64 = 0.0;

/// Size of a `--preview` picture, pixels.
pub const PREVIEW_SIZE_PX: [u32; 2] = [800, 600];

/// The machine a program was written for.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MachineReport {
    /// Mandrel diameter, mm.
    pub mandrel_diameter_mm: f64,
    /// Its circumference `pi * D`, mm.
    pub circumference_mm: f64,
    /// Axis letters: axial, rotary, radial.
    pub axes: String,
    /// Unit of the rotary word.
    pub rotary_unit: RotaryUnit,
    /// How F is written.
    pub feed_convention: FeedConvention,
}

impl MachineReport {
    /// The figures of a machine.
    pub fn of(m: &RotaryConfig) -> Self {
        Self {
            mandrel_diameter_mm: m.mandrel_diameter_mm,
            circumference_mm: m.circumference_mm(),
            axes: [m.axial_axis, m.rotary_axis, m.radial_axis].iter().collect(),
            rotary_unit: m.rotary_unit,
            feed_convention: m.feed_convention,
        }
    }
}

/// One layer of a wrapped part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WrapLayer {
    /// What the layer's beads do (the radius is the nozzle's, `R0 + z`).
    #[serde(flatten)]
    pub layer: LayerSummary,
    /// Angle the beads sweep, `theta max - theta min`, degrees. A part that wraps once and
    /// closes sweeps `360 - 360 * w / C` for a bead width `w`.
    pub span_deg: f64,
    /// Where the flat y = 0 (the weld line) lies on this layer, degrees in `[0, 360)`.
    pub seam_deg: f64,
}

/// What `rotary wrap` did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WrapReport {
    /// The flat file.
    pub input: PathBuf,
    /// The written file (`None` for standard output, which is not read back).
    pub output: Option<PathBuf>,
    /// The machine.
    pub machine: MachineReport,
    /// The Diabase mapping was used.
    pub keep_arc_length: bool,
    /// Each layer was wound as one turn of a helix (no weld line).
    pub helical: bool,
    /// Seam angle of layer 0, degrees.
    pub seam_offset_deg: f64,
    /// Seam turn per layer, degrees.
    pub seam_rotation_per_layer_deg: f64,
    /// Chord tolerance on the cylinder, mm.
    pub chord_tolerance_mm: f64,
    /// Per layer, read back.
    pub layers: Vec<WrapLayer>,
    /// Filament of the beads, mm (unretractions not counted).
    pub filament_mm: f64,
    /// Time of every move as the firmware reads F, seconds (no acceleration).
    pub time_s: f64,
}

/// One layer of a tube.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeLayer {
    /// 0-based index.
    pub index: u32,
    /// Bead centreline radius, mm.
    pub radius_mm: f64,
    /// Sense of the helix.
    pub handedness: Handedness,
    /// Turns of the mandrel, end turns included.
    pub turns: f64,
    /// Spindle speed at the print speed, deg/s.
    pub angular_speed_deg_s: f64,
    /// Axial position at the start and the end, mm.
    pub axial_mm: [f64; 2],
    /// Angle at the start and the end (the next layer starts there: no seam), degrees.
    pub theta_deg: [f64; 2],
}

/// What `rotary tube` did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeReport {
    /// The written file (`None` for standard output).
    pub output: Option<PathBuf>,
    /// The machine.
    pub machine: MachineReport,
    /// Tube length, mm.
    pub length_mm: f64,
    /// Layer height, mm.
    pub layer_height_mm: f64,
    /// Bead width, mm.
    pub bead_width_mm: f64,
    /// Axial advance per turn, mm.
    pub pitch_mm: f64,
    /// Handedness reverses every layer.
    pub interweave: bool,
    /// Per layer.
    pub layers: Vec<TubeLayer>,
    /// Filament pushed, mm.
    pub filament_mm: f64,
    /// Its volume, mm^3.
    pub extruded_mm3: f64,
    /// Volume of the closed tube wall `pi ((R0 + N h)^2 - R0^2) L`, mm^3.
    pub wall_volume_mm3: f64,
    /// Time as the firmware reads F, seconds (no acceleration).
    pub print_time_s: f64,
    /// Extruding moves read back from the written file (`None` for standard output).
    pub executed_beads: Option<usize>,
}

/// The file a target writes to, if it can be read back.
fn written_path(target: &Target, input: Option<&Path>) -> Option<PathBuf> {
    match target {
        Target::File(p) => Some(p.clone()),
        Target::InPlace { .. } => input.map(Path::to_path_buf),
        Target::Stdout(_) => None,
    }
}

/// A preview is drawn from the written file, so standard output cannot have one.
fn check_preview(target: &Target, preview: Option<&Path>) -> Result<()> {
    if preview.is_some() && target.is_stdout() {
        return Err(RotaryError::Config {
            key: "preview",
            reason: "a preview needs the G-code written to a file".into(),
        });
    }
    Ok(())
}

/// Reads the written program back and, in the same read, draws it to `preview` if asked: the
/// toolpath pass on the machine's cylinder (bounded by the segment ceiling), seen in the
/// isometric view, beads `bead_width_mm` wide (0: 2 px), travel hidden, coloured by tool when
/// the program changes tools and by layer otherwise.
fn read_back(
    machine: &RotaryConfig,
    output: Option<&Path>,
    preview: Option<&Path>,
    bead_width_mm: f64,
) -> Result<Option<Program>> {
    let Some(path) = output else {
        return Ok(None);
    };
    let reading = RotaryReading::new(machine)?;
    let mut program = ProgramPass::new(reading.clone());
    // A program gweave wrote holds a malformed line only where a lenient wrap copied one
    // through (a strict one refuses it first): it is read past here too.
    let run = Run::file(path).strictness(Strictness::Lenient);
    let Some(png) = preview else {
        run.scan(&mut program)?;
        return Ok(Some(program.finish()));
    };
    let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let mut toolpath = ToolpathPass::new(ToolpathOptions {
        travel: false,
        min_len_mm: ToolpathOptions::min_len_for_file_size(bytes),
        max_segments: Some(MAX_SEGMENTS),
        rotary: Some(reading),
        ..ToolpathOptions::default()
    });
    run.scan(&mut Both(&mut toolpath, &mut program))?;
    let toolpath = toolpath.finish_toolpath();
    let view = ViewOptions {
        kind: ViewKind::Iso,
        width_px: PREVIEW_SIZE_PX[0],
        height_px: PREVIEW_SIZE_PX[1],
        colour_by: if toolpath.tools > 1 { ColourBy::Tool } else { ColourBy::Layer },
        line_width_mm: bead_width_mm as f32,
        ..ViewOptions::default()
    };
    let image = png_out::rasterise(&view::draw(&toolpath, &view));
    let encoded = crate::picture::encode(&image).map_err(std::io::Error::other)?;
    write_file(png, |out| -> Result<()> { Ok(out.write_all(&encoded)?) })?;
    Ok(Some(program.finish()))
}

/// Wraps the file `run` reads to the target it writes (see [`super::wrap`]), reads the result
/// back and reports it, with the lines a lenient run read past.
pub fn wrap_file(
    config: &WrapConfig,
    run: Run<'_>,
    preview: Option<&Path>,
) -> Result<(WrapReport, Malformed)> {
    let input = run.source().path().to_path_buf();
    let output = match run.destination() {
        Dest::Target(target) => {
            check_preview(target, preview)?;
            written_path(target, Some(&input))
        }
        _ => None,
    };
    let ran = wrap(config.clone(), run)?;
    let program = read_back(&config.machine, output.as_deref(), preview, WRAP_PREVIEW_BEAD_MM)?;
    let program = program.unwrap_or_default();
    let layers = program
        .layers
        .iter()
        .map(|l| WrapLayer {
            layer: *l,
            span_deg: l.theta_range_deg[1] - l.theta_range_deg[0],
            seam_deg: config.unwrap.seam_deg(l.index).rem_euclid(360.0),
        })
        .collect();
    let report = WrapReport {
        input,
        output,
        machine: MachineReport::of(&config.machine),
        keep_arc_length: config.unwrap.keep_arc_length,
        helical: config.unwrap.helical,
        seam_offset_deg: config.unwrap.seam_offset_deg,
        seam_rotation_per_layer_deg: config.unwrap.seam_rotation_per_layer_deg,
        chord_tolerance_mm: config.chord_tolerance_mm,
        layers,
        filament_mm: program.filament_mm,
        time_s: program.time_s,
    };
    Ok((report, ran.malformed))
}

/// Writes the tube to `target`, reads it back and reports it.
pub fn tube_file(params: &TubeParams, target: &Target, preview: Option<&Path>) -> Result<TubeReport> {
    params.validate()?;
    check_preview(target, preview)?;
    let mut out = Output::create(target, None)?;
    let summary: ProgramSummary = params.write_gcode(BufWriter::new(&mut out))?;
    out.commit()?;
    let mut layers = Vec::new();
    let mut theta = 0.0;
    for k in 0..params.layers {
        let path = params.layer_path(k, theta);
        let points = path.points(params.print.resolution())?;
        let (Some(first), Some(last)) = (points.first(), points.last()) else {
            continue;
        };
        theta = last.theta_deg;
        layers.push(TubeLayer {
            index: k,
            radius_mm: params.layer_radius_mm(k),
            handedness: path.handedness,
            turns: (last.theta_deg - first.theta_deg).abs() / 360.0,
            angular_speed_deg_s: params.angular_speed_deg_s(k),
            axial_mm: [first.axial_mm, last.axial_mm],
            theta_deg: [first.theta_deg, last.theta_deg],
        });
    }
    let output = written_path(target, None);
    let program = read_back(&params.machine, output.as_deref(), preview, params.print.bead_width_mm)?;
    let area_mm2 = std::f64::consts::PI * params.print.filament_diameter_mm.powi(2) / 4.0;
    Ok(TubeReport {
        output,
        machine: MachineReport::of(&params.machine),
        length_mm: params.length_mm,
        layer_height_mm: params.print.layer_height_mm,
        bead_width_mm: params.print.bead_width_mm,
        pitch_mm: params.pitch(),
        interweave: params.interweave,
        layers,
        filament_mm: summary.filament_mm,
        extruded_mm3: summary.filament_mm * area_mm2,
        wall_volume_mm3: params.wall_volume_mm3(),
        print_time_s: summary.print_time_s,
        executed_beads: program.map(|p| p.beads),
    })
}

/// Settings of type `T` from an optional TOML file with `overrides` (a JSON object, the same
/// keys and tables) merged over it key by key; unknown keys are errors as in the file itself.
///
/// ```
/// use gweave::rotary::{helix::TubeParams, report::merged_settings};
/// let t: TubeParams = merged_settings(None, r#"{"layers": 2, "machine": {"mandrel_diameter_mm": 20}}"#).unwrap();
/// assert_eq!((t.layers, t.machine.mandrel_diameter_mm), (2, 20.0));
/// ```
pub fn merged_settings<T: DeserializeOwned>(toml_file: Option<&Path>, overrides: &str) -> Result<T> {
    let mut base = match toml_file {
        Some(path) => {
            let text = std::fs::read_to_string(path)?;
            let table: toml::Table = toml::from_str(&text)?;
            serde_json::to_value(table).map_err(json_error)?
        }
        None => serde_json::Value::Object(serde_json::Map::new()),
    };
    let over: serde_json::Value = serde_json::from_str(overrides).map_err(json_error)?;
    merge(&mut base, over);
    serde_json::from_value(base).map_err(json_error)
}

fn json_error(e: serde_json::Error) -> RotaryError {
    RotaryError::Config { key: "settings", reason: e.to_string() }
}

/// Merges `over` into `base`: objects key by key (recursively), anything else replaces; a
/// null in `over` leaves `base` as it is.
fn merge(base: &mut serde_json::Value, over: serde_json::Value) {
    use serde_json::Value;
    match (base, over) {
        (_, Value::Null) => {}
        (Value::Object(b), Value::Object(o)) => {
            for (key, value) in o.into_iter().filter(|(_, v)| !v.is_null()) {
                match b.get_mut(&key) {
                    Some(slot) => merge(slot, value),
                    None => {
                        let mut fresh = Value::Object(serde_json::Map::new());
                        merge(&mut fresh, value);
                        // A table of nulls only adds an empty table (its defaults).
                        b.insert(key, fresh);
                    }
                }
            }
        }
        (b, o) => *b = o,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_overrides_key_by_key_and_rejects_unknown_keys() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("tube.toml");
        std::fs::write(
            &file,
            "length_mm = 30\n[machine]\nmandrel_diameter_mm = 20\n[print]\nbead_width_mm = 0.5\n",
        )
        .unwrap();
        let t: TubeParams = merged_settings(
            Some(&file),
            r#"{"layers": 2, "print": {"layer_height_mm": 0.3}, "pitch_mm": null}"#,
        )
        .unwrap();
        assert_eq!((t.length_mm, t.layers, t.pitch_mm, t.interweave), (30.0, 2, None, true));
        // Nulls everywhere, nested too, leave every default in place.
        let d: TubeParams =
            merged_settings(None, r#"{"machine": {"mandrel_diameter_mm": 8, "rotary_unit": null}, "print": {"bead_width_mm": null}}"#)
                .unwrap();
        assert_eq!(d, TubeParams::new(RotaryConfig::new(8.0)));
        assert_eq!((t.print.bead_width_mm, t.print.layer_height_mm), (0.5, 0.3));
        let err = merged_settings::<TubeParams>(Some(&file), r#"{"print": {"speed": 3}}"#).unwrap_err();
        assert!(err.to_string().contains("unknown field `speed`"), "{err}");
    }

    #[test]
    fn tube_report_reads_back_what_it_wrote() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.gcode");
        let png = dir.path().join("t.png");
        let mut t = TubeParams::new(RotaryConfig::new(10.0));
        (t.length_mm, t.layers, t.pitch_mm) = (6.0, 2, Some(2.0));
        let r = tube_file(&t, &Target::File(out.clone()), Some(&png)).unwrap();
        assert_eq!(r.layers.len(), 2);
        assert_eq!((r.layers[0].handedness, r.layers[1].handedness), (Handedness::Right, Handedness::Left));
        // 5.6 mm of helix at 2 mm per turn plus two half end turns: 3.8 turns.
        assert!((r.layers[0].turns - 3.8).abs() < 1e-9, "{}", r.layers[0].turns);
        assert_eq!(r.layers[1].theta_deg[0], r.layers[0].theta_deg[1]);
        assert!(r.executed_beads.unwrap() > 100);
        assert!(std::fs::metadata(&png).unwrap().len() > 1000);
        let stdout = Target::Stdout(crate::gcode::container::Container::Text);
        let err = tube_file(&t, &stdout, Some(&png)).unwrap_err();
        assert!(matches!(err, RotaryError::Config { key: "preview", .. }));
    }
}
