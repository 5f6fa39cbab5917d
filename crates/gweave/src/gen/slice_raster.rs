//! Slices a mesh into 1-bit layer images for binder jetting.
//!
//! Layer `k` is cut at mid-layer height `z = z_min + (k + 1/2) h`. Each triangle that straddles
//! the plane gives one segment (its two edges with one end above and one end at or below `z`;
//! the same classification for every triangle keeps the outlines closed). A pixel is ink when
//! its centre is inside the section by the even-odd rule: for pixel row `j`, with centre
//! `y_c = origin_y + (j + 1/2) p`, collect the x of every segment crossing `y_c` (half-open
//! in y, `min(y0, y1) <= y_c < max(y0, y1)`, so a shared vertex counts once), sort them, and
//! fill pixel centres in `[x_0, x_1), [x_2, x_3), ...`. Image row 0 is the lowest Y, the same
//! convention as the raster generator, so slicing then rastering keeps the part's orientation.
//!
//! The grid covers the mesh's XY bounds plus a margin: `origin = min - margin p`,
//! `width = ceil((max - min) / p) + 2 margin`. A mesh flat along X, Y or Z (no column, row or
//! layer in its bounds) has no volume and is refused before anything is written, as is a vertex
//! coordinate that is NaN or infinite.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::bitmap::{Bitmap, BitmapError};
use super::stl::Mesh;
use crate::range::{
    short, Ceiling, OutOfRange, Range, TooLarge, DPI, LAYER_HEIGHT_MM, MAX_IMAGE_SIDE_PX, MAX_LAYERS,
    PIXEL_MM,
};

