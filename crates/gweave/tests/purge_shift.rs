//! purge-shift on real slicer output and hand-built cases: every invariant of
//! `purge_check::check` on every change, plus hand-computed split lines.

mod one_nozzle;
mod purge_check;

use std::path::PathBuf;

use gweave::gcode::layers::Feature;
use gweave::post::purge_shift::{PurgeShift, Rules};
use gweave::{purge_shift, PurgeShiftConfig, PurgeShiftReport, Run, Strictness};

use one_nozzle::fixture;

/// Runs the pass and checks every invariant against the input. Lenient: RepRapFirmware's
/// colon lists (`M567 P0 E0.3:0.7`) are malformed words to the lexer, which a strict run stops at.
fn run(rules: Rules, input: &[u8]) -> (Vec<u8>, PurgeShiftReport) {
    let options = PurgeShift::new(rules.clone()).state_options();
    let lenient = Run::text(input).to_memory().strictness(Strictness::Lenient);
    let (report, ran) = purge_shift(rules, lenient).unwrap();
    let out = ran.output;
    purge_check::check(input, &out, &report, &options);
    (out, report)
}

/// The fixture as for one nozzle (the `one_nozzle` module; unchanged if it is one nozzle's).
fn fixture_for_one_nozzle(rel: &str) -> Vec<u8> {
    one_nozzle::one_nozzle(&fixture(rel))
}

fn config(toml: &str) -> Rules {
    PurgeShiftConfig::from_toml(toml).unwrap()
}

fn lines(out: &[u8], from_1based: u64, n: usize) -> Vec<String> {
    String::from_utf8_lossy(out).lines().skip(from_1based as usize - 1).take(n).map(String::from).collect()
}

const ALL: &str = "allow_features = [\"unknown\", \"outer_wall\", \"inner_wall\", \"overhang_wall\", \"infill\", \
    \"solid_infill\", \"top_surface\", \"bridge\", \"support\", \"support_interface\", \"skirt\", \"wipe_tower\", \
    \"ironing\", \"gap_fill\", \"custom\"]\n";

#[test]
fn slic3r_absolute_e_first_change_by_hand() {
    let input = fixture("slic3r/slic3r_cone_2tool.gcode");
    let (out, r) = run(Rules::fixed(2.5).unwrap(), &input);
    assert_eq!(r.changes.total(), 108);
    let c = &r.changes.kept()[0];
    // T1 was at line 553 after `G1 X109.750 Y109.550 E24.30781`; 2.5 mm back is E21.80781, inside
    // `G1 X104.913 Y87.264 E21.85317` (line 509, from X104.282 Y87.038 E21.79225).
    assert_eq!((c.change_lines.as_slice(), c.output_line, c.at_line), (&[553][..], 511, 509));
    let t = (21.80781 - 21.79225) / (21.85317 - 21.79225);
    assert!((c.split.as_ref().unwrap().fraction - t).abs() < 1e-9);
    // T0's 10 mm tool-change retraction goes with the change, in the file's own E coordinates
    // (no `G92` between the split and it: the first half is 4.5 X steps, a move the planner
    // drops and carries into the next one); T1, never used, has nothing to unretract, and E is
    // put back where the file has it.
    assert_eq!(
        lines(&out, 509, 6),
        [
            "G1 X104.44317 Y87.09572 E21.80781",
            "G1 E11.80781 F2400",
            "T1",
            "G92 E21.80781",
            "G1 F1800",
            "G1 X104.913 Y87.264 E21.85317"
        ],
        "x = 104.282 + {t} * 0.631"
    );
    // The slicer's toolchange block stays but for its retraction, made by T0 at the new place:
    // the line keeps only the feed rate it sets, and E needs no putting back, the file resets it
    // right after (G92 E0, T1 gone, G92 E0), then T1's own travel retraction.
    assert_eq!(lines(&out, 556, 4), ["G1 F2400", "G92 E0", "G92 E0", "G1 E-2.00000 F2400.00000"]);
    let moved = c.retraction.as_ref().unwrap();
    assert_eq!(
        (moved.old_mm, moved.new_mm, moved.settle_mm, moved.dropped_mm, moved.absorbed_mm),
        (-10.0, 0.0, 0.0, 10.0, 0.0)
    );
    assert!(r.changes.kept().iter().all(|c| c.feature == Feature::Unknown));
    assert_eq!(r.changes.kept().iter().filter(|c| c.shortfall_mm == 0.0).count(), 79);
}

