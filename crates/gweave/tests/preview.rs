//! `gweave preview` on real slicer files, asserting on the pixels.
//!
//! `cura/cura_dual.gcode` prints a cylinder with T0 and a sphere with T1. From the file, layer
//! 60 (Z 12.3) extrudes T0 over X 117.6..145.4, Y 108.6..136.4 (the cylinder, centre
//! (131.5, 122.5), radius 13.9) and T1 over X 110.7..126.3, Y 119.7..135.3 (the sphere's
//! section, centre (118.5, 127.5), radius 7.8).

use std::path::{Path, PathBuf};

use gweave::picture::decode;
use gweave::picture::Image;
use gweave::render::colour_by::TOOL_COLOURS;
use gweave::render::png_out::rasterise;
use gweave::render::view::{Drawing, BACKGROUND, UNCHANGED};
use gweave::render::{drawing, svg, Format, ViewKind, ViewOptions};
use gweave::{preview, preview_with_progress, PreviewSettings, Quiet, Toolpath, ToolpathOptions};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(rel)
}

fn dual() -> PathBuf {
    data("cura/cura_dual.gcode")
}

fn options(view: ViewOptions) -> PreviewSettings {
    PreviewSettings { view, ..PreviewSettings::default() }
}

fn layer(n: u32) -> ViewOptions {
    ViewOptions { layers: Some(n..=n), ..ViewOptions::default() }
}

fn draw(path: &Path, compare: Option<&Path>, view: ViewOptions) -> (Drawing, Image) {
    let d = drawing(path, compare, &options(view), &mut gweave::Quiet).unwrap();
    let img = rasterise(&d);
    (d, img)
}

fn rgb(c: gweave::colour::Srgb8) -> [u8; 3] {
    [c.r, c.g, c.b]
}

/// How many pixels of a 15 x 15 patch around `p` have exactly colour `c`.
fn count_near(img: &Image, p: [f32; 2], c: [u8; 3]) -> usize {
    let mut n = 0;
    for y in p[1] as i32 - 7..=p[1] as i32 + 7 {
        for x in p[0] as i32 - 7..=p[0] as i32 + 7 {
            if x >= 0 && y >= 0 && (x as u32) < img.width && (y as u32) < img.height {
                let px = img.pixel(x as u32, y as u32);
                n += usize::from([px[0], px[1], px[2]] == c);
            }
        }
    }
    n
}

fn is_background(img: &Image, x: u32, y: u32) -> bool {
    let p = img.pixel(x, y);
    [p[0], p[1], p[2]] == BACKGROUND
}

#[test]
fn the_two_tools_of_cura_dual_draw_in_their_own_colours_where_they_print() {
    let (d, img) = draw(&dual(), None, layer(60));
    let proj = d.panels[0].projection;
    let (t0, t1) = (rgb(TOOL_COLOURS[0]), rgb(TOOL_COLOURS[1]));
    assert_ne!(t0, t1);
    // Inside the sphere's section, away from the cylinder: T1.
    let sphere = proj.project([114.0, 128.0, 12.3]);
    assert!(count_near(&img, sphere, t1) > 150, "{}", count_near(&img, sphere, t1));
    assert_eq!(count_near(&img, sphere, t0), 0);
    // On the cylinder's outer wall at its lowest Y, away from the sphere: T0.
    let wall = proj.project([131.5, 108.8, 12.3]);
    assert!(count_near(&img, wall, t0) > 40, "{}", count_near(&img, wall, t0));
    assert_eq!(count_near(&img, wall, t1), 0);
    // Far outside both objects: background.
    let outside = proj.project([146.0, 140.0, 12.3]);
    assert!(is_background(&img, outside[0] as u32, outside[1] as u32));
    // The same picture through the file-level API, as PNG bytes.
    let png = preview(&dual(), None, Format::Png, &options(layer(60))).unwrap();
    assert_eq!(decode(&png).unwrap(), img);
}

