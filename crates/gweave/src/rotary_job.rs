//! The two rotary jobs end to end, for the command line and Python alike: write the program,
//! read it back as the machine runs it ([`crate::rotary::preview::ProgramPass`]), in the same
//! read draw it if asked (the toolpath pass and the isometric view of `gweave preview`), and
//! report what it does ([`crate::rotary::report`]).
//!
//! - [`wrap_file`]: a flat G-code file wrapped onto the mandrel.
//! - [`tube_file`]: a helical tube.
//!
//! It sits above `render/` (it draws the `--preview`), as `rotary/` sits below it (the toolpath
//! pass reads rotary programs on their cylinder): so every arrow points down.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::gcode::writer::{write_file, Output, Target};
use crate::malformed::Malformed;
use crate::pass::Strictness;
use crate::render::toolpath::{ToolpathOptions, ToolpathPass};
use crate::render::{png_out, view, Both, ColourBy, ViewKind, ViewOptions, MAX_SEGMENTS};
use crate::rotary::cylinder::RotaryConfig;
use crate::rotary::helix::{ProgramSummary, TubeParams};
use crate::rotary::preview::{Program, ProgramPass, RotaryReading};
use crate::rotary::report::{MachineReport, TubeLayer, TubeReport, WrapLayer, WrapReport};
use crate::rotary::wrap::{wrap, WrapConfig};
use crate::rotary::{Result, RotaryError};
use crate::run::{Dest, Run};

/// Bead width drawn in the preview of a wrapped part, mm: 0, thin (2 px) toolpaths, so that
/// the infill, the layers below and the weld line stay visible through a solid skin.
pub(crate) const WRAP_PREVIEW_BEAD_MM: f64 = 0.0;

/// Size of a `--preview` picture, pixels.
pub(crate) const PREVIEW_SIZE_PX: [u32; 2] = [800, 600];

/// The file a target writes to, if it can be read back.
fn written_path(target: &Target, input: Option<&Path>) -> Option<PathBuf> {
    match target {
        Target::File(p) => Some(p.clone()),
        Target::Scratch(s) => Some(s.path().to_path_buf()),
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

/// Wraps the file `run` reads to the target it writes (see [`crate::rotary::wrap`]), reads the result
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotary::helix::Handedness;
    use crate::rotary::RotaryError;

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
