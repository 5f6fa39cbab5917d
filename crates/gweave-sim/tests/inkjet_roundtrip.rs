//! Round trips: images -> raster G-code -> inkjet canvas == thresholded (resampled) images.
//!
//! The G-code runs through the virtual printer ([`Machine`]) with the printhead in its profile,
//! so what is compared is what the real interpreter records.

use std::collections::BTreeSet;
use std::path::Path;
use std::sync::mpsc;

use gweave::gen::bitmap::{Bitmap, Channel, ThresholdOptions};
use gweave::gen::printhead::{HeadOffset, PrintheadProfile};
use gweave::gen::raster::{raster_image_stacks, raster_sl1, ImageStack, RasterConfig};
use gweave::gen::sl1::Sl1Reader;
use gweave_sim::{CanvasGeometry, InkjetLayer, InkjetWarning};
use gweave_sim::{Inkjet, MachineProfile};
use gweave_sim::{Machine, Outcome, SimReport};

fn word(line: &str, letter: char) -> Option<&str> {
    line.split_whitespace().find_map(|w| w.strip_prefix(letter))
}

/// What a machine carrying the printhead made of the G-code: its report and the canvases of
/// every layer it fired.
struct Driven {
    report: SimReport,
    layers: Vec<InkjetLayer>,
}

impl Driven {
    fn warnings(&self) -> Vec<&InkjetWarning> {
        self.report.inkjet_warnings().collect()
    }
}

/// Runs G-code through a machine carrying this printhead, with the canvas at `geometry`.
/// Every line must be accepted without a reply, and warn of nothing but inkjet fires.
fn drive(gcode: &str, printhead: &PrintheadProfile, geometry: CanvasGeometry) -> Driven {
    let inkjet = Inkjet {
        printhead: printhead.clone(),
        origin_x_mm: geometry.origin_x_mm,
        origin_y_mm: geometry.origin_y_mm,
        width_px: Some(geometry.width_px),
        height_px: Some(geometry.height_px),
    };
    let mut machine =
        Machine::new(MachineProfile { inkjet: Some(inkjet), ..MachineProfile::default() }).unwrap();
    let (sink, finished) = mpsc::channel();
    machine.send_inkjet_layers_to(Box::new(sink));
    let mut replies = Vec::new();
    for raw in gcode.lines() {
        let mut out = |_t: f64, l: &str| replies.push(format!("{raw}: {l}"));
        assert_eq!(machine.execute(raw.as_bytes(), &mut out), Outcome::Ok, "{raw}");
    }
    machine.finish(&mut |_, _| {});
    assert!(replies.is_empty(), "{:?}", &replies[..1]);
    let report = machine.report();
    assert!(report.warnings.iter().all(|w| w.kind.name() == "inkjet"), "{:?}", report.warnings);
    Driven { report, layers: finished.try_iter().collect() }
}

/// Y values of every G1 that moves in Y.
fn y_moves(gcode: &str) -> BTreeSet<String> {
    gcode.lines().filter(|l| l.starts_with("G1 ")).filter_map(|l| word(l, 'Y').map(str::to_string)).collect()
}

/// Compares each head's canvas of each layer with the expected images; empty expected layers
/// must have no canvas at all.
fn assert_layers_equal(run: &Driven, expected: &[Vec<Bitmap>], z_of: impl Fn(usize) -> f64) {
    assert!(run.warnings().is_empty(), "{:?}", &run.warnings()[..1]);
    let mut layers = run.layers.iter().peekable();
    for (k, planes) in expected.iter().enumerate() {
        let z = z_of(k);
        if planes.iter().all(|p| p.count_ones() == 0) {
            assert!(!matches!(layers.peek(), Some(l) if (l.z_mm - z).abs() < 1e-6));
            continue;
        }
        let layer = layers.next().expect("missing layer");
        assert!((layer.z_mm - z).abs() < 1e-6, "layer {k}: z {} vs {z}", layer.z_mm);
        for (h, want) in planes.iter().enumerate() {
            assert_eq!(&layer.heads[h], want, "layer {k} head {h}");
        }
    }
    assert!(layers.next().is_none());
}