/// Layers past the last: the drawing is blank, and a preview refuses them, naming the last
/// layer (a blank picture with exit 0 told a user nothing).
#[test]
fn layers_beyond_the_last_draw_blank_and_a_preview_refuses_them() {
    let tp = Toolpath::from_file(&dual(), ToolpathOptions { travel: false, ..ToolpathOptions::default() })
        .unwrap();
    assert_eq!(tp.layer_count(), 204);
    let view =
        ViewOptions { layers: Some(204..=300), width_px: 320, height_px: 240, ..ViewOptions::default() };
    let img = rasterise(&gweave::render::view::draw(&tp, &view));
    assert_eq!((img.width, img.height), (320, 240));
    assert!(img.rgba.chunks_exact(4).all(|p| p[..3] == BACKGROUND), "all background");
    let err = preview(&dual(), None, Format::Png, &options(view)).err().map(|e| e.to_string());
    assert_eq!(err.as_deref(), Some("layer 204 is past the file's last layer, 203 (layers count from 0)"));
}

#[test]
fn iso_view_of_the_whole_print_is_not_blank() {
    let view = ViewOptions { kind: ViewKind::Iso, width_px: 600, height_px: 450, ..ViewOptions::default() };
    let (d, img) = draw(&dual(), None, view);
    let drawn = img.rgba.chunks_exact(4).filter(|p| p[..3] != BACKGROUND).count();
    let share = drawn as f64 / (600.0 * 450.0);
    assert!(share > 0.15 && share < 0.6, "{share}");
    // The top of the sphere (Z 42.9) is drawn above the cylinder's top (Z ~30) in the picture.
    let proj = d.panels[0].projection;
    assert!(proj.project([118.5, 127.5, 42.9])[1] < proj.project([131.5, 122.5, 30.0])[1]);
    assert_eq!(d.legend.iter().map(|e| e.label.as_str()).collect::<Vec<_>>(), ["T0", "T1"]);
}

/// Shifts X of every move in layer `n` of a Cura file by `dx_mm`.
fn shift_layer(text: &str, n: u32, dx_mm: f64) -> String {
    let mut out = String::with_capacity(text.len());
    let mut in_layer = false;
    for line in text.lines() {
        if let Some(l) = line.strip_prefix(";LAYER:") {
            in_layer = l.trim() == n.to_string();
        }
        let shifted = in_layer && (line.starts_with("G0 ") || line.starts_with("G1 "));
        if !shifted {
            out.push_str(line);
        } else {
            let words: Vec<String> = line
                .split(' ')
                .map(|w| match w.strip_prefix('X').and_then(|v| v.parse::<f64>().ok()) {
                    Some(x) => format!("X{:.3}", x + dx_mm),
                    None => w.to_string(),
                })
                .collect();
            out.push_str(&words.join(" "));
        }
        out.push('\n');
    }
    out
}

#[test]
fn compare_highlights_only_the_changed_layer() {
    let dir = tempfile::tempdir().unwrap();
    let after = dir.path().join("after.gcode");
    std::fs::write(&after, shift_layer(&std::fs::read_to_string(dual()).unwrap(), 60, 3.0)).unwrap();

    let (d, img) = draw(&dual(), Some(&after), layer(60));
    let moved = Toolpath::from_file(
        &after,
        ToolpathOptions { layers: Some(60..=60), travel: false, ..ToolpathOptions::default() },
    )
    .unwrap();
    assert_eq!(d.panels[1].title, format!("after - {} moves changed", moved.segments.len()));
    assert!(moved.segments.len() > 300, "{}", moved.segments.len());
    // The report of the same preview: the moves changed on each side (layer 60 of both files,
    // one for one), what was drawn, the legend.
    let report = preview_with_progress(&dual(), Some(&after), Format::Svg, &options(layer(60)), &mut Quiet)
        .unwrap()
        .report;
    let n = moved.segments.len();
    assert_eq!(report.changed_moves, Some([n, n]));
    assert_eq!(
        (report.format, report.layers_drawn, report.strokes),
        ("svg", Some([60, 60]), Some(d.strokes.len()))
    );
    // Highlighted moves are drawn in their tool colours on both sides.
    let t1 = rgb(TOOL_COLOURS[1]);
    let sphere_after = d.panels[1].projection.project([114.0 + 3.0, 128.0, 12.3]);
    assert!(count_near(&img, sphere_after, t1) > 100);
    let sphere_before = d.panels[0].projection.project([114.0, 128.0, 12.3]);
    assert!(count_near(&img, sphere_before, t1) > 100);

    // An unchanged layer: everything drawn is grey.
    let (d59, img59) = draw(&dual(), Some(&after), layer(59));
    assert_eq!(d59.panels[1].title, "after - 0 moves changed");
    assert!(d59.strokes.iter().all(|s| s.colour == UNCHANGED));
    // The right half (the legend is on the left).
    let after_half: Vec<[u8; 4]> = (0..img59.height)
        .flat_map(|y| (600..img59.width).map(move |x| (x, y)))
        .map(|(x, y)| img59.pixel(x, y))
        .collect();
    let in_colour = after_half.iter().filter(|p| TOOL_COLOURS[..2].iter().any(|&c| p[..3] == rgb(c))).count();
    assert_eq!(in_colour, 0);
    let grey = after_half.iter().filter(|p| p[..3] == UNCHANGED).count();
    assert!(grey > 50_000, "{grey}");
}