#[test]
fn prusaslicer_relative_e_splits_the_e_word() {
    let input = fixture("prusaslicer/pr_bunny_3tool_rel.gcode");
    let (out, r) = run(Rules::fixed(2.5).unwrap(), &input);
    assert_eq!(r.changes.total(), 793);
    let c = &r.changes.kept()[1];
    assert_eq!((c.from_tool, c.to_tool, c.feature), (2, 0, Feature::Bridge));
    // `G1 X70.555 Y86.738 E1.25223`: the last 0.04197 mm of it, after the change, completes 2.5 mm
    // with the three moves after it (0.02048 + 0.02501 + 1.20551 + 1.15498 + 0.05205).
    // T2's 10 mm tool-change retraction and T0's unretraction go with the change, then the
    // feed rate in force.
    assert_eq!(
        lines(&out, 763, 6),
        [
            "G1 X70.82035 Y87.24949 E1.21026",
            "G1 E-10 F2400",
            "T0",
            "G1 E10 F2400",
            "G1 F3600",
            "G1 X70.555 Y86.738 E0.04197"
        ]
    );
    // The outer wall is a barrier by default: the change after it cannot move at all.
    assert_eq!(r.changes.kept()[0].achieved_mm, 0.0);
    assert_eq!(r.changes.kept()[0].stopped_by, Some("a feature that may not take the purge"));
    // A change that cannot move still names its layer (the bench's "layer -" warnings).
    assert_eq!(r.changes.kept()[0].layer, Some(0));
    let first =
        r.warnings.iter().map(ToString::to_string).find(|w| w.starts_with("layer 0, line 172: ")).unwrap();
    assert!(first.starts_with("layer 0, line 172: T0->T2 purge short by 2.500 mm"), "{first}");
    // What lets it move, said where the user reads that it did not (a new user's cone: 0 of
    // 2.5 mm on 38 changes, "stopped by a feature that may not take the purge", no way out).
    assert!(
        first.ends_with(
            "; --allow-features lets more features take the purge (default: all but the outer wall)"
        ),
        "{first}"
    );
    assert!(r.changes.kept().iter().all(|c| c.layer.is_some()));
    // Allowing every feature gives more room.
    let (_, all) = run(config(&format!("purge_mm = 2.5\n{ALL}")), &input);
    assert!(all.achieved_mm > r.achieved_mm + 100.0, "{} vs {}", all.achieved_mm, r.achieved_mm);
    assert_eq!(all.changes.kept()[0].achieved_mm, 2.5);
}

#[test]
fn cura_dual_with_and_without_crossing_layers() {
    let input = fixture_for_one_nozzle("cura/cura_dual.gcode");
    let (_, r) = run(Rules::fixed(2.5).unwrap(), &input);
    assert_eq!((r.changes.total(), r.untouched_changes), (77, 0));
    // T0 right after `;LAYER:1` cannot go back by default...
    let c = &r.changes.kept()[1];
    assert_eq!((c.change_lines[0], c.achieved_mm), (4730, 0.0));
    assert_eq!(c.stopped_by, Some("a layer change"));
    // ...but may move into layer 0 when crossing is allowed.
    let (_, x) = run(config(&format!("purge_mm = 2.5\ncross_layers = true\n{ALL}")), &input);
    assert_eq!((x.changes.kept()[1].achieved_mm, x.changes.kept()[1].layer), (2.5, Some(0)));
    assert!(x.achieved_mm > r.achieved_mm);
    assert!(x.max_window_lines < 2000, "{}", x.max_window_lines);
}

#[test]
fn marlin_mix_groups_move_together() {
    // Virtual tool 1 is defined (M163/M164) right before T1: the four lines move as one.
    let input = "M83\n;LAYER:0\n;TYPE:FILL\nG1 X0 Y0\nG1 X10 E1\nG1 X20 E1\nG1 E-1\nG0 X30\nG1 E1\n\
                 M163 S0 P0.5\nM163 S1 P0.5\n; blue\nM164 S1\nT1\nG1 X40 E1\n";
    let (out, r) = run(Rules::fixed(1.5).unwrap(), input.as_bytes());
    assert_eq!(r.changes.kept()[0].change_lines, [10, 11, 12, 13, 14]);
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("G1 X5 E0.5\nM163 S0 P0.5\nM163 S1 P0.5\n; blue\nM164 S1\nT1\nG1 X10 E0.5\nG1 X20 E1\nG1 E-1\nG0 X30\nG1 E1\nG1 X40"),
        "{text}"
    );
    // M165 changes the active mix without a T; M567 the RepRapFirmware one.
    let m165 = "M83\n;LAYER:0\nG1 X0 Y0\nG1 X10 E2\nM165 A0.2 B0.8\nG1 X20 E1\n";
    let (out, r) = run(Rules::fixed(1.0).unwrap(), m165.as_bytes());
    assert_eq!((r.changes.total(), r.changes.kept()[0].achieved_mm), (1, 1.0));
    assert!(String::from_utf8(out).unwrap().contains("G1 X5 E1\nM165 A0.2 B0.8\nG1 X10 E1\n"));
    let m567 = "M83\n;LAYER:0\nG1 X0 Y0\nG1 X10 E2\nM567 P0 E0.3:0.7\nG1 X20 E1\n";
    let (_, r) = run(Rules::fixed(1.0).unwrap(), m567.as_bytes());
    assert_eq!(r.changes.total(), 1);
    // Re-selecting the active tool, or storing a mix into an idle tool, is not a change, and a
    // later T1 may not move before the definition of tool 1.
    let idle = "M83\n;LAYER:0\nG1 X0 Y0\nG1 X10 E2\nT0\nM163 S0 P1\nM164 S1\nG1 X20 E1\nT1\nG1 X30 E1\n";
    let (out, r) = run(Rules::fixed(1.5).unwrap(), idle.as_bytes());
    assert_eq!(r.changes.total(), 1);
    assert_eq!((r.changes.kept()[0].achieved_mm, r.changes.kept()[0].shortfall_mm), (1.0, 0.5));
    assert!(String::from_utf8(out).unwrap().contains("M164 S1\nT1\nG1 X20 E1\n"));
}

