//! `gweave preview` of rotary programs: drawn in 3D on their cylinder, asserting on the pixels.
//!
//! A tube of 2 layers of 0.2 mm on a 20 mm mandrel, 20 mm long along X. The beads are drawn
//! where the nozzle runs, on top of their layer: radii 10.2 and 10.4 mm. Seen from the top the
//! outer layer spans Y = -10.4..10.4 mm: the lit pixels of a column across
//! the tube must reach the projected radius on both sides of the axis and no further, and the
//! shading must fall off towards the silhouette, where the surface turns away from the eye. Read
//! flat (the rotary word as a coordinate) it would span the 65 mm of the circumference instead.

use std::path::PathBuf;

use gweave::picture::Image;
use gweave::render::png_out::rasterise;
use gweave::render::view::BACKGROUND;
use gweave::render::{drawing, ColourBy, Format, ViewKind, ViewOptions};
use gweave::rotary::cylinder::RotaryConfig;
use gweave::rotary::helix::TubeParams;
use gweave::PreviewSettings;

/// A two-layer tube written to `name` in `dir` (a test's own temporary folder).
fn tube_file(dir: &tempfile::TempDir, name: &str) -> (PathBuf, TubeParams) {
    let mut tube = TubeParams::new(RotaryConfig::new(20.0));
    (tube.length_mm, tube.layers) = (20.0, 2);
    let mut gcode = Vec::new();
    tube.write_gcode(&mut gcode).unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, gcode).unwrap();
    (path, tube)
}

/// Rows of column `x` that are not background.
fn lit_rows(img: &Image, x: f32) -> Vec<u32> {
    (0..img.height)
        .filter(|&y| {
            let p = img.pixel(x as u32, y);
            [p[0], p[1], p[2]] != BACKGROUND
        })
        .collect()
}

fn options(kind: ViewKind) -> PreviewSettings {
    let view =
        ViewOptions { kind, width_px: 400, height_px: 400, colour_by: ColourBy::Layer, ..Default::default() };
    PreviewSettings { view, ..PreviewSettings::default() }
}

#[test]
fn a_tube_is_drawn_round_on_its_cylinder() {
    let dir = tempfile::tempdir().unwrap();
    let (path, tube) = tube_file(&dir, "tube.gcode");
    let r_mm = (tube.layer_radius_mm(1) + tube.print.layer_height_mm / 2.0) as f32;
    assert!((r_mm - 10.4).abs() < 1e-4, "{r_mm}");
    // The header names the machine: no rotary option needed.
    let d = drawing(&path, None, &options(ViewKind::Top), &mut gweave::Quiet).unwrap();
    let img = rasterise(&d);
    let proj = d.panels[0].projection;
    let x_mm = 10.0;
    let [col, axis_row] = proj.project([x_mm, 0.0, 0.0]);
    let top = proj.project([x_mm, r_mm, 0.0])[1];
    let bottom = proj.project([x_mm, -r_mm, 0.0])[1];
    let lit = lit_rows(&img, col);
    let (first, last) = (*lit.first().unwrap() as f32, *lit.last().unwrap() as f32);
    // Half a bead width (0.45 mm drawn) plus a pixel of anti-aliasing beyond the centre line.
    let slack = 0.45 / 2.0 * proj.scale_px_mm() + 1.5;
    assert!((first - top).abs() <= slack, "top edge at row {first}, expected {top} +- {slack}");
    assert!((last - bottom).abs() <= slack, "bottom edge at row {last}, expected {bottom} +- {slack}");
    assert!(((first + last) / 2.0 - axis_row).abs() < 1.5, "symmetric about the axis");
    assert_eq!(lit.len() as f32, last - first + 1.0, "a closed wall: every row between lit");
    // Facing the eye over the axis, turned away at the silhouette: darker there.
    let brightness = |y: f32| img.pixel(col as u32, y as u32)[..3].iter().map(|&v| v as u32).sum::<u32>();
    let centre = brightness(axis_row);
    let near_edge = brightness(top + 0.1 * (axis_row - top));
    assert!(centre > near_edge + 60, "centre {centre}, near the edge {near_edge}");

    // Isometric: the outline is symmetric about the projected axis.
    let d = drawing(&path, None, &options(ViewKind::Iso), &mut gweave::Quiet).unwrap();
    let img = rasterise(&d);
    let proj = d.panels[0].projection;
    let [ax, ay] = proj.project([x_mm, 0.0, 0.0]);
    // A cylinder's outline is a band between two lines parallel to its projected axis: a
    // vertical line through the axis crosses them at equal distances on either side.
    let lit = lit_rows(&img, ax);
    let (first, last) = (*lit.first().unwrap() as f32, *lit.last().unwrap() as f32);
    assert!(((first + last) / 2.0 - ay).abs() < 2.0, "{first}..{last} about {ay}");
    // At least the radius on each side (the band is wider along a vertical than across).
    assert!((last - first) / 2.0 >= r_mm * proj.scale_px_mm() - 1.0);
}