fn sphere() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../gweave/tests/data/raster/sphere.sl1")
}

fn sl1_roundtrip(serpentine: bool) {
    let profile = PrintheadProfile::default();
    let cfg = RasterConfig { serpentine, ..RasterConfig::default() };
    let opts = ThresholdOptions::default();
    let mut gcode = Vec::new();
    let report = raster_sl1(&mut gcode, &profile, &cfg, &sphere(), &opts).unwrap();
    let gcode = String::from_utf8(gcode).unwrap();

    let mut reader = Sl1Reader::open(&sphere()).unwrap();
    let (px_x, px_y) = reader.bed_pixel_mm();
    let pitch = profile.pitch_mm();
    let expected: Vec<Vec<Bitmap>> = (0..reader.layer_count())
        .map(|k| {
            let b = reader.bed_layer(k, &opts).unwrap();
            vec![b.resample(px_x, px_y, pitch).unwrap()]
        })
        .collect();
    let (w, h) = (expected[0][0].width(), expected[0][0].height());
    // The 120 mm x 80 mm display at 25.4/96 mm: round(453.54) x round(302.36) px.
    assert_eq!((w, h), (454, 302));
    let geometry = CanvasGeometry { origin_x_mm: 20.0, origin_y_mm: 20.0, width_px: w, height_px: h };
    let run = drive(&gcode, &profile, geometry);
    assert_layers_equal(&run, &expected, |k| 0.1 * (k + 1) as f64);
    let drops: u64 = expected.iter().map(|p| p[0].count_ones()).sum();
    assert_eq!(report.drops_per_head, vec![drops]);
    assert_eq!(run.report.inkjet.as_ref().unwrap().drops_per_head, [drops]);
    assert_eq!(report.layers, 308);
    assert!(drops > 1_000_000, "{drops}");
}

#[test]
fn sphere_sl1_serpentine() {
    sl1_roundtrip(true);
}

#[test]
#[ignore = "slow in debug builds (1M drops through the interpreter); the serpentine case covers the sphere"]
fn sphere_sl1_one_way() {
    sl1_roundtrip(false);
}

/// Deterministic pseudo-random bytes (64-bit LCG, Knuth's MMIX constants).
fn lcg(seed: &mut u64) -> u8 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 56) as u8
}

/// Writes a 24-bit bottom-up BMP; `pixel(x, y)` gives RGB with y = 0 the top row.
fn write_bmp(path: &Path, w: usize, h: usize, pixel: impl Fn(usize, usize) -> [u8; 3]) {
    let stride = (w * 3).div_ceil(4) * 4;
    let mut d = Vec::new();
    d.extend_from_slice(b"BM");
    d.extend_from_slice(&((54 + stride * h) as u32).to_le_bytes());
    d.extend_from_slice(&[0; 4]);
    d.extend_from_slice(&54u32.to_le_bytes());
    d.extend_from_slice(&40u32.to_le_bytes());
    d.extend_from_slice(&(w as i32).to_le_bytes());
    d.extend_from_slice(&(h as i32).to_le_bytes());
    d.extend_from_slice(&1u16.to_le_bytes());
    d.extend_from_slice(&24u16.to_le_bytes());
    d.extend_from_slice(&[0; 24]);
    for y in (0..h).rev() {
        let mut row: Vec<u8> = (0..w)
            .flat_map(|x| {
                let [r, g, b] = pixel(x, y);
                [b, g, r]
            })
            .collect();
        row.resize(stride, 0);
        d.extend_from_slice(&row);
    }
    std::fs::write(path, d).unwrap();
}