#[test]
fn arcs_split_on_the_circle_absolute_and_relative() {
    for (mode, e1, e2, second) in [("M82", "E2", "E3", "E2"), ("M83", "E2", "E1", "E0.5")] {
        let input = format!(
            "G90\n{mode}\n;LAYER:0\nG1 X10 Y0 F600\nG3 X0 Y10 I-10 J0 {e1}\nG2 X-10 Y0 R10 {e2}\nT1\nG1 X-20 E1\n"
        );
        let (out, r) = run(Rules::fixed(1.5).unwrap(), input.as_bytes());
        let s = r.changes.kept()[0].split.as_ref().unwrap();
        assert_eq!(s.line, 5);
        assert!((s.point_mm[0].hypot(s.point_mm[1]) - 10.0).abs() < 1e-9, "{s:?}");
        // 1 mm from the G2, 0.5 mm from the end of the G3 (t = 0.75), around the same centre.
        // The split is at 67.5 degrees: (10 cos, 10 sin) = (3.82683, 9.23880).
        let want = format!("G3 X3.82683 Y9.2388 E1.5 I-10 J0\nT1\nG3 X0 Y10 {second} I-3.82683 J-9.2388\n");
        assert!(String::from_utf8(out).unwrap().contains(&want), "{mode}");
    }
}

#[test]
fn retract_travel_unretract_is_never_split() {
    // Too little room: the change goes before the first extruding move of the layer, after the
    // unretract, never between retract, travel and unretract.
    let input =
        ";LAYER:0\nM83\nG1 E-1\nG0 X10 Y10\nG1 E1\nG1 X20 E0.5\nG1 E-1\nG0 X0\nG1 E1\nG1 X5 E0.25\nT1\n";
    let (out, r) = run(Rules::fixed(2.0).unwrap(), input.as_bytes());
    let c = &r.changes.kept()[0];
    assert_eq!((c.achieved_mm, c.shortfall_mm, c.at_line), (0.75, 1.25, 6));
    assert!(String::from_utf8(out).unwrap().contains("G0 X10 Y10\nG1 E1\nT1\nG1 X20 E0.5\n"));
    assert!(
        r.warnings.iter().any(|w| w.to_string().contains("line 11: T0->T1 purge short by 1.250 mm")),
        "{:?}",
        r.warnings
    );
}

#[test]
fn markers_limit_the_work_to_the_print_proper() {
    let input = "M83\nG1 X0 Y0\nG1 X10 E5\nT1\n;begin\nG1 X20 E5\nT0\n;end\nG1 X30 E5\nT1\n";
    let rules = config("purge_mm = 1.0\nmarkers = [\"begin\", \"end\"]\n");
    let (out, r) = run(rules, input.as_bytes());
    assert_eq!((r.changes.total(), r.untouched_changes), (1, 2));
    assert!(String::from_utf8(out)
        .unwrap()
        .starts_with("M83\nG1 X0 Y0\nG1 X10 E5\nT1\n;begin\nG1 X18 E4\nT0\n"));
}

#[test]
fn washout_predicts_the_transition() {
    // 1 mm^3 chamber, no dead volume, 2.5 mm of 1.75 mm filament = 6.013 mm^3 purge.
    let rules = config("purge_mm = 2.5\n[washout]\nchamber_mm3 = 1.0\ntolerance = 0.001\n");
    let input = ";LAYER:0\nM83\nG1 X0 Y0\nG1 X10 E1\nG1 X20 E1\nT1\nG1 X30 E1\n";
    let (_, r) = run(rules, input.as_bytes());
    let c = &r.changes.kept()[0];
    assert!((c.residual_fraction.unwrap() - (-2.0 * 2.405_281_875_404_685f64).exp()).abs() < 1e-9, "{c:?}");
    // Clean at 1000 ln(1000)... here V ln(1/eps) = 6.9078 mm^3; 2.4053 mm^3 was purged.
    let area = std::f64::consts::PI * 1.75 * 1.75 / 4.0;
    assert!((c.transition_mm.unwrap() - (1000f64.ln() - 2.0 * area) / area).abs() < 1e-9);
    assert!((r.saved_mm - 2.0).abs() < 1e-12 && (r.saved_mm3 - 2.0 * area).abs() < 1e-9);
}

/// Regression: a change that could not move (outer wall right before it) was reported on layer
/// "-", which showed on every layer of the bench's repeated file. Its layer is where it stands.
#[test]
fn unmoved_changes_report_their_layer_in_repeated_layers() {
    let layer = ";LAYER_CHANGE\n;Z:0.2\n;TYPE:External perimeter\nG1 X0 Y0\nG1 X10 E1\nT1\nG1 X20 E1\nT0\n";
    let input = format!(";generated by PrusaSlicer\nM83\n{}", layer.repeat(3));
    let (_, r) = run(Rules::fixed(1.0).unwrap(), input.as_bytes());
    let got: Vec<_> = r.changes.kept().iter().map(|c| (c.layer, c.moved_mm, c.feature)).collect();
    let want: Vec<_> = [0, 0, 1, 1, 2, 2].iter().map(|&l| (Some(l), 0.0, Feature::OuterWall)).collect();
    assert_eq!(got, want);
    assert!(r.warnings.iter().all(|w| !w.to_string().starts_with("layer -")), "{:?}", r.warnings);
    assert!(r.warnings[4].to_string().starts_with("layer 2, line 24: T0->T1"), "{:?}", r.warnings);
}