/// Errors from slicing.
#[derive(Debug, Error)]
pub enum SliceError {
    /// A mesh without a triangle.
    #[error("the mesh is empty")]
    EmptyMesh,
    /// A vertex coordinate that is NaN or infinite.
    #[error("the mesh has a vertex coordinate of {} (triangle {triangle})", short(*value))]
    NonFinite {
        /// The triangle, from 1 in file order.
        triangle: usize,
        /// The coordinate.
        value: f64,
    },
    /// A mesh with no extent along an axis: no pixel across it, or no layer.
    #[error("the mesh is flat in {axis} (all of its vertices at {axis} = {} mm): it has no volume to slice", short(*at_mm))]
    Flat {
        /// `X`, `Y` or `Z`.
        axis: &'static str,
        /// Where its vertices are along that axis.
        at_mm: f64,
    },
    /// A setting outside its range.
    #[error(transparent)]
    Range(#[from] OutOfRange),
    /// The images would be too large.
    #[error(transparent)]
    TooLarge(#[from] TooLarge),
    /// A layer image cannot be written.
    #[error(transparent)]
    Image(#[from] BitmapError),
    /// A file cannot be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
}

/// Slicing settings (TOML, unknown keys rejected).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SliceConfig {
    /// Layer thickness.
    pub layer_height_mm: f64,
    /// Pixel size; the default is the HP C6602 nozzle pitch 25.4 / 96 mm.
    pub pixel_mm: f64,
    /// Empty pixels added on every side.
    pub margin_px: usize,
}

/// Empty pixels around the part.
pub const MARGIN_PX: Range<usize> = Range::new(0, 1_000, "px");

impl SliceConfig {
    /// The settings as `gweave slice-raster`'s flags and Python's keywords give them: the pixel
    /// size if given, else one pixel per dot at `dpi` (25.4 / dpi mm, an inch being 25.4 mm;
    /// `dpi` checked against [`DPI`]). The other ranges are checked when slicing starts.
    pub fn with_resolution(
        layer_height_mm: f64,
        pixel_mm: Option<f64>,
        dpi: f64,
        margin_px: usize,
    ) -> Result<Self, SliceError> {
        let pixel_mm = match pixel_mm {
            Some(px) => px,
            None => 25.4 / DPI.check("dpi", dpi)?,
        };
        Ok(SliceConfig { layer_height_mm, pixel_mm, margin_px })
    }

    /// Checks every range (the flags and the TOML keys alike).
    pub fn validate(&self) -> Result<(), SliceError> {
        LAYER_HEIGHT_MM.check("layer_height_mm", self.layer_height_mm)?;
        PIXEL_MM.check("pixel_mm", self.pixel_mm)?;
        MARGIN_PX.check("margin_px", self.margin_px)?;
        Ok(())
    }
}

impl Default for SliceConfig {
    fn default() -> Self {
        SliceConfig { layer_height_mm: 0.1, pixel_mm: 25.4 / 96.0, margin_px: 0 }
    }
}

/// Where the layer images sit: pixel `(i, j)` has its centre at
/// `(origin_x + (i + 1/2) pixel, origin_y + (j + 1/2) pixel)`, layer `k` is cut at
/// `z_min + (k + 1/2) layer_height`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SliceGrid {
    /// X of the first pixel's edge, mm.
    pub origin_x_mm: f64,
    /// Y of the first pixel's edge, mm.
    pub origin_y_mm: f64,
    /// Pixel side, mm.
    pub pixel_mm: f64,
    /// Image width, px.
    pub width_px: usize,
    /// Image height, px.
    pub height_px: usize,
    /// Bottom of the mesh, mm.
    pub z_min_mm: f64,
    /// Layer thickness, mm.
    pub layer_height_mm: f64,
    /// Number of layers.
    pub layers: usize,
}

impl SliceGrid {
    /// Plans the grid for a mesh.
    pub(crate) fn for_mesh(mesh: &Mesh, cfg: &SliceConfig) -> Result<Self, SliceError> {
        cfg.validate()?;
        // Every coordinate, not the bounds: `min` and `max` pass over a NaN.
        let non_finite = mesh.triangles.iter().enumerate().find_map(|(i, t)| {
            let v = t.iter().flatten().find(|v| !v.is_finite())?;
            Some(SliceError::NonFinite { triangle: i + 1, value: f64::from(*v) })
        });
        if let Some(e) = non_finite {
            return Err(e);
        }
        let (lo, hi) = mesh.bounds().ok_or(SliceError::EmptyMesh)?;
        let p = cfg.pixel_mm;
        let m = cfg.margin_px as f64;
        // Sizes in floating point first, checked against their ceilings before anything is
        // allocated or written: a 1e30 mm mesh must be refused, not overflow. A small tolerance
        // keeps an exact multiple (10 mm / 0.5 mm, or 0.3 mm stored as f32) from gaining a
        // column or layer.
        let cells = |span: f64| (span / p - 1e-6).ceil().max(0.0);
        let side = Ceiling::new(MAX_IMAGE_SIDE_PX, "pixels per image side");
        let span = |axis: usize| hi[axis] - lo[axis];
        let because = |axis: usize| {
            let name = ["X", "Y"][axis];
            move || format!("a {} mm {name} extent at {} mm per pixel", short(span(axis)), short(p))
        };
        let columns_rows_layers =
            [cells(span(0)), cells(span(1)), (span(2) / cfg.layer_height_mm - 1e-6).ceil().max(0.0)];
        // Nothing to print along one axis: images 0 px tall (the PNG encoder's "Zero height not
        // allowed"), or no layer at all and a summary that went on to suggest printing it.
        if let Some(axis) = columns_rows_layers.iter().position(|&n| n == 0.0) {
            return Err(SliceError::Flat { axis: ["X", "Y", "Z"][axis], at_mm: lo[axis] });
        }
        let [columns, rows, layers] = columns_rows_layers;
        let width_px = side.check(columns + 2.0 * m, because(0))?;
        let height_px = side.check(rows + 2.0 * m, because(1))?;
        let layers = Ceiling::new(MAX_LAYERS, "layers").check(layers, || {
            format!("a part {} mm tall at {} mm per layer", short(span(2)), short(cfg.layer_height_mm))
        })?;
        Ok(SliceGrid {
            origin_x_mm: lo[0] - m * p,
            origin_y_mm: lo[1] - m * p,
            pixel_mm: p,
            width_px: width_px as usize,
            height_px: height_px as usize,
            z_min_mm: lo[2],
            layer_height_mm: cfg.layer_height_mm,
            layers: layers as usize,
        })
    }

    /// Height of the cutting plane of layer `k`.
    pub(crate) fn z_of_layer(&self, k: usize) -> f64 {
        self.z_min_mm + (k as f64 + 0.5) * self.layer_height_mm
    }
}

/// Reusable slicing state: per-row crossing lists, kept between layers.
pub struct Slicer<'m> {
    mesh: &'m Mesh,
    grid: SliceGrid,
    crossings: Vec<Vec<f64>>,
}

impl<'m> Slicer<'m> {
    /// A slicer for `mesh` on the grid `cfg` gives (refused for an empty, flat or non-finite
    /// mesh).
    pub fn new(mesh: &'m Mesh, cfg: &SliceConfig) -> Result<Self, SliceError> {
        let grid = SliceGrid::for_mesh(mesh, cfg)?;
        Ok(Slicer { mesh, grid, crossings: vec![Vec::new(); grid.height_px] })
    }

