//! Reader for PrusaSlicer `.sl1` SLA archives, used as layer images for binder jetting.
//!
//! An `.sl1` file is a ZIP holding `config.ini` (job: `jobDir`, `layerHeight`, `numFast`,
//! `numSlow`, ...), `prusaslicer.ini` (printer: `display_pixels_x/y`, `display_width/height` in
//! mm, `display_mirror_x/y`, `display_orientation`) and one anti-aliased greyscale PNG per layer
//! named `<jobDir>%05d.png` (PrusaSlicer's SL1 export). Both ini files are `key = value` lines.
//!
//! How the stored image relates to the bed (our own measurement: PrusaSlicer 2.5.0 exports of
//! an L-shaped plate for all eight orientation/mirror settings, `tests/data/raster/L_*.sl1`).
//! With bed pixel `(i, j)` = bed position `((i + 1/2) w, (j + 1/2) h)`, `W x H` =
//! `display_pixels_x x display_pixels_y`, and `mx`, `my` the mirror flags:
//!
//! ```text
//! landscape: PNG is W x H,  stored(col, row) = bed(mx ? W-1-col : col,  my ? row : H-1-row)
//! portrait:  PNG is H x W,  stored(col, row) = bed(my ? row : W-1-row,  mx ? col : H-1-col)
//! ```
//!
//! i.e. unmirrored landscape images are the top view with +Y up (row 0 = far edge), the mirror
//! flags flip the image's own columns and rows, and portrait turns the top view by 90 degrees.
//! [`Sl1Reader::layer`] returns the image as stored; [`Sl1Reader::bed_layer`] undoes all of
//! that and returns the bed view in the raster convention (x right, row 0 = lowest Y), which
//! is what a binder-jet print of the model needs.
//!
//! Layers are decoded one at a time straight from the archive, so memory stays bounded by one
//! layer whatever the number of layers.

use std::collections::HashMap;
use std::io::{Read, Seek};
use std::path::Path;

use thiserror::Error;

use super::bitmap::{decode, Bitmap, BitmapError, ThresholdOptions};

/// Errors from reading an `.sl1` archive.
#[derive(Debug, Error)]
pub enum Sl1Error {
    /// The archive cannot be opened.
    #[error("{path}: {source}")]
    Io {
        /// The archive.
        path: std::path::PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The archive is not a valid zip.
    #[error("sl1 archive: {0}")]
    Zip(#[from] zip::result::ZipError),
    /// A key of the archive's `config.ini` is missing or invalid.
    #[error("sl1 {file}: missing or invalid key {key}")]
    Key {
        /// The file inside the archive.
        file: &'static str,
        /// The key.
        key: &'static str,
    },
    /// A size in the archive's settings past its ceiling.
    #[error("sl1: {0}")]
    TooLarge(#[from] crate::range::TooLarge),
    /// No layer image in the archive.
    #[error("sl1 has no layer images {0}NNNNN.png")]
    NoLayers(String),
    /// A layer index past the last layer.
    #[error("sl1 layer {index} out of range (count {count})")]
    LayerIndex {
        /// The index asked for.
        index: usize,
        /// The number of layers.
        count: usize,
    },
    /// A layer image cannot be decoded.
    #[error("sl1 layer {name}: {source}")]
    Image {
        /// The image's name in the archive.
        name: String,
        /// Why it cannot be decoded.
        source: BitmapError,
    },
    /// A layer image of another size than the display.
    #[error("sl1 layer {name}: {width}x{height} px, expected {expected_w}x{expected_h}")]
    LayerSize {
        /// The image's name in the archive.
        name: String,
        /// Its width, px.
        width: usize,
        /// Its height, px.
        height: usize,
        /// The width the display needs, px.
        expected_w: usize,
        /// The height the display needs, px.
        expected_h: usize,
    },
}

/// Display orientation from `display_orientation`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Orientation {
    /// `display_orientation = landscape`: images as the display's pixels are laid out.
    Landscape,
    /// `display_orientation = portrait`: the images' width and height are swapped.
    Portrait,
}

/// What the archive says about its layers.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Sl1Info {
    /// `jobDir`: the prefix of the layer images' names.
    pub job_dir: String,
    /// `layerHeight`, mm.
    pub layer_height_mm: f64,
    /// `numFast`: layers printed with the fast tilt.
    pub num_fast: u32,
    /// `numSlow`: layers printed with the slow tilt.
    pub num_slow: u32,
    /// `display_pixels_x`: the display's width, px.
    pub display_pixels_x: u32,
    /// `display_pixels_y`: the display's height, px.
    pub display_pixels_y: u32,
    /// `display_width`, mm.
    pub display_width_mm: f64,
    /// `display_height`, mm.
    pub display_height_mm: f64,
    /// `display_mirror_x`: images are mirrored along x.
    pub mirror_x: bool,
    /// `display_mirror_y`: images are mirrored along y.
    pub mirror_y: bool,
    /// `display_orientation`.
    pub orientation: Orientation,
    /// Layer image size in pixels (after the portrait swap).
    pub image_width_px: usize,
    /// Layer image height in pixels (after the portrait swap).
    pub image_height_px: usize,
    /// Size of one image pixel along the image's x (columns) and y (rows) axes.
    pub pixel_x_mm: f64,
    /// Size of one image pixel along y (rows), mm.
    pub pixel_y_mm: f64,
    /// Number of layer PNGs in the archive.
    pub layer_count: usize,
}

/// An open `.sl1` archive.
pub struct Sl1Reader<R: Read + Seek> {
    archive: zip::ZipArchive<R>,
    info: Sl1Info,
    /// Entry names of the layers in order.
    layer_names: Vec<String>,
}

fn parse_ini(text: &str) -> HashMap<String, String> {
    text.lines()
        .filter_map(|l| l.split_once('='))
        .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        .collect()
}

fn read_entry<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    name: &str,
) -> Result<Option<String>, Sl1Error> {
    let entry = match archive.by_name(name) {
        Ok(e) => e,
        Err(zip::result::ZipError::FileNotFound) => return Ok(None),
        Err(e) => return Err(e.into()),
    };
    // A settings file of the archive, bounded as any settings file is (it may inflate to GBs).
    let limit = crate::settings::MAX_FILE_BYTES;
    let mut s = String::new();
    entry
        .take(limit + 1)
        .read_to_string(&mut s)
        .map_err(|source| Sl1Error::Io { path: name.into(), source })?;
    if s.len() as u64 > limit {
        let source =
            std::io::Error::new(std::io::ErrorKind::InvalidData, "larger than a settings file may be");
        return Err(Sl1Error::Io { path: name.into(), source });
    }
    Ok(Some(s))
}