/// `block` and `tower` purge exactly the shortfall right after the change and come back: the
/// checker verifies the return, the fed amount, the moved part and every untouched line, on
/// absolute E (Slic3r, with `G92 E0` at each change), relative E (PrusaSlicer) and Cura.
#[test]
fn fallbacks_purge_the_shortfall_and_return() {
    for (file, changes) in [
        ("slic3r/slic3r_cone_2tool.gcode", 108),
        ("prusaslicer/pr_bunny_3tool_rel.gcode", 793),
        ("cura/cura_dual.gcode", 77),
    ] {
        let input = fixture_for_one_nozzle(file);
        let (_, partial) = run(Rules::fixed(2.5).unwrap(), &input);
        for fallback in ["block", "tower"] {
            let (out, r) = run(config(&format!("purge_mm = 2.5\nfallback = \"{fallback}\"\n")), &input);
            assert_eq!(r.changes.total(), changes, "{file}");
            // Every change gets its whole purge; the moved part is the same as without fallback.
            assert!(r
                .changes
                .kept()
                .iter()
                .all(|c| c.shortfall_mm == 0.0 && (c.achieved_mm - 2.5).abs() < 1e-12));
            assert!((r.moved_mm - partial.achieved_mm).abs() < 1e-9, "{file}");
            assert!((r.fallback_mm - partial.shortfall_mm).abs() < 1e-9, "{file}");
            assert!(r.fallback_mm > 1.0, "{file}: {}", r.fallback_mm);
            let short = r.changes.kept().iter().filter(|c| c.fallback_mm > 0.0).count();
            assert_eq!(short, partial.changes.kept().iter().filter(|c| c.shortfall_mm > 1e-9).count());
            assert!(r.changes.kept().iter().all(|c| (c.fallback_mm > 0.0) == (c.fallback_lines > 0)));
            let text = String::from_utf8_lossy(&out);
            assert_eq!(text.matches("; gweave purge-shift: purge T").count(), short, "{file} {fallback}");
            assert_eq!(r.saved_mm, r.moved_mm);
        }
    }
}

/// The block by hand, relative E: right after the change, the seed's purge block extrudes the
/// shortfall at X10 Y10 and `G92 E` puts E back where the file had it.
#[test]
fn block_fallback_by_hand() {
    let input = "M83\n;LAYER_CHANGE\n;TYPE:Perimeter\nG1 X0 Y0 Z0.3 F1800\nG1 X10 E1\nT1\nG1 X30 E1\n";
    let (out, r) = run(config("purge_mm = 1.5\nfallback = \"block\"\n"), input.as_bytes());
    let c = &r.changes.kept()[0];
    assert_eq!((c.moved_mm, c.fallback_mm, c.fallback_lines, c.output_line), (1.0, 0.5, 13, 5));
    assert_eq!(
        String::from_utf8(out).unwrap(),
        "M83\n;LAYER_CHANGE\n;TYPE:Perimeter\nG1 X0 Y0 Z0.3 F1800\nT1\n\
         ; gweave purge-shift: purge T0->T1 shortfall, 0.5 mm\nG1 E-4 F2400\nG0 Z15.3 F200\nG0 X10 Y10 F1320\n\
         G1 E4.5 F200\nG1 E-4 F2400\nG0 X15 F1320\nG0 X0 Y0 F1320\nG0 Z0.3 F200\nG1 E4 F2400\nG92 E0\n\
         G1 F1800\n; gweave purge-shift: end purge\nG1 X10 E1\nG1 X30 E1\n"
    );
    assert!(
        r.warnings[0].to_string().ends_with("; the rest purged by the block fallback"),
        "{:?}",
        r.warnings
    );
}

