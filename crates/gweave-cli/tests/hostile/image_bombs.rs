//! Layer images whose header says more than a bed holds: `raster` of a 557 KB 1-bit PNG of
//! 60 000 x 60 000 pixels ran for minutes in 886 MB writing a 7.4 GB scratch file, and 21 000 x
//! 21 000 (83 KB) exited 0 after 113 s with 1.2 GB of G-code. The size in the header is checked
//! before anything is decoded or written, against the pixels that cover the largest bed (10 m)
//! at the pixel size the image is printed at, and at most 20 000 per side.

use std::fs;
use std::time::Duration;

use crate::bombs::{bmp_header, png};
use crate::harness::*;

const BUDGET_MIB: f64 = 64.0;

/// `raster` of the image `bytes` named `name`, with `extra` flags: refused in budget, at once,
/// with `message`, and nothing written.
#[track_caller]
fn raster_refuses(name: &str, bytes: &[u8], extra: &[&str], message: &str) {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join(name), bytes).unwrap();
    let mut args = vec!["raster", name, "-o", "out.gcode"];
    args.extend_from_slice(extra);
    let out =
        gweave(dir.path(), &args).limit(Duration::from_secs(30)).cpu_limit(Duration::from_secs(5)).run();
    out.assert_refused(message).assert_peak_under(BUDGET_MIB);
    assert!(!dir.path().join("out.gcode").exists(), "{name}: an output was written");
    assert_no_temp_left(dir.path());
}

/// Regression: a 60 000 x 60 000 1-bit PNG (about 450 KB) ran for minutes in 886 MB, writing a
/// 7.4 GB scratch file; 21 000 x 21 000 wrote 1.2 GB of G-code. Refused from the header.
#[test]
fn a_png_larger_than_any_bed_is_refused_before_it_is_decoded() {
    let big = png(60_000, 60_000, 1);
    assert!(big.len() < 1 << 20, "a small file: {} bytes", big.len());
    raster_refuses(
        "big.png",
        &big,
        &[],
        "the image is 60000 x 60000 px, more than the limit of 20000 px per side at 0.264583 mm a pixel",
    );
    raster_refuses("mid.png", &png(21_000, 21_000, 1), &[], "the image is 21000 x 21000 px");
    // The expanding decoder's path (8 bits a pixel) is checked the same way.
    raster_refuses("mid8.png", &png(21_000, 100, 8), &[], "the image is 21000 x 100 px");
}

/// The ceiling follows the pixel size the image is printed at: at 2.54 mm a pixel, 3 937
/// pixels cover the largest bed (10 m), so a 5 000-pixel-wide image is refused, and a BMP or
/// TIFF header is read as a PNG's is.
#[test]
fn the_ceiling_is_the_largest_bed_at_the_images_pixel_size() {
    raster_refuses(
        "wide.png",
        &png(5_000, 10, 1),
        &["--pixel-mm", "2.54"],
        "the image is 5000 x 10 px, more than the limit of 3937 px per side at 2.54 mm a pixel (the largest bed, \
         10000 mm",
    );
    raster_refuses("huge.bmp", &bmp_header(60_000, 60_000), &[], "the image is 60000 x 60000 px");
    // A negative BMP height is a top-down image; its size is the same.
    raster_refuses("down.bmp", &bmp_header(30_000, -30_000), &[], "the image is 30000 x 30000 px");
}

/// An image within the ceiling still rasters.
#[test]
fn an_image_within_the_ceiling_rasters() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("small.png"), png(2_000, 50, 1)).unwrap();
    gweave(dir.path(), &["raster", "small.png", "-o", "out.gcode", "--invert"]).run().assert_ok();
    let text = fs::read_to_string(dir.path().join("out.gcode")).unwrap();
    assert!(text.contains("M700 P0 S4095"), "every nozzle fires on black pixels with --invert");
}

/// Regression (a breaking session): an RGB image within the side ceiling whose pixels take more
/// than the `image` crate's allocation limit (13 500 x 13 500 px, 521 MiB) was refused with its
/// bare "Memory limit exceeded". The message says the size, the format and the way out, from
/// the header, before anything is decoded.
#[test]
fn an_image_too_large_to_decode_says_why() {
    raster_refuses(
        "rgb.bmp",
        &bmp_header(14_000, 14_000),
        &[],
        "the image is 14000 x 14000 px of Rgb8: 561 MiB decoded, more than the 512 MiB an image may take; save it \
         as 8-bit greyscale (a byte a pixel) or 1-bit",
    );
}
