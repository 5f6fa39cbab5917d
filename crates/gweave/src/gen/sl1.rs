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
//!
//! Every number of the two settings files has a physical range (below, beside the keys), checked
//! when the archive is opened: an archive is a file anyone can edit, and a `layerHeight` of
//! `nan` or `-5` would otherwise be written into the G-code as `G1 ZNaN` or `G1 Z-5`.

use std::collections::HashMap;
use std::io::{Read, Seek};
use std::path::Path;

use thiserror::Error;

use super::bitmap::{decode, Bitmap, BitmapError, ThresholdOptions};
use crate::range::{
    OutOfRange, Range, BED_SIZE_MM, LAYER_HEIGHT_MM, MAX_IMAGE_SIDE_PX, MAX_LAYERS, PIXEL_MM,
};

/// `display_pixels_x`, `display_pixels_y`: each layer is made a bed image of this size, so it is
/// held to the side of any generated image (the largest resin printers' masks are about
/// 15 000 px) before any is allocated.
const DISPLAY_PX: Range = Range::new(1.0, MAX_IMAGE_SIDE_PX as f64, "px");
/// `display_width`, `display_height`: the display is the printer's bed, and spans what a bed may.
const DISPLAY_MM: Range = BED_SIZE_MM;
/// `numFast`, `numSlow`: layers printed with each tilt, so no more than a print's layers.
const TILT_LAYERS: Range<u32> = Range::new(0, MAX_LAYERS as u32, "layers");

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
    /// A key of the archive's settings is missing or not a number.
    #[error("sl1 {file}: missing or invalid key {key}")]
    Key {
        /// The file inside the archive.
        file: &'static str,
        /// The key.
        key: &'static str,
    },
    /// A key of the archive's settings out of its physical range.
    #[error("sl1 {file}: {source}")]
    Range {
        /// The file inside the archive.
        file: &'static str,
        /// The key, its value and its range.
        source: OutOfRange,
    },
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

/// The archive's two settings files: the job's `config.ini` and the printer's `prusaslicer.ini`.
struct Settings {
    job: HashMap<String, String>,
    printer: HashMap<String, String>,
}

/// Where a key is looked up.
#[derive(Clone, Copy)]
enum File {
    /// `config.ini`.
    Job,
    /// `prusaslicer.ini`, then `config.ini` (hand-made archives put printer keys there).
    Printer,
}

impl Settings {
    /// The value of `key` and the name of the file that gives it; the first file to look in
    /// when none does.
    fn find(&self, file: File, key: &str) -> (&'static str, Option<&str>) {
        let job = ("config.ini", self.job.get(key).map(String::as_str));
        match file {
            File::Job => job,
            File::Printer => match self.printer.get(key) {
                Some(v) => ("prusaslicer.ini", Some(v)),
                None if job.1.is_some() => job,
                None => ("prusaslicer.ini", None),
            },
        }
    }

    /// `key` as a number in `range`: missing or not a number is refused, as is a value out of
    /// range (NaN and infinities included), naming the file and the key.
    fn number<T: crate::range::Quantity + std::str::FromStr>(
        &self,
        file: File,
        key: &'static str,
        range: Range<T>,
    ) -> Result<T, Sl1Error> {
        let (file, value) = self.find(file, key);
        let v = value.and_then(|v| v.parse().ok()).ok_or(Sl1Error::Key { file, key })?;
        range.check(key, v).map_err(|source| Sl1Error::Range { file, source })
    }

    /// A count of pixels (`display_pixels_x`): a whole number in [`DISPLAY_PX`].
    fn pixels(&self, key: &'static str) -> Result<u32, Sl1Error> {
        let px = self.number(File::Printer, key, DISPLAY_PX)?;
        if px.fract() != 0.0 {
            return Err(Sl1Error::Key { file: self.find(File::Printer, key).0, key });
        }
        Ok(px as u32)
    }

    /// An optional count (`numFast`): 0 when missing, refused when invalid or out of `range`.
    fn optional(&self, key: &'static str, range: Range<u32>) -> Result<u32, Sl1Error> {
        match self.find(File::Job, key) {
            (_, None) => Ok(0),
            _ => self.number(File::Job, key, range),
        }
    }
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
        let settings = Settings {
            job: parse_ini(
                &read_entry(&mut archive, "config.ini")?
                    .ok_or(Sl1Error::Key { file: "config.ini", key: "(file)" })?,
            ),
            printer: parse_ini(&read_entry(&mut archive, "prusaslicer.ini")?.unwrap_or_default()),
        };
        let printer = &settings.printer;
        let flag = |k: &str| printer.get(k).is_some_and(|v| v == "1");
        let job_dir =
            settings.job.get("jobDir").ok_or(Sl1Error::Key { file: "config.ini", key: "jobDir" })?.clone();
        // The G-code's Z steps: the range of any layer height.
        let layer_height_mm = settings.number(File::Job, "layerHeight", LAYER_HEIGHT_MM)?;
        let display_pixels_x = settings.pixels("display_pixels_x")?;
        let display_pixels_y = settings.pixels("display_pixels_y")?;
        let display_width_mm = settings.number(File::Printer, "display_width", DISPLAY_MM)?;
        let display_height_mm = settings.number(File::Printer, "display_height", DISPLAY_MM)?;
        // The pixel, resampled to the nozzle pitch: the span of any pixel size (`--pixel-mm`).
        // A 0.0000001 mm display in range of nothing else made pixels that no nozzle reached,
        // and the print was dropped without a word.
        let px_w = display_width_mm / f64::from(display_pixels_x);
        let px_h = display_height_mm / f64::from(display_pixels_y);
        for (key, keys, px) in [
            ("display_width", "display_width / display_pixels_x", px_w),
            ("display_height", "display_height / display_pixels_y", px_h),
        ] {
            let file = settings.find(File::Printer, key).0;
            PIXEL_MM.check(keys, px).map_err(|source| Sl1Error::Range { file, source })?;
        }
        let orientation = match printer.get("display_orientation").map(String::as_str) {
            Some("portrait") => Orientation::Portrait,
            _ => Orientation::Landscape,
        };
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
            num_fast: settings.optional("numFast", TILT_LAYERS)?,
            num_slow: settings.optional("numSlow", TILT_LAYERS)?,
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

