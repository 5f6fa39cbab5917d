//! Hangs and sizes: every numeric flag has a range, checked before anything is read, and every
//! computed size (image pixels, layers, chords, gradient steps) is checked before allocating.

use std::fs;
use std::time::Duration;

use crate::harness::*;

/// Regression: each of these hung, filled the disk, panicked or aborted on a terabyte
/// allocation (issue 25).
#[test]
fn hostile_flag_values_are_refused_with_the_flag_and_its_range() {
    let (dir, _) = dir_with_fixture("rotary/plate.gcode", "plate.gcode");
    let d = dir.path();
    fs::write(d.join("cube.stl"), ascii(&cube_facets(10.0, 10.0))).unwrap();
    let cases: &[(&[&str], &str, &str)] = &[
        (
            &["rotary", "tube", "-o", "t.gcode", "--mandrel-diameter", "20", "--layer-count", "1000000000"],
            "--layer-count",
            "1 to 1000",
        ),
        (
            &["rotary", "wrap", "plate.gcode", "-o", "w.gcode", "--mandrel-diameter", "1e-9"],
            "--mandrel-diameter",
            "1 to 1000 mm",
        ),
        (
            &[
                "rotary",
                "wrap",
                "plate.gcode",
                "-o",
                "w.gcode",
                "--mandrel-diameter",
                "20",
                "--chord-tol",
                "1e-12",
            ],
            "--chord-tol",
            "0 or 0.001 to 10 mm",
        ),
        (
            &["rotary", "tube", "-o", "t.gcode", "--mandrel-diameter", "20", "--chord-tol", "1e-12"],
            "--chord-tol",
            "0.001 to 10 mm",
        ),
        (
            &["purge-shift", "plate.gcode", "-o", "p.gcode", "--purge-mm", "1e308", "--fallback", "tower"],
            "--purge-mm",
            "0 to 1000 mm",
        ),
        (
            &["raster", "--test-pattern", "-o", "r.gcode", "--density", "4294967295"],
            "--density",
            "1 to 16 fires per pixel",
        ),
        (
            &["raster", "--test-pattern", "-o", "r.gcode", "--pattern-columns", "1e8"],
            "--pattern-columns",
            "1 to 100 columns",
        ),
        (&["raster", "cube.stl", "-o", "r.gcode", "--dpi", "1e-300"], "--dpi", "10 to 10000 dpi"),
        (&["raster", "cube.stl", "-o", "r.gcode", "--pixel-mm", "1e6"], "--pixel-mm", "0.00254 to 2.54 mm"),
        (
            &["slice-raster", "cube.stl", "--layer-height", "0.1", "--dpi", "1e6", "-o", "out"],
            "--dpi",
            "10 to 10000 dpi",
        ),
        (
            &["slice-raster", "cube.stl", "--layer-height", "0.1", "--pixel-mm", "1e-9", "-o", "out"],
            "--pixel-mm",
            "0.00254 to 2.54 mm",
        ),
        (
            &["slice-raster", "cube.stl", "--layer-height", "0.1", "--margin", "100000", "-o", "out"],
            "--margin",
            "0 to 1000 px",
        ),
        (
            &["slice-raster", "cube.stl", "--layer-height", "0.1", "--margin", "4294967295", "-o", "out"],
            "--margin",
            "0 to 1000 px",
        ),
        (
            &["preview", "plate.gcode", "-o", "x.png", "--mandrel-diameter", "1e308", "--view", "iso"],
            "--mandrel-diameter",
            "1 to 1000 mm",
        ),
        (&["mix", "plate.gcode", "-o", "m.gcode", "--purge-mm=-1"], "--purge-mm", "0 to 1000 mm"),
        (&["stats", "plate.gcode", "--filament-diameter", "nan"], "--filament-diameter", "0.5 to 5 mm"),
        (&["check", "plate.gcode", "--bed", "220,220,1e308"], "--bed", "1 to 10000 mm"),
        (&["check", "plate.gcode", "--max-feed", "0"], "--max-feed", "1 to 100000 mm/min"),
        (
            &["serve", "--tcp", "127.0.0.1:0", "--exit-after-idle", "inf"],
            "--exit-after-idle",
            "0.1 to 1000000 s",
        ),
    ];
    for (args, flag, range) in cases {
        assert_flag_refused(d, args, flag, range);
    }
}