/// The tower: beside the print's extent, at the layer's Z, with the file's ordinary retraction
/// around the travels; a configured corner wins.
#[test]
fn tower_fallback_beside_the_part() {
    // An ordinary retraction (0.8 mm at F2100) mid-layer, and the slicer's tool-change one
    // (not taken as the file's retraction).
    let input =
        "G90\nM82\n;LAYER_CHANGE\n;TYPE:Perimeter\nG1 X50 Y60 Z0.3 F1800\nG1 X70 E1\nG1 E0.2 F2100\nG0 Y62\n\
                 G1 E1 F2100\nG1 Y80 E2\nG1 E-3 F3000\nT1\nG0 X50\nG1 E2\nG1 Y60 E3\n";
    let (_, r) = run(config("purge_mm = 1.5\nfallback = \"tower\"\n"), input.as_bytes());
    let c = &r.changes.kept()[0];
    assert_eq!((c.moved_mm, c.fallback_mm, c.fallback_lines), (1.5, 0.0, 0), "the full purge moved");
    let (out, r) = run(config("purge_mm = 3.5\nfallback = \"tower\"\n"), input.as_bytes());
    let c = &r.changes.kept()[0];
    assert!((c.moved_mm - 2.0).abs() < 1e-12 && (c.fallback_mm - 1.5).abs() < 1e-12, "{c:?}");
    let text = String::from_utf8(out).unwrap();
    // 1.5 mm of 1.75 mm filament at 0.5 x 0.2 mm is a 36.08 mm path: 9 rows of 3.564 mm.
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("G1 X7") && l.ends_with(" F1200")).collect();
    assert_eq!(rows.len(), 9, "{text}");
    assert!(rows.iter().all(|l| l.starts_with("G1 X78.56436 E") || l.starts_with("G1 X75 E")), "{rows:?}");
    // 5 mm right of the extent seen so far (X 50..70, Y 60..80), the file's 0.8 mm retraction
    // at its feed around the travels, then E back to 0 for the file's own next move.
    // T0's 5 mm tool-change retraction goes with the change (T1 has none parked), in the file's
    // E coordinates (E is 0 there), the E and the feed put back before the tower.
    assert!(text.contains("F1800\nG1 E-5 F2400\nT1\nG92 E0\nG1 F1800\n; gweave purge-shift: purge T0->T1 shortfall, 1.5 mm\nG92 E0\nG1 E-0.8 F2100\nG0 X75 Y60 F6000\n"), "{text}");
    assert!(
        text.contains("\nG1 X78.56436 E1.5 F1200\nG1 E0.7 F2100\nG0 X50 Y60 F6000\nG1 E1.5 F2100\nG92 E0\n"),
        "{text}"
    );
    // A configured corner.
    let (out, _) = run(
        config("purge_mm = 3.5\nfallback = \"tower\"\n[tower]\nx_mm = 150.0\ny_mm = 5.0\n"),
        input.as_bytes(),
    );
    assert!(String::from_utf8(out).unwrap().contains("\nG0 X150 Y5 F6000\n"));
}

/// Chained after `gweave mix` (the fourth file): the torus with the seed's layer
/// schedule, and with a change every other layer written as Marlin virtual tools and as `M165`
/// direct mixes. Mix changes at a layer's first extrusion, so the change can only move back into
/// the previous layer: without `cross_layers` none moves (all shortfall), with it every one
/// does. Mix's own purge blocks stay where mix put them, and every invariant holds; with
/// `block`, the shortfall is purged too.
#[test]
fn after_gweave_mix_on_the_cura_torus() {
    use gweave::post::mix::{mix_bytes, profile::MixProfile};
    let seed = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/mix/seed_layers.toml"),
    )
    .unwrap();
    let every_other: String = (0..28)
        .map(|l| format!("[[schedule]]\nlayer = {l}\nmix = \"{}\"\n", ["Orange", "Blue"][l % 2]))
        .collect();
    let torus = fixture("cura/cura_torus.gcode");
    for (profile, changes, want_moved, want_moved_mm) in [
        (seed.clone(), 2, 1, 2.5),
        (format!("[hardware]\ndialect = \"marlin\"\n{every_other}"), 27, 16, 38.23664),
        (format!("[hardware]\ndialect = \"marlin-direct\"\n{every_other}"), 27, 16, 38.23664),
    ] {
        let (mixed, mix_report) = mix_bytes(MixProfile::from_toml_str(&profile).unwrap(), &torus).unwrap();
        assert_eq!(mix_report.changes, changes);
        let direct = String::from_utf8_lossy(&mixed).lines().filter(|l| l.starts_with("M165 ")).count();
        assert_eq!(direct > changes as usize, profile.contains("marlin-direct"), "{direct} M165 lines");
        let (_, r) = run(Rules::fixed(2.5).unwrap(), &mixed);
        assert_eq!(r.changes.total(), changes as usize, "{profile}");
        assert!(r.changes.kept().iter().all(|c| c.moved_mm == 0.0 && c.stopped_by == Some("a layer change")));
        // ... and the warnings say what to do about it.
        assert_eq!(r.warnings.len(), changes as usize);
        assert!(r
            .warnings
            .iter()
            .all(|w| w.to_string().ends_with("--cross-layers lets the purge reach the layer below")));
        for fallback in ["partial", "block"] {
            let (out, r) = run(
                config(&format!("purge_mm = 2.5\ncross_layers = true\nfallback = \"{fallback}\"\n")),
                &mixed,
            );
            assert_eq!(r.changes.total(), changes as usize, "{profile}");
            // Where the previous layer ends in an outer wall (layers 8-18 of Cura's torus) the
            // change cannot move; elsewhere it finds the purge.
            let moved = r.changes.kept().iter().filter(|c| c.moved_mm > 0.0).count();
            assert_eq!((moved, r.changes.kept().iter().all(|c| c.layer.is_some())), (want_moved, true));
            assert!((r.moved_mm - want_moved_mm).abs() < 1e-9, "{}", r.moved_mm);
            // Mix's purge blocks are all still there, one per change.
            let text = String::from_utf8_lossy(&out);
            assert_eq!(text.matches("; gweave mix: purge").count(), changes as usize);
            if fallback == "block" {
                assert!(r.changes.kept().iter().all(|c| c.shortfall_mm == 0.0 && c.achieved_mm == 2.5));
            }
        }
    }
}