fn key<T: std::str::FromStr>(
    map: &HashMap<String, String>,
    file: &'static str,
    key: &'static str,
) -> Result<T, Sl1Error> {
    map.get(key).and_then(|v| v.parse().ok()).ok_or(Sl1Error::Key { file, key })
}

impl Sl1Reader<std::io::BufReader<std::fs::File>> {
    /// Opens an `.sl1` file.
    pub fn open(path: &Path) -> Result<Self, Sl1Error> {
        let file =
            std::fs::File::open(path).map_err(|source| Sl1Error::Io { path: path.to_path_buf(), source })?;
        Self::new(std::io::BufReader::new(file))
    }
}

impl<R: Read + Seek> Sl1Reader<R> {
    /// Reads the configuration and the list of layer images.
    pub fn new(reader: R) -> Result<Self, Sl1Error> {
        let mut archive = zip::ZipArchive::new(reader)?;
        let job = parse_ini(
            &read_entry(&mut archive, "config.ini")?
                .ok_or(Sl1Error::Key { file: "config.ini", key: "(file)" })?,
        );
        let printer = parse_ini(&read_entry(&mut archive, "prusaslicer.ini")?.unwrap_or_default());
        // Printer keys may also appear in config.ini in hand-made archives.
        let pick = |k: &'static str| -> Result<f64, Sl1Error> {
            key(&printer, "prusaslicer.ini", k).or_else(|_| key(&job, "config.ini", k))
        };
        let flag = |k: &str| printer.get(k).is_some_and(|v| v == "1");
        let job_dir: String = key(&job, "config.ini", "jobDir")?;
        let layer_height_mm: f64 = key(&job, "config.ini", "layerHeight")?;
        let display_pixels_x = pick("display_pixels_x")? as u32;
        let display_pixels_y = pick("display_pixels_y")? as u32;
        let display_width_mm = pick("display_width")?;
        let display_height_mm = pick("display_height")?;
        if display_pixels_x == 0 || display_pixels_y == 0 || display_width_mm <= 0.0 {
            return Err(Sl1Error::Key { file: "prusaslicer.ini", key: "display_pixels_x" });
        }
        // Each layer is made a bed image of this size: held to the ceiling of an image side
        // before any is allocated (the largest resin printers' masks are about 15 000 px).
        let side = f64::from(display_pixels_x.max(display_pixels_y));
        crate::range::Ceiling::new(crate::range::MAX_IMAGE_SIDE_PX, "pixels per image side")
            .check(side, || "the archive's display (display_pixels_x, display_pixels_y)".to_owned())?;
        let orientation = match printer.get("display_orientation").map(String::as_str) {
            Some("portrait") => Orientation::Portrait,
            _ => Orientation::Landscape,
        };
        let px_w = display_width_mm / f64::from(display_pixels_x);
        let px_h = display_height_mm / f64::from(display_pixels_y);
        let (image_width_px, image_height_px, pixel_x_mm, pixel_y_mm) = match orientation {
            Orientation::Landscape => (display_pixels_x, display_pixels_y, px_w, px_h),
            Orientation::Portrait => (display_pixels_y, display_pixels_x, px_h, px_w),
        };
        // Layer entries: <jobDir><digits>.png, ordered by their number.
        let mut layers: Vec<(u64, String)> = archive
            .file_names()
            .filter_map(|n| {
                let digits = n.strip_prefix(job_dir.as_str())?.strip_suffix(".png")?;
                if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                    return None;
                }
                Some((digits.parse().ok()?, n.to_string()))
            })
            .collect();
        if layers.is_empty() {
            return Err(Sl1Error::NoLayers(job_dir));
        }
        layers.sort();
        let info = Sl1Info {
            num_fast: key(&job, "config.ini", "numFast").unwrap_or(0),
            num_slow: key(&job, "config.ini", "numSlow").unwrap_or(0),
            job_dir,
            layer_height_mm,
            display_pixels_x,
            display_pixels_y,
            display_width_mm,
            display_height_mm,
            mirror_x: flag("display_mirror_x"),
            mirror_y: flag("display_mirror_y"),
            orientation,
            image_width_px: image_width_px as usize,
            image_height_px: image_height_px as usize,
            pixel_x_mm,
            pixel_y_mm,
            layer_count: layers.len(),
        };
        Ok(Sl1Reader { archive, info, layer_names: layers.into_iter().map(|(_, n)| n).collect() })
    }

    /// What the archive says about its layers.
    pub fn info(&self) -> &Sl1Info {
        &self.info
    }

    /// Number of layer images.
    pub fn layer_count(&self) -> usize {
        self.layer_names.len()
    }

    /// Layer `index` as bed view: `display_pixels_x` wide, `display_pixels_y` tall, pixel
    /// `(i, j)` at bed `((i + 1/2) display_width / display_pixels_x, (j + 1/2) ...)`, row 0 at
    /// the lowest Y (see the module docs for the mapping).
    pub fn bed_layer(&mut self, index: usize, opts: &ThresholdOptions) -> Result<Bitmap, Sl1Error> {
        let stored = self.layer(index, opts)?;
        let info = &self.info;
        let (w, h) = (info.display_pixels_x as usize, info.display_pixels_y as usize);
        let (mx, my) = (info.mirror_x, info.mirror_y);
        let mut bed = Bitmap::new(w, h);
        for (col, row) in stored.ones() {
            let (i, j) = match info.orientation {
                Orientation::Landscape => {
                    (if mx { w - 1 - col } else { col }, if my { row } else { h - 1 - row })
                }
                Orientation::Portrait => {
                    (if my { row } else { w - 1 - row }, if mx { col } else { h - 1 - col })
                }
            };
            bed.set(i, j, true);
        }
        Ok(bed)
    }

    /// Bed pixel size `(x, y)` in mm for [`Self::bed_layer`] images.
    pub fn bed_pixel_mm(&self) -> (f64, f64) {
        (
            self.info.display_width_mm / f64::from(self.info.display_pixels_x),
            self.info.display_height_mm / f64::from(self.info.display_pixels_y),
        )
    }

    /// Decodes and thresholds layer `index` (0-based, the first exposed layer).
    pub fn layer(&mut self, index: usize, opts: &ThresholdOptions) -> Result<Bitmap, Sl1Error> {
        let name = self
            .layer_names
            .get(index)
            .ok_or(Sl1Error::LayerIndex { index, count: self.layer_names.len() })?
            .clone();
        let mut entry = self.archive.by_name(&name)?;
        // The size the archive claims is not trusted for the allocation: the read is bounded
        // by the largest 1-bit layer (one bit a pixel, plus PNG's row bytes).
        let most = crate::range::MAX_IMAGE_SIDE_PX.pow(2) / 8 + (1 << 20);
        let mut png = Vec::with_capacity(entry.size().min(1 << 20) as usize);
        (&mut entry)
            .take(most)
            .read_to_end(&mut png)
            .map_err(|source| Sl1Error::Io { path: name.clone().into(), source })?;
        let pixel_mm = self.info.pixel_x_mm.min(self.info.pixel_y_mm);
        let bitmap =
            decode(&png, opts, pixel_mm).map_err(|source| Sl1Error::Image { name: name.clone(), source })?;
        let (w, h) = (self.info.image_width_px, self.info.image_height_px);
        if (bitmap.width(), bitmap.height()) != (w, h) {
            return Err(Sl1Error::LayerSize {
                name,
                width: bitmap.width(),
                height: bitmap.height(),
                expected_w: w,
                expected_h: h,
            });
        }
        Ok(bitmap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/raster/sphere.sl1")
    }

    #[test]
    fn reads_sphere_fixture() {
        let mut r = Sl1Reader::open(&fixture()).unwrap();
        let info = r.info().clone();
        assert_eq!(info.job_dir, "sphere");
        assert_eq!(info.layer_height_mm, 0.1);
        assert_eq!(info.num_fast, 308);
        assert_eq!(info.layer_count, 308);
        assert_eq!(info.orientation, Orientation::Portrait);
        assert_eq!((info.image_width_px, info.image_height_px), (400, 600));
        assert!((info.pixel_x_mm - 0.2).abs() < 1e-12 && (info.pixel_y_mm - 0.2).abs() < 1e-12);
        assert!(info.mirror_x && !info.mirror_y);
        // The equator layer (150) is a disc centred on the 400x600 display: its area must be
        // pi r^2 for r = half its extent (anti-aliased edges thresholded at 50 %).
        let mid = r.layer(150, &ThresholdOptions::default()).unwrap();
        assert_eq!((mid.width(), mid.height()), (400, 600));
        let (mut x0, mut x1, mut y0, mut y1) = (usize::MAX, 0, usize::MAX, 0);
        for y in 0..mid.height() {
            for x in (0..mid.width()).filter(|&x| mid.get(x, y)) {
                (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
            }
        }
        assert_eq!((x0 + x1, y0 + y1), (399, 599), "centred");
        assert_eq!(x1 - x0, y1 - y0, "round");
        let r_mm = (x1 - x0 + 1) as f64 * 0.2 / 2.0;
        let area_mm2 = mid.count_ones() as f64 * 0.04;
        let disc = std::f64::consts::PI * r_mm * r_mm;
        assert!((area_mm2 - disc).abs() < 0.01 * disc, "{area_mm2} vs {disc}");
        let first = r.layer(0, &ThresholdOptions::default()).unwrap();
        assert!(first.count_ones() * 20 < mid.count_ones());
        let bed = r.bed_layer(150, &ThresholdOptions::default()).unwrap();
        assert_eq!((bed.width(), bed.height()), (600, 400));
        assert_eq!(bed.count_ones(), mid.count_ones());
        assert!(matches!(
            r.layer(308, &ThresholdOptions::default()),
            Err(Sl1Error::LayerIndex { index: 308, count: 308 })
        ));
    }

    /// Every orientation and mirror setting gives the same bed view of the L plate:
    /// bar x 20..40, y 15..19 mm and tab x 36..40, y 19..25 mm at 0.2 mm pixels.
    #[test]
    fn bed_layer_undoes_orientation_and_mirror() {
        let mut want = Bitmap::new(600, 400);
        for j in 75..95 {
            want.fill_span(j, 100, 200);
        }
        for j in 95..125 {
            want.fill_span(j, 180, 200);
        }
        for o in ["landscape", "portrait"] {
            for m in ["00", "01", "10", "11"] {
                let name = format!("L_{o}_{m}.sl1");
                let path = fixture().with_file_name(&name);
                let mut r = Sl1Reader::open(&path).unwrap();
                assert_eq!(r.info().mirror_x, &m[..1] == "1", "{name}");
                assert_eq!(r.info().mirror_y, &m[1..] == "1", "{name}");
                assert_eq!(r.bed_pixel_mm(), (0.2, 0.2));
                let last = r.layer_count() - 1;
                let bed = r.bed_layer(last, &ThresholdOptions::default()).unwrap();
                assert_eq!(bed, want, "{name}");
            }
        }
    }
}