    /// The sphere's settings and first layer as an archive in memory, each `(file, old, new)`
    /// of `edits` replacing `old` by `new` in that settings file.
    fn edited(edits: &[(&str, &str, &str)]) -> Vec<u8> {
        use std::io::Write;
        let mut src = zip::ZipArchive::new(std::fs::File::open(fixture()).unwrap()).unwrap();
        let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        for name in ["config.ini", "prusaslicer.ini", "sphere00000.png"] {
            let mut data = Vec::new();
            src.by_name(name).unwrap().read_to_end(&mut data).unwrap();
            for &(_, old, new) in edits.iter().filter(|e| e.0 == name) {
                let text = String::from_utf8(data).unwrap();
                assert!(text.contains(old), "{old}");
                data = text.replace(old, new).into_bytes();
            }
            out.start_file(name, zip::write::SimpleFileOptions::default()).unwrap();
            out.write_all(&data).unwrap();
        }
        out.finish().unwrap().into_inner()
    }

    /// Regression (B3): `layerHeight` was never range-checked (`nan` and `inf` wrote `G1 ZNaN`,
    /// `-5` wrote `G1 Z-5`, `1e300` a 301-digit Z, all with exit 0); `display_width =
    /// 0.0000001` dropped the print without a word (no pixel reached a nozzle); and `-120` or
    /// `0` was refused naming another key (display_pixels_x). Each key has its range, and a
    /// refusal names the file inside the archive, the key, the value and the range.
    #[test]
    fn b3_every_number_of_the_settings_is_in_its_range() {
        let job = |old: &str, new: &str| edited(&[("config.ini", old, new)]);
        let printer = |old: &str, new: &str| edited(&[("prusaslicer.ini", old, new)]);
        let height = "layerHeight = 0.1";
        let width = "display_width = 120";
        let cases = [
            (job(height, "layerHeight = nan"), "sl1 config.ini: layerHeight = nan is out of range: 0.001 to 10 mm"),
            (job(height, "layerHeight = inf"), "sl1 config.ini: layerHeight = inf is out of range: 0.001 to 10 mm"),
            (job(height, "layerHeight = -5"), "sl1 config.ini: layerHeight = -5 is out of range: 0.001 to 10 mm"),
            (job(height, "layerHeight = 1e300"), "sl1 config.ini: layerHeight = 1e300 is out of range: 0.001 to 10 mm"),
            (job(height, "layerHeight = thin"), "sl1 config.ini: missing or invalid key layerHeight"),
            (job("numFast = 308", "numFast = 1000000"), "sl1 config.ini: numFast = 1000000 is out of range: 0 to 100000 layers"),
            (job("numSlow = 0", "numSlow = -1"), "sl1 config.ini: missing or invalid key numSlow"),
            (
                printer(width, "display_width = 0.0000001"),
                "sl1 prusaslicer.ini: display_width = 1e-7 is out of range: 1 to 10000 mm",
            ),
            (printer(width, "display_width = -120"), "sl1 prusaslicer.ini: display_width = -120 is out of range: 1 to 10000 mm"),
            (printer(width, "display_width = 0"), "sl1 prusaslicer.ini: display_width = 0 is out of range: 1 to 10000 mm"),
            (
                printer("display_height = 80", "display_height = nan"),
                "sl1 prusaslicer.ini: display_height = nan is out of range: 1 to 10000 mm",
            ),
            (
                printer("display_pixels_x = 600", "display_pixels_x = 0"),
                "sl1 prusaslicer.ini: display_pixels_x = 0 is out of range: 1 to 20000 px",
            ),
            (
                printer("display_pixels_y = 400", "display_pixels_y = 1e9"),
                "sl1 prusaslicer.ini: display_pixels_y = 1e9 is out of range: 1 to 20000 px",
            ),
            (printer("display_pixels_x = 600", "display_pixels_x = 600.5"), "sl1 prusaslicer.ini: missing or invalid key display_pixels_x"),
            // In range each, but a pixel of 16.7 mm: no printer's.
            (
                printer(width, "display_width = 10000"),
                "sl1 prusaslicer.ini: display_width / display_pixels_x = 16.6667 is out of range: 0.00254 to 2.54 mm",
            ),
        ];
        for (archive, message) in cases {
            let err = Sl1Reader::new(std::io::Cursor::new(archive)).err().expect(message);
            assert_eq!(err.to_string(), message);
        }
        // A printer key that a hand-made archive puts in config.ini is named there.
        let moved = edited(&[
            ("prusaslicer.ini", width, ""),
            ("config.ini", height, "layerHeight = 0.1\ndisplay_width = 0"),
        ]);
        let err = Sl1Reader::new(std::io::Cursor::new(moved)).err().unwrap();
        assert_eq!(err.to_string(), "sl1 config.ini: display_width = 0 is out of range: 1 to 10000 mm");
        // The fixture itself reads, its numbers unchanged.
        let info = Sl1Reader::new(std::io::Cursor::new(edited(&[]))).unwrap().info().clone();
        assert_eq!(
            (info.layer_height_mm, info.display_width_mm, info.display_pixels_x, info.num_fast),
            (0.1, 120.0, 600, 308)
        );
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