/// purge-shift on a file sliced with a wipe tower moved the tool changes into the tower and its
/// ramming and reported "saved vs tower" without a word: the file is refused, the setting named.
#[test]
fn a_file_sliced_with_a_wipe_tower_is_refused_naming_the_setting() {
    let rules = config("purge_mm = 2.0");
    let body = "M104 S200\nG92 E0\nG1 X1 E1\nT1\nG1 X2 E2\n";
    let prusa = format!("{body}; filament_minimal_purge_on_wipe_tower = 15\n; wipe_tower = 1\n");
    let err = gweave::post::purge_shift::purge_shift_bytes(rules.clone(), prusa.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("was sliced with a wipe tower (wipe_tower = 1): purge-shift replaces the tower"),
        "{err}"
    );
    let cura = format!(
        "{body};SETTING_3 {{\"global_quality\": \"[general]\\\\nprime_tower_enable = True\\\\n\"}}\n"
    );
    let err =
        gweave::post::purge_shift::purge_shift_bytes(rules.clone(), cura.as_bytes()).unwrap_err().to_string();
    assert!(err.contains("(prime_tower_enable = True)"), "{err}");
    // Without the tower (a key that merely ends in wipe_tower is not it), the file shifts.
    let none = format!("{body}; filament_minimal_purge_on_wipe_tower = 15\n; wipe_tower = 0\n");
    assert!(gweave::post::purge_shift::purge_shift_bytes(rules, none.as_bytes()).is_ok());
}

/// A PrusaSlicer-like change (relative E): the old tool retracts 10 mm, `T`, a travel, the new
/// tool unretracts the 10 mm it retracted when it was put away.
const TOOL_CYCLE: &str = "G90\nM83\n;LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\n;TYPE:External perimeter\n\
    G1 X10 Y0 F1800\nG1 X20 E1\nG1 E-10 F2400\n;END gcode for filament\nT1\nG1 X30 Y5 F7800\n\
    ;TYPE:Solid infill\nG1 X40 E2 F1800\nG1 X50 E2\nG1 E-10 F2400\n;END gcode for filament\nT0\n\
    G1 X60 Y0 F7800\nG1 E10 F2400\n;TYPE:External perimeter\nG1 F1800\nG1 X70 E1\nG1 E-10 F2400\nT1\n\
    G1 X80 Y5 F7800\nG1 E10 F2400\n;TYPE:Solid infill\nG1 X90 E1\n";

/// The bug found on a screw sliced for two extruders: a change moved back went before the old
/// tool's tool-change retraction, so the new tool did both the `G1 E-10` and its own `G1 E10`,
/// and at the next change (held by the outer wall) the old tool retracted again and the other
/// "unretracted" 10 mm it never retracted: 10 mm lost by one tool and blobbed by the other per
/// cycle, the file's E total unchanged and nothing said.
#[test]
fn tool_change_retraction_stays_with_its_tool() {
    let options = gweave::gcode::state::StateOptions::default();
    let before = purge_check::ledger(TOOL_CYCLE.as_bytes(), &options);
    // T0 prints 1 + 1 mm, T1 2 + 2 + 1 mm; T0 ends with its 10 mm retracted, T1 with none.
    assert_eq!((before.left_mm, before.retracted_mm), (vec![2.0, 5.0], vec![10.0, 0.0]));
    let (out, r) = run(Rules::fixed(3.0).unwrap(), TOOL_CYCLE.as_bytes());
    // T0->T1 after the outer wall stays; T1->T0 moves 3 mm back into T1's infill, taking T1's
    // retraction and T0's unretraction with it; where it was, the file's `G1 E-10` and `G1 E10`
    // are taken out (their feed rate stays), so T0 travels as T1 did, with nothing retracted.
    let moved = &r.changes.kept()[1];
    assert_eq!((moved.from_tool, moved.to_tool, moved.moved_mm), (1, 0, 3.0));
    let text = String::from_utf8(out.clone()).unwrap();
    assert!(
        text.contains(
            "G1 X35 E1 F1800\nG1 E-10 F2400\nT0\nG1 E10 F2400\nG1 F1800\nG1 X40 E1 F1800\nG1 X50 E2\n\
             G1 F2400\n;END gcode for filament\nG1 X60 Y0 F7800\nG1 F2400\n;TYPE:External perimeter\n"
        ),
        "{text}"
    );
    let after = purge_check::ledger(&out, &options);
    // The 3 mm purge went from T1 to T0, and nothing else moved between the tools.
    assert_close(&after.left_mm, &[5.0, 2.0]);
    assert_close(&after.retracted_mm, &[10.0, 0.0]);
    // No E motion added: the retraction and the unretraction are moved, not made twice.
    let e_motion = |bytes: &[u8]| purge_check::e_only_motion_mm(bytes, &options);
    assert_eq!(e_motion(&out), e_motion(TOOL_CYCLE.as_bytes()));
    // (`run` checks too that at every change each tool has the retraction it had in the input.)
    // Absolute E: the same, in the file's E coordinates; where the change was, the retraction
    // and the unretraction keep their feed rate only, and a `G92` puts E where the file has it
    // before the next line that reads E.
    let abs = "G90\nM82\nG92 E0\n;LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\n;TYPE:External perimeter\n\
        G1 X10 Y0 F1800\nG1 X20 E1\nG1 E-9 F2400\nT1\nG1 X30 Y5 F7800\n;TYPE:Solid infill\n\
        G1 X40 E-7 F1800\nG1 X50 E-5\nG1 E-15 F2400\nT0\nG1 X60 Y0 F7800\nG1 E-5 F2400\n\
        ;TYPE:External perimeter\nG1 X70 E-4\nG1 E-14 F2400\nT1\nG1 X80 Y5 F7800\nG1 E-4 F2400\n\
        ;TYPE:Solid infill\nG1 X90 E-3\n";
    assert_close(&purge_check::ledger(abs.as_bytes(), &options).left_mm, &[2.0, 5.0]);
    let (out, _) = run(Rules::fixed(3.0).unwrap(), abs.as_bytes());
    let text = String::from_utf8(out.clone()).unwrap();
    assert!(
        text.contains(
            "G1 X35 E-8 F1800\nG1 E-18 F2400\nT0\nG1 E-8 F2400\nG1 F1800\nG1 X40 E-7 F1800\nG1 X50 E-5\n\
             G1 F2400\nG1 X60 Y0 F7800\nG1 F2400\n;TYPE:External perimeter\nG92 E-5\nG1 X70 E-4\n"
        ),
        "{text}"
    );
    let after = purge_check::ledger(&out, &options);
    assert_close(&after.left_mm, &[5.0, 2.0]);
    assert_close(&after.retracted_mm, &[10.0, 0.0]);
    assert_eq!(e_motion(&out), e_motion(abs.as_bytes()));
}