/// A stack of RGB BMPs: random blobs in rows outside 12..24 (an empty band), layer 2 empty.
/// Returns the file paths and, per layer, the exact red and blue channel masks.
fn bmp_stack(dir: &Path, w: usize, h: usize, layers: usize) -> (Vec<std::path::PathBuf>, Vec<[Bitmap; 2]>) {
    let mut seed = 7u64;
    let mut paths = Vec::new();
    let mut masks = Vec::new();
    for k in 0..layers {
        let mut rgb = vec![[0u8; 3]; w * h];
        if k != 2 {
            for (i, px) in rgb.iter_mut().enumerate() {
                let y = i / w;
                if !(12..24).contains(&y) {
                    *px = [lcg(&mut seed), lcg(&mut seed) / 2, lcg(&mut seed)];
                }
            }
        }
        let path = dir.join(format!("layer{k}.bmp"));
        write_bmp(&path, w, h, |x, y| rgb[y * w + x]);
        let mut red = Bitmap::new(w, h);
        let mut blue = Bitmap::new(w, h);
        for (i, px) in rgb.iter().enumerate() {
            red.set(i % w, i / w, px[0] >= 128);
            blue.set(i % w, i / w, px[2] >= 128);
        }
        paths.push(path);
        masks.push([red, blue]);
    }
    (paths, masks)
}

fn bmp_roundtrip(serpentine: bool, heads: usize) {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (70, 41); // 41 rows: bands of 12, the top one 5 rows tall
    let (paths, masks) = bmp_stack(dir.path(), w, h, 4);
    let mut profile = PrintheadProfile {
        nozzle_rows: vec![3, 1, 0, 2, 11, 10, 4, 5, 9, 8, 6, 7],
        ..PrintheadProfile::default()
    };
    if heads == 2 {
        profile.heads.push(HeadOffset { offset_x_mm: 30.5, offset_y_mm: -4.25 });
    }
    let cfg =
        RasterConfig { serpentine, layer_height_mm: Some(0.2), origin_x_mm: 40.0, ..RasterConfig::default() };
    let channels = [Channel::Red, Channel::Blue];
    let stacks: Vec<ImageStack> = channels[..heads]
        .iter()
        .map(|&channel| ImageStack {
            paths: paths.clone(),
            threshold: ThresholdOptions { channel, ..ThresholdOptions::default() },
            flip_y: false,
        })
        .collect();
    let mut gcode = Vec::new();
    let report = raster_image_stacks(&mut gcode, &profile, &cfg, &stacks, None).unwrap();
    let gcode = String::from_utf8(gcode).unwrap();
    let geometry = CanvasGeometry { origin_x_mm: 40.0, origin_y_mm: 20.0, width_px: w, height_px: h };
    let run = drive(&gcode, &profile, geometry);
    let expected: Vec<Vec<Bitmap>> = masks.iter().map(|m| m[..heads].to_vec()).collect();
    assert_layers_equal(&run, &expected, |k| 0.2 * (k + 1) as f64);
    assert_eq!(report.layers, 4);
    // Band 1 (rows 12..24) is empty in every layer: no move ever goes to its Y.
    let pitch = profile.pitch_mm();
    let band_y = |b: usize, head: usize| {
        let y = 20.0 + (12.0 * b as f64 + 0.5) * pitch - profile.heads[head].offset_y_mm;
        format!("{}", (y * 1e4).round() / 1e4)
    };
    let ys = y_moves(&gcode);
    let want: BTreeSet<String> = (0..heads).flat_map(|hd| [0, 2, 3].map(|b| band_y(b, hd))).collect();
    assert_eq!(ys, want);
    // 3 printed layers x 3 bands x heads; 3 x 1 + 1 x 4 bands skipped per head.
    assert_eq!(report.bands_printed, 9 * heads as u64);
    assert_eq!(report.bands_skipped, 7 * heads as u64);
    // Every fire is preceded by an M400 with no move in between, and has a P word.
    let lines: Vec<&str> = gcode.lines().collect();
    for (i, l) in lines.iter().enumerate() {
        if l.starts_with("M700") {
            assert!(word(l, 'P').is_some(), "{l}");
            let before = lines[..i].iter().rev().find(|p| !p.starts_with("M700")).unwrap();
            assert_eq!(*before, "M400", "line {i}");
        }
    }
}

#[test]
fn bmp_stack_one_head_serpentine() {
    bmp_roundtrip(true, 1);
}

#[test]
fn bmp_stack_one_head_one_way() {
    bmp_roundtrip(false, 1);
}