/// Chains of extruding moves in layer `n` of a Cura file (absolute E): a chain breaks where an
/// extruding move does not start where the last one ended, or the tool changes.
fn chains_in_layer(text: &str, n: u32) -> usize {
    let (mut x, mut y, mut e) = (0.0f64, 0.0f64, 0.0f64);
    let (mut tool, mut layer) = (0u32, None::<u32>);
    let mut last_end: Option<(f64, f64, u32)> = None;
    let mut chains = 0;
    for line in text.lines() {
        if let Some(l) = line.strip_prefix(";LAYER:") {
            layer = l.trim().parse().ok();
        }
        if let Some(t) = line.strip_prefix('T') {
            tool = t.trim().parse().unwrap_or(tool);
        }
        let word = |letter: char| {
            line.split(';')
                .next()
                .unwrap()
                .split(' ')
                .find_map(|w| w.strip_prefix(letter)?.parse::<f64>().ok())
        };
        if line.starts_with("G92") {
            e = word('E').unwrap_or(e);
            continue;
        }
        if !(line.starts_with("G0 ") || line.starts_with("G1 ")) {
            continue;
        }
        let (nx, ny, ne) = (word('X').unwrap_or(x), word('Y').unwrap_or(y), word('E').unwrap_or(e));
        let extruding = ne > e && (nx != x || ny != y);
        if extruding && layer == Some(n) && last_end != Some((x, y, tool)) {
            chains += 1;
        }
        if extruding {
            last_end = Some((nx, ny, tool));
        }
        (x, y, e) = (nx, ny, ne);
    }
    chains
}

#[test]
fn svg_has_one_path_per_chain_of_extrusion() {
    let text = std::fs::read_to_string(dual()).unwrap();
    let expected = chains_in_layer(&text, 60);
    assert!(expected > 10, "{expected}");
    let svg = String::from_utf8(preview(&dual(), None, Format::Svg, &options(layer(60))).unwrap()).unwrap();
    assert_eq!(svg.matches("<path ").count(), expected);
    assert!(svg.starts_with("<svg ") && svg.trim_end().ends_with("</svg>"));
    let (d, _) = draw(&dual(), None, layer(60));
    assert_eq!(svg::runs(&d.strokes).len(), expected);
}

#[test]
fn html_embeds_every_segment_and_the_stats() {
    let html =
        String::from_utf8(preview(&dual(), None, Format::Html, &options(ViewOptions::default())).unwrap())
            .unwrap();
    let tp = Toolpath::from_file(&dual(), ToolpathOptions::default()).unwrap();
    assert!(html.contains(&format!("\"n\":{},", tp.segments.len())));
    assert!(html.contains("\"slicer\":\"cura\""), "stats embedded");
    assert!(!html.contains("/*GWEAVE_DATA*/"));
}