/// Regression (found by the property test in CI): a change moved back across a `G92 E0`
/// carries the old tool's retraction before the reset and the new tool's unretraction after
/// it, so in relative E the counter after the reset is 0.5 mm off the input's: the checker
/// compared the split point's E coordinate and failed a correct file. The filament each tool
/// feeds is the input's, in relative and absolute E.
#[test]
fn a_retraction_carried_across_a_g92_keeps_each_tools_filament() {
    let options = gweave::gcode::state::StateOptions::default();
    for (mode, last) in [("M83", "E1.21645"), ("M82", "E0.71645")] {
        let text = format!(
            "{mode}\nG1 X0 Y0 F1200\nG1 X0.010 Y0 E0.00050\nG92 E0\nG1 E-0.5\n; end of the old filament\n\
             T1\nG0 X0.010 Y8\nG0 Y0\nG1 X24.339 Y0 {last}\nT0\n"
        );
        let before = purge_check::ledger(text.as_bytes(), &options);
        let (out, r) = run(Rules::fixed(0.05).unwrap(), text.as_bytes());
        assert_eq!(r.changes.kept().len(), 2, "{mode}");
        let after = purge_check::ledger(&out, &options);
        // T0's 0.0005 mm went to T1 (the first change moved as far as it could), T1's last
        // 0.05 mm to T0; each tool ends with the retraction it had.
        let moved = 0.05 - 0.0005;
        assert_close(&after.left_mm, &[before.left_mm[0] + moved, before.left_mm[1] - moved]);
        assert_close(&after.retracted_mm, &before.retracted_mm);
    }
}

/// Regression: the walk back counted an extrusion that only refills the tool's retraction as
/// purge. T0 comes back with the 0.5 mm it retracted when it was put away, and its one
/// extrusion feeds 0.0005 mm of them back: nothing leaves the nozzle, so there is no T0 colour
/// to purge and the last change stays where it is (it was moved before that move, reporting
/// 0.0005 mm).
#[test]
fn a_refill_of_the_retraction_is_not_counted_as_purge() {
    let input = "M83\nG1 E-0.5\nT1\nG1 E-0.5\nT0\nG1 X0.01 Y0 E0.0005\nT1\nG1 E0.5\n";
    let (out, r) = run(Rules::fixed(0.05).unwrap(), input.as_bytes());
    let last = r.changes.kept().last().unwrap();
    assert_eq!((last.from_tool, last.to_tool, last.moved_mm, last.split.is_none()), (0, 1, 0.0, true));
    assert_eq!(r.moved_mm, 0.0);
    // Unchanged, byte for byte: no change moved, no bracket written.
    assert_eq!(out, input.as_bytes());
    // A move feeding 0.6 mm refills the 0.5 first and prints 0.1: the 0.05 mm purge is the
    // end of it, so the change goes at (0.6 - 0.05) / 0.6 of the move, X 11 of 12.
    let input = input.replace("X0.01 Y0 E0.0005", "X12 Y0 E0.6");
    let (out, r) = run(Rules::fixed(0.05).unwrap(), input.as_bytes());
    let last = r.changes.kept().last().unwrap();
    assert_eq!((last.moved_mm, last.split.as_ref().map(|s| s.point_mm[0])), (0.05, Some(11.0)));
    // T0 refills and prints 0.05 mm, T1 unretracts the 0.5 mm it had parked (the file's
    // `G1 E0.5` after the change is taken out: T1 made it here) and prints the purge.
    assert_eq!(
        String::from_utf8(out).unwrap(),
        "M83\nG1 E-0.5\nT1\nG1 E-0.5\nT0\nG1 X11 Y0 E0.55\nT1\nG1 E0.5 F2400\nG1 X12 Y0 E0.05\n"
    );
}

fn assert_close(got: &[f64], want: &[f64]) {
    assert!(
        got.len() == want.len() && got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-6),
        "{got:?} vs {want:?}"
    );
}

