//! purge-shift on synthetic programs: the invariants hold and the pass never panics, and the
//! window does not grow with the file.

mod purge_check;

use gweave::post::purge_shift::report::KEPT_CHANGES;
use gweave::post::purge_shift::{PurgeShift, Rules};
use gweave::{purge_shift, PurgeShiftConfig, PurgeShiftReport, Run, Strictness};
use proptest::prelude::*;

/// The pass over text in memory, reading past malformed lines (what these properties feed it).
fn lenient(rules: Rules, input: &[u8]) -> gweave::Result<(Vec<u8>, PurgeShiftReport)> {
    let run = Run::text(input).to_memory().strictness(Strictness::Lenient);
    purge_shift(rules, run).map(|(report, ran)| (ran.output, report))
}

/// One step of a synthetic program.
#[derive(Debug, Clone)]
enum Step {
    /// An extruding move of this XY length (E = 0.05 mm per mm), optionally as an arc.
    Extrude {
        len_mm: f64,
        arc: bool,
    },
    Retract,
    ResetE,
    Travel(f64),
    Change,
    /// A slicer's change: the old tool retracts this much, the new one unretracts what it
    /// retracted when it was put away (PrusaSlicer's tool-change retraction).
    RetractedChange(f64),
    Layer,
    OuterWall,
    FwRetract,
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        8 => (0.01f64..30.0, proptest::bool::weighted(0.2)).prop_map(|(len_mm, arc)| Step::Extrude { len_mm, arc }),
        1 => Just(Step::Retract),
        1 => Just(Step::ResetE),
        1 => (0.1f64..20.0).prop_map(Step::Travel),
        2 => Just(Step::Change),
        2 => (0.5f64..12.0).prop_map(|mm| Step::RetractedChange((mm * 100.0).round() / 100.0)),
        1 => Just(Step::Layer),
        1 => Just(Step::OuterWall),
        1 => Just(Step::FwRetract),
    ]
}

/// Writes the program; `absolute_e` picks M82 or M83.
fn program(steps: &[Step], absolute_e: bool) -> String {
    let mut s = String::from(if absolute_e { "G90\nM82\n" } else { "G90\nM83\n" });
    s.push_str(";LAYER_CHANGE\n;Z:0.2\nG1 Z0.2\n;TYPE:Perimeter\n");
    let (mut x, mut e, mut layer, mut tool, mut dir) = (0.0f64, 0.0f64, 0, 0, 1.0f64);
    let mut parked_mm = [0.0f64; 2];
    let feed = |s: &mut String, words: String, de: f64, e: &mut f64| {
        if absolute_e {
            *e += de;
            s.push_str(&format!("{words} E{:.5}\n", *e));
        } else {
            s.push_str(&format!("{words} E{de:.5}\n"));
        }
    };
    for st in steps {
        match st {
            Step::Extrude { len_mm, arc } => {
                let de = (len_mm * 0.05 * 1e5).round() / 1e5;
                if de <= 0.0 {
                    continue;
                }
                if *arc {
                    // A half circle of diameter len_mm along X (never a zero-length move).
                    let r = len_mm / 2.0;
                    feed(&mut s, format!("G2 X{:.3} Y0 I{:.3} J0", x + dir * len_mm, dir * r), de, &mut e);
                } else {
                    feed(&mut s, format!("G1 X{:.3} Y0", x + dir * len_mm), de, &mut e);
                }
                x = ((x + dir * len_mm) * 1000.0).round() / 1000.0;
                if x.abs() > 100.0 {
                    dir = -dir;
                }
            }
            Step::Retract => {
                feed(&mut s, "G1".into(), -0.8, &mut e);
                s.push_str("G0 Y5\nG0 Y0\n");
                feed(&mut s, "G1".into(), 0.8, &mut e);
            }
            Step::ResetE => {
                s.push_str("G92 E0\n");
                e = 0.0;
            }
            Step::Travel(d) => {
                x = ((x - dir * d) * 1000.0).round() / 1000.0;
                s.push_str(&format!("G0 X{x:.3} Y0\n"));
            }
            Step::Change => {
                tool = 1 - tool;
                s.push_str(&format!("T{tool}\n"));
                // A tool put away retracted is unretracted when it is taken again, as a slicer
                // writes it: it never extrudes while still retracted (that file's "purge" would
                // leave no filament, which the checker's tool ledger does not model).
                if parked_mm[tool as usize] > 0.0 {
                    feed(&mut s, "G1".into(), parked_mm[tool as usize], &mut e);
                    parked_mm[tool as usize] = 0.0;
                }
            }
            Step::RetractedChange(mm) => {
                feed(&mut s, "G1".into(), -mm, &mut e);
                parked_mm[tool as usize] += mm;
                tool = 1 - tool;
                s.push_str(&format!("; end of the old filament\nT{tool}\nG0 X{x:.3} Y8\nG0 Y0\n"));
                if parked_mm[tool as usize] > 0.0 {
                    feed(&mut s, "G1".into(), parked_mm[tool as usize], &mut e);
                    parked_mm[tool as usize] = 0.0;
                }
            }
            Step::Layer => {
                layer += 1;
                let z = 0.2 * f64::from(layer + 1);
                s.push_str(&format!(";LAYER_CHANGE\n;Z:{z:.1}\nG1 Z{z:.1}\n;TYPE:Perimeter\n"));
            }
            Step::OuterWall => s.push_str(";TYPE:External perimeter\n"),
            Step::FwRetract => s.push_str("G10\nG0 Y3\nG0 Y0\nG11\n;TYPE:Perimeter\n"),
        }
    }
    s
}