/// What `gweave preview` says it drew: the layers (clipped to the file's `;LAYER:0` to `;LAYER:203`;
/// its `;LAYER_COUNT:205` counts one more than Cura writes), the lines in the
/// picture, the legend; the whole file in the viewer page; an error for layers the file lacks.
#[test]
fn the_report_says_what_the_preview_shows() {
    let (d, _) = draw(&dual(), None, layer(60));
    let png = preview_with_progress(&dual(), None, Format::Png, &options(layer(60)), &mut Quiet).unwrap();
    let r = png.report;
    assert_eq!((r.format, r.bytes, r.width_px, r.height_px), ("png", png.bytes.len(), 1200, 900));
    assert_eq!(
        (r.layers_drawn, r.strokes, r.moves, r.changed_moves),
        (Some([60, 60]), Some(d.strokes.len()), None, None)
    );
    assert!(d.strokes.len() > 500, "{}", d.strokes.len());
    let legend: Vec<(&str, gweave::colour::Srgb8)> =
        r.legend.iter().map(|e| (e.label.as_str(), e.colour)).collect();
    assert_eq!(legend, [("T0", TOOL_COLOURS[0]), ("T1", TOOL_COLOURS[1])]);

    let tail = ViewOptions { layers: Some(200..=300), ..ViewOptions::default() };
    let r = preview_with_progress(&dual(), None, Format::Png, &options(tail), &mut Quiet).unwrap().report;
    assert_eq!(r.layers_drawn, Some([200, 203]));
    // Past the last layer: refused with the last layer named (it was a blank picture, exit 0).
    let past = ViewOptions { layers: Some(300..=400), ..ViewOptions::default() };
    for format in [Format::Png, Format::Html] {
        let err = preview_with_progress(&dual(), None, format, &options(past.clone()), &mut Quiet)
            .err()
            .map(|e| e.to_string());
        assert_eq!(
            err.as_deref(),
            Some("layer 300 is past the file's last layer, 203 (layers count from 0)")
        );
    }

    let html =
        preview_with_progress(&dual(), None, Format::Html, &options(ViewOptions::default()), &mut Quiet)
            .unwrap()
            .report;
    let all = Toolpath::from_file(&dual(), ToolpathOptions::default()).unwrap();
    assert_eq!(
        (html.format, html.layers_drawn, html.moves),
        ("html", Some([0, 203]), Some(all.segments.len()))
    );
}

/// `--layers 0-60` on the viewer page said "layers 0-203" (every layer) and opened on them all:
/// the report and the page's opening range are what was asked, clipped to the file.
#[test]
fn the_html_report_says_the_layers_asked_for() {
    let page = |layers| {
        let view = ViewOptions { layers, ..ViewOptions::default() };
        preview_with_progress(&dual(), None, Format::Html, &options(view), &mut Quiet).unwrap()
    };
    let p = page(Some(0..=60));
    assert_eq!(p.report.layers_drawn, Some([0, 60]));
    assert!(String::from_utf8(p.bytes).unwrap().contains("\"layers\":[0,60]"));
    assert_eq!(page(Some(150..=900)).report.layers_drawn, Some([150, 203]));
    let all = page(None);
    assert_eq!(all.report.layers_drawn, Some([0, 203]));
    assert!(String::from_utf8(all.bytes).unwrap().contains("\"layers\":null"));
}

/// Every call a progress bar would get.
#[derive(Default)]
struct Recorder(Vec<(&'static str, u64)>);

impl gweave::Progress for Recorder {
    fn set_len(&mut self, bytes: u64) {
        self.0.push(("len", bytes));
    }
    fn advance(&mut self, done: u64) {
        self.0.push(("advance", done));
    }
    fn stage(&mut self, name: &'static str, len: u64) {
        self.0.push((name, len));
    }
}

/// Regression (issue 23): a long preview showed a finished bar, then nothing while it drew. The
/// drawing is now a stage of its own, reported to its end, after the reading.
#[test]
fn progress_covers_the_drawing_after_the_reading() {
    let mut rec = Recorder::default();
    let view = ViewOptions { kind: ViewKind::Iso, ..ViewOptions::default() };
    let p = preview_with_progress(&dual(), None, Format::Png, &options(view), &mut rec).unwrap();
    let strokes = p.report.strokes.unwrap() as u64;
    let bytes = std::fs::metadata(dual()).unwrap().len();
    let stage = rec.0.iter().position(|e| e.0 == "drawing").expect("a drawing stage");
    assert_eq!(rec.0[0], ("len", bytes));
    assert_eq!(rec.0[stage], ("drawing", strokes));
    assert_eq!(rec.0.last(), Some(&("advance", strokes)));
    // Before the stage, byte counts up to the file's end; after it, strokes, never going back.
    assert!(rec.0[..stage].iter().all(|e| e.0 != "advance" || e.1 <= bytes));
    let after: Vec<u64> = rec.0[stage + 1..].iter().map(|e| e.1).collect();
    assert!(after.windows(2).all(|w| w[0] <= w[1]), "{after:?}");
    assert!(strokes > 1000, "{strokes}");
}