    /// Where the layer images sit.
    pub fn grid(&self) -> &SliceGrid {
        &self.grid
    }

    /// Index of the first pixel whose centre is at or past `v` along an axis from `origin`.
    fn first_centre_at_or_after(&self, v: f64, origin: f64) -> isize {
        ((v - origin) / self.grid.pixel_mm - 0.5).ceil() as isize
    }

    /// The section at height `z_mm` as an image of the grid.
    pub(crate) fn slice_at(&mut self, z_mm: f64) -> Bitmap {
        let g = self.grid;
        for row in &mut self.crossings {
            row.clear();
        }
        for t in &self.mesh.triangles {
            let Some([(x0, y0), (x1, y1)]) = section_segment(t, z_mm) else {
                continue;
            };
            if y0 == y1 {
                continue;
            }
            let (ylo, yhi) = if y0 < y1 { (y0, y1) } else { (y1, y0) };
            let j0 = self.first_centre_at_or_after(ylo, g.origin_y_mm).max(0);
            let j1 = self.first_centre_at_or_after(yhi, g.origin_y_mm).min(g.height_px as isize);
            for j in j0..j1 {
                let yc = g.origin_y_mm + (j as f64 + 0.5) * g.pixel_mm;
                let x = x0 + (yc - y0) * (x1 - x0) / (y1 - y0);
                self.crossings[j as usize].push(x);
            }
        }
        let mut out = Bitmap::new(g.width_px, g.height_px);
        for j in 0..g.height_px {
            let xs = &mut self.crossings[j];
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                let clamp = |v: isize| v.clamp(0, g.width_px as isize) as usize;
                let i0 = clamp(((pair[0] - g.origin_x_mm) / g.pixel_mm - 0.5).ceil() as isize);
                let i1 = clamp(((pair[1] - g.origin_x_mm) / g.pixel_mm - 0.5).ceil() as isize);
                out.fill_span(j, i0, i1);
            }
        }
        out
    }

    /// Layer `k` at its mid-layer height.
    pub fn layer(&mut self, k: usize) -> Bitmap {
        let z = self.grid.z_of_layer(k);
        self.slice_at(z)
    }
}

/// The segment where a triangle crosses the plane `z`, as two (x, y) points, if it does.
fn section_segment(t: &[[f32; 3]; 3], z: f64) -> Option<[(f64, f64); 2]> {
    let v = t.map(|p| p.map(f64::from));
    let above = v.map(|p| p[2] > z);
    if above[0] == above[1] && above[1] == above[2] {
        return None;
    }
    let mut pts = [(0.0, 0.0); 2];
    let mut n = 0;
    for (a, b) in [(0, 1), (1, 2), (2, 0)] {
        if above[a] != above[b] {
            let s = (z - v[a][2]) / (v[b][2] - v[a][2]);
            pts[n] = (v[a][0] + s * (v[b][0] - v[a][0]), v[a][1] + s * (v[b][1] - v[a][1]));
            n += 1;
        }
    }
    Some(pts)
}

/// What [`slice_to_dir`] wrote.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SliceReport {
    /// Where the layer images sit.
    pub grid: SliceGrid,
    /// The images written, one per layer, bottom first.
    pub files: Vec<PathBuf>,
    /// Ink pixels per layer.
    pub pixels_per_layer: Vec<u64>,
}