/// Regression: `slice-raster` of a cube with a speck at Z = 1e6 wrote PNGs until the disk was
/// full; 1e30 or infinite coordinates panicked with "capacity overflow"; a 1 km cube aborted.
#[test]
fn slice_raster_refuses_sizes_past_its_ceilings_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut speck = cube_facets(10.0, 10.0);
    speck.push_str(&facets(&[[[0.0, 0.0, 1e6], [0.1, 0.0, 1e6], [0.0, 0.1, 1e6]]]));
    fs::write(d.join("speck.stl"), ascii(&speck)).unwrap();
    fs::write(d.join("km.stl"), ascii(&cube_facets(1e6, 10.0))).unwrap();
    fs::write(d.join("huge.stl"), ascii(&cube_facets(1e30, 10.0))).unwrap();
    fs::write(d.join("inf.stl"), ascii(&cube_facets(f64::INFINITY, 10.0))).unwrap();
    for (model, needle) in [
        (
            "speck.stl",
            "a part 1000000 mm tall at 0.1 mm per layer needs 10000000 layers, more than the limit of 100000",
        ),
        ("km.stl", "pixels per image side, more than the limit of 20000"),
        ("huge.stl", "pixels per image side, more than the limit of 20000"),
        ("inf.stl", "the mesh has a vertex coordinate of inf"),
    ] {
        let out = gweave(d, &["slice-raster", model, "--layer-height", "0.1", "-o", "out"])
            .limit(Duration::from_secs(20))
            .run();
        out.assert_refused(needle).assert_peak_under(64.0);
        assert!(!d.join("out").exists(), "{model}: the output folder was made");
    }
}

/// Regression (B8): a NaN vertex was sliced (exit 0, 100 layers) where an infinite one was
/// refused; a mesh with no Y extent failed in the PNG encoder ("Zero height not allowed"); one
/// with no Z extent wrote 0 layers of 0 x 0 px, exited 0 and still suggested `gweave raster`.
/// Each is refused naming the model and why, with no folder made.
#[test]
fn b8_slice_raster_refuses_nan_vertices_and_flat_meshes_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tilted = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 10.0]];
    let cases = [
        (
            "nan.stl",
            vec![[[f64::NAN, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 10.0]], tilted],
            "the mesh has a vertex coordinate of nan (triangle 1)",
        ),
        (
            "flat_y.stl",
            vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 10.0]]],
            "the mesh is flat in Y (all of its vertices at Y = 0 mm): it has no volume to slice",
        ),
        (
            "flat_z.stl",
            vec![[[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]]],
            "the mesh is flat in Z (all of its vertices at Z = 0 mm): it has no volume to slice",
        ),
    ];
    for (model, triangles, needle) in cases {
        fs::write(d.join(model), ascii(&facets(&triangles))).unwrap();
        let out = gweave(d, &["slice-raster", model, "--layer-height", "0.1", "-o", "out"])
            .limit(Duration::from_secs(20))
            .run();
        out.assert_refused(&format!("gweave: error: slicing {model}\n")).assert_refused(needle);
        assert!(out.stdout.is_empty(), "{model}: {}", out.stdout_text());
        assert!(!d.join("out").exists(), "{model}: the output folder was made");
    }
}

/// Regression: `raster` took layer images of different sizes silently (the .sl1 path refuses).
#[test]
fn raster_refuses_layer_images_of_different_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::create_dir(d.join("layers")).unwrap();
    fs::write(d.join("layers/a_0.bmp"), bmp(16, 8)).unwrap();
    fs::write(d.join("layers/a_1.bmp"), bmp(24, 8)).unwrap();
    let out = gweave(d, &["raster", "layers", "-o", "r.gcode", "-q"]).limit(Duration::from_secs(20)).run();
    out.assert_refused("a_1.bmp: the layer image is 24 x 8 px, but");
    assert!(out.stderr.contains("a_0.bmp is 16 x 8 px"), "{}", out.stderr);
    assert!(!d.join("r.gcode").exists());
    assert_no_temp_left(d);
}

/// Regression: `mix --gradient z0-1e308=...` allocated 34 GB for its steps.
#[test]
fn a_gradient_of_endless_steps_is_refused() {
    let (dir, _) = dir_with_fixture("cura/cura_torus.gcode", "in.gcode");
    for (gradient, needle) in [
        ("z0-1e308=Cyan..Magenta", "[gradient[0]] to_z_mm = 1e308 is out of range: 0 to 10000 mm"),
        ("0-1000000=Cyan..Magenta", "needs 1000000 gradient steps, more than the limit of 100000"),
    ] {
        let out = gweave(dir.path(), &["mix", "in.gcode", "-o", "m.gcode", "--gradient", gradient])
            .limit(Duration::from_secs(20))
            .run();
        out.assert_refused(needle).assert_peak_under(64.0);
        assert!(!dir.path().join("m.gcode").exists());
        assert_no_temp_left(dir.path());
    }
}