#[test]
fn the_viewer_page_of_a_tube_carries_its_3d_segments() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = tube_file(&dir, "tube_html.gcode");
    let html = gweave::preview(&path, None, Format::Html, &options(ViewKind::Iso)).unwrap();
    let html = String::from_utf8(html).unwrap();
    // Quantisation bounds of the 3D segments: Y and Z span the outer diameter, not the
    // circumference or the radial word.
    let lo = html.split("\"lo\":[").nth(1).unwrap().split(']').next().unwrap().to_owned();
    let lo: Vec<f32> = lo.split(',').map(|v| v.parse().unwrap()).collect();
    assert!((lo[1] + 10.4).abs() < 0.01 && (lo[2] + 10.4).abs() < 0.01, "{lo:?}");
}

/// Whether `p` is `base` shaded, as the cylinder shading does (`base * k`, k in 0.35..1, each
/// channel rounded).
fn shade_of(p: [u8; 4], base: [u8; 3]) -> bool {
    let i = (0..3).max_by_key(|&i| base[i]).unwrap();
    let k = f32::from(p[i]) / f32::from(base[i]);
    (0.34..=1.0).contains(&k) && (0..3).all(|c| (f32::from(p[c]) - f32::from(base[c]) * k).abs() <= 2.0)
}

/// Regression (issues 23 and 27): `rotary wrap --preview` drew every layer in a colour of its
/// own, so a two-tool part showed neither tool. It now goes through the toolpath pass and is
/// coloured by tool when the program changes tools.
#[test]
fn a_wrapped_two_tool_part_previews_in_both_tools_colours() {
    use gweave::render::colour_by::TOOL_COLOURS;
    use gweave::rotary::wrap::WrapConfig;
    use gweave::wrap_file;
    use gweave::Target;

    // A band of each tool, 20 mm across the flat Y (76 degrees of a 30 mm mandrel), the travel
    // between them never drawn.
    let mut flat = String::from(";LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F1200\nT0\n");
    let mut e = 0.0;
    for (tool, y0) in [(0, 0.0), (1, 30.0)] {
        flat.push_str(&format!("T{tool}\nG0 X0 Y{y0}\n"));
        for i in 0..40 {
            e += 2.0;
            let x = if i % 2 == 0 { 40 } else { 0 };
            flat.push_str(&format!(
                "G1 X{x} Y{:.1} E{e:.1}\nG1 Y{:.1}\n",
                y0 + 0.5 * i as f64,
                y0 + 0.5 * (i + 1) as f64
            ));
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let (input, output, png) =
        (dir.path().join("flat.gcode"), dir.path().join("wrapped.gcode"), dir.path().join("wrapped.png"));
    std::fs::write(&input, flat).unwrap();
    let config = WrapConfig::new(RotaryConfig::new(30.0));
    let target = Target::File(output);
    wrap_file(&config, gweave::Run::file(&input).to(&target), Some(&png)).unwrap();
    let img = gweave::picture::decode(&std::fs::read(&png).unwrap()).unwrap();
    let count = |c: gweave::colour::Srgb8| {
        (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| shade_of(img.pixel(x, y), [c.r, c.g, c.b]))
            .count()
    };
    let (t0, t1) = (count(TOOL_COLOURS[0]), count(TOOL_COLOURS[1]));
    // Each band covers thousands of pixels of an 800 x 600 picture.
    assert!(t0 > 2000 && t1 > 2000, "tool 0: {t0} px, tool 1: {t1} px");
}
