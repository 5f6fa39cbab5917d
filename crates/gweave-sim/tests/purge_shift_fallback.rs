//! purge-shift's `block` and `tower` fallbacks through the virtual printer: on the default
//! machine the shifted file feeds exactly the fallback purge more filament than the original,
//! ends at the same place with the same step counts on X Y Z, and no move leaves the bed.

#[path = "../../gweave/tests/one_nozzle/mod.rs"]
mod one_nozzle;

use std::path::PathBuf;

use gweave::post::purge_shift::purge_shift_bytes;
use gweave::PurgeShiftConfig;
use gweave_sim::MachineProfile;
use gweave_sim::{Machine, SimReport};

use one_nozzle::fixture;

fn sim(text: &[u8]) -> SimReport {
    sim_on(MachineProfile::default(), text)
}

/// The virtual printer's report of `text` on `machine`.
fn sim_on(machine: MachineProfile, text: &[u8]) -> SimReport {
    let mut m = Machine::new(machine).unwrap();
    let mut out = |_t: f64, _l: &str| {};
    for line in text.split(|&b| b == b'\n') {
        m.execute(line, &mut out);
    }
    m.finish(&mut out);
    m.report()
}

fn warnings(r: &SimReport, kind: &str) -> u64 {
    r.warning_counts.get(kind).copied().unwrap_or(0)
}

#[test]
fn fallbacks_feed_the_shortfall_and_stay_on_the_bed() {
    for file in ["slic3r/slic3r_cone_2tool.gcode", "prusaslicer/pr_bunny_3tool_rel.gcode"] {
        let input = fixture(file);
        let before = sim(&input);
        for fallback in ["block", "tower"] {
            let rules =
                PurgeShiftConfig::from_toml(&format!("purge_mm = 2.5\nfallback = \"{fallback}\"\n")).unwrap();
            let (out, report) = purge_shift_bytes(rules, &input).unwrap();
            assert!(report.fallback_mm > 10.0, "{file} {fallback}: {}", report.fallback_mm);
            let after = sim(&out);
            let fed = |r: &SimReport| r.filament_mm.iter().sum::<f64>();
            assert!(
                (fed(&after) - fed(&before) - report.fallback_mm).abs() < 1e-6,
                "{file} {fallback}: {} -> {} (+{})",
                fed(&before),
                fed(&after),
                report.fallback_mm
            );
            assert_eq!(after.position[..3], before.position[..3], "{file} {fallback}");
            assert_eq!(after.count[..3], before.count[..3], "{file} {fallback}");
            for kind in ["out_of_bounds", "below_bed"] {
                assert_eq!(warnings(&after, kind), warnings(&before, kind), "{file} {fallback}: {kind}");
            }
            assert!(!after.halted);
        }
    }
}

/// Regression (CI, on the tool-change retraction fix): the Slic3r cone's first change splits a
/// move 4.5 X steps from its start, a move the planner drops and carries into the next block; a
/// `G92 E0` written right after it made the virtual printer re-set its position and lose those
/// steps, and the shifted file ended 13 X steps and 1 Y step off (`[13, 8005, 99800]` against
/// `[0, 8006, 99800]`) at the same logical position. Cura's tool change begins with a 3-step
/// move, and a `G92 E` written in place of the retraction after it lost 9 X and 18 Y steps the
/// same way. Without a fallback too, E included (the file feeds what it fed), and the motion
/// time of the cone is the input's: the moved retraction and unretraction are not made twice (a
/// kept retraction undone at once cost 88 s of 985).
#[test]
fn a_split_too_short_to_plan_keeps_the_stepper_counts() {
    for (file, moved_mm) in [("slic3r/slic3r_cone_2tool.gcode", 241.02), ("cura/cura_dual.gcode", 45.10)] {
        // Cura's dual file as for one nozzle (the `one_nozzle` module): purge-shift refuses a
        // nozzle per tool.
        let input = one_nozzle::one_nozzle(&fixture(file));
        let before = sim(&input);
        let rules = PurgeShiftConfig::from_toml("purge_mm = 2.5\n").unwrap();
        let (out, report) = purge_shift_bytes(rules, &input).unwrap();
        assert!((report.moved_mm - moved_mm).abs() < 0.01, "{file}: {}", report.moved_mm);
        let after = sim(&out);
        assert_eq!(after.position[..3], before.position[..3], "{file}");
        assert_eq!(after.count[..4], before.count[..4], "{file}");
        if file.starts_with("slic3r") {
            // The default machine never waits at a `T` (one extruder, as Marlin): the moved
            // retraction, made where the change now is, stops the head mid-path where it
            // cruised (983.948 s in, 984.342 s out: 3.6 ms a change). On the dual extruder,
            // which waits at every `T` as Marlin does with several extruders, it is made during
            // that wait and the file's own, taken out where the change was, stops nothing
            // (985.770 s in, 985.368 s out). Making it twice cost 88 s.
            let extra_s = |before: &SimReport, after: &SimReport| after.time.motion_s - before.time.motion_s;
            let once = extra_s(&before, &after);
            assert!(
                (0.374..0.414).contains(&once),
                "default: {} s -> {} s",
                before.time.motion_s,
                after.time.motion_s
            );
            let dual = || {
                let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                    .join("../../examples/machines/dual-extruder.toml");
                MachineProfile::from_toml_str(&std::fs::read_to_string(path).unwrap()).unwrap()
            };
            let (dual_before, dual_after) = (sim_on(dual(), &input), sim_on(dual(), &out));
            let waited = extra_s(&dual_before, &dual_after);
            assert!(
                (-0.422..-0.382).contains(&waited),
                "dual-extruder: {} s -> {} s",
                dual_before.time.motion_s,
                dual_after.time.motion_s
            );
        }
    }
}
