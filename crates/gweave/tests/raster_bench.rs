//! Throughput check for the raster generator (run in release:
//! `cargo test --release -p gweave --test raster_bench -- --ignored --nocapture`).

use gweave::gen::bitmap::Bitmap;
use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster::{RasterConfig, RasterWriter};

/// A disc of radius 900 px in a 2000 x 2000 image (about 64 % ink).
fn disc(n: usize, r: f64) -> Bitmap {
    let mut b = Bitmap::new(n, n);
    let c = n as f64 / 2.0;
    for y in 0..n {
        let dy = y as f64 + 0.5 - c;
        let half = (r * r - dy * dy).max(0.0).sqrt();
        let x0 = (c - half).ceil().max(0.0) as usize;
        let x1 = (c + half).floor().max(0.0) as usize;
        b.fill_span(y, x0, x1);
    }
    b
}

#[test]
#[ignore = "benchmark: run in release"]
fn bench_500_layers_2000px() {
    let img = disc(2000, 900.0);
    let profile = PrintheadProfile::default();
    let cfg = RasterConfig::default();
    let t = std::time::Instant::now();
    let mut w = RasterWriter::new(std::io::sink(), &profile, &cfg, None).unwrap();
    for _ in 0..500 {
        w.layer(std::slice::from_ref(&img)).unwrap();
    }
    let (_, rep) = w.finish().unwrap();
    let s = t.elapsed().as_secs_f64();
    println!(
        "500 layers 2000x2000: {s:.2} s, {} columns, {} drops",
        rep.columns_fired, rep.drops_per_head[0]
    );
    assert_eq!(rep.drops_per_head[0], img.count_ones() * 500);
    assert!(s < 10.0, "{s} s");
}