fn check(text: &str, rules: Rules) -> gweave::PurgeShiftReport {
    let options = PurgeShift::new(rules.clone()).state_options();
    let (out, report) = lenient(rules, text.as_bytes()).unwrap();
    purge_check::check(text.as_bytes(), &out, &report, &options);
    // A slicer-style program (no wipe, nothing retracted while extruding): a moved change takes
    // the file's retraction and unretraction with it, so the E-only motion is the input's.
    let e_motion = |bytes: &[u8]| purge_check::e_only_motion_mm(bytes, &options);
    let (before, after) = (e_motion(text.as_bytes()), e_motion(&out));
    assert!((before - after).abs() < 1e-4, "E-only motion {before} mm -> {after} mm");
    report
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn invariants_hold(steps in proptest::collection::vec(step(), 0..120), absolute_e: bool,
                       purge_mm in 0.05f64..4.0, cross_layers: bool) {
        let text = program(&steps, absolute_e);
        let rules = PurgeShiftConfig { purge_mm: Some(purge_mm), cross_layers, ..PurgeShiftConfig::default() }
            .validate()
            .unwrap();
        let report = check(&text, rules);
        // `T` lines with only comments between are one group: it changes the colour if it
        // toggles an odd number of times.
        let mut changes = 0;
        let mut run = 0;
        for line in text.lines().chain(std::iter::once("")) {
            if line.starts_with('T') {
                run += 1;
            } else if !line.starts_with(';') {
                changes += run % 2;
                run = 0;
            }
        }
        prop_assert_eq!(report.changes.total(), changes);
    }

    #[test]
    fn never_panics_on_gcode_like_text(lines in proptest::collection::vec(
        "(G[0-3]|G92|G10|G11|M8[23]|T[0-2]|M16[345]|M567|;LAYER:[0-9]|;TYPE:WALL-OUTER)?( [XYZEIJRSP]-?[0-9]{0,3}(\\.[0-9]{0,3})?){0,4}",
        0..60)) {
        let text = lines.join("\n");
        let _ = lenient(Rules::fixed(1.0).unwrap(), text.as_bytes()).unwrap();
    }
}

/// The window holds the purge plus at most one layer: as many lines for 2 000 layers as for 20.
#[test]
fn window_does_not_grow_with_the_file() {
    let layers = |n: usize| {
        let mut s = String::from("G90\nM83\n");
        for layer in 0..n {
            s.push_str(&format!(";LAYER_CHANGE\n;Z:{}\nG1 Z{}\n;TYPE:Perimeter\n", layer + 1, layer + 1));
            for i in 0..50 {
                s.push_str(&format!("G1 X{} Y{} E0.05\n", i % 2 * 10, layer));
            }
            s.push_str(&format!("T{}\n", (layer + 1) % 2));
        }
        s
    };
    for cross_layers in [false, true] {
        let max = |n: usize| {
            let rules = PurgeShiftConfig { purge_mm: Some(1.0), cross_layers, ..PurgeShiftConfig::default() }
                .validate()
                .unwrap();
            let (_, r) = lenient(rules, layers(n).as_bytes()).unwrap();
            assert_eq!(r.changes.total(), n);
            // The report holds at most KEPT_CHANGES entries; the rest are in its spill file and
            // still come out, in order, in the JSON report.
            assert_eq!(r.changes.kept().len(), n.min(KEPT_CHANGES));
            assert_eq!(r.changes.spilled(), n.saturating_sub(KEPT_CHANGES));
            let json = serde_json::to_value(&r).unwrap();
            let entries = json["changes"].as_array().unwrap();
            assert_eq!(entries.len(), n);
            for (i, c) in entries.iter().enumerate() {
                assert_eq!(c["achieved_mm"].as_f64(), Some(1.0), "{c}");
                assert_eq!(c["layer"].as_u64(), Some(i as u64), "{c}");
            }
            assert!((r.achieved_mm - n as f64).abs() < 1e-6);
            r.max_window_lines
        };
        let (small, big) = (max(20), max(2000));
        assert_eq!(small, big, "cross_layers {cross_layers}");
        // 1 mm of purge is 20 moves of 0.05 mm; the window holds those, the one before (the
        // sum after it must exceed the purge) and the layer's 4 header lines.
        assert!((20..=27).contains(&big), "cross_layers {cross_layers}: {big}");
    }
}

/// A line longer than the reader's limit is copied through by the lenient in-memory run, in
/// its place: the moves held back for a later change go out before it.
#[test]
fn a_long_line_keeps_its_place_in_a_lenient_shift() {
    let mut text = b";TYPE:Perimeter\nG1 X1 E1 F600\nG1 X2 E2\n;".to_vec();
    text.extend(std::iter::repeat_n(b'x', gweave::gcode::reader::MAX_LINE + 1));
    text.extend_from_slice(b"\nG1 X3 E3\nT1\nG1 X4 E4\n");
    let (out, _) = lenient(Rules::fixed(0.5).unwrap(), &text).unwrap();
    let long_at = |bytes: &[u8]| bytes.windows(3).position(|w| w == b";xx").unwrap();
    assert_eq!(long_at(&out), long_at(&text));
    assert_eq!(&out[..long_at(&out)], &text[..long_at(&text)]);
}