#[test]
fn bmp_stack_two_heads_serpentine() {
    bmp_roundtrip(true, 2);
}

#[test]
fn bmp_stack_two_heads_one_way() {
    bmp_roundtrip(false, 2);
}

#[test]
fn driver_reports_fire_without_m400() {
    let profile = PrintheadProfile::default();
    let geometry = CanvasGeometry { origin_x_mm: 0.0, origin_y_mm: 0.0, width_px: 10, height_px: 12 };
    let run = drive("G1 X1 Y0.2\nM400\nM700 P0 S1\nG1 X2\nM700 P0 S1\nM700 S3\n", &profile, geometry);
    assert!(matches!(
        run.warnings()[..],
        [InkjetWarning::FireWithoutM400 { head: 0, .. }, InkjetWarning::MissingHead { .. }]
    ));
}

mod prop {
    use super::*;
    use gweave::gen::printhead::BitOrder;
    use gweave::gen::raster::RasterWriter;
    use proptest::prelude::*;

    /// A profile with a shuffled nozzle map, and random images for its heads.
    fn case() -> impl Strategy<Value = (PrintheadProfile, Vec<Bitmap>, bool, u32)> {
        (1u32..20, 1usize..3, any::<bool>(), any::<bool>(), 1u32..3)
            .prop_flat_map(|(n, heads, msb, serpentine, density)| {
                let map = Just((0..n).collect::<Vec<u32>>()).prop_shuffle();
                let images =
                    proptest::collection::vec((1usize..140, 1usize..45, any::<u64>(), 1u8..100), heads);
                (Just(n), map, Just(msb), Just(serpentine), Just(density), images)
            })
            .prop_map(|(n, map, msb, serpentine, density, images)| {
                let profile = PrintheadProfile {
                    nozzle_count: n,
                    nozzle_rows: map,
                    bit_order: if msb { BitOrder::MsbFirst } else { BitOrder::LsbFirst },
                    heads: (0..images.len())
                        .map(|h| HeadOffset { offset_x_mm: 7.25 * h as f64, offset_y_mm: -3.5 * h as f64 })
                        .collect(),
                    ..PrintheadProfile::default()
                };
                let planes = images
                    .into_iter()
                    .map(|(w, h, mut seed, percent)| {
                        let mut b = Bitmap::new(w, h);
                        for y in 0..h {
                            for x in 0..w {
                                b.set(x, y, u32::from(lcg(&mut seed)) * 100 < u32::from(percent) * 256);
                            }
                        }
                        b
                    })
                    .collect();
                (profile, planes, serpentine, density)
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn canvas_equals_input((profile, planes, serpentine, density) in case()) {
            let cfg = RasterConfig { serpentine, density, ..RasterConfig::default() };
            let mut w = RasterWriter::new(Vec::new(), &profile, &cfg, None).unwrap();
            w.layer(&planes).unwrap();
            let (out, report) = w.finish().unwrap();
            let gcode = String::from_utf8(out).unwrap();
            let width = planes.iter().map(Bitmap::width).max().unwrap();
            let height = planes.iter().map(Bitmap::height).max().unwrap();
            let geometry = CanvasGeometry {
                origin_x_mm: 20.0,
                origin_y_mm: 20.0,
                width_px: width,
                height_px: height,
            };
            let run = drive(&gcode, &profile, geometry);
            prop_assert!(run.warnings().is_empty());
            let total: u64 = planes.iter().map(Bitmap::count_ones).sum();
            prop_assert_eq!(run.layers.len(), usize::from(total > 0));
            for (h, plane) in planes.iter().enumerate() {
                let want = plane.count_ones();
                prop_assert_eq!(report.drops_per_head[h], want * u64::from(density));
                if let Some(layer) = run.layers.first() {
                    let got = &layer.heads[h];
                    prop_assert_eq!(got.count_ones(), want);
                    for y in 0..plane.height() {
                        for x in 0..plane.width() {
                            prop_assert_eq!(got.get(x, y), plane.get(x, y), "head {} ({}, {})", h, x, y);
                        }
                    }
                }
            }
        }
    }
}