/// Slices every layer and writes `layer_<k>.png` (five digits) into `dir`, one at a time.
pub fn slice_to_dir(mesh: &Mesh, cfg: &SliceConfig, dir: &Path) -> Result<SliceReport, SliceError> {
    let mut slicer = Slicer::new(mesh, cfg)?;
    std::fs::create_dir_all(dir).map_err(|source| SliceError::Io { path: dir.to_path_buf(), source })?;
    let grid = *slicer.grid();
    let mut files = Vec::with_capacity(grid.layers);
    let mut pixels_per_layer = Vec::with_capacity(grid.layers);
    for k in 0..grid.layers {
        let img = slicer.layer(k);
        let path = dir.join(format!("layer_{k:05}.png"));
        img.save_png(&path)?;
        pixels_per_layer.push(img.count_ones());
        files.push(path);
    }
    Ok(SliceReport { grid, files, pixels_per_layer })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gen::bitmap::{load_image, ThresholdOptions};
    use crate::gen::image_files::list_images;
    use crate::gen::stl::parse_stl;

    #[test]
    fn the_pixel_is_given_or_one_dot_at_the_resolution() {
        let c = SliceConfig::with_resolution(0.1, None, 96.0, 2).unwrap();
        assert_eq!(c, SliceConfig { layer_height_mm: 0.1, pixel_mm: 25.4 / 96.0, margin_px: 2 });
        let given = SliceConfig::with_resolution(0.1, Some(0.05), 96.0, 0).unwrap();
        assert_eq!(given.pixel_mm, 0.05);
        // A resolution of nothing is refused by name, not as an infinite pixel.
        let e = SliceConfig::with_resolution(0.1, None, 0.0, 0).unwrap_err();
        assert!(e.to_string().starts_with("dpi = 0 is out of range"), "{e}");
    }

    /// An axis-aligned box as 12 triangles.
    fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> Mesh {
        let c = |i: usize| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        };
        let quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
        let triangles =
            quads.iter().flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]]).collect();
        Mesh { triangles }
    }

    #[test]
    fn cube_gives_exact_pixel_counts() {
        let mesh = cuboid([2.0, -1.0, 0.5], [12.0, 4.0, 4.5]);
        let cfg = SliceConfig { layer_height_mm: 1.0, pixel_mm: 0.3, margin_px: 2 };
        // Through ASCII and binary STL too.
        let mut ascii = Vec::new();
        mesh.write_ascii(&mut ascii).unwrap();
        let mesh = parse_stl(&ascii).unwrap();
        let mut s = Slicer::new(&mesh, &cfg).unwrap();
        let g = *s.grid();
        // 10 mm / 0.3 -> 34 cells, 5 mm -> 17 cells, plus 2 margin on each side.
        assert_eq!((g.width_px, g.height_px, g.layers), (38, 21, 4));
        // Pixel centres inside [0, 10) along x from the box edge: (i + 1/2) 0.3 < 10 -> 33;
        // along y: (j + 1/2) 0.3 < 5 -> 17.
        for k in 0..g.layers {
            let img = s.layer(k);
            assert_eq!(img.count_ones(), 33 * 17, "layer {k}");
            assert!(img.get(2, 2) && img.get(34, 18) && !img.get(35, 2) && !img.get(2, 19));
        }
        assert_eq!(s.slice_at(4.6).count_ones(), 0);
    }

    /// UV sphere: `lat` bands from pole to pole, `lon` segments.
    fn sphere(r: f64, c: [f64; 3], lat: usize, lon: usize) -> Mesh {
        let p = |i: usize, j: usize| -> [f32; 3] {
            let th = std::f64::consts::PI * i as f64 / lat as f64;
            let ph = 2.0 * std::f64::consts::PI * j as f64 / lon as f64;
            [
                (c[0] + r * th.sin() * ph.cos()) as f32,
                (c[1] + r * th.sin() * ph.sin()) as f32,
                (c[2] + r * th.cos()) as f32,
            ]
        };
        let mut triangles = Vec::new();
        for i in 0..lat {
            for j in 0..lon {
                let (a, b, cc, d) = (p(i, j), p(i, j + 1), p(i + 1, j + 1), p(i + 1, j));
                if i > 0 {
                    triangles.push([a, b, cc]);
                }
                if i + 1 < lat {
                    triangles.push([a, cc, d]);
                }
            }
        }
        Mesh { triangles }
    }

    #[test]
    fn sphere_areas_within_one_percent() {
        let (r, c) = (10.0, [3.0, 4.0, 10.0]);
        let mesh = sphere(r, c, 180, 360);
        let cfg = SliceConfig { layer_height_mm: 0.5, pixel_mm: 0.1, margin_px: 1 };
        let mut s = Slicer::new(&mesh, &cfg).unwrap();
        let g = *s.grid();
        assert_eq!(g.layers, 40);
        let mut checked = 0;
        for k in 0..g.layers {
            let z = g.z_of_layer(k);
            let rz2 = r * r - (z - c[2]).powi(2);
            let want = std::f64::consts::PI * rz2;
            let got = s.layer(k).count_ones() as f64 * 0.01;
            if rz2 >= 9.0 {
                assert!((got - want).abs() < 0.01 * want, "layer {k}: {got} vs {want}");
                checked += 1;
            } else {
                assert!(got <= want * 1.05 + 0.05, "layer {k}: {got} vs {want}");
            }
        }
        assert_eq!(checked, 38);
    }

    #[test]
    fn slice_to_dir_writes_readable_pngs() {
        let mesh = cuboid([0.0, 0.0, 0.0], [2.0, 1.0, 0.3]);
        let cfg = SliceConfig { layer_height_mm: 0.1, pixel_mm: 0.25, margin_px: 0 };
        let dir = tempfile::tempdir().unwrap();
        let rep = slice_to_dir(&mesh, &cfg, dir.path()).unwrap();
        assert_eq!(rep.pixels_per_layer, vec![32, 32, 32]);
        let listed = list_images(dir.path()).unwrap();
        assert_eq!(listed, rep.files);
        let img = load_image(&listed[2], &ThresholdOptions::default(), 0.1).unwrap();
        assert_eq!((img.width(), img.height(), img.count_ones()), (8, 4, 32));
        assert!(matches!(slice_to_dir(&Mesh::default(), &cfg, dir.path()), Err(SliceError::EmptyMesh)));
    }

    /// Regression (B8): a NaN vertex was sliced (`min` and `max` pass over a NaN: 100 layers)
    /// where an infinite one was refused; a mesh with no Y extent reached the PNG encoder ("Zero
    /// height not allowed"); one with no Z extent gave 0 layers of 0 x 0 px. Each is refused
    /// before the folder is made.
    #[test]
    fn b8_nan_vertices_and_flat_meshes_are_refused_before_writing() {
        let tilted = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 10.0]];
        let cases: [(Vec<[[f32; 3]; 3]>, &str); 5] = [
            (
                vec![tilted, [[0.0, 0.0, 0.0], [10.0, f32::NAN, 0.0], [0.0, 10.0, 10.0]]],
                "the mesh has a vertex coordinate of nan (triangle 2)",
            ),
            (
                vec![[[0.0, 0.0, f32::NEG_INFINITY], [10.0, 0.0, 0.0], [0.0, 10.0, 10.0]]],
                "of -inf (triangle 1)",
            ),
            (
                vec![[[5.0, 0.0, 0.0], [5.0, 1.0, 0.0], [5.0, 0.0, 10.0]]],
                "the mesh is flat in X (all of its vertices at X = 5 mm): it has no volume to slice",
            ),
            (
                vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 10.0]]],
                "flat in Y (all of its vertices at Y = 0 mm)",
            ),
            (
                vec![[[0.0, 0.0, 2.5], [10.0, 0.0, 2.5], [0.0, 10.0, 2.5]]],
                "flat in Z (all of its vertices at Z = 2.5 mm)",
            ),
        ];
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("layers");
        for (triangles, message) in cases {
            let mesh = Mesh { triangles };
            let err = slice_to_dir(&mesh, &SliceConfig::default(), &out).unwrap_err().to_string();
            assert!(err.contains(message), "{err}");
            assert!(!out.exists());
        }
        // A margin makes no image of a flat mesh either.
        let flat = Mesh { triangles: vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 10.0]]] };
        let cfg = SliceConfig { margin_px: 5, ..SliceConfig::default() };
        assert!(matches!(Slicer::new(&flat, &cfg), Err(SliceError::Flat { axis: "Y", .. })));
        // The tilted triangle alone has an extent on every axis: it is sliced (into empty
        // layers, a lone triangle enclosing nothing).
        let lone = Mesh { triangles: vec![tilted] };
        let grid = *Slicer::new(&lone, &SliceConfig::default()).unwrap().grid();
        assert_eq!((grid.width_px, grid.height_px, grid.layers), (38, 38, 100));
    }

    /// Differential check against PrusaSlicer 2.5.0: the L plate (`tests/data/raster/L.stl`)
    /// sliced here at 0.2 mm pixels equals PrusaSlicer's SLA image of it, which put the part's
    /// corner at bed (20, 15) mm = pixel (100, 75).
    #[test]
    fn l_plate_matches_prusaslicer() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/raster");
        let mesh = crate::gen::stl::read_stl(&data.join("L.stl")).unwrap();
        let cfg = SliceConfig { layer_height_mm: 0.1, pixel_mm: 0.2, margin_px: 0 };
        let mut s = Slicer::new(&mesh, &cfg).unwrap();
        assert_eq!((s.grid().width_px, s.grid().height_px, s.grid().layers), (100, 50, 10));
        let ours = s.layer(5);
        let mut r = crate::gen::sl1::Sl1Reader::open(&data.join("L_portrait_10.sl1")).unwrap();
        let last = r.layer_count() - 1;
        let theirs = r.bed_layer(last, &ThresholdOptions::default()).unwrap();
        assert_eq!(ours.count_ones(), theirs.count_ones());
        assert_eq!(ours.count_ones(), 100 * 20 + 20 * 30);
        for (x, y) in ours.ones() {
            assert!(theirs.get(x + 100, y + 75), "({x}, {y})");
        }
    }
}
