//! The speed chart's figures on a real file: the planned speed over time, integrated, is the
//! length of every move of the file; no slice is faster than the fastest feed rate asked for;
//! and the layer bars are the report's per-layer times.

use std::path::Path;

use gweave::{Toolpath, ToolpathOptions};
use gweave_sim::MachineProfile;
use gweave_sim::{speed_chart, ChartFormat};
use gweave_sim::{Machine, Outcome};

#[test]
fn the_speed_trace_of_cura_torus_adds_up_to_its_path() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cura/cura_torus.gcode");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut machine = Machine::new(MachineProfile::default()).unwrap();
    machine.record_speed();
    for line in text.lines() {
        assert_ne!(machine.execute(line.as_bytes(), &mut |_, _| {}), Outcome::Halted);
    }
    machine.finish(&mut |_, _| {});
    let report = machine.report();
    let trace = machine.speed_trace().unwrap();

    let every_move = ToolpathOptions { print_only: false, travel: true, ..ToolpathOptions::default() };
    let tp = Toolpath::from_file(&path, every_move).unwrap();
    let path_mm: f64 = tp.segments.iter().map(|s| f64::from(s.len_mm())).sum();
    let traced_mm: f64 = trace.buckets().iter().map(|b| b.distance_mm).sum();
    // Marlin merges moves of fewer than 6 steps into the next one (838 of this file's 18532 XY
    // moves are under 0.075 mm): the machine goes straight across their little zigzags, 35 mm
    // (0.13 %) shorter than the file's path.
    assert!((traced_mm / path_mm - 1.0).abs() < 2e-3, "traced {traced_mm} mm, path {path_mm} mm");
    assert!(traced_mm < path_mm);

    let fastest_mm_s = tp.segments.iter().map(|s| s.feed_mm_s).fold(0.0f32, f32::max) as f64;
    let peak = trace.buckets().iter().map(|b| b.max_mm_s).fold(0.0, f64::max);
    assert!(
        // Marlin rounds step rates up from single-precision lengths: under two steps/s (1/80 mm)
        // more than asked.
        peak > 0.5 * fastest_mm_s && peak <= fastest_mm_s + 2.0 / 80.0,
        "peak {peak}, fastest F {fastest_mm_s}"
    );
    assert!(trace.end_s() <= report.time.total_s + 1e-6 && trace.end_s() > 0.9 * report.time.motion_s);
    assert_eq!(report.layer_s.len(), 28);

    let (png, axes) = speed_chart(trace, &report.layer_s, &report.mixing_input_mm, ChartFormat::Png).unwrap();
    // The speed axis ends above the peak (room for the legend), the layer axis after layer 27.
    assert!((axes.speed.get_y_range().end - peak * 1.26).abs() < 1e-9);
    assert_eq!(axes.layers.get_x_range(), 0.0..28.0);
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}