/// Regression (B4): each gradient was held to 100 000 steps but not their total, and every
/// declared step was resolved before the first line: 20 gradients over layers 0 to 99 999 (a
/// 1.1 KB profile) took 72 s on the 28-layer torus, and 3 500 (203 KB, under the 256 KiB of a
/// settings file) would have run for hours. Steps are resolved as the file's layers need them:
/// the last gradient is the one in force, and its steps at t = layer / 99 999 round (4
/// decimals) to Cyan up to layer 4, then 0.9999:0.0001 from layer 5, 0.9998:0.0002 from 15 and
/// 0.9997:0.0003 from 25.
#[test]
fn b4_gradient_steps_cost_the_files_layers_not_the_declared_span() {
    let (dir, _) = dir_with_fixture("cura/cura_torus.gcode", "in.gcode");
    let gradient = "{from_layer=0,to_layer=99999,start=\"Cyan\",end=\"Magenta\"}";
    for n in [20, 3500] {
        let toml = format!("gradient = [{}]\n", vec![gradient; n].join(","));
        fs::write(dir.path().join("g.toml"), &toml).unwrap();
        let out = gweave(dir.path(), &["mix", "-c", "g.toml", "in.gcode", "-o", "m.gcode", "--json"])
            .limit(Duration::from_secs(60))
            .cpu_limit(Duration::from_secs(20))
            .run();
        out.assert_ok();
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let mixes: Vec<(&str, Vec<f64>)> = report["mixes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| {
                let ratios = m["ratios"].as_array().unwrap().iter().map(|r| r.as_f64().unwrap()).collect();
                (m["name"].as_str().unwrap(), ratios)
            })
            .collect();
        let steps: Vec<(&str, Vec<f64>)> = vec![
            ("Cyan", vec![1.0, 0.0, 0.0, 0.0]),
            ("Magenta", vec![0.0, 1.0, 0.0, 0.0]),
            ("Cyan..Magenta 5/99999", vec![0.9999, 0.0001, 0.0, 0.0]),
            ("Cyan..Magenta 15/99999", vec![0.9998, 0.0002, 0.0, 0.0]),
            ("Cyan..Magenta 25/99999", vec![0.9997, 0.0003, 0.0, 0.0]),
        ];
        assert_eq!(mixes, steps, "{n} gradients");
        assert_eq!(report["changes"].as_u64(), Some(3), "{n} gradients");
        let gcode = fs::read_to_string(dir.path().join("m.gcode")).unwrap();
        assert!(
            gcode.contains(
                "\n; gweave mix: 2 mixes and gradient steps as their layers come, 4 inputs, Marlin dialect\n"
            ),
            "{n} gradients"
        );
    }
}

/// Regression: alternating travel and extrusion never chain, and `ToolpathPass::coarsen`
/// doubled its merge length for ever once the file passed the segment ceiling. The hang was a
/// busy loop, so it is caught by CPU time: a run takes about 4 s of CPU in a debug build, and
/// 12 s of wall clock on a loaded machine (a 20 s wall limit nearly tripped); the loop would
/// pass any limit.
#[test]
fn coarsen_hang_on_alternating_travel_and_extrusion() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 2.2 million segments (15 MB): past the preview's ceiling of 2^21 kept segments.
    let mut text = String::from(";LAYER:0\nM83\nG1 Z0.2 F1200\n");
    for i in 0..1_100_000u32 {
        let (x, y) = (i * 7 % 10, i * 13 % 10);
        text.push_str(&format!("G0X{x}Y{y}\nG1X{}E1\n", (x + 3) % 10));
    }
    fs::write(d.join("alt.gcode"), text).unwrap();
    // A small picture keeps the drawing short in a debug build (its ink budget scales with it).
    let out =
        gweave(d, &["preview", "alt.gcode", "-o", "x.png", "--travel", "--size", "300x200", "--json", "-q"])
            .cpu_limit(Duration::from_secs(120))
            .limit(Duration::from_secs(1200))
            .run();
    out.assert_ok().assert_peak_under(256.0);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let strokes = report["strokes"].as_u64().unwrap();
    assert!((1_000_000..=1 << 21).contains(&strokes), "{strokes} strokes kept");
}

/// An ASCII STL of these triangles.
fn ascii(facets: &str) -> String {
    format!("solid t\n{facets}endsolid t\n")
}

fn facets(triangles: &[[[f64; 3]; 3]]) -> String {
    let mut s = String::new();
    for t in triangles {
        s.push_str("facet normal 0 0 0\nouter loop\n");
        for v in t {
            s.push_str(&format!("vertex {:e} {:e} {:e}\n", v[0], v[1], v[2]));
        }
        s.push_str("endloop\nendfacet\n");
    }
    s
}

/// A box `side` wide and deep, `height` tall, as an ASCII STL's facets (wrap with [`ascii`]).
fn cube_facets(side: f64, height: f64) -> String {
    let c = |i: usize| {
        [
            if i & 1 == 0 { 0.0 } else { side },
            if i & 2 == 0 { 0.0 } else { side },
            if i & 4 == 0 { 0.0 } else { height },
        ]
    };
    let quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
    let tris: Vec<_> =
        quads.iter().flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]]).collect();
    facets(&tris)
}

/// A white 24-bit BMP of `w` x `h` px.
fn bmp(w: u32, h: u32) -> Vec<u8> {
    let row = (w * 3).div_ceil(4) * 4;
    let size = 54 + row * h;
    let mut b = Vec::new();
    b.extend(b"BM");
    b.extend(size.to_le_bytes());
    b.extend([0u8; 4]);
    b.extend(54u32.to_le_bytes());
    b.extend(40u32.to_le_bytes());
    b.extend(w.to_le_bytes());
    b.extend(h.to_le_bytes());
    b.extend(1u16.to_le_bytes());
    b.extend(24u16.to_le_bytes());
    b.extend([0u8; 24]);
    b.extend(std::iter::repeat_n(0xffu8, (row * h) as usize));
    b
}
