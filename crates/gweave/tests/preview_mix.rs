//! `gweave preview --colour-by mix` on the output of `gweave mix` and `gweave purge-shift`,
//! asserting on the pixels.
//!
//! `cura/cura_torus.gcode` (28 layers, one extruder) is mixed with a layer schedule: Blue
//! (50 % cyan, 50 % magenta) from layer 0, Yellow from layer 10, Magenta from layer 19, no
//! purge (`examples/mix/bands.toml`). Each layer of a band must draw in the colour the mixing model predicts for its mix.
//! Purge-shift (60 mm, across layers) then moves the change to Magenta back into layer 18: that
//! layer must show the washout's blend of yellow into magenta, which the unshifted file does not.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use gweave::picture::Image;
use gweave::post::mix::mix_bytes;
use gweave::post::mix::profile::MixProfile;
use gweave::post::purge_shift::purge_shift_bytes;
use gweave::render::png_out::rasterise;
use gweave::render::view::{Drawing, BACKGROUND};
use gweave::render::{drawing, ColourBy, MixColours, ViewOptions};
use gweave::{PreviewSettings, PurgeShiftConfig};

const BANDS: &str = include_str!("../../../examples/mix/bands.toml");

fn torus() -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cura/cura_torus.gcode");
    std::fs::read(path).unwrap()
}

/// Writes `bytes` to `name` in `dir` (a test's own temporary folder, removed when it ends).
fn write_temp(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn draw_layer(path: &Path, colours: &MixColours, layer: u32) -> (Drawing, Image) {
    let options = PreviewSettings {
        view: ViewOptions {
            layers: Some(layer..=layer),
            colour_by: ColourBy::Mix,
            width_px: 400,
            height_px: 300,
            ..ViewOptions::default()
        },
        mix: Some(colours.clone()),
        ..PreviewSettings::default()
    };
    let d = drawing(path, None, &options, &mut gweave::Quiet).unwrap();
    let img = rasterise(&d);
    (d, img)
}

/// Pixel count of each colour that is not the background.
fn histogram(img: &Image) -> HashMap<[u8; 3], usize> {
    let mut h = HashMap::new();
    for y in 0..img.height {
        for x in 0..img.width {
            let p = img.pixel(x, y);
            let c = [p[0], p[1], p[2]];
            if c != BACKGROUND {
                *h.entry(c).or_default() += 1;
            }
        }
    }
    h
}

fn dominant(img: &Image) -> ([u8; 3], usize) {
    histogram(img).into_iter().max_by_key(|&(c, n)| (n, c)).unwrap()
}

fn rgb(c: gweave::colour::Srgb8) -> [u8; 3] {
    [c.r, c.g, c.b]
}

#[test]
fn each_band_of_a_mixed_file_draws_in_its_predicted_colour_and_purge_shift_shows_the_blend() {
    let profile = MixProfile::from_toml_str(BANDS).unwrap();
    let colours = MixColours::from_profile(&profile).unwrap();
    let (mixed, _) = mix_bytes(profile, &torus()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mixed_path = write_temp(&dir, "torus.mix.gcode", &mixed);

    let blue = rgb(colours.predict(&[0.5, 0.5, 0.0, 0.0]).unwrap());
    let yellow = rgb(colours.predict(&[0.0, 0.0, 1.0, 0.0]).unwrap());
    let magenta = rgb(colours.predict(&[0.0, 1.0, 0.0, 0.0]).unwrap());
    assert!(blue[2] > blue[0] && yellow[0] > 200 && yellow[2] < 80 && magenta[0] > magenta[1]);

    for (layer, want) in [(5, blue), (15, yellow), (24, magenta)] {
        let (_, img) = draw_layer(&mixed_path, &colours, layer);
        let (c, n) = dominant(&img);
        assert_eq!(c, want, "layer {layer}");
        assert!(n > 2000, "layer {layer}: {n} px");
        let others = [blue, yellow, magenta].into_iter().filter(|&o| o != want);
        for o in others {
            assert!(histogram(&img).get(&o).copied().unwrap_or(0) < 20, "layer {layer} has {o:?}");
        }
    }

    // Purge-shift the changes 60 mm earlier, across layer changes.
    let rules = PurgeShiftConfig { purge_mm: Some(60.0), cross_layers: true, ..PurgeShiftConfig::default() }
        .validate()
        .unwrap();
    let (shifted, report) = purge_shift_bytes(rules, &mixed).unwrap();
    let moved = report.changes.kept().iter().filter(|c| c.achieved_mm > 10.0).count();
    assert!(moved >= 1, "{:?}", report.changes);
    let shifted_path = write_temp(&dir, "torus.shifted.gcode", &shifted);

    // Layer 18: all yellow before the shift; after it, the end of the layer prints the blend.
    let blends = |d: &Drawing| -> Vec<[u8; 3]> {
        let mut v: Vec<[u8; 3]> =
            d.strokes.iter().map(|s| s.colour).filter(|&c| c != yellow && c != magenta).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let (plain, _) = draw_layer(&mixed_path, &colours, 18);
    assert!(blends(&plain).is_empty(), "{:?}", blends(&plain));
    let (d, img) = draw_layer(&shifted_path, &colours, 18);
    let mid = blends(&d);
    assert!(mid.len() > 10, "a gradual washout, not a switch: {mid:?}");
    let hist = histogram(&img);
    let blend_px: usize = mid.iter().map(|c| hist.get(c).copied().unwrap_or(0)).sum();
    assert!(blend_px > 300, "{blend_px} px of blend");
    // The blend runs from yellow towards magenta: red rises, green falls, monotonically in
    // the washout, so every blend lies between the two.
    for c in &mid {
        assert!(c[0] >= magenta[0].min(yellow[0]) - 2 && c[1] <= yellow[1] + 2, "{c:?}");
    }
}

/// The viewer page's "mix" colouring showed tool colours and a T0/T1 legend unless the page was
/// made with `--colour-by mix` (it held `"mix_colours": []`), and its legend said `predicted
/// #ef4680` or `0:0.6:0.1:0.3` where the user had named the mix Pink. Now a page of a mixed file
/// carries the mix colours whatever it opens on, each named as `gweave mix` named it.
#[test]
fn the_viewer_page_colours_by_mix_with_the_users_names_whatever_it_opens_on() {
    let seed = include_str!("../../../examples/mix/seed_layers.toml");
    let (mixed, _) = mix_bytes(MixProfile::from_toml_str(seed).unwrap(), &torus()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = write_temp(&dir, "seed_layers.mix.gcode", &mixed);
    let page = |path: &Path| {
        let options = PreviewSettings::default();
        let p = gweave::preview_with_progress(
            path,
            None,
            gweave::render::Format::Html,
            &options,
            &mut gweave::Quiet,
        )
        .unwrap();
        String::from_utf8(p.bytes).unwrap()
    };
    let html = page(&path);
    let legend = html.split("\"mix_legend\":").nth(1).unwrap().split("]]").next().unwrap();
    let mut names: Vec<&str> = legend.split("\",\"").skip(1).map(|s| s.split('"').next().unwrap()).collect();
    names.sort();
    assert!(names.contains(&"Orange") && names.contains(&"Pink"), "{legend}");
    assert!(!names.iter().any(|n| n.contains(':') || n.starts_with("predicted")), "{legend}");
    assert!(!html.contains("\"mix_colours\":[]"));
    // A plain slicer file has no mix to show: the page says so instead of tool colours.
    let plain = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cura/cura_torus.gcode");
    assert!(page(&plain).contains("\"mix\":null,\"mix_colours\":[],\"mix_legend\":[]"));
}