/// The same on the screw's first seven layers (as for one nozzle), relative and absolute E, with each fallback: each
/// tool's filament is the input's but for the purge (sim of the whole screw before the fix:
/// T0 -68.91 mm, T1 700.25 mm for 355.12 and 276.22 in the input).
#[test]
fn tool_change_retraction_stays_with_its_tool_on_a_sliced_screw() {
    let options = gweave::gcode::state::StateOptions::default();
    for file in ["prusaslicer/pr_screw_2t_trim.gcode", "prusaslicer/pr_screw_2t_abs_trim.gcode"] {
        let input = fixture_for_one_nozzle(file);
        let before = purge_check::ledger(&input, &options);
        assert_close(&before.retracted_mm, &[10.0, 0.0]);
        for fallback in ["partial", "block", "tower"] {
            let rules = config(&format!("purge_mm = 3.0\nfallback = \"{fallback}\"\n"));
            let (out, r) = run(rules, &input);
            let after = purge_check::ledger(&out, &options);
            // T1->T0 changes move into T1's infill (8.24 mm in all); T0->T1 ones follow the
            // outer wall and stay; the fallbacks purge the 12.76 mm shortfall with the new tool.
            assert!((r.moved_mm - 8.24027).abs() < 1e-4, "{file} {fallback}: moved {}", r.moved_mm);
            let to_t1 = if fallback == "partial" { 0.0 } else { 12.0 };
            let to_t0 = if fallback == "partial" { 0.0 } else { 0.75973 };
            let want = [before.left_mm[0] + 8.24027 + to_t0, before.left_mm[1] - 8.24027 + to_t1];
            for t in 0..2 {
                assert!(
                    (after.left_mm[t] - want[t]).abs() < 2e-4,
                    "{file} {fallback}: {:?} vs {want:?}",
                    after.left_mm
                );
            }
            assert_close(&after.retracted_mm, &[10.0, 0.0]);
        }
    }
}

/// A file whose tool extrudes while still retracted (no unretraction after the change: the
/// first 1 mm only refills T0's nozzle). The moved change has T0 unretract its 10 mm at the new
/// place, and there is nothing after the change to take out: T0 retracts them again before its
/// next extrusion, so each tool ends as in the input (T0 with 9 mm retracted, T1 with 10).
#[test]
fn a_tool_taken_without_its_unretraction_is_retracted_again() {
    let options = gweave::gcode::state::StateOptions::default();
    let input = "G90\nM83\n;LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\n;TYPE:Solid infill\nG1 X10 Y0 F1800\n\
        G1 X20 E1\nG1 E-10 F2400\nT1\nG1 X30 E2\nG1 X40 E2\nG1 E-10 F2400\nT0\nG1 X50 E1\n";
    let before = purge_check::ledger(input.as_bytes(), &options);
    assert_close(&before.left_mm, &[1.0, 4.0]);
    assert_close(&before.retracted_mm, &[9.0, 10.0]);
    let (out, r) = run(Rules::fixed(3.0).unwrap(), input.as_bytes());
    let text = String::from_utf8(out.clone()).unwrap();
    assert!(
        // The feed rate in force is the moves' own (2400 mm/min, from the file's retraction), so
        // it is not restored after them.
        text.contains("G1 X25 E1\nG1 E-10 F2400\nT0\nG1 E10 F2400\nG1 X30 E1\nG1 X40 E2\nG1 F2400\nG1 E-10 F2400\nG1 X50 E1\n"),
        "{text}"
    );
    let moved = r.changes.kept()[1].retraction.clone().unwrap();
    assert_eq!((moved.dropped_mm, moved.absorbed_mm), (10.0, 10.0));
    // 1 mm of T0's moved to T1, 3 mm of T1's to T0.
    let after = purge_check::ledger(&out, &options);
    assert_close(&after.left_mm, &[3.0, 2.0]);
    assert_close(&after.retracted_mm, &before.retracted_mm);
}

/// Regression: purge-shift moved the changes of Cura's dual-extrusion file (a nozzle per tool)
/// before the file's heating of the new tool's nozzle, so the virtual dual extruder refused 13
/// cold extrusions. Such a file is refused, at the evidence: Cura's standby of the last nozzle
/// under the next one's temperature; PrusaSlicer's setting at the first change of tool.
#[test]
fn a_file_for_a_nozzle_per_tool_is_refused() {
    use gweave::post::purge_shift::SeparateNozzles;
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    let refused = |rel: &str| {
        let path = data.join(rel);
        match purge_shift(Rules::fixed(2.5).unwrap(), Run::file(&path).to_memory()) {
            Err(gweave::Error::Pass { line, source, .. }) => {
                (line, source.downcast_ref::<SeparateNozzles>().cloned())
            }
            other => panic!("{rel}: {:?}", other.map(|(r, _)| r.changes.total())),
        }
    };
    let temperatures = SeparateNozzles::Temperatures {
        line: 4247,
        tool: 0,
        celsius: 200.0,
        other: 1,
        other_celsius: 215.0,
        other_line: 3974,
    };
    assert_eq!(refused("cura/cura_dual.gcode"), (Some(4249), Some(temperatures)));
    assert_eq!(
        refused("prusaslicer/pr_cone_2tool.gcode"),
        (Some(504), Some(SeparateNozzles::Setting { tool: 1 }))
    );
    // The same file as for one nozzle is accepted.
    let (_, r) = run(Rules::fixed(2.5).unwrap(), &fixture_for_one_nozzle("cura/cura_dual.gcode"));
    assert_eq!(r.changes.total(), 77);
}
