//! Print time against Marlin's own planner on every real fixture, with three sets of limits and
//! both corner rules (ground truth in the fixtures README: `marlin-calc`, Marlin bugfix-2.0.x
//! as PrintTimeGenius builds it, eyal0/Marlin commit 134d0c21). The tool itself is not needed
//! here: its figures are recorded below.

use std::path::Path;

use gweave_sim::estimate_time;
use gweave_sim::{AxisLimits, CornerMode, Jerk, MotionProfile, MoveAccel, StepsPerUnit};

/// One set of limits, as the M-code lines given to the tool (`M92`, `M201`, `M203`,
/// `M204 P R T`, `M205 X Y Z E S0 T0` or `M205 S0 T0 J`).
struct Limits {
    steps: [f64; 4],
    max_accel: [f64; 4],
    max_feed: [f64; 4],
    accel: f64,
    jerk: [f64; 4],
    junction_deviation_mm: f64,
}

/// PrusaSlicer's normal-mode machine limits (Original Prusa i3 MK3S), the tool's own steps/mm.
const PRUSA: Limits = Limits {
    steps: [80.0, 80.0, 400.0, 500.0],
    max_accel: [9000.0, 9000.0, 500.0, 10000.0],
    max_feed: [500.0, 500.0, 12.0, 120.0],
    accel: 1500.0,
    jerk: [10.0, 10.0, 0.2, 2.5],
    junction_deviation_mm: 0.013,
};

/// A stock Creality Ender-3 (Marlin's `config/examples/Creality/Ender-3`).
const ENDER3: Limits = Limits {
    steps: [80.0, 80.0, 400.0, 93.0],
    max_accel: [500.0, 500.0, 100.0, 5000.0],
    max_feed: [500.0, 500.0, 5.0, 25.0],
    accel: 500.0,
    jerk: [10.0, 10.0, 0.3, 5.0],
    junction_deviation_mm: 0.08,
};

/// Marlin's default `Configuration.h` (RAMPS 1.4), gweave's default machine.
const RAMPS: Limits = Limits {
    steps: [80.0, 80.0, 4000.0, 500.0],
    max_accel: [3000.0, 3000.0, 100.0, 10000.0],
    max_feed: [300.0, 300.0, 5.0, 25.0],
    accel: 3000.0,
    jerk: [10.0, 10.0, 0.3, 5.0],
    junction_deviation_mm: 0.013,
};

impl Limits {
    fn profile(&self, jerk: bool) -> MotionProfile {
        let [x, y, z, e] = self.steps;
        let axes = |[x, y, z, e]: [f64; 4]| AxisLimits { x, y, z, e, a: 360.0 };
        let [jx, jy, jz, je] = self.jerk;
        MotionProfile {
            steps: StepsPerUnit { x, y, z, e, ..StepsPerUnit::default() },
            max_feed_mm_s: axes(self.max_feed),
            max_accel_mm_s2: axes(self.max_accel),
            accel: MoveAccel { print_mm_s2: self.accel, retract_mm_s2: self.accel, travel_mm_s2: self.accel },
            corners: CornerMode::Marlin {
                junction_deviation_mm: (!jerk).then_some(self.junction_deviation_mm),
                jerk_mm_s: jerk.then_some(Jerk { x: jx, y: jy, z: jz, e: je }),
                lookahead_blocks: 16,
                min_segment_time_us: 20_000.0,
            },
            extruders: Vec::new(),
        }
    }
}

/// The fixture as the README says both tools read it: `G28`, `M109` and `M190` go (the tool
/// neither homes nor waits, and plans straight through), so does RepRapFirmware's tool
/// temperature `G10 P S` (the tool takes it for a swap retraction); `{machine_depth}` becomes
/// 220; `M207 S3` first (Marlin's `RETRACT_LENGTH` for `G10`).
fn prepared(fixture: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(fixture);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut out = String::from("M207 S3\n");
    for line in text.lines() {
        let mut words = line.split(';').next().unwrap_or("").split_whitespace();
        let command = words.next().unwrap_or("");
        let rrf_temperature = command == "G10" && words.any(|w| w.starts_with(['P', 'S']));
        if matches!(command, "G28" | "M109" | "M190") || rrf_temperature {
            continue;
        }
        out.push_str(&line.replace("{machine_depth}", "220"));
        out.push('\n');
    }
    out
}

const FIXTURES: [&str; 6] = [
    "prusaslicer/pr_torus_pva.gcode",
    "prusaslicer/pr_bunny_3tool_rel.gcode",
    "prusaslicer/pr_sphere_rrf_fwretract.gcode",
    "cura/cura_torus.gcode",
    "cura/cura_dual.gcode",
    "slic3r/slic3r_cone_2tool.gcode",
];

/// Every fixture under `limits` in both corner modes, against Marlin's seconds (junction
/// deviation, classic jerk) in the order of [`FIXTURES`]; all misses are listed together.
fn assert_matches_marlin(limits: &Limits, marlin_s: [[f64; 2]; 6]) {
    let mut misses = Vec::new();
    for (fixture, want) in FIXTURES.iter().zip(marlin_s) {
        let text = prepared(fixture);
        for (jerk, want_s) in [(false, want[0]), (true, want[1])] {
            let got_s = estimate_time(text.as_bytes(), &limits.profile(jerk)).unwrap().total_s;
            let rel = (got_s - want_s) / want_s;
            if rel.abs() >= 1e-4 {
                let mode = if jerk { "classic jerk" } else { "junction deviation" };
                misses.push(format!(
                    "{fixture} {mode}: {got_s:.3} s, Marlin {want_s} s ({:+.4} %)",
                    rel * 100.0
                ));
            }
        }
    }
    assert!(misses.is_empty(), "more than 0.01 % from Marlin:\n{}", misses.join("\n"));
}

#[test]
fn prusaslicer_limits_match_marlin() {
    assert_matches_marlin(
        &PRUSA,
        [
            [469.742, 464.069],
            [20096.257, 19881.828],
            [1830.364, 1811.008],
            [785.498, 759.417],
            [7144.307, 7001.452],
            [981.809, 971.996],
        ],
    );
}

#[test]
fn ender3_limits_match_marlin() {
    assert_matches_marlin(
        &ENDER3,
        [
            [538.000, 536.125],
            [22847.061, 22743.510],
            [2096.053, 2082.321],
            [910.058, 865.375],
            [7958.189, 7741.938],
            [1096.344, 1084.241],
        ],
    );
}

#[test]
fn ramps_limits_match_marlin() {
    assert_matches_marlin(
        &RAMPS,
        [
            [446.390, 446.399],
            [19364.622, 19395.841],
            [1757.361, 1756.505],
            [723.281, 719.229],
            [6797.882, 6770.576],
            [983.950, 981.927],
        ],
    );
}
