//! The raster generator's bytes, pinned: multi-layer jobs written by the build before the speed
//! work of issue 35 (the column text from templates, the bands gathered a word at a time, the
//! PNG rows unfiltered straight into the bitmap). Work that makes the raster cheaper must not
//! move a byte of its G-code nor a bit of its report.
//!
//! The layers are drawn here (rings with a speckle, as wide as two and a half 64-column words
//! and as tall as two and a half 12-nozzle bands), written through the default head, through two
//! heads firing in the binder-jet seed's order, and through a 16-nozzle head whose fires are
//! past the pre-formatted table; the same layers as 1-bit PNG files give the first job's bytes.
//! `GWEAVE_BLESS=1` rewrites the golden files (only for a deliberate change of the output).

use std::path::{Path, PathBuf};

use gweave::gen::bitmap::{Bitmap, ThresholdOptions};
use gweave::gen::printhead::{BitOrder, HeadOffset, PrintheadProfile};
use gweave::gen::raster::{
    raster_image_stacks, FireOrder, ImageStack, RasterConfig, RasterReport, RasterWriter,
};

const WIDTH_PX: usize = 160;
const HEIGHT_PX: usize = 30;
const LAYERS: usize = 3;

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/raster/golden")
}

/// Layer `k`: a ring whose radii grow with `k`, a solid bar (whole bytes and words inked on every
/// row of a band, a whole 64-column word among them) and a reproducible speckle (xorshift, about one pixel in twelve).
fn layer(k: usize) -> Bitmap {
    let mut b = Bitmap::new(WIDTH_PX, HEIGHT_PX);
    let (cx, cy) = (60.0, 14.0);
    let (r_in, r_out) = (4.0 + 2.0 * k as f64, 12.0 + 2.0 * k as f64);
    let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ k as u64;
    for y in 0..HEIGHT_PX {
        for x in 0..WIDTH_PX {
            let r = (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy);
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let bar = (60..150).contains(&x) && (2..26 - k).contains(&y);
            if (r_in..r_out).contains(&r) || bar || state.is_multiple_of(12) {
                b.set(x, y, true);
            }
        }
    }
    b
}

/// The G-code and report of `layers` (one plane per head) through `profile` and `cfg`.
fn job(profile: &PrintheadProfile, cfg: &RasterConfig, layers: &[Vec<Bitmap>]) -> (Vec<u8>, RasterReport) {
    let mut w = RasterWriter::new(Vec::new(), profile, cfg, None).unwrap();
    for planes in layers {
        w.layer(planes).unwrap();
    }
    w.finish().unwrap()
}

/// The report's figures, each exact (floats by their bits).
fn report_text(r: &RasterReport) -> String {
    format!(
        "layers {} bands_printed {} bands_skipped {} columns_fired {} columns_skipped {} \
         fire_commands {} drops_per_head {:?} xy_moves {} z_moves {} xy_path_mm {:#x} \
         estimated_time_s {:#x} binder_volume_ul {:?}\n",
        r.layers,
        r.bands_printed,
        r.bands_skipped,
        r.columns_fired,
        r.columns_skipped,
        r.fire_commands,
        r.drops_per_head,
        r.xy_moves,
        r.z_moves,
        r.xy_path_mm.to_bits(),
        r.estimated_time_s.to_bits(),
        r.binder_volume_ul.map(f64::to_bits),
    )
}

/// Compares with (or, blessing, writes) `name.gcode` and `name.report`.
fn check(name: &str, gcode: &[u8], report: &RasterReport) {
    let (gcode_path, report_path) =
        (golden_dir().join(format!("{name}.gcode")), golden_dir().join(format!("{name}.report")));
    if std::env::var_os("GWEAVE_BLESS").is_some() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        std::fs::write(&gcode_path, gcode).unwrap();
        std::fs::write(&report_path, report_text(report)).unwrap();
        return;
    }
    let want = std::fs::read(&gcode_path).unwrap();
    if gcode != want {
        let line = gcode.split(|&b| b == b'\n').zip(want.split(|&b| b == b'\n')).position(|(a, b)| a != b);
        panic!(
            "{name}: the G-code differs from {} ({} bytes, golden {}), first at line {}",
            gcode_path.display(),
            gcode.len(),
            want.len(),
            line.map_or("past the shorter's end".into(), |l| (l + 1).to_string())
        );
    }
    assert_eq!(report_text(report), std::fs::read_to_string(&report_path).unwrap(), "{name}: report");
}

fn one_head_layers() -> Vec<Vec<Bitmap>> {
    (0..LAYERS).map(|k| vec![layer(k)]).collect()
}

#[test]
fn the_default_head_writes_the_golden_bytes() {
    let (gcode, report) = job(&PrintheadProfile::default(), &RasterConfig::default(), &one_head_layers());
    assert_eq!(report.layers, LAYERS as u64);
    check("default", &gcode, &report);
}

#[test]
fn two_heads_in_the_seeds_order_write_the_golden_bytes() {
    let profile = PrintheadProfile {
        heads: vec![HeadOffset::default(), HeadOffset { offset_x_mm: 25.4, offset_y_mm: -1.5 }],
        dialect: gweave::Firmware::RepRapFirmware,
        drop_volume_pl: Some(32.0),
        ..PrintheadProfile::default()
    };
    let cfg = RasterConfig {
        fire_order: FireOrder::Before,
        serpentine: false,
        density: 2,
        decimals: 3,
        ..RasterConfig::default()
    };
    // Head 1 prints the layer mirrored: other columns and bands than head 0's.
    let layers: Vec<Vec<Bitmap>> = (0..LAYERS).map(|k| vec![layer(k), layer(k).mirror_x()]).collect();
    let (gcode, report) = job(&profile, &cfg, &layers);
    assert_eq!(report.drops_per_head.len(), 2);
    check("two_heads_before", &gcode, &report);
}

#[test]
fn a_head_past_the_fire_table_writes_the_golden_bytes() {
    // 16 nozzles: `S` up to 65535, formatted where it is written; rows mapped in reverse.
    let profile = PrintheadProfile {
        nozzle_count: 16,
        nozzle_rows: (0..16).rev().collect(),
        bit_order: BitOrder::MsbFirst,
        ..PrintheadProfile::default()
    };
    let (gcode, report) = job(&profile, &RasterConfig::default(), &one_head_layers());
    assert!(report.fire_commands > 0);
    check("sixteen_nozzles", &gcode, &report);
}

#[test]
fn the_layers_as_png_files_give_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let paths: Vec<PathBuf> = (0..LAYERS)
        .map(|k| {
            let path = dir.path().join(format!("layer_{k}.png"));
            layer(k).save_png(&path).unwrap();
            path
        })
        .collect();
    let stack = ImageStack { paths, threshold: ThresholdOptions::default(), flip_y: false };
    let mut from_files = Vec::new();
    let report = raster_image_stacks(
        &mut from_files,
        &PrintheadProfile::default(),
        &RasterConfig::default(),
        &[stack],
        None,
    )
    .unwrap();
    let (from_bitmaps, _) = job(&PrintheadProfile::default(), &RasterConfig::default(), &one_head_layers());
    assert!(from_files == from_bitmaps, "the PNG files' G-code differs from the bitmaps'");
    check("default", &from_files, &report);
}
