//! Acceptance test of issue 7: `slice-raster` of a PrusaSlicer sample mesh matches PrusaSlicer's
//! own SLA export of that mesh within one pixel at the edges.
//!
//! `tests/data/raster/torus.stl` is PrusaSlicer's `shapes/torus.stl` (a ring with a hole, so the
//! even-odd fill is exercised) and `torus.sl1` its export with the printer of `sphere.sl1`
//! (0.2 mm pixels, portrait, mirrored in X), centred at (60, 40) mm on the bed, 0.1 mm layers;
//! the exact command is in `tests/data/raster/README.md`. PrusaSlicer cuts layer `k` at
//! `(k + 1/2) 0.1` mm above the bed when the initial layer height equals the layer height, as
//! our slicer does.

use std::path::Path;

use gweave::gen::bitmap::{Bitmap, ThresholdOptions};
use gweave::gen::sl1::Sl1Reader;
use gweave::gen::slice_raster::{SliceConfig, Slicer};
use gweave::gen::stl::{read_stl, Mesh};

/// Is pixel (x, y) within one pixel of an edge of `img`: does its 3 x 3 neighbourhood hold
/// both ink and empty pixels? Outside the image counts as empty.
fn near_edge(img: &Bitmap, x: usize, y: usize) -> bool {
    let at = |dx: isize, dy: isize| {
        let (i, j) = (x as isize + dx, y as isize + dy);
        i >= 0
            && j >= 0
            && (i as usize) < img.width()
            && (j as usize) < img.height()
            && img.get(i as usize, j as usize)
    };
    let centre = at(0, 0);
    (-1..=1).any(|dy| (-1..=1).any(|dx| at(dx, dy) != centre))
}

/// The mesh moved as PrusaSlicer places it: XY bounding-box centre at `centre`, bottom on the
/// bed; plus one degenerate triangle at the bed corner (0, 0), which never crosses a cutting
/// plane but makes our grid start there, so our pixel (i, j) is the bed pixel (i, j) of the
/// SLA display.
fn placed_on_bed(mesh: &Mesh, centre: [f64; 2]) -> Mesh {
    let (lo, hi) = mesh.bounds().unwrap();
    let d = [centre[0] - (lo[0] + hi[0]) / 2.0, centre[1] - (lo[1] + hi[1]) / 2.0, -lo[2]];
    let mut triangles: Vec<_> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| [0, 1, 2].map(|a| (f64::from(v[a]) + d[a]) as f32)))
        .collect();
    triangles.push([[0.0, 0.0, 0.0]; 3]);
    Mesh { triangles }
}

#[test]
fn torus_slices_match_prusaslicer_sla_export() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/raster");
    let mesh = placed_on_bed(&read_stl(&data.join("torus.stl")).unwrap(), [60.0, 40.0]);
    let mut theirs = Sl1Reader::open(&data.join("torus.sl1")).unwrap();
    assert_eq!(theirs.bed_pixel_mm(), (0.2, 0.2));
    assert_eq!(theirs.layer_count(), 56);
    let cfg = SliceConfig { layer_height_mm: 0.1, pixel_mm: 0.2, margin_px: 0 };
    let mut ours = Slicer::new(&mesh, &cfg).unwrap();
    let g = *ours.grid();
    assert_eq!((g.origin_x_mm, g.origin_y_mm, g.z_min_mm), (0.0, 0.0, 0.0));
    // 5.66 mm tall: we cut 57 layers, PrusaSlicer stops at the last full layer (5.6 mm).
    assert_eq!(g.layers, 57);

    let opts = ThresholdOptions::default();
    let (mut ink_ours, mut ink_theirs, mut differing, mut off_edge) = (0u64, 0u64, 0u64, 0u64);
    for k in 0..theirs.layer_count() {
        let a = ours.layer(k);
        let b = theirs.bed_layer(k, &opts).unwrap();
        assert_eq!((b.width(), b.height()), (600, 400));
        // The torus (28.54 mm wide, centred at 60, 40) lies inside our grid: nothing of theirs
        // may fall outside it.
        assert!(b.ones().all(|(x, y)| x < a.width() && y < a.height()), "layer {k}");
        ink_ours += a.count_ones();
        ink_theirs += b.count_ones();
        for y in 0..a.height() {
            for x in 0..a.width() {
                if a.get(x, y) != b.get(x, y) {
                    differing += 1;
                    if !(near_edge(&a, x, y) && near_edge(&b, x, y)) {
                        off_edge += 1;
                        eprintln!("layer {k}: pixel ({x}, {y}) differs away from an edge");
                    }
                }
            }
        }
    }
    eprintln!("ink ours {ink_ours}, theirs {ink_theirs}, differing {differing}");
    assert_eq!(off_edge, 0, "{off_edge} differing pixels away from any edge");
    // 56 rings of about 8000 pixels; measured: ours 447696, theirs 447867, 209 differing
    // (0.05 %), all on the outlines where PrusaSlicer's anti-aliased coverage and our
    // pixel-centre test disagree by a hair.
    assert_eq!(ink_theirs, 447_867);
    assert!(differing <= 250, "{differing} of {ink_theirs}");
    assert!(ink_ours.abs_diff(ink_theirs) * 1000 < ink_theirs, "{ink_ours} vs {ink_theirs}");
}
